//! The parity space of model G: what the readings say about a fault, whatever the
//! motion.
//!
//! Model G is linear in twelve unknowns — σ0, Ω′ and the six components of `A` (paper eq. 11:
//! the nine columns `[s; R × s; s∘R]` of σ0, Ω′ and `d`, plus the off-diagonals of `A`, which
//! the null-space equations carry as `2 Q₁₂, 2 Q₁₃, 2 Q₂₃`). With whitened readings
//! `w_i = (p_i − bias_i) / (scale_i σ_i)` and `P = I − H` the projector onto the left null
//! space of that N × 12 design, the residual `r = P w` is independent of the motion:
//!
//! - `χ² = wᵀ P w` has `N − 12` degrees of freedom when every part is healthy;
//! - without the channels `S` of one part, the residual is `χ² − r_Sᵀ (P_SS)⁻¹ r_S` with
//!   `N − 12 − |S|` degrees of freedom (the deletion formula of a linear model: the exact
//!   leave-one-part-out test of parity-space isolation), evaluated as the norm of
//!   `r − P_{·S} (P_SS)⁻¹ r_S` (no cancellation under a gross fault).
//!
//! So a fault in part `p` leaves the residual without `p` consistent and every other one
//! high. Everything is precomputed per channel set ([`Parity::build`], outside the sample
//! loop); [`Parity::evaluate`] costs `N²` multiply–adds and `4 N` per part (on the M4F,
//! `cargo qemu-bench`: the fault monitor's step, this and its window, 6 342 instructions per
//! set at N = 24 with 8 parts, a first version
//! indexed by channel, with the mask tested in
//! every inner loop, took 16 163). Model F's
//! residual is not linear in its unknowns (`a ≡ Ω` enters quadratically), so there is no
//! motion-independent parity space there; [`crate::fault_monitor`] says so.

use crate::arrangement::{Arrangement, ChannelMask, Model};
use crate::design::{design_row, MAX_CONDITION};
use crate::error::ConfigError;
use crate::linalg::Sym3;
use crate::real::Real;
use crate::svd::{Svd, MAX_COLS};

/// Unknowns of model G's linear form (σ0, Ω′, the six components of `A`).
pub const UNKNOWNS: usize = 12;

/// Channels of one part that the parity space tells apart (a tri-axial part has three).
pub const PART_CHANNELS: usize = 3;

/// A part marker for channels that belong to no part the monitor should isolate.
pub const NO_PART: u8 = u8::MAX;

/// The leave-one-part-out test of one part.
#[derive(Clone, Copy, Debug)]
struct PartTest<T> {
    /// Its included channels (`count` of them), and their rows of the channel set.
    channels: [u8; PART_CHANNELS],
    rows: [u8; PART_CHANNELS],
    count: u8,
    /// `(P_SS)⁻¹`, padded with the identity beyond `count`.
    inverse: Sym3<T>,
    /// Whether removing the part leaves a residual that can be tested (at least one degree of
    /// freedom) and `P_SS` is invertible: otherwise the part cannot be isolated.
    isolable: bool,
}

/// The precomputed parity space of one channel set (model G).
#[derive(Clone)]
pub struct Parity<T, const CAP: usize> {
    n: usize,
    dof: usize,
    /// The channel set's channels, in order (`rows` of them): row `a` is channel `index[a]`.
    index: [u8; CAP],
    rows: usize,
    /// `P` (whitened channel space), by row of the channel set.
    projector: [[T; CAP]; CAP],
    /// `1 / (scale σ)` per row.
    weight: [T; CAP],
    /// Calibrated bias per row.
    bias: [T; CAP],
    parts: [PartTest<T>; CAP],
    n_parts: usize,
}

/// What one sample set says ([`Parity::evaluate`]).
#[derive(Clone, Copy, Debug)]
pub struct ParitySample<T, const CAP: usize> {
    /// `χ² = wᵀ P w` over the channel set.
    pub chi2: T,
    /// Per part (in the order of part numbers): the residual without it (`χ²` for a part that
    /// cannot be isolated).
    pub without: [T; CAP],
}

