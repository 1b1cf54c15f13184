//! The drivers' bus traffic, byte for byte, against mock buses: start-up (reset,
//! identification, configuration) and data reads, and the errors they return.

use ballisto_fw::drivers::{adxl355, lis3dh, G0};
use embedded_hal_mock::eh1::i2c::{Mock as I2cMock, Transaction as I2cT};
use embedded_hal_mock::eh1::spi::{Mock as SpiMock, Transaction as SpiT};
use futures::executor::block_on;

/// One SPI transaction: a write of `w`, then (if any) a read of `r`.
fn spi(w: &[u8], r: Option<&[u8]>) -> Vec<SpiT<u8>> {
    let mut t = vec![SpiT::transaction_start(), SpiT::write_vec(w.to_vec())];
    if let Some(r) = r {
        t.push(SpiT::read_vec(r.to_vec()));
    }
    t.push(SpiT::transaction_end());
    t
}

fn adxl_start_up(ids: [u8; 3]) -> Vec<SpiT<u8>> {
    let mut t = spi(&[0x5E, 0x52], None); // RESET (0x2F) = 0x52
    t.extend(spi(&[0x01], Some(&ids))); // read DEVID_AD..PARTID
    t
}

fn adxl_config() -> Vec<SpiT<u8>> {
    let mut t = Vec::new();
    for w in [
        [0x5A, 0x01], // POWER_CTL: standby
        [0x50, 0x05], // FILTER: ODR 125 Hz
        [0x58, 0x81], // RANGE: ±2 g (I²C HS bit kept)
        [0x56, 0x01], // SYNC: external
        [0x5A, 0x00], // POWER_CTL: measure
    ] {
        t.extend(spi(&w, None));
    }
    t
}

const CONFIG: adxl355::Config = adxl355::Config {
    range: adxl355::Range::G2,
    // 125 Hz.
    odr: match adxl355::Odr::from_code(5) {
        Some(o) => o,
        None => panic!("code 5 is valid"),
    },
    sync: adxl355::Sync::External,
};

#[test]
fn adxl355_start_up_and_burst_read() {
    let mut t = adxl_start_up([0xAD, 0x1D, 0xED]);
    t.extend(adxl_config());
    // X = +256 000 (1 g), Y = −1, Z = 0x12345.
    t.extend(spi(
        &[0x11],
        Some(&[0x3E, 0x80, 0x00, 0xFF, 0xFF, 0xF0, 0x12, 0x34, 0x50]),
    ));
    // TEMP2, TEMP1 = 1 885 − 181 = 1 704: 45 °C; then a TEMP2 with bits 7:4 set.
    t.extend(spi(&[0x0D], Some(&[0x06, 0xA8])));
    t.extend(spi(&[0x0D], Some(&[0x16, 0xA8])));
    let mut mock = SpiMock::new(&t);
    let mut dev = block_on(adxl355::Adxl355::new(mock.clone(), CONFIG)).unwrap();
    let a = block_on(dev.read_acceleration()).unwrap();
    let lsb = G0 / 256_000.0;
    assert!((a[0] - G0).abs() < 1e-5);
    assert!((a[1] + lsb).abs() < 1e-9);
    assert!((a[2] - 0x12345 as f32 * lsb).abs() < 1e-5);
    let t = block_on(dev.read_temperature()).unwrap();
    assert!((t - 45.0).abs() < 1e-4, "{t}");
    assert_eq!(
        block_on(dev.read_temperature()),
        Err(adxl355::Error::Implausible)
    );
    mock.done();
}

#[test]
fn adxl355_wrong_ids_and_implausible_bytes_are_errors() {
    let t = adxl_start_up([0xFF, 0xFF, 0xFF]);
    let mut mock = SpiMock::new(&t);
    let r = block_on(adxl355::Adxl355::new(mock.clone(), CONFIG));
    assert!(matches!(
        r,
        Err(adxl355::Error::WrongId([0xFF, 0xFF, 0xFF]))
    ));
    mock.done();

    let mut t = adxl_start_up([0xAD, 0x1D, 0xED]);
    t.extend(adxl_config());
    // MISO high: the reserved low nibble of XDATA1 reads 1s.
    t.extend(spi(&[0x11], Some(&[0xFF; 9])));
    let mut mock = SpiMock::new(&t);
    let mut dev = block_on(adxl355::Adxl355::new(mock.clone(), CONFIG)).unwrap();
    assert_eq!(
        block_on(dev.read_acceleration()),
        Err(adxl355::Error::Implausible)
    );
    mock.done();
}

#[test]
fn adxl355_fifo_sets_start_at_the_x_marker_and_stop_at_empty() {
    let mut t = adxl_start_up([0xAD, 0x1D, 0xED]);
    t.extend(adxl_config());
    t.extend(spi(&[0x0B], Some(&[7]))); // FIFO_ENTRIES = 7: two sets
                                        // A torn Z entry first, then x (marker), y, z, then empty.
    t.extend(spi(
        &[0x23],
        Some(&[
            0x00, 0x01, 0x00, // z of an older set: skipped
            0x3E, 0x80, 0x01, // x = 1 g, marker
            0x00, 0x00, 0x00, // y = 0
            0xC1, 0x80, 0x00, // z = −1 g
            0x00, 0x00, 0x02, // empty
            0x00, 0x00, 0x02,
        ]),
    ));
    let mut mock = SpiMock::new(&t);
    let mut dev = block_on(adxl355::Adxl355::new(mock.clone(), CONFIG)).unwrap();
    let mut out = [[0.0f32; 3]; 4];
    assert_eq!(block_on(dev.read_fifo(&mut out)), Ok(1));
    assert!((out[0][0] - G0).abs() < 1e-5 && out[0][1] == 0.0 && (out[0][2] + G0).abs() < 1e-5);
    mock.done();
}

