//! Branch crossings (model F): where two branches of the quadratic forms come within a few
//! deviations of each other, the first-order covariance of each is invalid, and the output's
//! deviations are widened to cover it.
//!
//! Where two branches cross, the forms have a double root; noise splits it into two roots
//! `±h` about their mean, with `h ~ √e` for a perturbation `e` of the forms (or into a complex
//! pair: the least-squares fallback). The Jacobian at a split root then gives a deviation `s`
//! along the separation with `h / s ≈ 2 |e| / σ_e`: at a crossing the observed half separation
//! is only a few first-order deviations (`h / s` ≤ [`CROSSING_RHO`] with 99.9 %), the truth may
//! be anywhere between the two roots, and the sample cannot say which root it is. Each root's
//! `cov(a)` is widened along the separation by `w(ρ) (d/2)(d/2)ᵀ`, with `d` the difference to
//! the nearest other root (either sign), `ρ = h / s` and `w = 1 / (1 + (ρ / CROSSING_RHO)⁸)`:
//! 1/2 at the 99.9 % point, 3.6 % at ρ = 10; the variance along `d` grows by the factor
//! `1 + w ρ²`: ×4.6 at ρ = 10, ×1.014 at ρ = 25; beyond ρ = 37 (w < 1e-6) nothing is added.
//! Through `cov(a)` the widening reaches the deviations of Ω and, in proportion to their
//! dependence on `a`, of σ0 and Ω′.
//!
//! Measured (the `nine_lock` probe (removed; in the git history under `tests/examples/`), the nine-channel family of issue 15, 10 s, seeds
//! 1–4): at 1 kHz the chosen root was more than 5 first-order deviations off on 1.1 % of the
//! rows, all with another root within 25 deviations, where the truth-nearest root's own error
//! was 2–3× its first-order deviation; with the widening 0.003 %. Only the output's deviations
//! are widened: the tracker keeps the first-order variances. Fed to the tracker as well, the
//! widening raised the 1 kHz Ω RMS (tumble 0.075 → 0.081 rad/s; 5 cm arm, manoeuvre
//! 0.137 → 0.174) and doubled the rows flagged ambiguous (6.5 → 13.6 %).

use super::Branch;
use crate::estimate::Estimate;
use crate::linalg::{norm2, sub, Vec3};
use crate::real::Real;
use crate::tracker::MAX_CANDIDATES;

/// The 99.9 % point of `h / s` at a crossing: `2 × 3.29`.
pub const CROSSING_RHO: f64 = 6.6;

/// Widens each branch's `cov(a)` along the separation to its nearest other branch (model F,
/// `Ω = a`; see the module documentation).
///
/// Returns whether any branch was widened (a weight above 1e-6, ρ below 37; beyond, the
/// factor `1 + w ρ²` is below 1.0014 and nothing is added).
pub(super) fn widen_near_crossings<T: Real>(branches: &mut [Branch<T>]) -> bool {
    let n = branches.len().min(MAX_CANDIDATES);
    for b in branches.iter_mut() {
        b.widening = [T::ZERO; 3];
    }
    let mut any = false;
    if n < 2 {
        return any;
    }
    // The nearest other root of each, either sign: squared distance and difference.
    let mut near = [(T::of(1e30), [T::ZERO; 3]); MAX_CANDIDATES];
    for i in 0..n {
        for j in (i + 1)..n {
            let (ai, aj) = (&branches[i].a, &branches[j].a);
            let dm = sub(ai, aj);
            let dp = [ai[0] + aj[0], ai[1] + aj[1], ai[2] + aj[2]];
            let (m2, p2) = (norm2(&dm), norm2(&dp));
            let nd = if m2 <= p2 { (m2, dm) } else { (p2, dp) };
            if nd.0 < near[i].0 {
                near[i] = nd;
            }
            if nd.0 < near[j].0 {
                near[j] = nd;
            }
        }
    }
    let k2 = CROSSING_RHO * CROSSING_RHO;
    let k8 = T::of(k2 * k2 * k2 * k2);
    for (b, (d2, d)) in branches.iter_mut().zip(near.iter()).take(n) {
        // ρ² = h² / s² with h² = |d|² / 4 and s² = dᵀ cov d / |d|².
        let q = b.cov_a.quad(d).max(T::of(1e-30));
        let rho2 = T::of(0.25) * *d2 * *d2 / q;
        let r4 = rho2 * rho2;
        let w = k8 / (k8 + r4 * r4);
        if w > T::of(1e-6) {
            let k = T::of(0.25) * w;
            b.cov_a.add_outer_scaled(k, d);
            b.widening = [k * d[0] * d[0], k * d[1] * d[1], k * d[2] * d[2]];
            any = true;
        }
    }
    any
}

