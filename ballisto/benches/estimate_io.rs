//! `ballisto estimate` end to end on a large record: rows per second of reading the samples
//! file, estimating (f64, smoothed) and writing the estimates file. Prints figures, asserts
//! nothing (speed is checked by reading them, not by a timed test).
//!
//! `cargo bench -p ballisto --bench estimate_io` (`ESTIMATE_IO_ROWS`, default 1 000 000).

use std::io::{BufWriter, Write};
use std::time::Instant;

use ballisto::estimate::{estimate_files, EstimateJob, Precision};
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
    let _ = std::fs::remove_dir_all(&dir);
}
