//! Precomputation per (arrangement, channel mask, frame `V`): everything the sample loop needs
//! as matrix–vector products. Done in `f64`, stored in the sample-loop scalar `T`.
//!
//! Paper eq. (10)–(11): with rows `g_i = [s_i; R_i × s_i; s_i∘R_i] / σ_i` (model G, frame `V`
//! coordinates) or `[s_i; R_i × s_i] / σ_i` (model F), the thin SVD of the whitened `G` gives
//! the pseudo-inverse `G⁺` and the left null space `U⊥`. The sample loop then needs only
//! - `y = W p`, `W = [G⁺; U⊥ᵀ] diag(1/σ)` (`N` rows: `k` linear, `m = N − k` quadratic),
//! - `M_k = Σ_i U⊥_ik Q_i / σ_i` (the quadratic forms of the null-space equations),
//! - `T_j = Σ_i G⁺_ji Q_i / σ_i`, so that `G⁺ q(a) = [aᵀ T_j a]_j` costs 9 quadratic forms.

use crate::arrangement::{Arrangement, ChannelMask, Model};
use crate::error::{ConfigError, Unknown};
use crate::linalg::{cross, mat_t_vec, mat_vec, Mat3, Sym3, Vec3};
use crate::real::Real;
use crate::svd::{Svd, MAX_COLS};

/// Equilibrated condition number above which the design is refused (single precision could not
/// separate the unknowns).
pub const MAX_CONDITION: f64 = 1e6;

/// The precomputed matrices for one channel mask and one frame.
#[derive(Clone)]
pub struct Projection<T, const CAP: usize> {
    /// Linear unknowns (9 or 6).
    pub k: usize,
    /// Quadratic equations (`N_included − k`).
    pub m: usize,
    /// `W` (rows `0..k`: `G⁺`, rows `k..k+m`: `U⊥ᵀ`, whitening folded in) stored by channel:
    /// `wt[i][r] = W[r][i]` (with channel `i`'s `1 / scale` folded in), so that `W p` streams
    /// each channel's column once. Excluded
    /// channels and rows beyond `k + m` are zero.
    pub wt: [[T; CAP]; CAP],
    /// `W bias`: the channels' calibrated biases as they enter `y = W p`, taken off `y` per
    /// sample (with the `1 / scale` in `W`, the calibration costs one subtraction per row).
    pub bias_offset: [T; CAP],
    /// Whether `bias_offset` is other than zero.
    pub has_bias_offset: bool,
    /// `M_k`, `k < m`.
    pub mq: [Sym3<T>; CAP],
    /// `T_j`, `j < k`.
    pub tq: [Sym3<T>; MAX_COLS],
    /// Model G: the diagonals of the `T_j` are known exactly and are not read per sample
    /// ([`Projection::tq_structured`]; checked when built).
    pub tq_diag_known: bool,
    /// Diagonal 3×3 blocks of `G⁺ G⁺ᵀ` (σ0, Ω′, d): the covariance of `x` for known `a`.
    pub cov0: [Sym3<T>; 3],
    /// The forms of the body-frame components of σ0 and Ω′ (`x_body = Vᵀ x`):
    /// `Σ_r V[r][c] T_{3b+r}` for block `b` (0: σ0, 1: Ω′) and body axis `c`.
    pub tq_body: [Sym3<T>; 6],
    /// Variances of the body-frame components of σ0 and Ω′ for known `a`: `diag(Vᵀ cov0_b V)`.
    pub var0_body: [T; 6],
    /// Model G: the constant covariances of its (linear) estimates, body frame.
    pub general_cov: Option<GeneralCovariance<T>>,
    /// With `m ≥ 6`: `L` (6 × m), the least-squares solve of `tr(M_k S) = P_k` for
    /// `S = a aᵀ` stored as `[xx, yy, zz, xy, xz, yz]`.
    pub lin_s: [[T; CAP]; 6],
    /// Whether `lin_s` is valid.
    pub has_lin_s: bool,
    /// Model G: `L_o` (3 × m), the solve of the null-space equations for the off-diagonals
    /// `o = (A₁₂, A₁₃, A₂₃)` of `A` in frame `V`. Every `M_k` has a zero diagonal in model G
    /// (a diagonal `{a}²` is absorbed by `d`), so `ε aᵀ M_k a = 2 (M₁₂ o₁₂ + M₁₃ o₁₃ + M₂₃ o₂₃)`:
    /// linear in `o`.
    pub lin_o: [[T; CAP]; 3],
    /// Whether `lin_o` is valid.
    pub has_lin_o: bool,
    /// Frame `V` (rows: frame axes in body coordinates).
    pub frame: Mat3<T>,
    /// `V` is the identity (the body axes; always in model F): rotations are skipped.
    pub identity: bool,
    /// Equilibrated condition number of the whitened design matrix.
    pub condition: f64,
    /// 99.9 % point of χ² for the `m − 3` degrees of freedom of the residual (infinite when
    /// `m = 3`): a first root that fits below it is taken without trying the other starts.
    pub chi2_gate: T,
    /// 99.99 % point of the same ([`crate::estimate::chi2_9999`]): above it the row is flagged
    /// [`crate::Flags::RESIDUAL_HIGH`].
    pub fault_gate: T,
}

