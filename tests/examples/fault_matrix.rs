//! The fault matrix of issue 17, measured on what the firmware does today: every fault kind of
//! hal-sim injected into one part at a random time, through the firmware on the simulated
//! buses (`ballisto sim --firmware`'s path), on a layout with redundancy: the `tetra-orbit`
//! tetrahedron (ideal ADXL355s: noise and clock offsets only) with two more ADXL355s on its
//! SPI bus, N = 18, model G: 6 degrees of freedom in the whitened residual.
//!
//! A fault is "seen" when a row carries flag 64 (residual high: the per-sample χ² above its
//! 99.9 % point, or the fault monitor's window high with no part isolated) or the faulty part
//! is missing or out of the solve (bus-level checks, or isolated by the fault monitor,
//! `estimator_core::fault_monitor`). Per kind: runs, detection rate within 1 s of the onset,
//! median and worst latency; isolation (the faulty part out of the solve while the fault is
//! active: runs, median and worst latency); rows with a healthy part out; rows flagged 64 while
//! the fault is active; rows silently wrong (Ω error above 5 reported deviations, no warning
//! flag) while it is active and after it; the Ω error while the faulty part is out against the
//! same run without the fault and without that part (RMS ratio over the runs); NaN in any
//! estimate, telemetry packets lost. The fault-free runs give the false-alarm rates.
//!
//! `cargo run --release -p e2e-tests --example fault_matrix -- [RUNS]` (default 20; about 2 s).
//! `SHOW=KIND` (a kind's name as in the table) prints each run of that kind: the part, the
//! onset, when the part went out, its worst Ω error while out, rows with a healthy part out.

use e2e_tests::faults::{errors_without_part, fault_run, redundant_layout};
use hal_sim::scenario::{FaultSpec, Scenario};

/// Seconds of each run.
const DURATION: f64 = 12.0;
/// Each fault lasts this long (s), starting uniformly in 3–7 s.
const FAULT_S: f64 = 3.0;

fn layout(seed: u64) -> Scenario {
    redundant_layout(seed, DURATION)
}

/// The fault kinds of hal-sim, as scenario faults on `part` from `start`.
fn kinds(sigma: f64) -> Vec<(&'static str, FaultSpec)> {
    let f = |kind: &str| FaultSpec {
        part: String::new(),
        kind: kind.to_string(),
        start: 0.0,
        end: None,
        bias: None,
        rate: None,
        density: None,
        probability: None,
        stall: None,
    };
    let bias = |b: f64| FaultSpec {
        bias: Some([b, -b, 0.5 * b]),
        ..f("bias-jump")
    };
    vec![
        ("stuck", f("stuck")),
        ("bias jump 0.1 m/s²", bias(0.1)),
        ("bias jump 10 σ", bias(10.0 * sigma)),
        ("bias jump 3 σ", bias(3.0 * sigma)),
        (
            "drift 3 σ per s",
            FaultSpec {
                rate: Some([3.0 * sigma, -3.0 * sigma, 1.5 * sigma]),
                ..f("drift")
            },
        ),
        (
            "noise burst ×30",
            FaultSpec {
                density: Some(30.0 * 2.2e-4),
                ..f("noise-burst")
            },
        ),
        ("saturation", f("saturation")),
        ("dead", f("dead")),
        (
            "corrupt 5 %",
            FaultSpec {
                probability: Some(0.05),
                ..f("corrupt")
            },
        ),
        (
            "timeout",
            FaultSpec {
                stall: Some(1e-3),
                ..f("timeout")
            },
        ),
    ]
}

