//! # hal-sim
//!
//! Host simulation of the ballistometer: rigid-body motion (truth, [`motion`]), register-level
//! sensor models ([`sensors`]) on simulated buses ([`bus`]) in simulated time ([`clock`]) with
//! injected [`faults`], the hardware of a [`scenario`] ([`rig`]), the simulator's own reader
//! ([`bench`], [`recorder`]), ideal channel outputs ([`ideal`]), and the firmware's tasks run on
//! the simulated buses ([`firmware_host`]). A scenario's parts are described in the
//! arrangement file format of `ballisto-config`. The ground tool `ballisto` is its own crate.
#![deny(missing_docs)]

pub mod bench;
pub mod bus;
pub mod clock;
pub mod faults;
pub mod firmware_host;
pub mod ideal;
pub mod in_flight;
pub mod motion;
pub mod recorder;
pub mod reference;
pub mod rig;
pub mod scenario;
pub mod sensors;
