//! Simulated time shared by the buses and the sensors: bus transfers advance it by their
//! duration at the configured clock, so the cost of sampling is visible; sensors sample the
//! motion at their own ODR instants up to it.

use std::cell::Cell;
use std::rc::Rc;

/// A shared simulated clock in seconds (cheap to clone: every clone sees the same time).
#[derive(Clone, Debug, Default)]
pub struct SimClock(Rc<Cell<f64>>);

impl SimClock {
    /// A clock at `t = 0`.
    pub fn new() -> Self {
        Self::default()
    }

    /// A clock starting at `t` (e.g. before 0, so that start-up transactions are done when
    /// the record begins at 0).
    pub fn starting_at(t: f64) -> Self {
        SimClock(Rc::new(Cell::new(t)))
    }

    /// The current simulated time (s).
    pub fn now(&self) -> f64 {
        self.0.get()
    }

    /// Advances the time by `dt` seconds (negative or non-finite `dt` is ignored).
    pub fn advance(&self, dt: f64) {
        if dt.is_finite() && dt > 0.0 {
            self.0.set(self.0.get() + dt);
        }
    }

    /// Moves the time forward to `t` (never backwards).
    pub fn advance_to(&self, t: f64) {
        self.advance(t - self.now());
    }
}
