//! A real rate reference is imperfect: `compare --reference` and `calibrate --reference` use
//! only its valid rows (flag columns in the reference or beside it, the gyro's range) and say
//! how many they left out and why; `compare --reference` scores Ω against it per axis.

mod common;

use std::path::{Path, PathBuf};

use common::{ballisto, succeeded, tmpdir};

/// 101 rows at 100 Hz: the estimates' Ω, and a reference off by 0.1 rad/s in x everywhere and
/// by 50 rad/s at rows 40–44 (a saturated gyro).
const ROWS: usize = 101;

fn estimate_omega(k: usize) -> [f64; 3] {
    let t = k as f64 * 0.01;
    [t.sin(), 2.0 * t.cos(), 0.5]
}

fn clipped(k: usize) -> bool {
    (40..45).contains(&k)
}

/// Writes the estimates, the reference (with `own_flags`: a `gyro_saturated` column in it) and
/// a flags file beside it; returns their paths.
fn files(dir: &Path, own_flags: bool) -> (PathBuf, PathBuf, PathBuf) {
    let (est, reference, flags) = (
        dir.join("estimates.csv"),
        dir.join("reference.csv"),
        dir.join("reference_flags.csv"),
    );
    let mut e = String::from("t,omega_x,omega_y,omega_z,flags\n");
    let mut r = String::from(if own_flags {
        "t,omega_x,omega_y,omega_z,gyro_saturated\n"
    } else {
        "t,omega_x,omega_y,omega_z\n"
    });
    let mut f = String::from("t,gyro_saturated,acc_saturated\n");
    for k in 0..ROWS {
        let t = format!("{:.6}", k as f64 * 0.01);
        let w = estimate_omega(k);
        e.push_str(&format!("{t},{},{},{},0\n", w[0], w[1], w[2]));
        let off = if clipped(k) { 50.0 } else { 0.1 };
        r.push_str(&format!("{t},{},{},{}", w[0] + off, w[1], w[2]));
        if own_flags {
            r.push_str(&format!(",{}", u8::from(clipped(k))));
        }
        r.push('\n');
        f.push_str(&format!("{t},{},0\n", u8::from(clipped(k))));
    }
    std::fs::write(&est, e).unwrap();
    std::fs::write(&reference, r).unwrap();
    std::fs::write(&flags, f).unwrap();
    (est, reference, flags)
}

/// The RMS error of `omega_x` and the rows compared, from compare's output.
fn rms_x(stdout: &str) -> (f64, usize) {
    let line = |p: &str| {
        stdout
            .lines()
            .find(|l| l.starts_with(p))
            .unwrap()
            .to_string()
    };
    let x = line("omega_x");
    let rms: f64 = x.split_whitespace().nth(3).unwrap().parse().unwrap();
    let rows: usize = line("rows compared")
        .split_whitespace()
        .nth(2)
        .unwrap()
        .parse()
        .unwrap();
    (rms, rows)
}

/// `ballisto compare --reference REFERENCE` with `args` before it and the estimates after.
fn compare_ref(reference: &Path, args: &[&str], est: &Path) -> std::process::Output {
    ballisto()
        .arg("compare")
        .args(args)
        .arg("--reference")
        .arg(reference)
        .arg(est)
        .output()
        .unwrap()
}

