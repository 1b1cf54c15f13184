//! `ballisto estimate`'s gravity-gradient columns (docs/formats.md: `gamma_*` = `A − {Ω}²` under
//! model G, empty under model F) against the truth file's, on `tetra-orbit`: the errors are
//! within the reported deviations, and model F leaves the columns empty.

mod common;

use common::ballisto;

use std::collections::HashMap;
use std::path::Path;

/// The file's columns by name, each row's fields as text.
fn read(path: &Path) -> (HashMap<String, usize>, Vec<Vec<String>>) {
    let (header, rows) = common::read_table(path);
    let index = header
        .into_iter()
        .enumerate()
        .map(|(i, h)| (h, i))
        .collect();
    (index, rows)
}

fn estimate(dir: &Path, model: &str, out: &str) {
    common::run_ok(
        common::estimate(
            &dir.join("arrangement.toml"),
            &dir.join("samples.csv"),
            &dir.join(out),
        )
        .args(["--model", model]),
    );
}

const NAMES: [&str; 6] = ["xx", "yy", "zz", "xy", "xz", "yz"];

#[test]
fn gravity_gradient_columns_are_within_their_deviations_and_empty_under_model_f() {
    let dir = common::tmpdir("gamma", "tetra");
    common::run_ok(
        ballisto()
            .args(["sim", "--scenario", "tetra-orbit", "--out"])
            .arg(&dir),
    );
    estimate(&dir, "general", "g.csv");
    estimate(&dir, "free-float", "f.csv");
    let (th, truth) = read(&dir.join("truth.csv"));
    let (gh, g) = read(&dir.join("g.csv"));
    assert_eq!(truth.len(), g.len());
    let mut ratio2 = [0.0f64; 6];
    let mut truth_size = 0.0f64;
    for (t, e) in truth.iter().zip(g.iter()) {
        for (k, n) in NAMES.iter().enumerate() {
            let name = format!("gamma_{n}");
            let true_value: f64 = t[th[&name]].parse().unwrap();
            let value: f64 = e[gh[&name]].parse().unwrap();
            let sd: f64 = e[gh[&format!("sd_gamma_{n}")]].parse().unwrap();
            assert!(value.is_finite() && sd > 0.0, "{name} {value} ± {sd}");
            ratio2[k] += ((value - true_value) / sd).powi(2);
            truth_size = truth_size.max(true_value.abs());
        }
    }
    // In orbit Γ is of the order of 3n² ≈ 4e-6 s⁻²: what the truth file says.
    assert!(truth_size > 1e-6 && truth_size < 1e-5, "{truth_size}");
    for (k, r) in ratio2.iter().enumerate() {
        let rms = (r / g.len() as f64).sqrt();
        println!("gamma_{}: RMS(error / sd) {rms:.3}", NAMES[k]);
        // Honest (≤ 1.5) and not uselessly wide (A's and {Ω}²'s errors are taken as
        // independent, so the deviation is an upper bound).
        assert!(rms > 0.2 && rms < 1.5, "gamma_{}: {rms}", NAMES[k]);
    }
    let (fh, f) = read(&dir.join("f.csv"));
    for n in NAMES {
        let c = fh[&format!("gamma_{n}")];
        assert!(f.iter().all(|r| r[c].is_empty()), "gamma_{n} under model F");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
