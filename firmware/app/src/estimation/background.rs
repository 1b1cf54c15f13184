//! The precomputation of a channel-mask change outside the sample loop: the second
//! configuration buffer and the task that builds into it.
//!
//! ```text
//! application task (sets)            Builds (spare buffer, request)          builder task
//!  exclusion wanted ──request──────▶ ┌──────────────────────────┐ ◀──lock, build── (lower
//!  estimates go on with the old     │ Mutex: only ever *tried*  │                   priority)
//!  configuration (parts on their    │ by the application        │ ──done──▶
//!  way out read as missing)         └──────────────────────────┘
//!  next set after done ◀──swap (one exchange of the two buffers, no precomputation)
//! ```
//!
//! The application never waits for the buffer: it only *tries* to lock it, and the builder
//! holds it for the whole build, so the estimate never meets a half-built configuration. The
//! fault monitor's parity space for the channels it will test
//! is built with the configuration (an SVD in f64 as well: 4.2 M instructions at N = 18 on the
//! M4F). What the swap replaces — configuration and parity space — stays in the buffer (set
//! aside), so that the return when the part is back is a swap too. Commanded changes
//! (`Estimation::set_commanded`, `Estimation::configure`) go the same way.
//!
//! [`Builds::inline`] is the same buffer without a builder task: the change is built in the
//! sample path at once (the host simulator, whose time is simulated, so that its estimates stay
//! those of `ballisto estimate` set for set). On the QEMU board (Cortex-M4F, soft f64) builds
//! in the sample path lost 110 of the built-in scenario's 1 000 sets (24 at the G → F switch);
//! with the builder task, none.

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex as Cs;
use embassy_sync::mutex::{MappedMutexGuard, Mutex, MutexGuard};
use embassy_sync::signal::Signal;
use estimator_core::{Arrangement, ChannelMask, ConfigError, Model, Options};

use super::{FwEstimator, FwSpare};

use crate::config::MAX_CHANNELS;
use crate::isolation::{build_parity, Checks};

/// The parity space a change needs: the channels the fault monitor
/// will test and each channel's part; `None` where the tested channels do not change, or
/// there is no monitor.
pub type Tested = Option<(ChannelMask, [u8; MAX_CHANNELS])>;

/// A configuration asked of the builder.
struct Request {
    ticket: u32,
    arrangement: Arrangement<MAX_CHANNELS>,
    options: Options,
    mask: ChannelMask,
    preferred: Model,
    tested: Tested,
}

/// The buffer and what was asked of it.
struct Slot {
    spare: FwSpare,
    request: Option<Request>,
    /// The ticket of the last build and its outcome.
    done: Option<(u32, Result<Model, ConfigError>)>,
    /// The fault monitor's second buffer: a parity space and the channels it tests, built
    /// with a configuration or set aside when one was swapped in.
    parity: Option<(ChannelMask, Checks)>,
}

impl Slot {
    /// Forgets what the buffer holds (a configuration and parity space built for a change no
    /// longer wanted, or set aside for an arrangement no longer in force).
    fn forget(&mut self) {
        self.spare.clear();
        {
            self.parity = None;
        }
    }
}

/// A change of the channels in use waiting for its configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pending {
    ticket: u32,
    /// The channels the configuration is built for.
    pub mask: ChannelMask,
}

/// The second configuration buffer, shared by the application and the builder task.
pub struct Builds {
    slot: Mutex<Cs, Slot>,
    wake: Signal<Cs, ()>,
    background: bool,
}

impl Builds {
    /// A buffer built into by a task of lower priority than the application's, which the board
    /// must run ([`Builds::run`]); until it does, exclusions wait.
    pub fn background() -> Self {
        Self::with(true)
    }

    /// A buffer without a builder task: changes are built in the sample path at once.
    pub fn inline() -> Self {
        Self::with(false)
    }

