//! Analog Devices ADXL355: low-noise 3-axis accelerometer, 20-bit output, SPI (this model) —
//! register map, data format and SPI conventions from the ADXL354/ADXL355 datasheet.
//!
//! - SPI mode 0. The first byte of a transaction is `address << 1 | R` (R = 1: read); further
//!   bytes read or write successive registers (auto-increment), except that reads of
//!   `FIFO_DATA` keep popping the FIFO.
//! - Data: 20-bit two's complement, left-justified over three registers
//!   (`DATA3` = bits 19:12, `DATA2` = 11:4, `DATA1` bits 7:4 = 3:0). Sensitivity 256 000,
//!   128 000 or 64 000 LSB/g for ±2, ±4, ±8 g (`RANGE` bits 1:0 = 1, 2, 3).
//! - ODR `4000 / 2^ODR_LPF` Hz (`FILTER` bits 3:0, 0..=10); the digital low-pass corner is
//!   ODR/4, so white noise of density `nd` gives `nd·√(ODR/4)` per sample.
//! - `POWER_CTL` bit 0 = standby (the reset state): no measurements.
//! - `STATUS` bit 0 DATA_RDY (set by each new sample, cleared by reading a data register),
//!   bit 1 FIFO_FULL (entries ≥ `FIFO_SAMPLES`), bit 2 FIFO_OVR.
//! - FIFO of 96 entries (32 x, y, z sets, 3 bytes each); an x entry has bit 0 of its last byte
//!   set, an empty FIFO reads with bit 1 set.
//! - `SYNC` bits 1:0 ≠ 0: external synchronisation, one sample per pulse on the SYNC pin
//!   ([`Adxl355::connect_sync`] to a [`SyncLine`], or [`Adxl355::sync_pulse`]) instead of the
//!   internal clock.
//! - Temperature: 12 bits over `TEMP2` (bits 3:0 = 11:8) and `TEMP1`, 1 885 LSB at 25 °C and
//!   −9.05 LSB/°C (nominal intercept and slope), converted while measuring unless `POWER_CTL`
//!   bit 1 (TEMP_OFF) is set; the registers then keep the last conversion.
//! - Writing 0x52 to `RESET` restores every register.

use std::collections::VecDeque;

use super::errors::{SensorErrors, G0};
use super::frontend::Frontend;
use super::sync_line::SyncLine;
use super::ForceSource;
use crate::bus::spi::SpiTarget;
use crate::faults::Fault;

/// Register addresses.
pub mod reg {
    /// Analog Devices ID, 0xAD.
    pub const DEVID_AD: u8 = 0x00;
    /// MEMS ID, 0x1D.
    pub const DEVID_MST: u8 = 0x01;
    /// Part ID, 0xED.
    pub const PARTID: u8 = 0x02;
    /// Revision.
    pub const REVID: u8 = 0x03;
    /// Status.
    pub const STATUS: u8 = 0x04;
    /// Entries in the FIFO.
    pub const FIFO_ENTRIES: u8 = 0x05;
    /// Temperature, bits 11:8.
    pub const TEMP2: u8 = 0x06;
    /// Temperature, bits 7:0.
    pub const TEMP1: u8 = 0x07;
    /// X data, bits 19:12 (then XDATA2, XDATA1, and Y, Z likewise up to 0x10).
    pub const XDATA3: u8 = 0x08;
    /// Z data, bits 3:0 in 7:4 (the last data register).
    pub const ZDATA1: u8 = 0x10;
    /// FIFO read port.
    pub const FIFO_DATA: u8 = 0x11;
    /// Filter: high-pass corner (6:4) and ODR/low-pass (3:0).
    pub const FILTER: u8 = 0x28;
    /// FIFO watermark (entries).
    pub const FIFO_SAMPLES: u8 = 0x29;
    /// Interrupt map.
    pub const INT_MAP: u8 = 0x2A;
    /// External sync (1:0) and clock (2).
    pub const SYNC: u8 = 0x2B;
    /// Range (1:0), interrupt polarity (6), I²C speed (7).
    pub const RANGE: u8 = 0x2C;
    /// Standby (0), temperature off (1), DRDY off (2).
    pub const POWER_CTL: u8 = 0x2D;
    /// Self test.
    pub const SELF_TEST: u8 = 0x2E;
    /// Reset: write 0x52.
    pub const RESET: u8 = 0x2F;
}

/// Register file size (0x00..=0x2F).
const NREG: usize = 0x30;
/// FIFO capacity in entries (one axis each).
const FIFO_CAP: usize = 96;
/// Code written to `RESET`.
pub const RESET_CODE: u8 = 0x52;
/// Full-scale code of the 20-bit output.
/// The 20-bit output's positive rail (codes); the negative one is one code further.
pub const CODE_MAX: i32 = (1 << 19) - 1;