/// Each part's leave-one-part-out test over the channels of `mask` (`idx`: their channel
/// indices in row order; `part[i]`: channel `i`'s part, of `n` channels): its included channels
/// and `(P_SS)⁻¹` from the projector `p64`, isolable where removing it leaves a degree of
/// freedom of `dof` and `P_SS` is invertible. Returns the tests and the number of parts.
fn part_tests<T: Real, const CAP: usize>(
    part: &[u8],
    mask: ChannelMask,
    n: usize,
    idx: &[usize],
    dof: usize,
    p64: &[[f64; CAP]; CAP],
) -> ([PartTest<T>; CAP], usize) {
    // The parts: their included channels and P_SS⁻¹.
    let empty = PartTest {
        channels: [0; PART_CHANNELS],
        rows: [0; PART_CHANNELS],
        count: 0,
        inverse: Sym3([T::ONE, T::ONE, T::ONE, T::ZERO, T::ZERO, T::ZERO]),
        isolable: false,
    };
    let mut parts = [empty; CAP];
    let mut n_parts = 0;
    let mut row_of = [usize::MAX; CAP];
    for (row, &i) in idx.iter().enumerate() {
        row_of[i] = row;
    }
    let mut overfull = [false; CAP];
    for (i, &pt) in part.iter().enumerate().take(n) {
        let pt = usize::from(pt);
        if pt >= CAP || !mask.contains(i) {
            continue;
        }
        n_parts = n_parts.max(pt + 1);
        let t = &mut parts[pt];
        if usize::from(t.count) == PART_CHANNELS {
            overfull[pt] = true;
            continue;
        }
        t.channels[usize::from(t.count)] = i as u8;
        t.rows[usize::from(t.count)] = row_of[i] as u8;
        t.count += 1;
    }
    for (t, over) in parts.iter_mut().zip(overfull).take(n_parts) {
        let c = usize::from(t.count);
        if c == 0 || over || dof <= c {
            continue;
        }
        let mut pss = [[0.0f64; 3]; 3];
        for (a, pa) in pss.iter_mut().enumerate() {
            for (b, pab) in pa.iter_mut().enumerate() {
                *pab = if a < c && b < c {
                    p64[usize::from(t.rows[a])][usize::from(t.rows[b])]
                } else if a == b {
                    1.0
                } else {
                    0.0
                };
            }
        }
        // Invertible to well within working precision (each diagonal ≤ 1): a part whose
        // channels' parity directions are (nearly) dependent cannot be told apart.
        if let Some(inv) = Sym3::from_mat(&pss).inverse(1e-6) {
            t.inverse = inv.cast();
            t.isolable = true;
        }
    }
    (parts, n_parts)
}

