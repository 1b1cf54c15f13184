//! # ballisto
//!
//! The ground tool of the ballistometer (docs/formats.md): the `ballisto` command line and its
//! jobs — `estimate` (estimator-core over a samples file), `sim` (a hal-sim scenario recorded by
//! the simulator's reader or by the firmware's tasks), `decode` (the spacecraft link's telemetry
//! stream back into an estimates file), `compare` — with the file formats they read and write
//! and the plots they draw. The simulation itself (motion, sensors, buses, scenarios, the
//! firmware host) is `hal-sim`'s.
#![deny(missing_docs)]

pub mod calibrate;
pub mod capture;
mod columns;
pub mod com;
pub mod compare;
mod decimal;
pub mod decode;
pub mod estimate;
pub mod estimates_csv;
pub mod exit;
pub mod output;
pub mod plausibility;
pub mod plot;
mod progress;
pub mod samples_csv;
pub mod sim;
pub mod tc;
pub mod text_input;
pub mod truth_csv;
