//! Helpers shared by the command-line tests.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The `ballisto` binary under test.
pub fn ballisto() -> Command {
    Command::new(env!("CARGO_BIN_EXE_ballisto"))
}

/// `ballisto estimate --arrangement A --samples S --out O` (more arguments to be added).
pub fn estimate(arrangement: &Path, samples: &Path, out: &Path) -> Command {
    let mut c = ballisto();
    c.arg("estimate")
        .arg("--arrangement")
        .arg(arrangement)
        .arg("--samples")
        .arg(samples)
        .arg("--out")
        .arg(out);
    c
}

/// Asserts that the command succeeded (showing its stderr if not); its stdout.
pub fn succeeded(out: &Output) -> String {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Asserts that the command succeeded; its summary (stderr: diagnostics, where every command
/// but `compare` and `decode`'s log says what it did).
pub fn summary(out: &Output) -> String {
    succeeded(out);
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Runs `cmd` and asserts that it succeeded ([`succeeded`]).
pub fn run_ok(cmd: &mut Command) -> Output {
    let out = cmd.output().unwrap();
    succeeded(&out);
    out
}

/// A fresh temporary directory `ballisto-<suite>-<pid>-<name>`.
pub fn tmpdir(suite: &str, name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ballisto-{suite}-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A fresh directory with `ballisto sim --firmware`'s record of tetra-orbit (its
/// `telemetry.bin` among the files).
pub fn firmware_record(suite: &str, name: &str) -> PathBuf {
    let d = tmpdir(suite, name);
    let mut c = ballisto();
    c.args([
        "sim",
        "-q",
        "--scenario",
        "tetra-orbit",
        "--firmware",
        "--out",
    ])
    .arg(&d);
    run_ok(&mut c);
    d
}

/// The text of the named scenario file `hal-sim/scenarios/<name>.toml`.
pub fn scenario_text(name: &str) -> String {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../hal-sim/scenarios")
        .join(format!("{name}.toml"));
    std::fs::read_to_string(path).unwrap()
}

/// A CSV file as text: its header's names and every row's fields.
pub fn read_table(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    (header, rows)
}