impl<T: Real, const CAP: usize> Parity<T, CAP> {
    /// The parity space of the channels of `mask` in `arr`; `part[i]` is channel `i`'s part
    /// number (below `CAP`, or [`NO_PART`]). Errors: too few channels for a residual (model G
    /// needs 13 for one degree of freedom), or a design that cannot separate the unknowns.
    pub fn build(
        arr: &Arrangement<CAP>,
        mask: ChannelMask,
        part: &[u8],
    ) -> Result<Self, ConfigError> {
        let n = arr.len();
        let mut idx = [0usize; CAP];
        let mut rows = 0;
        for i in 0..n {
            if mask.contains(i) {
                idx[rows] = i;
                rows += 1;
            }
        }
        let need = UNKNOWNS + 1;
        if rows < need {
            return Err(ConfigError::TooFewChannels {
                model: Model::General,
                have: rows,
                need,
            });
        }
        // The nine linear columns (whitened, equilibrated) and the three off-diagonal ones.
        let mut cols = [[0.0f64; CAP]; MAX_COLS];
        let mut off = [[0.0f64; CAP]; 3];
        for (row, &i) in idx.iter().enumerate().take(rows) {
            let ch = &arr.channels()[i];
            let g = design_row(&ch.axis, &ch.position);
            for c in 0..MAX_COLS {
                cols[c][row] = g[c] / ch.noise;
            }
            let q = Sym3::sensor_form(&ch.axis, &ch.position);
            for c in 0..3 {
                off[c][row] = 2.0 * q.0[3 + c] / ch.noise;
            }
        }
        for col in cols.iter_mut() {
            let norm = Real::sqrt(col[..rows].iter().map(|x| x * x).sum::<f64>());
            if norm > 0.0 {
                col[..rows].iter_mut().for_each(|x| *x /= norm);
            }
        }
        let svd = Svd::<CAP>::new(&cols, rows, MAX_COLS);
        let degenerate = |condition: f64| ConfigError::Degenerate {
            involved: 0,
            condition,
            frame: 0,
        };
        if !(svd.condition() <= MAX_CONDITION) {
            return Err(degenerate(svd.condition()));
        }
        let m = rows - MAX_COLS;
        let mut null = [[0.0f64; CAP]; CAP];
        svd.left_null_space(&mut null);
        // The off-diagonal columns in the null space (`L`, m × 3), orthonormalised.
        let mut l = [[0.0f64; CAP]; MAX_COLS];
        for c in 0..3 {
            for e in 0..m {
                l[c][e] = (0..rows).map(|row| null[e][row] * off[c][row]).sum();
            }
        }
        let lsvd = Svd::<CAP>::new(&l, m, 3);
        if !(lsvd.condition() <= MAX_CONDITION) {
            return Err(degenerate(lsvd.condition()));
        }
        // v_c = U⊥ u_c: the null-space directions the off-diagonals take away.
        let mut v = [[0.0f64; CAP]; 3];
        for c in 0..3 {
            for row in 0..rows {
                v[c][row] = (0..m).map(|e| null[e][row] * lsvd.u[c][e]).sum();
            }
        }
        let mut projector = [[T::ZERO; CAP]; CAP];
        let mut p64 = [[0.0f64; CAP]; CAP];
        for a in 0..rows {
            for b in 0..rows {
                let x = (0..m).map(|e| null[e][a] * null[e][b]).sum::<f64>()
                    - (0..3).map(|c| v[c][a] * v[c][b]).sum::<f64>();
                p64[a][b] = x;
                projector[a][b] = T::of(x);
            }
        }
        let dof = m - 3;
        let mut weight = [T::ZERO; CAP];
        let mut bias = [T::ZERO; CAP];
        let mut index = [0u8; CAP];
        for (row, &i) in idx.iter().enumerate().take(rows) {
            let ch = &arr.channels()[i];
            weight[row] = T::of(1.0 / (ch.scale * ch.noise));
            bias[row] = T::of(ch.bias);
            index[row] = i as u8;
        }
        let (parts, n_parts) = part_tests(part, mask, n, &idx[..rows], dof, &p64);
        Ok(Parity {
            n,
            dof,
            index,
            rows,
            projector,
            weight,
            bias,
            parts,
            n_parts,
        })
    }

    /// Degrees of freedom of `χ²` (`N − 12`).
    pub fn dof(&self) -> usize {
        self.dof
    }

    /// Part numbers covered (`without` of [`ParitySample`] has this many entries).
    pub fn parts(&self) -> usize {
        self.n_parts
    }

    /// Whether part `p` can be isolated, and the degrees of freedom left without it.
    pub fn part_dof(&self, p: usize) -> Option<usize> {
        let t = self.parts.get(p).filter(|t| t.isolable)?;
        Some(self.dof - usize::from(t.count))
    }

    /// The channels of part `p` in the channel set.
    pub fn part_channels(&self, p: usize) -> &[u8] {
        match self.parts.get(p) {
            Some(t) => &t.channels[..usize::from(t.count)],
            None => &[],
        }
    }

    /// The residual of one sample set (`p[i]`: channel `i`'s reading, m/s²), or `None` if a
    /// reading of the channel set is not finite: `χ²` and each part's residual without it
    /// ([`Self::residual`], then [`Self::split`]).
    pub fn evaluate(&self, p: &[T]) -> Option<ParitySample<T, CAP>> {
        self.residual(p).map(|r| self.split(&r))
    }

