//! The watchdog's supervisor: the board arms its watchdog at boot and only this task
//! feeds it, and only while the data path makes progress. Two counts say so: the sets the
//! sampling task has produced (the snapshots it published on its health board) and the sets the
//! application task has handled ([`Liveness`]: estimated, reported and their telemetry written — the downlink is
//! written by the application task, so a link that blocks stops this count too). Either count
//! standing still for a whole [`CHECK_EVERY`] stops the feeding, and the watchdog resets the
//! unit; the board reads the cause at the next boot (`ResetCause::Watchdog`). The tasks that
//! may legitimately run long — the builder, the storage task, the identification's search —
//! are not watched: they run below the watched ones and cannot stop them.

use core::sync::atomic::{AtomicU32, Ordering};

use embassy_sync::blocking_mutex::raw::RawMutex;

use crate::sampler::HealthBoard;
use crate::time::{Nanos, TimeBase};

/// How often the supervisor looks at the counts: every 250 ms. The boards' watchdogs expire
/// after 1 s without a feed, four looks: a stall is a reset within 1.25 s, and a look that
/// falls between two sets at the slowest rate a configuration may have (10 Hz) never reads as
/// one.
pub const CHECK_EVERY: Nanos = 250_000_000;

/// The board's watchdog, armed by the board before the tasks start.
pub trait Watchdog {
    /// Restarts the watchdog's count.
    fn feed(&mut self);
}

/// The application task's progress: sets handled.
#[derive(Default)]
pub struct Liveness {
    handled: AtomicU32,
}

impl Liveness {
    /// Nothing handled yet.
    pub const fn new() -> Self {
        Liveness {
            handled: AtomicU32::new(0),
        }
    }

    /// The application task has handled a set (its estimate and telemetry done).
    pub fn handled(&self) {
        self.handled.fetch_add(1, Ordering::Relaxed);
    }

    fn handled_count(&self) -> u32 {
        self.handled.load(Ordering::Relaxed)
    }
}

/// Which part of the data path stood still.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Stall {
    /// No set produced.
    Sampling,
    /// No set handled (estimate, reports, telemetry).
    Application,
}

/// The counts at one look.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Progress {
    /// Sets the sampling task produced.
    pub sampled: u32,
    /// Sets the application task handled.
    pub handled: u32,
}

impl Progress {
    /// What stood still between `self` (the look before) and `now`, if anything.
    pub fn stall(&self, now: &Progress) -> Option<Stall> {
        if now.sampled == self.sampled {
            Some(Stall::Sampling)
        } else if now.handled == self.handled {
            Some(Stall::Application)
        } else {
            None
        }
    }
}

/// The supervisor task: every [`CHECK_EVERY`] it feeds `watchdog` if both counts moved since
/// the look before, and otherwise stops feeding for good (the watchdog resets the unit; a
/// path that stalled once is not trusted to have recovered). `stalled` is told what stood
/// still, once (a board may keep it for the next boot). Never returns.
pub async fn supervisor_task<M, W, T>(
    board: &HealthBoard<M>,
    live: &Liveness,
    watchdog: &mut W,
    time: &mut T,
    stalled: impl FnOnce(Stall),
) -> !
where
    M: RawMutex,
    W: Watchdog,
    T: TimeBase,
{
    let look = || Progress {
        sampled: board.published(),
        handled: live.handled_count(),
    };
    let mut before = look();
    let mut at = time.now();
    loop {
        watchdog.feed();
        at += CHECK_EVERY;
        time.wait_until(at).await;
        let now = look();
        if let Some(stall) = before.stall(&now) {
            stalled(stall);
            loop {
                // The watchdog's reset ends this.
                time.wait_until(time.now() + CHECK_EVERY).await;
            }
        }
        before = now;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Health;
    use core::cell::Cell;
    use embassy_sync::blocking_mutex::raw::NoopRawMutex;

    struct Counted<'a>(&'a Cell<u32>);

    impl Watchdog for Counted<'_> {
        fn feed(&mut self) {
            self.0.set(self.0.get() + 1);
        }
    }

    /// Time that jumps to each instant waited for, and the data path behind it: a set every
    /// 10 ms, produced and handled, until `sets` (then nothing); past `end` it stops.
    struct Path<'a> {
        now: &'a Cell<Nanos>,
        board: &'a HealthBoard<NoopRawMutex>,
        live: &'a Liveness,
        sets: u32,
        end: Nanos,
    }

    impl TimeBase for Path<'_> {
        fn now(&self) -> Nanos {
            self.now.get()
        }

        async fn wait_until(&mut self, at: Nanos) {
            if at > self.end {
                core::future::pending::<()>().await;
            }
            self.now.set(self.now.get().max(at));
            let mut health = Health::default();
            self.board.latest_into(&mut health);
            let due = ((at / 10_000_000) as u32).min(self.sets);
            while health.sampling.sets < due {
                health.sampling.sets += 1;
                self.board.publish(health);
                self.live.handled();
            }
        }
    }

    #[test]
    fn a_stall_is_named_and_only_progress_is_fed() {
        let before = Progress {
            sampled: 10,
            handled: 9,
        };
        let moved = Progress {
            sampled: 35,
            handled: 34,
        };
        assert_eq!(before.stall(&moved), None);
        let no_sets = Progress {
            handled: 34,
            ..before
        };
        assert_eq!(before.stall(&no_sets), Some(Stall::Sampling));
        let not_handled = Progress {
            sampled: 35,
            ..before
        };
        assert_eq!(before.stall(&not_handled), Some(Stall::Application));
    }

    /// The sets stop after 1 s: the supervisor fed at boot and at each of the four looks that
    /// saw progress, then names the stall and never feeds again.
    #[test]
    fn the_supervisor_stops_feeding_when_the_sets_stop() {
        let board = HealthBoard::<NoopRawMutex>::new();
        let live = Liveness::new();
        let feeds = Cell::new(0);
        let now = Cell::new(0);
        let seen = Cell::new(None);
        let mut time = Path {
            now: &now,
            board: &board,
            live: &live,
            sets: 100,
            end: 5_000_000_000,
        };
        let mut watchdog = Counted(&feeds);
        let supervisor = supervisor_task(&board, &live, &mut watchdog, &mut time, |s| {
            seen.set(Some(s))
        });
        let until_end = async {
            while now.get() < 5_000_000_000 - CHECK_EVERY {
                embassy_futures::yield_now().await;
            }
        };
        let _ = embassy_futures::block_on(embassy_futures::select::select(supervisor, until_end));
        assert_eq!(seen.get(), Some(Stall::Sampling));
        assert_eq!(feeds.get(), 5);
    }
}
