//! A simulated I²C bus: several targets on 7-bit addresses, the embedded-hal 1.0 transaction
//! contract (adjacent operations of one kind merge; a change of direction is a repeated START
//! with the address), and the time it takes at the bus clock: 9 bit times per byte (8 + ACK)
//! including the address byte of every (repeated) START, plus one bit time each for START and
//! STOP. Connection faults ([`crate::faults`]) scheduled per address: a dead part does not
//! acknowledge its address, corruption flips bits of the bytes read, a timeout (a target
//! holding SCL low) stalls the transaction and fails it.

use std::cell::RefCell;
use std::rc::Rc;

use embedded_hal::i2c::{ErrorKind, ErrorType, NoAcknowledgeSource, Operation};

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::Connection;
use crate::clock::SimClock;
use crate::faults::Fault;

/// A device on the bus, seen between START and STOP.
pub trait I2cTarget {
    /// (Repeated) START addressed to this target at simulated time `now`; `read` is the R/W
    /// bit. Returns whether the target acknowledges its address.
    fn start(&mut self, now: f64, read: bool) -> bool;
    /// A byte written by the controller; returns ACK.
    fn write(&mut self, byte: u8) -> bool;
    /// A byte read by the controller.
    fn read(&mut self) -> u8;
    /// STOP.
    fn stop(&mut self);
}

/// Errors of the simulated bus, as the driver sees them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SimI2cError {
    /// Nothing acknowledged the address.
    AddressNack {
        /// The 7-bit address.
        address: u8,
    },
    /// The target did not acknowledge a data byte.
    DataNack {
        /// The 7-bit address.
        address: u8,
    },
    /// SCL was held low past the controller's timeout.
    Timeout {
        /// The 7-bit address.
        address: u8,
    },
}

impl core::fmt::Display for SimI2cError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SimI2cError::AddressNack { address } => {
                write!(f, "no acknowledge from I²C address {address:#04x}")
            }
            SimI2cError::DataNack { address } => {
                write!(
                    f,
                    "I²C device {address:#04x} did not acknowledge a data byte"
                )
            }
            SimI2cError::Timeout { address } => {
                write!(f, "I²C transaction with {address:#04x} timed out")
            }
        }
    }
}

impl std::error::Error for SimI2cError {}

impl embedded_hal::i2c::Error for SimI2cError {
    fn kind(&self) -> ErrorKind {
        match self {
            SimI2cError::AddressNack { .. } => {
                ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address)
            }
            SimI2cError::DataNack { .. } => ErrorKind::NoAcknowledge(NoAcknowledgeSource::Data),
            SimI2cError::Timeout { .. } => ErrorKind::Other,
        }
    }
}

struct Slot {
    address: u8,
    target: Box<dyn I2cTarget>,
    faults: Vec<Fault>,
}

struct Bus {
    clock: SimClock,
    hz: f64,
    slots: Vec<Slot>,
    bytes: u64,
    busy: f64,
    /// Draws of byte corruption.
    rng: ChaCha8Rng,
}

/// A simulated I²C bus (cheap to clone; clones share the bus). Implements the embedded-hal
/// `I2c` traits (blocking and async) with 7-bit addresses.
#[derive(Clone)]
pub struct SimI2cBus(Rc<RefCell<Bus>>);

impl SimI2cBus {
    /// A bus clocked at `hz` (e.g. 400 kHz) on the simulated `clock`.
    pub fn new(clock: SimClock, hz: f64) -> Self {
        SimI2cBus(Rc::new(RefCell::new(Bus {
            clock,
            hz,
            slots: Vec::new(),
            bytes: 0,
            busy: 0.0,
            rng: ChaCha8Rng::seed_from_u64(0x12C),
        })))
    }

    /// Connects `target` at the 7-bit `address` (replacing what was there).
    pub fn attach(&self, address: u8, target: Box<dyn I2cTarget>) {
        let mut b = self.0.borrow_mut();
        b.slots.retain(|s| s.address != address);
        b.slots.push(Slot {
            address,
            target,
            faults: Vec::new(),
        });
    }

    /// Schedules connection faults (dead, corrupt, timeout) at `address`; measurement faults
    /// in the list are ignored here (they belong to the part).
    pub fn set_faults(&self, address: u8, faults: &[Fault]) {
        let mut b = self.0.borrow_mut();
        if let Some(slot) = b.slots.iter_mut().find(|s| s.address == address) {
            slot.faults = faults.iter().filter(|f| f.kind.on_bus()).cloned().collect();
        }
    }

