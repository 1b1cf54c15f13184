//! `ballisto estimate`: the docs/formats.md contract, bad input, streaming.

mod common;

use common::estimate;

use std::path::{Path, PathBuf};

use ballisto::samples_csv::write_samples;
use ballisto::truth_csv::write_truth;
use ballisto_config::arrangement_file::ArrangementFile;
use hal_sim::ideal::simulate_outputs;
use rand::SeedableRng;
use test_fixtures::{families, motions};

fn tmpdir(name: &str) -> PathBuf {
    common::tmpdir("cli", name)
}

/// A tetrahedral arrangement tumbling: arrangement.toml, samples.csv, truth.csv in `dir`.
fn scenario(dir: &Path, samples: usize) -> Vec<hal_sim::motion::Truth> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let file = families::tetrahedron(0.15, 0.003, Some(&mut rng));
    std::fs::write(dir.join("arrangement.toml"), file.to_toml()).unwrap();
    let loaded = file.load("arrangement.toml").unwrap();
    let motion = motions::tumble();
    let truth = motion.run(0.01, samples, 2);
    let out = simulate_outputs(&loaded, &truth, true, 9);
    write_samples(&dir.join("samples.csv"), &loaded.names, &truth, &out).unwrap();
    write_truth(&dir.join("truth.csv"), &truth).unwrap();
    truth
}

/// The file's header and its rows as numbers (an empty field, such as model F's gravity
/// gradient, is NaN).
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let (header, rows) = common::read_table(path);
    let rows = rows
        .iter()
        .map(|r| {
            r.iter()
                .map(|v| {
                    if v.is_empty() {
                        f64::NAN
                    } else {
                        v.parse().unwrap()
                    }
                })
                .collect()
        })
        .collect();
    (header, rows)
}

#[test]
fn estimate_writes_the_contract_columns_one_row_per_sample() {
    let d = tmpdir("contract");
    let truth = scenario(&d, 600);
    let out = d.join("estimates.csv");
    common::run_ok(&mut estimate(
        &d.join("arrangement.toml"),
        &d.join("samples.csv"),
        &out,
    ));
    let (header, rows) = read_csv(&out);
    let want = "t,sigma0_x,sigma0_y,sigma0_z,domega_x,domega_y,domega_z,omega_x,omega_y,omega_z,A_xx,A_yy,A_zz,A_xy,A_xz,A_yz,flags";
    assert_eq!(header[..17].join(","), want);
    assert_eq!(rows.len(), truth.len());
    let mut se = 0.0;
    for (r, tr) in rows.iter().zip(truth.iter()) {
        assert_eq!(r[0], tr.t);
        // Every column but the protection levels (empty without redundancy: 12 channels).
        let levels = header.iter().position(|h| h == "pl_sigma0").unwrap();
        assert!(r[..levels].iter().all(|v| v.is_finite()));
        assert!(r[levels..].iter().all(|v| v.is_nan()));
        se += (0..3)
            .map(|k| (r[7 + k] - tr.omega[k]).powi(2))
            .sum::<f64>();
    }
    let rms = (se / rows.len() as f64).sqrt();
    assert!(rms < 0.01, "Ω RMS error {rms} rad/s");
    // The truth file uses the same column names (then the attitude).
    let (th, _) = read_csv(&d.join("truth.csv"));
    assert_eq!(th[..16].join(","), want.trim_end_matches(",flags"));
}

#[test]
fn initial_omega_accepts_a_leading_minus_in_both_spellings() {
    let d = tmpdir("minus");
    scenario(&d, 50);
    for args in [
        vec!["--initial-omega", "-1,0,2"],
        vec!["--initial-omega=-1,0,2"],
    ] {
        let st = estimate(
            &d.join("arrangement.toml"),
            &d.join("samples.csv"),
            &d.join("e.csv"),
        )
        .args(&args)
        .arg("--raw")
        .output()
        .unwrap();
        assert!(
            st.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&st.stderr)
        );
    }
}

