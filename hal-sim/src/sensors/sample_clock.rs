//! A part's own sample clock: instants `start + k / (ODR·(1 + ppm·10⁻⁶))` plus jitter (which
//! does not accumulate), started when measurement starts (the first result one period later).

use rand_chacha::ChaCha8Rng;

use super::errors::SensorErrors;

/// The internal sample clock of one part.
#[derive(Clone, Debug, Default)]
pub struct SampleClock {
    next: Option<f64>,
    start: f64,
    k: u64,
}

impl SampleClock {
    /// Stops the clock; the next [`SampleClock::next_due`] with a positive ODR restarts it.
    pub fn stop(&mut self) {
        self.next = None;
    }

    /// The next sample instant up to `t`, if one is due, for the nominal `odr` (Hz; `≤ 0`
    /// stops the clock). Call until `None` to take every due sample in order.
    pub fn next_due(
        &mut self,
        t: f64,
        odr: f64,
        errors: &SensorErrors,
        rng: &mut ChaCha8Rng,
    ) -> Option<f64> {
        if odr.is_nan() || odr <= 0.0 {
            self.next = None;
            return None;
        }
        let period = 1.0 / (odr * (1.0 + errors.clock_ppm * 1e-6));
        let next = match self.next {
            Some(n) => n,
            None => {
                self.start = t;
                self.k = 1;
                t + period
            }
        };
        self.next = Some(next);
        if next > t {
            return None;
        }
        self.k += 1;
        self.next = Some(self.start + self.k as f64 * period + errors.jitter_sample(rng));
        Some(next)
    }
}
