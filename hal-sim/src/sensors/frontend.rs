//! What every part does before it quantises: samples the true specific force at the instants
//! of its own clock, applies its error model and the measurement faults active at that instant.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::errors::SensorErrors;
use super::sample_clock::SampleClock;
use super::ForceSource;
use crate::faults::{Fault, FaultKind};

/// The analogue front end of one part.
pub struct Frontend {
    errors: SensorErrors,
    faults: Vec<Fault>,
    source: ForceSource,
    rng: ChaCha8Rng,
    clock: SampleClock,
    /// The frozen output while a `Stuck` fault lasts.
    held: Option<[f64; 3]>,
}

impl Frontend {
    /// A front end with the given errors, seeing `source` (part axes, m/s²).
    pub fn new(errors: SensorErrors, source: ForceSource) -> Self {
        let rng = ChaCha8Rng::seed_from_u64(errors.seed);
        Frontend {
            errors,
            faults: Vec::new(),
            source,
            rng,
            clock: SampleClock::default(),
            held: None,
        }
    }

    /// Schedules measurement faults (connection faults are the bus's; they are ignored here).
    pub fn set_faults(&mut self, faults: Vec<Fault>) {
        self.faults = faults.into_iter().filter(|f| !f.kind.on_bus()).collect();
    }

    /// What the part's temperature sensor sees at `t` (°C, before quantisation).
    pub fn temperature(&self, t: f64) -> f64 {
        self.errors.thermal.sensed(t)
    }

    /// Stops the internal clock (standby, reconfiguration).
    pub fn stop_clock(&mut self) {
        self.clock.stop();
    }

    /// The next sample instant of the internal clock up to `t` at the nominal `odr`.
    pub fn next_due(&mut self, t: f64, odr: f64) -> Option<f64> {
        self.clock.next_due(t, odr, &self.errors, &mut self.rng)
    }

    /// The measured specific force (part axes, m/s², before quantisation) at `t`, with white
    /// noise over the part's noise `bandwidth` (Hz).
    pub fn measure(&mut self, t: f64, bandwidth: f64) -> [f64; 3] {
        let f = (self.source)(t);
        let mut density2 = self.errors.noise_density * self.errors.noise_density;
        let mut bias = [0.0; 3];
        let (mut stuck, mut saturated) = (false, false);
        for fault in self.faults.iter().filter(|f| f.active(t)) {
            match &fault.kind {
                FaultKind::Stuck => stuck = true,
                FaultKind::BiasJump { bias: b } => {
                    for (o, v) in bias.iter_mut().zip(b.iter()) {
                        *o += v;
                    }
                }
                FaultKind::Drift { rate } => {
                    for (o, v) in bias.iter_mut().zip(rate.iter()) {
                        *o += v * (t - fault.start);
                    }
                }
                FaultKind::NoiseBurst { density } => density2 += density * density,
                FaultKind::Saturation => saturated = true,
                FaultKind::Dead | FaultKind::Corrupt { .. } | FaultKind::Timeout { .. } => {}
            }
        }
        let mut a = self
            .errors
            .apply(&f, t, (density2 * bandwidth).sqrt(), &mut self.rng);
        for (o, b) in a.iter_mut().zip(bias.iter()) {
            *o += b;
        }
        if saturated {
            a = [f64::MAX; 3];
        }
        if stuck {
            *self.held.get_or_insert(a)
        } else {
            self.held = None;
            a
        }
    }
}
