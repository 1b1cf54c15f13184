//! The LIS3DH register model as a driver sees it: through the simulated I²C bus and the
//! embedded-hal `I2c` traits only.

use embedded_hal::i2c::{Error as _, ErrorKind, I2c, NoAcknowledgeSource};
use hal_sim::bus::i2c::{SimI2cBus, SimI2cError};
use hal_sim::clock::SimClock;
use hal_sim::sensors::errors::G0;
use hal_sim::sensors::lis3dh::{reg, Lis3dh, AUTO_INCREMENT};
use hal_sim::sensors::SensorErrors;

const ADDR: u8 = 0x18;
const HZ: f64 = 400e3;

fn part(f: [f64; 3]) -> (SimClock, SimI2cBus) {
    let clock = SimClock::new();
    let bus = SimI2cBus::new(clock.clone(), HZ);
    bus.attach(
        ADDR,
        Box::new(Lis3dh::new(SensorErrors::default(), Box::new(move |_| f))),
    );
    (clock, bus)
}

fn read(bus: &mut SimI2cBus, sub: u8, n: usize) -> Vec<u8> {
    let mut buf = vec![0u8; n];
    bus.write_read(ADDR, &[sub], &mut buf).unwrap();
    buf
}

fn axis(b: &[u8], bits: u32) -> i32 {
    i32::from(i16::from_le_bytes([b[0], b[1]])) >> (16 - bits)
}

#[test]
fn identity_and_reset_values() {
    let (_, mut bus) = part([0.0; 3]);
    assert_eq!(read(&mut bus, reg::WHO_AM_I, 1), vec![0x33]);
    assert_eq!(read(&mut bus, reg::CTRL_REG1, 1), vec![0x07]);
}

#[test]
fn auto_increment_only_with_the_msb_of_the_sub_address() {
    let (_, mut bus) = part([0.0; 3]);
    // CTRL_REG1..CTRL_REG4 in one write, auto-increment.
    bus.write(
        ADDR,
        &[reg::CTRL_REG1 | AUTO_INCREMENT, 0x97, 0x00, 0x00, 0x88],
    )
    .unwrap();
    assert_eq!(
        read(&mut bus, reg::CTRL_REG1 | AUTO_INCREMENT, 4),
        vec![0x97, 0x00, 0x00, 0x88]
    );
    // Without the flag, every byte reads the same register.
    assert_eq!(read(&mut bus, reg::CTRL_REG1, 3), vec![0x97; 3]);
}

#[test]
fn outputs_are_left_justified_by_mode_and_range() {
    let f = [0.5 * G0, -0.25 * G0, G0];
    let (clock, mut bus) = part(f);
    // 400 Hz, high resolution, ±2 g: 12 bits, 1 mg/digit.
    bus.write(ADDR, &[reg::CTRL_REG1, 0x77]).unwrap();
    bus.write(ADDR, &[reg::CTRL_REG4, 0x08]).unwrap();
    clock.advance(0.01);
    assert_eq!(read(&mut bus, reg::STATUS_REG, 1)[0] & 0x08, 0x08, "ZYXDA");
    let b = read(&mut bus, reg::OUT_X_L | AUTO_INCREMENT, 6);
    assert_eq!(axis(&b[0..2], 12), 500);
    assert_eq!(axis(&b[2..4], 12), -250);
    assert_eq!(axis(&b[4..6], 12), 1000);
    assert_eq!(b[0] & 0x0F, 0, "the low 4 bits of a 12-bit value are zero");
    assert_eq!(
        read(&mut bus, reg::STATUS_REG, 1)[0] & 0x08,
        0,
        "cleared by reading"
    );
    // Normal mode ±8 g: 10 bits, 16 mg/digit.
    bus.write(ADDR, &[reg::CTRL_REG4, 0x20]).unwrap();
    clock.advance(0.01);
    let b = read(&mut bus, reg::OUT_X_L | AUTO_INCREMENT, 6);
    assert_eq!(axis(&b[4..6], 10), (1000.0f64 / 16.0).round() as i32);
}

#[test]
fn overrun_is_flagged_when_data_are_not_read_in_time() {
    let (clock, mut bus) = part([0.0; 3]);
    bus.write(ADDR, &[reg::CTRL_REG1, 0x57]).unwrap(); // 100 Hz
    clock.advance(0.025);
    assert_eq!(read(&mut bus, reg::STATUS_REG, 1)[0] & 0x88, 0x88);
}

#[test]
fn missing_address_and_timing() {
    let (clock, mut bus) = part([0.0; 3]);
    let err = bus.write(0x19, &[0x0F]).unwrap_err();
    assert_eq!(err, SimI2cError::AddressNack { address: 0x19 });
    assert_eq!(
        err.kind(),
        ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address)
    );
    // write_read of 6 bytes: START + addr + sub, repeated START + addr + 6 data, STOP:
    // 2 + 1 bit times for the conditions and 9 bit times for each of 9 bytes.
    let t0 = clock.now();
    let _ = read(&mut bus, reg::OUT_X_L | AUTO_INCREMENT, 6);
    let expect = (3.0 + 9.0 * 9.0) / HZ;
    assert!(
        (clock.now() - t0 - expect).abs() < 1e-12,
        "{}",
        clock.now() - t0
    );
}

#[test]
fn async_bus_reads_the_same_registers() {
    use embedded_hal_async::i2c::I2c as AsyncI2c;
    let (_, mut bus) = part([0.0; 3]);
    let mut id = [0u8; 1];
    futures::executor::block_on(AsyncI2c::write_read(
        &mut bus,
        ADDR,
        &[reg::WHO_AM_I],
        &mut id,
    ))
    .unwrap();
    assert_eq!(id, [0x33]);
}

#[test]
fn block_data_update_keeps_low_and_high_bytes_of_one_sample() {
    for bdu in [true, false] {
        let clock = SimClock::new();
        let mut bus = SimI2cBus::new(clock.clone(), HZ);
        // A ramp of 50 g/s along x: 1 mg per 20 µs.
        bus.attach(
            ADDR,
            Box::new(Lis3dh::new(
                SensorErrors::default(),
                Box::new(|t| [50.0 * G0 * t, 0.0, 0.0]),
            )),
        );
        let ctrl4 = if bdu { 0x88 } else { 0x08 };
        bus.write(ADDR, &[reg::CTRL_REG4, ctrl4]).unwrap();
        bus.write(ADDR, &[reg::CTRL_REG1, 0x77]).unwrap();
        clock.advance(0.01);
        let lo = read(&mut bus, reg::OUT_X_L, 1)[0];
        clock.advance(0.01);
        let hi = read(&mut bus, reg::OUT_X_H, 1)[0];
        let v = axis(&[lo, hi], 12);
        if bdu {
            // Both bytes from the sample at ≈ 10 ms (≈ 500 mg).
            assert!((480..=520).contains(&v), "BDU: {v}");
        } else {
            // The high byte is from the sample at ≈ 20 ms: a torn value.
            assert!(v > 900, "no BDU: {v}");
        }
    }
}