    /// Bytes on the bus so far (address bytes included) and the time it was busy (s).
    pub fn usage(&self) -> (u64, f64) {
        let b = self.0.borrow();
        (b.bytes, b.busy)
    }

    fn transaction(&self, address: u8, ops: &mut [Operation<'_>]) -> Result<(), SimI2cError> {
        let mut guard = self.0.borrow_mut();
        let bus = &mut *guard;
        let t0 = bus.clock.now();
        let slot = bus.slots.iter_mut().find(|s| s.address == address);
        let conn = slot
            .as_ref()
            .map_or_else(Connection::default, |s| Connection::at(&s.faults, t0));
        let mut wire = Wire {
            clock: bus.clock.clone(),
            bit: 1.0 / bus.hz,
            address,
            conn,
            rng: &mut bus.rng,
        };
        let mut bytes = 0u64;
        let mut target = slot.filter(|_| !conn.dead).map(|s| s.target.as_mut());
        let result = match (conn.stall, target.as_deref_mut()) {
            (Some(stall), _) => {
                // START, the address, then SCL held low until the controller gives up.
                wire.start_and_address(&mut bytes);
                wire.clock.advance(stall);
                Err(SimI2cError::Timeout { address })
            }
            (None, Some(t)) => wire.run(t, ops, &mut bytes),
            (None, None) if ops.is_empty() => Ok(()),
            (None, None) => {
                // START and an address byte nobody acknowledges.
                wire.start_and_address(&mut bytes);
                Err(SimI2cError::AddressNack { address })
            }
        };
        // STOP, also after an error (the controller releases the bus).
        wire.clock.advance(wire.bit);
        if let Some(t) = target {
            t.stop();
        }
        bus.bytes += bytes;
        bus.busy += bus.clock.now() - t0;
        result
    }
}

/// One transaction's view of the bus: its time base, bit time, address and connection faults.
struct Wire<'a> {
    clock: SimClock,
    bit: f64,
    address: u8,
    conn: Connection,
    rng: &'a mut ChaCha8Rng,
}

impl Wire<'_> {
    /// A (repeated) START and the address byte.
    fn start_and_address(&self, bytes: &mut u64) {
        self.clock.advance(self.bit);
        *bytes += 1;
        self.clock.advance(9.0 * self.bit);
    }

    /// The operations between START and STOP with `target` addressed: adjacent operations of
    /// one kind merge, a change of direction is a repeated START.
    fn run(
        &mut self,
        target: &mut dyn I2cTarget,
        ops: &mut [Operation<'_>],
        bytes: &mut u64,
    ) -> Result<(), SimI2cError> {
        let address = self.address;
        let mut dir: Option<bool> = None;
        for op in ops.iter_mut() {
            let read = matches!(op, Operation::Read(_));
            if dir != Some(read) {
                self.start_and_address(bytes);
                if !target.start(self.clock.now(), read) {
                    return Err(SimI2cError::AddressNack { address });
                }
                dir = Some(read);
            }
            match op {
                Operation::Read(buf) => {
                    for b in buf.iter_mut() {
                        *b = self.conn.receive(target.read(), self.rng);
                        *bytes += 1;
                        self.clock.advance(9.0 * self.bit);
                    }
                }
                Operation::Write(buf) => {
                    for b in buf.iter() {
                        *bytes += 1;
                        self.clock.advance(9.0 * self.bit);
                        if !target.write(*b) {
                            return Err(SimI2cError::DataNack { address });
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

impl ErrorType for SimI2cBus {
    type Error = SimI2cError;
}

impl embedded_hal::i2c::I2c for SimI2cBus {
    fn transaction(
        &mut self,
        address: u8,
        operations: &mut [Operation<'_>],
    ) -> Result<(), Self::Error> {
        SimI2cBus::transaction(self, address, operations)
    }
}

impl embedded_hal_async::i2c::I2c for SimI2cBus {
    async fn transaction(
        &mut self,
        address: u8,
        operations: &mut [Operation<'_>],
    ) -> Result<(), Self::Error> {
        SimI2cBus::transaction(self, address, operations)
    }
}
