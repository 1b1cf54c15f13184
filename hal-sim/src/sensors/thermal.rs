//! A part's temperature: the temperature of its surroundings (a scenario's
//! `[temperature]`: constant, a ramp of a ground thermal test, or an orbit's cycle), followed
//! by the die with the part's own first-order lag, and what that temperature does to the
//! part's bias and sensitivity (its temperature coefficients, referred to 25 °C as datasheets
//! give them).
//!
//! The lagged temperature is the exact solution of `τ·dT/dt = T_env − T` from a steady start,
//! in closed form for each profile: a read at any instant, in any order, gives the same value
//! (the parts are read out of time order: FIFO samples before the register reads of a set).

use serde::Deserialize;

/// The temperature datasheets give the coefficients at (°C).
pub const DATASHEET_REFERENCE_C: f64 = 25.0;

/// The surroundings' temperature over time (°C): a scenario's `[temperature]` table.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Surroundings {
    /// Constant.
    Constant {
        /// °C.
        value: f64,
    },
    /// A thermal chamber's ramp: `from` until `start`, linear to `to` over `duration` s, then
    /// `to`.
    Ramp {
        /// °C before the ramp.
        from: f64,
        /// °C after it.
        to: f64,
        /// When it starts (s).
        #[serde(default)]
        start: f64,
        /// How long it takes (s, > 0).
        duration: f64,
    },
    /// An orbit's cycle: `mean + amplitude·sin(2π t / period + phase)`.
    Orbit {
        /// °C.
        mean: f64,
        /// °C.
        amplitude: f64,
        /// s (a 400 km orbit: about 5 550 s).
        period: f64,
        /// rad.
        #[serde(default)]
        phase: f64,
    },
}

impl Default for Surroundings {
    /// The datasheets' 25 °C: the coefficients then do nothing.
    fn default() -> Self {
        Surroundings::Constant {
            value: DATASHEET_REFERENCE_C,
        }
    }
}

impl Surroundings {
    /// What is wrong with it, if anything.
    pub fn check(&self) -> Result<(), String> {
        let plausible = |t: f64| estimator_core::thermal::plausible(t);
        match *self {
            Surroundings::Constant { value } if plausible(value) => Ok(()),
            Surroundings::Ramp {
                from,
                to,
                start,
                duration,
            } if plausible(from)
                && plausible(to)
                && start.is_finite()
                && duration.is_finite()
                && duration > 0.0 =>
            {
                Ok(())
            }
            Surroundings::Orbit {
                mean,
                amplitude,
                period,
                phase,
            } if plausible(mean - amplitude.abs())
                && plausible(mean + amplitude.abs())
                && period.is_finite()
                && period > 0.0
                && phase.is_finite() =>
            {
                Ok(())
            }
            _ => Err(format!(
                "temperature: {self:?}: temperatures must lie in [{}, {}] °C, durations and periods be positive",
                estimator_core::thermal::PLAUSIBLE_C.0,
                estimator_core::thermal::PLAUSIBLE_C.1
            )),
        }
    }

    /// The temperature at `t` of a body that follows the surroundings with time constant
    /// `lag` (s, ≥ 0; 0: the surroundings' own), started in equilibrium with them.
    pub fn lagged(&self, t: f64, lag: f64) -> f64 {
        match *self {
            Surroundings::Constant { value } => value,
            Surroundings::Ramp {
                from,
                to,
                start,
                duration,
            } => {
                let slope = (to - from) / duration;
                // The response to a ramp from rest: it trails by `lag·slope`, reached
                // exponentially.
                let during = |u: f64| {
                    if lag > 0.0 {
                        from + slope * (u - lag * (1.0 - (-u / lag).exp()))
                    } else {
                        from + slope * u
                    }
                };
                let u = t - start;
                if u <= 0.0 {
                    from
                } else if u <= duration {
                    during(u)
                } else {
                    let at_end = during(duration);
                    if lag > 0.0 {
                        to + (at_end - to) * (-(u - duration) / lag).exp()
                    } else {
                        to
                    }
                }
            }
            Surroundings::Orbit {
                mean,
                amplitude,
                period,
                phase,
            } => {
                // The steady response to a sine: smaller by 1/√(1 + (ωτ)²), late by
                // atan(ωτ).
                let w = std::f64::consts::TAU / period;
                let wt = w * lag;
                mean + amplitude / (1.0 + wt * wt).sqrt() * (w * t + phase - wt.atan()).sin()
            }
        }
    }
}

