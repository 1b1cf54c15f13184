//! The firmware's drivers against hal-sim's register models: what they read is what the part
//! measures, and every bus fault reaches them as a driver error.

use ballisto_fw::drivers::{adxl355, lis3dh};
use embedded_hal::i2c::{Error as _, ErrorKind as I2cKind, NoAcknowledgeSource};
use embedded_hal::spi::{Error as _, ErrorKind as SpiKind};
use futures::executor::block_on;
use hal_sim::bus::i2c::SimI2cBus;
use hal_sim::bus::spi::{SimSpiBus, SimSpiDevice};
use hal_sim::clock::SimClock;
use hal_sim::faults::{Fault, FaultKind};
use hal_sim::sensors::adxl355::Adxl355;
use hal_sim::sensors::lis3dh::Lis3dh;
use hal_sim::sensors::sync_line::SyncLine;
use hal_sim::sensors::SensorErrors;

const F: [f64; 3] = [1.0, -2.0, 9.80665];

fn window(kind: FaultKind) -> Vec<Fault> {
    vec![Fault {
        start: 0.5,
        end: 0.7,
        kind,
    }]
}

fn adxl_config(odr: f32, sync: adxl355::Sync) -> adxl355::Config {
    adxl355::Config {
        range: adxl355::Range::G2,
        odr: adxl355::Odr::at_least(odr),
        sync,
    }
}

/// The driver started on chip select 0 of `bus`.
fn adxl_start(bus: &SimSpiBus, odr: f32, sync: adxl355::Sync) -> adxl355::Adxl355<SimSpiDevice> {
    block_on(adxl355::Adxl355::new(bus.device(0), adxl_config(odr, sync))).unwrap()
}

fn adxl_rig(faults: Vec<Fault>) -> (SimClock, SimSpiBus, SyncLine) {
    let clock = SimClock::new();
    let bus = SimSpiBus::new(clock.clone(), 10e6);
    let line = SyncLine::new();
    let mut part = Adxl355::new(SensorErrors::default(), Box::new(|_| F));
    part.set_faults(faults.clone());
    part.connect_sync(line.clone());
    bus.attach(0, Box::new(part));
    bus.set_faults(0, &faults);
    (clock, bus, line)
}

#[test]
fn adxl355_driver_reads_the_measured_force_on_sync_pulses() {
    let (clock, bus, line) = adxl_rig(Vec::new());
    let mut dev = adxl_start(&bus, 100.0, adxl355::Sync::External);
    // No pulse yet: no data.
    assert!(!block_on(dev.status()).unwrap().data_ready());
    clock.advance_to(0.01);
    line.pulse(0.01);
    assert!(block_on(dev.status()).unwrap().data_ready());
    let a = block_on(dev.read_acceleration()).unwrap();
    let lsb = 9.80665 / 256_000.0;
    for k in 0..3 {
        assert!((f64::from(a[k]) - F[k]).abs() < lsb, "axis {k}: {}", a[k]);
    }
}

#[test]
fn adxl355_driver_drains_the_fifo_of_the_internal_clock() {
    let (clock, bus, _) = adxl_rig(Vec::new());
    let mut dev = adxl_start(&bus, 1000.0, adxl355::Sync::Internal);
    clock.advance(0.0101);
    let mut out = [[0.0f32; 3]; 32];
    let n = block_on(dev.read_fifo(&mut out)).unwrap();
    assert_eq!(n, 10, "10 samples at 1 kHz in 10.1 ms");
    for s in &out[..n] {
        assert!((f64::from(s[2]) - F[2]).abs() < 1e-4);
    }
    assert_eq!(block_on(dev.read_fifo(&mut out)), Ok(0));
}

