//! The simulator's bench reader: the minimal controller software `ballisto sim` uses to
//! identify, configure and read each part through its bus, with the published driver crates
//! (`adxl355`, `lis3dh`) — nothing taken from the register models directly, which stay
//! independent of the drivers and so check them. The simulated buses are ready at once, so
//! each driver call is run to completion where it is made (`embassy_futures::block_on`).

use embassy_futures::block_on;

use crate::bus::i2c::SimI2cBus;
use crate::bus::spi::SimSpiDevice;
use crate::rig::Port;
use crate::scenario::{PartType, Scenario};

/// What went wrong with one part.
#[derive(Clone, Debug, PartialEq)]
pub enum BenchError {
    /// The bus reported an error, or a transfer read bits the part never sets.
    Bus(String),
    /// The identification registers did not hold the part's IDs.
    WrongId {
        /// What was read.
        read: Vec<u8>,
    },
}

impl std::fmt::Display for BenchError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BenchError::Bus(e) => write!(f, "bus error: {e}"),
            BenchError::WrongId { read } => write!(f, "wrong device ID {read:02x?}"),
        }
    }
}

impl<E: std::fmt::Debug> From<adxl355::Error<E>> for BenchError {
    fn from(e: adxl355::Error<E>) -> Self {
        match e {
            adxl355::Error::WrongId(id) => BenchError::WrongId { read: id.to_vec() },
            e => BenchError::Bus(format!("{e:?}")),
        }
    }
}

impl<E: std::fmt::Debug> From<lis3dh::Error<E>> for BenchError {
    fn from(e: lis3dh::Error<E>) -> Self {
        match e {
            lis3dh::Error::WrongId(id) => BenchError::WrongId { read: vec![id] },
            e => BenchError::Bus(format!("{e:?}")),
        }
    }
}

/// One part through its driver.
enum BenchPart {
    Adxl355(adxl355::Adxl355<SimSpiDevice>),
    Lis3dh(lis3dh::Lis3dh<SimI2cBus>),
}

/// Reads every part of a scenario, and counts.
pub struct BenchReader {
    parts: Vec<BenchPart>,
    /// Reads per part.
    pub reads: Vec<u64>,
    /// Failed reads per part.
    pub errors: Vec<u64>,
}

impl BenchReader {
    /// Identifies and configures each part (range, ODR, sync, measurement on); the first
    /// failure names the part.
    pub fn start(sc: &Scenario, ports: &[Port]) -> Result<Self, String> {
        let mut parts = Vec::new();
        for (p, port) in sc.parts.iter().zip(ports.iter()) {
            let range = sc.range_g(p);
            let odr = sc.odr(p) as f32;
            let part = match (port.clone(), p.part) {
                (Port::Spi(dev), PartType::Adxl355) => {
                    let config = adxl355::Config {
                        range: match range {
                            2 => adxl355::Range::G2,
                            4 => adxl355::Range::G4,
                            _ => adxl355::Range::G8,
                        },
                        odr: adxl355::Odr::at_least(odr),
                        sync: if sc.sync(p) {
                            adxl355::Sync::External
                        } else {
                            adxl355::Sync::Internal
                        },
                    };
                    block_on(adxl355::Adxl355::new(dev, config))
                        .map(BenchPart::Adxl355)
                        .map_err(BenchError::from)
                }
                (Port::I2c(bus, address), PartType::Lis3dh) => {
                    let config = lis3dh::Config {
                        range: match range {
                            2 => lis3dh::Range::G2,
                            4 => lis3dh::Range::G4,
                            8 => lis3dh::Range::G8,
                            _ => lis3dh::Range::G16,
                        },
                        odr: lis3dh::Odr::at_least(odr),
                        fifo: false,
                    };
                    block_on(lis3dh::Lis3dh::new(bus, address, config))
                        .map(BenchPart::Lis3dh)
                        .map_err(BenchError::from)
                }
                _ => Err(BenchError::Bus(
                    "part type and bus kind do not match".into(),
                )),
            }
            .map_err(|e| format!("part \"{}\" at start-up: {e}", p.name))?;
            parts.push(part);
        }
        let n = parts.len();
        Ok(BenchReader {
            parts,
            reads: vec![0; n],
            errors: vec![0; n],
        })
    }

    /// Reads part `i`'s temperature (°C, as its driver gives it).
    pub fn read_temperature(&mut self, i: usize) -> Result<f64, BenchError> {
        self.reads[i] += 1;
        let r = match &mut self.parts[i] {
            BenchPart::Adxl355(d) => block_on(d.read_temperature()).map_err(BenchError::from),
            BenchPart::Lis3dh(d) => block_on(d.read_temperature()).map_err(BenchError::from),
        };
        if r.is_err() {
            self.errors[i] += 1;
        }
        r.map(f64::from)
    }

    /// Reads part `i` (m/s², part axes).
    pub fn read(&mut self, i: usize) -> Result<[f64; 3], BenchError> {
        self.reads[i] += 1;
        let r = match &mut self.parts[i] {
            BenchPart::Adxl355(d) => block_on(d.read_acceleration()).map_err(BenchError::from),
            BenchPart::Lis3dh(d) => block_on(d.read_acceleration()).map_err(BenchError::from),
        };
        if r.is_err() {
            self.errors[i] += 1;
        }
        r.map(|v| v.map(f64::from))
    }
}
