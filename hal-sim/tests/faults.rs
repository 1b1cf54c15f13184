//! Each scheduled fault is visible on the bus — and only there — from its start to its end.
//! Faults are active for 0.5 s ≤ t < 0.7 s; the parts are read before, during and after.

use embedded_hal::i2c::{Error as _, ErrorKind as I2cKind, I2c, NoAcknowledgeSource};
use embedded_hal::spi::{Error as _, ErrorKind as SpiKind, Operation, SpiDevice};
use hal_sim::bus::i2c::SimI2cBus;
use hal_sim::bus::spi::{SimSpiBus, SimSpiDevice};
use hal_sim::clock::SimClock;
use hal_sim::faults::{Fault, FaultKind};
use hal_sim::sensors::adxl355::{self, reg, Adxl355};
use hal_sim::sensors::errors::G0;
use hal_sim::sensors::lis3dh::{self, Lis3dh, AUTO_INCREMENT};
use hal_sim::sensors::SensorErrors;

const START: f64 = 0.5;
const END: f64 = 0.7;
/// The specific force every part sees (part axes, m/s²).
const F: [f64; 3] = [1.0, -2.0, G0];

fn window(kind: FaultKind) -> Vec<Fault> {
    vec![Fault {
        start: START,
        end: END,
        kind,
    }]
}

/// An ADXL355 measuring at 1 kHz (±2 g, 3.83e-5 m/s² per LSB) with the given noise.
fn adxl(noise_density: f64, kind: FaultKind) -> (SimClock, SimSpiDevice) {
    let clock = SimClock::new();
    let bus = SimSpiBus::new(clock.clone(), 10e6);
    let mut part = Adxl355::new(
        SensorErrors {
            noise_density,
            ..Default::default()
        },
        Box::new(|_| F),
    );
    let faults = window(kind);
    part.set_faults(faults.clone());
    let mut dev = bus.attach(0, Box::new(part));
    bus.set_faults(0, &faults);
    dev.write(&[reg::FILTER << 1, 0x02]).unwrap();
    dev.write(&[reg::POWER_CTL << 1, 0x00]).unwrap();
    (clock, dev)
}

/// X, Y, Z in m/s² from one burst read of the data registers.
fn adxl_read(dev: &mut SimSpiDevice) -> [f64; 3] {
    let mut b = [0u8; 9];
    dev.transaction(&mut [
        Operation::Write(&[(reg::XDATA3 << 1) | 1]),
        Operation::Read(&mut b),
    ])
    .unwrap();
    let mut out = [0.0; 3];
    for (o, c) in out.iter_mut().zip(b.chunks_exact(3)) {
        *o = f64::from(adxl355::code_from_bytes(c)) / 256_000.0 * G0;
    }
    out
}

/// Readings every 2 ms over [t0, t1).
fn adxl_series(clock: &SimClock, dev: &mut SimSpiDevice, t0: f64, t1: f64) -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    let mut t = t0;
    while t < t1 {
        clock.advance_to(t);
        out.push(adxl_read(dev));
        t += 0.002;
    }
    out
}

fn mean_sd(v: &[[f64; 3]], axis: usize) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().map(|x| x[axis]).sum::<f64>() / n;
    let var = v.iter().map(|x| (x[axis] - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, var.sqrt())
}

const ND: f64 = 2.5e-4; // 25 µg/√Hz: 2.5e-4 m/s²/√Hz, σ = 3.9e-3 m/s² at 1 kHz.

#[test]
fn stuck_output_repeats_one_value_during_the_window_only() {
    let (clock, mut dev) = adxl(ND, FaultKind::Stuck);
    let before = adxl_series(&clock, &mut dev, 0.3, 0.4);
    let during = adxl_series(&clock, &mut dev, START + 0.01, END - 0.01);
    let after = adxl_series(&clock, &mut dev, END + 0.01, END + 0.1);
    assert!(
        during.iter().all(|r| *r == during[0]),
        "frozen in the window"
    );
    for series in [&before, &after] {
        let distinct = series.windows(2).filter(|w| w[0] != w[1]).count();
        assert!(distinct > series.len() / 2, "live outside the window");
    }
}

#[test]
fn bias_jump_shifts_the_mean_by_the_configured_step() {
    let bias = [0.05, -0.1, 0.2];
    let (clock, mut dev) = adxl(ND, FaultKind::BiasJump { bias });
    let before = adxl_series(&clock, &mut dev, 0.3, 0.45);
    let during = adxl_series(&clock, &mut dev, START + 0.005, END - 0.005);
    let after = adxl_series(&clock, &mut dev, END + 0.005, END + 0.15);
    for axis in 0..3 {
        let (m0, sd) = mean_sd(&before, axis);
        let (m1, _) = mean_sd(&during, axis);
        let (m2, _) = mean_sd(&after, axis);
        // Means of ~75 samples: 5 standard errors.
        let tol = 5.0 * sd / (before.len() as f64).sqrt() * 2f64.sqrt();
        assert!((m0 - F[axis]).abs() < tol, "axis {axis} before");
        assert!((m1 - m0 - bias[axis]).abs() < tol, "axis {axis} step");
        assert!((m2 - m0).abs() < tol, "axis {axis} after");
    }
}

