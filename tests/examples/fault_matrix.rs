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
//! active: runs, median and worst latency); for a bias or a drift, the runs isolated within 2 s
//! of those whose fault the layout itself can attribute to its part by then
//! (`e2e_tests::faults::attributable`: no other part can stand in for it, by the noncentrality
//! a test of the whole 2 s would see); rows with a healthy part out; rows flagged 64 while
//! the fault is active; the share of its rows with the faulty part out, and of those from its
//! first exclusion on (an intermittent kind's window spans its bursts and the gaps between;
//! also from its second exclusion on, when its pattern can be known); rows silently wrong (Ω error above 5 reported deviations, no warning
//! flag) while it is active and after it; the Ω error while the faulty part is out against the
//! same run without the fault and without that part (RMS ratio over the runs); the share of
//! rows whose σ0, Ω′ and Ω errors exceed their protection levels (`estimator_core::integrity`)
//! and the mean levels; NaN in any estimate, telemetry packets lost. The fault-free runs give the false-alarm rates.
//!
//! `cargo run -p e2e-tests --example fault_matrix -- [RUNS] [LAYOUT]`: RUNS per fault kind
//! (default 20; about 2 s), LAYOUT `g` (default: the N = 18 layout in model G), `f` (the same
//! estimated in model F) or `mixed` (the 24-channel mixed layout,
//! `e2e_tests::faults::mixed_layout`). `scripts/validate.sh` runs all three.

use e2e_tests::faults::{
    fault_matrix, layout, layout_free_float, mixed, Protection, DURATION, FAULT_S, INTERMITTENT,
};

fn main() {
    let runs: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(20);
    let which = std::env::args().nth(2).unwrap_or_else(|| "g".to_string());
    let (mixed_layout, free_float) = match which.as_str() {
        "g" => (false, false),
        "f" => (false, true),
        "mixed" => (true, false),
        other => {
            eprintln!("fault_matrix: layout \"{other}\" is not one of g, f, mixed");
            std::process::exit(2);
        }
    };
    let layout = match (mixed_layout, free_float) {
        (true, _) => mixed,
        (false, true) => layout_free_float,
        (false, false) => layout,
    };
    // One sample's noise per part type: faults are sized by the faulty part's own.
    let sc = layout(0);
    let mut sigmas: Vec<String> = sc
        .parts
        .iter()
        .map(|p| format!("{} ≈ {:.1e} m/s²", p.part.label(), sc.channel_noise(p)))
        .collect();
    sigmas.sort();
    sigmas.dedup();
    let sigmas = sigmas.join(", ");
    let name = if mixed_layout {
        "ground-spin-mixed doubled: 4 ADXL355 on SPI, 4 LIS3DH on two I²C buses (N = 24, model G, 12 dof)"
    } else if free_float {
        "tetra-orbit + 2 ADXL355 (N = 18, model F; the monitor's parity space model G's, 6 dof)"
    } else {
        "tetra-orbit + 2 ADXL355 (N = 18, model G, 6 dof)"
    };
    println!(
        "layout: {name}, ideal parts (noise and clock offsets only), {DURATION} s at 100 Hz, faults of {FAULT_S} s from 3–7 s, one part chosen at random, the fault sized by its own σ (one sample: {sigmas})"
    );
    println!("| fault | runs | detected ≤ 1 s | latency median / worst (s) | isolated (runs) | isolation latency median / worst (s) | isolated ≤ 2 s, of the runs the layout can attribute by then at even odds (with 99 % probability) | rows with a healthy part out | rows flagged 64 while active | part out while active / since its first exclusion (intermittent: / since its second) | silent while active | silent after | Ω error while out / without the part | error above PL σ0 / Ω′ / Ω | mean PL σ0 / Ω′ / Ω | NaN | TM lost |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let (clean, rows) = fault_matrix(runs, layout);
    println!(
        "| none (false alarms) | {runs} | — | — | — | — | — | {:.3} % | {:.3} % of {} rows | — | {:.1} % (fault-free) | — | — | {} | {} | {} | {} |",
        pct(clean.wrong_excluded, clean.rows),
        pct(clean.flagged_clean, clean.clean_rows),
        clean.clean_rows,
        pct(clean.silent_clean, clean.clean_rows),
        above(&clean.protection),
        levels(&clean.protection),
        clean.nan,
        clean.lost
    );
    for (name, mut t) in rows {
        let mut ratio = t
            .error_ratio()
            .map_or("—".to_string(), |r| format!("{r:.2}"));
        if t.wrong_references > 0 {
            let n = t.wrong_references;
            ratio += &format!(" ({n} wrong reference{})", if n > 1 { "s" } else { "" });
        }
        let attributable = t.attributable.map_or("—".to_string(), |[even, sure]| {
            format!("{} of {} ({} of {})", even.1, even.0, sure.1, sure.0)
        });
        let mut out = format!(
            "{:.1} % / {:.1} %",
            pct(t.out_active, t.active),
            pct(t.out_since_isolation, t.since_isolation)
        );
        if name.starts_with(INTERMITTENT) {
            out += &format!(" / {:.1} %", pct(t.out_since_second, t.since_second));
        }
        println!(
            "| {name} | {runs} | {} | {} | {} | {} | {attributable} | {:.2} % | {:.1} % | {out} | {:.1} % | {:.1} % | {ratio} | {} | {} | {} | {} |",
            t.detected.len(),
            median_worst(&mut t.detected),
            t.isolated.len(),
            median_worst(&mut t.isolated),
            pct(t.wrong_excluded, t.rows),
            pct(t.flagged_active, t.active),
            pct(t.silent_active, t.active),
            pct(t.silent_after, t.after),
            above(&t.protection),
            levels(&t.protection),
            t.nan,
            t.lost
        );
    }
}

/// The shares of rows above each protection level, and the rows without one.
fn above(p: &Protection) -> String {
    let [a, b, c] = p.above_pct();
    let mut s = format!("{a:.2} / {b:.2} / {c:.2} %");
    if p.unbounded > 0 {
        s += &format!(" ({} rows without)", p.unbounded);
    }
    s
}

/// The mean protection levels (m/s², rad/s², rad/s).
fn levels(p: &Protection) -> String {
    let [a, b, c] = p.mean();
    format!("{a:.3} / {b:.3} / {c:.3}")
}

fn pct(part: usize, of: usize) -> f64 {
    100.0 * part as f64 / of.max(1) as f64
}

/// "median / worst" of `v` (sorted in place), or "—".
fn median_worst(v: &mut [f64]) -> String {
    v.sort_by(f64::total_cmp);
    match (v.get(v.len() / 2), v.last()) {
        (Some(m), Some(w)) => format!("{m:.2} / {w:.2}"),
        _ => "—".to_string(),
    }
}
