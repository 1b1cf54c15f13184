//! Estimation at sample rate (sample sets → estimator-core → the telemetry sink).
//!
//! Each sample set becomes the estimator's channel vector (part axis → channel); a part
//! without a value leaves its channels NaN, which the estimator answers with its prediction,
//! flagged. A part missing for [`EXCLUDE_AFTER`] sets in a row is excluded (the channel mask
//! changes, if the rest still suffices for the model), and included again after
//! [`INCLUDE_AFTER`] good sets; across such a change the last Ω is carried as the rate hint, so
//! branch and sign are kept. Channels can also be taken out by command
//! ([`Estimation::set_commanded`]); the solve uses every channel neither excluded automatically
//! nor by command.
//!
//! With the feature `fault-isolation` the measurements themselves are tested as well
//! ([`crate::isolation`], issue 17): a part that the parity space isolates, or whose own
//! signal is stuck, is kept out of the solve until the readings are consistent again, where
//! the model can spare it; while a fault is seen but not isolated, or isolated and not left
//! out, the estimate carries [`Flags::RESIDUAL_HIGH`].

use ballisto_link::{ChannelSet, PartSet};
use estimator_core::fault_monitor::{TrustedRate, Verdict};
use estimator_core::{
    Arrangement, ChannelMask, ConfigError, Estimate, Estimator, Flags, Model, Options,
};

use crate::config::{AppConfig, MAX_CHANNELS, MAX_PARTS};
use crate::isolation::Isolation;
use crate::sampler::SampleSet;
use crate::time::{seconds, Nanos};

/// Sets in a row without a value after which a part is excluded.
pub const EXCLUDE_AFTER: u16 = 5;
/// Good sets in a row after which an excluded part is included again.
pub const INCLUDE_AFTER: u16 = 100;

/// The estimate of one sample set (what the estimation task outputs per set).
#[derive(Clone, Copy, Debug)]
pub struct SetEstimate {
    /// Sample set index.
    pub k: u32,
    /// Sample instant.
    pub t: Nanos,
    /// The estimate.
    pub estimate: Estimate<f32>,
    /// Parts without a value in this set.
    pub missing: PartSet,
    /// Parts excluded from the estimate (missing on the bus, or isolated).
    pub excluded: PartSet,
    /// What the fault monitor said of this set's readings.
    pub verdict: Verdict,
}

/// The estimator and the channel bookkeeping.
pub struct Estimation {
    estimator: Estimator<f32, MAX_CHANNELS>,
    channels: [[Option<u8>; 3]; MAX_PARTS],
    n: usize,
    p: [f32; MAX_CHANNELS],
    missing_run: [u16; MAX_PARTS],
    good_run: [u16; MAX_PARTS],
    /// Parts out because they stopped answering.
    excluded: PartSet,
    /// Parts out because the fault monitor isolated them (parity space or stuck).
    isolated: PartSet,
    /// An isolation the solve could not take (too few channels left): not retried per set.
    refused: Option<PartSet>,
    isolation: Isolation,
    commanded: ChannelSet,
    options: Options,
    last_omega: Option<[f64; 3]>,
    /// The rate hint when an isolated part leaves or re-enters the solve.
    trusted: TrustedRate,
}

impl Estimation {
    /// The estimator for a configuration (validated by estimator-core: arrangement vs model).
    pub fn new(config: &AppConfig) -> Result<Self, ConfigError> {
        let options = Options {
            initial_omega: config.hint,
            ..Options::default()
        };
        let estimator = ballisto_fw_precompute::new(&config.arrangement, config.model, options)?;
        let mut channels = [[None; 3]; MAX_PARTS];
        for (i, p) in config.sampling.parts() {
            channels[i] = p.channels;
        }
        let mut e = Estimation {
            estimator,
            channels,
            n: config.arrangement.len(),
            p: [f32::NAN; MAX_CHANNELS],
            missing_run: [0; MAX_PARTS],
            good_run: [0; MAX_PARTS],
            excluded: PartSet::EMPTY,
            isolated: PartSet::EMPTY,
            refused: None,
            isolation: Isolation::new(config),
            commanded: ChannelSet::EMPTY,
            options,
            last_omega: None,
            trusted: TrustedRate::default(),
        };
        e.rebuild_monitor();
        Ok(e)
    }

    /// The fault monitor's parity space over the channels neither missing nor commanded out.
    fn rebuild_monitor(&mut self) {
        let tested = self.mask(self.excluded, self.commanded);
        self.isolation.rebuild(&self.estimator, tested);
    }

