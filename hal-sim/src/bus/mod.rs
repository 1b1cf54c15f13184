//! Simulated buses behind the embedded-hal 1.0 traits (blocking and async): the firmware's
//! drivers talk to the register models of [`crate::sensors`] through these exactly as through
//! a board's peripherals. Transfers take simulated time at the configured bus clock.
//!
//! - [`spi`]: an SPI bus with devices on chip selects ([`spi::SimSpiDevice`] implements
//!   `SpiDevice`).
//! - [`i2c`]: an I²C bus with devices on 7-bit addresses ([`i2c::SimI2cBus`] implements `I2c`).

pub mod i2c;
pub mod spi;

use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::faults::{active_at, Fault, FaultKind};

/// The connection faults of one bus slot active at the start of a transaction.
#[derive(Clone, Copy, Debug, Default)]
struct Connection {
    /// The part does not answer.
    dead: bool,
    /// Probability that a byte read has a bit flipped.
    corrupt: f64,
    /// The transaction stalls this long and fails.
    stall: Option<f64>,
}

impl Connection {
    /// The faults of `faults` active at `t` (measurement faults are not the bus's).
    fn at(faults: &[Fault], t: f64) -> Self {
        let mut c = Connection::default();
        for kind in active_at(faults, t) {
            match kind {
                FaultKind::Dead => c.dead = true,
                FaultKind::Corrupt { probability } => c.corrupt = *probability,
                FaultKind::Timeout { stall } => c.stall = Some(*stall),
                _ => {}
            }
        }
        c
    }

    /// One byte as the controller receives it: a random bit flipped with the corruption
    /// probability.
    fn receive(&self, byte: u8, rng: &mut ChaCha8Rng) -> u8 {
        if self.corrupt > 0.0 && rng.gen_bool(self.corrupt.min(1.0)) {
            byte ^ (1 << rng.gen_range(0..8))
        } else {
            byte
        }
    }
}
