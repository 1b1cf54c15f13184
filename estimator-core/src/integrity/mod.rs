//! Protection levels (the aviation RAIM idea): for σ0, Ω′ and Ω, a bound on the
//! error (vector norm) that holds, at a chosen probability, whatever fault one part has.
//!
//! Model G is linear in twelve unknowns (σ0, Ω′, `A`: [`crate::parity`]). With whitened
//! readings `w = H x + n + b` — `n` the noise, `b` a fault confined to the channels `S` of one
//! part — the least-squares gain `K = (HᵀH)⁻¹Hᵀ` puts `K b` into the unknowns, and the
//! parity projector `P = I − H K` shows `|P b|`, with `|P b|² = b_Sᵀ P_SS b_S`. Writing
//! `b_S = R u` with `R Rᵀ = P_SS⁻¹` (then `|u| = |P b|`), the fault's error is `K_S R u`: at most
//! `‖K_S R‖ |P b|` for the rows of a quantity (`‖·‖` the largest singular value). And `|P b|` is
//! bounded by what the row shows: `|P b| ≤ |P w| + |P n| = √χ² + |P n|`, `|P n|² ~ χ²_ν`.
//!
//! So for each quantity `x`, at each row,
//!
//! `PL_x = z |sd_x| + s_x (√χ² + √χ²_ν(1 − β/2))`, `s_x = max over parts ‖K_{x,S} R_S‖`,
//!
//! with `|sd_x|` the norm of the reported deviations (the fault-free error, frame uncertainty
//! included) and `z` the two-sided normal point at `β/2`: the error exceeds it with probability
//! at most `β` ([`DEFAULT_MISSED`]) when no more than one part is faulty — a fault the monitor
//! has not detected, or one it has not yet isolated, alike (the bound uses the row's own `χ²`,
//! not a detection threshold, so no fault history escapes it: a fault that has just begun, a
//! drift, the gaps between bursts). σ0's and Ω′'s slopes are constants of the channel set,
//! computed exactly at configuration. Ω's goes through `∂Ω/∂A` at the row's Ω
//! ([`crate::linalg::omega_jacobian`]), so it grows as `1/|Ω|` towards rest; per sample it is
//! bounded by the Frobenius norm of `∂Ω/∂A · K_{A,S} R_S` (9 squares per part; at most √3 above
//! the largest singular value, which would cost a 3 × 3 eigenvalue per part and sample).
//!
//! No bound (`None`) without redundancy (`ν = N − 12 ≤ 0`), or where one part's fault can hide
//! from the parity space (`P_SS` singular: the part's removal leaves no test of it), or in
//! model F (its Ω enters quadratically: its gains are not these).

use crate::arrangement::{Arrangement, ChannelMask};
use crate::design::design_row;
use crate::estimate::Estimate;
use crate::fault_monitor::{chi2_quantile, upper_normal_quantile};
use crate::identify::cholesky::{cholesky, cholesky_solve, invert_spd};
use crate::linalg::{omega_jacobian, Sym3, Vec3};
use crate::parity::{NO_PART, PART_CHANNELS, UNKNOWNS};
use crate::real::Real;
use crate::svd::{Svd, MAX_COLS};

/// The default probability that an output's error exceeds its protection level at a row
/// (half of it for the fault-free error, half for the parity space's noise).
pub const DEFAULT_MISSED: f64 = 1e-3;

/// The protection level of an output whose first order fails (Ω at rest): large and finite.
const UNBOUNDED: f64 = 1e6;

/// `√χ²_ν` at `1 − β/2` and the two-sided normal point at `β/2`, for `ν = dof` and
/// `β = missed`: the two halves of the missed probability (the parity space's noise, the
/// fault-free error). `None` unless `0 < missed < 1`.
fn points(dof: usize, missed: f64) -> Option<(f64, f64)> {
    if !(missed > 0.0 && missed < 1.0) {
        return None;
    }
    let half = 0.5 * missed;
    Some((
        Real::sqrt(chi2_quantile(dof as f64, upper_normal_quantile(half))),
        upper_normal_quantile(0.5 * half),
    ))
}

