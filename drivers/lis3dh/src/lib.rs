//! An `embedded-hal-async` driver for the STMicroelectronics LIS3DH: a tri-axial MEMS
//! accelerometer on I²C, used in high-resolution (12-bit) mode with block data update (±2/4/8/16
//! g, 1 Hz to 1.344 kHz, a 32-entry FIFO in stream mode, the temperature through its ADC).
//!
//! The driver checks the identity register, configures range, rate and FIFO, and reads
//! acceleration in m/s² (part axes) with the datasheet's sensitivity, the FIFO's level and a
//! burst of its samples, and the temperature. A data byte with bits set that the 12-bit output
//! always reads as zero is an error, not a reading. `no_std`, no allocation; generic over any
//! [`I2c`] bus.
//!
//! Why its own driver: `lis3dh-async` (0.9) returns the `accelerometer` crate's types in g with
//! its own configuration set and no check of the data bytes.
//!
//! ```
//! # use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};
//! # const ADDRESS: u8 = 0x19;
//! # let mut bus = Mock::new(&[
//! #     T::write_read(ADDRESS, vec![0x0F], vec![0x33]),
//! #     T::write(ADDRESS, vec![0x23, 0x88 | 0x10]),
//! #     T::write(ADDRESS, vec![0x24, 0x00]),
//! #     T::write(ADDRESS, vec![0x2E, 0x00]),
//! #     T::write(ADDRESS, vec![0x1F, 0xC0]),
//! #     T::write(ADDRESS, vec![0x20, 0x57]),
//! #     T::write_read(ADDRESS, vec![0xA8], vec![0x00, 0x3E, 0, 0, 0, 0]),
//! # ]);
//! use lis3dh::{Config, Lis3dh, Odr, Range};
//!
//! # futures::executor::block_on(async {
//! let config = Config {
//!     range: Range::G4,
//!     odr: Odr::at_least(100.0),
//!     fifo: false,
//! };
//! let mut part = Lis3dh::new(bus.clone(), ADDRESS, config).await?;
//! let [x, y, z] = part.read_acceleration().await?; // m/s², part axes: here 992 digits of 2 mg
//! assert!((x - 1.984 * lis3dh::STANDARD_GRAVITY).abs() < 1e-4 && y == 0.0 && z == 0.0);
//! # Ok::<(), lis3dh::Error<embedded_hal::i2c::ErrorKind>>(())
//! # }).unwrap();
//! # bus.done();
//! ```
#![no_std]
#![deny(missing_docs)]

pub mod registers;

use embedded_hal_async::i2c::I2c;

use registers as reg;

/// Standard gravity (m/s² per g, the conventional value of the CGPM): the datasheet gives
/// sensitivities per g. The estimator's `G0` is the same number; the application checks that
/// they agree at compile time.
pub const STANDARD_GRAVITY: f32 = 9.806_65;

/// Full-scale range (sensitivity in high-resolution mode).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Range {
    /// ±2 g, 1 mg per digit.
    G2,
    /// ±4 g, 2 mg per digit.
    G4,
    /// ±8 g, 4 mg per digit.
    G8,
    /// ±16 g, 12 mg per digit.
    G16,
}

impl Range {
    /// `CTRL_REG4` bits 5:4.
    pub fn bits(self) -> u8 {
        match self {
            Range::G2 => 0,
            Range::G4 => 1,
            Range::G8 => 2,
            Range::G16 => 3,
        }
    }

    /// m/s² per digit of the 12-bit output.
    pub fn scale(self) -> f32 {
        let mg = match self {
            Range::G2 => 1.0,
            Range::G4 => 2.0,
            Range::G8 => 4.0,
            Range::G16 => 12.0,
        };
        mg * 1e-3 * STANDARD_GRAVITY
    }

    /// The largest magnitude a reading takes (m/s²): 2047 digits, the 12-bit output's positive
    /// rail (a clipped axis reads it, or one digit more on the negative side).
    pub fn full_scale(self) -> f32 {
        2047.0 * self.scale()
    }
}

/// Output data rates of the normal and high-resolution modes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Odr {
    /// 1 Hz.
    Hz1,
    /// 10 Hz.
    Hz10,
    /// 25 Hz.
    Hz25,
    /// 50 Hz.
    Hz50,
    /// 100 Hz.
    Hz100,
    /// 200 Hz.
    Hz200,
    /// 400 Hz.
    Hz400,
    /// 1.344 kHz.
    Hz1344,
}

