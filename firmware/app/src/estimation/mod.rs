//! Estimation at sample rate (sample sets → estimator-core → the telemetry sink).
//!
//! Each sample set becomes the estimator's channel vector (part axis → channel); a part
//! without a value leaves its channels NaN, which the estimator answers with its prediction,
//! flagged. A part missing for [`EXCLUDE_AFTER`] sets in a row is excluded (the channel mask
//! changes), and included again after [`INCLUDE_AFTER`] good sets (estimator-core's
//! `exclusion`, which `ballisto estimate` shares); across such a change the last Ω is carried
//! as the rate hint, so branch and sign are kept, and where the
//! change takes channels out the last [`estimator_core::recent::REPLAY_SETS`] sets are
//! replayed through the new configuration before the set at hand, so that its rate filter
//! starts warm ([`estimator_core::recent`]). Channels can also be taken out by command
//! ([`Estimation::set_commanded`]); the solve uses every channel neither excluded automatically
//! nor by command.
//!
//! The model is the configured one where the channels in use carry it. Where exclusions leave
//! model G unobservable (fewer than 12 channels), the estimate is made in model F (Γ known) on
//! the channels left, and in model G again once they carry it; each switch is
//! reported ([`Estimation::take_model_switch`], the `model-switched` event).
//!
//! The measurements themselves are tested as well
//! ([`crate::isolation`]): a part that the parity space isolates, or whose own
//! signal is stuck, is kept out of the solve until the readings are consistent again, where
//! the model can spare it; while a fault is seen but not isolated, or isolated and not left
//! out, the estimate carries [`Flags::RESIDUAL_HIGH`].
//!
//! With a [`Builds`] buffer attached
//! ([`Estimation::attach_builds`]) the configuration of an exclusion or a re-admission is
//! built beside the one in force, by a task of lower priority where the board runs one
//! ([`background`]): the estimate goes on meanwhile, the parts on their way out read as
//! missing (flagged predictions), and the new configuration is swapped in at the first set
//! after it is built.

pub mod background;
pub mod temperature;
pub use background::Builds;

use ballisto_link::{ChannelSet, PartSet};
use estimator_core::exclusion::MissingRuns;
use estimator_core::fault_monitor::{Suspicion, TrustedRate, Verdict};
use estimator_core::recent::{replays, Recent, REPLAY_SETS};
use estimator_core::{
    Arrangement, ChannelMask, ConfigError, Estimate, Estimator, Flags, Model, Options,
};

use crate::config::{AppConfig, MAX_CHANNELS, MAX_PARTS};
use crate::isolation::Isolation;
use crate::sampler::SampleSet;
use crate::time::{seconds, Nanos};
use temperature::Compensation;

pub use estimator_core::exclusion::{EXCLUDE_AFTER, INCLUDE_AFTER};

/// The firmware's estimator: f32, up to [`MAX_CHANNELS`] channels.
pub type FwEstimator = Estimator<f32, MAX_CHANNELS>;

/// The second configuration buffer of [`FwEstimator`].
pub type FwSpare = estimator_core::SpareConfig<f32, MAX_CHANNELS>;

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
    /// The model the estimate was made in (model F instead of the configured model G while
    /// exclusions leave it unobservable).
    pub model: Model,
}

/// When a commanded configuration change takes effect.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Applied {
    /// It is in force.
    Now,
    /// Once the builder task has built it ([`Builds::background`]):
    /// [`Estimation::take_order_outcome`] says how it ended.
    WhenBuilt,
}

/// A commanded configuration change being built by the builder task.
#[derive(Clone, Copy, Debug)]
struct Order {
    pending: background::Pending,
    /// The configured model and the channels out by command once it is in force.
    model: Model,
    commanded: ChannelSet,
    /// A new arrangement or model (the configuration set aside is then forgotten), or only
    /// the channels out by command.
    reconfigures: bool,
}

