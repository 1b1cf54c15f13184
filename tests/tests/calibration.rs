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
use ballisto_config::arrangement_file::ArrangementFile;
use ballisto_fw::config::Alignment;
use e2e_tests::frame::{errors_in, frame_of, Frame};
use e2e_tests::report::{row, Parts};
use hal_sim::scenario::{BodySpec, Scenario, TurntableSpec};
use nalgebra::Vector3;

/// The late reference's lag (s) and bias (rad/s).
const LAG_S: f64 = 0.005;
const LATE_BIAS: [f64; 3] = [0.01, -0.02, 0.015];

/// The scaled reference's scale factor (an uncalibrated gyro reading 3 % high).
const GYRO_SCALE: f64 = 1.03;

/// Writes `reference` as a gyro `lag` seconds late with a `bias` and a `scale` factor would
/// have recorded it: the row stamped `t` holds `scale` times the rate at `t − lag`
/// (interpolated) plus the bias.
fn write_late_reference(reference: &Path, out: &Path, lag: f64, bias: [f64; 3], scale: f64) {
    let text = std::fs::read_to_string(reference).unwrap();
    let rows: Vec<[f64; 4]> = text
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            [v[0], v[1], v[2], v[3]]
        })
        .collect();
    let mut csv = String::from("t,omega_x,omega_y,omega_z\n");
    for row in &rows {
        let t = row[0] - lag;
        let j = rows.partition_point(|r| r[0] <= t).clamp(1, rows.len() - 1) - 1;
        let (a, b) = (rows[j], rows[j + 1]);
        let u = ((t - a[0]) / (b[0] - a[0])).clamp(0.0, 1.0);
        let w: Vec<String> = (0..3)
            .map(|i| {
                format!(
                    "{}",
                    (a[i + 1] * (1.0 - u) + b[i + 1] * u) * scale + bias[i]
                )
            })
            .collect();
        csv.push_str(&format!("{},{}\n", row[0], w.join(",")));
    }
    std::fs::write(out, csv).unwrap();
}

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
        sc.with_ideal_parts()
    } else {
        sc
    }
}

