//! Options and inputs refused as documented (`ballisto --help`, `docs/ballisto.md`): a bad
//! option value exits 2 naming the option, before any work; the wrong kind of input exits 1
//! with nothing written.

use crate::common;

use std::process::Command;

fn ballisto(args: &[&str]) -> Command {
    let mut c = common::ballisto();
    c.args(args);
    c
}

/// Runs `c`, which must exit `code` with one line on stderr containing `says`.
fn refused(mut c: Command, code: i32, says: &str) {
    let out = c.output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "{c:?}: {stderr}");
    assert!(stderr.contains(says), "{c:?}: {stderr}");
}

#[test]
fn non_finite_and_out_of_range_option_values_exit_2_naming_the_option() {
    let d = common::tmpdir("options", "values");
    let out = d.join("x.bin");
    let o = out.to_str().unwrap();
    for value in ["nan", "inf", "-inf"] {
        refused(
            ballisto(&["decode", "t.bin", "--out", o, "--time-offset", value]),
            2,
            "--time-offset",
        );
        refused(
            ballisto(&["tc", "set-time", value, "--out", o]),
            2,
            "SECONDS",
        );
        refused(
            ballisto(&[
                "tc",
                "identify",
                "--period-ms",
                "40",
                "--window",
                value,
                "--out",
                o,
            ]),
            2,
            "--window",
        );
    }
    refused(
        ballisto(&["tc", "--sequence", "16384", "ping", "--out", o]),
        2,
        "--sequence",
    );
    refused(
        ballisto(&[
            "tc",
            "identify",
            "--period-ms",
            "40",
            "--window",
            "0",
            "--out",
            o,
        ]),
        2,
        "--window",
    );
    // `--to inf` is the documented default: no end.
    refused(
        ballisto(&["tc", "reference", "r.csv", "--to", "nan", "--out", o]),
        2,
        "--to",
    );
    assert!(!out.exists(), "nothing written");
}

#[test]
fn a_directory_as_output_is_refused_before_the_work() {
    let d = common::tmpdir("options", "dir");
    refused(
        ballisto(&["tc", "ping", "--out", d.to_str().unwrap()]),
        1,
        "is a directory",
    );
}

#[test]
fn bytes_without_a_packet_are_not_telemetry_and_nothing_is_written() {
    let d = common::tmpdir("options", "garbage");
    let input = d.join("garbage.bin");
    // Bytes of no frame: a text file given by mistake.
    std::fs::write(&input, "t,a,b\n0.0,1.0,2.0\n".repeat(200)).unwrap();
    let out = d.join("estimates.csv");
    refused(
        ballisto(&[
            "decode",
            input.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]),
        1,
        "not telemetry",
    );
    assert!(!out.exists(), "nothing written");
}
