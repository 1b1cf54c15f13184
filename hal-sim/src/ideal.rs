//! Ideal channels: each channel's output from the truth by paper eq. (4) plus white noise of its
//! declared `noise`, without a register model (the fixture of the estimator's tests; the
//! register-level record is [`crate::recorder`]).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use crate::motion::Truth;
use ballisto_config::arrangement_file::LoadedArrangement;

/// Simulated channel outputs: truth through paper eq. (4) plus white noise of each channel's
/// `noise` (seeded).
pub fn simulate_outputs(
    loaded: &LoadedArrangement,
    truth: &[Truth],
    noisy: bool,
    seed: u64,
) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    truth
        .iter()
        .map(|tr| {
            loaded
                .arrangement
                .channels()
                .iter()
                .map(|c| {
                    let v = tr.channel(&c.position, &c.axis);
                    if noisy {
                        v + c.noise * rng.sample::<f64, _>(StandardNormal)
                    } else {
                        v
                    }
                })
                .collect()
        })
        .collect()
}