/// The filtered output near and after a crossing. The rate filter's variance assumes its
/// measurements' errors independent; near a crossing the root each hypothesis takes is the one
/// nearest its own prediction, so the errors it takes in are biased, by up to the half
/// separation `h`, and alike from sample to sample: the filter drifts, and its variance does
/// not see it (0.2–0.5 rad/s out of a crossing at 1 kHz, 2–3× more than it reported). This
/// carries a bound on that drift as a bias through the filter, per component:
/// `b ← (1 − K) b + K √w h` with `K = P⁺/R` the filter's gain for the chosen root (`P⁺`
/// the filtered variance, `R` the root's first-order one) and
/// `√w h` the root's widening (its deviation added near the crossing; [`widen_near_crossings`]);
/// the amplitudes add (worst case, all biases alike), and the bound decays with the filter's
/// memory once the roots have parted. `b²` is added to the filtered Ω's variance.
///
/// Measured (`nine_lock FILTERED=1`, 20 s): 4 kHz, 1e-2 m/s², 0.12 m: 305 of 80 000 rows
/// silently wrong → 0, Ω error / sd RMS 2.78 → 0.67; 1 kHz manoeuvre 1.39 → 0.73; 100 Hz
/// 0.85 → 0.73 (a bound: conservative where there is little to bound). The widening of the
/// sample alone (instead of `b`) made the firmware path's `nine-channel` case at 1 kHz honest
/// (1 208 → 0 silent) but left 305 on this one.
///
/// Returns whether the bound is still carried (`false` once it has decayed to nothing: the
/// caller then skips this until the next widening).
pub(crate) fn carry_bias<T: Real>(
    bias: &mut Vec3<T>,
    (posterior, r): (T, T),
    widening: &Vec3<T>,
    est: &mut Estimate<T>,
) -> bool {
    let zero = T::ZERO;
    let mut active = false;
    let k = (posterior / r.max(T::of(1e-30))).max(zero).min(T::ONE);
    for ((b, w), sd) in bias
        .iter_mut()
        .zip(widening.iter())
        .zip(est.sd_omega.iter_mut())
    {
        *b = (T::ONE - k) * *b + k * w.max(zero).sqrt();
        // Dropped where its square is below 1e-4 of the filtered variance.
        if *b * *b < T::of(1e-4) * posterior {
            *b = zero;
        } else {
            active = true;
            *sd = (*sd * *sd + *b * *b).sqrt();
        }
    }
    active
}