/// The parts of the rows in a solve: each part's rows (a channel of no part is a part of its
/// own).
#[derive(Clone, Debug)]
struct Groups<const CAP: usize> {
    group: [[usize; PART_CHANNELS]; CAP],
    count: [usize; CAP],
    parts: usize,
}

impl<const CAP: usize> Groups<CAP> {
    /// The parts of the channels `idx` (row `r` is channel `idx[r]`); `None` with a part of more
    /// channels than a tri-axial one (not modelled).
    fn of(arr: &Arrangement<CAP>, idx: &[usize]) -> Option<Self> {
        let mut g = Groups {
            group: [[0usize; PART_CHANNELS]; CAP],
            count: [0; CAP],
            parts: 0,
        };
        let mut label = [NO_PART; CAP];
        for (r, &i) in idx.iter().enumerate() {
            let p = arr.part(i);
            let k = match (p != NO_PART)
                .then(|| label[..g.parts].iter().position(|q| *q == p))
                .flatten()
            {
                Some(k) => k,
                None => {
                    label[g.parts] = p;
                    g.parts += 1;
                    g.parts - 1
                }
            };
            if g.count[k] == PART_CHANNELS {
                return None;
            }
            g.group[k][g.count[k]] = r;
            g.count[k] += 1;
        }
        Some(g)
    }

    /// The rows of part `k`.
    fn rows(&self, k: usize) -> &[usize] {
        &self.group[k][..self.count[k]]
    }
}

mod free_float;
pub use free_float::FreeFloatIntegrity;

/// The protection levels' gains of a configuration, by model.
#[derive(Clone, Debug)]
pub enum Protection<T, const CAP: usize> {
    /// Model G: constants of the channel set (Ω's slope through `∂Ω/∂A` per row).
    General(Integrity<T, CAP>),
    /// Model F: linearised at every row's Ω.
    FreeFloat(FreeFloatIntegrity<T, CAP>),
}

impl<T: Real, const CAP: usize> Protection<T, CAP> {
    /// The gains of the channels of `mask` in `arr` under `model`; `None` where no level
    /// exists at any row (no redundancy, a part whose fault can hide).
    pub fn build(
        arr: &Arrangement<CAP>,
        mask: ChannelMask,
        model: crate::Model,
        missed: f64,
    ) -> Option<Self> {
        match model {
            crate::Model::General => Integrity::build(arr, mask, missed).map(Protection::General),
            crate::Model::FreeFloat => {
                FreeFloatIntegrity::build(arr, mask, missed).map(Protection::FreeFloat)
            }
        }
    }

    /// The levels `[σ0, Ω′, Ω]` of `e`; `None` where this row gives none.
    pub fn levels(&self, e: &Estimate<T>) -> Option<[T; 3]> {
        match self {
            Protection::General(g) => Some(g.levels(e)),
            Protection::FreeFloat(f) => f.levels(e),
        }
    }
}

/// The precomputed gains of one channel set (model G).
#[derive(Clone, Debug)]
pub struct Integrity<T, const CAP: usize> {
    /// `s_x` of σ0 and of Ω′: the largest slope over the parts.
    slope: [T; 2],
    /// Per part (`parts` of them): `K_{A,S} R_S`, 6 × 3 (columns beyond its channels zero).
    field: [[[T; PART_CHANNELS]; 6]; CAP],
    parts: usize,
    /// `√χ²_ν` at `1 − β/2`.
    parity_noise: T,
    /// The two-sided normal point at `β/2`.
    free: T,
}

