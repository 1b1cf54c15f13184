//! `ballisto calibrate` on the command line: the calibrated file, and bad input refused with
//! a sentence naming what is wrong (no calibration file written).

mod common;

use common::ballisto;

use std::path::{Path, PathBuf};
use std::process::Output;

fn tmpdir(name: &str) -> PathBuf {
    common::tmpdir("calcli", name)
}

/// The calibration record of `ground-calibration` (firmware on the simulated buses).
fn record(dir: &Path) {
    common::run_ok(
        ballisto()
            .args([
                "sim",
                "--firmware",
                "--scenario",
                "ground-calibration",
                "--out",
            ])
            .arg(dir),
    );
}

fn calibrate(dir: &Path, samples: &Path, extra: &[&str]) -> Output {
    ballisto()
        .arg("calibrate")
        .arg("--arrangement")
        .arg(dir.join("arrangement.toml"))
        .arg("--samples")
        .arg(samples)
        .arg("--out")
        .arg(dir.join("calibrated.toml"))
        .args(extra)
        .output()
        .unwrap()
}

fn refused(out: &Output, dir: &Path, words: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "accepted: {err}");
    assert!(
        err.contains(words),
        "stderr does not say \"{words}\": {err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "one sentence: {err}");
    assert!(
        !dir.join("calibrated.toml").exists(),
        "a calibration file was written"
    );
}

/// The first `n` lines of the samples file (header included).
fn head(dir: &Path, n: usize, name: &str) -> PathBuf {
    head_of(dir, "samples.csv", n, name)
}

/// The first `n` lines of the file `source` in `dir` (header included), as `name`.
fn head_of(dir: &Path, source: &str, n: usize, name: &str) -> PathBuf {
    let text = std::fs::read_to_string(dir.join(source)).unwrap();
    let part: Vec<&str> = text.lines().take(n).collect();
    let p = dir.join(name);
    std::fs::write(&p, part.join("\n") + "\n").unwrap();
    p
}