    /// The residual vector `r = P w` of one sample set, by row of the channel set (zero
    /// beyond it), or `None` if a reading of the channel set is not finite. `N²`
    /// multiply–adds. Linear in the readings: the mean of residuals is the residual of the
    /// mean ([`crate::fault_monitor`]'s mean test).
    pub fn residual(&self, p: &[T]) -> Option<[T; CAP]> {
        if p.len() < self.n {
            return None;
        }
        let rows = self.rows;
        let mut w = [T::ZERO; CAP];
        let mut finite = T::ZERO;
        for (((wa, &i), b), k) in w
            .iter_mut()
            .zip(self.index.iter())
            .zip(self.bias.iter())
            .zip(self.weight.iter())
            .take(rows)
        {
            *wa = (p[usize::from(i)] - *b) * *k;
            finite += *wa * T::ZERO;
        }
        if !(finite == T::ZERO) {
            return None;
        }
        let w = &w[..rows];
        // `r = P w` then `χ² = |r|²`, not `wᵀ P w`: the readings' rigid-body part (`|w|` ≈ 10⁴
        // for gravity at σ = 1 mg) is what `P` removes, and `wᵀ (P w)` would multiply the
        // round-off of `P w` by it (in f32: 886.8 against 893.4 in f64 for one sample of the
        // test below).
        let mut r = [T::ZERO; CAP];
        for (ra, pa) in r.iter_mut().zip(self.projector.iter()).take(rows) {
            *ra = pa[..rows]
                .iter()
                .zip(w)
                .fold(T::ZERO, |acc, (x, y)| acc + *x * *y);
        }
        Some(r)
    }

    /// `χ² = |r|²` of a residual vector (by row, [`Self::residual`]) and each part's residual
    /// without it: `4 N` multiply–adds per part.
    pub fn split(&self, r: &[T; CAP]) -> ParitySample<T, CAP> {
        let r = &r[..self.rows];
        let chi2 = r.iter().fold(T::ZERO, |acc, x| acc + *x * *x);
        // Without part S: `r − P_{·S} (P_SS)⁻¹ r_S`, component by component, then its square.
        // (`χ² − r_Sᵀ (P_SS)⁻¹ r_S` is the same in exact arithmetic, but under a gross fault
        // both terms are ≈ |w|² ≈ 10⁸ and f32 leaves their difference at ±10: a part whose
        // removal did not explain the fault then looked as if it did.) `P` is symmetric: its
        // column `s` is its row `s`.
        let mut without = [chi2; CAP];
        for (out, t) in without.iter_mut().zip(self.parts.iter()).take(self.n_parts) {
            if !t.isolable {
                continue;
            }
            let mut rs = [T::ZERO; 3];
            for (x, &row) in rs.iter_mut().zip(t.rows.iter()).take(usize::from(t.count)) {
                *x = r[usize::from(row)];
            }
            let g = t.inverse.mul_vec(&rs);
            // Padded rows have g = 0 (identity inverse, zero residual).
            let [c0, c1, c2] = t
                .rows
                .map(|row| &self.projector[usize::from(row)][..self.rows]);
            let mut acc = T::ZERO;
            for (((ra, x0), x1), x2) in r.iter().zip(c0).zip(c1).zip(c2) {
                let d = *ra - *x0 * g[0] - *x1 * g[1] - *x2 * g[2];
                acc += d * d;
            }
            *out = acc;
        }
        ParitySample { chi2, without }
    }