/// One part's temperature and what it does: the die follows the surroundings with `lag`; at
/// die temperature `T` each axis's bias is `bias + bias_tc·(T − 25)` and its scale
/// `scale·(1 + scale_tc·(T − 25))`; the part's sensor reads `T + sensor_offset`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PartThermal {
    /// The surroundings.
    pub surroundings: Surroundings,
    /// The die's time constant (s).
    pub lag: f64,
    /// Bias temperature coefficient per axis (m/s² per °C).
    pub bias_tc: [f64; 3],
    /// Sensitivity temperature coefficient per axis (1/°C).
    pub scale_tc: [f64; 3],
    /// What the part's temperature sensor reads above the die's temperature (°C): its
    /// intercept error.
    pub sensor_offset: f64,
}

impl PartThermal {
    /// The die's temperature at `t` (°C).
    pub fn die(&self, t: f64) -> f64 {
        self.surroundings.lagged(t, self.lag)
    }

    /// What the part's temperature sensor sees at `t` (°C, before its quantisation).
    pub fn sensed(&self, t: f64) -> f64 {
        self.die(t) + self.sensor_offset
    }

    /// Bias and scale factor of axis `k` at die temperature `die` ([`Self::die`], computed
    /// once for the three axes of a sample), given those at 25 °C.
    pub fn at(&self, die: f64, k: usize, bias: f64, scale: f64) -> (f64, f64) {
        let dt = die - DATASHEET_REFERENCE_C;
        (
            bias + self.bias_tc[k] * dt,
            scale * (1.0 + self.scale_tc[k] * dt),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed forms solve `τ·dT/dt = T_env − T`: a fine Euler integration agrees.
    #[test]
    fn the_lag_solves_the_first_order_equation() {
        let profiles = [
            Surroundings::Ramp {
                from: -10.0,
                to: 50.0,
                start: 20.0,
                duration: 300.0,
            },
            Surroundings::Orbit {
                mean: 20.0,
                amplitude: 20.0,
                period: 600.0,
                phase: 0.3,
            },
        ];
        let lag = 45.0;
        for s in profiles {
            let h = 1e-3;
            let mut t = 0.0;
            let mut temp = s.lagged(0.0, lag);
            while t < 700.0 {
                temp += h * (s.lagged(t, 0.0) - temp) / lag;
                t += h;
            }
            assert!((temp - s.lagged(t, lag)).abs() < 1e-2, "{s:?}");
        }
        // No lag: the surroundings themselves.
        let r = profiles[0];
        assert_eq!(r.lagged(170.0, 0.0), 20.0);
        assert_eq!(r.lagged(1000.0, 0.0), 50.0);
    }

    #[test]
    fn coefficients_act_from_25_degrees() {
        let p = PartThermal {
            surroundings: Surroundings::Constant { value: 45.0 },
            bias_tc: [1e-3, 0.0, 0.0],
            scale_tc: [0.0, 1e-4, 0.0],
            sensor_offset: -1.5,
            ..Default::default()
        };
        let (b, s) = p.at(p.die(3.0), 0, 0.1, 1.0);
        assert!((b - 0.12).abs() < 1e-12 && s == 1.0);
        let (b, s) = p.at(p.die(3.0), 1, 0.1, 1.0);
        assert!(b == 0.1 && (s - 1.002).abs() < 1e-12);
        assert_eq!(p.sensed(0.0), 43.5);
        assert!(Surroundings::Constant { value: 400.0 }.check().is_err());
    }
}
