//! STMicroelectronics LIS3DH: 3-axis accelerometer on I²C (this model), register map, data
//! format and I²C conventions from its datasheet. Chosen as the I²C part because it is the most
//! common I²C accelerometer on boards and breakouts, and its conventions differ usefully from
//! the ADXL355's: the auto-increment flag is the MSB of the sub-address, data are 16-bit
//! left-justified with 8, 10 or 12 significant bits by mode, and its noise is about ten times
//! the ADXL355's (a realistic mixed-noise arrangement).
//!
//! - Address 0x18 or 0x19 (SA0). A write's first byte is the sub-address: bits 6:0 the register,
//!   bit 7 auto-increment; further written bytes go to successive registers if set; reads
//!   (after a repeated START) continue from the sub-address, incrementing if set.
//! - `WHO_AM_I` (0x0F) = 0x33. `CTRL_REG1` (0x20): ODR bits 7:4 (0 power-down, 1, 10, 25, 50,
//!   100, 200, 400 Hz, 1.6 kHz low-power, 1.344 kHz), LPen bit 3, axes enable bits 2:0;
//!   reset value 0x07. `CTRL_REG4` (0x23): BDU bit 7, FS bits 5:4 (±2, 4, 8, 16 g), HR bit 3.
//! - Output `OUT_X_L` .. `OUT_Z_H` (0x28..0x2D): little-endian 16-bit two's complement,
//!   left-justified; sensitivity 1/2/4/12 mg per digit (12-bit high resolution), 4/8/16/48
//!   (10-bit normal), 16/32/64/192 (8-bit low power) for ±2/4/8/16 g.
//! - `STATUS_REG` (0x27): ZYXDA bit 3 (new data, cleared by reading the outputs), ZYXOR bit 7
//!   (a sample overwrote unread data). With BDU, the outputs are not updated between the read
//!   of a low byte and of its high byte.
//! - FIFO of 32 samples, stream mode only: enabled by `CTRL_REG5` bit 6 (FIFO_EN) with
//!   `FIFO_CTRL_REG` (0x2E) mode bits 7:6 = 10; bypass (00) empties it. Each conversion is
//!   pushed; when full the oldest is dropped and OVRN is set. While enabled, the outputs show
//!   the oldest sample, reading `OUT_Z_H` pops it, and auto-increment wraps from 0x2D to 0x28
//!   so that one burst reads several samples. `FIFO_SRC_REG` (0x2F): WTM bit 7 (level ≥ the
//!   threshold in `FIFO_CTRL_REG` bits 4:0), OVRN bit 6 (cleared by reading this register),
//!   EMPTY bit 5, FSS bits 4:0 (unread samples; 31 with OVRN when full).
//! - Noise bandwidth ODR/2.
//! - Temperature through the auxiliary ADC: with `TEMP_CFG_REG` (0x1F) ADC_EN (bit 7) and
//!   TEMP_EN (bit 6) set and the part measuring, `OUT_ADC3_L`/`_H` (0x0C, 0x0D) hold a
//!   left-justified two's complement value whose high byte changes by one digit per °C. The
//!   datasheet gives no intercept (the reading is relative); this model reads 0 at 25 °C of
//!   the part's sensor (its `sensor_offset` is the unknown intercept).

use std::collections::VecDeque;

use super::errors::{SensorErrors, G0};
use super::frontend::Frontend;
use super::ForceSource;
use crate::bus::i2c::I2cTarget;
use crate::faults::Fault;

/// Register addresses.
pub mod reg {
    /// Identity, 0x33.
    pub const WHO_AM_I: u8 = 0x0F;
    /// ODR, low power, axes.
    pub const CTRL_REG1: u8 = 0x20;
    /// BDU, full scale, high resolution.
    pub const CTRL_REG4: u8 = 0x23;
    /// Reboot (bit 7), FIFO enable (bit 6).
    pub const CTRL_REG5: u8 = 0x24;
    /// FIFO mode (7:6) and threshold (4:0).
    pub const FIFO_CTRL_REG: u8 = 0x2E;
    /// FIFO status: WTM, OVRN, EMPTY, level.
    pub const FIFO_SRC_REG: u8 = 0x2F;
    /// Auxiliary ADC channel 3 (the temperature), low byte.
    pub const OUT_ADC3_L: u8 = 0x0C;
    /// Its high byte.
    pub const OUT_ADC3_H: u8 = 0x0D;
    /// ADC_EN (bit 7), TEMP_EN (bit 6).
    pub const TEMP_CFG_REG: u8 = 0x1F;
    /// Data status.
    pub const STATUS_REG: u8 = 0x27;
    /// X low byte (then X high, Y low/high, Z low/high).
    pub const OUT_X_L: u8 = 0x28;
    /// X high byte.
    pub const OUT_X_H: u8 = 0x29;
    /// Z high byte.
    pub const OUT_Z_H: u8 = 0x2D;
}

