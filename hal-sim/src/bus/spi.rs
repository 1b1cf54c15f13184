//! A simulated SPI bus: several targets on chip selects, full duplex byte exchange, and the
//! time each transaction takes at the bus clock (8 bit times per byte plus the chip-select
//! setup and hold). Connection faults ([`crate::faults`]) scheduled per chip select: a dead
//! part leaves MISO high (every byte reads 0xFF), corruption flips bits of the bytes read, a
//! timeout stalls the transaction and fails it.

use std::cell::RefCell;
use std::rc::Rc;

use embedded_hal::spi::{ErrorKind, ErrorType, Operation};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::Connection;
use crate::clock::SimClock;
use crate::faults::Fault;

/// A device on the bus, seen byte by byte while its chip select is low.
pub trait SpiTarget {
    /// Chip select asserted at simulated time `now` (s).
    fn select(&mut self, now: f64);
    /// One byte clocked: `mosi` in, the returned byte out on MISO.
    fn exchange(&mut self, mosi: u8) -> u8;
    /// Chip select released.
    fn deselect(&mut self);
}

/// Errors of the simulated bus, as the driver sees them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SimSpiError {
    /// Nothing is connected on this chip select.
    NoDevice {
        /// The chip select.
        cs: usize,
    },
    /// The transaction did not complete in time (the controller gave up).
    Timeout {
        /// The chip select.
        cs: usize,
    },
}

impl core::fmt::Display for SimSpiError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SimSpiError::NoDevice { cs } => write!(f, "no SPI device on chip select {cs}"),
            SimSpiError::Timeout { cs } => {
                write!(f, "SPI transaction on chip select {cs} timed out")
            }
        }
    }
}

impl std::error::Error for SimSpiError {}

impl embedded_hal::spi::Error for SimSpiError {
    fn kind(&self) -> ErrorKind {
        match self {
            SimSpiError::NoDevice { .. } => ErrorKind::ChipSelectFault,
            SimSpiError::Timeout { .. } => ErrorKind::Other,
        }
    }
}

/// Chip-select setup plus hold time, in bit times, added to every transaction.
const CS_OVERHEAD_BITS: f64 = 2.0;

struct Slot {
    target: Box<dyn SpiTarget>,
    faults: Vec<Fault>,
}

struct Bus {
    clock: SimClock,
    hz: f64,
    slots: Vec<Option<Slot>>,
    bytes: u64,
    busy: f64,
    /// Draws of byte corruption.
    rng: ChaCha8Rng,
}

/// A simulated SPI bus (cheap to clone; clones share the bus).
#[derive(Clone)]
pub struct SimSpiBus(Rc<RefCell<Bus>>);

impl SimSpiBus {
    /// A bus clocked at `hz` on the simulated `clock`.
    pub fn new(clock: SimClock, hz: f64) -> Self {
        SimSpiBus(Rc::new(RefCell::new(Bus {
            clock,
            hz,
            slots: Vec::new(),
            bytes: 0,
            busy: 0.0,
            rng: ChaCha8Rng::seed_from_u64(0x5B1),
        })))
    }

    /// Connects `target` on chip select `cs` (replacing what was there) and returns the
    /// driver-side device for it.
    pub fn attach(&self, cs: usize, target: Box<dyn SpiTarget>) -> SimSpiDevice {
        let mut b = self.0.borrow_mut();
        if b.slots.len() <= cs {
            b.slots.resize_with(cs + 1, || None);
        }
        b.slots[cs] = Some(Slot {
            target,
            faults: Vec::new(),
        });
        SimSpiDevice {
            bus: self.clone(),
            cs,
        }
    }

    /// The driver-side device on chip select `cs` (errors on use if nothing is attached).
    pub fn device(&self, cs: usize) -> SimSpiDevice {
        SimSpiDevice {
            bus: self.clone(),
            cs,
        }
    }

