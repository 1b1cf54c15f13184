//! # firmware
//!
//! The ballistometer application, independent of the board: generic over the embedded-hal
//! (async) traits. The data path, module by module:
//!
//! - [`drivers`] — the MEMS parts on their buses (sensor → driver).
#![no_std]
#![deny(missing_docs)]

pub mod drivers;
