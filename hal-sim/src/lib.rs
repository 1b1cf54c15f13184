//! # hal-sim
//!
//! Host simulation for the ballistometer: rigid-body motion (truth), arrangement families, the
//! file formats of interfaces.md, and the host binary `ballisto`; register-level sensor models
//! ([`sensors`]) on simulated buses ([`bus`]) in simulated time ([`clock`]).
#![deny(missing_docs)]

pub mod arrangement_file;
pub mod bench;
pub mod bus;
pub mod clock;
pub mod compare;
pub mod decode;
pub mod estimates_csv;
pub mod families;
pub mod faults;
pub mod firmware_host;
pub mod motion;
pub mod noise;
pub mod plot;
pub mod rig;
pub mod run;
pub mod samples_csv;
pub mod scenario;
pub mod sensors;
pub mod sim;