#[test]
fn writes_a_calibrated_arrangement_that_estimate_reads() {
    let dir = tmpdir("ok");
    record(&dir);
    let report = dir.join("report.md");
    let out = calibrate(
        &dir,
        &dir.join("samples.csv"),
        &[
            "--reference",
            dir.join("reference.csv").to_str().unwrap(),
            "--report",
            report.to_str().unwrap(),
        ],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("static poses"), "{err}");
    // Validated on the motion held out of the fit: the datasheet errors' residual and Ω error
    // gone there (the figures nominal → calibrated, in the summary and the report).
    assert!(err.contains("validated: held out of the fit"), "{err}");
    assert!(err.contains("Ω against the reference"), "{err}");
    let text = std::fs::read_to_string(dir.join("calibrated.toml")).unwrap();
    assert!(
        text.starts_with("# Calibrated by ballisto calibrate"),
        "{text}"
    );
    for key in [
        "bias = ",
        "scale = ",
        "position_sd = ",
        "axis_sd = ",
        "bias_sd = ",
        "scale_sd = ",
        "frame_rotation_sd = ",
        "frame_translation_sd = ",
        "frame_size_sd = ",
    ] {
        assert!(text.contains(key), "no {key} in the calibrated file");
    }
    let md = std::fs::read_to_string(&report).unwrap();
    assert!(md.contains("| u0.x |"));
    assert!(md.contains("- Validation: held out of the fit"), "{md}");
    // The residuals' PNG beside it, referenced.
    assert!(md.contains("](report.png)"));
    let png = std::fs::read(dir.join("report.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    common::run_ok(&mut common::estimate(
        &dir.join("calibrated.toml"),
        &dir.join("samples.csv"),
        &dir.join("estimates.csv"),
    ));
    // A nominal file with temperature coefficients: calibrate does not identify them, so it
    // does not write them, and says so.
    let mut file =
        ballisto_config::arrangement_file::ArrangementFile::read(&dir.join("arrangement.toml"))
            .unwrap();
    let mut channels = file.expanded_channels("arrangement.toml").unwrap();
    channels[0].t_ref = Some(25.0);
    channels[0].bias_tc = Some(1e-3);
    file.sensors.clear();
    file.channels = channels;
    let warm = dir.join("warm.toml");
    std::fs::write(&warm, file.to_toml()).unwrap();
    let out = ballisto()
        .arg("calibrate")
        .arg("--arrangement")
        .arg(&warm)
        .arg("--samples")
        .arg(dir.join("samples.csv"))
        .arg("--reference")
        .arg(dir.join("reference.csv"))
        .arg("--out")
        .arg(dir.join("calibrated-warm.toml"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("temperature coefficients of u0.x are not written"),
        "{err}"
    );
    let text = std::fs::read_to_string(dir.join("calibrated-warm.toml")).unwrap();
    assert!(
        !text.contains("t_ref") && !text.contains("bias_tc"),
        "{text}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_input_is_refused_by_name() {
    let dir = tmpdir("bad");
    record(&dir);
    // Too short.
    let short = head(&dir, 100, "short.csv");
    refused(&calibrate(&dir, &short, &[]), &dir, "too few to calibrate");
    // One static pose and nothing else, with and without the reference: refused as not
    // exciting enough, saying what the record holds and what it does not determine (it once
    // wrote a file with a scale 51 tolerances off, with the reference).
    let rest = head(&dir, 301, "rest.csv");
    let rest_reference = head_of(&dir, "reference.csv", 301, "rest-reference.csv");
    for extra in [
        vec![],
        vec!["--reference", rest_reference.to_str().unwrap()],
    ] {
        let out = calibrate(&dir, &rest, &extra);
        refused(&out, &dir, "not exciting enough");
        assert_eq!(
            out.status.code(),
            Some(4),
            "a refused result, not a bad input"
        );
        refused(&out, &dir, "1 static poses");
        refused(&out, &dir, "bias 18 of 18");
    }
    // A reference that does not overlap the record.
    let reference = dir.join("late-reference.csv");
    let shifted: String = std::fs::read_to_string(dir.join("reference.csv"))
        .unwrap()
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 0 {
                return format!("{l}\n");
            }
            let (t, rest) = l.split_once(',').unwrap();
            format!("{},{rest}\n", t.parse::<f64>().unwrap() + 1000.0)
        })
        .collect();
    std::fs::write(&reference, shifted).unwrap();
    refused(
        &calibrate(
            &dir,
            &dir.join("samples.csv"),
            &["--reference", reference.to_str().unwrap()],
        ),
        &dir,
        "does not overlap the record",
    );
    // A non-finite reference value.
    let nan = dir.join("nan-reference.csv");
    std::fs::write(&nan, "t,omega_x,omega_y,omega_z\n0,0,0,0\n0.01,NaN,0,0\n").unwrap();
    refused(
        &calibrate(
            &dir,
            &dir.join("samples.csv"),
            &["--reference", nan.to_str().unwrap()],
        ),
        &dir,
        "line 3: \"NaN\" is not a finite number",
    );
    // A non-finite reading.
    let text = std::fs::read_to_string(dir.join("samples.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let fields: Vec<&str> = lines[500].split(',').collect();
    lines[500] = format!("{},inf,{}", fields[0], fields[2..].join(","));
    let bad = dir.join("inf.csv");
    std::fs::write(&bad, lines.join("\n") + "\n").unwrap();
    refused(&calibrate(&dir, &bad, &[]), &dir, "line 501");
    // A reference's scale deviation that is no relative deviation: the command line is
    // wrong (exit 2), said by name.
    for bad in ["0", "1.5", "-0.01", "half"] {
        let out = calibrate(
            &dir,
            &dir.join("samples.csv"),
            &[
                "--reference",
                dir.join("reference.csv").to_str().unwrap(),
                "--reference-scale-sd",
                bad,
            ],
        );
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{bad}: {err}");
        assert!(
            err.contains("--reference-scale-sd")
                && err.contains("a relative deviation is a number above 0 and below 1"),
            "{bad}: {err}"
        );
        assert!(!dir.join("calibrated.toml").exists());
    }
    // An unknown --fit item.
    refused(
        &calibrate(&dir, &dir.join("samples.csv"), &["--fit", "bias,gain"]),
        &dir,
        "\"gain\" is not one of bias, scale, axis, position",
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_orbit_tumble_without_reference_is_refused_not_guessed() {
    // tetra-orbit's parts with errors, tumbling in orbit, no static pose, no reference: the
    // record leaves most parameters undetermined (docs/ballisto.md): refused, naming what
    // it does not determine, and nothing is written.
    let dir = tmpdir("orbit");
    let text = common::scenario_text("tetra-orbit")
    .replace(
        "noise_density = 2.2e-4\n",
        "noise_density = 2.2e-4\nbias = [0.1, -0.2, 0.15]\nscale = [1.01, 0.99, 1.005]\nposition_error = [3e-4, -2e-4, 1e-4]\norientation_error = [0.004, -0.003, 0.002]\n",
    );
    std::fs::write(dir.join("orbit.toml"), text).unwrap();
    common::run_ok(
        ballisto()
            .args(["sim", "--firmware", "--scenario"])
            .arg(dir.join("orbit.toml"))
            .arg("--out")
            .arg(&dir),
    );
    refused(
        &calibrate(&dir, &dir.join("samples.csv"), &[]),
        &dir,
        "with a reference rate",
    );
    // Scales alone are "determined" to first order, but in free fall only with the lever
    // arms: the fit runs away with them. Said as such, not as the estimator's complaint
    // about the geometry it was handed.
    refused(
        &calibrate(&dir, &dir.join("samples.csv"), &["--fit", "scale"]),
        &dir,
        "the identification diverged",
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A calibration that does not improve the part of the record held out of the fit is refused
/// (exit 4, nothing written); `--force` writes it with the warning in the file. Ideal parts
/// (the nominal geometry is the truth): a calibration can only fit the record's noise.
#[test]
fn a_calibration_that_does_not_improve_the_held_out_part_is_refused() {
    let dir = tmpdir("ideal");
    let ideal: String = common::scenario_text("ground-calibration")
        .lines()
        .filter(|l| {
            ![
                "bias = ",
                "scale = ",
                "cross = ",
                "position_error = ",
                "orientation_error = ",
            ]
            .iter()
            .any(|k| l.starts_with(k))
        })
        .map(|l| format!("{l}\n"))
        .collect();
    let scenario = dir.join("ideal.toml");
    std::fs::write(&scenario, ideal).unwrap();
    common::run_ok(
        ballisto()
            .args(["sim", "--firmware", "--scenario"])
            .arg(&scenario)
            .arg("--out")
            .arg(&dir),
    );
    let reference = dir.join("reference.csv");
    let args = ["--reference", reference.to_str().unwrap()];
    let out = calibrate(&dir, &dir.join("samples.csv"), &args);
    assert_eq!(out.status.code(), Some(4));
    refused(
        &out,
        &dir,
        "does not improve the part of the record held out of the fit",
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--force"), "{err}");
    let forced = [args[0], args[1], "--force"];
    let out = calibrate(&dir, &dir.join("samples.csv"), &forced);
    common::succeeded(&out);
    let text = std::fs::read_to_string(dir.join("calibrated.toml")).unwrap();
    assert!(
        text.contains(
            "# WARNING: the calibration does not improve the part of the record held out"
        ),
        "{text}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
