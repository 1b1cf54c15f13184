//! The firmware estimator's per-sample estimate ([`Estimator::update`]) as a plain function of
//! its type, so that it is compiled here, at the flashed profile's speed level
//! (`opt-level = 3`), while the application crate that calls it is built for size.
//!
//! Generic code is compiled in the crate that first uses it with concrete types, at that
//! crate's optimisation level (the precomputation crate does the opposite for the same
//! reason). Measured on the STM32H743 image: with the whole application crate built for speed
//! the image was 124 320 B; with only this function built for speed and the rest for size,
//! 105 352 B (README, "Budgets"). `cargo qemu-bench` counts the same per-sample path (its own
//! instantiation, built for speed as this one).
#![no_std]

pub use ballisto_fw_precompute::FwEstimator;
use estimator_core::Estimate;

/// [`Estimator::update`] for the firmware's estimator: the estimate of the sample `p` at time
/// `t` (s). Out of line, so that the per-sample path stays here, built for speed.
///
/// [`Estimator::update`]: estimator_core::Estimator::update
#[inline(never)]
pub fn update<'a>(estimator: &'a mut FwEstimator, t: f64, p: &[f32]) -> &'a Estimate<f32> {
    estimator.update(t, p)
}
