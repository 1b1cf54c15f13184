//! The driver's bus traffic, byte for byte, against a mock SPI device: start-up (reset,
//! identification, configuration) and data reads, and the errors they return.

use adxl355::STANDARD_GRAVITY as G0;
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
}
