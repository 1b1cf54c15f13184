//! # hal-sim
//!
//! Host simulation for the ballistometer: rigid-body motion (truth), arrangement families, the
//! file formats of interfaces.md, and the host binary `ballisto`.
#![deny(missing_docs)]

pub mod arrangement_file;
pub mod compare;
pub mod estimates_csv;
pub mod families;
pub mod motion;
pub mod noise;
pub mod run;
pub mod samples_csv;