fn sim(sc: &Scenario, out: &Path) {
    run_sim(&SimJob {
        scenario: sc,
        out,
        estimate: false,
        progress: false,
        firmware: Some(Alignment::Interpolate),
        identify: false,
        uplink: Vec::new(),
        calibration: None,
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
        progress: false,
    })
    .unwrap();
    compare(&run.join("truth.csv"), &out).unwrap()
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
    // A real reference: the same gyro 5 ms late with a bias.
    let late = cal.join("reference-late.csv");
    write_late_reference(&cal.join("reference.csv"), &late, LAG_S, LATE_BIAS, 1.0);
    // An uncalibrated one: its scale 3 % off, said known to 0.5 %.
    let scaled = cal.join("reference-scaled.csv");
    write_late_reference(
        &cal.join("reference.csv"),
        &scaled,
        0.0,
        [0.0; 3],
        GYRO_SCALE,
    );
    for (name, reference) in [
        ("reference", Some(cal.join("reference.csv"))),
        ("reference-late", Some(late.clone())),
        ("reference-scaled", Some(scaled.clone())),
        ("self", None),
    ] {
        let file = cal.join(format!("calibrated-{name}.toml"));
        let summary = calibrate_files(&CalibrateJob {
            arrangement: &cal.join("arrangement.toml"),
            samples: &cal.join("samples.csv"),
            out: &file,
            reference: reference.as_deref(),
            reference_validity: Default::default(),
            reference_scale_sd: (name == "reference-scaled").then_some(0.005),
            fit: FitSet::ALL,
            model: None,
            report: None,
            force: false,
            progress: false,
        })
        .unwrap();
        if let Some(found) = &summary.reference_found {
            println!("calibrated ({name}): {}", found.describe());
            let a = found.alignment;
            let (bias, bias_sd) = a.bias.expect("the schedule has static poses");
            let (offset, offset_sd, _) = a.offset.expect("the schedule's turns determine it");
            let (true_bias, true_offset) = if name == "reference-late" {
                (Vector3::from(LATE_BIAS), LAG_S)
            } else {
                (Vector3::zeros(), 0.0)
            };
            // Within 3 of their deviations (the bias's is from the poses' scatter, and the
            // reference's own noise, 1e-3 rad/s, leaves 1e-5 over a pose).
            for i in 0..3 {
                assert!(
                    (bias[i] - true_bias[i]).abs() <= 3.0 * bias_sd[i],
                    "{name}: bias {bias} ± {bias_sd} vs {true_bias}"
                );
            }
            assert!(
                (offset - true_offset).abs() <= 3.0 * offset_sd,
                "{name}: offset {offset} ± {offset_sd} s vs {true_offset}"
            );
            assert_eq!(a.bias_removed, name == "reference-late", "{name}");
        }
        let cal_file = ArrangementFile::read(&file).unwrap();
        println!(
            "calibrated ({name}): frame sd rotation {:.3e} rad, translation {:.3e} m, size {:.3e}",
            cal_file.frame_rotation_sd.unwrap(),
            cal_file.frame_translation_sd.unwrap(),
            cal_file.frame_size_sd.unwrap()
        );
        let est = format!("calibrated-{name}.csv");
        let c = estimate(&file, &real, &est);
        let frame = frame_of(&file, &cal.join("truth_geometry.toml"));
        let at_origin = Frame {
            rotation: Vector3::zeros(),
            translation: frame.translation,
            size: 0.0,
            relative_rotation: Vector3::zeros(),
        };
        let sigma0_moved = errors_in(&real, &est, &at_origin)[0];
        let relative_sd = cal_file.frame_relative_rotation_sd.unwrap();
        println!(
            "calibrated ({name}): axes against lever arms {:.4} mrad, largest axis {:.4} mrad, reported sd {:.4} mrad",
            frame.relative_rotation.norm() * 1e3,
            frame.relative_rotation.amax() * 1e3,
            relative_sd * 1e3
        );
        let own = errors_in(&real, &est, &frame);
        println!(
            "calibrated ({name}): its frame against the truth: rotation {:.3} mrad, translation {:.3} mm, size {:.2e}; errors in it: σ0 {:.3e} ({:.2}×)  Ω′ {:.3e} ({:.2}×)  Ω {:.3e} ({:.2}×)",
            frame.rotation.norm() * 1e3,
            frame.translation.norm() * 1e3,
            frame.size,
            own[0],
            own[0] / base.sigma0,
            own[1],
            own[1] / base.domega,
            own[2],
            own[2] / base.omega
        );
        println!(
            "calibrated ({name}): σ0 {:.3e} ({:.3e} at the calibrated origin, {:.2} mm from the drawn one)  Ω′ {:.3e}  Ω {:.3e}; unflagged beyond 5 sd of {}: {:?}",
            c.sigma0,
            sigma0_moved,
            frame.translation.norm() * 1e3,
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
        let case = format!("ground-calibration → operating, {name}");
        assert!(
            row(
                &case,
                Parts::Datasheet,
                "rows silently wrong (σ0, Ω)",
                format!("{}, {} of {}", silent.sigma0, silent.omega, c.rows),
                "≤ 0.1 %",
                silent.omega <= allowed && silent.sigma0 <= allowed
            ),
            "{name}: {silent:?} of {} rows silently wrong",
            c.rows
        );
        if name == "reference-scaled" {
            // The size is held at the drawing's and the reference's common factor follows it:
            // positions (1 + s) × the true ones read as Ω ÷ √(1 + s).
            let c = summary
                .identification
                .reference_scale
                .expect("a reference of inexact scale has its factor fitted");
            let expected = 1.0 / (GYRO_SCALE * (1.0 + frame.size).sqrt());
            println!("calibrated ({name}): common scale factor {c:.5}, expected {expected:.5} (size {:.2e})", frame.size);
            assert!(
                row(
                    &case,
                    Parts::Datasheet,
                    "gyro scale factor fitted",
                    format!("{c:.5} (expected {expected:.5})"),
                    "± 2e-3",
                    (c - expected).abs() < 2e-3
                ),
                "factor {c} vs {expected}"
            );
            // In its own frame (the size a convention, as without a reference) as ideal parts.
            for (q, what) in ["σ0", "Ω′", "Ω"].iter().enumerate() {
                let ideal = [base.sigma0, base.domega, base.omega][q];
                assert!(
                    ratio_row(&case, &format!("{what} in its frame"), own[q], ideal, 1.2),
                    "{what} in its frame {} vs ideal {ideal}",
                    own[q]
                );
            }
        } else if name == "reference-late" {
            // The offset is known to ±1 ms here, and the frame's rotation with it to ±0.4
            // mrad (in its deviation): Ω as with an exact reference; σ0 and Ω′ carry the frame
            // (measured 3.8× and 1.3× ideal, none silently wrong).
            assert!(
                ratio_row(&case, "Ω", c.omega, base.omega, 1.2),
                "Ω {} vs ideal {}",
                c.omega,
                base.omega
            );
        } else if reference.is_some() {
            assert!(
                ratio_row(&case, "Ω′", c.domega, base.domega, 1.2),
                "Ω′ {} vs ideal {}",
                c.domega,
                base.domega
            );
            assert!(
                ratio_row(&case, "Ω", c.omega, base.omega, 1.2),
                "Ω {} vs ideal {}",
                c.omega,
                base.omega
            );
            // σ0 at the point the calibrated file calls the origin (0.2 mm from the drawn
            // one: the parts' mean mounting error, which no accelerometer record sees). On the
            // ground it carries g times the frame's rotation: this record's came out at 0.2 of
            // its reported sd; at one sd σ0 would be ≈ 1.15× (`docs/validation.md`).
            assert!(
                ratio_row(
                    &case,
                    "σ0 at the calibrated origin",
                    sigma0_moved,
                    base.sigma0,
                    1.2
                ),
                "σ0 at the calibrated origin {sigma0_moved} vs ideal {}",
                base.sigma0
            );
        } else {
            // Without a reference the frame (a common rotation) and the size are conventions:
            // σ0 and Ω′ carry them; Ω's magnitude and most of its error do not. In its own
            // frame the self-calibrated file estimates σ0, Ω′ and Ω as well as ideal parts.
            // Ω′ needs the kinematic tie (Ω′ against the change of Ω): without it the axes'
            // rotation against the lever arms stayed at 2.1 mrad and Ω′ at 1.4× (`docs/validation.md`).
            assert!(
                ratio_row(&case, "Ω′ in its frame", own[1], base.domega, 1.2),
                "Ω′ in its frame {} vs ideal {}",
                own[1],
                base.domega
            );
            // The axes against the lever arms, as the fitted positions show it (their own
            // rotation is only as good as ≈ 0.1 mrad here: 0.04 mrad came out with the
            // reference, whose Ω fixes it): 0.20 mrad, from 2.1 without the tie.
            assert!(
                row(
                    &case,
                    Parts::Datasheet,
                    "axes against lever arms",
                    format!("{:.3} mrad", frame.relative_rotation.norm() * 1e3),
                    "≤ 0.5 mrad",
                    frame.relative_rotation.norm() <= 0.5e-3
                ),
                "axes against lever arms {} rad",
                frame.relative_rotation.norm()
            );
            assert!(
                ratio_row(&case, "σ0 in its frame", own[0], base.sigma0, 1.2),
                "σ0 in its frame {} vs ideal {}",
                own[0],
                base.sigma0
            );
            assert!(
                ratio_row(&case, "Ω in its frame", own[2], base.omega, 1.2),
                "Ω in its frame {} vs ideal {}",
                own[2],
                base.omega
            );
            assert!(
                ratio_row(&case, "Ω", c.omega, base.omega, 2.0),
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

/// A report row of an RMS error against ideal parts' on the same motion, held to `limit` × it.
fn ratio_row(case: &str, what: &str, got: f64, ideal: f64, limit: f64) -> bool {
    row(
        case,
        Parts::Datasheet,
        &format!("RMS error of {what} / ideal parts"),
        format!("{:.2} ({got:.3e})", got / ideal),
        &format!("≤ {limit}"),
        got <= limit * ideal,
    )
}
