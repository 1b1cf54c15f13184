//! The ground tool's conventions: telecommands built by `ballisto tc` go through the firmware
//! and their verification reports come back named by `decode --commands`; exit codes are
//! distinct; `-` is stdin/stdout; `--quiet` is quiet; empty inputs are errors.

/// Memory bounded whatever the input's size.
#[path = "conventions_cli/bounded.rs"]
mod bounded;
mod common;
/// Options and inputs refused as documented.
#[path = "conventions_cli/options.rs"]
mod options;

use std::io::Write;
use std::path::Path;
use std::process::{Output, Stdio};

use common::{ballisto, read_table, run_ok, summary, tmpdir};

fn tc(dir: &Path, file: &str, args: &[&str]) -> Output {
    ballisto()
        .arg("tc")
        .args(args)
        .arg("--out")
        .arg(dir.join(file))
        .output()
        .unwrap()
}

/// A fresh directory with `tetra-orbit` simulated into it (arrangement, samples, truth).
fn simulated(name: &str) -> std::path::PathBuf {
    let d = tmpdir("conventions", name);
    run_ok(
        ballisto()
            .args(["sim", "--scenario", "tetra-orbit", "-q", "--out"])
            .arg(&d),
    );
    d
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// `tc` → the firmware's command link (`sim --firmware --uplink`) → `decode --commands`: each
/// verification report names its command, the exclusion shows in the decoded estimates, a
/// command the unit refuses is reported refused, and a command never sent has no report.
#[test]
fn telecommands_built_on_the_ground_reach_the_firmware_and_their_reports_come_back_named() {
    let d = tmpdir("conventions", "tc");
    // The unit's arrangement: what the scenario writes.
    run_ok(
        ballisto()
            .args(["sim", "--scenario", "tetra-orbit", "--out"])
            .arg(d.join("first")),
    );
    let arrangement = d.join("first/arrangement.toml");
    let a = arrangement.to_str().unwrap();
    summary(&tc(
        &d,
        "exclude.bin",
        &["exclude", "u1.x", "--arrangement", a, "--sequence", "5"],
    ));
    summary(&tc(&d, "include.bin", &["include", "3", "--sequence", "6"]));
    summary(&tc(&d, "ping.bin", &["ping", "--sequence", "9"]));
    // Within what the link carries, so the ground passes it; the unit has 12 channels.
    summary(&tc(
        &d,
        "refused.bin",
        &["exclude", "20", "--sequence", "10"],
    ));
    summary(&tc(&d, "unsent.bin", &["housekeeping", "--sequence", "11"]));
    // The ground refuses what it knows the unit would: nothing is written.
    let out = tc(&d, "bad.bin", &["exclude", "12", "--arrangement", a]);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("the unit would refuse it"),
        "{}",
        stderr(&out)
    );
    assert!(!d.join("bad.bin").exists());

    let uplink = |t: &str, f: &str| format!("{t}:{}", d.join(f).display());
    run_ok(
        ballisto()
            .args([
                "sim",
                "--scenario",
                "tetra-orbit",
                "--firmware",
                "-q",
                "--out",
            ])
            .arg(d.join("sim"))
            .args(["--uplink", &uplink("2", "exclude.bin")])
            .args(["--uplink", &uplink("4", "include.bin")])
            .args(["--uplink", &uplink("5", "ping.bin")])
            .args(["--uplink", &uplink("6", "refused.bin")]),
    );
    let decoded = d.join("decoded.csv");
    let mut decode = ballisto();
    decode
        .arg("decode")
        .arg(d.join("sim/telemetry.bin"))
        .arg("--out")
        .arg(&decoded);
    for f in [
        "exclude.bin",
        "include.bin",
        "ping.bin",
        "refused.bin",
        "unsent.bin",
    ] {
        decode.arg("--commands").arg(d.join(f));
    }
    let out = run_ok(&mut decode);
    let log = String::from_utf8_lossy(&out.stdout);
    for line in [
        "TC 0x18ba/0xc005 accepted -- TC[200,4] exclude channel 3",
        "TC 0x18ba/0xc005 completed -- TC[200,4] exclude channel 3",
        "TC 0x18ba/0xc006 completed -- TC[200,5] include channel 3",
        "TC 0x18ba/0xc009 completed -- TC[17,1] are you alive",
        "NO VERIFICATION TC 0x18ba/0xc00b -- TC[3,27] report housekeeping",
    ] {
        assert!(log.contains(line), "no \"{line}\" in\n{log}");
    }
    assert!(log.contains("ALIVE"), "{log}");
    let refused = log
        .lines()
        .find(|l| l.contains("0xc00a"))
        .unwrap_or_else(|| panic!("no report of seq 10:\n{log}"));
    assert!(
        refused.contains("NOT ACCEPTED") && refused.ends_with("-- TC[200,4] exclude channel 20"),
        "{refused}"
    );
    // The exclusion in the estimates the unit sent: channel 3 out from 2 s to 4 s.
    let (names, rows) = read_table(&decoded);
    let col = |n: &str| names.iter().position(|h| h == n).unwrap();
    let (t, excluded) = (col("t"), col("excluded_channels"));
    let mut out_rows = 0;
    for r in &rows {
        let t: f64 = r[t].parse().unwrap();
        let e: u32 = r[excluded].parse().unwrap();
        if !(1.9..=4.2).contains(&t) {
            assert_eq!(e, 0, "t = {t}");
        }
        if (2.2..3.9).contains(&t) {
            assert_eq!(e, 1 << 3, "t = {t}");
            out_rows += 1;
        }
    }
    assert!(out_rows > 150, "{out_rows}");
}