    /// Channels in the arrangement.
    pub fn channels(&self) -> usize {
        self.n
    }

    /// Channels out of the solve, automatically or by command.
    pub fn excluded_channels(&self) -> ChannelSet {
        ChannelSet((!self.estimator.mask().0 & ChannelMask::all(self.n).0) as u32)
    }

    /// Channels out by command.
    pub fn commanded(&self) -> ChannelSet {
        self.commanded
    }

    /// Parts out automatically (missing on the bus, or isolated).
    pub fn excluded_parts(&self) -> PartSet {
        PartSet(self.excluded.0 | self.isolated.0)
    }

    /// Takes the channels of `commanded` out of the solve and puts the others back. On error
    /// (too few channels left, or a degenerate geometry) nothing changes.
    pub fn set_commanded(&mut self, commanded: ChannelSet) -> Result<(), ConfigError> {
        let mask = self.mask(self.excluded_parts(), commanded);
        ballisto_fw_precompute::set_mask(&mut self.estimator, mask)?;
        self.commanded = commanded;
        let _ = self.estimator.set_hint(self.last_omega);
        self.rebuild_monitor();
        Ok(())
    }

    /// A new arrangement (same channels) or model. On error nothing changes.
    pub fn configure(
        &mut self,
        arrangement: &Arrangement<MAX_CHANNELS>,
        model: Model,
    ) -> Result<(), ConfigError> {
        if arrangement.len() != self.n {
            return Err(ConfigError::NoSuchChannel {
                channel: arrangement.len().min(self.n),
            });
        }
        let mask = self.mask(self.excluded_parts(), self.commanded);
        let options = Options {
            initial_omega: self.last_omega,
            ..self.options
        };
        ballisto_fw_precompute::configure(&mut self.estimator, arrangement, model, mask, options)?;
        self.rebuild_monitor();
        Ok(())
    }

    /// A rate hint (settles sign and branch from the next set on).
    pub fn set_hint(&mut self, omega: [f64; 3]) -> Result<(), ConfigError> {
        self.estimator.set_hint(Some(omega))?;
        self.last_omega = Some(omega);
        Ok(())
    }

    /// Starts again after a pause (standby): history forgotten, the last Ω as the hint.
    pub fn restart(&mut self) {
        let _ = self.estimator.set_hint(self.last_omega);
    }

    /// The solve's channel mask with `parts` and `commanded` out.
    fn mask(&self, parts: PartSet, commanded: ChannelSet) -> ChannelMask {
        let mut mask = ChannelMask::all(self.n);
        for c in 0..self.n {
            if commanded.contains(c) {
                mask = mask.without(c);
            }
        }
        for (i, chans) in self.channels.iter().enumerate() {
            if parts.contains(i) {
                for c in chans.iter().flatten() {
                    mask = mask.without(usize::from(*c));
                }
            }
        }
        mask
    }

    /// The last set's channel vector as the estimator got it (NaN where a part had no value).
    pub fn readings(&self) -> &[f32] {
        &self.p[..self.n]
    }

    /// The events the fault monitor's `verdict` of the last set calls for (part isolated,
    /// fault suspected or no longer; none without the feature `fault-isolation`).
    pub fn fault_events(
        &mut self,
        verdict: Verdict,
    ) -> [Option<(ballisto_link::EventId, u32, u32)>; 2] {
        self.isolation.events(verdict)
    }

    /// The estimator (model, mask, condition).
    pub fn estimator(&self) -> &Estimator<f32, MAX_CHANNELS> {
        &self.estimator
    }

    /// One sample set.
    pub fn process(&mut self, set: &SampleSet) -> SetEstimate {
        let mut missing = PartSet::EMPTY;
        self.p[..self.n].fill(f32::NAN);
        for (i, (value, chans)) in set.parts.iter().zip(self.channels.iter()).enumerate() {
            match value {
                Some(v) => {
                    for (x, c) in v.iter().zip(chans.iter()) {
                        if let Some(c) = c {
                            self.p[usize::from(*c)] = *x;
                        }
                    }
                    self.missing_run[i] = 0;
                    self.good_run[i] = self.good_run[i].saturating_add(1);
                }
                None if chans.iter().any(Option::is_some) => {
                    missing = missing.with(i);
                    self.good_run[i] = 0;
                    self.missing_run[i] = self.missing_run[i].saturating_add(1);
                }
                None => {}
            }
        }
        let verdict = self.isolation.step(&self.p[..self.n]);
        self.update_exclusions(set.t);
        // Through the speed-built crate: this crate is built for size.
        let mut estimate =
            *ballisto_fw_estimate::update(&mut self.estimator, seconds(set.t), &self.p[..self.n]);
        if estimate.is_finite() && !estimate.flags.has(Flags::INPUT_INVALID) {
            self.last_omega = Some(estimate.omega.map(f64::from));
        }
        // A fault the solve may still be using (seen but not isolated, or, with no parity
        // space, the readings inconsistent with the known field): the estimate is in doubt.
        let field_bad = self.isolation.field_inconsistent(&estimate);
        let verdict = if field_bad {
            Verdict::NotIsolated
        } else {
            verdict
        };
        if verdict == Verdict::NotIsolated {
            estimate.flags.0 |= Flags::RESIDUAL_HIGH;
        }
        if self.isolation.enabled() {
            self.trusted.observe(seconds(set.t), &estimate, verdict);
        }
        SetEstimate {
            k: set.k,
            t: set.t,
            estimate,
            missing,
            excluded: self.excluded_parts(),
            verdict,
        }
    }

