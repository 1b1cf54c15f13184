//! Bus budgets of the firmware's sampling, measured on hal-sim's buses (bytes and busy time at
//! the configured clocks, start-up excluded), and the highest sample rate they allow. Prints
//! the figures; asserts that the sets fit their period at the scenario rates.

use ballisto_fw::config::Alignment;
use hal_sim::firmware_host::{firmware_config, run_firmware};
use hal_sim::scenario::Scenario;

/// Bus busy time per sample set (s), summed over buses (the sampler reads one part after the
/// other), and the sets run.
fn bus_time_per_set(text: &str) -> (f64, u32) {
    let sc = Scenario::parse(text, "budget").unwrap();
    let loaded = sc.arrangement().load("arrangement.toml").unwrap();
    let config = firmware_config(&sc, &loaded, Alignment::Interpolate).unwrap();
    let r = run_firmware(&sc, &config, sc.samples() as u32, &mut |_, _, _| {}).unwrap();
    let busy: f64 = r.buses.iter().map(|(_, _, t)| t).sum();
    assert!(r.parts.iter().all(|p| p.missed <= 1), "{:?}", r.parts);
    (busy / f64::from(r.sampling.sets), r.sampling.sets)
}

/// The tetrahedral arrangement of `tetra-orbit` at another rate, 2 s.
fn tetra(rate: f64) -> String {
    hal_sim::scenario::named::text("tetra-orbit")
        .unwrap()
        .replace("rate = 100.0", &format!("rate = {rate}"))
        .replace("duration = 20.0", "duration = 2.0")
}

/// 4 × ADXL355 on SPI at 10 MHz (external sync).
fn spi_adxl355(rate: f64) -> String {
    tetra(rate)
}

/// The same four mounts with LIS3DH parts, two on each of two 400 kHz I²C buses (the part has
/// two addresses).
fn i2c_lis3dh(rate: f64) -> String {
    let mut s = tetra(rate)
        .replace("type = \"adxl355\"", "type = \"lis3dh\"")
        .replace(
            "name = \"spi1\"\nkind = \"spi\"\nclock_hz = 10e6",
            "name = \"i2c1\"\nkind = \"i2c\"\nclock_hz = 400e3\n\n[[bus]]\nname = \"i2c2\"\nkind = \"i2c\"\nclock_hz = 400e3",
        );
    for cs in 0..4 {
        s = s.replacen(
            &format!("bus = \"spi1\"\ncs = {cs}"),
            &format!("bus = \"i2c{}\"\naddress = {}", 1 + cs / 2, 0x18 + cs % 2),
            1,
        );
    }
    assert!(!s.contains("spi1"), "{s}");
    s
}

#[test]
fn bus_time_per_sample_set_and_the_highest_rate_it_allows() {
    // 4 × ADXL355 on SPI at 10 MHz, external sync: one 14-byte status+data burst each.
    let (spi, _) = bus_time_per_set(&spi_adxl355(1000.0));
    // 4 × LIS3DH on I²C at 400 kHz, ODR = rate: FIFO level and one sample each per set.
    let (i2c, _) = bus_time_per_set(&i2c_lis3dh(100.0));
    // Free-running reads must end by 7/8 of the period (the sampler's window).
    let spi_max = 1.0 / spi;
    let i2c_max = 7.0 / 8.0 / i2c;
    println!(
        "bus time per sample set: 4 x ADXL355 SPI 10 MHz {:.1} us (bus allows {:.0} Hz; the part's \
         ODR tops at 4000 Hz); 4 x LIS3DH I2C 400 kHz {:.1} us (bus allows {:.0} Hz)",
        spi * 1e6,
        spi_max,
        i2c * 1e6,
        i2c_max
    );
    assert!(spi < 1e-3 && i2c < 8.75e-3, "the sets fit 1 kHz / 100 Hz");
    // At a rate near the I²C limit, with the LIS3DH at its next ODR (400 Hz): still no gaps.
    let rate = 400.0f64.min((i2c_max / 2.0).floor());
    let (i2c_fast, sets) = bus_time_per_set(&i2c_lis3dh(rate));
    println!(
        "4 x LIS3DH at {rate} Hz: {:.1} us per set, {sets} sets",
        i2c_fast * 1e6
    );
    assert!(i2c_fast < 7.0 / 8.0 / rate);
}
