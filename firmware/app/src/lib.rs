//! # firmware
//!
//! The ballistometer application, independent of the board: generic over the embedded-hal
//! (async) traits and two small traits of its own, [`time::TimeBase`] and
//! [`estimation::TelemetrySink`]. The data path, module by module:
//!
//! - [`drivers`] — the MEMS parts on their buses (sensor → driver).
//! - [`sampler`] — all parts at one rate on one time base, free-running parts aligned to the
//!   common instants (driver → sampler).
//! - [`estimation`] — estimator-core on every sample set, out to the telemetry sink
//!   (sampler → estimator → telemetry).
//! - [`config`] — what runs: parts, channels, rate, arrangement, model (built-in table or
//!   command); [`time`] — the time base.
//!
//! The tasks are async functions ([`sampler::sampling_task`], [`estimation::estimation_task`])
//! joined by a bounded queue; a board spawns them on the embassy executor, the host simulator
//! polls them in simulated time.
#![no_std]
#![deny(missing_docs)]
// `!(x >= y)` rejects NaN along with the out-of-range values: intentional.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod config;
pub mod drivers;
pub mod estimation;
pub mod sampler;
pub mod time;

/// Depth of the queue between the sampling and the estimation task.
pub const QUEUE: usize = 4;
