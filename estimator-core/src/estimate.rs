//! What the estimator produces for each sample set.

use crate::linalg::{Sym3, Vec3};
use crate::real::Real;

/// Status bits of an [`Estimate`] (the `flags` column of `estimates.csv`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Flags(pub u16);

impl Flags {
    /// The sign of Ω is not yet settled (steady spin, no hint): Ω may be −Ω.
    pub const SIGN_UNRESOLVED: u16 = 1 << 0;
    /// No real solution for `a`: least-squares fallback used.
    pub const FALLBACK: u16 = 1 << 1;
    /// Ill-conditioned: the `a` solve (its Jacobian) or the frame decomposition is nearly
    /// singular; typically a rate near zero or along a frame plane.
    pub const ILL_CONDITIONED: u16 = 1 << 2;
    /// One or more channels excluded from the solve.
    pub const CHANNELS_EXCLUDED: u16 = 1 << 3;
    /// Another branch (solution of the quadratic forms) is still nearly as consistent as the
    /// chosen one.
    pub const BRANCH_AMBIGUOUS: u16 = 1 << 4;
    /// The sample had a non-finite reading: the output is the prediction, not a measurement.
    pub const INPUT_INVALID: u16 = 1 << 5;
    /// Whitened residual χ² above the 99.99 % point for its degrees of freedom ([`chi2_9999`]), or
    /// the fault monitor's window inconsistent with no part isolated (fault suspected).
    pub const RESIDUAL_HIGH: u16 = 1 << 6;
    /// A reading no accelerometer can give (beyond twice its part's full scale, or 10⁴ m/s²
    /// where none is declared): treated as missing, so [`Flags::INPUT_INVALID`] is set too.
    /// Set by the ground tool's reader (`ballisto estimate`), which checks the file's readings.
    pub const INPUT_ABSURD: u16 = 1 << 7;
    /// A protection level above its configured alert limit, or no protection level where an
    /// alert limit is configured ([`crate::Options::alert_limits`]): the output is not assured
    /// to the accuracy asked for.
    pub const INTEGRITY_ALERT: u16 = 1 << 8;
    /// The configuration gives protection levels (it has redundancy) but this solved row has
    /// none: a part checked too poorly for the estimator's precision to bound its fault, or
    /// model F with Ω exactly zero (its first order vanishes; near rest the level is a bound
    /// as large as Ω's deviation). A prediction ([`Flags::INPUT_INVALID`]) has
    /// none either and is flagged as such. A configuration without redundancy gives none on
    /// any row and does not set this: its telemetry's consistency test says so.
    pub const NO_PROTECTION_LEVEL: u16 = 1 << 9;

    /// True if `bit` is set.
    pub const fn has(self, bit: u16) -> bool {
        self.0 & bit != 0
    }
}

/// One estimate: the field at the instrument origin and the solver's internals.
#[derive(Clone, Copy, Debug, Default)]
pub struct Estimate<T> {
    /// Specific force at the origin σ(0), m/s² (body frame).
    pub sigma0: Vec3<T>,
    /// Angular acceleration Ω′, rad/s² (body frame).
    pub domega: Vec3<T>,
    /// Angular rate Ω, rad/s (body frame; sign per [`Flags::SIGN_UNRESOLVED`]).
    pub omega: Vec3<T>,
    /// Field matrix `A = Γ + {Ω}²`, s⁻² (body frame).
    pub field: Sym3<T>,
    /// The vector `a` of the decomposition `A = ε{a}² + diag(d)` (frame coordinates).
    pub a: Vec3<T>,
    /// The diagonal `d` (frame coordinates; zero in model F).
    pub d: Vec3<T>,
    /// Index of the frame `V` used.
    pub frame: u8,
    /// `ε = ±1`.
    pub epsilon: i8,
    /// Status bits.
    pub flags: Flags,
    /// Whitened residual `|r|²`.
    pub chi2: T,
    /// Degrees of freedom of `chi2` (N − 12 in model G, N − 9 in model F).
    pub dof: u8,
    /// Number of real branches of the `a` solve at this sample.
    pub branches: u8,
    /// Standard deviations of σ0 (first order).
    pub sd_sigma0: Vec3<T>,
    /// Standard deviations of Ω′.
    pub sd_domega: Vec3<T>,
    /// Standard deviations of Ω.
    pub sd_omega: Vec3<T>,
    /// Standard deviations of the components of A (`[xx, yy, zz, xy, xz, yz]`).
    pub sd_field: Sym3<T>,
    /// The branch tracker's cost margin of the best competing branch over the chosen one
    /// (twice the negative log-likelihood ratio of its hypothesis; below 16, the sign margin,
    /// [`Flags::BRANCH_AMBIGUOUS`] is set); 200, the tracker's memory, when no other branch
    /// is left in it.
    pub branch_margin: T,
    /// Protection levels `[σ0 (m/s²), Ω′ (rad/s²), Ω (rad/s)]`: each output's error (vector
    /// norm) is below its level but with the configured missed probability, whatever fault one
    /// part has ([`crate::integrity`]); `None` where no bound exists (no redundancy, model F).
    pub protection: Option<[T; 3]>,
}

/// 99.9 % points of χ² for 1..=30 degrees of freedom (beyond: Wilson–Hilferty).
pub fn chi2_999(dof: usize) -> f64 {
    const TABLE: [f64; 30] = [
        10.83, 13.82, 16.27, 18.47, 20.52, 22.46, 24.32, 26.12, 27.88, 29.59, 31.26, 32.91, 34.53,
        36.12, 37.70, 39.25, 40.79, 42.31, 43.82, 45.31, 46.80, 48.27, 49.73, 51.18, 52.62, 54.05,
        55.48, 56.89, 58.30, 59.70,
    ];
    chi2_point(dof, &TABLE, 3.090)
}

