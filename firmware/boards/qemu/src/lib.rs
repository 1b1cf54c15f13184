//! The QEMU board's built-in scenario, for a board without accelerometers: what the QEMU
//! mps2-an386 board runs in CI in place of parts and a ground segment, and what the host
//! recomputes to check it (`tests/tests/builtin_scenario.rs`). Not part of the application
//! (`ballisto-fw`): the board wires it to the application's tasks as another board wires
//! its parts.
//!
//! - [`synthetic`] — sample sets computed from a known motion (a part can be silenced or stuck);
//! - [`demo`] — the scenario: its two boots, the parts as mounted, the scripted uplink;
//! - [`tumble`] — the torque-free tumble: identification without a reference, its two boots.
#![no_std]
#![deny(missing_docs)]

pub mod demo;
pub mod synthetic;
pub mod tumble;
