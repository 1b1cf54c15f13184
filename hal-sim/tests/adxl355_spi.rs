//! The ADXL355 register model as a driver sees it: through the simulated SPI bus and the
//! embedded-hal `SpiDevice` traits only.

use embedded_hal::spi::{Error as _, ErrorKind, Operation, SpiDevice};
use hal_sim::bus::spi::{SimSpiBus, SimSpiDevice, SimSpiError};
use hal_sim::clock::SimClock;
use hal_sim::sensors::adxl355::{code_from_bytes as decode, reg, Adxl355, RESET_CODE};
use hal_sim::sensors::errors::G0;
use hal_sim::sensors::SensorErrors;

const HZ: f64 = 10e6;

fn read(dev: &mut SimSpiDevice, addr: u8, n: usize) -> Vec<u8> {
    let mut buf = vec![0u8; n];
    dev.transaction(&mut [
        Operation::Write(&[(addr << 1) | 1]),
        Operation::Read(&mut buf),
    ])
    .unwrap();
    buf
}

fn write(dev: &mut SimSpiDevice, addr: u8, v: &[u8]) {
    let mut bytes = vec![addr << 1];
    bytes.extend_from_slice(v);
    dev.write(&bytes).unwrap();
}

fn part(errors: SensorErrors, f: [f64; 3]) -> (SimClock, SimSpiBus, SimSpiDevice) {
    let clock = SimClock::new();
    let bus = SimSpiBus::new(clock.clone(), HZ);
    let dev = bus.attach(0, Box::new(Adxl355::new(errors, Box::new(move |_| f))));
    (clock, bus, dev)
}

#[test]
fn ids_read_with_auto_increment() {
    let (_, _, mut dev) = part(SensorErrors::default(), [0.0; 3]);
    assert_eq!(
        read(&mut dev, reg::DEVID_AD, 4),
        vec![0xAD, 0x1D, 0xED, 0x01]
    );
    // Writes to read-only registers are ignored.
    write(&mut dev, reg::DEVID_AD, &[0x00]);
    assert_eq!(read(&mut dev, reg::DEVID_AD, 1), vec![0xAD]);
}

#[test]
fn configuration_writes_read_back_and_reset_restores_them() {
    let (_, _, mut dev) = part(SensorErrors::default(), [0.0; 3]);
    assert_eq!(
        read(&mut dev, reg::RANGE, 2),
        vec![0x81, 0x01],
        "reset values"
    );
    // Two registers in one write (auto-increment): FILTER then FIFO_SAMPLES.
    write(&mut dev, reg::FILTER, &[0x05, 0x30]);
    write(&mut dev, reg::RANGE, &[0x83]);
    assert_eq!(read(&mut dev, reg::FILTER, 2), vec![0x05, 0x30]);
    assert_eq!(read(&mut dev, reg::RANGE, 1), vec![0x83]);
    write(&mut dev, reg::RESET, &[0x12]);
    assert_eq!(
        read(&mut dev, reg::RANGE, 1),
        vec![0x83],
        "only 0x52 resets"
    );
    write(&mut dev, reg::RESET, &[RESET_CODE]);
    assert_eq!(read(&mut dev, reg::FILTER, 1), vec![0x00]);
    assert_eq!(read(&mut dev, reg::RANGE, 2), vec![0x81, 0x01]);
}

#[test]
fn data_registers_hold_the_20_bit_codes_and_data_ready_follows_them() {
    let f = [G0, -0.5 * G0, 2.0];
    let (clock, _, mut dev) = part(SensorErrors::default(), f);
    // Standby: no data.
    clock.advance(0.01);
    assert_eq!(read(&mut dev, reg::STATUS, 1)[0] & 1, 0);
    write(&mut dev, reg::POWER_CTL, &[0x00]);
    clock.advance(0.001);
    assert_eq!(read(&mut dev, reg::STATUS, 1)[0] & 1, 1, "DATA_RDY");
    let b = read(&mut dev, reg::XDATA3, 9);
    for (axis, want) in f.iter().enumerate() {
        let code = decode(&b[3 * axis..3 * axis + 3]);
        let expect = (want / G0 * 256_000.0).round() as i32;
        assert_eq!(code, expect, "axis {axis}");
        assert_eq!(b[3 * axis + 2] & 0x0F, 0, "low nibble of DATA1 is zero");
    }
    assert_eq!(
        read(&mut dev, reg::STATUS, 1)[0] & 1,
        0,
        "cleared by reading data"
    );
}

#[test]
fn range_scales_and_saturates() {
    let f = [3.0 * G0, -3.0 * G0, 7.0 * G0];
    let (clock, _, mut dev) = part(SensorErrors::default(), f);
    write(&mut dev, reg::POWER_CTL, &[0x00]);
    clock.advance(0.001);
    let b = read(&mut dev, reg::XDATA3, 9);
    assert_eq!(decode(&b[0..3]), (1 << 19) - 1, "±2 g saturates high");
    assert_eq!(decode(&b[3..6]), -(1 << 19), "and low");
    write(&mut dev, reg::RANGE, &[0x83]);
    clock.advance(0.001);
    let b = read(&mut dev, reg::XDATA3, 9);
    assert_eq!(decode(&b[0..3]), 3 * 64_000);
    assert_eq!(decode(&b[6..9]), 7 * 64_000);
}