#[test]
fn odr_choices() {
    assert_eq!(adxl355::Odr::at_least(100.0).hz(), 125.0);
    assert_eq!(adxl355::Odr::at_least(4000.0).code(), 0);
    assert_eq!(adxl355::Odr::at_least(1.0).code(), 10);
    assert_eq!(adxl355::Odr::from_code(11), None);
    assert_eq!(lis3dh::Odr::at_least(100.0), lis3dh::Odr::Hz100);
    assert_eq!(lis3dh::Odr::at_least(500.0).code(), 9);
    assert_eq!(lis3dh::Odr::at_least(5000.0), lis3dh::Odr::Hz1344);
}

const ADDR: u8 = 0x19;

#[test]
fn lis3dh_start_up_and_burst_read() {
    let t = [
        I2cT::write_read(ADDR, vec![0x0F], vec![0x33]),
        I2cT::write(ADDR, vec![0x23, 0x88 | 0x10]), // BDU, ±4 g, HR
        I2cT::write(ADDR, vec![0x24, 0x00]),        // FIFO off
        I2cT::write(ADDR, vec![0x2E, 0x00]),        // bypass
        I2cT::write(ADDR, vec![0x1F, 0xC0]),        // ADC and temperature sensor on
        I2cT::write(ADDR, vec![0x20, 0x77]),        // 400 Hz, XYZ on
        // X = +1000 digits, Y = −1, Z = 0 (12-bit, left-justified, little-endian).
        I2cT::write_read(ADDR, vec![0xA8], vec![0x80, 0x3E, 0xF0, 0xFF, 0x00, 0x00]),
        I2cT::write_read(ADDR, vec![0xA8], vec![0x81, 0x3E, 0, 0, 0, 0]),
        // OUT_ADC3 with auto-increment: −5 digits, 20 °C.
        I2cT::write_read(ADDR, vec![0x8C], vec![0x00, 0xFB]),
    ];
    let mut mock = I2cMock::new(&t);
    let config = lis3dh::Config {
        range: lis3dh::Range::G4,
        odr: lis3dh::Odr::Hz400,
        fifo: false,
    };
    let mut dev = block_on(lis3dh::Lis3dh::new(mock.clone(), ADDR, config)).unwrap();
    let a = block_on(dev.read_acceleration()).unwrap();
    let digit = 2e-3 * G0;
    assert!((a[0] - 1000.0 * digit).abs() < 1e-4);
    assert!((a[1] + digit).abs() < 1e-6 && a[2] == 0.0);
    assert_eq!(
        block_on(dev.read_acceleration()),
        Err(lis3dh::Error::Implausible)
    );
    assert_eq!(block_on(dev.read_temperature()), Ok(20.0));
    mock.done();
}

#[test]
fn lis3dh_wrong_identity_is_an_error() {
    let t = [I2cT::write_read(ADDR, vec![0x0F], vec![0x32])];
    let mut mock = I2cMock::new(&t);
    let config = lis3dh::Config {
        range: lis3dh::Range::G2,
        odr: lis3dh::Odr::Hz100,
        fifo: false,
    };
    let r = block_on(lis3dh::Lis3dh::new(mock.clone(), ADDR, config));
    assert!(matches!(r, Err(lis3dh::Error::WrongId(0x32))));
    mock.done();
}

#[test]
fn lis3dh_fifo_stream_level_and_one_burst_of_samples() {
    let t = [
        I2cT::write_read(ADDR, vec![0x0F], vec![0x33]),
        I2cT::write(ADDR, vec![0x23, 0x88]), // BDU, ±2 g, HR
        I2cT::write(ADDR, vec![0x24, 0x40]), // FIFO_EN
        I2cT::write(ADDR, vec![0x2E, 0x80]), // stream mode
        I2cT::write(ADDR, vec![0x1F, 0xC0]), // ADC and temperature sensor on
        I2cT::write(ADDR, vec![0x20, 0x57]), // 100 Hz, XYZ on
        I2cT::write_read(ADDR, vec![0x2F], vec![0x42]), // OVRN, 2 samples
        // Two samples in one 12-byte burst: X = 16, then X = −16 digits.
        I2cT::write_read(
            ADDR,
            vec![0xA8],
            vec![0x00, 0x01, 0, 0, 0, 0, 0x00, 0xFF, 0, 0, 0, 0],
        ),
    ];
    let mut mock = I2cMock::new(&t);
    let config = lis3dh::Config {
        range: lis3dh::Range::G2,
        odr: lis3dh::Odr::Hz100,
        fifo: true,
    };
    let mut dev = block_on(lis3dh::Lis3dh::new(mock.clone(), ADDR, config)).unwrap();
    let level = block_on(dev.fifo_level()).unwrap();
    assert_eq!(
        level,
        lis3dh::FifoLevel {
            samples: 2,
            overrun: true
        }
    );
    let mut out = [[0.0f32; 3]; 2];
    block_on(dev.read_fifo(&mut out)).unwrap();
    let digit = 1e-3 * G0;
    assert!((out[0][0] - 16.0 * digit).abs() < 1e-5);
    assert!((out[1][0] + 16.0 * digit).abs() < 1e-5);
    mock.done();
}
