//! The driver's bus traffic, byte for byte, against a mock I²C bus: start-up
//! (identification, configuration) and data reads, and the errors they return.

use embedded_hal_mock::eh1::i2c::{Mock as I2cMock, Transaction as I2cT};
use futures::executor::block_on;
use lis3dh::STANDARD_GRAVITY as G0;

#[test]
fn odr_choices() {
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