/// Usage, bad input, damaged telemetry and refused results have their own codes (the last two
/// are checked in sim_cli.rs and calibrate_cli.rs); bare `ballisto` shows its help, laid out.
#[test]
fn exit_codes_and_bare_help() {
    let out = ballisto().output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let help = stderr(&out);
    assert!(
        help.lines().count() > 10 && help.contains("Commands:"),
        "{help}"
    );
    assert!(
        help.contains("Exit status: 0 done (or stdout's reader went away); 1 an input is wrong"),
        "{help}"
    );
    let out = ballisto()
        .args(["estimate", "--samples", "x.csv"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2), "usage: {}", stderr(&out));
    let d = tmpdir("conventions", "codes");
    let out = ballisto()
        .args(["estimate", "--arrangement"])
        .arg(d.join("missing.toml"))
        .args(["--samples", "s.csv", "--out"])
        .arg(d.join("e.csv"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "bad input: {}", stderr(&out));
    assert!(stderr(&out).contains("missing.toml"), "{}", stderr(&out));
}

/// A samples file with a header and no rows, and an empty telemetry file, are errors: nothing
/// is written, an earlier output of that name is kept.
#[test]
fn empty_inputs_are_errors() {
    let d = simulated("empty");
    let samples = std::fs::read_to_string(d.join("samples.csv")).unwrap();
    let header_only = d.join("header-only.csv");
    std::fs::write(
        &header_only,
        samples.lines().next().unwrap().to_string() + "\n",
    )
    .unwrap();
    let out_file = d.join("estimates-old.csv");
    std::fs::write(&out_file, "kept\n").unwrap();
    let out = common::estimate(&d.join("arrangement.toml"), &header_only, &out_file)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("no sample rows"), "{}", stderr(&out));
    assert_eq!(std::fs::read_to_string(&out_file).unwrap(), "kept\n");

    let empty = d.join("empty.bin");
    std::fs::write(&empty, b"").unwrap();
    let out = ballisto()
        .arg("decode")
        .arg(&empty)
        .arg("--out")
        .arg(d.join("decoded.csv"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("empty: no telemetry"),
        "{}",
        stderr(&out)
    );
    assert!(!d.join("decoded.csv").exists());
}

/// `--samples -` reads stdin and `--out -` writes stdout: the same bytes as through files;
/// `--quiet` leaves stderr empty, and the summary is on stderr otherwise.
#[test]
fn dash_is_stdin_and_stdout_and_quiet_is_quiet() {
    let d = simulated("dash");
    let arrangement = d.join("arrangement.toml");
    let through_files = d.join("estimates-files.csv");
    let out = run_ok(&mut common::estimate(
        &arrangement,
        &d.join("samples.csv"),
        &through_files,
    ));
    assert!(out.stdout.is_empty(), "results go to the file");
    assert!(
        stderr(&out).contains("ballisto estimate: 2001 rows"),
        "{}",
        stderr(&out)
    );

    let mut child = ballisto()
        .args(["estimate", "-q", "--arrangement"])
        .arg(&arrangement)
        .args(["--samples", "-", "--out", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let samples = std::fs::read(d.join("samples.csv")).unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let writer = std::thread::spawn(move || stdin.write_all(&samples));
    let out = child.wait_with_output().unwrap();
    writer.join().unwrap().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(stderr(&out), "", "--quiet");
    assert_eq!(out.stdout, std::fs::read(&through_files).unwrap());
    assert!(!Path::new("-").exists(), "no file named -");
}

/// A wrong unit does not pass silently: readings in mg, readings in g in orbit, positions in mm
/// and a reading no part can give are each named in a warning, and the absurd reading's row carries its own flag.
#[test]
fn implausible_units_and_absurd_readings_are_named() {
    let d = simulated("plausible");
    let arrangement = std::fs::read_to_string(d.join("arrangement.toml")).unwrap();
    let samples = std::fs::read_to_string(d.join("samples.csv")).unwrap();
    let map_readings = |f: &dyn Fn(usize, f64) -> String| -> String {
        let mut lines = samples.lines();
        let mut out = lines.next().unwrap().to_string() + "\n";
        for (k, line) in lines.enumerate() {
            let mut fields = line.split(',');
            out.push_str(fields.next().unwrap());
            for v in fields {
                out.push(',');
                out.push_str(&f(k, v.parse().unwrap()));
            }
            out.push('\n');
        }
        out
    };
    let run = |name: &str, arrangement: &str, samples: &str| -> String {
        let a = d.join(format!("{name}.toml"));
        let s = d.join(format!("{name}.csv"));
        std::fs::write(&a, arrangement).unwrap();
        std::fs::write(&s, samples).unwrap();
        summary(
            &common::estimate(&a, &s, &d.join(format!("{name}-est.csv")))
                .output()
                .unwrap(),
        )
    };
    // As simulated: no warning.
    let clean = run("clean", &arrangement, &samples);
    assert!(!clean.contains("WARNING"), "{clean}");
    // Readings in mg (no full scale declared, so they are not absurd).
    let no_range: String = arrangement
        .lines()
        .filter(|l| !l.starts_with("range"))
        .map(|l| l.to_string() + "\n")
        .collect();
    let mg = run(
        "mg",
        &no_range,
        &map_readings(&|_, v| (v * 1000.0).to_string()),
    );
    assert!(
        mg.contains("WARNING") && mg.contains("raw counts or mg"),
        "{mg}"
    );
    // Readings in g, in orbit (σ0 near zero in any unit): named by their noise, 1/9.81 of the
    // declared.
    let g = run(
        "g",
        &arrangement,
        &map_readings(&|_, v| (v / 9.80665).to_string()),
    );
    assert!(
        g.contains("WARNING") && g.contains("readings look like g"),
        "{g}"
    );
    // Positions in millimetres.
    let mm: String = arrangement
        .lines()
        .map(|l| match l.strip_prefix("position = [") {
            Some(rest) => {
                let v: Vec<f64> = rest
                    .trim_end_matches(']')
                    .split(',')
                    .map(|x| x.trim().parse::<f64>().unwrap() * 1000.0)
                    .collect();
                format!("position = [{}, {}, {}]\n", v[0], v[1], v[2])
            }
            None => l.to_string() + "\n",
        })
        .collect();
    let out = run("mm", &mm, &samples);
    assert!(out.contains("positions look like millimetres"), "{out}");
    // Every reading of row 100 set to 1e300.
    let absurd = map_readings(&|k, v| {
        if k == 100 {
            "1e300".to_string()
        } else {
            v.to_string()
        }
    });
    let out = run("absurd", &arrangement, &absurd);
    assert!(
        out.contains("readings beyond") && out.contains("rows flagged 128"),
        "{out}"
    );
    let (names, rows) = read_table(&d.join("absurd-est.csv"));
    let flags = names.iter().position(|n| n == "flags").unwrap();
    for (k, r) in rows.iter().enumerate() {
        let f: u32 = r[flags].parse().unwrap();
        assert_eq!(f & 128 != 0, k == 100, "row {k}: flags {f}");
        if k == 100 {
            assert_ne!(f & 32, 0, "read as missing: the row is the prediction");
        }
    }
}

/// `compare` with no rows to compare is an error, not an RMS error of 0.
#[test]
fn compare_without_rows_is_an_error() {
    let d = tmpdir("conventions", "compare");
    run_ok(
        ballisto()
            .args([
                "sim",
                "--scenario",
                "tetra-orbit",
                "-q",
                "--estimate",
                "--out",
            ])
            .arg(&d),
    );
    let est = std::fs::read_to_string(d.join("estimates.csv")).unwrap();
    let header_only = d.join("header-only.csv");
    std::fs::write(&header_only, est.lines().next().unwrap().to_string() + "\n").unwrap();
    let out = ballisto()
        .arg("compare")
        .arg(d.join("truth.csv"))
        .arg(&header_only)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("nothing to compare"),
        "{}",
        stderr(&out)
    );
    assert!(out.stdout.is_empty());
}

/// An output in a directory that does not exist is refused before any work is done.
#[test]
fn an_output_in_a_missing_directory_is_refused_at_once() {
    let d = simulated("nodir");
    let out = common::estimate(
        &d.join("arrangement.toml"),
        &d.join("samples.csv"),
        &d.join("missing/estimates.csv"),
    )
    .output()
    .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("does not exist"), "{}", stderr(&out));
}

/// `sim --help` lists every named scenario.
#[test]
fn sim_help_lists_every_named_scenario() {
    let out = run_ok(ballisto().args(["sim", "--help"]));
    let help = String::from_utf8_lossy(&out.stdout);
    for name in hal_sim::scenario::named::NAMES {
        assert!(
            help.contains(&format!("\n  {name} ")),
            "sim --help omits {name}:\n{help}"
        );
    }
}

/// The shell completions and the manual pages come from the command line's definition: every
/// subcommand is in them.
#[test]
fn completions_and_manual_pages_cover_every_subcommand() {
    let subcommands = [
        "estimate",
        "sim",
        "decode",
        "calibrate",
        "com",
        "compare",
        "tc",
    ];
    for shell in ["bash", "zsh", "fish"] {
        let out = common::ballisto()
            .args(["completions", shell])
            .output()
            .unwrap();
        let script = common::succeeded(&out);
        for s in subcommands {
            assert!(script.contains(s), "{shell}: no {s}");
        }
    }
    let d = common::tmpdir("conventions", "man");
    let out = common::ballisto()
        .args(["man", "--out"])
        .arg(&d)
        .output()
        .unwrap();
    common::succeeded(&out);
    for s in subcommands {
        let page = std::fs::read_to_string(d.join(format!("ballisto-{s}.1"))).unwrap();
        assert!(page.contains(".SH NAME"), "{s}: {page}");
    }
    let tc = std::fs::read_to_string(d.join("ballisto-tc-identify.1")).unwrap();
    assert!(tc.contains("period\\-ms"), "{tc}");
    assert!(std::fs::read_to_string(d.join("ballisto.1"))
        .unwrap()
        .contains("ballisto\\-decode(1)"));
}