    /// Schedules connection faults (dead, corrupt, timeout) on chip select `cs`; measurement
    /// faults in the list are ignored here (they belong to the part). Nothing happens if no
    /// part is attached there.
    pub fn set_faults(&self, cs: usize, faults: &[Fault]) {
        if let Some(Some(slot)) = self.0.borrow_mut().slots.get_mut(cs) {
            slot.faults = faults.iter().filter(|f| f.kind.on_bus()).cloned().collect();
        }
    }

    /// Bytes exchanged so far and the time the bus was busy (s).
    pub fn usage(&self) -> (u64, f64) {
        let b = self.0.borrow();
        (b.bytes, b.busy)
    }

    fn transaction(&self, cs: usize, ops: &mut [Operation<'_, u8>]) -> Result<(), SimSpiError> {
        let mut guard = self.0.borrow_mut();
        let bus = &mut *guard;
        let bit = 1.0 / bus.hz;
        let clock = bus.clock.clone();
        let Some(Some(slot)) = bus.slots.get_mut(cs) else {
            return Err(SimSpiError::NoDevice { cs });
        };
        let t0 = clock.now();
        let conn = Connection::at(&slot.faults, t0);
        let dead = conn.dead;
        if let Some(s) = conn.stall {
            clock.advance(s);
            bus.busy += s;
            return Err(SimSpiError::Timeout { cs });
        }
        let target = &mut slot.target;
        let rng = &mut bus.rng;
        clock.advance(CS_OVERHEAD_BITS * 0.5 * bit);
        if !dead {
            target.select(clock.now());
        }
        // One byte on the wires: a dead part leaves MISO pulled high.
        let mut exchange = |mosi: u8| {
            let miso = if dead { 0xFF } else { target.exchange(mosi) };
            conn.receive(miso, rng)
        };
        let mut bytes = 0u64;
        for op in ops.iter_mut() {
            match op {
                Operation::Read(buf) => {
                    for b in buf.iter_mut() {
                        *b = exchange(0x00);
                    }
                    bytes += buf.len() as u64;
                }
                Operation::Write(buf) => {
                    for b in buf.iter() {
                        exchange(*b);
                    }
                    bytes += buf.len() as u64;
                }
                Operation::Transfer(read, write) => {
                    let n = read.len().max(write.len());
                    for i in 0..n {
                        let miso = exchange(write.get(i).copied().unwrap_or(0x00));
                        if let Some(r) = read.get_mut(i) {
                            *r = miso;
                        }
                    }
                    bytes += n as u64;
                }
                Operation::TransferInPlace(buf) => {
                    for b in buf.iter_mut() {
                        *b = exchange(*b);
                    }
                    bytes += buf.len() as u64;
                }
                Operation::DelayNs(ns) => clock.advance(f64::from(*ns) * 1e-9),
            }
        }
        clock.advance(bytes as f64 * 8.0 * bit + CS_OVERHEAD_BITS * 0.5 * bit);
        if !dead {
            slot.target.deselect();
        }
        bus.bytes += bytes;
        bus.busy += clock.now() - t0;
        Ok(())
    }
}

/// One device on a [`SimSpiBus`]: implements the embedded-hal `SpiDevice` traits (blocking
/// and async), chip select handled per transaction.
#[derive(Clone)]
pub struct SimSpiDevice {
    bus: SimSpiBus,
    cs: usize,
}

impl ErrorType for SimSpiDevice {
    type Error = SimSpiError;
}

impl embedded_hal::spi::SpiDevice for SimSpiDevice {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), Self::Error> {
        self.bus.transaction(self.cs, operations)
    }
}

impl embedded_hal_async::spi::SpiDevice for SimSpiDevice {
    async fn transaction(
        &mut self,
        operations: &mut [Operation<'_, u8>],
    ) -> Result<(), Self::Error> {
        self.bus.transaction(self.cs, operations)
    }
}