fn run_expect_error(d: &Path, arrangement: &str, samples: &str, extra: &[&str]) -> (String, usize) {
    std::fs::write(d.join("a.toml"), arrangement).unwrap();
    std::fs::write(d.join("s.csv"), samples).unwrap();
    let out = d.join("e.csv");
    let _ = std::fs::remove_file(&out);
    let st = estimate(&d.join("a.toml"), &d.join("s.csv"), &out)
        .args(extra)
        .output()
        .unwrap();
    assert!(!st.status.success(), "expected failure");
    let err = String::from_utf8_lossy(&st.stderr).to_string();
    assert_eq!(err.trim().lines().count(), 1, "one sentence: {err}");
    let rows = std::fs::read_to_string(&out)
        .map(|t| t.lines().count().saturating_sub(1))
        .unwrap_or(0);
    (err, rows)
}

fn good_arrangement() -> String {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    families::tetrahedron(0.15, 0.003, Some(&mut rng)).to_toml()
}

fn good_samples(rows: usize) -> String {
    let f = ArrangementFile::parse(&good_arrangement(), "a").unwrap();
    let l = f.load("a").unwrap();
    let mut s = format!("t,{}\n", l.names.join(","));
    for k in 0..rows {
        s += &format!("{}", k as f64 * 0.01);
        for i in 0..l.names.len() {
            s += &format!(",{}", 0.1 * ((k * 7 + i * 3) % 11) as f64);
        }
        s += "\n";
    }
    s
}

#[test]
fn bad_samples_are_named_and_nothing_is_written() {
    let d = tmpdir("badsamples");
    let a = good_arrangement();
    let s = good_samples(10);
    // Missing channel column.
    let mut lines: Vec<String> = s
        .lines()
        .map(|l| l.rsplit_once(',').unwrap().0.to_string())
        .collect();
    lines.push(String::new());
    let (err, _) = run_expect_error(&d, &a, &lines.join("\n"), &[]);
    assert!(
        err.contains("s.csv line 1") && err.contains("channel \"u3.z\" has no column"),
        "{err}"
    );
    // Non-numeric field on line 6.
    let mut l: Vec<String> = s.lines().map(str::to_string).collect();
    l[5] = l[5].replacen(",0.", ",zero", 1);
    let (err, rows) = run_expect_error(&d, &a, &(l.join("\n") + "\n"), &[]);
    assert!(
        err.contains("line 6") && err.contains("is not a number"),
        "{err}"
    );
    assert_eq!(rows, 0, "a failed run writes nothing");
    // Non-increasing t on line 4.
    let mut l: Vec<String> = s.lines().map(str::to_string).collect();
    l[3] = l[3].replacen("0.02", "0.005", 1);
    let (err, rows) = run_expect_error(&d, &a, &(l.join("\n") + "\n"), &[]);
    assert!(
        err.contains("line 4") && err.contains("does not increase"),
        "{err}"
    );
    assert_eq!(rows, 0);
    // Wrong number of fields.
    let mut l: Vec<String> = s.lines().map(str::to_string).collect();
    l[2] += ",1.0";
    let (err, _) = run_expect_error(&d, &a, &(l.join("\n") + "\n"), &[]);
    assert!(err.contains("line 3") && err.contains("fields"), "{err}");
}