    /// The mean of [`Self::evaluate`]'s `χ²` and of each part's residual without it when the
    /// readings are consistent but channel `i`'s noise variance is `var[i]` times the declared
    /// one (a value interpolated between two samples with weight `w` has `w² + (1 − w)²`, 0.5
    /// to 1): `tr(P V)` and `tr(P⁽ᵖ⁾ V)`, `P⁽ᵖ⁾ = P − P_{·S} (P_SS)⁻¹ P_{S·}` (with `var` all 1,
    /// the degrees of freedom). A factor that is not finite and positive counts as 1.
    /// `N (1 + 10 · parts)` multiply–adds: for a change of `var`, not for every set.
    pub fn expected(&self, var: &[T]) -> (T, [T; CAP]) {
        let rows = self.rows;
        let factor = |a: usize| {
            let v = var
                .get(usize::from(self.index[a]))
                .copied()
                .unwrap_or(T::ONE);
            if v > T::ZERO && v.is_finite() {
                v
            } else {
                T::ONE
            }
        };
        let mut chi2 = T::ZERO;
        for a in 0..rows {
            chi2 += factor(a) * self.projector[a][a];
        }
        let mut without = [chi2; CAP];
        for (out, t) in without.iter_mut().zip(self.parts.iter()).take(self.n_parts) {
            if !t.isolable {
                continue;
            }
            let count = usize::from(t.count);
            let mut acc = T::ZERO;
            for a in 0..rows {
                // `P_{aS}` (padded rows: zero) and its form with `(P_SS)⁻¹`.
                let mut u = [T::ZERO; 3];
                for (x, &row) in u.iter_mut().zip(t.rows.iter()).take(count) {
                    *x = self.projector[a][usize::from(row)];
                }
                acc += factor(a) * (self.projector[a][a] - t.inverse.quad(&u));
            }
            *out = acc;
        }
        (chi2, without)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Six tri-axial parts (N = 18): a tetrahedron and two more, none opposite another (two
    /// parts mirrored through the origin can stand in for each other's faults along some
    /// axes: a layout property that the monitor reports as "not isolated").
    pub(crate) fn six_parts() -> (Arrangement<24>, [u8; 18]) {
        let corners = [
            [0.1, 0.1, 0.1],
            [-0.1, -0.1, 0.1],
            [-0.1, 0.1, -0.1],
            [0.1, -0.1, -0.1],
            [0.05, 0.0, -0.12],
            [-0.03, 0.11, 0.02],
        ];
        let mut arr = Arrangement::new();
        let mut part = [0u8; 18];
        for (p, r) in corners.iter().enumerate() {
            for a in 0..3 {
                let mut s = [0.0; 3];
                s[a] = 1.0;
                let c = arr.push(*r, s, 1e-3).unwrap();
                part[c] = p as u8;
            }
        }
        (arr, part)
    }

    /// Readings of a rigid-body field (σ0, Ω′, A general symmetric) plus white noise.
    fn readings(arr: &Arrangement<24>, rng: &mut ChaCha8Rng, noise: f64) -> [f64; 18] {
        let mut u = || rng.gen_range(-1.0..1.0);
        let sigma0 = [u() * 9.8, u() * 9.8, u() * 9.8];
        let domega = [u(), u(), u()];
        let a = Sym3([u(), u(), u(), u(), u(), u()]);
        let mut p = [0.0; 18];
        for (i, ch) in arr.channels().iter().enumerate() {
            let f = crate::linalg::cross(&domega, &ch.position);
            let ar = a.mul_vec(&ch.position);
            p[i] = (0..3)
                .map(|k| ch.axis[k] * (sigma0[k] + f[k] + ar[k]))
                .sum::<f64>();
        }
        let normal = rand_distr_normal(rng);
        for (x, z) in p.iter_mut().zip(normal) {
            *x += noise * z;
        }
        p
    }

    fn rand_distr_normal(rng: &mut ChaCha8Rng) -> [f64; 18] {
        core::array::from_fn(|_| {
            // Box–Muller.
            let (u1, u2): (f64, f64) = (rng.gen_range(1e-12..1.0), rng.gen());
            (-2.0 * u1.ln()).sqrt() * (2.0 * core::f64::consts::PI * u2).cos()
        })
    }

    #[test]
    fn a_noise_free_rigid_body_has_no_residual_and_noise_gives_its_degrees_of_freedom() {
        let (arr, part) = six_parts();
        let par = Parity::<f64, 24>::build(&arr, ChannelMask::all(18), &part).unwrap();
        assert_eq!(par.dof(), 6);
        assert_eq!(par.parts(), 6);
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        for _ in 0..20 {
            let s = par.evaluate(&readings(&arr, &mut rng, 0.0)).unwrap();
            assert!(s.chi2 < 1e-12, "{}", s.chi2);
        }
        let trials = 4000;
        let mean = (0..trials)
            .map(|_| par.evaluate(&readings(&arr, &mut rng, 1e-3)).unwrap().chi2)
            .sum::<f64>()
            / trials as f64;
        // E χ²₆ = 6, its sample mean's deviation sqrt(12 / 4000) = 0.055.
        assert!((mean - 6.0).abs() < 0.25, "mean χ² {mean}");
    }

    #[test]
    fn the_residual_without_a_part_is_that_of_the_parity_space_built_without_it() {
        let (arr, part) = six_parts();
        let all = Parity::<f64, 24>::build(&arr, ChannelMask::all(18), &part).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let p = readings(&arr, &mut rng, 1e-3);
        let s = all.evaluate(&p).unwrap();
        for pt in 0..6 {
            let mut mask = ChannelMask::all(18);
            for &c in all.part_channels(pt) {
                mask = mask.without(usize::from(c));
            }
            let less = Parity::<f64, 24>::build(&arr, mask, &part).unwrap();
            assert_eq!(all.part_dof(pt), Some(less.dof()));
            let direct = less.evaluate(&p).unwrap().chi2;
            // Agreement to round-off: `w` is ≈ 10⁴ here, the residuals ≈ 1.
            assert!(
                (s.without[pt] - direct).abs() < 1e-6 * (1.0 + direct),
                "part {pt}: {} vs {direct}",
                s.without[pt]
            );
        }
    }

    /// The means under declared variances: the degrees of freedom with every channel as
    /// declared, and the sample mean of many draws with some channels at other variances.
    #[test]
    fn the_expected_residuals_are_the_degrees_of_freedom_and_follow_the_variances() {
        let (arr, part) = six_parts();
        let par = Parity::<f64, 24>::build(&arr, ChannelMask::all(18), &part).unwrap();
        let (chi2, without) = par.expected(&[1.0; 18]);
        assert!((chi2 - 6.0).abs() < 1e-9, "{chi2}");
        for (pt, w) in without.iter().enumerate().take(6) {
            let dof = par.part_dof(pt).unwrap() as f64;
            assert!((w - dof).abs() < 1e-9, "part {pt}: {w}");
        }
        // Parts 0 and 1 at half their declared variance, part 5 at 1.5 times.
        let var: [f64; 18] = core::array::from_fn(|i| match i / 3 {
            0 | 1 => 0.5,
            5 => 1.5,
            _ => 1.0,
        });
        let (chi2, without) = par.expected(&var);
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let trials = 20_000;
        let mut mean = [0.0f64; 7];
        for _ in 0..trials {
            let clean = readings(&arr, &mut rng, 0.0);
            let z = rand_distr_normal(&mut rng);
            let p: [f64; 18] = core::array::from_fn(|i| clean[i] + 1e-3 * var[i].sqrt() * z[i]);
            let s = par.evaluate(&p).unwrap();
            mean[0] += s.chi2 / trials as f64;
            for pt in 0..6 {
                mean[pt + 1] += s.without[pt] / trials as f64;
            }
        }
        // Sample means of χ²-like sums of about 6 and 3 terms: deviation ≲ 0.03.
        assert!((mean[0] - chi2).abs() < 0.1, "χ² {} vs {chi2}", mean[0]);
        for pt in 0..6 {
            let (got, want) = (mean[pt + 1], without[pt]);
            assert!((got - want).abs() < 0.1, "part {pt}: {got} vs {want}");
        }
        assert!(!(5.7..=6.3).contains(&chi2), "{chi2}: the variances matter");
    }

    #[test]
    fn a_biased_part_is_the_one_whose_removal_restores_consistency() {
        let (arr, part) = six_parts();
        let par = Parity::<f32, 24>::build(&arr, ChannelMask::all(18), &part).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for faulty in 0..6 {
            let mut p = readings(&arr, &mut rng, 1e-3);
            p[3 * faulty + 1] += 0.1;
            let p32 = p.map(|x| x as f32);
            let s = par.evaluate(&p32).unwrap();
            assert!(s.chi2 > 100.0, "χ² {}", s.chi2);
            for pt in 0..6 {
                let dof = par.part_dof(pt).unwrap();
                let clean = f64::from(s.without[pt]) < crate::estimate::chi2_999(dof);
                assert_eq!(
                    clean,
                    pt == faulty,
                    "fault in {faulty}: without {pt} {}",
                    s.without[pt]
                );
            }
        }
        // A non-finite reading: no verdict.
        let mut p = [0.0f32; 18];
        p[4] = f32::NAN;
        assert!(par.evaluate(&p).is_none());
    }

    #[test]
    fn too_few_channels_for_a_residual_are_refused_by_name() {
        let (arr, part) = six_parts();
        let twelve = ChannelMask::all(12);
        match Parity::<f64, 24>::build(&arr, twelve, &part) {
            Err(ConfigError::TooFewChannels {
                have: 12, need: 13, ..
            }) => {}
            other => panic!("{:?}", other.map(|p| p.dof())),
        }
        // Fifteen channels: three degrees of freedom, too few to test without a tri-axial part.
        let p = Parity::<f64, 24>::build(&arr, ChannelMask::all(15), &part).unwrap();
        assert_eq!(p.dof(), 3);
        assert_eq!(p.part_dof(0), None);
    }
}
