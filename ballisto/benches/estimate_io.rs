//! `ballisto estimate` end to end on a large record: rows per second of reading the samples
//! file, estimating (f64, smoothed) and writing the estimates file; the reader alone; and, as
//! the I/O yardstick, a Python loop that only counts the samples file's lines, with
//! the ratio. Prints figures, asserts nothing (speed is checked by reading them, not by a
//! timed test).
//!
//! `cargo bench -p ballisto --bench estimate_io` (`ESTIMATE_IO_ROWS`, default 1 000 000).

use std::io::{BufWriter, Write};
use std::time::Instant;

use ballisto::estimate::{estimate_files, EstimateJob, Precision};
use ballisto::samples_csv::SamplesReader;
use estimator_core::Options;
use hal_sim::ideal::simulate_outputs;
use test_fixtures::{families, motions};

fn main() {
    let rows: usize = std::env::var("ESTIMATE_IO_ROWS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000);
    let dir = std::env::temp_dir().join(format!("ballisto-estimate-io-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    let file = families::tetrahedron::<rand_chacha::ChaCha8Rng>(0.15, 0.003, None);
    std::fs::write(dir.join("arrangement.toml"), file.to_toml()).expect("arrangement");
    let loaded = file.load("arrangement.toml").expect("arrangement");
    // 2 000 distinct samples of a tumble, repeated with increasing t (the estimator sees a
    // jump every 20 s, as a record with gaps would show it).
    let motion = motions::tumble();
    let truth = motion.run(0.01, 2000, 2);
    let outputs = simulate_outputs(&loaded, &truth, true, 9);
    let samples = dir.join("samples.csv");
    let mut w = BufWriter::new(std::fs::File::create(&samples).expect("samples"));
    writeln!(w, "t,{}", loaded.names.join(",")).unwrap();
    for k in 0..rows {
        write!(w, "{}", k as f64 * 0.01).unwrap();
        for v in &outputs[k % outputs.len()] {
            write!(w, ",{v}").unwrap();
        }
        writeln!(w).unwrap();
    }
    w.flush().unwrap();
    drop(w);
    let bytes_in = std::fs::metadata(&samples).map(|m| m.len()).unwrap_or(0);
    let out = dir.join("estimates.csv");
    let mut times = Vec::new();
    for _ in 0..3 {
        let started = Instant::now();
        let summary = estimate_files(&EstimateJob {
            arrangement: &dir.join("arrangement.toml"),
            samples: &samples,
            out: &out,
            model: None,
            options: Options::default(),
            precision: Precision::F64,
            progress: false,
        })
        .expect("estimate");
        times.push(started.elapsed().as_secs_f64());
        assert_eq!(summary.rows as usize, rows);
    }
    let bytes_out = std::fs::metadata(&out).map(|m| m.len()).unwrap_or(0);
    let best = times.iter().copied().fold(f64::INFINITY, f64::min);
    let worst = times.iter().copied().fold(0.0, f64::max);
    println!(
        "estimate_io: {rows} rows x 12 channels ({:.0} MB in, {:.0} MB out): best {best:.2} s = {:.0} rows/s, worst {worst:.2} s = {:.0} rows/s",
        bytes_in as f64 / 1e6,
        bytes_out as f64 / 1e6,
        rows as f64 / best,
        rows as f64 / worst
    );
    // The reader alone (parsing every field into channel order).
    let read = best_of(3, || {
        let mut reader = SamplesReader::open(&samples, &loaded.names).expect("samples");
        let mut row = vec![0.0; loaded.names.len()];
        let mut n = 0usize;
        while reader.next_row(&mut row).expect("row").is_some() {
            n += 1;
        }
        assert_eq!(n, rows);
    });
    println!(
        "estimate_io: reading alone {read:.2} s = {:.0} rows/s",
        rows as f64 / read
    );
    // The yardstick: Python counting the file's lines.
    let script = "import sys\nn = 0\nfor line in open(sys.argv[1]):\n    n += 1\n";
    let python = best_of(3, || {
        let ok = std::process::Command::new("python3")
            .args(["-c", script])
            .arg(&samples)
            .status()
            .is_ok_and(|s| s.success());
        if !ok {
            println!("estimate_io: python3 not available: no yardstick");
        }
    });
    println!(
        "estimate_io: python line loop {python:.2} s; ballisto estimate {:.1} x (best), {:.1} x (worst); the issue's budget is 6 x",
        best / python,
        worst / python
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The shortest of `n` runs of `f`, s.
fn best_of(n: usize, mut f: impl FnMut()) -> f64 {
    (0..n)
        .map(|_| {
            let started = Instant::now();
            f();
            started.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}