impl<T: Real, const CAP: usize> Projection<T, CAP> {
    /// An empty projection (to be filled by [`Projection::build`]).
    pub fn empty() -> Self {
        Projection {
            k: 0,
            m: 0,
            wt: [[T::ZERO; CAP]; CAP],
            bias_offset: [T::ZERO; CAP],
            has_bias_offset: false,
            mq: [Sym3::zero(); CAP],
            tq: [Sym3::zero(); MAX_COLS],
            tq_diag_known: false,
            cov0: [Sym3::zero(); 3],
            tq_body: [Sym3::zero(); 6],
            var0_body: [T::ZERO; 6],
            general_cov: None,
            lin_s: [[T::ZERO; CAP]; 6],
            has_lin_s: false,
            lin_o: [[T::ZERO; CAP]; 3],
            has_lin_o: false,
            frame: [
                [T::ONE, T::ZERO, T::ZERO],
                [T::ZERO, T::ONE, T::ZERO],
                [T::ZERO, T::ZERO, T::ONE],
            ],
            identity: true,
            condition: f64::INFINITY,
            chi2_gate: T::of(f64::MAX),
            fault_gate: T::of(f64::MAX),
        }
    }

    /// `Vᵀ x`: frame coordinates to body coordinates.
    #[inline]
    pub fn to_body(&self, x: &Vec3<T>) -> Vec3<T> {
        if self.identity {
            *x
        } else {
            mat_t_vec(&self.frame, x)
        }
    }

    /// `V w`: body coordinates to frame coordinates.
    #[inline]
    pub fn to_frame(&self, w: &Vec3<T>) -> Vec3<T> {
        if self.identity {
            *w
        } else {
            mat_vec(&self.frame, w)
        }
    }