impl<T: Real, const CAP: usize> Integrity<T, CAP> {
    /// The gains for the channels of `mask` in `arr` (each channel's part from
    /// [`Arrangement::part`]), at missed probability `missed`; `None` where no bound exists
    /// (module doc). Configuration time, f64.
    pub fn build(arr: &Arrangement<CAP>, mask: ChannelMask, missed: f64) -> Option<Self> {
        let mut idx = [0usize; CAP];
        let mut rows = 0;
        for i in 0..arr.len() {
            if mask.contains(i) {
                idx[rows] = i;
                rows += 1;
            }
        }
        if rows <= UNKNOWNS || !(missed > 0.0 && missed < 1.0) {
            return None;
        }
        let dof = rows - UNKNOWNS;
        // The whitened design, its columns equilibrated (`norm`).
        let mut h = [[0.0f64; UNKNOWNS]; CAP];
        for (row, &i) in idx.iter().enumerate().take(rows) {
            let ch = &arr.channels()[i];
            let g = design_row(&ch.axis, &ch.position);
            let q = Sym3::sensor_form(&ch.axis, &ch.position);
            for c in 0..9 {
                h[row][c] = g[c] / ch.noise;
            }
            for c in 0..3 {
                h[row][9 + c] = 2.0 * q.0[3 + c] / ch.noise;
            }
        }
        let mut norm = [0.0f64; UNKNOWNS];
        for (c, n) in norm.iter_mut().enumerate() {
            *n = Real::sqrt((0..rows).map(|r| h[r][c] * h[r][c]).sum::<f64>());
            if !(*n > 0.0) {
                return None;
            }
            for hr in h.iter_mut().take(rows) {
                hr[c] /= *n;
            }
        }
        let mut l = [[0.0f64; UNKNOWNS]; UNKNOWNS];
        for a in 0..UNKNOWNS {
            for b in 0..UNKNOWNS {
                l[a][b] = (0..rows).map(|r| h[r][a] * h[r][b]).sum();
            }
        }
        if !cholesky(&mut l, UNKNOWNS) {
            return None;
        }
        // `(HᵀH)⁻¹ h_row` per row: the gain column of each reading (equilibrated unknowns).
        let mut k = [[0.0f64; UNKNOWNS]; CAP];
        for r in 0..rows {
            k[r] = cholesky_solve(&l, UNKNOWNS, &h[r]);
        }
        let groups = Groups::of(arr, &idx[..rows])?;
        let parts = groups.parts;
        let mut slope = [0.0f64; 2];
        let mut field = [[[T::ZERO; PART_CHANNELS]; 6]; CAP];
        for g in 0..parts {
            let s = groups.rows(g);
            // P_SS = I − h_a · k_b, padded with the identity.
            let mut pss = [[0.0f64; 3]; 3];
            for a in 0..3 {
                for b in 0..3 {
                    pss[a][b] = if a < s.len() && b < s.len() {
                        let hk: f64 = (0..UNKNOWNS).map(|c| h[s[a]][c] * k[s[b]][c]).sum();
                        f64::from(u8::from(a == b)) - hk
                    } else {
                        f64::from(u8::from(a == b))
                    };
                }
            }
            // A part whose parity directions are dependent (to f64's precision: Cholesky's
            // pivots) can hide a fault: no bound. Nearly dependent ones give a large slope, not
            // none (an absolute determinant threshold refused the mixed layout's parts with
            // P_SS ≈ 0.005 I, a well-posed bound).
            let mut r = invert_spd(&pss)?;
            if !cholesky(&mut r, 3) {
                return None;
            }
            // F = K_S R (R lower), unknowns unequilibrated.
            let mut f = [[0.0f64; PART_CHANNELS]; UNKNOWNS];
            for (c, fc) in f.iter_mut().enumerate() {
                for j in 0..s.len() {
                    fc[j] = (j..s.len()).map(|a| k[s[a]][c] * r[a][j]).sum::<f64>() / norm[c];
                }
            }
            // σ0's and Ω′'s slopes exactly: the largest singular value of their 3 × |S| block
            // (the configuration's own SVD).
            let gain = |from: usize| -> f64 {
                let mut cols = [[0.0f64; CAP]; MAX_COLS];
                for (j, col) in cols.iter_mut().enumerate().take(s.len()) {
                    for r in 0..3 {
                        col[r] = f[from + r][j];
                    }
                }
                Svd::<CAP>::new(&cols, 3, s.len()).s[0]
            };
            slope[0] = slope[0].max(gain(0));
            slope[1] = slope[1].max(gain(3));
            for c in 0..6 {
                for j in 0..PART_CHANNELS {
                    field[g][c][j] = T::of(f[6 + c][j]);
                }
            }
        }
        let (parity_noise, free) = points(dof, missed)?;
        Some(Integrity {
            slope: [T::of(slope[0]), T::of(slope[1])],
            field,
            parts,
            parity_noise: T::of(parity_noise),
            free: T::of(free),
        })
    }

