//! The firmware estimator's precomputation — the projections, forms and covariances of every
//! frame, built by estimator-core's `Projection::build` (an SVD per frame, in `f64`) — as plain
//! functions of the firmware's own estimator type.
//!
//! Generic code is compiled in the crate that first uses it with concrete types, at that
//! crate's optimisation level. `ballisto-fw` was built for speed for its per-sample path (now
//! only `ballisto-fw-estimate` is); called from there, the precomputation was built for speed
//! as well, although it runs once per configuration. Called through this crate (the flashed
//! profile's `opt-level = "z"`), it is built for size. Measured on the STM32H743 image: see the
//! README, "Budgets".
#![no_std]

use estimator_core::{
    Arrangement, ChannelMask, ConfigError, Estimator, Model, Options, SpareConfig,
};

/// Most channels of the firmware's arrangement.
pub const MAX_CHANNELS: usize = ballisto_link::ids::MAX_CHANNELS;

/// The firmware's estimator (f32 on target).
pub type FwEstimator = Estimator<f32, MAX_CHANNELS>;

/// [`Estimator::new`] for the firmware's estimator.
#[inline(never)]
pub fn new(
    arrangement: &Arrangement<MAX_CHANNELS>,
    model: Model,
    options: Options,
) -> Result<FwEstimator, ConfigError> {
    Estimator::new(arrangement, model, options)
}

/// [`Estimator::set_mask_in`] (the channels in use, in model F where they do not carry the
/// preferred model G); returns the model in force.
#[inline(never)]
pub fn set_mask_in(
    estimator: &mut FwEstimator,
    mask: ChannelMask,
    preferred: Model,
) -> Result<Model, ConfigError> {
    estimator.set_mask_in(mask, preferred)
}

/// The firmware's second configuration buffer.
pub type FwSpare = SpareConfig<f32, MAX_CHANNELS>;

/// [`Estimator::set_mask_keeping`] (the channels in use, in model F where they do not carry
/// the preferred model G, the configuration in force set aside in `spare`); returns the model
/// in force.
#[inline(never)]
pub fn set_mask_keeping(
    estimator: &mut FwEstimator,
    mask: ChannelMask,
    preferred: Model,
    spare: &mut FwSpare,
) -> Result<Model, ConfigError> {
    estimator.set_mask_keeping(mask, preferred, spare)
}

/// [`Estimator::configure_preferring`] (a new arrangement, model, mask and options; model F in
/// force where the mask does not carry model G); returns the model in force.
#[inline(never)]
pub fn configure_preferring(
    estimator: &mut FwEstimator,
    arrangement: &Arrangement<MAX_CHANNELS>,
    model: Model,
    mask: ChannelMask,
    options: Options,
) -> Result<Model, ConfigError> {
    estimator.configure_preferring(arrangement, model, mask, options)
}

/// [`SpareConfig::build`]: the precomputation of a configuration in the second buffer,
/// beside the estimator in force (the firmware's lower-priority builder task, issue 17);
/// returns the model built.
#[inline(never)]
pub fn build_spare(
    spare: &mut FwSpare,
    arrangement: &Arrangement<MAX_CHANNELS>,
    preferred: Model,
    mask: ChannelMask,
    options: Options,
) -> Result<Model, ConfigError> {
    spare.build(arrangement, preferred, mask, options)
}