fn reset_registers() -> [u8; NREG] {
    let mut r = [0u8; NREG];
    r[reg::DEVID_AD as usize] = 0xAD;
    r[reg::DEVID_MST as usize] = 0x1D;
    r[reg::PARTID as usize] = 0xED;
    r[reg::REVID as usize] = 0x01;
    r[reg::FIFO_SAMPLES as usize] = 0x60;
    r[reg::RANGE as usize] = 0x81;
    r[reg::POWER_CTL as usize] = 0x01;
    // 25 °C: 1885 LSB.
    r[reg::TEMP2 as usize] = (1885 >> 8) as u8;
    r[reg::TEMP1 as usize] = (1885 & 0xff) as u8;
    r
}

/// The temperature code at 25 °C (LSB).
pub const TEMP_INTERCEPT: f64 = 1885.0;
/// The temperature code's slope (LSB/°C).
pub const TEMP_SLOPE: f64 = -9.05;

/// The 12-bit temperature code of `celsius`.
pub fn temperature_code(celsius: f64) -> u16 {
    let c = TEMP_INTERCEPT + TEMP_SLOPE * (celsius - 25.0);
    c.round().clamp(0.0, 4095.0) as u16
}

/// Sensitivity (LSB/g) for a `RANGE` register value.
pub fn sensitivity(range_reg: u8) -> f64 {
    match range_reg & 0x03 {
        0x02 => 128_000.0,
        0x03 => 64_000.0,
        // 0b01 (±2 g) and the reserved 0b00.
        _ => 256_000.0,
    }
}

/// The 20-bit code of `a` (m/s²) at `lsb_per_g`, saturated.
pub fn code(a: f64, lsb_per_g: f64) -> i32 {
    let c = (a / G0 * lsb_per_g).round();
    if c.is_nan() {
        0
    } else {
        c.clamp(-(CODE_MAX as f64) - 1.0, CODE_MAX as f64) as i32
    }
}

/// The three register bytes of a 20-bit code (left-justified).
pub fn code_bytes(c: i32) -> [u8; 3] {
    let u = (c as u32) & 0xF_FFFF;
    [(u >> 12) as u8, (u >> 4) as u8, ((u & 0xF) << 4) as u8]
}

/// The signed 20-bit code of three left-justified register bytes (the inverse of
/// [`code_bytes`]; the low nibble of the third byte is ignored).
pub fn code_from_bytes(b: &[u8]) -> i32 {
    let u = (u32::from(b[0]) << 12) | (u32::from(b[1]) << 4) | (u32::from(b[2]) >> 4);
    ((u << 12) as i32) >> 12
}

/// The ADXL355 register model.
pub struct Adxl355 {
    regs: [u8; NREG],
    fifo: VecDeque<[u8; 3]>,
    /// Sampling, error model and measurement faults.
    front: Frontend,
    /// SPI transaction state: current address, direction, bytes seen.
    addr: u8,
    reading: bool,
    byte_index: usize,
    /// Bytes of the FIFO entry being read.
    fifo_entry: [u8; 3],
    fifo_pos: usize,
    /// Simulated time of the current transaction.
    now: f64,
    /// The SYNC pin's line and the pulses seen on it.
    sync: Option<(SyncLine, u64)>,
}

impl Adxl355 {
    /// A part with the given errors, seeing the specific force `source` (part axes, m/s²).
    pub fn new(errors: SensorErrors, source: ForceSource) -> Self {
        Adxl355 {
            regs: reset_registers(),
            fifo: VecDeque::with_capacity(FIFO_CAP),
            front: Frontend::new(errors, source),
            addr: 0,
            reading: false,
            byte_index: 0,
            fifo_entry: [0; 3],
            fifo_pos: 3,
            now: 0.0,
            sync: None,
        }
    }

    /// Wires the SYNC pin to `line`: with external sync enabled, each pulse is one sample.
    /// Pulses sent before the connection are not seen.
    pub fn connect_sync(&mut self, line: SyncLine) {
        let seen = line.count();
        self.sync = Some((line, seen));
    }

    /// Schedules measurement faults (stuck, bias jump, noise burst, saturation).
    pub fn set_faults(&mut self, faults: Vec<Fault>) {
        self.front.set_faults(faults);
    }

    /// Nominal output data rate (Hz) from `FILTER`.
    pub fn odr(&self) -> f64 {
        let sel = (self.regs[reg::FILTER as usize] & 0x0F).min(10);
        4000.0 / f64::from(1u32 << sel)
    }

    fn measuring(&self) -> bool {
        self.regs[reg::POWER_CTL as usize] & 0x01 == 0
    }

    /// Converts the temperature at `t` into `TEMP2`/`TEMP1` if the sensor is on.
    fn convert_temperature(&mut self, t: f64) {
        if self.measuring() && self.regs[reg::POWER_CTL as usize] & 0x02 == 0 {
            let code = temperature_code(self.front.temperature(t));
            self.regs[reg::TEMP2 as usize] = (code >> 8) as u8;
            self.regs[reg::TEMP1 as usize] = (code & 0xff) as u8;
        }
    }