/// 99.99 % points of χ² for 1..=30 degrees of freedom (beyond: Wilson–Hilferty): the
/// per-sample point of [`Flags::RESIDUAL_HIGH`]. At 99.9 % that test alone would spend the
/// whole false-alarm budget of 0.1 % of rows, and the readings' systematic misfit
/// (interpolation, quantisation) takes it above: 0.118 % of the fault-free rows of the N = 18
/// fault matrix were flagged by it. (Computed by the regularised incomplete gamma function;
/// the same routine reproduces [`chi2_999`]'s table to the digit.)
pub fn chi2_9999(dof: usize) -> f64 {
    const TABLE: [f64; 30] = [
        15.14, 18.42, 21.11, 23.51, 25.74, 27.86, 29.88, 31.83, 33.72, 35.56, 37.37, 39.13, 40.87,
        42.58, 44.26, 45.92, 47.57, 49.19, 50.80, 52.39, 53.96, 55.52, 57.07, 58.61, 60.14, 61.66,
        63.16, 64.66, 66.15, 67.63,
    ];
    chi2_point(dof, &TABLE, 3.719)
}

/// `table[dof − 1]`, infinite for 0, and beyond the table Wilson–Hilferty at the upper normal
/// point `z` ([`crate::fault_monitor::chi2_quantile`]).
fn chi2_point(dof: usize, table: &[f64; 30], z: f64) -> f64 {
    if dof == 0 {
        return f64::INFINITY;
    }
    if dof <= table.len() {
        return table[dof - 1];
    }
    crate::fault_monitor::chi2_quantile(dof as f64, z)
}

impl<T: Real> Estimate<T> {
    /// Model G's gravity gradient `Γ = A − {Ω}²` (paper eq. 12; body frame, s⁻²) and its
    /// first-order standard deviations, taking the errors of `A` and of `{Ω}²` as independent
    /// (Ω comes partly from `A`, so the true deviation is no larger). Under model F, `A` is
    /// built as `Γ + {Ω}²` from the Γ given to the estimator, and this returns that Γ.
    pub fn gravity_gradient(&self) -> (Sym3<T>, Sym3<T>) {
        let gamma = self
            .field
            .add_scaled(-T::ONE, &Sym3::skew_squared(&self.omega));
        let [x, y, z] = self.sd_omega;
        let cov = Sym3([x * x, y * y, z * z, T::ZERO, T::ZERO, T::ZERO]);
        let rate = crate::linalg::skew_squared_sd(&self.omega, &cov);
        let mut sd = Sym3([T::ZERO; 6]);
        for ((s, a), w) in
            sd.0.iter_mut()
                .zip(self.sd_field.0.iter())
                .zip(rate.0.iter())
        {
            *s = (*a * *a + *w * *w).sqrt();
        }
        (gamma, sd)
    }

    /// True if no component is NaN or infinite (the estimator guarantees this).
    pub fn is_finite(&self) -> bool {
        // x·0 is ±0 for finite x and NaN otherwise: one test for all components.
        let mut acc = T::ZERO;
        let mut add = |x: &[T]| {
            for v in x {
                acc += *v * T::ZERO;
            }
        };
        add(&self.sigma0);
        add(&self.domega);
        add(&self.omega);
        add(&self.field.0);
        add(&self.a);
        add(&self.d);
        add(&[self.chi2, self.branch_margin]);
        add(&self.sd_sigma0);
        add(&self.sd_domega);
        add(&self.sd_omega);
        add(&self.sd_field.0);
        acc == T::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::{chi2_999, chi2_9999, Estimate};

    /// The table and the Wilson–Hilferty continuation against published 99.9 % points
    /// (Abramowitz & Stegun table 26.8): 40 → 73.402, 50 → 86.661, 100 → 149.449.
    #[test]
    fn chi2_points_match_the_published_table() {
        assert_eq!(chi2_999(0), f64::INFINITY);
        assert_eq!(chi2_999(1), 10.83);
        assert_eq!(chi2_999(30), 59.70);
        for (dof, published) in [(40, 73.402), (50, 86.661), (100, 149.449)] {
            let x = chi2_999(dof);
            assert!(
                (x - published).abs() < 0.01 * published,
                "dof {dof}: {x} vs {published}"
            );
        }
        // Monotone across the table's end.
        assert!(chi2_999(31) > chi2_999(30));
        // 99.99 %: 40 → 82.062, 100 → 161.319 (the same routine as the table).
        assert_eq!(chi2_9999(0), f64::INFINITY);
        for (dof, published) in [(40, 82.062), (100, 161.319)] {
            let x = chi2_9999(dof);
            assert!(
                (x - published).abs() < 0.01 * published,
                "dof {dof}: {x} vs {published}"
            );
        }
        assert!(chi2_9999(31) > chi2_9999(30));
        assert!((1..60).all(|k| chi2_9999(k) > chi2_999(k)));
    }

    #[test]
    fn estimate_finiteness_sees_every_component() {
        let e = Estimate::<f32>::default();
        assert!(e.is_finite());
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let mut x = e;
            x.sd_field.0[5] = bad;
            assert!(!x.is_finite());
            let mut x = e;
            x.sigma0[0] = bad;
            assert!(!x.is_finite());
            let mut x = e;
            x.chi2 = bad;
            assert!(!x.is_finite());
        }
    }
}
