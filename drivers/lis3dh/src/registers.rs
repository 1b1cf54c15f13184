//! LIS3DH register map (datasheet DocID17530, section 7) and the I²C sub-address convention.

/// Identity: 0x33.
pub const WHO_AM_I: u8 = 0x0F;
/// The identity value.
pub const ID: u8 = 0x33;
/// ODR (7:4), low power (3), Z/Y/X enable (2:0).
pub const CTRL_REG1: u8 = 0x20;
/// BDU (7), BLE (6), full scale (5:4), high resolution (3).
pub const CTRL_REG4: u8 = 0x23;
/// Reboot (7), FIFO enable (6).
pub const CTRL_REG5: u8 = 0x24;
/// FIFO mode (7:6), threshold (4:0).
pub const FIFO_CTRL_REG: u8 = 0x2E;
/// FIFO status: WTM (7), OVRN (6), EMPTY (5), level (4:0).
pub const FIFO_SRC_REG: u8 = 0x2F;
/// Auxiliary ADC channel 3 (the temperature) low byte; its high byte follows.
pub const OUT_ADC3_L: u8 = 0x0C;
/// ADC enable (7), temperature sensor enable (6).
pub const TEMP_CFG_REG: u8 = 0x1F;
/// `TEMP_CFG_REG`: the ADC and the temperature sensor on.
pub const TEMP_ON: u8 = 0xC0;
/// Status: ZYXOR (7), ZYXDA (3).
pub const STATUS_REG: u8 = 0x27;
/// X low byte; X high, Y low/high, Z low/high follow.
pub const OUT_X_L: u8 = 0x28;
/// Sub-address flag: increment the register address after each byte.
pub const AUTO_INCREMENT: u8 = 0x80;

/// `CTRL_REG4` bit: block data update.
pub const BDU: u8 = 0x80;
/// `CTRL_REG4` bit: high resolution (12-bit).
pub const HR: u8 = 0x08;
/// `STATUS_REG` bit: new X, Y, Z data.
pub const ZYXDA: u8 = 0x08;
/// `STATUS_REG` bit: X, Y, Z data overwritten before being read.
pub const ZYXOR: u8 = 0x80;
/// `CTRL_REG5` bit: FIFO enable.
pub const FIFO_EN: u8 = 0x40;
/// `FIFO_CTRL_REG` mode bits: stream (the oldest sample is dropped when full).
pub const FIFO_STREAM: u8 = 0b10 << 6;
/// `FIFO_SRC_REG` bit: the FIFO overran (samples were lost).
pub const FIFO_OVRN: u8 = 0x40;
/// `FIFO_SRC_REG` level bits (unread samples).
pub const FIFO_LEVEL: u8 = 0x1F;
/// FIFO depth (samples).
pub const FIFO_DEPTH: usize = 32;