impl Odr {
    const ALL: [(Odr, f32, u8); 8] = [
        (Odr::Hz1, 1.0, 1),
        (Odr::Hz10, 10.0, 2),
        (Odr::Hz25, 25.0, 3),
        (Odr::Hz50, 50.0, 4),
        (Odr::Hz100, 100.0, 5),
        (Odr::Hz200, 200.0, 6),
        (Odr::Hz400, 400.0, 7),
        (Odr::Hz1344, 1344.0, 9),
    ];

    /// The lowest rate at or above `hz` (1.344 kHz if higher).
    pub fn at_least(hz: f32) -> Self {
        Self::ALL
            .iter()
            .find(|(_, r, _)| *r >= hz)
            .map_or(Odr::Hz1344, |(o, _, _)| *o)
    }

    /// The rate (Hz).
    pub fn hz(self) -> f32 {
        Self::ALL
            .iter()
            .find(|(o, _, _)| *o == self)
            .map_or(0.0, |(_, r, _)| *r)
    }

    /// `CTRL_REG1` bits 7:4.
    pub fn code(self) -> u8 {
        Self::ALL
            .iter()
            .find(|(o, _, _)| *o == self)
            .map_or(0, |(_, _, c)| *c)
    }
}

/// Configuration applied at start-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Config {
    /// Full-scale range.
    pub range: Range,
    /// Output data rate.
    pub odr: Odr,
    /// FIFO in stream mode (samples are read in bursts with their count, for timestamping);
    /// otherwise the output registers hold the latest sample.
    pub fifo: bool,
}

/// The FIFO's state (`FIFO_SRC_REG`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FifoLevel {
    /// Unread samples.
    pub samples: u8,
    /// Samples were lost since the last look (the FIFO was full).
    pub overrun: bool,
}

/// Errors of the driver.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error<E> {
    /// The bus failed (no acknowledge, timeout, …).
    Bus(E),
    /// `WHO_AM_I` did not read 0x33.
    WrongId(u8),
    /// A data byte had bits set that read as zero in high-resolution mode (bits 3:0 of each
    /// low byte): a corrupted transfer.
    Implausible,
}

/// A LIS3DH on an I²C bus at a 7-bit address (0x18 or 0x19 by SA0).
pub struct Lis3dh<I2C> {
    i2c: I2C,
    address: u8,
    scale: f32,
}

impl<I2C: I2c> Lis3dh<I2C> {
    /// Checks the identity and applies `config` (BDU, high resolution, all axes on).
    pub async fn new(i2c: I2C, address: u8, config: Config) -> Result<Self, Error<I2C::Error>> {
        let mut dev = Self::bare(i2c, address, config.range);
        dev.start(config).await?;
        Ok(dev)
    }

    /// The driver without any transfer yet (call [`Lis3dh::start`]): a part that fails at
    /// start-up keeps its bus handle, so that it can be started again later.
    pub fn bare(i2c: I2C, address: u8, range: Range) -> Self {
        Lis3dh {
            i2c,
            address,
            scale: range.scale(),
        }
    }

    /// Identification check and configuration.
    pub async fn start(&mut self, config: Config) -> Result<(), Error<I2C::Error>> {
        self.identify().await?;
        self.configure(config).await
    }

    /// Reads `WHO_AM_I`.
    pub async fn identify(&mut self) -> Result<(), Error<I2C::Error>> {
        let mut id = [0u8; 1];
        self.i2c
            .write_read(self.address, &[reg::WHO_AM_I], &mut id)
            .await
            .map_err(Error::Bus)?;
        if id[0] == reg::ID {
            Ok(())
        } else {
            Err(Error::WrongId(id[0]))
        }
    }

    /// Applies a configuration: range with BDU and high resolution, then the ODR (which
    /// starts the part's clock).
    pub async fn configure(&mut self, config: Config) -> Result<(), Error<I2C::Error>> {
        let ctrl4 = reg::BDU | (config.range.bits() << 4) | reg::HR;
        self.i2c
            .write(self.address, &[reg::CTRL_REG4, ctrl4])
            .await
            .map_err(Error::Bus)?;
        let (ctrl5, fifo_ctrl) = if config.fifo {
            (reg::FIFO_EN, reg::FIFO_STREAM)
        } else {
            (0, 0)
        };
        self.i2c
            .write(self.address, &[reg::CTRL_REG5, ctrl5])
            .await
            .map_err(Error::Bus)?;
        self.i2c
            .write(self.address, &[reg::FIFO_CTRL_REG, fifo_ctrl])
            .await
            .map_err(Error::Bus)?;
        self.i2c
            .write(self.address, &[reg::TEMP_CFG_REG, reg::TEMP_ON])
            .await
            .map_err(Error::Bus)?;
        self.i2c
            .write(
                self.address,
                &[reg::CTRL_REG1, (config.odr.code() << 4) | 0x07],
            )
            .await
            .map_err(Error::Bus)?;
        self.scale = config.range.scale();
        Ok(())
    }