#[test]
fn bad_arrangements_and_options_are_named() {
    let d = tmpdir("badarr");
    let s = good_samples(3);
    let a = good_arrangement();
    let (err, _) = run_expect_error(&d, &a.replacen("position", "positon", 1), &s, &[]);
    assert!(err.contains("a.toml") && err.contains("positon"), "{err}");
    let zero = "[[channel]]\nname = \"c\"\nposition = [0.1, 0.0, 0.0]\naxis = [0.0, 0.0, 0.0]\nnoise = 0.01\n";
    let (err, _) = run_expect_error(&d, zero, "t,c\n0,1\n", &[]);
    assert!(err.contains("channel \"c\": axis has zero length"), "{err}");
    let (err, _) = run_expect_error(&d, &a.replacen("noise = 0.003", "noise = -1.0", 1), &s, &[]);
    assert!(
        err.contains("noise = -1 must be a positive finite number"),
        "{err}"
    );
    let (err, _) = run_expect_error(&d, &a, &s, &["--model", "ballistic"]);
    // clap's refusal names the option, the value and the values it takes.
    assert!(
        err.contains("'ballistic'") && err.contains("--model") && err.contains("free-float"),
        "{err}"
    );
    let (err, _) = run_expect_error(&d, &a, &s, &["--initial-omega", "1,x,2"]);
    assert!(err.contains("\"x\" is not a number"), "{err}");
    let (err, _) = run_expect_error(&d, &a, &s, &["--initial-omega", "1,2"]);
    assert!(err.contains("expected three numbers"), "{err}");
    // Too few channels for the model, named.
    let nine = families::nine_channel(0.1, 0.01).to_toml();
    let f9 = ArrangementFile::parse(&nine, "a")
        .unwrap()
        .load("a")
        .unwrap();
    let s9 = format!("t,{}\n0,{}\n", f9.names.join(","), ["0.5"; 9].join(","));
    let (err, _) = run_expect_error(&d, &nine, &s9, &["--model", "general"]);
    assert!(
        err.contains("model general needs at least 12 channels, 9 are included"),
        "{err}"
    );
    // Duplicate channel names.
    let dup = format!(
        "{zero}{}",
        zero.replace("[0.0, 0.0, 0.0]", "[1.0, 0.0, 0.0]")
    );
    let (err, _) = run_expect_error(
        &d,
        &dup.replacen("[0.0, 0.0, 0.0]", "[0.0, 1.0, 0.0]", 1),
        "t,c\n",
        &[],
    );
    assert!(err.contains("channel \"c\" is defined twice"), "{err}");
}

fn max_rss_of_children_kib() -> i64 {
    // SAFETY: getrusage writes into the struct we pass; RUSAGE_CHILDREN is a valid selector.
    unsafe {
        let mut ru: libc::rusage = std::mem::zeroed();
        libc::getrusage(libc::RUSAGE_CHILDREN, &mut ru);
        ru.ru_maxrss
    }
}

#[test]
fn estimate_streams_memory_does_not_grow_with_the_file() {
    let d = tmpdir("stream");
    let a = good_arrangement();
    std::fs::write(d.join("a.toml"), &a).unwrap();
    let run = |rows: usize| {
        // Written row by row: the test process itself must stay small, because a child's
        // maximum RSS includes what it shared with its parent before exec.
        {
            use std::io::Write;
            let f = std::fs::File::create(d.join("s.csv")).unwrap();
            let mut w = std::io::BufWriter::new(f);
            let text = good_samples(2);
            let header = text.lines().next().unwrap();
            writeln!(w, "{header}").unwrap();
            let n = header.split(',').count() - 1;
            for k in 0..rows {
                write!(w, "{}", k as f64 * 0.01).unwrap();
                for i in 0..n {
                    write!(w, ",{}", 0.1 * ((k * 7 + i * 3) % 11) as f64).unwrap();
                }
                writeln!(w).unwrap();
            }
        }
        let st = estimate(&d.join("a.toml"), &d.join("s.csv"), &d.join("e.csv"))
            .arg("--raw")
            .status()
            .unwrap();
        assert!(st.success());
        max_rss_of_children_kib()
    };
    let small = run(2_000);
    let big_rows = 300_000;
    let big = run(big_rows);
    let file_kib = std::fs::metadata(d.join("s.csv")).unwrap().len() as i64 / 1024;
    let out_kib = std::fs::metadata(d.join("e.csv")).unwrap().len() as i64 / 1024;
    println!("max RSS: {small} KiB for 2 000 rows, {big} KiB for {big_rows} rows (input {file_kib} KiB, output {out_kib} KiB)");
    assert!(
        big - small < file_kib / 10,
        "memory grew by {} KiB for a {file_kib} KiB input",
        big - small
    );
}
