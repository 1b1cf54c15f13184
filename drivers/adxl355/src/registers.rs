//! ADXL354/ADXL355 register map (datasheet Rev. D, table 15) and the SPI command byte.

/// Analog Devices ID: 0xAD.
pub const DEVID_AD: u8 = 0x00;
/// MEMS ID: 0x1D.
pub const DEVID_MST: u8 = 0x01;
/// Part ID: 0xED.
pub const PARTID: u8 = 0x02;
/// Status: DATA_RDY (0), FIFO_FULL (1), FIFO_OVR (2), ACTIVITY (3), NVM_BUSY (4).
pub const STATUS: u8 = 0x04;
/// Entries (axis values) in the FIFO.
pub const FIFO_ENTRIES: u8 = 0x05;
/// Temperature bits 11:8 (in bits 3:0); TEMP1, bits 7:0, follows.
pub const TEMP2: u8 = 0x06;
/// The temperature code at 25 °C (datasheet: nominal intercept, LSB).
pub const TEMP_INTERCEPT: f32 = 1885.0;
/// The temperature code's change per °C (datasheet: nominal slope, LSB/°C).
pub const TEMP_SLOPE: f32 = -9.05;
/// X data bits 19:12; XDATA2, XDATA1, then Y and Z follow (9 bytes).
pub const XDATA3: u8 = 0x08;
/// FIFO read port.
pub const FIFO_DATA: u8 = 0x11;
/// High-pass corner (6:4), ODR / low-pass (3:0).
pub const FILTER: u8 = 0x28;
/// External sync (1:0), external clock (2).
pub const SYNC: u8 = 0x2B;
/// I²C speed (7), interrupt polarity (6), range (1:0).
pub const RANGE: u8 = 0x2C;
/// Standby (0), temperature off (1), DRDY off (2).
pub const POWER_CTL: u8 = 0x2D;
/// Reset: write [`RESET_CODE`].
pub const RESET: u8 = 0x2F;
/// The code that resets the part.
pub const RESET_CODE: u8 = 0x52;

/// Expected identification bytes (DEVID_AD, DEVID_MST, PARTID).
pub const IDS: [u8; 3] = [0xAD, 0x1D, 0xED];

/// Status bit: new data.
pub const DATA_RDY: u8 = 0x01;
/// Status bit: FIFO overrun.
pub const FIFO_OVR: u8 = 0x04;

/// The command byte of a read of `addr` (auto-increment follows).
pub const fn read(addr: u8) -> u8 {
    (addr << 1) | 1
}

/// The command byte of a write of `addr`.
pub const fn write(addr: u8) -> u8 {
    addr << 1
}