    /// Fills `self` for the included channels of `arr`, the model and the frame `v`.
    /// On error `self` is left unchanged.
    pub fn build(
        &mut self,
        arr: &Arrangement<CAP>,
        mask: ChannelMask,
        model: Model,
        v: &Mat3<f64>,
        frame_index: u8,
    ) -> Result<(), ConfigError> {
        let k = model.linear_unknowns();
        let mut idx = [0usize; CAP];
        let mut n = 0;
        for i in 0..arr.len() {
            if mask.contains(i) {
                idx[n] = i;
                n += 1;
            }
        }
        if n < model.min_channels() {
            return Err(ConfigError::TooFewChannels {
                model,
                have: n,
                need: model.min_channels(),
            });
        }
        // Rows g_i (whitened) and forms Q_i (whitened) in frame coordinates.
        let mut cols = [[0.0f64; CAP]; MAX_COLS];
        let mut q = [Sym3::<f64>::zero(); CAP];
        for (row, &i) in idx.iter().enumerate().take(n) {
            let ch = &arr.channels()[i];
            let s = mat_vec(v, &ch.axis);
            let r = mat_vec(v, &ch.position);
            let g = design_row(&s, &r);
            for c in 0..k {
                cols[c][row] = g[c] / ch.noise;
            }
            q[row] = Sym3::sensor_form(&s, &r).scaled(1.0 / ch.noise);
        }
        // Equilibrate columns (unit norm) so the condition number does not depend on units.
        let mut col_norm = [0.0f64; MAX_COLS];
        for c in 0..k {
            let norm = Real::sqrt(cols[c][..n].iter().map(|x| x * x).sum::<f64>());
            col_norm[c] = norm;
            if norm > 0.0 {
                for x in cols[c][..n].iter_mut() {
                    *x /= norm;
                }
            }
        }
        let svd = Svd::<CAP>::new(&cols, n, k);
        let condition = svd.condition();
        if !(condition <= MAX_CONDITION) {
            let mut involved = 0u16;
            for c in 0..k {
                if libm::fabs(svd.v[c][k - 1]) > 0.2 {
                    involved |= 1 << c;
                }
            }
            return Err(ConfigError::Degenerate {
                involved,
                condition,
                frame: frame_index,
            });
        }
        let mut pinv = [[0.0f64; CAP]; MAX_COLS];
        svd.pseudo_inverse(&mut pinv);
        for c in 0..k {
            for x in pinv[c][..n].iter_mut() {
                *x /= col_norm[c];
            }
        }
        let m = n - k;
        let mut null = [[0.0f64; CAP]; CAP];
        svd.left_null_space(&mut null);

        // Everything is computed; now write (so that an error above leaves self unchanged).
        self.k = k;
        self.m = m;
        self.condition = condition;
        self.chi2_gate = T::of(crate::estimate::chi2_999(m - 3).min(f64::MAX));
        self.fault_gate = T::of(crate::estimate::chi2_9999(m - 3).min(f64::MAX));
        self.wt = [[T::ZERO; CAP]; CAP];
        // A calibrated channel reads `scale · (s·f) + bias`: its column takes `1 / scale` and
        // its bias goes into `W bias`.
        let mut offset = [0.0f64; CAP];
        for (row, &i) in idx.iter().enumerate().take(n) {
            let ch = &arr.channels()[i];
            let w = 1.0 / (ch.noise * ch.scale);
            for r in 0..k + m {
                let x = if r < k {
                    pinv[r][row]
                } else {
                    null[r - k][row]
                } * w;
                self.wt[i][r] = T::of(x);
                offset[r] += x * ch.bias;
            }
        }
        for (o, v) in self.bias_offset.iter_mut().zip(offset.iter()) {
            *o = T::of(*v);
        }
        self.has_bias_offset = offset.iter().any(|v| *v != 0.0);
        let mut mq = [Sym3::<f64>::zero(); CAP];
        for (e, mqe) in mq.iter_mut().enumerate().take(m) {
            for row in 0..n {
                *mqe = mqe.add_scaled(null[e][row], &q[row]);
            }
        }
        for (dst, src) in self.mq.iter_mut().zip(mq.iter()) {
            *dst = src.cast();
        }
        let mut tq = [Sym3::<f64>::zero(); MAX_COLS];
        for (c, tqc) in tq.iter_mut().enumerate().take(k) {
            for row in 0..n {
                *tqc = tqc.add_scaled(pinv[c][row], &q[row]);
            }
        }
        for (dst, src) in self.tq.iter_mut().zip(tq.iter()) {
            *dst = src.cast();
        }
        self.tq_diag_known = model == Model::General && tq_structured(&tq, k);
        self.build_covariances(&pinv, n, &tq, k, v);
        self.build_linear_s(&mq, m);
        self.build_linear_o(&mq, m, model);
        self.general_cov = None;
        if model == Model::General {
            if let Some(gc) = general_covariance(&pinv, n, &mq, &tq, m, v) {
                self.general_cov = Some(gc.cast());
            }
        }
        for (dst, src) in self.frame.iter_mut().zip(v.iter()) {
            for (d, s) in dst.iter_mut().zip(src.iter()) {
                *d = T::of(*s);
            }
        }
        self.identity = (0..3).all(|r| (0..3).all(|c| v[r][c] == if r == c { 1.0 } else { 0.0 }));
        Ok(())
    }