#[test]
fn adxl355_driver_sees_a_dead_or_corrupting_part_and_a_timeout() {
    // Dead from the start: identification fails.
    let (clock, bus, _) = adxl_rig(vec![Fault {
        start: 0.0,
        end: 1.0,
        kind: FaultKind::Dead,
    }]);
    let r = block_on(adxl355::Adxl355::new(
        bus.device(0),
        adxl_config(100.0, adxl355::Sync::Internal),
    ));
    assert!(matches!(
        r,
        Err(adxl355::Error::WrongId([0xFF, 0xFF, 0xFF]))
    ));
    drop(clock);

    // Dead during the run: implausible data, then normal again.
    let (clock, bus, _) = adxl_rig(window(FaultKind::Dead));
    let mut dev = adxl_start(&bus, 1000.0, adxl355::Sync::Internal);
    clock.advance_to(0.6);
    assert_eq!(
        block_on(dev.read_acceleration()),
        Err(adxl355::Error::Implausible)
    );
    clock.advance_to(0.8);
    assert!(block_on(dev.read_acceleration()).is_ok());

    // Timeout: the bus error, with its kind.
    let (clock, bus, _) = adxl_rig(window(FaultKind::Timeout { stall: 1e-3 }));
    let mut dev = adxl_start(&bus, 1000.0, adxl355::Sync::Internal);
    clock.advance_to(0.6);
    match block_on(dev.read_acceleration()) {
        Err(adxl355::Error::Bus(e)) => assert_eq!(e.kind(), SpiKind::Other),
        other => panic!("{other:?}"),
    }

    // Corruption: every read in the window fails or is off; most are caught as implausible.
    let (clock, bus, _) = adxl_rig(window(FaultKind::Corrupt { probability: 0.5 }));
    let mut dev = adxl_start(&bus, 1000.0, adxl355::Sync::Internal);
    clock.advance_to(0.5);
    let mut caught = 0;
    for _ in 0..100 {
        clock.advance(1e-3);
        if block_on(dev.read_acceleration()) == Err(adxl355::Error::Implausible) {
            caught += 1;
        }
    }
    assert!(caught > 50, "{caught} of 100 caught");
}

fn lis_rig(faults: Vec<Fault>) -> (SimClock, SimI2cBus) {
    let clock = SimClock::new();
    let bus = SimI2cBus::new(clock.clone(), 400e3);
    let mut part = Lis3dh::new(SensorErrors::default(), Box::new(|_| F));
    part.set_faults(faults.clone());
    bus.attach(0x18, Box::new(part));
    bus.set_faults(0x18, &faults);
    (clock, bus)
}

const LIS: lis3dh::Config = lis3dh::Config {
    range: lis3dh::Range::G2,
    odr: lis3dh::Odr::Hz400,
    fifo: false,
};

#[test]
fn lis3dh_driver_reads_the_measured_force_and_sees_bus_faults() {
    let (clock, bus) = lis_rig(window(FaultKind::Dead));
    let mut dev = block_on(lis3dh::Lis3dh::new(bus.clone(), 0x18, LIS)).unwrap();
    clock.advance_to(0.01);
    assert_eq!(block_on(dev.status()).unwrap(), (true, true));
    let a = block_on(dev.read_acceleration()).unwrap();
    for k in 0..3 {
        assert!((f64::from(a[k]) - F[k]).abs() < 9.80665e-3, "axis {k}");
    }
    clock.advance_to(0.6);
    match block_on(dev.read_acceleration()) {
        Err(lis3dh::Error::Bus(e)) => assert_eq!(
            e.kind(),
            I2cKind::NoAcknowledge(NoAcknowledgeSource::Address)
        ),
        other => panic!("{other:?}"),
    }
    clock.advance_to(0.8);
    assert!(block_on(dev.read_acceleration()).is_ok());
    // Nothing at the other address.
    let r = block_on(lis3dh::Lis3dh::new(bus, 0x19, LIS));
    assert!(matches!(r, Err(lis3dh::Error::Bus(_))));
}

