//! Temporal fusion of the rate (estimator.md, "Fusion"): a Kalman filter with state Ω,
//! predicted with the measured Ω′ (trapezoidal rule) and updated with the algebraic Ω of the
//! tracked branch. Per component (the cross-covariances are ignored), so it costs a few dozen
//! operations. At low rates the algebraic Ω is noisy and the filter leans on ∫Ω′; at high
//! rates it follows the algebraic Ω.

use crate::linalg::Vec3;
use crate::real::Real;

/// Innovation gate (in standard deviations²) beyond which the filter restarts from the
/// measurement (branch or sign switch by the tracker).
const GATE: f64 = 36.0;

/// Per-component Kalman filter on Ω.
#[derive(Clone, Copy, Debug, Default)]
pub struct RateFilter<T> {
    omega: Vec3<T>,
    var: Vec3<T>,
    domega: Vec3<T>,
    active: bool,
}

impl<T: Real> RateFilter<T> {
    /// A filter with no state.
    pub fn new() -> Self {
        RateFilter {
            omega: [T::ZERO; 3],
            var: [T::ZERO; 3],
            domega: [T::ZERO; 3],
            active: false,
        }
    }

    /// Forgets the state.
    pub fn reset(&mut self) {
        self.active = false;
    }

    /// One step. `z`, `z_var`: the algebraic Ω and its variances; `domega`, `domega_var`: this
    /// sample's Ω′; `model_var`: variance of the trapezoidal model error per step. Returns the
    /// filtered Ω and its variances.
    pub fn update(
        &mut self,
        dt: T,
        z: &Vec3<T>,
        z_var: &Vec3<T>,
        domega: &Vec3<T>,
        domega_var: &Vec3<T>,
        model_var: T,
    ) -> (Vec3<T>, Vec3<T>) {
        if !self.active {
            self.omega = *z;
            self.var = *z_var;
            self.domega = *domega;
            self.active = true;
            return (self.omega, self.var);
        }
        let half_dt = T::of(0.5) * dt;
        let mut restart = false;
        let mut pred = [T::ZERO; 3];
        let mut pvar = [T::ZERO; 3];
        for k in 0..3 {
            pred[k] = self.omega[k] + half_dt * (self.domega[k] + domega[k]);
            pvar[k] = self.var[k] + half_dt * half_dt * T::of(2.0) * domega_var[k] + model_var;
            let innov = z[k] - pred[k];
            if innov * innov > T::of(GATE) * (pvar[k] + z_var[k]) {
                restart = true;
            }
        }
        if restart {
            self.omega = *z;
            self.var = *z_var;
        } else {
            for k in 0..3 {
                let s = pvar[k] + z_var[k];
                let gain = if s > T::ZERO { pvar[k] / s } else { T::ONE };
                self.omega[k] = pred[k] + gain * (z[k] - pred[k]);
                self.var[k] = (T::ONE - gain) * pvar[k];
            }
        }
        self.domega = *domega;
        (self.omega, self.var)
    }
}
