//! Drivers of the accelerometers, generic over embedded-hal-async `SpiDevice` / `I2c`. Each
//! has the same layout: `registers` (addresses and bit fields from the datasheet), the types of
//! its configuration, one error enum, and the driver (identify, configure, burst-read, convert
//! to m/s² with the part's exact scale).
//!
//! Why not existing crates: `adxl355` (0.2) is embedded-hal 0.2, blocking, with board features;
//! `lis3dh-async` (0.9) is async but returns the `accelerometer` crate's types in g with its
//! own configuration set and no plausibility check of the data bytes; neither exposes the
//! ADXL355 external sync and FIFO markers we need. Two small drivers in one style serve better.

pub mod adxl355;
pub mod lis3dh;

/// Standard gravity, m/s², in the drivers' scalar (estimator-core's `G0`).
pub const G0: f32 = estimator_core::G0 as f32;
