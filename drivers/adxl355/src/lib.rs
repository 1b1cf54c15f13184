//! An `embedded-hal-async` driver for the Analog Devices ADXL355: a 20-bit tri-axial MEMS
//! accelerometer on SPI (±2/4/8 g, output data rate 4 kHz/2ⁿ, external sync, a 96-entry FIFO).
//!
//! The driver resets the part, checks its identity registers, configures range, rate and
//! sync, and reads acceleration in m/s² (part axes) with the datasheet's exact sensitivity, the
//! temperature, the status and the FIFO. Every data byte is checked against the bits the part
//! always reads as zero, so a stuck MISO line is an error, not a reading. `no_std`, no
//! allocation; generic over any [`SpiDevice`].
//!
//! Why its own driver: the `adxl355` crate on crates.io (0.2) is blocking, on embedded-hal 0.2,
//! and exposes neither the external sync nor the FIFO's axis markers that synchronised
//! sampling needs.
//!
//! ```
//! # use embedded_hal_mock::eh1::spi::{Mock, Transaction as T};
//! # fn tx(w: &[u8], r: Option<&[u8]>) -> Vec<T<u8>> {
//! #     let mut t = vec![T::transaction_start(), T::write_vec(w.to_vec())];
//! #     t.extend(r.map(|r| T::read_vec(r.to_vec())));
//! #     t.push(T::transaction_end());
//! #     t
//! # }
//! # let mut script = tx(&[0x5E, 0x52], None);
//! # script.extend(tx(&[0x01], Some(&[0xAD, 0x1D, 0xED])));
//! # for w in [[0x5A, 0x01], [0x50, 0x05], [0x58, 0x81], [0x56, 0x00], [0x5A, 0x00]] {
//! #     script.extend(tx(&w, None));
//! # }
//! # script.extend(tx(&[0x11], Some(&[0x3E, 0x80, 0x00, 0, 0, 0, 0, 0, 0])));
//! # let mut spi = Mock::new(&script);
//! use adxl355::{Adxl355, Config, Odr, Range, Sync};
//!
//! # futures::executor::block_on(async {
//! let config = Config {
//!     range: Range::G2,
//!     odr: Odr::at_least(100.0), // 125 Hz, the lowest rate at or above 100 Hz
//!     sync: Sync::Internal,
//! };
//! let mut part = Adxl355::new(spi.clone(), config).await?;
//! let [x, y, z] = part.read_acceleration().await?; // m/s², part axes
//! assert!((x - adxl355::STANDARD_GRAVITY).abs() < 1e-4 && y == 0.0 && z == 0.0);
//! # Ok::<(), adxl355::Error<embedded_hal::spi::ErrorKind>>(())
//! # }).unwrap();
//! # spi.done();
//! ```
#![no_std]
#![deny(missing_docs)]

pub mod registers;

use embedded_hal_async::spi::{Operation, SpiDevice};

use registers as reg;

/// Standard gravity (m/s² per g, the conventional value of the CGPM): the datasheet gives
/// sensitivities per g. The estimator's `G0` is the same number; the application checks that
/// they agree at compile time.
pub const STANDARD_GRAVITY: f32 = 9.806_65;

/// Full-scale range.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Range {
    /// ±2 g, 256 000 LSB/g.
    G2,
    /// ±4 g, 128 000 LSB/g.
    G4,
    /// ±8 g, 64 000 LSB/g.
    G8,
}

impl Range {
    /// `RANGE` bits 1:0.
    pub fn bits(self) -> u8 {
        match self {
            Range::G2 => 0b01,
            Range::G4 => 0b10,
            Range::G8 => 0b11,
        }
    }

    /// m/s² per LSB of the 20-bit output.
    pub fn scale(self) -> f32 {
        let lsb_per_g = match self {
            Range::G2 => 256_000.0,
            Range::G4 => 128_000.0,
            Range::G8 => 64_000.0,
        };
        STANDARD_GRAVITY / lsb_per_g
    }

    /// The largest magnitude a reading takes (m/s²): 524 287 LSB, the 20-bit output's positive
    /// rail (a clipped axis reads it, or one LSB more on the negative side).
    pub fn full_scale(self) -> f32 {
        524_287.0 * self.scale()
    }
}

/// Output data rate `4000 / 2ⁿ` Hz, `n` = 0..=10 (`FILTER` bits 3:0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Odr(u8);

impl Odr {
    /// The ODR code `n` (0: 4 kHz … 10: 3.906 Hz); `None` above 10.
    pub const fn from_code(n: u8) -> Option<Self> {
        if n <= 10 {
            Some(Odr(n))
        } else {
            None
        }
    }

