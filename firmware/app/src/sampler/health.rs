//! The sampler's health, published after every sample set for the housekeeping reports.

use core::cell::Cell;
use core::sync::atomic::{AtomicU32, Ordering};

use embassy_sync::blocking_mutex::raw::RawMutex;
use embassy_sync::blocking_mutex::Mutex;

use super::{LoopHealth, PartHealth};
use crate::config::MAX_PARTS;

/// A snapshot of every counter of the sampler.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Health {
    /// Per part slot (`None`: no part configured).
    pub parts: [Option<PartHealth>; MAX_PARTS],
    /// The loop's own counters.
    pub sampling: LoopHealth,
}

/// Where the sampling task leaves its latest [`Health`] for the application task, and how
/// many times it has (the watchdog's supervisor watches that count: the snapshot's own set
/// count saturates, this one wraps).
pub struct HealthBoard<M: RawMutex> {
    latest: Mutex<M, Cell<Health>>,
    published: AtomicU32,
}

impl<M: RawMutex> Default for HealthBoard<M> {
    fn default() -> Self {
        Self::new()
    }
}

impl<M: RawMutex> HealthBoard<M> {
    /// An empty board (every counter zero, no part).
    pub const fn new() -> Self {
        HealthBoard {
            latest: Mutex::new(Cell::new(Health {
                parts: [None; MAX_PARTS],
                sampling: LoopHealth {
                    sets: 0,
                    skipped: 0,
                    dropped: 0,
                    sync_errors: 0,
                },
            })),
            published: AtomicU32::new(0),
        }
    }

    /// Publishes a snapshot (the sampling task: once per set).
    pub fn publish(&self, health: Health) {
        self.latest.lock(|c| c.set(health));
        self.published.fetch_add(1, Ordering::Relaxed);
    }

    /// Snapshots published since the board was made (wrapping).
    pub fn published(&self) -> u32 {
        self.published.load(Ordering::Relaxed)
    }

    /// Copies the latest snapshot into `dst` (straight from the board: no intermediate copy
    /// of the 240-byte snapshot).
    pub fn latest_into(&self, dst: &mut Health) {
        self.latest.lock(|c| *dst = c.get());
    }
}