    /// The linear solve's covariance blocks (σ0, Ω′, and the third block of model G's nine
    /// columns) per unit noise, and, for σ0 and Ω′ in body axes, the `T` forms and variances
    /// of each component (`pinv`: the pseudo-inverse's rows over `n` channels, `tq` its forms,
    /// `k` the linear unknowns, `v` the frame).
    fn build_covariances(
        &mut self,
        pinv: &[[f64; CAP]; MAX_COLS],
        n: usize,
        tq: &[Sym3<f64>; MAX_COLS],
        k: usize,
        v: &Mat3<f64>,
    ) {
        for b in 0..3 {
            let mut blk = [[0.0f64; 3]; 3];
            if 3 * b + 2 < k {
                for (i, blk_row) in blk.iter_mut().enumerate() {
                    for (j, cell) in blk_row.iter_mut().enumerate() {
                        *cell = (0..n)
                            .map(|row| pinv[3 * b + i][row] * pinv[3 * b + j][row])
                            .sum();
                    }
                }
            }
            self.cov0[b] = Sym3::from_mat(&blk).cast();
            if b < 2 {
                let c0 = Sym3::from_mat(&blk);
                for c in 0..3 {
                    let col = [v[0][c], v[1][c], v[2][c]];
                    let mut form = Sym3::<f64>::zero();
                    if 3 * b + 2 < k {
                        for (r, vr) in col.iter().enumerate() {
                            form = form.add_scaled(*vr, &tq[3 * b + r]);
                        }
                    }
                    self.tq_body[3 * b + c] = form.cast();
                    self.var0_body[3 * b + c] = T::of(c0.quad(&col));
                }
            }
        }
    }

    /// `L_o` for model G (see [`Projection::lin_o`]): columns `2 (M₁₂, M₁₃, M₂₃)` of the forms.
    fn build_linear_o(&mut self, mq: &[Sym3<f64>; CAP], m: usize, model: Model) {
        self.lin_o = [[T::ZERO; CAP]; 3];
        self.has_lin_o = model == Model::General
            && m >= 3
            && forms_pseudo_inverse(mq, m, &[3, 4, 5], &mut self.lin_o);
    }

    /// `L` for `tr(M_k S) = P_k` when `m ≥ 6`: columns `(M₁₁, M₂₂, M₃₃, 2M₁₂, 2M₁₃, 2M₂₃)`.
    fn build_linear_s(&mut self, mq: &[Sym3<f64>; CAP], m: usize) {
        self.lin_s = [[T::ZERO; CAP]; 6];
        self.has_lin_s =
            m >= 6 && forms_pseudo_inverse(mq, m, &[0, 1, 2, 3, 4, 5], &mut self.lin_s);
    }
}

/// The pseudo-inverse (written to `out`, `entries.len()` rows × `m`) of the `m × entries.len()`
/// matrix whose row `k` holds the entries `entries` of the form `M_k` (off-diagonals doubled,
/// as they enter `aᵀ M a`). False, with `out` untouched, if it is too ill-conditioned.
fn forms_pseudo_inverse<T: Real, const CAP: usize>(
    mq: &[Sym3<f64>; CAP],
    m: usize,
    entries: &[usize],
    out: &mut [[T; CAP]],
) -> bool {
    let mut cols = [[0.0f64; CAP]; MAX_COLS];
    for (c, &entry) in entries.iter().enumerate() {
        let weight = if entry >= 3 { 2.0 } else { 1.0 };
        for e in 0..m {
            cols[c][e] = weight * mq[e].0[entry];
        }
    }
    let svd = Svd::<CAP>::new(&cols, m, entries.len());
    if !(svd.condition() <= MAX_CONDITION) {
        return false;
    }
    let mut l = [[0.0f64; CAP]; MAX_COLS];
    svd.pseudo_inverse(&mut l);
    for (row, lrow) in out.iter_mut().zip(l.iter()).take(entries.len()) {
        for e in 0..m {
            row[e] = T::of(lrow[e]);
        }
    }
    true
}