#[test]
fn lis3dh_fifo_counts_every_conversion_of_the_parts_own_clock() {
    let (clock, bus) = lis_rig(Vec::new());
    let config = lis3dh::Config { fifo: true, ..LIS };
    let mut dev = block_on(lis3dh::Lis3dh::new(bus, 0x18, config)).unwrap();
    let start = clock.now();
    let mut total = 0usize;
    let mut out = [[0.0f32; 3]; 32];
    // Read every 10 ms for 1 s: 400 conversions, none lost, each close to the force.
    for k in 1..=100 {
        clock.advance_to(start + 0.01 * f64::from(k));
        let level = block_on(dev.fifo_level()).unwrap();
        assert!(!level.overrun);
        let n = usize::from(level.samples);
        block_on(dev.read_fifo(&mut out[..n])).unwrap();
        for s in &out[..n] {
            for a in 0..3 {
                assert!((f64::from(s[a]) - F[a]).abs() < 9.80665e-3, "axis {a}");
            }
        }
        total += n;
    }
    assert!(
        (399..=400).contains(&total),
        "{total} conversions in 1 s at 400 Hz"
    );
    // Left unread for 0.1 s, 40 conversions overflow the 32-sample FIFO.
    clock.advance_to(clock.now() + 0.1);
    let level = block_on(dev.fifo_level()).unwrap();
    assert!(level.overrun && level.samples == 31, "{level:?}");
}

/// Both drivers read their part's temperature through its registers: the ADXL355's within
/// its 0.11 °C code (nominal intercept and slope), the LIS3DH's relative one within its 1 °C
/// digit, following a chamber ramp with the part's own lag and sensor intercept; and a
/// warming part's readings move by its coefficients.
#[test]
fn drivers_read_the_parts_temperature() {
    use hal_sim::sensors::thermal::{PartThermal, Surroundings};
    let thermal = PartThermal {
        surroundings: Surroundings::Ramp {
            from: -10.0,
            to: 50.0,
            start: 0.0,
            duration: 60.0,
        },
        lag: 20.0,
        bias_tc: [1e-3, 0.0, 0.0],
        scale_tc: [0.0, 0.0, 1e-4],
        sensor_offset: 1.5,
    };
    let errors = SensorErrors {
        thermal,
        ..SensorErrors::default()
    };
    // ADXL355 on SPI, internal clock.
    let clock = SimClock::new();
    let bus = SimSpiBus::new(clock.clone(), 10e6);
    bus.attach(0, Box::new(Adxl355::new(errors.clone(), Box::new(|_| F))));
    let mut adxl = adxl_start(&bus, 125.0, adxl355::Sync::Internal);
    // LIS3DH on I²C.
    let i2c = SimI2cBus::new(clock.clone(), 400e3);
    i2c.attach(0x18, Box::new(Lis3dh::new(errors, Box::new(|_| F))));
    let mut lis = block_on(lis3dh::Lis3dh::new(i2c.clone(), 0x18, LIS)).unwrap();
    for t in [1.0, 20.0, 45.0, 90.0] {
        clock.advance_to(t);
        let sensed = thermal.sensed(clock.now());
        let a = f64::from(block_on(adxl.read_temperature()).unwrap());
        assert!(
            (a - sensed).abs() < 0.06,
            "ADXL355 at {t} s: {a} vs {sensed}"
        );
        let l = f64::from(block_on(lis.read_temperature()).unwrap());
        assert!(
            (l - sensed).abs() <= 0.5,
            "LIS3DH at {t} s: {l} vs {sensed}"
        );
        // The die's temperature moves x's bias and z's scale from 25 °C.
        let dt = thermal.die(clock.now()) - 25.0;
        let f = block_on(adxl.read_acceleration()).unwrap();
        let want = [F[0] + 1e-3 * dt, F[1], F[2] * (1.0 + 1e-4 * dt)];
        for k in 0..3 {
            assert!(
                (f64::from(f[k]) - want[k]).abs() < 1e-4,
                "axis {k} at {t} s"
            );
        }
    }
}
