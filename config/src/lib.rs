//! # ballisto-config
//!
//! The configuration of a ballistometer on the host, in one place for every host crate and
//! for the boards' build scripts: the arrangement file ([`arrangement_file`]: what a user
//! writes and `ballisto calibrate` writes back), the one choice of model for an arrangement
//! ([`model_choice`]), the one builder of the firmware's configuration from an arrangement and
//! its parts ([`firmware_config`]), and the board file a board's `build.rs` turns into Rust
//! ([`board_file`]). The ground tool, the simulator and the boards make each of these
//! decisions through this crate, so that they cannot disagree.
#![deny(missing_docs)]

pub mod arrangement_file;
pub mod board_file;
pub mod firmware_config;
pub mod model_choice;