/// Model G's estimates of σ0, Ω′ and A are linear in the outputs p (the decomposition
/// `A = ε{a}² + diag(d)` only reparametrises the six components of A), so their covariances are
/// constants of the arrangement and mask: computed once, by first-order propagation through
/// `(a, x)` at any point where it is regular (exact for a linear map).
#[derive(Clone, Copy, Debug)]
pub struct GeneralCovariance<T> {
    /// Standard deviations of σ0 (body frame), per unit whitened noise.
    pub sd_sigma0: [T; 3],
    /// Standard deviations of Ω′ (body frame).
    pub sd_domega: [T; 3],
    /// Covariance of A (body frame, components `[xx, yy, zz, xy, xz, yz]`).
    pub field: [[T; 6]; 6],
    /// Standard deviations of A's components (the square roots of `field`'s diagonal).
    pub sd_field: Sym3<T>,
}

impl GeneralCovariance<f64> {
    fn cast<T: Real>(&self) -> GeneralCovariance<T> {
        let c3 = |v: &[f64; 3]| [T::of(v[0]), T::of(v[1]), T::of(v[2])];
        let mut field = [[T::ZERO; 6]; 6];
        for (d, s) in field.iter_mut().zip(self.field.iter()) {
            for (dd, ss) in d.iter_mut().zip(s.iter()) {
                *dd = T::of(*ss);
            }
        }
        GeneralCovariance {
            sd_sigma0: c3(&self.sd_sigma0),
            sd_domega: c3(&self.sd_domega),
            field,
            sd_field: self.sd_field.cast(),
        }
    }
}

/// See [`GeneralCovariance`]. Evaluated at `a = (1, 1, 1)`, `ε = +1` in frame `v`.
fn general_covariance<const CAP: usize>(
    pinv: &[[f64; CAP]; MAX_COLS],
    n: usize,
    mq: &[Sym3<f64>; CAP],
    tq: &[Sym3<f64>; MAX_COLS],
    m: usize,
    v: &Mat3<f64>,
) -> Option<GeneralCovariance<f64>> {
    let a = [1.0, 1.0, 1.0];
    // cov(a) = (JᵀJ)⁻¹, J rows 2 M_k a.
    let mut jtj = Sym3::<f64>::zero();
    for mk in mq.iter().take(m) {
        let g = mk.mul_vec(&a);
        jtj.add_outer(&[2.0 * g[0], 2.0 * g[1], 2.0 * g[2]]);
    }
    let ca = jtj.inverse(1e-300)?.to_mat();
    // x = y − [aᵀ T_j a]: H rows −2 T_j a; cov(x) = G⁺G⁺ᵀ + H cov(a) Hᵀ, cov(x, a) = H cov(a).
    let mut h = [[0.0f64; 3]; MAX_COLS];
    for (hj, tj) in h.iter_mut().zip(tq.iter()) {
        let t = tj.mul_vec(&a);
        *hj = [-2.0 * t[0], -2.0 * t[1], -2.0 * t[2]];
    }
    let mut z = [[0.0f64; 12]; 12]; // covariance of (a, x)
    for i in 0..3 {
        for j in 0..3 {
            z[i][j] = ca[i][j];
        }
    }
    for r in 0..MAX_COLS {
        let hc = crate::linalg::mat_t_vec(&ca, &h[r]);
        for j in 0..3 {
            z[3 + r][j] = hc[j];
            z[j][3 + r] = hc[j];
        }
        for c in 0..MAX_COLS {
            let g0: f64 = (0..n).map(|i| pinv[r][i] * pinv[c][i]).sum();
            z[3 + r][3 + c] = g0 + hc[0] * h[c][0] + hc[1] * h[c][1] + hc[2] * h[c][2];
        }
    }
    // A_V = {a}² + diag(d) (ε = +1): K = ∂A_V/∂(a, x), rows [xx, yy, zz, xy, xz, yz].
    let mut kmat = [[0.0f64; 12]; 6];
    for i in 0..3 {
        // ∂(a_i² − |a|²)/∂a_j = −2 a_j for j ≠ i.
        for j in 0..3 {
            if j != i {
                kmat[i][j] = -2.0 * a[j];
            }
        }
        kmat[i][3 + 6 + i] = 1.0; // d_i
    }
    for (row, (p, q)) in [(3, (0, 1)), (4, (0, 2)), (5, (1, 2))] {
        kmat[row][p] = a[q];
        kmat[row][q] = a[p];
    }
    let cav = sandwich::<6, 12>(&kmat, &z);
    // Rotate to the body frame: A_b = Vᵀ A_V V, a linear map R on the six components.
    let idx = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)];
    let mut rot = [[0.0f64; 6]; 6];
    for (col, &(p, q)) in idx.iter().enumerate() {
        let mut e = [[0.0f64; 3]; 3];
        e[p][q] = 1.0;
        e[q][p] = 1.0;
        for (row, &(r, c)) in idx.iter().enumerate() {
            let mut acc = 0.0;
            for k in 0..3 {
                for l in 0..3 {
                    acc += v[k][r] * e[k][l] * v[l][c];
                }
            }
            rot[row][col] = acc;
        }
    }
    let field = sandwich::<6, 6>(&rot, &cav);
    let body_sd = |b: usize| {
        let mut out = [0.0f64; 3];
        for (k, o) in out.iter_mut().enumerate() {
            let mut acc = 0.0;
            for i in 0..3 {
                for j in 0..3 {
                    acc += v[i][k] * z[3 + 3 * b + i][3 + 3 * b + j] * v[j][k];
                }
            }
            *o = Real::sqrt(acc.max(0.0));
        }
        out
    };
    let mut sd_field = Sym3::<f64>::zero();
    for (i, o) in sd_field.0.iter_mut().enumerate() {
        *o = Real::sqrt(field[i][i].max(0.0));
    }
    let gc = GeneralCovariance {
        sd_sigma0: body_sd(0),
        sd_domega: body_sd(1),
        field,
        sd_field,
    };
    let finite = gc
        .sd_sigma0
        .iter()
        .chain(gc.sd_domega.iter())
        .chain(gc.field.iter().flatten())
        .all(|x| x.is_finite());
    finite.then_some(gc)
}

