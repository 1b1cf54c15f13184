//! Every command refuses an output that is one of its inputs —
//! the same file by identity (another path to it, a hard link), not only by name — before it
//! writes anything, and leaves the input as it was; a finished run leaves no temporary file.

mod common;
/// What may not happen to a file a command writes or reads (special files, modes, stdin, signals, closed pipes).
#[path = "no_data_loss/output_safety.rs"]
mod output_safety;

use std::path::{Path, PathBuf};
use std::process::Command;

use ballisto::samples_csv::write_samples;
use hal_sim::ideal::simulate_outputs;
use rand::SeedableRng;
use test_fixtures::{families, motions};

/// A tetrahedral arrangement tumbling: arrangement.toml and samples.csv in a fresh directory.
fn record(name: &str) -> PathBuf {
    let dir = common::tmpdir("no-data-loss", name);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let file = families::tetrahedron(0.15, 0.003, Some(&mut rng));
    std::fs::write(dir.join("arrangement.toml"), file.to_toml()).unwrap();
    let loaded = file.load("arrangement.toml").unwrap();
    let truth = motions::tumble().run(0.01, 300, 2);
    let out = simulate_outputs(&loaded, &truth, true, 9);
    write_samples(&dir.join("samples.csv"), &loaded.names, &truth, &out).unwrap();
    dir
}

/// Runs `cmd`, which must fail naming `input` as the input it refuses to overwrite, and checks
/// that every file in `dir` is as it was.
fn refused(mut cmd: Command, dir: &Path, input: &Path) {
    let before = contents(dir);
    let out = cmd.output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "not refused: {stderr}");
    assert!(
        stderr.contains("refusing to overwrite an input")
            && stderr.contains(&*input.display().to_string()),
        "{stderr}"
    );
    assert_eq!(contents(dir), before, "a file changed");
}

/// Every file of `dir` by name, with its bytes.
fn contents(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    files.sort();
    files
}

#[test]
fn estimate_refuses_to_overwrite_its_samples_or_arrangement() {
    let d = record("estimate");
    let (arr, samples) = (d.join("arrangement.toml"), d.join("samples.csv"));
    // By name, by another path to it, and through a hard link.
    let link = d.join("link.csv");
    std::fs::hard_link(&samples, &link).unwrap();
    for out in [samples.clone(), d.join(".").join("samples.csv"), link] {
        refused(common::estimate(&arr, &samples, &out), &d, &samples);
    }
    refused(common::estimate(&arr, &samples, &arr), &d, &arr);
    // A run that writes: its output in place, no temporary file beside it.
    common::run_ok(&mut common::estimate(
        &arr,
        &samples,
        &d.join("estimates.csv"),
    ));
    let names: Vec<String> = contents(&d).into_iter().map(|(n, _)| n).collect();
    assert!(names.iter().all(|n| !n.contains(".tmp")), "{names:?}");
    assert!(names.contains(&"estimates.csv".to_string()));
}

#[test]
fn com_refuses_to_overwrite_its_samples() {
    let d = record("com");
    let samples = d.join("samples.csv");
    let mut c = common::ballisto();
    c.arg("com")
        .arg("--arrangement")
        .arg(d.join("arrangement.toml"))
        .arg("--samples")
        .arg(&samples)
        .arg("--out")
        .arg(&samples);
    refused(c, &d, &samples);
}

#[test]
fn calibrate_refuses_to_overwrite_its_nominal_arrangement_or_record() {
    let d = record("calibrate");
    let (arr, samples) = (d.join("arrangement.toml"), d.join("samples.csv"));
    // The calibrated file onto the nominal one; the report onto the record.
    for (out, report, input) in [
        (arr.clone(), None, &arr),
        (d.join("calibrated.toml"), Some(&samples), &samples),
    ] {
        let mut c = common::ballisto();
        c.arg("calibrate")
            .arg("--arrangement")
            .arg(&arr)
            .arg("--samples")
            .arg(&samples)
            .arg("--out")
            .arg(&out);
        if let Some(r) = report {
            c.arg("--report").arg(r);
        }
        refused(c, &d, input);
    }
}

#[test]
fn decode_refuses_to_overwrite_its_telemetry_or_arrangement() {
    let d = record("decode");
    let tm = d.join("telemetry.bin");
    std::fs::write(&tm, [0u8, 1, 2, 3]).unwrap();
    let arr = d.join("arrangement.toml");
    let decode = |out: &Path, log: Option<&Path>, cal: Option<&Path>| {
        let mut c = common::ballisto();
        c.arg("decode").arg(&tm).arg("--out").arg(out);
        if let Some(l) = log {
            c.arg("--log").arg(l);
        }
        if let Some(cal) = cal {
            c.arg("--calibration")
                .arg(cal)
                .arg("--arrangement")
                .arg(&arr);
        }
        c
    };
    refused(decode(&tm, None, None), &d, &tm);
    refused(decode(&d.join("estimates.csv"), Some(&tm), None), &d, &tm);
    refused(decode(&d.join("estimates.csv"), None, Some(&arr)), &d, &arr);
}

#[test]
fn sim_refuses_to_overwrite_its_scenario_or_uplink() {
    let d = common::tmpdir("no-data-loss", "sim");
    // A scenario file saved under the name of one of sim's outputs, in its output directory.
    let scenario = d.join("arrangement.toml");
    std::fs::write(&scenario, common::scenario_text("tetra-orbit")).unwrap();
    let mut c = common::ballisto();
    c.args(["sim", "--scenario"])
        .arg(&scenario)
        .arg("--out")
        .arg(&d);
    refused(c, &d, &scenario);
    // An uplink file named like the telemetry it would be answered in.
    let uplink = d.join("telemetry.bin");
    std::fs::write(&uplink, [0u8, 1, 2, 0]).unwrap();
    let mut c = common::ballisto();
    c.args(["sim", "--scenario", "tetra-orbit", "--firmware", "--out"])
        .arg(&d)
        .arg("--uplink")
        .arg(format!("1:{}", uplink.display()));
    refused(c, &d, &uplink);
}