fn main() {
    let runs: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(20);
    // One sample's noise: the arrangement's declared channel noise.
    let loaded = layout(0).arrangement().load("arrangement.toml").unwrap();
    let sigma = loaded.arrangement.channels()[0].noise;
    println!(
        "layout: tetra-orbit + 2 ADXL355 (N = 18, model G, 6 dof), ideal parts (noise and clock offsets only), {DURATION} s at 100 Hz, faults of {FAULT_S} s from 3–7 s, one part chosen at random; one sample's σ ≈ {sigma:.1e} m/s²"
    );
    println!("| fault | runs | detected ≤ 1 s | latency median / worst (s) | isolated (runs) | isolation latency median / worst (s) | rows with a healthy part out | rows flagged 64 while active | silent while active | silent after | Ω error while out / without the part | NaN | TM lost |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut rng = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut clean = (0usize, 0usize, 0usize, 0u32, 0usize);
    for seed in 0..runs {
        let r = fault_run(&layout(1000 + seed), None);
        clean.0 += r.flagged_clean;
        clean.1 += r.clean_rows;
        clean.2 += r.nan;
        clean.3 += r.lost;
        clean.4 += r.wrong_excluded;
    }
    println!(
        "| none (false alarms) | {runs} | — | — | — | — | {:.3} % | {:.3} % of {} rows | — | — | — | {} | {} |",
        100.0 * clean.4 as f64 / clean.1 as f64,
        100.0 * clean.0 as f64 / clean.1 as f64,
        clean.1,
        clean.2,
        clean.3
    );
    for (name, spec) in kinds(sigma) {
        let (mut detected, mut lat, mut flagged, mut active) = (0, Vec::new(), 0, 0);
        let (mut silent_a, mut silent_b, mut after, mut nan, mut lost) = (0, 0, 0, 0, 0);
        let (mut isolated, mut iso_lat, mut wrong, mut rows) = (0, Vec::new(), 0, 0);
        let (mut err_out, mut err_ref) = (0.0, 0.0);
        for seed in 0..runs {
            let mut sc = layout(2000 + seed);
            let part = (next() * sc.parts.len() as f64) as usize % sc.parts.len();
            let start = 3.0 + 4.0 * next();
            let mut f = spec.clone();
            f.part = sc.parts[part].name.clone();
            f.start = start;
            f.end = Some(start + FAULT_S);
            sc.faults.push(f);
            let r = fault_run(&sc, Some((part, start, start + FAULT_S)));
            if let Some(l) = r.excluded_after {
                isolated += 1;
                iso_lat.push(l);
                err_out += r.excluded_errors.iter().map(|(_, e)| e).sum::<f64>();
                err_ref += errors_without_part(&sc, part, &r.excluded_errors)
                    .iter()
                    .sum::<f64>();
            }
            if std::env::var("SHOW").is_ok_and(|k| k == name) {
                let worst = r
                    .excluded_errors
                    .iter()
                    .copied()
                    .max_by(|a, b| a.1.total_cmp(&b.1));
                eprintln!(
                    "{name}: part {part} from {start:.2} s: out after {:?} s, {} rows out, worst {:?}, wrong {}",
                    r.excluded_after, r.excluded_active, worst, r.wrong_excluded
                );
            }
            wrong += r.wrong_excluded;
            rows += r.clean_rows + r.active_rows + r.after_rows;
            if let Some(l) = r.latency.filter(|l| *l <= 1.0) {
                detected += 1;
                lat.push(l);
            }
            flagged += r.flagged_active;
            active += r.active_rows;
            silent_a += r.silent_active;
            silent_b += r.silent_after;
            after += r.after_rows;
            nan += r.nan;
            lost += r.lost;
        }
        let latency = median_worst(&mut lat);
        let iso_latency = median_worst(&mut iso_lat);
        let ratio = if err_ref > 0.0 {
            format!("{:.2}", (err_out / err_ref).sqrt())
        } else {
            "—".to_string()
        };
        println!(
            "| {name} | {runs} | {detected} | {latency} | {isolated} | {iso_latency} | {:.2} % | {:.1} % | {:.1} % | {:.1} % | {ratio} | {nan} | {lost} |",
            100.0 * wrong as f64 / rows.max(1) as f64,
            100.0 * flagged as f64 / active.max(1) as f64,
            100.0 * silent_a as f64 / active.max(1) as f64,
            100.0 * silent_b as f64 / after.max(1) as f64,
        );
    }
}

/// "median / worst" of `v` (sorted in place), or "—".
fn median_worst(v: &mut [f64]) -> String {
    v.sort_by(f64::total_cmp);
    match (v.get(v.len() / 2), v.last()) {
        (Some(m), Some(w)) => format!("{m:.2} / {w:.2}"),
        _ => "—".to_string(),
    }
}
