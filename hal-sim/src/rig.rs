//! The simulated hardware of a scenario: the motion (one shared propagator), the simulated
//! clock, the buses with their parts attached at their chip selects or addresses, each part
//! seeing the specific force at its mount along its own axes, the SYNC line, and the faults.
//! What a controller gets is one [`Port`] per part: the bus handle it talks to.

use std::cell::RefCell;
use std::rc::Rc;

use crate::bus::i2c::SimI2cBus;
use crate::bus::spi::{SimSpiBus, SimSpiDevice};
use crate::clock::SimClock;
use crate::motion::Propagator;
use crate::scenario::{PartSpec, PartType, Scenario};
use crate::sensors::adxl355::Adxl355;
use crate::sensors::lis3dh::Lis3dh;
use crate::sensors::sync_line::SyncLine;
use crate::sensors::ForceSource;

/// Integration step of the truth (s).
pub const TRUTH_STEP: f64 = 1.0 / 800.0;
/// The simulated time at which the rig is powered (s): start-up transactions happen before
/// the record starts at 0.
pub const POWER_ON: f64 = -0.05;

/// How the controller reaches one part.
#[derive(Clone)]
pub enum Port {
    /// An SPI device (its chip select included).
    Spi(SimSpiDevice),
    /// An I²C bus and the part's 7-bit address.
    I2c(SimI2cBus, u8),
}

/// The hardware of a scenario.
pub struct Rig {
    /// Simulated time.
    pub clock: SimClock,
    /// The motion, shared with every part.
    pub truth: Rc<RefCell<Propagator>>,
    /// The SYNC line wired to every part that samples on it.
    pub sync: SyncLine,
    /// SPI buses by name.
    pub spi: Vec<(String, SimSpiBus)>,
    /// I²C buses by name.
    pub i2c: Vec<(String, SimI2cBus)>,
    /// One port per part, in scenario order.
    pub ports: Vec<Port>,
}

impl Rig {
    /// Builds the hardware of a scenario; errors name a part whose bus is not declared.
    pub fn build(sc: &Scenario) -> Result<Rig, String> {
        let clock = SimClock::starting_at(POWER_ON);
        let truth = Rc::new(RefCell::new(Propagator::new(sc.motion(), TRUTH_STEP)));
        let sync = SyncLine::new();
        let mut spi = Vec::new();
        let mut i2c = Vec::new();
        for b in &sc.buses {
            if b.kind == "spi" {
                spi.push((b.name.clone(), SimSpiBus::new(clock.clone(), b.clock_hz)));
            } else {
                i2c.push((b.name.clone(), SimI2cBus::new(clock.clone(), b.clock_hz)));
            }
        }
        let mut ports = Vec::new();
        for (index, p) in sc.parts.iter().enumerate() {
            let source = mount(&truth, p);
            let errors = sc.errors(index, p);
            let faults = sc.faults_of(&p.name);
            let port = match p.part {
                PartType::Adxl355 => {
                    let mut part = Adxl355::new(errors, source);
                    part.set_faults(faults.clone());
                    part.connect_sync(sync.clone());
                    let bus = find_bus(&spi, &p.bus, &p.name)?;
                    let cs = p.cs.unwrap_or(0);
                    let dev = bus.attach(cs, Box::new(part));
                    bus.set_faults(cs, &faults);
                    Port::Spi(dev)
                }
                PartType::Lis3dh => {
                    let mut part = Lis3dh::new(errors, source);
                    part.set_faults(faults.clone());
                    let bus = find_bus(&i2c, &p.bus, &p.name)?;
                    let address = p.address.unwrap_or(0x18);
                    bus.attach(address, Box::new(part));
                    bus.set_faults(address, &faults);
                    Port::I2c(bus.clone(), address)
                }
            };
            ports.push(port);
        }
        Ok(Rig {
            clock,
            truth,
            sync,
            spi,
            i2c,
            ports,
        })
    }

    /// Bus usage since an earlier [`Rig::bus_usage`] (e.g. the start-up's end).
    pub fn bus_usage_since(&self, earlier: &[(String, u64, f64)]) -> Vec<(String, u64, f64)> {
        self.bus_usage()
            .into_iter()
            .zip(earlier.iter())
            .map(|((n, b, t), (_, b0, t0))| (n, b - b0, t - t0))
            .collect()
    }

    /// Bus usage so far: `(bus name, bytes, busy seconds)`.
    pub fn bus_usage(&self) -> Vec<(String, u64, f64)> {
        let spi = self.spi.iter().map(|(n, b)| (n, b.usage()));
        let i2c = self.i2c.iter().map(|(n, b)| (n, b.usage()));
        spi.chain(i2c)
            .map(|(n, (bytes, busy))| (n.clone(), bytes, busy))
            .collect()
    }
}

fn find_bus<'a, B>(buses: &'a [(String, B)], bus: &str, part: &str) -> Result<&'a B, String> {
    buses
        .iter()
        .find(|(n, _)| n == bus)
        .map(|(_, b)| b)
        .ok_or_else(|| format!("part \"{part}\": no bus \"{bus}\" of its kind"))
}

/// The specific force a part measures along its own axes where it really sits: paper eq. (4)
/// at the nominal position plus its `position_error`, for each axis `s_k` = column k of its
/// orientation turned by its `orientation_error`.
fn mount(truth: &Rc<RefCell<Propagator>>, p: &PartSpec) -> ForceSource {
    let truth = truth.clone();
    let position = p.true_position();
    let axes = [0, 1, 2].map(|k| p.true_axis(k));
    Box::new(move |t| {
        let tr = truth.borrow_mut().truth_at(t);
        axes.map(|s| tr.channel(&position, &s))
    })
}