    /// The lowest ODR at or above `hz` (4 kHz if `hz` is higher).
    pub fn at_least(hz: f32) -> Self {
        let mut n = 10;
        while n > 0 && (4000.0 / (1u32 << n) as f32) < hz {
            n -= 1;
        }
        Odr(n)
    }

    /// The rate (Hz).
    pub fn hz(self) -> f32 {
        4000.0 / (1u32 << self.0) as f32
    }

    /// The `FILTER` code.
    pub fn code(self) -> u8 {
        self.0
    }
}

/// How samples are timed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sync {
    /// The part's own clock at the ODR.
    Internal,
    /// One sample per pulse on the SYNC pin (`SYNC` = 0b01).
    External,
}

/// Configuration applied at start-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Config {
    /// Full-scale range.
    pub range: Range,
    /// Output data rate (and low-pass corner ODR/4).
    pub odr: Odr,
    /// Timing.
    pub sync: Sync,
}

/// Errors of the driver.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error<E> {
    /// The bus failed.
    Bus(E),
    /// The identification registers did not read 0xAD, 0x1D, 0xED (part missing, dead with
    /// MISO high, or another part).
    WrongId([u8; 3]),
    /// A data byte had bits set that the part always reads as zero (bits 3:0 of `XDATA1` …):
    /// MISO stuck high or a corrupted transfer.
    Implausible,
}

/// The status register.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Status(pub u8);

impl Status {
    /// A new sample since the data registers were last read.
    pub fn data_ready(self) -> bool {
        self.0 & reg::DATA_RDY != 0
    }

    /// The FIFO overflowed.
    pub fn fifo_overrun(self) -> bool {
        self.0 & reg::FIFO_OVR != 0
    }
}

/// An ADXL355 on an SPI device.
pub struct Adxl355<SPI> {
    spi: SPI,
    scale: f32,
}

impl<SPI: SpiDevice> Adxl355<SPI> {
    /// Resets the part, checks its IDs and applies `config` (measurement on).
    pub async fn new(spi: SPI, config: Config) -> Result<Self, Error<SPI::Error>> {
        let mut dev = Self::bare(spi, config.range);
        dev.start(config).await?;
        Ok(dev)
    }

    /// The driver without any transfer yet (call [`Adxl355::start`]): a part that fails at
    /// start-up keeps its bus handle, so that it can be started again later.
    pub fn bare(spi: SPI, range: Range) -> Self {
        Adxl355 {
            spi,
            scale: range.scale(),
        }
    }

    /// Reset, identification check, configuration.
    pub async fn start(&mut self, config: Config) -> Result<(), Error<SPI::Error>> {
        self.write(reg::RESET, reg::RESET_CODE).await?;
        self.identify().await?;
        self.configure(config).await
    }

    /// Reads the three identification registers in one burst.
    pub async fn identify(&mut self) -> Result<(), Error<SPI::Error>> {
        let mut id = [0u8; 3];
        self.read_burst(reg::DEVID_AD, &mut id).await?;
        if id == reg::IDS {
            Ok(())
        } else {
            Err(Error::WrongId(id))
        }
    }

    /// Applies a configuration: standby, filter, range, sync, then measurement.
    pub async fn configure(&mut self, config: Config) -> Result<(), Error<SPI::Error>> {
        self.write(reg::POWER_CTL, 0x01).await?;
        self.write(reg::FILTER, config.odr.code()).await?;
        // Keep the I²C high-speed bit of the reset value.
        self.write(reg::RANGE, 0x80 | config.range.bits()).await?;
        let sync = match config.sync {
            Sync::Internal => 0b00,
            Sync::External => 0b01,
        };
        self.write(reg::SYNC, sync).await?;
        self.write(reg::POWER_CTL, 0x00).await?;
        self.scale = config.range.scale();
        Ok(())
    }

    /// The status register.
    pub async fn status(&mut self) -> Result<Status, Error<SPI::Error>> {
        let mut b = [0u8; 1];
        self.read_burst(reg::STATUS, &mut b).await?;
        Ok(Status(b[0]))
    }

    /// The latest sample, x, y, z in m/s² (part axes): one 10-byte transaction.
    pub async fn read_acceleration(&mut self) -> Result<[f32; 3], Error<SPI::Error>> {
        let mut b = [0u8; 9];
        self.read_burst(reg::XDATA3, &mut b).await?;
        self.convert(&b)
    }

    /// m/s² from the nine data bytes, checking the bits that read as zero.
    fn convert(&self, b: &[u8]) -> Result<[f32; 3], Error<SPI::Error>> {
        let mut out = [0.0; 3];
        for (o, c) in out.iter_mut().zip(b.chunks_exact(3)) {
            if c[2] & 0x0F != 0 {
                return Err(Error::Implausible);
            }
            *o = decode(c[0], c[1], c[2]) as f32 * self.scale;
        }
        Ok(out)
    }

