//! Calibration end to end on the datasheet-error scenario `ground-calibration`: the firmware
//! records the calibration schedule, `ballisto calibrate` identifies the parts (with the
//! reference gyro, and without it), and `ballisto estimate` with the calibrated file on an
//! operating run of the same parts (a turntable spin-up) is compared with the same run of
//! ideal parts.

use std::path::{Path, PathBuf};

use ballisto::calibrate::fit::FitSet;
use ballisto::calibrate::{calibrate_files, CalibrateJob};
use ballisto::compare::{compare, Comparison};
use ballisto::estimate::{estimate_files, EstimateJob, Precision};
use ballisto::sim::{run_sim, SimJob};
use ballisto_fw::config::Alignment;
use hal_sim::arrangement_file::ArrangementFile;
use hal_sim::scenario::{BodySpec, Scenario, TurntableSpec};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ballisto-cal-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The operating run: the calibration scenario's parts on a turntable spinning up about a
/// tilted axis, 20 s, no reference; `ideal` removes every part error.
fn operating(ideal: bool) -> Scenario {
    let mut sc = Scenario::load("ground-calibration").unwrap();
    sc.duration = 20.0;
    sc.seed = 77;
    sc.reference = None;
    sc.body = BodySpec {
        inertia: None,
        omega0: None,
        attitude0: Some([0.96, 0.2, -0.1, 0.15]),
        origin_offset: None,
        torque: None,
        turntable: Some(TurntableSpec {
            axis: [0.2, -0.3, 0.93],
            rate: 3.0,
            spin_up: 5.0,
        }),
        schedule: None,
    };
    if ideal {
        for p in sc.parts.iter_mut() {
            p.bias = None;
            p.scale = None;
            p.cross = None;
            p.position_error = None;
            p.orientation_error = None;
        }
    }
    sc
}

fn sim(sc: &Scenario, out: &Path) {
    run_sim(&SimJob {
        scenario: sc,
        out,
        estimate: false,
        progress: false,
        firmware: Some(Alignment::Interpolate),
    })
    .unwrap();
}

fn estimate(arrangement: &Path, run: &Path, name: &str) -> Comparison {
    let out = run.join(name);
    estimate_files(&EstimateJob {
        arrangement,
        samples: &run.join("samples.csv"),
        out: &out,
        model: None,
        options: Default::default(),
        precision: Precision::F64,
    })
    .unwrap();
    compare(&run.join("truth.csv"), &out).unwrap()
}

/// The mean offset of the calibrated positions from the true ones: the common translation
/// that calibration cannot see (σ0 is estimated at the point the calibrated coordinates
/// call the origin).
fn common_translation(calibrated: &Path, truth: &Path) -> [f64; 3] {
    let c = ArrangementFile::read(calibrated)
        .unwrap()
        .expanded_channels("c")
        .unwrap();
    let t = ArrangementFile::read(truth)
        .unwrap()
        .expanded_channels("t")
        .unwrap();
    let mut s = [0.0; 3];
    for (a, b) in c.iter().zip(t.iter()) {
        assert_eq!(a.name, b.name);
        for (sk, (pa, pb)) in s.iter_mut().zip(a.position.iter().zip(b.position.iter())) {
            *sk += (pa - pb) / c.len() as f64;
        }
    }
    s
}

/// RMS σ0 error with the truth moved to the point `-shift` (true coordinates):
/// σ(−c) = σ0 − Ω′×c − Ω×(Ω×c).
fn sigma0_rms_at(run: &Path, estimates: &str, shift: [f64; 3]) -> f64 {
    let read = |p: &Path| -> (Vec<String>, Vec<Vec<f64>>) {
        let text = std::fs::read_to_string(p).unwrap();
        let mut lines = text.lines();
        let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
        let rows = lines
            .map(|l| {
                l.split(',')
                    .map(|v| v.parse().unwrap_or(f64::NAN))
                    .collect()
            })
            .collect();
        (header, rows)
    };
    let (th, tr) = read(&run.join("truth.csv"));
    let (eh, er) = read(&run.join(estimates));
    let col = |h: &[String], n: &str| h.iter().position(|x| x == n).unwrap();
    let mut sum = 0.0;
    for (t, e) in tr.iter().zip(er.iter()) {
        let v = |h: &[String], r: &[f64], n: &str| r[col(h, n)];
        let w = [
            v(&th, t, "omega_x"),
            v(&th, t, "omega_y"),
            v(&th, t, "omega_z"),
        ];
        let dw = [
            v(&th, t, "domega_x"),
            v(&th, t, "domega_y"),
            v(&th, t, "domega_z"),
        ];
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let a = cross(dw, shift);
        let b = cross(w, cross(w, shift));
        for (k, n) in ["sigma0_x", "sigma0_y", "sigma0_z"].iter().enumerate() {
            let truth = v(&th, t, n) - a[k] - b[k];
            sum += (v(&eh, e, n) - truth).powi(2);
        }
    }
    (sum / tr.len() as f64).sqrt()
}

