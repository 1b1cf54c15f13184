//! The identification task: the window's work below the estimate.
//!
//! ```text
//! application task (sets, TCs)                 Identifier                 identification task
//!  each set of an open window ──try_send──▶ sets (SET_QUEUE)  ──────────▶ (lower priority)
//!  TC[200,8] start, TC[200,9] points,        orders (ORDERS)   ──────────▶ queue, reference,
//!  TC[200,10] solve ──────────try_send──▶                                  sums, solve
//!  report the solution at once ◀────────── solved (Signal) ◀───────────── solution
//! ```
//!
//! The application never waits for the task: it only *tries* to queue. A set that finds the
//! queue full is lost to the window and counted (the summary's `not_covered`); an order that
//! finds it full is refused (not ready, `IDENTIFICATION_BUSY`: send it again). On the M4F
//! (soft f64) moving a set into the sums costs about 41 000 instructions and a solve 31 M
//! (`docs/validation.md`): in the sample path the whole per-set cost with a window open was
//! five times the budget; queued, it is the copy of the set.

use ballisto_link::identification::{IdentificationSummary, ReferencePoint, MAX_POINTS};
use embassy_futures::select::{select, Either};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex as Cs;
use embassy_sync::channel::Channel;
use embassy_sync::signal::Signal;
use estimator_core::identify::Identified;
use estimator_core::{Arrangement, FrameUncertainty};

use super::{Identification, Unsolved};
use crate::config::MAX_CHANNELS;
use crate::time::Nanos;

/// Sets the application can queue ahead of the task.
pub const SET_QUEUE: usize = 16;

/// Orders the application can queue ahead of the task.
pub const ORDERS: usize = 2;

/// A set on its way to the task: its time, channels and the estimator's rate.
type QueuedSet = (Nanos, [f32; MAX_CHANNELS], [f32; 3]);

/// A solve's outcome: the solution, its frame and summary, or why there is none.
pub type Solved = Result<
    (
        Identified<MAX_CHANNELS>,
        FrameUncertainty<f64>,
        IdentificationSummary,
    ),
    Unsolved,
>;

/// What the application asks of the task.
#[allow(clippy::large_enum_variant)] // one slot per order, two orders: no allocation.
pub enum Order {
    /// TC[200,8]: a new window from `now` over the channels of `arrangement`.
    Start {
        /// The command's time.
        now: Nanos,
        /// The reference's period.
        period_ms: u16,
        /// The window's length.
        window_ms: u32,
        /// The sample rate.
        rate_hz: f32,
        /// The arrangement in force.
        arrangement: Arrangement<MAX_CHANNELS>,
        /// Without a reference: the body's inertia (a torque-free tumble).
        inertia: Option<[f32; 6]>,
    },
    /// TC[200,9]: reference points, in time order.
    Points(heapless::Vec<ReferencePoint, MAX_POINTS>),
    /// TC[200,10]: solve; `lost` sets found the queue full.
    Solve {
        /// Sets lost to the window on the way.
        lost: u32,
    },
}

/// The queues between the application and the identification task.
pub struct Identifier {
    sets: Channel<Cs, QueuedSet, SET_QUEUE>,
    orders: Channel<Cs, Order, ORDERS>,
    solved: Signal<Cs, Solved>,
}

impl Default for Identifier {
    fn default() -> Self {
        Self::new()
    }
}

impl Identifier {
    /// Empty queues.
    pub const fn new() -> Self {
        Identifier {
            sets: Channel::new(),
            orders: Channel::new(),
            solved: Signal::new(),
        }
    }

    /// Empties the queues and forgets a solution not taken (a host run reusing them).
    pub fn clear(&self) {
        self.sets.clear();
        self.orders.clear();
        self.solved.reset();
    }

    /// The identification task's body, on `window` (its state): takes each set and order in
    /// turn — before an order, every set queued before it. Never returns.
    pub async fn run(&self, window: &mut Identification) -> ! {
        loop {
            match select(self.orders.receive(), self.sets.receive()).await {
                Either::First(order) => {
                    self.take_sets(window);
                    self.execute(order, window);
                }
                Either::Second((t, p, w)) => window.on_set(t, &p, &w),
            }
        }
    }

    /// What the task does, at once: every set and order queued (for a board or test that
    /// runs it from its own loop).
    pub fn run_now(&self, window: &mut Identification) {
        self.take_sets(window);
        while let Ok(order) = self.orders.try_receive() {
            self.execute(order, window);
            self.take_sets(window);
        }
    }

    fn take_sets(&self, window: &mut Identification) {
        while let Ok((t, p, w)) = self.sets.try_receive() {
            window.on_set(t, &p, &w);
        }
    }

    fn execute(&self, order: Order, window: &mut Identification) {
        match order {
            Order::Start {
                now,
                period_ms,
                window_ms,
                rate_hz,
                arrangement,
                inertia,
            } => window.start(now, period_ms, window_ms, &arrangement, rate_hz, inertia),
            Order::Points(points) => window.on_points(points.into_iter()),
            Order::Solve { lost } => self.solved.signal(window.solve(lost)),
        }
    }

    /// Queues a set's channel vector (NaN where a part had no value) taken at `t` and the
    /// estimator's rate then; `false` if the queue is full (the set is lost to the window).
    pub fn post_set(&self, t: Nanos, p: &[f32], omega: [f32; 3]) -> bool {
        let mut v = [0.0; MAX_CHANNELS];
        let n = p.len().min(MAX_CHANNELS);
        v[..n].copy_from_slice(&p[..n]);
        self.sets.try_send((t, v, omega)).is_ok()
    }

    /// Queues an order; `false` if the queue is full (nothing was asked).
    pub fn post(&self, order: Order) -> bool {
        self.orders.try_send(order).is_ok()
    }

    /// The outcome of the last solve asked for, once the task has it.
    pub async fn solved(&self) -> Solved {
        self.solved.wait().await
    }
}