    fn external_sync(&self) -> bool {
        self.regs[reg::SYNC as usize] & 0x03 != 0
    }

    /// A pulse on the SYNC pin at time `t`: one sample when external sync is enabled.
    pub fn sync_pulse(&mut self, t: f64) {
        if self.measuring() && self.external_sync() {
            self.take_sample(t);
        }
    }

    /// Takes every internal-clock sample due up to `t`.
    fn catch_up(&mut self, t: f64) {
        let pulses = match &mut self.sync {
            Some((line, seen)) => line.take_since(seen, t),
            None => Vec::new(),
        };
        if !self.measuring() || self.external_sync() {
            self.front.stop_clock();
            for p in pulses {
                self.sync_pulse(p);
            }
            return;
        }
        let odr = self.odr();
        while let Some(ts) = self.front.next_due(t, odr) {
            self.take_sample(ts);
        }
    }

    fn take_sample(&mut self, t: f64) {
        let a = self.front.measure(t, self.odr() / 4.0);
        let lsb = sensitivity(self.regs[reg::RANGE as usize]);
        for (axis, v) in a.iter().enumerate() {
            let b = code_bytes(code(*v, lsb));
            let base = reg::XDATA3 as usize + 3 * axis;
            self.regs[base..base + 3].copy_from_slice(&b);
            if self.fifo.len() < FIFO_CAP {
                let mut e = b;
                if axis == 0 {
                    e[2] |= 0x01;
                }
                self.fifo.push_back(e);
            } else {
                self.regs[reg::STATUS as usize] |= 0x04;
            }
        }
        self.regs[reg::STATUS as usize] |= 0x01;
        self.update_fifo_status();
    }

    fn update_fifo_status(&mut self) {
        let n = self.fifo.len();
        self.regs[reg::FIFO_ENTRIES as usize] = n as u8;
        let watermark = usize::from(self.regs[reg::FIFO_SAMPLES as usize]).clamp(1, FIFO_CAP);
        if n >= watermark {
            self.regs[reg::STATUS as usize] |= 0x02;
        } else {
            self.regs[reg::STATUS as usize] &= !0x02;
        }
    }

    fn read_register(&mut self, addr: u8) -> u8 {
        match addr {
            reg::FIFO_DATA => {
                if self.fifo_pos >= 3 {
                    match self.fifo.pop_front() {
                        Some(e) => self.fifo_entry = e,
                        // Empty: the "empty" indicator in the last byte.
                        None => self.fifo_entry = [0, 0, 0x02],
                    }
                    self.fifo_pos = 0;
                    self.update_fifo_status();
                }
                let b = self.fifo_entry[self.fifo_pos];
                self.fifo_pos += 1;
                b
            }
            a if (a as usize) < NREG => {
                let v = self.regs[a as usize];
                if (reg::XDATA3..=reg::ZDATA1).contains(&a) {
                    self.regs[reg::STATUS as usize] &= !0x01;
                }
                if a == reg::STATUS {
                    // FIFO_OVR is cleared by reading it.
                    self.regs[reg::STATUS as usize] &= !0x04;
                }
                v
            }
            _ => 0,
        }
    }

    fn write_register(&mut self, addr: u8, v: u8) {
        match addr {
            reg::RESET if v == RESET_CODE => {
                self.regs = reset_registers();
                self.fifo.clear();
                self.front.stop_clock();
            }
            // Any other value written to RESET does nothing.
            reg::RESET => {}
            // Read-only registers ignore writes.
            a if a <= reg::FIFO_DATA => {}
            a if (a as usize) < NREG => {
                let was_measuring = self.measuring();
                self.regs[a as usize] = v;
                if a == reg::POWER_CTL || a == reg::FILTER || a == reg::SYNC {
                    if !was_measuring || a != reg::POWER_CTL {
                        // (Re)start the internal clock from now.
                        self.front.stop_clock();
                    }
                    self.catch_up(self.now);
                }
            }
            _ => {}
        }
    }
}

impl SpiTarget for Adxl355 {
    fn select(&mut self, now: f64) {
        self.now = now;
        self.catch_up(now);
        self.convert_temperature(now);
        self.byte_index = 0;
        self.fifo_pos = 3;
    }

    fn exchange(&mut self, mosi: u8) -> u8 {
        let i = self.byte_index;
        self.byte_index += 1;
        if i == 0 {
            self.addr = mosi >> 1;
            self.reading = mosi & 1 == 1;
            return 0;
        }
        let a = self.addr;
        if a != reg::FIFO_DATA || !self.reading {
            self.addr = self.addr.wrapping_add(1);
        }
        if self.reading {
            self.read_register(a)
        } else {
            self.write_register(a, mosi);
            0
        }
    }

    fn deselect(&mut self) {
        self.byte_index = 0;
    }
}