    /// `STATUS_REG`: (new data, overrun).
    pub async fn status(&mut self) -> Result<(bool, bool), Error<I2C::Error>> {
        let mut s = [0u8; 1];
        self.i2c
            .write_read(self.address, &[reg::STATUS_REG], &mut s)
            .await
            .map_err(Error::Bus)?;
        Ok((s[0] & reg::ZYXDA != 0, s[0] & reg::ZYXOR != 0))
    }

    /// The latest sample, x, y, z in m/s² (part axes): one 6-byte burst.
    pub async fn read_acceleration(&mut self) -> Result<[f32; 3], Error<I2C::Error>> {
        let mut out = [[0.0; 3]];
        self.read_samples(&mut out).await?;
        Ok(out[0])
    }

    /// The part's temperature (°C): the auxiliary ADC's channel 3, one digit per °C (its high
    /// byte), read as 25 °C + that. The datasheet gives no intercept: the reading is relative
    /// to a temperature that differs from part to part, and a calibration's `t_ref` is on the
    /// same scale, so only its changes matter. Its resolution is 1 °C.
    pub async fn read_temperature(&mut self) -> Result<f32, Error<I2C::Error>> {
        let mut b = [0u8; 2];
        self.i2c
            .write_read(
                self.address,
                &[reg::OUT_ADC3_L | reg::AUTO_INCREMENT],
                &mut b,
            )
            .await
            .map_err(Error::Bus)?;
        Ok(25.0 + f32::from(b[1] as i8))
    }

    /// `FIFO_SRC_REG`: the unread samples in the FIFO (configured with `fifo`).
    pub async fn fifo_level(&mut self) -> Result<FifoLevel, Error<I2C::Error>> {
        let mut s = [0u8; 1];
        self.i2c
            .write_read(self.address, &[reg::FIFO_SRC_REG], &mut s)
            .await
            .map_err(Error::Bus)?;
        Ok(FifoLevel {
            samples: s[0] & reg::FIFO_LEVEL,
            overrun: s[0] & reg::FIFO_OVRN != 0,
        })
    }

    /// Pops `out.len()` samples (at most [`reg::FIFO_DEPTH`]) from the FIFO, oldest first,
    /// in one burst (the address wraps from `OUT_Z_H` to `OUT_X_L` in FIFO mode). Ask
    /// [`Lis3dh::fifo_level`] first: reading more than are stored repeats zeros.
    pub async fn read_fifo(&mut self, out: &mut [[f32; 3]]) -> Result<(), Error<I2C::Error>> {
        let n = out.len().min(reg::FIFO_DEPTH);
        self.read_samples(&mut out[..n]).await
    }

    /// Reads `out.len()` (≤ [`reg::FIFO_DEPTH`]) consecutive 6-byte samples in one burst and
    /// checks the bits that read as zero in high-resolution mode.
    async fn read_samples(&mut self, out: &mut [[f32; 3]]) -> Result<(), Error<I2C::Error>> {
        let mut b = [0u8; 6 * reg::FIFO_DEPTH];
        let bytes = &mut b[..6 * out.len().min(reg::FIFO_DEPTH)];
        self.i2c
            .write_read(self.address, &[reg::OUT_X_L | reg::AUTO_INCREMENT], bytes)
            .await
            .map_err(Error::Bus)?;
        for (sample, raw) in out.iter_mut().zip(bytes.chunks_exact(6)) {
            for (o, c) in sample.iter_mut().zip(raw.chunks_exact(2)) {
                if c[0] & 0x0F != 0 {
                    return Err(Error::Implausible);
                }
                *o = f32::from(i16::from_le_bytes([c[0], c[1]]) >> 4) * self.scale;
            }
        }
        Ok(())
    }

    /// Gives the bus back.
    pub fn release(self) -> I2C {
        self.i2c
    }
}