/// Register file size (0x00..=0x3F).
const NREG: usize = 0x40;
/// FIFO depth (samples).
const FIFO_DEPTH: usize = 32;
/// Sub-address flag: auto-increment.
pub const AUTO_INCREMENT: u8 = 0x80;

fn reset_registers() -> [u8; NREG] {
    let mut r = [0u8; NREG];
    r[reg::WHO_AM_I as usize] = 0x33;
    r[0x1E] = 0x10; // CTRL_REG0
    r[reg::CTRL_REG1 as usize] = 0x07;
    r
}

/// Output data rate (Hz) of `CTRL_REG1` (0 in power-down).
pub fn odr(ctrl1: u8) -> f64 {
    let low_power = ctrl1 & 0x08 != 0;
    match ctrl1 >> 4 {
        1 => 1.0,
        2 => 10.0,
        3 => 25.0,
        4 => 50.0,
        5 => 100.0,
        6 => 200.0,
        7 => 400.0,
        8 if low_power => 1620.0,
        9 if low_power => 5376.0,
        9 => 1344.0,
        _ => 0.0,
    }
}

/// Significant bits and sensitivity (g per digit of the significant value).
pub fn resolution(ctrl1: u8, ctrl4: u8) -> (u32, f64) {
    let fs = usize::from((ctrl4 >> 4) & 0x03);
    let hr = ctrl4 & 0x08 != 0;
    let lp = ctrl1 & 0x08 != 0;
    // mg/digit for ±2, 4, 8, 16 g.
    let (bits, mg) = if lp {
        (8, [16.0, 32.0, 64.0, 192.0])
    } else if hr {
        (12, [1.0, 2.0, 4.0, 12.0])
    } else {
        (10, [4.0, 8.0, 16.0, 48.0])
    };
    (bits, mg[fs] * 1e-3)
}

/// The LIS3DH register model.
pub struct Lis3dh {
    regs: [u8; NREG],
    /// Sampling, error model and measurement faults.
    front: Frontend,
    /// I²C state: sub-address, auto-increment, whether the sub-address byte has come.
    sub: u8,
    auto_inc: bool,
    have_sub: bool,
    /// BDU: a low byte of this axis has been read, its high byte not yet.
    bdu_hold: bool,
    /// A sample that arrived during a BDU hold, applied at its release.
    pending: Option<[u8; 6]>,
    /// The FIFO (stream mode), oldest first, and whether it overran since `FIFO_SRC_REG` was
    /// last read.
    fifo: VecDeque<[u8; 6]>,
    fifo_overrun: bool,
    /// Simulated time of the current transaction.
    now: f64,
}

impl Lis3dh {
    /// A part with the given errors, seeing the specific force `source` (part axes, m/s²).
    pub fn new(errors: SensorErrors, source: ForceSource) -> Self {
        Lis3dh {
            regs: reset_registers(),
            front: Frontend::new(errors, source),
            sub: 0,
            auto_inc: false,
            have_sub: false,
            bdu_hold: false,
            pending: None,
            fifo: VecDeque::with_capacity(FIFO_DEPTH),
            fifo_overrun: false,
            now: 0.0,
        }
    }

    /// Schedules measurement faults (stuck, bias jump, noise burst, saturation).
    pub fn set_faults(&mut self, faults: Vec<Fault>) {
        self.front.set_faults(faults);
    }

    fn odr(&self) -> f64 {
        odr(self.regs[reg::CTRL_REG1 as usize])
    }

    /// FIFO enabled and in stream mode.
    fn fifo_on(&self) -> bool {
        self.regs[reg::CTRL_REG5 as usize] & 0x40 != 0
            && self.regs[reg::FIFO_CTRL_REG as usize] >> 6 == 0b10
    }

    fn fifo_source(&mut self) -> u8 {
        let n = self.fifo.len();
        let threshold = usize::from(self.regs[reg::FIFO_CTRL_REG as usize] & 0x1F);
        let mut v = n.min(31) as u8;
        if n >= threshold && threshold > 0 {
            v |= 0x80;
        }
        if self.fifo_overrun {
            v |= 0x40;
        }
        if n == 0 {
            v |= 0x20;
        }
        self.fifo_overrun = false;
        v
    }

    fn catch_up(&mut self, t: f64) {
        let odr = self.odr();
        while let Some(ts) = self.front.next_due(t, odr) {
            self.take_sample(ts);
        }
    }