    /// The status and the latest sample in one 14-byte transaction (`STATUS` through
    /// `ZDATA1`): whether the sample is new, and x, y, z in m/s².
    pub async fn read_status_and_acceleration(
        &mut self,
    ) -> Result<(Status, [f32; 3]), Error<SPI::Error>> {
        let mut b = [0u8; 13];
        self.read_burst(reg::STATUS, &mut b).await?;
        // STATUS bits 7:5 and the unused bits of FIFO_ENTRIES and TEMP2 read as zero.
        if b[0] & 0xE0 != 0 || b[1] & 0x80 != 0 || b[2] & 0xF0 != 0 {
            return Err(Error::Implausible);
        }
        Ok((Status(b[0]), self.convert(&b[4..13])?))
    }

    /// The part's temperature (°C) with the datasheet's nominal intercept and slope: one
    /// 3-byte transaction (`TEMP2`, `TEMP1`). The intercept varies from part to part; a
    /// calibration's `t_ref` is on the same scale, so only its changes matter.
    pub async fn read_temperature(&mut self) -> Result<f32, Error<SPI::Error>> {
        let mut b = [0u8; 2];
        self.read_burst(reg::TEMP2, &mut b).await?;
        // TEMP2 bits 7:4 read as zero.
        if b[0] & 0xF0 != 0 {
            return Err(Error::Implausible);
        }
        let code = f32::from(u16::from(b[0]) << 8 | u16::from(b[1]));
        Ok(25.0 + (code - reg::TEMP_INTERCEPT) / reg::TEMP_SLOPE)
    }

    /// Entries (single-axis values) waiting in the FIFO.
    pub async fn fifo_entries(&mut self) -> Result<u8, Error<SPI::Error>> {
        let mut b = [0u8; 1];
        self.read_burst(reg::FIFO_ENTRIES, &mut b).await?;
        Ok(b[0] & 0x7F)
    }

    /// Reads whole x, y, z sets from the FIFO into `out` (m/s²); returns how many. Reads
    /// `3 × out.len()` entries at most, in one transaction; stops at the empty marker, and
    /// starts at the first x marker (a set torn by an earlier read is skipped).
    pub async fn read_fifo(&mut self, out: &mut [[f32; 3]]) -> Result<usize, Error<SPI::Error>> {
        let entries = self.fifo_entries().await?;
        self.read_fifo_entries(entries, out).await
    }

    /// As [`Adxl355::read_fifo`], for a number of `entries` already read with
    /// [`Adxl355::fifo_entries`] (whole sets only; at most `3 × out.len()`).
    pub async fn read_fifo_entries(
        &mut self,
        entries: u8,
        out: &mut [[f32; 3]],
    ) -> Result<usize, Error<SPI::Error>> {
        let n = (usize::from(entries) / 3).min(out.len()).min(32);
        if n == 0 {
            return Ok(0);
        }
        let mut b = [0u8; 96 * 3];
        let bytes = &mut b[..n * 9];
        self.read_burst(reg::FIFO_DATA, bytes).await?;
        let mut sets = 0;
        let mut axis = 0;
        for e in bytes.chunks_exact(3) {
            if e[2] & 0x02 != 0 {
                break; // empty
            }
            let x_marker = e[2] & 0x01 != 0;
            if x_marker {
                axis = 0;
            } else if axis == 0 {
                continue; // not aligned to a set yet
            }
            out[sets][axis] = decode(e[0], e[1], e[2] & 0xF0) as f32 * self.scale;
            axis += 1;
            if axis == 3 {
                sets += 1;
                axis = 0;
            }
        }
        Ok(sets)
    }

    /// Gives the SPI device back.
    pub fn release(self) -> SPI {
        self.spi
    }

    async fn write(&mut self, addr: u8, value: u8) -> Result<(), Error<SPI::Error>> {
        self.spi
            .write(&[reg::write(addr), value])
            .await
            .map_err(Error::Bus)
    }

    async fn read_burst(&mut self, addr: u8, buf: &mut [u8]) -> Result<(), Error<SPI::Error>> {
        self.spi
            .transaction(&mut [Operation::Write(&[reg::read(addr)]), Operation::Read(buf)])
            .await
            .map_err(Error::Bus)
    }
}

/// The signed 20-bit value of a left-justified three-byte group.
pub fn decode(b3: u8, b2: u8, b1: u8) -> i32 {
    let u = (u32::from(b3) << 12) | (u32::from(b2) << 4) | (u32::from(b1) >> 4);
    ((u << 12) as i32) >> 12
}