#[test]
fn compare_scores_omega_against_the_valid_rows_of_a_reference() {
    let dir = tmpdir("reference", "flags");
    let (est, reference, flags) = files(&dir, false);
    // Without the flags, the saturated rows count.
    let out = compare_ref(&reference, &[], &est);
    let (rms, rows) = rms_x(&succeeded(&out));
    assert_eq!(rows, ROWS);
    assert!(rms > 10.0, "{rms}");
    // With the flags file: the five rows and the instants between them are left out, and the
    // error is the 0.1 rad/s offset alone; the summary says what was left out and why.
    let out = compare_ref(
        &reference,
        &["--reference-flags", flags.to_str().unwrap()],
        &est,
    );
    let (rms, rows) = rms_x(&succeeded(&out));
    assert_eq!(rows, ROWS - 5);
    assert!((rms - 0.1).abs() < 1e-9, "{rms}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("5 of 101 reference rows left out (gyro_saturated 5)"),
        "{stderr}"
    );
    // The same flags as a column of the reference itself.
    let dir = tmpdir("reference", "own");
    let (est, reference, _) = files(&dir, true);
    let out = compare_ref(&reference, &[], &est);
    let (rms, rows) = rms_x(&succeeded(&out));
    assert_eq!((rows, (rms * 1e6).round()), (ROWS - 5, 1e5));
    // A range: the clipped rows read 50 rad/s and more; a 45 rad/s gyro leaves them out.
    let dir = tmpdir("reference", "range");
    let (est, reference, _) = files(&dir, false);
    let out = compare_ref(&reference, &["--reference-range", "45"], &est);
    let (rms, rows) = rms_x(&succeeded(&out));
    assert_eq!(rows, ROWS - 5);
    assert!((rms - 0.1).abs() < 1e-9, "{rms}");
    assert!(String::from_utf8_lossy(&out.stderr).contains("at the range ±45 rad/s 5"));
}

#[test]
fn bad_reference_validity_is_named() {
    let dir = tmpdir("reference", "bad");
    let (est, reference, flags) = files(&dir, false);
    // Exit 1 for a wrong input, 2 for a wrong command line.
    let fails_with = |code: i32, args: &[&str], files: &[&Path], says: &str| {
        let mut c = ballisto();
        c.args(args);
        for f in files {
            c.arg(f);
        }
        let out = c.output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(code), "{args:?}: {stderr}");
        assert!(stderr.contains(says), "{args:?}: {stderr}");
    };
    let fails = |args: &[&str], files: &[&Path], says: &str| fails_with(1, args, files, says);
    let usage = |args: &[&str], files: &[&Path], says: &str| fails_with(2, args, files, says);
    // A flags file whose times are not the reference's.
    let shifted = dir.join("shifted.csv");
    std::fs::write(&shifted, "t,gyro_saturated\n0.005,1\n").unwrap();
    let mut args = vec!["compare", "--reference", reference.to_str().unwrap()];
    args.extend(["--reference-flags", shifted.to_str().unwrap()]);
    fails(&args, &[&est], "t = 0.005 is not a time of");
    // A flags file with no flag column.
    let none = dir.join("none.csv");
    std::fs::write(&none, "t,spread\n0,1\n").unwrap();
    let mut args = vec!["compare", "--reference", reference.to_str().unwrap()];
    args.extend(["--reference-flags", none.to_str().unwrap()]);
    fails(&args, &[&est], "no flag column");
    // A flag that is not a number, with its line.
    let bad = dir.join("bad.csv");
    std::fs::write(&bad, "t,gyro_saturated\n0,0\n0.01,yes\n").unwrap();
    let mut args = vec!["compare", "--reference", reference.to_str().unwrap()];
    args.extend(["--reference-flags", bad.to_str().unwrap()]);
    fails(
        &args,
        &[&est],
        "line 3: gyro_saturated \"yes\" is not a finite number",
    );
    // A range that is not a positive number.
    let args = [
        "compare",
        "--reference-range",
        "-1",
        "--reference",
        reference.to_str().unwrap(),
    ];
    usage(&args, &[&est], "must be a positive number");
    // The options need a reference; a truth file and a reference do not go together.
    usage(
        &["compare", "--reference-flags", flags.to_str().unwrap()],
        &[&est, &est],
        "--reference <REFERENCE.csv>",
    );
    usage(
        &["compare", "--reference", reference.to_str().unwrap()],
        &[&est, &est],
        "takes the estimates file alone",
    );
    usage(&["compare"], &[&est], "TRUTH.csv ESTIMATES.csv");
}
