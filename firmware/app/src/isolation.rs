//! Fault isolation on the unit: estimator-core's [`Supervisor`] (the one fault supervisor,
//! which `ballisto estimate` runs too) over the configuration's parts, and what it tells the
//! ground: the events of a suspicion and of a part isolated, the consistency test in force.
//!
//! The monitor tests every channel that is neither missing on the bus nor taken out by
//! command — the isolated part's included, so that it is re-admitted when it is consistent
//! again — whatever channels the estimate uses; its parity space (model G's, in either
//! model) is rebuilt when that set changes. Every board runs it (the STM32H743 flight image
//! too).

use ballisto_link::{ConsistencyTest, EventId, PartSet};
use estimator_core::fault_monitor::{NoParityTest, Verdict};
use estimator_core::parity::NO_PART;
use estimator_core::supervisor::Supervisor;
use estimator_core::ChannelMask;

use crate::config::{AppConfig, MAX_CHANNELS, MAX_PARTS};

/// The firmware's supervisor: f32, up to [`MAX_CHANNELS`] channels.
pub type FwSupervisor = Supervisor<f32, MAX_CHANNELS, MAX_PARTS>;

/// The supervisor and what the events have told the ground.
pub struct Isolation {
    /// The supervisor (the estimation drives it set by set).
    pub supervisor: FwSupervisor,
    /// The verdict and the isolated parts the events have told the ground.
    reported: Verdict,
    reported_isolated: PartSet,
}

impl Isolation {
    /// A supervisor for `config`'s parts, ranges (the full scale of each part's configured
    /// range) and rate; no parity space until it is rebuilt.
    pub fn new(config: &AppConfig) -> Self {
        let mut part = [NO_PART; MAX_CHANNELS];
        let mut range = [f64::INFINITY; MAX_CHANNELS];
        for (i, p) in config.sampling.parts() {
            for c in p.channels.iter().flatten() {
                if let Some(slot) = part.get_mut(usize::from(*c)) {
                    *slot = i as u8;
                    range[usize::from(*c)] = f64::from(p.kind.full_scale());
                }
            }
        }
        let n = config.arrangement.len().min(MAX_CHANNELS);
        let rate_hz = f64::from(config.sampling.rate_hz);
        Isolation {
            supervisor: Supervisor::new(&part[..n], &range[..n], Some(rate_hz)),
            reported: Verdict::NoTest,
            reported_isolated: PartSet::EMPTY,
        }
    }

    /// Each channel's part ([`NO_PART`] for none), as the parity space is built with.
    pub fn parts(&self) -> [u8; MAX_CHANNELS] {
        let mut part = [NO_PART; MAX_CHANNELS];
        for (slot, p) in part.iter_mut().zip(self.supervisor.parts()) {
            *slot = *p;
        }
        part
    }

    /// One set's readings (NaN where a part had no value) and each part's noise variance
    /// over its declared one (the sampler's: below 1 for an interpolated value).
    pub fn step(&mut self, p: &[f32], variance: &[f32; MAX_PARTS]) -> Verdict {
        let mut var = [1.0f32; MAX_CHANNELS];
        for (v, q) in var.iter_mut().zip(self.supervisor.parts()) {
            if let Some(x) = variance.get(usize::from(*q)) {
                *v = *x;
            }
        }
        let n = self.supervisor.parts().len();
        self.supervisor.observe(p, Some(&var[..n]))
    }

    /// The events a set calls for, from its `verdict` (the final one: with the known-field
    /// test and any isolation the solve could not take) and the parts isolated: a
    /// suspicion started or ended, a part newly isolated (by the parity space or as stuck).
    pub fn events(&mut self, verdict: Verdict) -> [Option<(EventId, u32, u32)>; 2] {
        let before = core::mem::replace(&mut self.reported, verdict);
        let level = (self.supervisor.level() * 1000.0) as u32;
        let suspicion = match (
            before == Verdict::NotIsolated,
            verdict == Verdict::NotIsolated,
        ) {
            (false, true) => Some((EventId::FaultSuspected, 1, level)),
            (true, false) => Some((EventId::FaultSuspected, 0, level)),
            _ => None,
        };
        let isolated = self.isolated();
        let new = isolated.minus(self.reported_isolated);
        self.reported_isolated = isolated;
        let part = (0..MAX_PARTS).find(|p| new.contains(*p));
        let named = part.map(|p| {
            let mut bits = 0u32;
            for (c, q) in self.supervisor.parts().iter().enumerate() {
                if usize::from(*q) == p {
                    bits |= 1 << c;
                }
            }
            // The high octet: the part's re-admissions so far (an intermittent fault).
            let back = u32::from(self.supervisor.readmissions(p as u8));
            (EventId::PartIsolated, p as u32, bits | back << 24)
        });
        [suspicion, named]
    }

    /// The consistency test on the readings (housekeeping).
    pub fn test(&self) -> ConsistencyTest {
        if self.supervisor.has_parity() {
            return ConsistencyTest::Parity;
        }
        match self.supervisor.no_parity() {
            NoParityTest::Field(_) => ConsistencyTest::KnownField,
            NoParityTest::Residual(_) => ConsistencyTest::OwnResidual,
            NoParityTest::None => ConsistencyTest::None,
        }
    }

    /// The parts isolated at the last set (to be kept out of the solve): by the parity
    /// space, or by their own signal.
    pub fn isolated(&self) -> PartSet {
        PartSet((self.supervisor.isolated_now() & 0xff) as u8)
    }
}

/// A parity space, or none (too few channels: N ≤ 12).
pub type Checks = estimator_core::supervisor::Checks<f32, MAX_CHANNELS>;

/// The parity space of the channels of `tested` in `arrangement` (`part`: each channel's
/// part), or none where they have no redundancy: one SVD in f64, 4.2 M instructions at
/// N = 18 and 4.9 M at N = 24 on the Cortex-M4F (`cargo qemu-bench`).
pub fn build_parity(
    arrangement: &estimator_core::Arrangement<MAX_CHANNELS>,
    tested: ChannelMask,
    part: &[u8; MAX_CHANNELS],
) -> Checks {
    estimator_core::parity::Parity::build(arrangement, tested, part).ok()
}