    /// The protection levels `[σ0 (m/s²), Ω′ (rad/s²), Ω (rad/s)]` of estimate `e` (its `χ²`,
    /// deviations and Ω); finite always.
    pub fn levels(&self, e: &Estimate<T>) -> [T; 3] {
        let norm = |v: &Vec3<T>| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let chi = if e.chi2 > T::ZERO {
            e.chi2.sqrt()
        } else {
            T::ZERO
        };
        let c = chi + self.parity_noise;
        let omega_slope = match omega_jacobian(&e.omega) {
            Some(j) => {
                let mut worst = T::ZERO;
                for f in self.field.iter().take(self.parts) {
                    let mut acc = T::ZERO;
                    for jr in &j {
                        for col in 0..PART_CHANNELS {
                            let mut x = T::ZERO;
                            for (jri, fi) in jr.iter().zip(f.iter()) {
                                x += *jri * fi[col];
                            }
                            acc += x * x;
                        }
                    }
                    worst = worst.max(acc);
                }
                worst.sqrt()
            }
            None => T::of(UNBOUNDED),
        };
        let level = |sd: &Vec3<T>, slope: T| {
            let v = self.free * norm(sd) + slope * c;
            if v.is_finite() {
                v.min(T::of(UNBOUNDED))
            } else {
                T::of(UNBOUNDED)
            }
        };
        [
            level(&e.sd_sigma0, self.slope[0]),
            level(&e.sd_domega, self.slope[1]),
            level(&e.sd_omega, omega_slope),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::{cross, dot};
    use crate::{Estimator, Model, Options};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Six tri-axial parts (N = 18, ν = 6), noise 1 mg, parts given to the arrangement.
    pub(super) fn layout() -> Arrangement<24> {
        let (mut arr, part) = crate::parity::tests::six_parts();
        arr.set_parts(&part);
        arr
    }

    /// Noise-free readings of a rigid body (Γ = 0): σ0, Ω′, Ω.
    pub(super) fn readings(
        arr: &Arrangement<24>,
        s0: Vec3<f64>,
        dw: Vec3<f64>,
        w: Vec3<f64>,
    ) -> [f64; 18] {
        core::array::from_fn(|i| {
            let ch = &arr.channels()[i];
            let r = ch.position;
            let wr = cross(&w, &r);
            let f = [0, 1, 2].map(|k| s0[k] + cross(&dw, &r)[k] + cross(&w, &wr)[k]);
            dot(&ch.axis, &f)
        })
    }

    pub(super) fn raw() -> Options {
        Options {
            raw: true,
            initial_omega: Some([1.0, -0.5, 2.0]),
            ..Options::default()
        }
    }

    pub(super) fn dist(a: &Vec3<f64>, b: &Vec3<f64>) -> f64 {
        (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
    }

    /// A fault on one part moves σ0, Ω′ and (to first order) Ω by no more than its slope
    /// times `√χ²` (noise-free readings: `χ²` is then `|P b|²`), and the bound is not loose: the
    /// worst of many random faults reaches σ0's and Ω′'s slopes and more than half of Ω's
    /// (a Frobenius norm, at most √3 above the exact gain).
    #[test]
    fn a_fault_of_one_part_moves_each_output_by_at_most_its_slope_times_the_residual() {
        let arr = layout();
        let integrity = Integrity::<f64, 24>::build(&arr, ChannelMask::all(18), 1e-3).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let (s0, dw, w) = ([0.3, -9.8, 1.0], [0.5, 0.2, -1.0], [1.0, -0.5, 2.0]);
        let clean = readings(&arr, s0, dw, w);
        let mut est = Estimator::<f64, 24>::new(&arr, Model::General, raw()).unwrap();
        let base = *est.update(0.0, &clean);
        assert!(base.chi2 < 1e-12, "noise-free χ² {}", base.chi2);
        let mut worst = [0.0f64; 3];
        for k in 0..600 {
            let part = k % 6;
            let mut p = clean;
            // 3–30 σ of one reading, random direction over the part's three channels.
            let size = 1e-3 * rng.gen_range(3.0..30.0);
            let dir: [f64; 3] = core::array::from_fn(|_| rng.gen_range(-1.0..1.0));
            let n = dir.iter().map(|x| x * x).sum::<f64>().sqrt();
            for a in 0..3 {
                p[3 * part + a] += size * dir[a] / n;
            }
            let mut est = Estimator::<f64, 24>::new(&arr, Model::General, raw()).unwrap();
            let e = *est.update(0.0, &p);
            let chi = e.chi2.sqrt();
            let omega_slope = {
                // Ω's slope at the fault-free Ω (first order).
                let mut only = e;
                only.chi2 = 0.0;
                only.sd_sigma0 = [0.0; 3];
                only.sd_domega = [0.0; 3];
                only.sd_omega = [0.0; 3];
                only.omega = base.omega;
                integrity.levels(&only)[2] / integrity.parity_noise
            };
            let moved = [
                (dist(&e.sigma0, &base.sigma0), integrity.slope[0]),
                (dist(&e.domega, &base.domega), integrity.slope[1]),
                (dist(&e.omega, &base.omega), omega_slope),
            ];
            for (q, (d, slope)) in moved.iter().enumerate() {
                let ratio = d / (slope * chi);
                // Ω to first order: 2 % allowed for the curvature at 30 σ.
                let room = if q == 2 { 1.02 } else { 1.0 + 1e-9 };
                assert!(ratio <= room, "output {q}, part {part}: {ratio}");
                worst[q] = worst[q].max(ratio);
            }
        }
        // σ0's and Ω′'s slopes are exact (some fault direction reaches them); Ω's is the
        // Frobenius bound.
        assert!(
            worst[0] > 0.95 && worst[1] > 0.95 && worst[2] > 0.5,
            "worst share of the bound {worst:?}"
        );
    }

    /// With noise and a fault of random size (0–30 σ) on a random part, each output's error
    /// is below its protection level on at least 99.9 % of rows (the missed probability);
    /// the levels are finite and none of them is vacuous (below 10 × the fault-free error's
    /// 99.9 % point at the median row).
    #[test]
    fn errors_stay_below_the_protection_levels_with_a_fault_of_any_size() {
        let arr = layout();
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let mut est = Estimator::<f64, 24>::new(&arr, Model::General, raw()).unwrap();
        // A steady spin-up (Ω′ constant: Ω moves by 0.4 rad/s over the run), so that the sign
        // is settled by the motion.
        let (s0, dw, w0) = ([0.3, -9.8, 1.0], [0.02, 0.01, -0.01], [1.0, -0.5, 2.0]);
        let rows = 20_000;
        let mut above = [0usize; 3];
        let mut ratio: [Vec<f64>; 3] = Default::default();
        for k in 0..rows {
            let t = k as f64 * 0.01;
            let w = [0, 1, 2].map(|i| w0[i] + dw[i] * t);
            let mut p = readings(&arr, s0, dw, w);
            let truth = [s0, dw, w];
            for x in p.iter_mut() {
                let (u1, u2): (f64, f64) = (rng.gen_range(1e-12..1.0), rng.gen());
                *x += 1e-3 * (-2.0 * u1.ln()).sqrt() * (2.0 * core::f64::consts::PI * u2).cos();
            }
            let part = rng.gen_range(0..6);
            let size = 1e-3 * rng.gen_range(0.0..30.0);
            for a in 0..3 {
                p[3 * part + a] += size * rng.gen_range(-1.0..1.0);
            }
            let e = *est.update(t, &p);
            assert!(!e.flags.has(crate::Flags::SIGN_UNRESOLVED), "row {k}");
            let pl = e.protection.expect("a bound with six degrees of freedom");
            let out = [e.sigma0, e.domega, e.omega];
            for q in 0..3 {
                assert!(pl[q].is_finite() && pl[q] > 0.0);
                let err = dist(&out[q], &truth[q]);
                above[q] += usize::from(err > pl[q]);
                ratio[q].push(err / pl[q]);
            }
        }
        for q in 0..3 {
            assert!(
                above[q] * 1000 <= rows,
                "output {q}: {} rows above",
                above[q]
            );
            ratio[q].sort_by(f64::total_cmp);
            let median = ratio[q][rows / 2];
            assert!(median > 0.02, "output {q}: median error / level {median}");
        }
    }

    /// No bound without redundancy (12 channels in model G, 9 in model F), or with a part of
    /// more channels than its parity space can test (thirteen channels: one degree of freedom,
    /// a tri-axial part); fifteen channels each a part of its own have one, and so has model F
    /// on ten or more.
    #[test]
    fn there_is_no_bound_without_redundancy() {
        let arr = layout();
        assert!(Integrity::<f32, 24>::build(&arr, ChannelMask::all(12), 1e-3).is_none());
        assert!(Integrity::<f32, 24>::build(&arr, ChannelMask::all(13), 1e-3).is_none());
        let mut singles = arr.clone();
        singles.set_parts(&[NO_PART; 18]);
        assert!(Integrity::<f32, 24>::build(&singles, ChannelMask::all(15), 1e-3).is_some());
        assert!(FreeFloatIntegrity::<f32, 24>::build(&arr, ChannelMask::all(9), 1e-3).is_none());
        assert!(FreeFloatIntegrity::<f32, 24>::build(&arr, ChannelMask::all(12), 1e-3).is_some());
        assert!(FreeFloatIntegrity::<f32, 24>::build(&arr, ChannelMask::all(18), 1e-3).is_some());
    }

    /// An alert limit below the protection level sets the alert flag; one above it does not;
    /// a finite limit where there is no bound alerts too.
    #[test]
    fn an_alert_limit_below_the_level_raises_the_alert() {
        let arr = layout();
        let clean = readings(&arr, [0.0, 0.0, 9.8], [0.1; 3], [1.0, -0.5, 2.0]);
        let run = |limits: [f64; 3], model| {
            let options = Options {
                alert_limits: limits,
                ..raw()
            };
            let mut est = Estimator::<f64, 24>::new(&arr, model, options).unwrap();
            *est.update(0.0, &clean)
        };
        for model in [Model::General, Model::FreeFloat] {
            let e = run([f64::INFINITY; 3], model);
            let pl = e.protection.unwrap();
            assert!(!e.flags.has(crate::Flags::INTEGRITY_ALERT));
            for q in 0..3 {
                let mut limits = [f64::INFINITY; 3];
                limits[q] = 0.5 * pl[q];
                assert!(run(limits, model).flags.has(crate::Flags::INTEGRITY_ALERT));
                limits[q] = 2.0 * pl[q];
                assert!(!run(limits, model).flags.has(crate::Flags::INTEGRITY_ALERT));
            }
        }
        // Twelve channels in model G: no level, so a finite limit alerts.
        let mut twelve = Arrangement::<24>::new();
        for ch in &arr.channels()[..12] {
            twelve.push(ch.position, ch.axis, ch.noise).unwrap();
        }
        let options = Options {
            alert_limits: [1.0; 3],
            ..raw()
        };
        let mut g = Estimator::<f64, 24>::new(&twelve, Model::General, options).unwrap();
        let e = *g.update(0.0, &clean[..12]);
        assert!(e.protection.is_none() && e.flags.has(crate::Flags::INTEGRITY_ALERT));
        let bad = Options {
            missed: 1.5,
            ..raw()
        };
        assert!(Estimator::<f64, 24>::new(&arr, Model::General, bad).is_err());
    }
}
