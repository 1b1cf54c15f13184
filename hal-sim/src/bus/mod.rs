//! Simulated buses behind the embedded-hal 1.0 traits (blocking and async): the firmware's
//! drivers talk to the register models of [`crate::sensors`] through these exactly as through
//! a board's peripherals. Transfers take simulated time at the configured bus clock.
//!
//! - [`spi`]: an SPI bus with devices on chip selects ([`spi::SimSpiDevice`] implements
//!   `SpiDevice`).
//! - [`i2c`]: an I²C bus with devices on 7-bit addresses ([`i2c::SimI2cBus`] implements `I2c`).

pub mod i2c;
pub mod spi;
