//! The simulator's own bench reader: the minimal controller software `ballisto sim` uses to
//! identify, configure and read each part through its bus — register by register, as a driver
//! does, with nothing taken from the models directly. (The firmware's drivers are separate;
//! this one only produces the reference record.)

use embedded_hal::i2c::I2c;
use embedded_hal::spi::{Operation, SpiDevice};

use crate::rig::Port;
use crate::scenario::{PartType, Scenario};
use crate::sensors::{adxl355, lis3dh};

/// What went wrong with one part.
#[derive(Clone, Debug, PartialEq)]
pub enum BenchError {
    /// The bus reported an error.
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

/// One part as the bench reader sees it.
struct BenchPart {
    kind: PartType,
    port: Port,
    /// m/s² per count of the output.
    lsb: f64,
}

/// Reads every part of a scenario, and counts.
pub struct BenchReader {
    parts: Vec<BenchPart>,
    /// Reads per part.
    pub reads: Vec<u64>,
    /// Failed reads per part.
    pub errors: Vec<u64>,
}

fn bus<E: std::fmt::Debug>(e: E) -> BenchError {
    BenchError::Bus(format!("{e:?}"))
}

impl BenchReader {
    /// Identifies and configures each part (range, ODR, sync, measurement on); the first
    /// failure names the part.
    pub fn start(sc: &Scenario, ports: &[Port]) -> Result<Self, String> {
        let mut parts = Vec::new();
        for (p, port) in sc.parts.iter().zip(ports.iter()) {
            let range = sc.range_g(p);
            let mut part = BenchPart {
                kind: p.part,
                port: port.clone(),
                lsb: p.part.lsb(range),
            };
            part.configure(range, sc.odr(p), sc.sync(p))
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

    /// Reads part `i`'s temperature (°C: the ADXL355's with its nominal intercept and slope,
    /// the LIS3DH's as 25 °C + its relative digits), as the firmware's drivers do.
    pub fn read_temperature(&mut self, i: usize) -> Result<f64, BenchError> {
        self.reads[i] += 1;
        let r = self.parts[i].read_temperature();
        if r.is_err() {
            self.errors[i] += 1;
        }
        r
    }

    /// Reads part `i` (m/s², part axes).
    pub fn read(&mut self, i: usize) -> Result<[f64; 3], BenchError> {
        self.reads[i] += 1;
        let r = self.parts[i].read();
        if r.is_err() {
            self.errors[i] += 1;
        }
        r
    }
}

impl BenchPart {
    fn configure(&mut self, range_g: u32, odr: f64, sync: bool) -> Result<(), BenchError> {
        match (&mut self.port, self.kind) {
            (Port::Spi(dev), PartType::Adxl355) => {
                use adxl355::reg;
                let w = |dev: &mut crate::bus::spi::SimSpiDevice, a: u8, v: u8| {
                    dev.write(&[a << 1, v]).map_err(bus)
                };
                w(dev, reg::RESET, adxl355::RESET_CODE)?;
                let mut id = [0u8; 3];
                dev.transaction(&mut [
                    Operation::Write(&[(reg::DEVID_AD << 1) | 1]),
                    Operation::Read(&mut id),
                ])
                .map_err(bus)?;
                if id != [0xAD, 0x1D, 0xED] {
                    return Err(BenchError::WrongId { read: id.to_vec() });
                }
                let filter = (4000.0 / odr).log2().round() as u8;
                let range = match range_g {
                    2 => 1,
                    4 => 2,
                    _ => 3,
                };
                w(dev, reg::FILTER, filter)?;
                w(dev, reg::RANGE, 0x80 | range)?;
                w(dev, reg::SYNC, if sync { 0x01 } else { 0x00 })?;
                w(dev, reg::POWER_CTL, 0x00)
            }
            (Port::I2c(b, a), PartType::Lis3dh) => {
                use lis3dh::reg;
                let mut id = [0u8; 1];
                b.write_read(*a, &[reg::WHO_AM_I], &mut id).map_err(bus)?;
                if id[0] != 0x33 {
                    return Err(BenchError::WrongId { read: id.to_vec() });
                }
                // The CTRL_REG1 ODR code (normal / high-resolution mode) of this rate.
                let code = (1u8..=9).find(|c| lis3dh::odr(c << 4) == odr).unwrap_or(5);
                let fs = match range_g {
                    2 => 0,
                    4 => 1,
                    8 => 2,
                    _ => 3,
                };
                // BDU, full scale, high resolution; the ADC and its temperature sensor on.
                b.write(*a, &[reg::CTRL_REG4, 0x80 | (fs << 4) | 0x08])
                    .map_err(bus)?;
                b.write(*a, &[reg::TEMP_CFG_REG, 0xC0]).map_err(bus)?;
                b.write(*a, &[reg::CTRL_REG1, (code << 4) | 0x07])
                    .map_err(bus)
            }
            _ => Err(BenchError::Bus(
                "part type and bus kind do not match".into(),
            )),
        }
    }

    fn read_temperature(&mut self) -> Result<f64, BenchError> {
        let mut b = [0u8; 2];
        match &mut self.port {
            Port::Spi(dev) => {
                dev.transaction(&mut [
                    Operation::Write(&[(adxl355::reg::TEMP2 << 1) | 1]),
                    Operation::Read(&mut b),
                ])
                .map_err(bus)?;
                let code = f64::from(u16::from(b[0] & 0x0F) << 8 | u16::from(b[1]));
                Ok(25.0 + (code - adxl355::TEMP_INTERCEPT) / adxl355::TEMP_SLOPE)
            }
            Port::I2c(bus_handle, a) => {
                bus_handle
                    .write_read(
                        *a,
                        &[lis3dh::reg::OUT_ADC3_L | lis3dh::AUTO_INCREMENT],
                        &mut b,
                    )
                    .map_err(bus)?;
                Ok(25.0 + f64::from(b[1] as i8))
            }
        }
    }

    fn read(&mut self) -> Result<[f64; 3], BenchError> {
        let mut out = [0.0; 3];
        match &mut self.port {
            Port::Spi(dev) => {
                let mut b = [0u8; 9];
                dev.transaction(&mut [
                    Operation::Write(&[(adxl355::reg::XDATA3 << 1) | 1]),
                    Operation::Read(&mut b),
                ])
                .map_err(bus)?;
                for (o, c) in out.iter_mut().zip(b.chunks_exact(3)) {
                    *o = f64::from(adxl355::code_from_bytes(c)) * self.lsb;
                }
            }
            Port::I2c(bus_handle, a) => {
                let mut b = [0u8; 6];
                bus_handle
                    .write_read(*a, &[lis3dh::reg::OUT_X_L | lis3dh::AUTO_INCREMENT], &mut b)
                    .map_err(bus)?;
                for (i, o) in out.iter_mut().enumerate() {
                    // 12-bit high resolution, left-justified.
                    *o = f64::from(i16::from_le_bytes([b[2 * i], b[2 * i + 1]]) >> 4) * self.lsb;
                }
            }
        }
        Ok(out)
    }
}