#[test]
fn calibrated_parts_estimate_as_well_as_ideal_ones() {
    let cal = dir("schedule");
    sim(&Scenario::load("ground-calibration").unwrap(), &cal);
    let ideal = dir("ideal");
    sim(&operating(true), &ideal);
    let real = dir("real");
    sim(&operating(false), &real);
    let base = estimate(&ideal.join("arrangement.toml"), &ideal, "estimates.csv");
    let nominal = estimate(&real.join("arrangement.toml"), &real, "nominal.csv");
    println!(
        "ideal parts:       σ0 {:.3e}  Ω′ {:.3e}  Ω {:.3e}; unflagged beyond 5 sd: {:?}",
        base.sigma0, base.domega, base.omega, base.silent
    );
    println!(
        "datasheet errors, nominal geometry: σ0 {:.3e}  Ω′ {:.3e}  Ω {:.3e}; unflagged beyond 5 sd: {:?}",
        nominal.sigma0, nominal.domega, nominal.omega, nominal.silent
    );
    assert!(
        nominal.omega > 20.0 * base.omega,
        "the errors must matter for this test"
    );
    for (name, reference) in [
        ("reference", Some(cal.join("reference.csv"))),
        ("self", None),
    ] {
        let file = cal.join(format!("calibrated-{name}.toml"));
        calibrate_files(&CalibrateJob {
            arrangement: &cal.join("arrangement.toml"),
            samples: &cal.join("samples.csv"),
            out: &file,
            reference: reference.as_deref(),
            fit: FitSet::ALL,
            model: None,
            report: None,
        })
        .unwrap();
        let cal_file = ArrangementFile::read(&file).unwrap();
        println!(
            "calibrated ({name}): frame sd rotation {:.3e} rad, translation {:.3e} m, size {:.3e}",
            cal_file.frame_rotation_sd.unwrap(),
            cal_file.frame_translation_sd.unwrap(),
            cal_file.frame_size_sd.unwrap()
        );
        let est = format!("calibrated-{name}.csv");
        let c = estimate(&file, &real, &est);
        let shift = common_translation(&file, &cal.join("truth_geometry.toml"));
        let sigma0_moved = sigma0_rms_at(&real, &est, shift);
        println!(
            "calibrated ({name}): σ0 {:.3e} ({:.3e} at the calibrated origin, {:.2} mm from the drawn one)  Ω′ {:.3e}  Ω {:.3e}; unflagged beyond 5 sd of {}: {:?}",
            c.sigma0,
            sigma0_moved,
            shift.iter().map(|v| v * v).sum::<f64>().sqrt() * 1e3,
            c.domega,
            c.omega,
            c.rows,
            c.silent
        );
        // Never silently wrong: the reported deviations carry the frame's uncertainty (the
        // common rotation, translation and size calibration could not tie down), so no more
        // than 0.1 % of the rows may be off by over 5 sd without a flag (before the frame
        // uncertainty: 1 635 of 2 001 rows of the self-calibrated estimate).
        let silent = c.silent.expect("estimates carry deviations and flags");
        let allowed = c.rows / 1000;
        assert!(
            silent.omega <= allowed && silent.sigma0 <= allowed,
            "{name}: {silent:?} of {} rows silently wrong",
            c.rows
        );
        if reference.is_some() {
            assert!(
                c.domega <= 1.2 * base.domega,
                "Ω′ {} vs ideal {}",
                c.domega,
                base.domega
            );
            assert!(
                c.omega <= 1.2 * base.omega,
                "Ω {} vs ideal {}",
                c.omega,
                base.omega
            );
            // σ0 on the ground carries g times the frame's error: the common rotation of the
            // axes the calibration leaves (≈ 0.1 mrad, reported as frame_rotation_sd) is
            // 1e-3 m/s², as large as the ideal run's error. The 1.2× goal is not met for σ0
            // (README); this bounds what calibration achieves: a twentieth of the
            // uncalibrated error.
            assert!(
                sigma0_moved <= nominal.sigma0 / 20.0,
                "σ0 at the calibrated origin {sigma0_moved} vs uncalibrated {}",
                nominal.sigma0
            );
        } else {
            // Without a reference the frame (a common rotation) and the size are conventions:
            // σ0 and Ω′ carry them; Ω's magnitude and most of its error do not.
            assert!(
                c.omega <= 2.0 * base.omega,
                "Ω {} vs ideal {}",
                c.omega,
                base.omega
            );
            assert!(c.omega < nominal.omega / 50.0);
        }
    }
    for d in [cal, ideal, real] {
        let _ = std::fs::remove_dir_all(d);
    }
}
