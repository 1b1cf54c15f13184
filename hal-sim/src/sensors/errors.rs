//! The error model every simulated part applies to the true specific force, and its own clock.
//! Bias and scale move with the part's temperature ([`super::thermal`]).

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use super::thermal::PartThermal;

/// Standard gravity, m/s² (estimator-core's).
pub use estimator_core::G0;

/// Errors of one part: `out = S (C f) + b + n`, sampled at its own clock.
#[derive(Clone, Debug)]
pub struct SensorErrors {
    /// Scale factor per axis (1 = exact).
    pub scale: [f64; 3],
    /// Bias per axis (m/s²).
    pub bias: [f64; 3],
    /// Cross-axis sensitivity: `C = I + cross` (off-diagonal terms; the diagonal is ignored).
    pub cross: [[f64; 3]; 3],
    /// White-noise density (m/s²/√Hz); the noise per sample follows the ODR through the
    /// part's bandwidth.
    pub noise_density: f64,
    /// Offset of the part's clock from nominal (ppm): its ODR is `nominal · (1 + ppm·10⁻⁶)`.
    pub clock_ppm: f64,
    /// Standard deviation of the jitter of each sample instant (s).
    pub jitter: f64,
    /// Seed of this part's noise.
    pub seed: u64,
    /// Its temperature and temperature coefficients (default: 25 °C, none).
    pub thermal: PartThermal,
}

impl Default for SensorErrors {
    /// An ideal part: no scale, bias, cross-axis or noise, exact clock.
    fn default() -> Self {
        SensorErrors {
            scale: [1.0; 3],
            bias: [0.0; 3],
            cross: [[0.0; 3]; 3],
            noise_density: 0.0,
            clock_ppm: 0.0,
            jitter: 0.0,
            seed: 1,
            thermal: PartThermal::default(),
        }
    }
}

impl SensorErrors {
    /// The measured specific force for the true `f` at time `t` (the part's temperature then
    /// moves its bias and scale) with noise of standard deviation `sd`.
    pub fn apply(&self, f: &[f64; 3], t: f64, sd: f64, rng: &mut ChaCha8Rng) -> [f64; 3] {
        let mut out = [0.0; 3];
        let die = self.thermal.die(t);
        for (i, o) in out.iter_mut().enumerate() {
            let mut c = f[i];
            for (j, fj) in f.iter().enumerate() {
                if j != i {
                    c += self.cross[i][j] * fj;
                }
            }
            let n = if sd > 0.0 {
                sd * rng.sample::<f64, _>(StandardNormal)
            } else {
                0.0
            };
            let (bias, scale) = self.thermal.at(die, i, self.bias[i], self.scale[i]);
            *o = scale * c + bias + n;
        }
        out
    }

    /// The jitter of one sample instant (s).
    pub fn jitter_sample(&self, rng: &mut ChaCha8Rng) -> f64 {
        if self.jitter > 0.0 {
            self.jitter * rng.sample::<f64, _>(StandardNormal)
        } else {
            0.0
        }
    }
}
