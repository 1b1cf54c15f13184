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

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn instants_follow_the_offset_clock_and_jitter_does_not_accumulate() {
        let errors = SensorErrors {
            clock_ppm: 100.0,
            jitter: 1e-6,
            ..SensorErrors::default()
        };
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut c = SampleClock::default();
        let odr = 1000.0;
        let period = 1.0 / (odr * (1.0 + 1e-4));
        let mut got = Vec::new();
        assert_eq!(
            c.next_due(0.0, odr, &errors, &mut rng),
            None,
            "starts at t = 0"
        );
        // To 10.0005 s at 1000.1 Hz: instants k/1000.1 for k = 1 ..= 10 001 (the last at 10 s).
        while let Some(t) = c.next_due(10.0005, odr, &errors, &mut rng) {
            got.push(t);
        }
        assert_eq!(got.len(), 10_001, "last {:?}", got.last());
        let mut sum2 = 0.0;
        for (k, t) in got.iter().enumerate().skip(1) {
            let dev = t - (k as f64 + 1.0) * period;
            assert!(dev.abs() < 6e-6, "sample {k}: {dev}");
            sum2 += dev * dev;
        }
        let sd = (sum2 / (got.len() - 1) as f64).sqrt();
        assert!((sd / 1e-6 - 1.0).abs() < 0.05, "jitter sd {sd}");
        // A stopped clock gives nothing.
        assert_eq!(c.next_due(20.0, 0.0, &errors, &mut rng), None);
    }
}
