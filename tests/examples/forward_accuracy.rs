//! Probe (issue 15): the forward path (the firmware's: no look-ahead) on the accuracy cases of
//! `tests/tests/branch_lock.rs` — raw σ0, Ω′ and Ω RMS over the truth-started maximum
//! likelihood, and the filtered (default) output's Ω RMS, flagged and silently wrong rows.
//!
//! `cargo run --release -p e2e-tests --example forward_accuracy`
//!
//! `SEEDS=1,2` the seeds (default 1), `CASES=0,3` the cases by index (default all: the four
//! rates, the two other noises and the two other arms around 1 kHz, 2e-3 m/s², 0.12 m, in a
//! tumble then a manoeuvre), `CASE=RATE,NOISE,ARM,tumble|manoeuvre` one case of the family
//! instead, `SECONDS` the record's length (default 20). The maximum
//! likelihood's RMS is cached per case in `target/ml-cache/` (slow at 4 kHz).

use e2e_tests::nine::{self, Params, Score};

/// The accuracy cases in a tumble, then in a manoeuvre.
fn cases() -> Vec<(f64, f64, f64, bool)> {
    [false, true]
        .into_iter()
        .flat_map(|m| {
            nine::accuracy_cases()
                .into_iter()
                .map(move |(r, n, a)| (r, n, a, m))
        })
        .collect()
}

fn list<T: std::str::FromStr>(name: &str) -> Option<Vec<T>> {
    std::env::var(name)
        .ok()
        .map(|v| v.split(',').filter_map(|x| x.parse().ok()).collect())
}

fn main() {
    let seeds: Vec<u64> = list("SEEDS").unwrap_or_else(|| vec![1]);
    let seconds: f64 = std::env::var("SECONDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(20.0);
    // `CASE=RATE,NOISE,ARM,manoeuvre|tumble`: one case of the family instead.
    let all = match std::env::var("CASE") {
        Ok(v) => {
            let f: Vec<&str> = v.split(',').collect();
            let num = |i: usize| f.get(i).and_then(|x| x.parse::<f64>().ok()).expect("CASE");
            vec![(num(0), num(1), num(2), f.get(3) == Some(&"manoeuvre"))]
        }
        Err(_) => cases(),
    };
    let picked: Vec<usize> = list("CASES").unwrap_or_else(|| (0..all.len()).collect());
    let cache = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/ml-cache");
    std::fs::create_dir_all(&cache).expect("cache directory");
    println!("| case | seed | raw σ0 / ML | Ω′ / ML | Ω / ML | filtered Ω RMS | flagged | silent raw / filtered |");
    println!("|---|---|---|---|---|---|---|---|");
    for &ci in &picked {
        let Some(&(rate_hz, noise, arm, manoeuvre)) = all.get(ci) else {
            continue;
        };
        for &seed in &seeds {
            let case = nine::make(Params {
                rate_hz,
                noise,
                arm,
                seconds,
                seed,
                manoeuvre,
            });
            let key = cache.join(format!(
                "{rate_hz}_{noise:e}_{arm}_{manoeuvre}_{seed}_{seconds}"
            ));
            // The cache holds the three RMS figures; anything else is computed again.
            let cached: Option<[f64; 3]> = std::fs::read_to_string(&key).ok().and_then(|s| {
                let v: Vec<f64> = s.split(',').filter_map(|x| x.parse().ok()).collect();
                v.try_into().ok()
            });
            let ml = cached.unwrap_or_else(|| {
                let r = nine::rms_of(&case.ml_errors());
                std::fs::write(&key, format!("{},{},{}", r[0], r[1], r[2])).expect("cache");
                r
            });
            let fwd = case.forward(true);
            if let Ok(n) = std::env::var("DUMP").map(|v| v.parse::<usize>().unwrap_or(0)) {
                for (k, (e, tr)) in fwd.iter().zip(case.truth.iter()).take(n).enumerate() {
                    let d = (0..3)
                        .map(|i| (e.omega[i] - tr.omega[i]).powi(2))
                        .sum::<f64>()
                        .sqrt();
                    println!(
                        "{k} err {d:.4} flags {} margin {:.1} sd {:.4}",
                        e.flags.0, e.branch_margin, e.sd_omega[0]
                    );
                }
            }
            let raw = Score::of(&fwd, &case.truth);
            let filtered = Score::of(&case.forward(false), &case.truth);
            let r = raw.rms();
            let ratio: [f64; 3] = core::array::from_fn(|i| r[i] / ml[i]);
            println!(
                "| {rate_hz} Hz {noise:e} {arm} m {} | {seed} | {:.2} | {:.2} | {:.2} | {:.4} | {:.1} % | {} / {} |",
                if manoeuvre { "manoeuvre" } else { "tumble" },
                ratio[0],
                ratio[1],
                ratio[2],
                filtered.rms()[2],
                raw.pct(raw.flagged),
                raw.silent,
                filtered.silent
            );
        }
    }
}