#[test]
fn drift_grows_the_bias_at_the_configured_rate() {
    let rate = [0.5, -1.0, 2.0];
    let (clock, mut dev) = adxl(ND, FaultKind::Drift { rate });
    let before = adxl_series(&clock, &mut dev, 0.3, 0.45);
    let (t0, t1) = (START + 0.005, END - 0.005);
    let during = adxl_series(&clock, &mut dev, t0, t1);
    let after = adxl_series(&clock, &mut dev, END + 0.005, END + 0.15);
    // The slope of the readings against their times while it drifts (a constant output delay
    // does not change it), within 5 standard errors of a least-squares slope.
    let times: Vec<f64> = (0..during.len()).map(|k| t0 + 0.002 * k as f64).collect();
    let t_mean = times.iter().sum::<f64>() / times.len() as f64;
    let stt: f64 = times.iter().map(|t| (t - t_mean).powi(2)).sum();
    for axis in 0..3 {
        let (m0, sd) = mean_sd(&before, axis);
        let (m2, _) = mean_sd(&after, axis);
        let (m1, _) = mean_sd(&during, axis);
        let slope = times
            .iter()
            .zip(&during)
            .map(|(t, v)| (t - t_mean) * (v[axis] - m1))
            .sum::<f64>()
            / stt;
        assert!(
            (slope - rate[axis]).abs() < 5.0 * sd / stt.sqrt(),
            "axis {axis}: slope {slope} against {}",
            rate[axis]
        );
        // Before and after: no bias.
        let tol = 5.0 * sd / (before.len() as f64).sqrt() * 2f64.sqrt();
        assert!((m0 - F[axis]).abs() < tol, "axis {axis} before");
        assert!((m2 - m0).abs() < tol, "axis {axis} after");
    }
}

#[test]
fn noise_burst_raises_the_spread_to_the_configured_density() {
    let burst = 10.0 * ND;
    let (clock, mut dev) = adxl(ND, FaultKind::NoiseBurst { density: burst });
    let before = adxl_series(&clock, &mut dev, 0.3, 0.45);
    let during = adxl_series(&clock, &mut dev, START + 0.005, END - 0.005);
    let after = adxl_series(&clock, &mut dev, END + 0.005, END + 0.15);
    let bw: f64 = 1000.0 / 4.0;
    let expect_quiet = ND * bw.sqrt();
    let expect_burst = (ND * ND + burst * burst).sqrt() * bw.sqrt();
    for axis in 0..3 {
        let (_, s0) = mean_sd(&before, axis);
        let (_, s1) = mean_sd(&during, axis);
        let (_, s2) = mean_sd(&after, axis);
        // Sample standard deviations of ~75 values: within 30 %.
        assert!((s0 / expect_quiet - 1.0).abs() < 0.3, "axis {axis}: {s0}");
        assert!((s1 / expect_burst - 1.0).abs() < 0.3, "axis {axis}: {s1}");
        assert!((s2 / expect_quiet - 1.0).abs() < 0.3, "axis {axis}: {s2}");
    }
}

#[test]
fn saturation_pins_every_axis_at_full_scale() {
    let (clock, mut dev) = adxl(0.0, FaultKind::Saturation);
    let full = f64::from((1 << 19) - 1) / 256_000.0 * G0;
    clock.advance_to(0.4);
    assert!((adxl_read(&mut dev)[2] - G0).abs() < 1e-4);
    clock.advance_to(0.6);
    assert_eq!(adxl_read(&mut dev), [full; 3]);
    clock.advance_to(0.8);
    assert!((adxl_read(&mut dev)[0] - F[0]).abs() < 1e-4);
}

fn devid(dev: &mut SimSpiDevice) -> Result<u8, SpiKind> {
    let mut b = [0u8; 1];
    dev.transaction(&mut [
        Operation::Write(&[(reg::DEVID_AD << 1) | 1]),
        Operation::Read(&mut b),
    ])
    .map_err(|e| e.kind())?;
    Ok(b[0])
}

#[test]
fn dead_spi_part_reads_all_ones_and_takes_no_writes() {
    let (clock, mut dev) = adxl(0.0, FaultKind::Dead);
    clock.advance_to(0.4);
    assert_eq!(devid(&mut dev), Ok(0xAD));
    clock.advance_to(0.6);
    assert_eq!(devid(&mut dev), Ok(0xFF));
    assert_eq!(adxl_read(&mut dev)[0], -G0 / 256_000.0, "0xFFFFF = −1 LSB");
    // A write while dead does not reach the part.
    dev.write(&[reg::RANGE << 1, 0x83]).unwrap();
    clock.advance_to(0.8);
    assert_eq!(devid(&mut dev), Ok(0xAD));
    let mut r = [0u8; 1];
    dev.transaction(&mut [
        Operation::Write(&[(reg::RANGE << 1) | 1]),
        Operation::Read(&mut r),
    ])
    .unwrap();
    assert_eq!(r[0], 0x81, "range untouched");
}

