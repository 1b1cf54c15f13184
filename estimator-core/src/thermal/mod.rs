//! Temperature compensation of a channel's reading (`docs/formats.md`, "Temperature").
//! A MEMS part's bias and sensitivity move with its temperature: at temperature `T` a channel
//! calibrated at `t_ref` reads
//!
//! ```text
//! p = scale·(1 + scale_tc·(T − t_ref))·(s·f) + bias + bias_tc·(T − t_ref)
//! ```
//!
//! (`s·f` the specific force along its axis, paper eq. 4). The estimator removes `bias` and
//! `scale` from every reading with constants precomputed for its configuration
//! ([`crate::Arrangement::set_calibration`]); [`Thermal::at_reference`] turns a reading taken at
//! `T` into the one the part would have given at `t_ref`, so that the same constants then give
//! `s·f` exactly. Applied before the estimate, to the readings, by whoever knows the
//! temperatures (the ground tool from a samples file's `temp_<channel>` columns).

use core::fmt;

use crate::real::Real;

pub mod track;

pub use track::{Line, Track, MIN_WINDOWS};

/// The least temperature span (°C) from which coefficients are identified, on the ground over a
/// channel's static poses and in flight over the identification windows' mean temperatures
/// ([`track`]): a datasheet-typical 0.15 mg/°C moves the bias by 15 µg over it, about the noise
/// of one 3 s pose of an ADXL355.
pub const MIN_SPAN_C: f64 = 10.0;

/// Temperatures (°C) a part can report: the ADXL355's and LIS3DH's operating ranges are
/// −40…+125 °C; a value outside −100…+200 °C is not a temperature.
pub const PLAUSIBLE_C: (f64, f64) = (-100.0, 200.0);

/// The largest temperature coefficient of a bias accepted (m/s² per °C): 20 × the LIS3DH's
/// datasheet ±0.5 mg/°C.
pub const BIAS_TC_MAX: f64 = 0.1;

/// The largest temperature coefficient of a scale accepted (1/°C): 10 × the LIS3DH's datasheet
/// ±0.01 %/°C; `1 + scale_tc·(T − t_ref)` then stays within (0.7, 1.3) over [`PLAUSIBLE_C`].
pub const SCALE_TC_MAX: f64 = 1e-3;

/// One channel's temperature coefficients.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Thermal {
    /// The temperature the channel's `bias` and `scale` refer to (°C).
    pub t_ref: f64,
    /// The bias's change per °C (m/s² per °C).
    pub bias_tc: f64,
    /// The scale's relative change per °C (1/°C).
    pub scale_tc: f64,
}

/// Why coefficients are refused.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ThermalError {
    /// `t_ref` not finite or outside [`PLAUSIBLE_C`].
    Reference(f64),
    /// `bias_tc` not finite or beyond ±[`BIAS_TC_MAX`].
    BiasCoefficient(f64),
    /// `scale_tc` not finite or beyond ±[`SCALE_TC_MAX`].
    ScaleCoefficient(f64),
}

impl fmt::Display for ThermalError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ThermalError::Reference(t) => write!(
                f,
                "t_ref = {t} °C is not a temperature in [{}, {}]",
                PLAUSIBLE_C.0, PLAUSIBLE_C.1
            ),
            ThermalError::BiasCoefficient(b) => write!(
                f,
                "bias_tc = {b} m/s² per °C must be finite and within ±{BIAS_TC_MAX}"
            ),
            ThermalError::ScaleCoefficient(k) => write!(
                f,
                "scale_tc = {k} per °C must be finite and within ±{SCALE_TC_MAX}"
            ),
        }
    }
}

impl core::error::Error for ThermalError {}

/// Whether `t` (°C) can be a part's temperature.
pub fn plausible(t: f64) -> bool {
    t.is_finite() && (PLAUSIBLE_C.0..=PLAUSIBLE_C.1).contains(&t)
}

impl Thermal {
    /// Validated coefficients.
    pub fn new(t_ref: f64, bias_tc: f64, scale_tc: f64) -> Result<Self, ThermalError> {
        if !plausible(t_ref) {
            return Err(ThermalError::Reference(t_ref));
        }
        if !(bias_tc.is_finite() && bias_tc.abs() <= BIAS_TC_MAX) {
            return Err(ThermalError::BiasCoefficient(bias_tc));
        }
        if !(scale_tc.is_finite() && scale_tc.abs() <= SCALE_TC_MAX) {
            return Err(ThermalError::ScaleCoefficient(scale_tc));
        }
        Ok(Thermal {
            t_ref,
            bias_tc,
            scale_tc,
        })
    }

    /// The reading `p` taken at temperature `t` (°C, [`plausible`]) as the channel would have
    /// given it at `t_ref`, for a channel of bias `bias` (m/s²):
    /// `bias + (p − bias − bias_tc·ΔT) / (1 + scale_tc·ΔT)`, ΔT = `t − t_ref`; then
    /// `(result − bias) / scale` is `(p − bias(T)) / scale(T)`. A missing reading (NaN) stays
    /// missing.
    pub fn at_reference(&self, p: f64, t: f64, bias: f64) -> f64 {
        let (gain, offset) = self.linear(t, bias);
        gain * p + offset
    }

    /// [`Thermal::at_reference`] at temperature `t` as `gain·p + offset`: what the firmware
    /// precomputes once per temperature read, so that a reading costs one multiply-add. In
    /// `R` = f32 on the target (the Cortex-M4F's FPU has no f64), f64 on the ground.
    pub fn linear<R: Real>(&self, t: R, bias: R) -> (R, R) {
        let dt = t - R::of(self.t_ref);
        let gain = R::ONE / (R::ONE + R::of(self.scale_tc) * dt);
        (gain, bias - (bias + R::of(self.bias_tc) * dt) * gain)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reading made with the model above comes back to the part's at `t_ref`, and the
    /// estimator's constants then give the field exactly.
    #[test]
    fn a_reading_at_t_comes_back_to_the_reference() {
        let th = Thermal::new(25.0, 1.5e-3, -1.2e-4).unwrap();
        let (bias, scale, field) = (0.03, 1.004, 0.7);
        for t in [-40.0, 0.0, 25.0, 60.0, 125.0] {
            let dt = t - th.t_ref;
            let p = scale * (1.0 + th.scale_tc * dt) * field + bias + th.bias_tc * dt;
            let back = th.at_reference(p, t, bias);
            assert!(((back - bias) / scale - field).abs() < 1e-12, "{t} °C");
        }
        assert!(th.at_reference(f64::NAN, 40.0, bias).is_nan());
    }

    #[test]
    fn coefficients_beyond_any_part_are_refused_by_name() {
        assert!(matches!(
            Thermal::new(f64::NAN, 0.0, 0.0),
            Err(ThermalError::Reference(_))
        ));
        assert!(matches!(
            Thermal::new(300.0, 0.0, 0.0),
            Err(ThermalError::Reference(_))
        ));
        assert!(matches!(
            Thermal::new(25.0, 0.2, 0.0),
            Err(ThermalError::BiasCoefficient(_))
        ));
        assert!(matches!(
            Thermal::new(25.0, 0.0, 2e-3),
            Err(ThermalError::ScaleCoefficient(_))
        ));
        assert!(!plausible(f64::INFINITY) && !plausible(-150.0) && plausible(-40.0));
    }
}