    /// Excludes parts missing too long or isolated, and includes recovered ones.
    fn update_exclusions(&mut self, now: Nanos) {
        let mut wanted = self.excluded;
        for i in 0..MAX_PARTS {
            if self.missing_run[i] >= EXCLUDE_AFTER {
                wanted = wanted.with(i);
            } else if self.good_run[i] >= INCLUDE_AFTER {
                wanted = wanted.without(i);
            }
        }
        let isolated = self.isolation.isolated();
        if wanted == self.excluded && (isolated == self.isolated || Some(isolated) == self.refused)
        {
            return;
        }
        let mask = self.mask(PartSet(wanted.0 | isolated.0), self.commanded);
        // Too few channels left for the model: keep the mask (the sets stay flagged).
        if ballisto_fw_precompute::set_mask(&mut self.estimator, mask).is_ok() {
            let missing_changed = wanted != self.excluded;
            let hint = if isolated != self.isolated {
                self.trusted.hint_at(seconds(now)).or(self.last_omega)
            } else {
                self.last_omega
            };
            self.excluded = wanted;
            self.isolated = isolated;
            let _ = self.estimator.set_hint(hint);
            if missing_changed {
                self.rebuild_monitor();
            }
        } else {
            self.refused = Some(isolated);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::tetra;
    use estimator_core::{Flags, Model};

    fn set(k: u32, part0: bool) -> SampleSet {
        // The same small change in every part's reading each set (a uniform σ0: consistent),
        // so that no part repeats its values (the stuck check of `fault-isolation`).
        let d = 1e-4 * (k % 7) as f32;
        let mut parts = [Some([0.1 + d, 0.2 - d, 9.8 + d]); MAX_PARTS];
        if !part0 {
            parts[0] = None;
        }
        SampleSet {
            k,
            t: u64::from(k) * 10_000_000,
            parts,
        }
    }

    #[test]
    fn a_part_missing_for_several_sets_is_excluded_and_later_included() {
        let mut cfg = tetra();
        cfg.model = Model::FreeFloat;
        let mut e = Estimation::new(&cfg).unwrap();
        for k in 0..5 {
            assert_eq!(e.process(&set(k, true)).excluded, PartSet(0));
        }
        let gap = 5 + u32::from(EXCLUDE_AFTER);
        for k in 5..gap {
            let m = e.process(&set(k, false));
            assert_eq!(m.missing, PartSet(1));
            let excluded = k + 1 == gap;
            assert_eq!(m.excluded, PartSet(u8::from(excluded)), "set {k}");
            // Missing before the exclusion: the flagged prediction; after: an estimate.
            assert_eq!(m.estimate.flags.has(Flags::INPUT_INVALID), !excluded);
            assert_eq!(m.estimate.flags.has(Flags::CHANNELS_EXCLUDED), excluded);
        }
        let back = gap + u32::from(INCLUDE_AFTER);
        for k in gap..back {
            let m = e.process(&set(k, true));
            assert_eq!(m.excluded, PartSet(u8::from(k + 1 < back)), "set {k}");
        }
        assert_eq!(e.estimator().mask(), ChannelMask::all(12));
    }

    #[test]
    fn model_g_cannot_spare_a_part_and_keeps_all_channels() {
        let mut e = Estimation::new(&tetra()).unwrap();
        for k in 0..20 {
            let m = e.process(&set(k, k < 5));
            assert_eq!(m.excluded, PartSet(0));
            assert_eq!(m.estimate.flags.has(Flags::INPUT_INVALID), k >= 5);
            assert!(m.estimate.is_finite());
        }
    }
}
