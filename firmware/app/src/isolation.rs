//! Fault isolation from the measurements: estimator-core's
//! [`FaultMonitor`](estimator_core::fault_monitor::FaultMonitor) over the parts that answer,
//! with redundancy (N ≥ 13; isolating a tri-axial part needs N ≥ 16) in either model: its
//! parity space is model G's, and model F's readings lie in it too.
//!
//! The monitor tests every channel that is neither missing on the bus nor taken out by
//! command — the isolated part's included, so that it is re-admitted when it is consistent
//! again — whatever channels the estimate uses. Its parity space is rebuilt (one SVD, outside
//! the per-sample solve, as the estimator's own mask change) when that set changes.
//!
//! Every board runs it (the STM32H743 flight image too).

use ballisto_link::{ConsistencyTest, EventId, PartSet};
use estimator_core::fault_monitor::Verdict;
use estimator_core::{ChannelMask, Estimate, Estimator};

use crate::config::{AppConfig, MAX_CHANNELS, MAX_PARTS};

use estimator_core::fault_monitor::{FaultMonitor, NoParityTest, Settings, StuckCheck};
use estimator_core::parity::NO_PART;

/// The monitor, each channel's part, the test where there is no parity space (model G's
/// known field, or model F's own residual), and every part's check from its own signal
/// (stuck, or at its range limit: the full scale of its configured range).
pub struct Isolation {
    monitor: FaultMonitor<f32, MAX_CHANNELS>,
    part: [u8; MAX_CHANNELS],
    no_parity: NoParityTest<f32>,
    stuck: StuckCheck<f32, MAX_CHANNELS>,
    /// The parts stuck at the last set (bit per part).
    stuck_parts: u32,
    rate_hz: f64,
    /// The verdict and the isolated parts the events have told the ground.
    reported: Verdict,
    reported_isolated: PartSet,
}

impl Isolation {
    /// A monitor for `config`'s parts and rate (no parity space until [`Isolation::rebuild`]).
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
        let rate_hz = f64::from(config.sampling.rate_hz);
        Isolation {
            monitor: FaultMonitor::new(Settings::default(), rate_hz),
            part,
            no_parity: NoParityTest::None,
            stuck: StuckCheck::with_limits(&part, &range),
            stuck_parts: 0,
            rate_hz,
            reported: Verdict::NoTest,
            reported_isolated: PartSet::EMPTY,
        }
    }

    /// The parity space of the channels of `tested` (model G's linear design whatever the
    /// model estimated in: model F's field is one of model G's, so its readings are
    /// consistent with the same space; none with too few channels, N ≤ 12); without one,
    /// estimator-core's [`NoParityTest`] for the estimator's configuration.
    pub fn rebuild(&mut self, estimator: &Estimator<f32, MAX_CHANNELS>, tested: ChannelMask) {
        let parity = build_parity(estimator.arrangement(), tested, &self.part);
        self.install(estimator, parity);
    }

    /// As [`Isolation::rebuild`] with the parity space built elsewhere (the firmware's
    /// builder task, `estimation::background`); returns the one it replaces.
    pub fn install(&mut self, estimator: &Estimator<f32, MAX_CHANNELS>, parity: Checks) -> Checks {
        self.no_parity = NoParityTest::for_estimator(
            estimator,
            parity.is_some(),
            Settings::default(),
            self.rate_hz,
        );
        self.monitor.replace_parity(parity)
    }

    /// The parity space in force kept, the rest made anew for the estimator's new
    /// configuration (its model's test, the window restarted): the same channels tested,
    /// no SVD.
    pub fn refit(&mut self, estimator: &Estimator<f32, MAX_CHANNELS>) {
        let checks = self.monitor.replace_parity(None);
        self.install(estimator, checks);
    }

    /// Each channel's part ([`NO_PART`] for none), as the parity space is built with.
    pub fn parts(&self) -> &[u8; MAX_CHANNELS] {
        &self.part
    }

    /// After the estimate: whether model G's known-field test, or model F's own residual,
    /// finds its window inconsistent; `None` where there is neither (a parity space
    /// instead, nine channels in model F, or an estimate it cannot use).
    pub fn field_inconsistent(&mut self, e: &Estimate<f32>) -> Option<bool> {
        self.no_parity.step(e)
    }

    /// One set's readings (NaN where a part had no value) and each part's noise variance
    /// over its declared one (the sampler's: below 1 for an interpolated value).
    pub fn step(&mut self, p: &[f32], variance: &[f32; MAX_PARTS]) -> Verdict {
        let mut var = [1.0f32; MAX_CHANNELS];
        for (v, q) in var.iter_mut().zip(self.part.iter()) {
            if let Some(x) = variance.get(usize::from(*q)) {
                *v = *x;
            }
        }
        self.monitor.set_variance(&var);
        self.stuck_parts = self.stuck.step(p);
        self.monitor.step_with(p, self.stuck_parts)
    }

    /// The events a set calls for, from its `verdict` (the final one: with the known-field
    /// test and any isolation the solve could not take) and the parts isolated: a
    /// suspicion started or ended, a part newly isolated (by the parity space or as stuck).
    pub fn events(&mut self, verdict: Verdict) -> [Option<(EventId, u32, u32)>; 2] {
        let before = core::mem::replace(&mut self.reported, verdict);
        let level = (self.level() * 1000.0) as u32;
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
            for (c, q) in self.part.iter().enumerate() {
                if usize::from(*q) == p {
                    bits |= 1 << c;
                }
            }
            // The high octet: the part's re-admissions so far (an intermittent fault).
            let back = u32::from(self.monitor.readmissions(p as u8));
            (EventId::PartIsolated, p as u32, bits | back << 24)
        });
        [suspicion, named]
    }

    /// The window's χ² over its limit (or the mean test's over its own, if higher): the
    /// monitor's, or the test's where it has no parity space.
    fn level(&self) -> f32 {
        self.no_parity
            .level()
            .unwrap_or_else(|| self.monitor.level())
    }

    /// The consistency test on the readings (housekeeping).
    pub fn test(&self) -> ConsistencyTest {
        if self.monitor.has_parity() {
            return ConsistencyTest::Parity;
        }
        match &self.no_parity {
            NoParityTest::Field(_) => ConsistencyTest::KnownField,
            NoParityTest::Residual(_) => ConsistencyTest::OwnResidual,
            NoParityTest::None => ConsistencyTest::None,
        }
    }

    /// The parts isolated (to be kept out of the solve): by the parity space, or stuck.
    pub fn isolated(&self) -> PartSet {
        let stuck = PartSet((self.stuck_parts & 0xff) as u8);
        match self.monitor.isolated() {
            Some(p) => stuck.with(usize::from(p)),
            None => stuck,
        }
    }
}

/// A parity space, or none (too few channels: N ≤ 12).
pub type Checks = Option<estimator_core::parity::Parity<f32, MAX_CHANNELS>>;

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