    fn take_sample(&mut self, t: f64) {
        let a = self.front.measure(t, self.odr() / 2.0);
        let ctrl1 = self.regs[reg::CTRL_REG1 as usize];
        let (bits, g_per_digit) = resolution(ctrl1, self.regs[reg::CTRL_REG4 as usize]);
        let max = (1i32 << (bits - 1)) - 1;
        let mut out = [0u8; 6];
        for (axis, v) in a.iter().enumerate() {
            let enabled = ctrl1 & (1 << axis) != 0;
            let c = if enabled {
                let c = (v / G0 / g_per_digit).round();
                if c.is_nan() {
                    0
                } else {
                    c.clamp(-f64::from(max) - 1.0, f64::from(max)) as i32
                }
            } else {
                0
            };
            let raw = ((c << (16 - bits)) as i16).to_le_bytes();
            out[2 * axis] = raw[0];
            out[2 * axis + 1] = raw[1];
        }
        let status = &mut self.regs[reg::STATUS_REG as usize];
        if *status & 0x08 != 0 {
            *status |= 0x80;
        }
        *status |= 0x08;
        if self.fifo_on() {
            if self.fifo.len() == FIFO_DEPTH {
                self.fifo.pop_front();
                self.fifo_overrun = true;
            }
            self.fifo.push_back(out);
        } else if self.bdu_hold {
            self.pending = Some(out);
        } else {
            self.latch(&out);
        }
    }

    fn latch(&mut self, out: &[u8; 6]) {
        let base = reg::OUT_X_L as usize;
        self.regs[base..base + 6].copy_from_slice(out);
    }

    /// Converts the temperature at `t` into `OUT_ADC3` if the ADC and sensor are on.
    fn convert_temperature(&mut self, t: f64) {
        if self.odr() > 0.0 && self.regs[reg::TEMP_CFG_REG as usize] & 0xC0 == 0xC0 {
            let digits = (self.front.temperature(t) - 25.0)
                .round()
                .clamp(-128.0, 127.0);
            self.regs[reg::OUT_ADC3_L as usize] = 0;
            self.regs[reg::OUT_ADC3_H as usize] = digits as i8 as u8;
        }
    }

    fn read_register(&mut self, a: u8) -> u8 {
        if a == reg::FIFO_SRC_REG {
            return self.fifo_source();
        }
        if self.fifo_on() && (reg::OUT_X_L..=reg::OUT_Z_H).contains(&a) {
            let head = self.fifo.front().copied().unwrap_or([0; 6]);
            if a == reg::OUT_Z_H {
                self.fifo.pop_front();
            }
            self.regs[reg::STATUS_REG as usize] &= !0x88;
            return head[usize::from(a - reg::OUT_X_L)];
        }
        let v = self.regs[usize::from(a) % NREG];
        if (reg::OUT_X_L..=reg::OUT_Z_H).contains(&a) {
            let status = &mut self.regs[reg::STATUS_REG as usize];
            *status &= !0x88;
            let bdu = self.regs[reg::CTRL_REG4 as usize] & 0x80 != 0;
            if bdu {
                if (a - reg::OUT_X_L).is_multiple_of(2) {
                    self.bdu_hold = true;
                } else {
                    self.bdu_hold = false;
                    if let Some(p) = self.pending.take() {
                        self.latch(&p);
                    }
                }
            }
        }
        v
    }

    fn write_register(&mut self, a: u8, v: u8) {
        match a {
            // Read-only: identity, status and outputs.
            reg::WHO_AM_I | reg::STATUS_REG | reg::FIFO_SRC_REG => {}
            reg::OUT_ADC3_L | reg::OUT_ADC3_H => {}
            a if (reg::OUT_X_L..=reg::OUT_Z_H).contains(&a) => {}
            reg::CTRL_REG5 if v & 0x80 != 0 => {
                // BOOT reloads the trimming; registers keep their contents.
                self.regs[a as usize] = v & 0x7F;
            }
            a if (a as usize) < NREG => {
                let old_odr = self.odr();
                self.regs[a as usize] = v;
                if !self.fifo_on() {
                    self.fifo.clear();
                    self.fifo_overrun = false;
                }
                if a == reg::CTRL_REG1 && self.odr() != old_odr {
                    // Restart the sample clock from the time of this write.
                    self.front.stop_clock();
                    self.catch_up(self.now);
                }
            }
            _ => {}
        }
    }

    fn advance_sub(&mut self) {
        if self.auto_inc {
            self.sub = if self.sub == reg::OUT_Z_H && self.fifo_on() {
                reg::OUT_X_L
            } else {
                (self.sub + 1) & 0x7F
            };
        }
    }
}

impl I2cTarget for Lis3dh {
    fn start(&mut self, now: f64, read: bool) -> bool {
        self.now = now;
        self.catch_up(now);
        self.convert_temperature(now);
        if !read {
            self.have_sub = false;
        }
        true
    }

    fn write(&mut self, byte: u8) -> bool {
        if !self.have_sub {
            self.sub = byte & 0x7F;
            self.auto_inc = byte & AUTO_INCREMENT != 0;
            self.have_sub = true;
        } else {
            let a = self.sub;
            self.write_register(a, byte);
            self.advance_sub();
        }
        true
    }

    fn read(&mut self) -> u8 {
        let a = self.sub;
        let v = self.read_register(a);
        self.advance_sub();
        v
    }

    fn stop(&mut self) {
        self.have_sub = false;
    }
}