/// The smoother's filtered output: the forward path's bias bound of that sample
/// ([`carry_bias`]), or the chosen root's own widening where larger (the smoother may take
/// another hypothesis than the forward path did).
pub(crate) fn widen_smoothed<T: Real>(est: &mut Estimate<T>, bias: &Vec3<T>, widening: &Vec3<T>) {
    for ((sd, b), w) in est
        .sd_omega
        .iter_mut()
        .zip(bias.iter())
        .zip(widening.iter())
    {
        let extra = (*b * *b).max(*w);
        if extra > T::ZERO {
            *sd = (*sd * *sd + extra).sqrt();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::Sym3;
    use crate::Estimate;

    fn branch(a: Vec3<f64>, sd: f64) -> Branch<f64> {
        let v = sd * sd;
        Branch {
            a,
            cov_a: Sym3([v, v, v, 0.0, 0.0, 0.0]),
            ..Default::default()
        }
    }

    /// Variance of `b`'s `cov(a)` along `u` (unit).
    fn along(b: &Branch<f64>, u: &Vec3<f64>) -> f64 {
        b.cov_a.quad(u)
    }

    /// Two roots a few deviations apart are widened by about `(d/2)²` along the separation
    /// and not across it; roots far apart (or one root alone) keep their first-order
    /// covariance (beyond ρ = 37 exactly: the weight is below 1e-6 and nothing is added).
    #[test]
    fn widens_along_the_separation_of_near_roots_only() {
        let sd = 0.04;
        // ρ = h / s = 2: the pair is within the 99.9 % of a crossing.
        let mut near = [branch([1.0, 0.0, 0.0], sd), branch([1.16, 0.0, 0.0], sd)];
        assert!(widen_near_crossings(&mut near));
        let h2 = 0.08f64 * 0.08;
        for b in &near {
            let v = along(b, &[1.0, 0.0, 0.0]);
            assert!((v - sd * sd - h2).abs() < 0.01 * h2, "{v}");
            assert!((along(b, &[0.0, 1.0, 0.0]) - sd * sd).abs() < 1e-15);
        }
        // The other sign of a root is the same root: −a counts as near.
        let mut mirrored = [branch([1.0, 0.0, 0.0], sd), branch([-1.16, 0.0, 0.0], sd)];
        widen_near_crossings(&mut mirrored);
        assert!(along(&mirrored[0], &[1.0, 0.0, 0.0]) > sd * sd + 0.9 * h2);
        // ρ = 50: untouched, and reported so.
        let mut far = [branch([1.0, 0.0, 0.0], sd), branch([1.0, 4.0, 0.0], sd)];
        assert!(!widen_near_crossings(&mut far));
        for b in &far {
            assert_eq!(b.cov_a.0, branch([1.0, 0.0, 0.0], sd).cov_a.0);
            assert_eq!(b.widening, [0.0; 3]);
        }
        let mut alone = [branch([1.0, 0.0, 0.0], sd)];
        widen_near_crossings(&mut alone);
        assert_eq!(alone[0].cov_a.0, branch([1.0, 0.0, 0.0], sd).cov_a.0);
    }

    /// The weight is 1/2 at ρ = CROSSING_RHO and falls as ρ⁻⁸ beyond; each root is widened
    /// toward its nearest neighbour, not a farther one.
    #[test]
    fn weight_and_nearest_neighbour() {
        let sd = 0.01;
        let h = CROSSING_RHO * sd;
        let mut pair = [
            branch([0.0, 0.0, 1.0], sd),
            branch([0.0, 0.0, 1.0 + 2.0 * h], sd),
            branch([0.0, 3.0, 1.0], sd),
        ];
        widen_near_crossings(&mut pair);
        let z = along(&pair[0], &[0.0, 0.0, 1.0]);
        assert!((z - sd * sd - 0.5 * h * h).abs() < 1e-9 * h * h, "{z}");
        assert!((along(&pair[0], &[0.0, 1.0, 0.0]) - sd * sd).abs() < 1e-15);
        // The third root's nearest is 3 away (ρ = 150): untouched (3e-7 relative).
        assert!((along(&pair[2], &[0.0, 1.0, 0.0]) / (sd * sd) - 1.0).abs() < 1e-6);
    }

    /// The drift bound: under a steady widening it tends to the widening's deviation (the gain
    /// sets how fast), it widens the filtered deviation by itself, and once the roots have
    /// parted it decays with the filter's memory, `(1 − K)` per sample, until it is dropped.
    #[test]
    fn the_bias_bound_builds_up_decays_and_is_dropped() {
        let (posterior, r) = (1e-4, 1e-3); // K = 0.1
        let widening = [0.04, 0.0, 0.01]; // deviations 0.2 and 0.1 along x and z
        let mut bias = [0.0; 3];
        let mut est = Estimate::<f64>::default();
        for _ in 0..200 {
            est.sd_omega = [0.01; 3];
            assert!(carry_bias(&mut bias, (posterior, r), &widening, &mut est));
        }
        assert!(
            (bias[0] - 0.2).abs() < 1e-6 && (bias[2] - 0.1).abs() < 1e-6,
            "{bias:?}"
        );
        assert_eq!(bias[1], 0.0);
        assert!((est.sd_omega[0] - (1e-4f64 + 0.04).sqrt()).abs() < 1e-9);
        assert_eq!(est.sd_omega[1], 0.01);
        // The roots part: 0.9ⁿ decay; dropped once b² < 1e-4 P⁺ (b < 1e-4), after
        // ln(0.2 / 1e-4) / ln(1/0.9) ≈ 72 samples.
        let mut n = 0;
        while carry_bias(&mut bias, (posterior, r), &[0.0; 3], &mut est) {
            n += 1;
            assert!(n < 100, "never dropped: {bias:?}");
        }
        assert!((65..=80).contains(&n), "{n}");
        assert_eq!(bias, [0.0; 3]);
    }

    /// Coincident roots (d = 0) and a zero covariance give finite covariances, never NaN.
    #[test]
    fn degenerate_inputs_stay_finite() {
        let mut same = [branch([1.0, 2.0, 3.0], 0.0), branch([1.0, 2.0, 3.0], 0.0)];
        widen_near_crossings(&mut same);
        let mut zero = [branch([1.0, 2.0, 3.0], 0.0), branch([1.0, 2.0, 3.1], 0.0)];
        widen_near_crossings(&mut zero);
        for b in same.iter().chain(zero.iter()) {
            assert!(b.cov_a.0.iter().all(|v| v.is_finite()), "{:?}", b.cov_a);
        }
    }
}