/// The estimator and the channel bookkeeping.
pub struct Estimation {
    estimator: Estimator<f32, MAX_CHANNELS>,
    channels: [[Option<u8>; 3]; MAX_PARTS],
    n: usize,
    p: [f32; MAX_CHANNELS],
    runs: MissingRuns<MAX_PARTS>,
    /// Parts out because they stopped answering.
    excluded: PartSet,
    /// Parts out because the fault monitor isolated them (parity space or stuck).
    isolated: PartSet,
    /// An isolation the solve could not take (too few channels left): not retried per set.
    refused: Option<PartSet>,
    isolation: Isolation,
    commanded: ChannelSet,
    options: Options,
    /// The configured model (the estimator's, unless the channels in use do not carry it).
    model: Model,
    /// The second configuration buffer (where the board attaches one):
    /// model G's configuration set aside while model F is in force, so that the return is a
    /// swap, and, with a builder task, where changes are built outside the sample loop.
    builds: Option<&'static Builds>,
    /// The exclusion or re-admission waiting for its configuration (built in the background).
    pending: Option<background::Pending>,
    /// Numbers the builds asked for.
    tickets: u32,
    /// The commanded change being built, and how the last one ended (not yet taken).
    order: Option<Order>,
    order_outcome: Option<Result<(), ConfigError>>,
    /// A change of the model in force not yet reported: (before, after).
    switch: Option<(Model, Model)>,
    last_omega: Option<[f64; 3]>,
    /// The rate hint when an isolated part leaves or re-enters the solve.
    trusted: TrustedRate,
    /// A fault suspected and not isolated, held through sets without a test.
    suspicion: Suspicion,
    /// The last sets read (every channel), replayed through the configuration an automatic
    /// change of the channels in use puts in force.
    recent: Recent<f32, MAX_CHANNELS, REPLAY_SETS>,
    /// Such a change was put in force at this set: replay [`Self::recent`] before its estimate.
    replay_due: bool,
    /// The readings' temperature compensation.
    compensation: Compensation,
}

impl Estimation {
    /// The estimator for a configuration (validated by estimator-core: arrangement vs model).
    pub fn new(config: &AppConfig) -> Result<Self, ConfigError> {
        let options = Options {
            initial_omega: config.hint,
            ..Options::default()
        };
        let isolation = Isolation::new(config);
        let mut arrangement = config.arrangement.clone();
        arrangement.set_parts(isolation.parts());
        let estimator = Estimator::new(&arrangement, config.model, options)?;
        let mut channels = [[None; 3]; MAX_PARTS];
        for (i, p) in config.sampling.parts() {
            channels[i] = p.channels;
        }
        let mut e = Estimation {
            estimator,
            channels,
            n: config.arrangement.len(),
            p: [f32::NAN; MAX_CHANNELS],
            runs: MissingRuns::new(),
            excluded: PartSet::EMPTY,
            isolated: PartSet::EMPTY,
            refused: None,
            isolation,
            commanded: ChannelSet::EMPTY,
            options,
            model: config.model,
            builds: None,
            pending: None,
            tickets: 0,
            order: None,
            order_outcome: None,
            switch: None,
            last_omega: None,
            trusted: TrustedRate::default(),
            suspicion: Suspicion::default(),
            recent: Recent::new(),
            replay_due: false,
            compensation: Compensation::new(),
        };
        e.compensation
            .reconfigure(e.estimator.arrangement(), &e.channels);
        e.rebuild_monitor();
        Ok(e)
    }

    /// Takes `builds` as the second configuration buffer: mask changes keep the configuration
    /// they replace there, and, if it is [`Builds::background`], the exclusions' and
    /// re-admissions' configurations are built there by the board's builder task.
    pub fn attach_builds(&mut self, builds: &'static Builds) {
        self.builds = Some(builds);
        self.pending = None;
        self.order = None;
    }

    /// The channels whose exclusion (automatic or commanded) waits for its configuration
    /// (none without a builder task).
    pub fn channels_leaving(&self) -> ChannelMask {
        if let Some(p) = self.order.map(|o| o.pending).or(self.pending) {
            return ChannelMask(self.estimator.mask().0 & !p.mask.0);
        }
        ChannelMask(0)
    }

    /// Whether a commanded configuration change is being built (another is refused meanwhile).
    pub fn order_awaited(&self) -> bool {
        self.order.is_some()
    }

    /// How the last commanded change built by the builder task ended, once (`None` while it
    /// is being built, or if none was).
    pub fn take_order_outcome(&mut self) -> Option<Result<(), ConfigError>> {
        self.order_outcome.take()
    }

