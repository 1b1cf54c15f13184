//! # ballisto-fw
//!
//! The ballistometer application, independent of the board: generic over the embedded-hal
//! (async) traits, embedded-io-async for the spacecraft link, and one small trait of its own,
//! [`time::TimeBase`]. The data path, module by module:
//!
//! - [`drivers`] — the MEMS parts on their buses (sensor → driver).
//! - [`sampler`] — all parts at one rate on one time base, free-running parts aligned to the
//!   common instants, health counters on a board (driver → sampler).
//! - [`estimation`] — estimator-core on every sample set, automatic and commanded channel
//!   exclusion (sampler → estimator).
//! - [`identification`] — identification in flight (paper §6): sample sets and a reference
//!   rate into estimator-core's sums, solved on command (estimator → identification).
//! - [`app`] — the application task: estimates, housekeeping and events out as telemetry,
//!   telecommands in, mode (estimator → telemetry).
//! - [`telemetry`] — the downlink writer: PUS packets (the layouts are `ballisto_link`'s, shared
//!   with the ground), CCSDS sequence counts, COBS framing on the link. Telecommand acceptance
//!   is `ballisto_link::telecommand`.
//! - [`boot`] — the boot count the board keeps across resets (housekeeping, reset event).
//! - [`config`] — what runs: parts, channels, rate, arrangement, model (built-in table or
//!   command); [`time`] — the time base; [`calstore`] — calibration records in flash;
//!   [`storage`] — the task that commits a calibration to them (app → storage);
//!   [`supervisor`] — feeds the board's watchdog while the data path makes progress.
//!
//! The tasks are async functions ([`sampler::sampling_task`], [`app::app_task`],
//! [`app::uplink_task`]) joined by bounded queues; a board spawns them on the embassy
//! executor, the host simulator polls them in simulated time.
#![no_std]
#![deny(missing_docs)]
// `!(x >= y)` rejects NaN along with the out-of-range values: intentional.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

// The logging macros first: the modules below use them.
mod fmt;

pub mod app;
pub mod boot;
/// Calibration records in flash (its own crate: `firmware/calstore`).
pub use ballisto_calstore as calstore;
pub mod config;
pub mod drivers;
pub mod estimation;
pub mod identification;
pub mod isolation;
pub mod sampler;
pub mod storage;
pub mod supervisor;
pub mod telemetry;
pub mod time;

/// Depth of the queue between the sampling and the estimation task: the sets the application
/// task may fall behind before one is lost. Its longest hold is the identification's solve on
/// TC[200,10] (1.5 M instructions on the M7, ≈ 4 ms: four sets at 1 kHz; 31 M on the QEMU
/// board's M4F) and a reference batch moving its sets into the sums (≈ 0.8 M on the M4F).
pub const QUEUE: usize = 16;