#[test]
fn corruption_flips_one_bit_per_byte_read() {
    let (clock, mut dev) = adxl(0.0, FaultKind::Corrupt { probability: 1.0 });
    clock.advance_to(0.4);
    assert_eq!(devid(&mut dev), Ok(0xAD));
    clock.advance_to(0.6);
    let mut seen = std::collections::HashSet::new();
    for _ in 0..50 {
        let b = devid(&mut dev).unwrap();
        assert_eq!((b ^ 0xAD).count_ones(), 1, "{b:#04x}");
        seen.insert(b);
    }
    assert!(seen.len() > 4, "random bits: {seen:?}");
    clock.advance_to(0.8);
    assert_eq!(devid(&mut dev), Ok(0xAD));
}

#[test]
fn spi_timeout_fails_the_transaction_after_the_stall() {
    let (clock, mut dev) = adxl(0.0, FaultKind::Timeout { stall: 1e-3 });
    clock.advance_to(0.6);
    assert_eq!(devid(&mut dev), Err(SpiKind::Other));
    assert!((clock.now() - 0.601).abs() < 1e-12, "stalled 1 ms");
    clock.advance_to(0.8);
    assert_eq!(devid(&mut dev), Ok(0xAD));
}

const ADDR: u8 = 0x19;

fn lis(kind: FaultKind) -> (SimClock, SimI2cBus) {
    let clock = SimClock::new();
    let bus = SimI2cBus::new(clock.clone(), 400e3);
    let mut part = Lis3dh::new(SensorErrors::default(), Box::new(|_| F));
    let faults = window(kind);
    part.set_faults(faults.clone());
    bus.attach(ADDR, Box::new(part));
    bus.set_faults(ADDR, &faults);
    let mut b = bus.clone();
    // 400 Hz, high resolution, ±2 g.
    b.write(ADDR, &[lis3dh::reg::CTRL_REG1, 0x77]).unwrap();
    b.write(ADDR, &[lis3dh::reg::CTRL_REG4, 0x08]).unwrap();
    (clock, bus)
}

fn who(bus: &mut SimI2cBus) -> Result<u8, I2cKind> {
    let mut b = [0u8; 1];
    bus.write_read(ADDR, &[lis3dh::reg::WHO_AM_I], &mut b)
        .map_err(|e| e.kind())?;
    Ok(b[0])
}

fn lis_z(bus: &mut SimI2cBus) -> f64 {
    let mut b = [0u8; 6];
    bus.write_read(ADDR, &[lis3dh::reg::OUT_X_L | AUTO_INCREMENT], &mut b)
        .unwrap();
    f64::from(i16::from_le_bytes([b[4], b[5]]) >> 4) * 1e-3 * G0
}

#[test]
fn dead_i2c_part_does_not_acknowledge_its_address() {
    let (clock, mut bus) = lis(FaultKind::Dead);
    clock.advance_to(0.4);
    assert_eq!(who(&mut bus), Ok(0x33));
    clock.advance_to(0.6);
    assert_eq!(
        who(&mut bus),
        Err(I2cKind::NoAcknowledge(NoAcknowledgeSource::Address))
    );
    clock.advance_to(0.8);
    assert_eq!(who(&mut bus), Ok(0x33));
}

#[test]
fn i2c_corruption_and_timeout_show_in_the_window() {
    let (clock, mut bus) = lis(FaultKind::Corrupt { probability: 1.0 });
    clock.advance_to(0.6);
    let b = who(&mut bus).unwrap();
    assert_eq!((b ^ 0x33).count_ones(), 1);
    clock.advance_to(0.8);
    assert_eq!(who(&mut bus), Ok(0x33));

    let (clock, mut bus) = lis(FaultKind::Timeout { stall: 25e-3 });
    clock.advance_to(0.6);
    assert_eq!(who(&mut bus), Err(I2cKind::Other));
    assert!(clock.now() > 0.625, "stalled 25 ms");
    clock.advance_to(0.8);
    assert_eq!(who(&mut bus), Ok(0x33));
}

#[test]
fn measurement_faults_reach_the_i2c_part_too() {
    let (clock, mut bus) = lis(FaultKind::BiasJump {
        bias: [0.0, 0.0, 0.5],
    });
    clock.advance_to(0.4);
    let z0 = lis_z(&mut bus);
    clock.advance_to(0.6);
    let z1 = lis_z(&mut bus);
    clock.advance_to(0.8);
    let z2 = lis_z(&mut bus);
    // 12-bit, 1 mg per digit: the 0.5 m/s² step is 51 digits.
    assert!((z0 - G0).abs() < 0.01 && (z2 - G0).abs() < 0.01);
    assert!((z1 - z0 - 0.5).abs() < 0.01, "{z1} vs {z0}");
    let (clock, mut bus) = lis(FaultKind::Saturation);
    clock.advance_to(0.6);
    assert!((lis_z(&mut bus) - 2047.0e-3 * G0).abs() < 1e-9);
}