    /// The builder task's buffer, if the board runs one.
    fn background(&self) -> Option<&'static Builds> {
        self.builds.filter(|b| b.in_background())
    }

    /// Asks the builder task for a commanded change: the configuration of `arrangement` (the
    /// one in force if `None`) in `model` with the channels of `commanded` out
    /// ([`Applied::WhenBuilt`]), or, a change of channels back to the configuration set aside
    /// (a channel commanded back in), swaps that in at once ([`Applied::Now`]). `None` (nothing
    /// asked) without a builder task or while it holds the buffer: the caller makes the change
    /// in the sample path.
    fn order(
        &mut self,
        arrangement: Option<&Arrangement<MAX_CHANNELS>>,
        model: Model,
        commanded: ChannelSet,
    ) -> Option<Applied> {
        let builds = self.background()?;
        let mask = self.mask(self.excluded_parts(), commanded);
        let reconfigures = arrangement.is_some() || model != self.model;
        if !reconfigures {
            let before = self.estimator.model();
            if builds.swap_back(&mut self.estimator, model, mask).is_some() {
                self.pending = None;
                self.take_order(commanded, model, false, before);
                return Some(Applied::Now);
            }
        }
        // As the change in the sample path: a reconfiguration with the options configured, a
        // change of channels with those in force.
        let options = Options {
            initial_omega: self.last_omega,
            ..if reconfigures {
                self.options
            } else {
                self.estimator.options()
            }
        };
        let tested = self.tested_after(self.excluded, commanded, reconfigures);
        let arrangement = arrangement.unwrap_or(self.estimator.arrangement());
        let tickets = &mut self.tickets;
        let pending = builds.post(arrangement, options, mask, model, tested, tickets)?;
        // An automatic change waiting is superseded: it is asked again once this is in force.
        self.pending = None;
        self.order = Some(Order {
            pending,
            model,
            commanded,
            reconfigures,
        });
        Some(Applied::WhenBuilt)
    }

    /// A commanded change now in force (the estimator's configuration swapped in; the model in
    /// force was `before`): the channels out by command, the configured model, the hint, the
    /// fault monitor.
    fn take_order(
        &mut self,
        commanded: ChannelSet,
        model: Model,
        reconfigures: bool,
        before: Model,
    ) {
        let tested_before = self.mask(self.excluded, self.commanded);
        self.commanded = commanded;
        let _ = self.estimator.set_hint(self.last_omega);
        self.refresh_monitor(tested_before);
        if reconfigures {
            // The `reconfigured` event reports the model in force; what is set aside has the
            // old arrangement or model.
            self.model = model;
            if let Some(builds) = self.builds {
                builds.clear();
            }
            self.compensation
                .reconfigure(self.estimator.arrangement(), &self.channels);
        } else {
            self.note_model(before);
        }
    }

    /// Takes a commanded change once it is built (where no set is processed: standby).
    pub fn poll_order(&mut self) {
        self.collect_order();
    }

    /// The commanded change being built, swapped in once it is: `true` while it is still
    /// being built (the exclusions wait for it).
    fn collect_order(&mut self) -> bool {
        let (Some(order), Some(builds)) = (self.order, self.builds) else {
            return false;
        };
        let before = self.estimator.model();
        let outcome = match builds.collect(&mut self.estimator, order.pending) {
            background::Collected::Building => return true,
            background::Collected::Done(Ok(_)) => {
                self.take_order(order.commanded, order.model, order.reconfigures, before);
                Ok(())
            }
            background::Collected::Done(Err(e)) => Err(e),
            // Cannot happen (nothing takes the buffer while an order waits); said, not hung.
            background::Collected::Lost => Err(ConfigError::NotFinite {
                what: "configuration lost by the builder",
            }),
        };
        self.order = None;
        self.order_outcome = Some(outcome);
        false
    }

    /// What a change needs built besides the configuration: the fault monitor's parity space
    /// for the channels neither `missing` nor `commanded` out, if they are not those it tests
    /// now (or, `anew`, a new arrangement: whatever they are).
    fn tested_after(
        &self,
        missing: PartSet,
        commanded: ChannelSet,
        anew: bool,
    ) -> background::Tested {
        let tested = self.mask(missing, commanded);
        let now = self.mask(self.excluded, self.commanded);
        (anew || tested != now).then(|| (tested, *self.isolation.parts()))
    }

    /// The fault monitor after a change built by the builder task (the channels it tested were
    /// `before`): the parity space built with it or set aside, where the buffer holds the one
    /// for the channels now tested (the one replaced is set aside in turn); else, the same
    /// channels tested, the one in force (only the model's test refitted, no SVD); else built
    /// here. The buffer comes first: a new arrangement's parity space is built with it for the
    /// same channels.
    fn refresh_monitor(&mut self, before: ChannelMask) {
        if let Some(builds) = self.background() {
            let tested = self.mask(self.excluded, self.commanded);
            if let Some(checks) = builds.take_parity(tested) {
                let replaced = self.isolation.install(&self.estimator, checks);
                builds.set_aside_parity(before, replaced);
                return;
            }
            if tested == before {
                self.isolation.refit(&self.estimator);
                return;
            }
        }
        let _ = before;
        self.rebuild_monitor();
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
    /// With a builder task the change is built there ([`Applied::WhenBuilt`]).
    pub fn set_commanded(&mut self, commanded: ChannelSet) -> Result<Applied, ConfigError> {
        if let Some(applied) = self.order(None, self.model, commanded) {
            return Ok(applied);
        }
        let mask = self.mask(self.excluded_parts(), commanded);
        self.take_mask(mask)?;
        self.commanded = commanded;
        let _ = self.estimator.set_hint(self.last_omega);
        self.rebuild_monitor();
        Ok(Applied::Now)
    }

    /// The configured model (the estimator's is model F instead where the channels in use do
    /// not carry model G).
    pub fn model(&self) -> Model {
        self.model
    }

    /// The change of the model in force since the last call, if any: (before, after).
    pub fn take_model_switch(&mut self) -> Option<(Model, Model)> {
        self.switch.take()
    }

    /// Takes the channels of `mask` in the configured model, or in model F where they do not
    /// carry it (estimator-core's `Estimator::set_mask_in`;
    /// with a second buffer attached `set_mask_keeping`: back in the configured model, its configuration set aside at the
    /// switch is swapped in), and notes a change of the model in force. On error nothing
    /// changes.
    fn take_mask(&mut self, mask: ChannelMask) -> Result<(), ConfigError> {
        let before = self.estimator.model();
        // Made here and now: a change waiting for the builder is no longer wanted.
        self.pending = None;
        match self.builds.and_then(|b| b.spare_now()) {
            Some(mut spare) => self
                .estimator
                .set_mask_keeping(mask, self.model, &mut spare)?,
            None => self.estimator.set_mask_in(mask, self.model)?,
        };
        self.note_model(before);
        Ok(())
    }

    /// As [`Estimation::take_mask`] for the exclusions' and re-admissions' own changes, built
    /// by the builder task where there is one: `None` while it is being built (nothing
    /// changes meanwhile). `missing`: the parts out because they stopped answering once the
    /// change is made (the fault monitor tests the others).
    fn take_mask_when_built(
        &mut self,
        mask: ChannelMask,
        missing: PartSet,
    ) -> Option<Result<(), ConfigError>> {
        if let Some(builds) = self.background() {
            let before = self.estimator.model();
            let tested = self.tested_after(missing, self.commanded, false);
            let (est, pending, tickets) =
                (&mut self.estimator, &mut self.pending, &mut self.tickets);
            let taken = builds.change(est, mask, self.model, tested, pending, tickets)?;
            self.note_model(before);
            return Some(taken.map(|_| ()));
        }
        Some(self.take_mask(mask))
    }

    /// Notes that the model in force was `before` (a switch and its reversal before the
    /// report cancel out).
    fn note_model(&mut self, before: Model) {
        let now = self.estimator.model();
        if now != before {
            let first = self.switch.map_or(before, |(b, _)| b);
            self.switch = (first != now).then_some((first, now));
        }
    }

    /// A new arrangement (same channels) or model (model F in force instead of model G where
    /// the channels in use do not carry it). On error nothing changes. With a builder task the
    /// change is built there ([`Applied::WhenBuilt`]).
    pub fn configure(
        &mut self,
        mut arrangement: Arrangement<MAX_CHANNELS>,
        model: Model,
    ) -> Result<Applied, ConfigError> {
        if arrangement.len() != self.n {
            return Err(ConfigError::NoSuchChannel {
                channel: arrangement.len().min(self.n),
            });
        }
        // The parts are the sampling's, whatever the arrangement came with.
        arrangement.set_parts(self.isolation.parts());
        let arrangement = &arrangement;
        if let Some(applied) = self.order(Some(arrangement), model, self.commanded) {
            return Ok(applied);
        }
        let mask = self.mask(self.excluded_parts(), self.commanded);
        let options = Options {
            initial_omega: self.last_omega,
            ..self.options
        };
        self.pending = None; // an exclusion waiting was for the old configuration
        let est = &mut self.estimator;
        est.configure_preferring(arrangement, model, mask, options)?;
        // A commanded change: the `reconfigured` event reports the model in force; a
        // configuration set aside has the old arrangement.
        self.model = model;
        if let Some(b) = self.builds {
            b.clear();
        }
        self.compensation.reconfigure(arrangement, &self.channels);
        self.rebuild_monitor();
        Ok(Applied::Now)
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

    /// The parts' temperatures a set carries (°C, NaN: not read) after the sampler's `reads`-th
    /// temperature read: the channels of a part whose temperature changed get their
    /// corrections for it. Called for every set, before it is processed, in standby too.
    /// Returns whether the set carried a new read.
    pub fn observe_temperatures(&mut self, reads: u32, celsius: &[f32; MAX_PARTS]) -> bool {
        // Most sets carry no new temperature.
        if !self.compensation.news(reads) {
            return false;
        }
        for (part, (&t, chans)) in celsius.iter().zip(self.channels.iter()).enumerate() {
            let known = self.compensation.temperatures()[part];
            if !t.is_nan() && t.to_bits() != known.to_bits() {
                self.compensation
                    .observe(self.estimator.arrangement(), part, chans, t);
            }
        }
        true
    }

    /// The part channel `channel` is read from.
    pub fn part_of(&self, channel: usize) -> Option<usize> {
        self.channels
            .iter()
            .position(|chans| chans.iter().flatten().any(|&c| usize::from(c) == channel))
    }

    /// Each part's last temperature read (°C; NaN where none yet).
    pub fn temperatures(&self) -> &[f32; MAX_PARTS] {
        self.compensation.temperatures()
    }

    /// The last set's channel vector as the estimator got it (NaN where a part had no value).
    pub fn readings(&self) -> &[f32] {
        &self.p[..self.n]
    }

    /// The events the fault monitor's `verdict` of the last set calls for (part isolated,
    /// fault suspected or no longer).
    pub fn fault_events(
        &mut self,
        verdict: Verdict,
    ) -> [Option<(ballisto_link::EventId, u32, u32)>; 2] {
        self.isolation.events(verdict)
    }

    /// The consistency test the fault monitor runs on the readings of the channels in use
    /// (housekeeping).
    pub fn consistency_test(&self) -> ballisto_link::ConsistencyTest {
        self.isolation.test()
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
                    // Each reading brought to its channel's `t_ref` on the way in (the
                    // identity where a channel has no coefficients).
                    for (x, c) in v.iter().zip(chans.iter()) {
                        if let Some(c) = c {
                            let c = usize::from(*c);
                            self.p[c] = self.compensation.corrected(c, *x);
                        }
                    }
                    self.runs.observe(i, true);
                }
                None if chans.iter().any(Option::is_some) => {
                    missing = missing.with(i);
                    self.runs.observe(i, false);
                }
                None => {}
            }
        }
        let verdict = self.isolation.step(&self.p[..self.n], &set.variance);
        let isolated_before = self.isolated;
        let ordered = self.collect_order();
        if !ordered {
            self.update_exclusions(set.t);
        }
        // A new channel set in force: the last sets through it first (their estimates
        // are dropped), so that the rate filter meets this set warm.
        if core::mem::take(&mut self.replay_due) {
            let est = &mut self.estimator;
            self.recent.replay(|t, p| {
                est.update(t, p);
            });
        }
        self.recent.push(seconds(set.t), &self.p[..self.n]);
        // Parts whose exclusion waits for its configuration are out already: read as missing.
        let leaving = self.channels_leaving();
        if leaving.0 != 0 {
            for (c, x) in self.p[..self.n].iter_mut().enumerate() {
                if leaving.contains(c) {
                    *x = f32::NAN;
                }
            }
        }
        let newly_out = !self.isolated.minus(isolated_before).is_empty();
        let mut estimate = *self.estimator.update(seconds(set.t), &self.p[..self.n]);
        if estimate.is_finite() && !estimate.flags.has(Flags::INPUT_INVALID) {
            self.last_omega = Some(estimate.omega.map(f64::from));
        }
        // A fault the solve may still be using (seen but not isolated, or, with no parity
        // space, the readings inconsistent with the known field): the estimate is in doubt.
        let verdict = verdict.with_field(self.isolation.field_inconsistent(&estimate));
        // In model F on the channels left by an exclusion there is no test: a suspicion
        // stands until a test clears it or an isolated part is taken out.
        let verdict = self.suspicion.hold(verdict, newly_out);
        if verdict == Verdict::NotIsolated {
            estimate.flags.0 |= Flags::RESIDUAL_HIGH;
        }
        self.trusted.observe(seconds(set.t), &estimate, verdict);
        SetEstimate {
            k: set.k,
            t: set.t,
            estimate,
            missing,
            excluded: self.excluded_parts(),
            verdict,
            model: self.estimator.model(),
        }
    }

    /// Excludes parts missing too long or isolated, and includes recovered ones; in model F
    /// where the channels left do not carry model G, and back.
    fn update_exclusions(&mut self, now: Nanos) {
        let wanted = PartSet(self.runs.wanted(u32::from(self.excluded.0)) as u8);
        let isolated = self.isolation.isolated();
        if wanted == self.excluded && (isolated == self.isolated || Some(isolated) == self.refused)
        {
            self.pending = None; // a change no longer wanted
            return;
        }
        let mask = self.mask(PartSet(wanted.0 | isolated.0), self.commanded);
        // Too few channels left for either model: keep the mask (the sets stay flagged).
        let model_before = self.estimator.model();
        let replay = replays(self.estimator.mask(), mask);
        let Some(taken) = self.take_mask_when_built(mask, wanted) else {
            return; // being built: the estimate goes on with the configuration in force
        };
        if taken.is_ok() {
            let monitor_stale = wanted != self.excluded || self.estimator.model() != model_before;
            // The hint is for the first set the estimator will see.
            let from = self.recent.first_seen(replay, seconds(now));
            let hint = if isolated != self.isolated {
                self.trusted.hint_at(from).or(self.last_omega)
            } else {
                self.last_omega
            };
            let tested_before = self.mask(self.excluded, self.commanded);
            self.excluded = wanted;
            self.isolated = isolated;
            let _ = self.estimator.set_hint(hint);
            self.replay_due = replay;
            if monitor_stale {
                self.refresh_monitor(tested_before);
            }
        } else {
            self.refused = Some(isolated);
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::config::tetra;
    use estimator_core::{Flags, Model};

    fn set(k: u32, part0: bool) -> SampleSet {
        // The same small change in every part's reading each set (a uniform σ0: consistent),
        // so that no part repeats its values (the fault monitor's stuck check).
        let d = 1e-4 * (k % 7) as f32;
        let mut parts = [Some([0.1 + d, 0.2 - d, 9.8 + d]); MAX_PARTS];
        if !part0 {
            parts[0] = None;
        }
        SampleSet::new(k, u64::from(k) * 10_000_000, parts)
    }

    /// Model G on all twelve channels again, and the return from model F reported once.
    fn back_in_model_g(e: &mut Estimation) {
        assert_eq!(e.estimator().model(), Model::General);
        assert_eq!(e.estimator().mask(), ChannelMask::all(12));
        assert_eq!(
            e.take_model_switch(),
            Some((Model::FreeFloat, Model::General))
        );
        assert_eq!(e.take_model_switch(), None);
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

    /// With a part dead, twelve channels leave model G unobservable: the part is
    /// excluded all the same and the estimate made in model F on the nine left (instead of the
    /// flagged prediction held for as long as the part is dead); back in model G once the part
    /// has answered for [`INCLUDE_AFTER`] sets. Each switch is reported once.
    #[test]
    fn model_g_switches_to_model_f_while_a_part_is_out_and_back() {
        let mut e = Estimation::new(&tetra()).unwrap();
        assert_eq!(e.estimator().model(), Model::General);
        let gap = 5 + u32::from(EXCLUDE_AFTER);
        for k in 0..gap {
            let m = e.process(&set(k, k < 5));
            let out = k + 1 == gap;
            assert_eq!(m.excluded, PartSet(u8::from(out)), "set {k}");
            assert_eq!(m.estimate.flags.has(Flags::INPUT_INVALID), k >= 5 && !out);
            assert!(m.estimate.is_finite());
        }
        assert_eq!(e.estimator().model(), Model::FreeFloat);
        assert_eq!(e.model(), Model::General, "the configured model is kept");
        assert_eq!(
            e.take_model_switch(),
            Some((Model::General, Model::FreeFloat))
        );
        assert_eq!(e.take_model_switch(), None);
        // Dead 20 sets more, then good: back in after INCLUDE_AFTER good sets.
        let back = gap + 20 + u32::from(INCLUDE_AFTER);
        for k in gap..back {
            let m = e.process(&set(k, k >= gap + 20));
            assert_eq!(m.excluded, PartSet(u8::from(k + 1 < back)), "set {k}");
            assert!(m.estimate.is_finite());
            if k < gap + 20 {
                assert!(m.estimate.flags.has(Flags::CHANNELS_EXCLUDED), "set {k}");
                assert!(!m.estimate.flags.has(Flags::INPUT_INVALID), "set {k}");
            }
        }
        back_in_model_g(&mut e);
    }

    /// The tetrahedron's estimation with a builder task's buffer (the test builds at once with
    /// `Builds::build_now` where the board's task would build).
    fn with_builder() -> (Estimation, &'static Builds) {
        let builds: &'static Builds =
            std::boxed::Box::leak(std::boxed::Box::new(Builds::background()));
        let mut e = Estimation::new(&tetra()).unwrap();
        e.attach_builds(builds);
        (e, builds)
    }

    /// With a builder task the exclusion's configuration is built beside the one in
    /// force. Until it is built the estimates go on every set — the configured model, the
    /// leaving part read as missing: flagged predictions, finite — and none uses a half-built
    /// configuration; the first set after the build is made in model F without the part. The
    /// return, once the part has answered for `INCLUDE_AFTER` sets, swaps model G's
    /// configuration back from the buffer at once, with no build.
    #[test]
    fn an_exclusion_built_in_the_background_never_stops_the_estimates() {
        let (mut e, builds) = with_builder();
        let part0 = ChannelMask(0b111);
        let gap = 5 + u32::from(EXCLUDE_AFTER);
        for k in 0..gap + 30 {
            let m = e.process(&set(k, k < 5));
            assert_eq!(
                m.excluded,
                PartSet::EMPTY,
                "set {k}: not out before it is built"
            );
            assert_eq!(m.model, Model::General, "set {k}");
            assert!(m.estimate.is_finite(), "set {k}");
            assert_eq!(
                m.estimate.flags.has(Flags::INPUT_INVALID),
                k >= 5,
                "set {k}"
            );
            let leaving = if k + 1 >= gap { part0 } else { ChannelMask(0) };
            assert_eq!(e.channels_leaving(), leaving, "set {k}");
        }
        assert_eq!(e.take_model_switch(), None);
        // The builder runs (once it has the processor): the configuration is built.
        assert!(builds.build_now());
        assert!(!builds.build_now(), "one build asked for");
        let k = gap + 30;
        let m = e.process(&set(k, false));
        assert_eq!(m.excluded, PartSet(1));
        assert_eq!(m.model, Model::FreeFloat);
        assert!(m.estimate.flags.has(Flags::CHANNELS_EXCLUDED));
        assert!(!m.estimate.flags.has(Flags::INPUT_INVALID));
        assert_eq!(e.channels_leaving(), ChannelMask(0));
        assert_eq!(
            e.take_model_switch(),
            Some((Model::General, Model::FreeFloat))
        );
        // Back without the builder: model G's configuration was set aside at the swap.
        let back = k + 1 + u32::from(INCLUDE_AFTER);
        for k in k + 1..back {
            let m = e.process(&set(k, true));
            assert_eq!(m.excluded, PartSet(u8::from(k + 1 < back)), "set {k}");
            assert!(m.estimate.is_finite(), "set {k}");
        }
        back_in_model_g(&mut e);
    }

    /// A part back before its exclusion's configuration is built: the change is abandoned —
    /// the estimator keeps its configuration and the part, and the build, when the builder
    /// gets to it, is not swapped in.
    #[test]
    fn an_exclusion_no_longer_wanted_is_not_swapped_in() {
        let (mut e, builds) = with_builder();
        let gap = 5 + u32::from(EXCLUDE_AFTER);
        for k in 0..gap {
            e.process(&set(k, k < 5));
        }
        assert_eq!(e.channels_leaving(), ChannelMask(0b111), "asked for");
        let m = e.process(&set(gap, true));
        assert_eq!(e.channels_leaving(), ChannelMask(0), "no longer wanted");
        assert!(!m.estimate.flags.has(Flags::INPUT_INVALID));
        assert!(builds.build_now(), "the builder gets to it");
        for k in gap + 1..gap + 20 {
            let m = e.process(&set(k, true));
            assert_eq!(m.excluded, PartSet::EMPTY, "set {k}");
            assert_eq!(m.model, Model::General, "set {k}");
            assert!(!m.estimate.flags.has(Flags::INPUT_INVALID), "set {k}");
        }
        assert_eq!(e.estimator().mask(), ChannelMask::all(12));
        assert_eq!(e.take_model_switch(), None);
    }

    /// Eighteen channels: the tetrahedron and two more parts on the axes (the host simulator's
    /// `tetra-orbit` with two ADXL355s added).
    fn eighteen() -> AppConfig {
        eighteen_turned(0)
    }

    /// [`eighteen`] with the two added parts' axes turned by `turn` places (another
    /// arrangement of the same channels).
    fn eighteen_turned(turn: usize) -> AppConfig {
        let mut cfg = tetra();
        let extra = cfg.sampling.parts[0].expect("part 0");
        for (i, pos) in [[0.12, 0.0, 0.0], [0.0, 0.0, -0.12]].iter().enumerate() {
            let mut channels = [None; 3];
            for (k, ch) in channels.iter_mut().enumerate() {
                let mut axis = [0.0; 3];
                axis[(k + i + turn) % 3] = 1.0;
                let noise = cfg.arrangement.channels()[0].noise;
                *ch = cfg
                    .arrangement
                    .push(*pos, axis, noise)
                    .ok()
                    .map(|c| c as u8);
            }
            cfg.sampling.parts[4 + i] = Some(crate::config::PartConfig { channels, ..extra });
        }
        cfg
    }

    /// Readings consistent with a uniform specific force (no rotation), `part0` absent.
    fn consistent_set(cfg: &AppConfig, k: u32, part0: bool) -> SampleSet {
        let d = 1e-3 * f64::from(k % 7);
        let f = [0.1 + d, 0.2 - d, 9.8 + d];
        let mut parts = [None; MAX_PARTS];
        for (i, p) in cfg.sampling.parts() {
            let mut v = [0.0f32; 3];
            for (x, c) in v.iter_mut().zip(p.channels.iter()) {
                if let Some(c) = c {
                    let a = cfg.arrangement.channels()[usize::from(*c)].axis;
                    *x = (a[0] * f[0] + a[1] * f[1] + a[2] * f[2]) as f32;
                }
            }
            parts[i] = (i != 0 || part0).then_some(v);
        }
        SampleSet::new(k, u64::from(k) * 10_000_000, parts)
    }

    /// With redundancy (N = 18) the fault monitor's parity space is built by the builder task
    /// with the exclusion's configuration, not in the sample path: at the swap the monitor
    /// tests the fifteen channels left with it, and the one for all eighteen is set aside; the
    /// part's return takes that one back (and sets the other aside) with no build at all.
    #[test]
    fn the_parity_space_is_built_with_the_configuration_in_the_background() {
        let cfg = eighteen();
        let builds: &'static Builds =
            std::boxed::Box::leak(std::boxed::Box::new(Builds::background()));
        let mut e = Estimation::new(&cfg).unwrap();
        e.attach_builds(builds);
        let all = ChannelMask::all(18);
        let without0 = all.without(0).without(1).without(2);
        assert_eq!(e.consistency_test(), ballisto_link::ConsistencyTest::Parity);
        let gap = 5 + u32::from(EXCLUDE_AFTER);
        for k in 0..gap {
            let m = e.process(&consistent_set(&cfg, k, k < 5));
            assert_eq!(m.excluded, PartSet::EMPTY, "set {k}");
        }
        assert_eq!(builds.parity_held(), None, "asked for, not built");
        assert!(builds.build_now());
        assert_eq!(
            builds.parity_held(),
            Some(without0),
            "built with the configuration"
        );
        let m = e.process(&consistent_set(&cfg, gap, false));
        assert_eq!(m.excluded, PartSet(1));
        assert_eq!(m.model, Model::General, "fifteen channels carry model G");
        assert_eq!(e.consistency_test(), ballisto_link::ConsistencyTest::Parity);
        assert_eq!(
            builds.parity_held(),
            Some(all),
            "the one replaced, set aside"
        );
        // Back after INCLUDE_AFTER good sets, with no build: the configuration and the
        // parity space set aside are swapped back.
        let back = gap + 1 + u32::from(INCLUDE_AFTER);
        let mut k = gap + 1;
        while k < back {
            e.process(&consistent_set(&cfg, k, true));
            k += 1;
        }
        assert!(!builds.build_now(), "nothing asked of the builder");
        assert_eq!(e.excluded_parts(), PartSet::EMPTY, "back at set {k}");
        assert_eq!(e.estimator().mask(), all);
        assert_eq!(e.consistency_test(), ballisto_link::ConsistencyTest::Parity);
        assert_eq!(builds.parity_held(), Some(without0), "swapped back");
        for k in k..k + 20 {
            let m = e.process(&consistent_set(&cfg, k, true));
            assert!(!m.estimate.flags.has(Flags::RESIDUAL_HIGH), "set {k}");
        }
    }

    /// A new arrangement commanded with a builder task: the parity space built with its
    /// configuration is the one installed (the channels tested are the same as before, which
    /// must not keep the old arrangement's): readings consistent with the new arrangement are
    /// not flagged once it is in force.
    #[test]
    fn a_new_arrangement_built_in_the_background_brings_its_own_parity_space() {
        let (cfg, turned) = (eighteen(), eighteen_turned(1));
        let builds: &'static Builds =
            std::boxed::Box::leak(std::boxed::Box::new(Builds::background()));
        let mut e = Estimation::new(&cfg).unwrap();
        e.attach_builds(builds);
        for k in 0..50 {
            let m = e.process(&consistent_set(&cfg, k, true));
            assert!(!m.estimate.flags.has(Flags::RESIDUAL_HIGH), "set {k}");
        }
        let applied = e.configure(turned.arrangement.clone(), Model::General);
        assert_eq!(applied, Ok(Applied::WhenBuilt));
        assert!(builds.build_now());
        // Set 50 is tested before the swap, by the old arrangement's parity space.
        e.process(&consistent_set(&turned, 50, true));
        assert_eq!(e.take_order_outcome(), Some(Ok(())));
        for k in 51..300 {
            let m = e.process(&consistent_set(&turned, k, true));
            assert!(!m.estimate.flags.has(Flags::RESIDUAL_HIGH), "set {k}");
        }
    }
}
