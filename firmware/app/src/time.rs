//! The firmware's time base: one monotonic clock in nanoseconds since boot for every
//! timestamp, and waiting until an instant. The board implements it on its timer (embassy-time
//! on the STM32H743, SysTick under QEMU); the host simulator implements it on simulated time.

use core::future::Future;

/// Nanoseconds since boot.
pub type Nanos = u64;

/// A monotonic clock that tasks can wait on.
pub trait TimeBase {
    /// The current time.
    fn now(&self) -> Nanos;

    /// Completes at `at` or later (at once if `at` has passed).
    fn wait_until(&mut self, at: Nanos) -> impl Future<Output = ()>;
}

/// Seconds from nanoseconds (for the estimator's time argument).
pub fn seconds(t: Nanos) -> f64 {
    t as f64 * 1e-9
}
