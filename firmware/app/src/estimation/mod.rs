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
use estimator_core::fault_monitor::Verdict;
use estimator_core::{Arrangement, ChannelMask, ConfigError, Estimate, Estimator, Model, Options};

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
    /// The fault supervisor (parts out for silence or as isolated, the replay, the hint).
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
        arrangement.set_parts(&isolation.parts());
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
            initial_omega: self.isolation.supervisor.last_omega(),
            ..if reconfigures {
                self.options
            } else {
                self.estimator.options()
            }
        };
        let tested = self.tested_after(self.missing(), commanded, reconfigures);
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
        let tested_before = self.mask(self.missing(), self.commanded);
        self.commanded = commanded;
        let _ = self
            .estimator
            .set_hint(self.isolation.supervisor.last_omega());
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
        let now = self.mask(self.missing(), self.commanded);
        (anew || tested != now).then(|| (tested, self.isolation.parts()))
    }

    /// The fault monitor after a change built by the builder task (the channels it tested were
    /// `before`): the parity space built with it or set aside, where the buffer holds the one
    /// for the channels now tested (the one replaced is set aside in turn); else, the same
    /// channels tested, the one in force (only the model's test refitted, no SVD); else built
    /// here. The buffer comes first: a new arrangement's parity space is built with it for the
    /// same channels.
    fn refresh_monitor(&mut self, before: ChannelMask) {
        if let Some(builds) = self.background() {
            let tested = self.mask(self.missing(), self.commanded);
            if let Some(checks) = builds.take_parity(tested) {
                let replaced = self.isolation.supervisor.install(&self.estimator, checks);
                builds.set_aside_parity(before, replaced);
                return;
            }
            if tested == before {
                self.isolation.supervisor.refit(&self.estimator);
                return;
            }
        }
        let _ = before;
        self.rebuild_monitor();
    }

    /// The fault monitor's parity space over the channels neither missing nor commanded out.
    fn rebuild_monitor(&mut self) {
        let tested = self.mask(self.missing(), self.commanded);
        self.isolation.supervisor.rebuild(&self.estimator, tested);
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
        let s = &self.isolation.supervisor;
        PartSet(((s.missing() | s.isolated()) & 0xff) as u8)
    }

    /// Parts out because they stopped answering.
    fn missing(&self) -> PartSet {
        PartSet((self.isolation.supervisor.missing() & 0xff) as u8)
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
        let _ = self
            .estimator
            .set_hint(self.isolation.supervisor.last_omega());
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
        arrangement.set_parts(&self.isolation.parts());
        let arrangement = &arrangement;
        if let Some(applied) = self.order(Some(arrangement), model, self.commanded) {
            return Ok(applied);
        }
        let mask = self.mask(self.excluded_parts(), self.commanded);
        let options = Options {
            initial_omega: self.isolation.supervisor.last_omega(),
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
        self.isolation.supervisor.set_last_omega(omega);
        Ok(())
    }

    /// Starts again after a pause (standby): history forgotten, the last Ω as the hint.
    pub fn restart(&mut self) {
        let _ = self
            .estimator
            .set_hint(self.isolation.supervisor.last_omega());
    }

    /// The solve's channel mask with `parts` and `commanded` out.
    fn mask(&self, parts: PartSet, commanded: ChannelSet) -> ChannelMask {
        let mut mask = self.isolation.supervisor.without_parts(u32::from(parts.0));
        for c in 0..self.n {
            if commanded.contains(c) {
                mask = mask.without(c);
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
                }
                None if chans.iter().any(Option::is_some) => missing = missing.with(i),
                None => {}
            }
        }
        let verdict = self.isolation.step(&self.p[..self.n], &set.variance);
        let ordered = self.collect_order();
        if !ordered {
            self.update_exclusions(set.t);
        }
        let (t, est) = (seconds(set.t), &mut self.estimator);
        self.isolation
            .supervisor
            .before_update(t, &self.p[..self.n], |t, p| {
                est.update(t, p);
            });
        // Parts whose exclusion waits for its configuration are out already: read as missing.
        let leaving = self.channels_leaving();
        if leaving.0 != 0 {
            for (c, x) in self.p[..self.n].iter_mut().enumerate() {
                if leaving.contains(c) {
                    *x = f32::NAN;
                }
            }
        }
        let mut estimate = *self.estimator.update(t, &self.p[..self.n]);
        let verdict = self
            .isolation
            .supervisor
            .after_update(t, &mut estimate, verdict);
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

    /// Takes out the parts the supervisor wants out (missing too long or isolated) and
    /// includes recovered ones; in model F where the channels left do not carry model G, and
    /// back.
    fn update_exclusions(&mut self, now: Nanos) {
        let Some(change) = self.isolation.supervisor.change() else {
            self.pending = None; // a change no longer wanted
            return;
        };
        let wanted = PartSet((change.missing & 0xff) as u8);
        let mask = self.mask(PartSet((change.out() & 0xff) as u8), self.commanded);
        let model_before = self.estimator.model();
        let before = self.estimator.mask();
        let restarted = mask != before;
        let tested_before = self.mask(self.missing(), self.commanded);
        if !restarted {
            // The channels in force are the ones wanted: a build for others is not.
            self.pending = None;
        }
        if restarted {
            let Some(taken) = self.take_mask_when_built(mask, wanted) else {
                return; // being built: the estimate goes on with the configuration in force
            };
            if taken.is_err() {
                // Too few channels left for either model: the mask stays (the sets flagged).
                self.isolation.supervisor.refuse(change);
                return;
            }
        }
        let taken = self
            .isolation
            .supervisor
            .taken(change, before, mask, seconds(now));
        if restarted {
            let _ = self.estimator.set_hint(taken.hint);
        }
        if taken.missing_changed || self.estimator.model() != model_before {
            self.refresh_monitor(tested_before);
        }
    }
}

#[cfg(test)]
mod tests;
