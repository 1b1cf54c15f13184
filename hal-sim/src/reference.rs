//! A reference rate sensor (a gyro or a turntable encoder): the true Ω (body frame) plus a
//! constant bias and white noise, at the scenario's rate or a whole fraction of it. Written
//! by `ballisto sim` as `reference.csv` (`t, omega_x, omega_y, omega_z`), the input of
//! `ballisto calibrate --reference`.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use crate::motion::Truth;
use crate::scenario::{ReferenceSpec, Scenario};

/// The reference sensor of a scenario.
pub struct ReferenceSensor {
    bias: [f64; 3],
    /// Per-sample noise, rad/s RMS.
    sd: f64,
    /// Every how many sample sets it outputs.
    every: usize,
    rng: ChaCha8Rng,
}

impl ReferenceSensor {
    /// The scenario's reference sensor, if it has one.
    pub fn of(sc: &Scenario) -> Option<Self> {
        let spec: &ReferenceSpec = sc.reference.as_ref()?;
        let rate = spec.rate.unwrap_or(sc.rate);
        Some(ReferenceSensor {
            bias: spec.bias,
            // White noise over the output's Nyquist band.
            sd: spec.noise_density * (rate / 2.0).sqrt(),
            every: (sc.rate / rate).round().max(1.0) as usize,
            rng: ChaCha8Rng::seed_from_u64(sc.seed ^ 0x5EF_E7E1_CE5E),
        })
    }

    /// The reference's output at sample set `k` (truth `truth`), when it has one there.
    pub fn sample(&mut self, k: usize, truth: &Truth) -> Option<[f64; 3]> {
        k.is_multiple_of(self.every).then(|| {
            core::array::from_fn(|i| {
                truth.omega[i] + self.bias[i] + self.sd * self.rng.sample::<f64, _>(StandardNormal)
            })
        })
    }
}