#[test]
fn fifo_holds_marked_x_y_z_entries() {
    let f = [0.1, 0.2, 0.3];
    let (clock, _, mut dev) = part(SensorErrors::default(), f);
    write(&mut dev, reg::POWER_CTL, &[0x00]);
    // 4 kHz for 1.0 ms: 4 samples, 12 entries.
    clock.advance(0.0010001);
    assert_eq!(read(&mut dev, reg::FIFO_ENTRIES, 1), vec![12]);
    let b = read(&mut dev, reg::FIFO_DATA, 9);
    assert_eq!(b[2] & 1, 1, "x entry marked");
    assert_eq!(b[5] & 1, 0);
    assert_eq!(b[8] & 1, 0);
    assert_eq!(decode(&b[3..6]), (0.2 / G0 * 256_000.0f64).round() as i32);
    assert_eq!(read(&mut dev, reg::FIFO_ENTRIES, 1), vec![9]);
    // Drain, then an empty read says so.
    let _ = read(&mut dev, reg::FIFO_DATA, 27);
    let e = read(&mut dev, reg::FIFO_DATA, 3);
    assert_eq!(e[2] & 0x02, 0x02, "empty indicator");
}

#[test]
fn the_part_clock_runs_at_its_own_rate() {
    // A 5 % fast clock (exaggerated to be visible in a few samples): 21 samples in 5 ms.
    let errors = SensorErrors {
        clock_ppm: 50_000.0,
        ..SensorErrors::default()
    };
    let (clock, _, mut dev) = part(errors, [0.0; 3]);
    write(&mut dev, reg::POWER_CTL, &[0x00]);
    let t0 = clock.now();
    clock.advance_to(t0 + 0.005);
    assert_eq!(read(&mut dev, reg::FIFO_ENTRIES, 1), vec![63]);
}

#[test]
fn transactions_take_bus_time_and_missing_devices_are_errors() {
    let (clock, bus, mut dev) = part(SensorErrors::default(), [0.0; 3]);
    let t0 = clock.now();
    let _ = read(&mut dev, reg::XDATA3, 9);
    // 10 bytes at 10 MHz plus one bit time of chip-select setup and hold each.
    let expect = (10.0 * 8.0 + 2.0) / HZ;
    assert!((clock.now() - t0 - expect).abs() < 1e-15);
    assert_eq!(bus.usage().0, 10);
    let mut none = bus.device(3);
    let err = none.write(&[0x01]).unwrap_err();
    assert_eq!(err, SimSpiError::NoDevice { cs: 3 });
    assert_eq!(err.kind(), ErrorKind::ChipSelectFault);
}

#[test]
fn async_device_reads_the_same_registers() {
    use embedded_hal_async::spi::SpiDevice as AsyncSpiDevice;
    let (_, _, mut dev) = part(SensorErrors::default(), [0.0; 3]);
    let mut buf = [0u8; 3];
    futures::executor::block_on(AsyncSpiDevice::transaction(
        &mut dev,
        &mut [Operation::Write(&[0x01]), Operation::Read(&mut buf)],
    ))
    .unwrap();
    assert_eq!(buf, [0xAD, 0x1D, 0xED]);
}

#[test]
fn noise_follows_the_odr() {
    // 25 µg/√Hz: σ = nd·√(ODR/4) per sample; at 4 kHz that is 25 µg·√1000.
    let nd = 25e-6 * G0;
    let errors = SensorErrors {
        noise_density: nd,
        seed: 7,
        ..SensorErrors::default()
    };
    for (filter, odr) in [(0u8, 4000.0f64), (4, 250.0)] {
        let (clock, _, mut dev) = part(errors.clone(), [0.0; 3]);
        write(&mut dev, reg::FILTER, &[filter]);
        write(&mut dev, reg::POWER_CTL, &[0x00]);
        let mut sum2 = 0.0;
        let n = 2000;
        for _ in 0..n {
            clock.advance(1.0 / odr);
            let b = read(&mut dev, reg::XDATA3, 3);
            let a = f64::from(decode(&b)) / 256_000.0 * G0;
            sum2 += a * a;
        }
        let sd = (sum2 / n as f64).sqrt();
        let want = nd * (odr / 4.0).sqrt();
        assert!(
            (sd / want - 1.0).abs() < 0.08,
            "ODR {odr}: sd {sd} want {want}"
        );
    }
}

#[test]
fn scale_bias_and_cross_axis_enter_as_configured() {
    let mut cross = [[0.0; 3]; 3];
    cross[0][1] = 0.01;
    cross[2][0] = -0.02;
    let errors = SensorErrors {
        scale: [1.01, 0.99, 1.0],
        bias: [0.05, -0.03, 0.0],
        cross,
        ..SensorErrors::default()
    };
    let f = [1.0, 2.0, 3.0];
    let (clock, _, mut dev) = part(errors, f);
    write(&mut dev, reg::POWER_CTL, &[0x00]);
    clock.advance(0.001);
    let b = read(&mut dev, reg::XDATA3, 9);
    let want = [
        1.01 * (1.0 + 0.01 * 2.0) + 0.05,
        0.99 * 2.0 - 0.03,
        3.0 - 0.02 * 1.0,
    ];
    for axis in 0..3 {
        let a = f64::from(decode(&b[3 * axis..3 * axis + 3])) / 256_000.0 * G0;
        // Within half an LSB (quantisation).
        assert!(
            (a - want[axis]).abs() <= 0.5 * G0 / 256_000.0 + 1e-12,
            "axis {axis}: {a}"
        );
    }
}
