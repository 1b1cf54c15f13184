//! Normal and χ² quantiles for the monitor's limits.

use crate::real::Real;

/// The upper-tail standard normal quantile `z` with `P(Z > z) = alpha` (Abramowitz & Stegun
/// 26.2.23, error below 4.5·10⁻⁴), for `0 < alpha ≤ 0.5`; clamped outside.
pub fn upper_normal_quantile(alpha: f64) -> f64 {
    let p = if alpha.is_finite() {
        alpha.clamp(1e-300, 0.5)
    } else {
        0.5
    };
    let t = Real::sqrt(-2.0 * libm::log(p));
    let (c0, c1, c2) = (2.515517, 0.802853, 0.010328);
    let (d1, d2, d3) = (1.432788, 0.189269, 0.001308);
    t - (c0 + c1 * t + c2 * t * t) / (1.0 + d1 * t + d2 * t * t + d3 * t * t * t)
}

/// The point of χ² with `dof` degrees of freedom (not necessarily whole) exceeded with the
/// upper-tail normal quantile `z` (Wilson–Hilferty).
pub fn chi2_quantile(dof: f64, z: f64) -> f64 {
    let h = 2.0 / (9.0 * dof);
    let c = 1.0 - h + z * Real::sqrt(h);
    dof * c * c * c
}