/// `K C Kᵀ` for `K` (R × C) and symmetric `C` (C × C).
fn sandwich<const R: usize, const C: usize>(k: &[[f64; C]; R], c: &[[f64; C]; C]) -> [[f64; R]; R] {
    let mut kc = [[0.0f64; C]; R];
    for r in 0..R {
        for j in 0..C {
            kc[r][j] = (0..C).map(|i| k[r][i] * c[i][j]).sum();
        }
    }
    let mut out = [[0.0f64; R]; R];
    for r in 0..R {
        for s in 0..R {
            out[r][s] = (0..C).map(|j| kc[r][j] * k[s][j]).sum();
        }
    }
    out
}

/// Row of paper eq. (11) for a channel with axis `s` and position `r` (same frame):
/// `[s; R × s; s∘R]` (σ0, Ω′, d).
pub(crate) fn design_row(s: &[f64; 3], r: &[f64; 3]) -> [f64; MAX_COLS] {
    let rxs = cross(r, s);
    [
        s[0],
        s[1],
        s[2],
        rxs[0],
        rxs[1],
        rxs[2],
        s[0] * r[0],
        s[1] * r[1],
        s[2] * r[2],
    ]
}

/// Whether the model-G forms `T_j = Σ_i G⁺_ji Q_i` have the diagonals the design implies:
/// zero for σ0 and Ω′ (`j < 6`), `e_c − (1, 1, 1)` for `d_c` (`j = 6 + c`). Each sensor form's
/// diagonal is `s∘R − (s·R)(1, 1, 1)` and `s∘R` is the design row's `d` part, so
/// `diag T_j = (G⁺G)_{j,d} − Σ_c (G⁺G)_{j,d_c}` with `G⁺G = I`. Then
/// `aᵀ T_j a = 2 (T_j,xy a_x a_y + T_j,xz a_x a_z + T_j,yz a_y a_z) + [j ≥ 6] (a_c² − |a|²)`:
/// the sample loop reads three entries of each form instead of six. Checked, not assumed
/// (to 1e-9 of the form's largest entry, or of 1), so that any other design keeps the full
/// forms.
pub(crate) fn tq_structured(tq: &[Sym3<f64>; MAX_COLS], k: usize) -> bool {
    k == MAX_COLS
        && tq.iter().enumerate().all(|(j, t)| {
            let big = t.0.iter().fold(1.0f64, |a, v| a.max(v.abs()));
            (0..3).all(|c| {
                let want = if j < 6 || j - 6 == c { 0.0 } else { -1.0 };
                (t.0[c] - want).abs() <= 1e-9 * big
            })
        })
}

