//! The accelerometers' drivers the application samples: the crates `adxl355` (SPI) and
//! `lis3dh` (I²C) of this repository (`drivers/`), generic over embedded-hal-async, which
//! depend on nothing of the application.

pub use adxl355;
pub use lis3dh;

/// Standard gravity, m/s², in the drivers' scalar (estimator-core's `G0`).
pub const G0: f32 = estimator_core::G0 as f32;

// The drivers convert the datasheets' sensitivities per g with the estimator's standard gravity.
const _: () = assert!(adxl355::STANDARD_GRAVITY == G0 && lis3dh::STANDARD_GRAVITY == G0);
