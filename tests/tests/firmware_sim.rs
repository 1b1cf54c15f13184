//! The firmware's tasks on hal-sim's buses (`ballisto sim --firmware`): alignment of
//! free-running parts, and the estimates against the truth and against estimator-core on the
//! same samples.

use firmware::config::Alignment;
use hal_sim::firmware_host::{firmware_config, run_firmware, SimTime};
use hal_sim::motion::Propagator;
use hal_sim::rig::TRUTH_STEP;
use hal_sim::scenario::{PartType, Scenario};

/// RMS error (m/s²) of the firmware's samples of the LIS3DH parts against eq. (4) at the
/// sample instants, with noise off (the clock offsets and jitter of the scenario kept).
fn lis3dh_sample_error(sc: &Scenario, alignment: Alignment) -> (f64, usize) {
    let loaded = sc.arrangement().load("arrangement.toml").unwrap();
    let config = firmware_config(sc, &loaded, alignment).unwrap();
    let mut truth = Propagator::new(sc.motion(), TRUTH_STEP);
    let (mut sum, mut n) = (0.0, 0usize);
    let mut emit = |set: &firmware::sampler::SampleSet, _: &firmware::estimation::Motion| {
        let tr = truth.truth_at(SimTime::seconds(set.t));
        for (p, v) in sc.parts.iter().zip(set.parts.iter()) {
            if p.part != PartType::Lis3dh || set.k < 100 {
                continue;
            }
            if let Some(v) = v {
                for k in 0..3 {
                    let e = f64::from(v[k]) - tr.channel(&p.position, &p.axis(k));
                    sum += e * e;
                    n += 1;
                }
            }
        }
    };
    run_firmware(sc, &config, sc.samples() as u32, &mut emit).unwrap();
    ((sum / n as f64).sqrt(), n)
}

#[test]
fn interpolation_aligns_free_running_parts_to_the_sample_instants() {
    let mut sc = Scenario::load("ground-spin-mixed").unwrap();
    for p in &mut sc.parts {
        p.noise_density = Some(0.0);
    }
    let lsb = 1e-3 * 9.80665;
    let (latest, n1) = lis3dh_sample_error(&sc, Alignment::Latest);
    let (aligned, n2) = lis3dh_sample_error(&sc, Alignment::Interpolate);
    println!(
        "LIS3DH samples vs eq. (4): latest output {:.2} LSB RMS, interpolated {:.2} LSB RMS ({n1}, {n2} values)",
        latest / lsb,
        aligned / lsb
    );
    assert!(n2 + 6 >= n1, "interpolation lost values: {n2} of {n1}");
    assert!(aligned < latest / 3.0, "{aligned} vs {latest}");
}