    fn with(background: bool) -> Self {
        Builds {
            slot: Mutex::new(Slot {
                spare: FwSpare::new(),
                request: None,
                done: None,
                parity: None,
            }),
            wake: Signal::new(),
            background,
        }
    }

    /// Whether changes are built by [`Builds::run`].
    pub fn in_background(&self) -> bool {
        self.background
    }

    /// The builder task's body: builds each configuration asked for into the buffer, holding
    /// the buffer for the whole build. Never returns.
    pub async fn run(&self) -> ! {
        loop {
            self.wake.wait().await;
            build_asked(&mut *self.slot.lock().await);
        }
    }

    /// What the builder task does, at once: builds the configuration asked for, if there is
    /// one and no build holds the buffer; whether it built one (for a board that builds from
    /// its idle loop, and for tests).
    pub fn build_now(&self) -> bool {
        self.slot
            .try_lock()
            .is_ok_and(|mut slot| build_asked(&mut slot))
    }

    /// The buffer, if no build holds it, with any request or build for a change no longer
    /// wanted (not `pending`) forgotten: its configuration is not the estimator's to take.
    fn free(&self, pending: Option<Pending>) -> Option<MutexGuard<'_, Cs, Slot>> {
        let mut slot = self.slot.try_lock().ok()?;
        let wanted = |ticket: u32| pending.is_some_and(|p| p.ticket == ticket);
        if slot.request.as_ref().is_some_and(|r| !wanted(r.ticket)) {
            slot.request = None;
        }
        if slot
            .done
            .as_ref()
            .is_some_and(|(ticket, _)| !wanted(*ticket))
        {
            slot.done = None;
            slot.forget();
        }
        Some(slot)
    }

    /// The spare configuration for a change made in the sample path (a telecommand, or no
    /// builder task), if no build holds it; a build under way for another change is abandoned
    /// (its outcome is forgotten when it is done).
    pub fn spare_now(&self) -> Option<MappedMutexGuard<'_, Cs, FwSpare>> {
        Some(MutexGuard::map(self.free(None)?, |s| &mut s.spare))
    }

    /// Forgets the configuration and parity space set aside (a new arrangement or options),
    /// or, if a build holds the buffer, leaves them to be forgotten when that build is done.
    pub fn clear(&self) {
        if let Some(mut slot) = self.free(None) {
            slot.forget();
        }
    }

    /// Asks the builder for the configuration of `arrangement`, `options` and `mask` in the
    /// `preferred` model (model F where the mask does not carry model G), in place of any
    /// request not yet taken; `None` if a build holds the buffer. `tickets` numbers the requests.
    /// With `tested`, the fault monitor's parity space for those channels is built too.
    #[allow(clippy::too_many_arguments)]
    pub fn post(
        &self,
        arrangement: &Arrangement<MAX_CHANNELS>,
        options: Options,
        mask: ChannelMask,
        preferred: Model,
        tested: Tested,
        tickets: &mut u32,
    ) -> Option<Pending> {
        let mut slot = self.free(None)?;
        *tickets = tickets.wrapping_add(1);
        slot.request = Some(Request {
            ticket: *tickets,
            arrangement: arrangement.clone(),
            options,
            mask,
            preferred,
            tested,
        });
        drop(slot);
        self.wake.signal(());
        Some(Pending {
            ticket: *tickets,
            mask,
        })
    }

    /// The configuration asked for by `pending`, swapped into `estimator` once built (the one
    /// in force is set aside): [`Collected::Building`] meanwhile, nothing changed.
    pub fn collect(&self, estimator: &mut FwEstimator, pending: Pending) -> Collected {
        let Some(mut guard) = self.free(Some(pending)) else {
            return Collected::Building;
        };
        let slot = &mut *guard;
        match slot.done.take() {
            Some((_, built)) => Collected::Done(
                built.map(|model| estimator.swap_in(&mut slot.spare).unwrap_or(model)),
            ),
            None if slot.request.is_some() => Collected::Building,
            None => Collected::Lost,
        }
    }

    /// The channels of `mask` in the `preferred` model (model F where they do not carry model
    /// G) for `estimator`, built outside the sample loop: `Some` once the estimator uses them
    /// (or the build was refused: nothing changed), `None` while they are being built — the
    /// estimator keeps its configuration meanwhile. `pending` is the caller's record of the
    /// change asked for; `tickets` numbers the requests.
    pub fn change(
        &self,
        estimator: &mut FwEstimator,
        mask: ChannelMask,
        preferred: Model,
        tested: Tested,
        pending: &mut Option<Pending>,
        tickets: &mut u32,
    ) -> Option<Result<Model, ConfigError>> {
        if let Some(asked) = pending.filter(|p| p.mask == mask) {
            match self.collect(estimator, asked) {
                Collected::Building => return None,
                Collected::Done(taken) => {
                    *pending = None;
                    return Some(taken);
                }
                Collected::Lost => {} // asked again below
            }
        }
        // The return to the configuration set aside (it has the arrangement and options in
        // force: the buffer is emptied when they change).
        if let Some(model) = self.swap_back(estimator, preferred, mask) {
            *pending = None;
            return Some(Ok(model));
        }
        let (arrangement, options) = (estimator.arrangement(), estimator.options());
        *pending = self.post(arrangement, options, mask, preferred, tested, tickets);
        None
    }

    /// The configuration set aside, if it is the channels of `mask` in the `preferred` model,
    /// swapped into `estimator` (the one in force set aside in turn); the model in force, or
    /// `None` (nothing changed: another configuration, or a build holds the buffer).
    pub fn swap_back(
        &self,
        estimator: &mut FwEstimator,
        preferred: Model,
        mask: ChannelMask,
    ) -> Option<Model> {
        let mut slot = self.free(None)?;
        if slot.spare.holds() != Some((preferred, mask)) {
            return None;
        }
        estimator.swap_in(&mut slot.spare)
    }

    /// The parity space built or set aside for the channels of `tested`, if the buffer holds
    /// it and no build holds the buffer.
    pub fn take_parity(&self, tested: ChannelMask) -> Option<Checks> {
        let mut slot = self.slot.try_lock().ok()?;
        match slot.parity.take() {
            Some((mask, checks)) if mask == tested => Some(checks),
            other => {
                slot.parity = other;
                None
            }
        }
    }

    /// The channels of the parity space the buffer holds (built or set aside), if no build
    /// holds the buffer.
    pub fn parity_held(&self) -> Option<ChannelMask> {
        self.slot
            .try_lock()
            .ok()?
            .parity
            .as_ref()
            .map(|(mask, _)| *mask)
    }

    /// Sets aside the parity space of the channels of `tested` that a change replaced.
    pub fn set_aside_parity(&self, tested: ChannelMask, checks: Checks) {
        if let Ok(mut slot) = self.slot.try_lock() {
            slot.parity = Some((tested, checks));
        }
    }
}

/// Builds the configuration asked for in `slot`, if any, and keeps its outcome there.
fn build_asked(slot: &mut Slot) -> bool {
    let Some(r) = slot.request.take() else {
        return false;
    };
    let built = slot
        .spare
        .build(&r.arrangement, r.preferred, r.mask, r.options);
    // The parity space only for a configuration that will be swapped in.
    if let (Ok(_), Some((tested, part))) = (&built, r.tested) {
        slot.parity = Some((tested, build_parity(&r.arrangement, tested, &part)));
    }
    slot.done = Some((r.ticket, built));
    true
}

/// What became of a configuration asked for ([`Builds::collect`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Collected {
    /// Not built yet: the estimator keeps its configuration.
    Building,
    /// Built and swapped in (the model in force), or refused (nothing changed).
    Done(Result<Model, ConfigError>),
    /// Neither built nor asked for any longer (a change made in the sample path took the
    /// buffer): nothing changed.
    Lost,
}
