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
                for (k, x) in v.iter().enumerate() {
                    let e = f64::from(*x) - tr.channel(&p.position, &p.axis(k));
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

fn tmpdir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("firmware-sim-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// estimator-core's real-time estimator (no smoothing: what the firmware runs) in the scalar
/// `T` over the samples the firmware recorded; writes `reference-<name>.csv` next to them.
fn reference_estimates<T: estimator_core::Real>(
    dir: &std::path::Path,
    sc: &Scenario,
    name: &str,
) -> std::path::PathBuf {
    use hal_sim::arrangement_file::load_arrangement;
    use hal_sim::samples_csv::SamplesReader;
    use std::io::Write;
    let loaded = load_arrangement(&dir.join("arrangement.toml")).unwrap();
    let model = hal_sim::run::choose_model(None, &loaded);
    let options = estimator_core::Options {
        initial_omega: sc.initial_omega,
        ..Default::default()
    };
    let mut est =
        estimator_core::Estimator::<T, 32>::new(&loaded.arrangement, model, options).unwrap();
    let mut rd = SamplesReader::open(&dir.join("samples.csv"), &loaded.names).unwrap();
    let out = dir.join(format!("reference-{name}.csv"));
    let mut w = std::io::BufWriter::new(std::fs::File::create(&out).unwrap());
    hal_sim::estimates_csv::write_header(&mut w).unwrap();
    let mut p = vec![0.0; loaded.names.len()];
    let mut pt = vec![T::ZERO; loaded.names.len()];
    while let Some(t) = rd.next_row(&mut p).unwrap() {
        pt.iter_mut().zip(&p).for_each(|(a, b)| *a = T::of(*b));
        let e = est.update(t, &pt);
        hal_sim::estimates_csv::write_row(&mut w, t, e).unwrap();
    }
    w.flush().unwrap();
    out
}

#[test]
fn named_scenarios_through_the_firmware_match_estimator_core_on_the_same_samples() {
    use hal_sim::compare::compare;
    use hal_sim::sim::{run_sim, SimJob};
    for name in [
        "tetra-orbit",
        "nine-channel",
        "ground-spin-mixed",
        "tetra-orbit-faults",
    ] {
        let sc = Scenario::load(name).unwrap();
        let dir = tmpdir(name);
        let report = run_sim(&SimJob {
            scenario: &sc,
            out: &dir,
            estimate: false,
            progress: false,
            firmware: Some(Alignment::Interpolate),
        })
        .unwrap();
        assert_eq!(report.samples, sc.samples(), "{name}: every set estimated");
        let fw = report.errors.unwrap();
        let truth = dir.join("truth.csv");
        let core = compare(&truth, &reference_estimates::<f32>(&dir, &sc, "f32")).unwrap();
        let core64 = compare(&truth, &reference_estimates::<f64>(&dir, &sc, "f64")).unwrap();
        println!(
            "{name}: RMS firmware / estimator-core f32 / f64 on the firmware's samples: \
             sigma0 {:.2e} / {:.2e} / {:.2e}, domega {:.2e} / {:.2e} / {:.2e}, \
             omega {:.2e} / {:.2e} / {:.2e}",
            fw.sigma0,
            core.sigma0,
            core64.sigma0,
            fw.domega,
            core.domega,
            core64.domega,
            fw.omega,
            core.omega,
            core64.omega
        );
        assert_eq!(fw.rows, core.rows, "{name}");
        // The firmware runs estimator-core in f32 on these samples: the same accuracy, up to
        // its exclusion of parts missing for several sets.
        for (what, f, c) in [
            ("sigma0", fw.sigma0, core.sigma0),
            ("domega", fw.domega, core.domega),
            ("omega", fw.omega, core.omega),
        ] {
            assert!(
                f <= 1.01 * c + 1e-6,
                "{name} {what}: firmware {f:e}, core {c:e}"
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