/// Checks that no design-matrix column (body frame) is zero over the included channels, naming
/// the unknown that could not be seen (for example "d_z is not observable: every channel has
/// s_z·R_z = 0").
pub fn check_structural<const CAP: usize>(
    arr: &Arrangement<CAP>,
    mask: ChannelMask,
    model: Model,
) -> Result<(), ConfigError> {
    let k = model.linear_unknowns();
    let mut colmax = [0.0f64; MAX_COLS];
    let mut scale = 0.0f64;
    for (i, ch) in arr.channels().iter().enumerate() {
        if !mask.contains(i) {
            continue;
        }
        let (s, r) = (ch.axis, ch.position);
        let g = design_row(&s, &r);
        for c in 0..k {
            colmax[c] = colmax[c].max(libm::fabs(g[c]));
        }
        let rn = Real::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
        scale = scale.max(rn);
    }
    for (c, &cm) in colmax.iter().enumerate().take(k) {
        // σ0 columns are unitless (axis components), the others scale with the lever arm.
        let tol = if c < 3 { 1e-9 } else { 1e-9 * scale.max(1e-12) };
        if cm <= tol {
            return Err(ConfigError::NotObservable {
                unknown: Unknown::of_column(c),
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimator::FRAME_QUATERNIONS;
    use crate::linalg::{dot, quat_to_mat};

    const CAP: usize = 24;

    /// Five tri-axial parts at irregular positions, tilted axes, unequal noise: N = 15.
    fn arrangement() -> Arrangement<CAP> {
        let mut arr = Arrangement::new();
        let positions = [
            [0.12, 0.01, -0.03],
            [-0.05, 0.11, 0.02],
            [0.02, -0.09, 0.10],
            [-0.08, -0.04, -0.07],
            [0.04, 0.06, 0.09],
        ];
        for (p, r) in positions.iter().enumerate() {
            let tilt = 0.1 * (p as f64 + 1.0);
            for (j, axis) in [
                [1.0, tilt, 0.0],
                [-tilt, 1.0, 0.5 * tilt],
                [0.0, -0.5 * tilt, 1.0],
            ]
            .iter()
            .enumerate()
            {
                let noise = 0.002 * (1.0 + ((p + j) % 3) as f64);
                arr.push(*r, *axis, noise).unwrap();
            }
        }
        arr
    }

    /// `y = W p` for the first `k + m` rows.
    fn apply(pr: &Projection<f64, CAP>, p: &[f64]) -> [f64; CAP] {
        let mut y = [0.0; CAP];
        for (r, yr) in y.iter_mut().enumerate().take(pr.k + pr.m) {
            *yr = p.iter().enumerate().map(|(i, v)| pr.wt[i][r] * v).sum();
        }
        y
    }

    /// Paper eq. (10)–(11): `W = [G⁺; U⊥ᵀ] diag(1/σ)` gives back the linear unknowns of a
    /// field with `a = 0` and zero in the null-space rows, in every frame, for both models.
    #[test]
    fn w_inverts_the_design_and_its_null_rows_annihilate_it() {
        let arr = arrangement();
        let n = arr.len();
        for model in [Model::General, Model::FreeFloat] {
            for (f, q) in FRAME_QUATERNIONS.iter().enumerate() {
                let v = quat_to_mat(*q);
                let mut pr = Projection::<f64, CAP>::empty();
                pr.build(&arr, ChannelMask::all(n), model, &v, f as u8)
                    .unwrap();
                assert_eq!((pr.k, pr.m), (model.linear_unknowns(), n - pr.k));
                let x: [f64; MAX_COLS] = core::array::from_fn(|j| 0.3 * j as f64 - 1.1);
                let p: Vec<f64> = arr
                    .channels()
                    .iter()
                    .map(|c| {
                        let g = design_row(&mat_vec(&v, &c.axis), &mat_vec(&v, &c.position));
                        (0..pr.k).map(|j| g[j] * x[j]).sum()
                    })
                    .collect();
                let y = apply(&pr, &p);
                for j in 0..pr.k {
                    assert!((y[j] - x[j]).abs() < 1e-9, "{model:?} frame {f} x{j}");
                }
                for e in 0..pr.m {
                    assert!(y[pr.k + e].abs() < 1e-9, "{model:?} frame {f} null row {e}");
                }
            }
        }
    }

    /// Model F (`A = {a}²`, Γ = 0): the null-space rows of `W p` are the quadratic forms
    /// `aᵀ M_k a`, and `y_lin − [aᵀ T_j a]` gives σ0 and Ω′ back (estimator.md: "G⁺ q(a) is nine
    /// quadratic forms").
    #[test]
    fn forms_reproduce_the_centripetal_term() {
        let arr = arrangement();
        let n = arr.len();
        let mut pr = Projection::<f64, CAP>::empty();
        let id = quat_to_mat(FRAME_QUATERNIONS[0]);
        pr.build(&arr, ChannelMask::all(n), Model::FreeFloat, &id, 0)
            .unwrap();
        let (sigma0, domega, a) = ([0.2, -9.7, 0.4], [1.5, -0.3, 0.8], [0.7, -1.9, 2.4]);
        let field = Sym3::skew_squared(&a);
        let p: Vec<f64> = arr
            .channels()
            .iter()
            .map(|c| {
                let (s, r) = (&c.axis, &c.position);
                dot(s, &sigma0) + dot(&cross(r, s), &domega) + dot(s, &field.mul_vec(r))
            })
            .collect();
        let y = apply(&pr, &p);
        let x = [sigma0, domega].concat();
        for j in 0..6 {
            let lin = y[j] - pr.tq[j].quad(&a);
            assert!((lin - x[j]).abs() < 1e-8, "x{j}: {lin} vs {}", x[j]);
        }
        for e in 0..pr.m {
            let form = pr.mq[e].quad(&a);
            assert!(
                (y[6 + e] - form).abs() < 1e-8,
                "form {e}: {} vs {form}",
                y[6 + e]
            );
        }
    }

    /// Model G in every frame: the forms `T_j` have the diagonals the design implies
    /// ([`tq_structured`]), so the sample loop's three-entry `aᵀ T_j a` equals the full form;
    /// model F's forms do not (its design has no `d` columns) and keep all six entries.
    #[test]
    fn general_forms_have_the_known_diagonals() {
        let arr = arrangement();
        let n = arr.len();
        let a = [0.7, -1.9, 2.4];
        for (f, q) in FRAME_QUATERNIONS.iter().enumerate() {
            let v = quat_to_mat(*q);
            let mut pr = Projection::<f64, CAP>::empty();
            pr.build(&arr, ChannelMask::all(n), Model::General, &v, f as u8)
                .unwrap();
            assert!(pr.tq_diag_known, "frame {f}");
            let a2 = dot(&a, &a);
            for j in 0..pr.k {
                let t = &pr.tq[j].0;
                let off = 2.0 * (t[3] * a[0] * a[1] + t[4] * a[0] * a[2] + t[5] * a[1] * a[2]);
                let diag = if j >= 6 {
                    a[j - 6] * a[j - 6] - a2
                } else {
                    0.0
                };
                let full = pr.tq[j].quad(&a);
                assert!(
                    (off + diag - full).abs() < 1e-9 * full.abs().max(1.0),
                    "frame {f} T{j}: {} vs {full}",
                    off + diag
                );
            }
        }
        let mut pr = Projection::<f64, CAP>::empty();
        pr.build(
            &arr,
            ChannelMask::all(n),
            Model::FreeFloat,
            &quat_to_mat(FRAME_QUATERNIONS[0]),
            0,
        )
        .unwrap();
        assert!(!pr.tq_diag_known);
    }
}
