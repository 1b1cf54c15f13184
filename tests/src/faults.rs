//! Faults through the firmware on a layout with redundancy (issue 17): the layout, one run
//! with at most one fault in one part, and what the run showed against the truth.

use ballisto_fw::config::Alignment;
use estimator_core::Flags;
use hal_sim::firmware_host::{firmware_config, run_firmware};
use hal_sim::scenario::Scenario;

/// Flags that warn (everything but the informational "channels excluded", 8).
pub const WARNING: u16 = !Flags::CHANNELS_EXCLUDED;

/// `tetra-orbit` (four ADXL355 on a tetrahedron, ideal parts: noise and clock offsets only)
/// with two more ADXL355s on its SPI bus: N = 18, model G, 6 degrees of freedom in the
/// whitened residual; `duration` s at 100 Hz, no faults yet.
pub fn redundant_layout(seed: u64, duration: f64) -> Scenario {
    let mut sc = Scenario::load("tetra-orbit").unwrap();
    sc.duration = duration;
    sc.seed = seed;
    sc.faults.clear();
    let template = sc.parts[0].clone();
    for (i, (position, cs)) in [([0.12, 0.0, -0.05], 4), ([-0.05, 0.11, 0.08], 5)]
        .into_iter()
        .enumerate()
    {
        let mut p = template.clone();
        p.name = format!("u{}", 4 + i);
        p.position = position;
        p.cs = Some(cs);
        p.orientation = None;
        sc.parts.push(p);
    }
    sc
}

/// What one run showed, from 1 s on (the start-up excluded).
#[derive(Debug, Default)]
pub struct FaultRun {
    /// Time from the fault's start to the first row that shows it (flag 64, or the part
    /// missing or excluded), if any while it is active.
    pub latency: Option<f64>,
    /// Rows before the fault (all rows of a run without one).
    pub clean_rows: usize,
    /// Of [`Self::clean_rows`], those flagged 64 (false alarms).
    pub flagged_clean: usize,
    /// Rows while the fault is active.
    pub active_rows: usize,
    /// Of [`Self::active_rows`], those flagged 64.
    pub flagged_active: usize,
    /// Of [`Self::active_rows`], those silently wrong: Ω error above 5 reported deviations,
    /// no warning flag.
    pub silent_active: usize,
    /// Rows after the fault.
    pub after_rows: usize,
    /// Of [`Self::after_rows`], those silently wrong.
    pub silent_after: usize,
    /// Estimates with a value that is not finite.
    pub nan: usize,
    /// Telemetry packets the firmware could not send.
    pub lost: u32,
    /// Time from the fault's start to the first row with the faulty part out of the solve
    /// (isolated from the measurements, or missing on the bus), if any while it is active.
    pub excluded_after: Option<f64>,
    /// Rows (from 1 s on) with a healthy part out of the solve (and answering on its bus).
    pub wrong_excluded: usize,
    /// Of [`Self::active_rows`], those with the faulty part out of the solve.
    pub excluded_active: usize,
    /// Rows after the fault with the faulty part still out of the solve.
    pub excluded_after_end: usize,
    /// The rows while the fault is active with the faulty part out of the solve: their times
    /// (s) and squared Ω errors (rad²/s²).
    pub excluded_errors: Vec<(f64, f64)>,
}

/// Runs `sc` through the firmware; `fault`: the faulty part's index, and the fault's start
/// and end (s).
pub fn fault_run(sc: &Scenario, fault: Option<(usize, f64, f64)>) -> FaultRun {
    let loaded = sc.arrangement().load("arrangement.toml").unwrap();
    let config = firmware_config(sc, &loaded, Alignment::Interpolate).unwrap();
    let mut r = FaultRun::default();
    let part_bit = fault.map_or(0, |(p, _, _)| 1u8 << p);
    let (start, end) = fault.map_or((f64::INFINITY, f64::INFINITY), |f| (f.1, f.2));
    let report = run_firmware(sc, &config, sc.samples() as u32, &mut |_, m, tr| {
        let t = m.t as f64 * 1e-9;
        let e = &m.estimate;
        let vals = e.omega.iter().chain(&e.sigma0).chain(&e.domega);
        if vals.clone().any(|v| !v.is_finite()) {
            r.nan += 1;
        }
        let err: f64 = (0..3)
            .map(|k| (f64::from(e.omega[k]) - tr.omega[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        let sd: f64 = e
            .sd_omega
            .iter()
            .map(|s| f64::from(*s).powi(2))
            .sum::<f64>()
            .sqrt();
        let silent = err > 5.0 * sd && e.flags.0 & WARNING == 0;
        let residual = e.flags.has(Flags::RESIDUAL_HIGH);
        let seen = residual || (m.missing.0 | m.excluded.0) & part_bit != 0;
        let out = m.excluded.0 & part_bit != 0;
        if t < 1.0 {
            return;
        }
        r.wrong_excluded += usize::from(m.excluded.0 & !part_bit & !m.missing.0 != 0);
        if t < start {
            r.clean_rows += 1;
            r.flagged_clean += usize::from(residual);
        } else if t < end {
            r.active_rows += 1;
            r.flagged_active += usize::from(residual);
            r.silent_active += usize::from(silent);
            if seen && r.latency.is_none() {
                r.latency = Some(t - start);
            }
            if out {
                r.excluded_active += 1;
                r.excluded_errors.push((t, err * err));
                if r.excluded_after.is_none() {
                    r.excluded_after = Some(t - start);
                }
            }
        } else {
            r.after_rows += 1;
            r.silent_after += usize::from(silent);
            r.excluded_after_end += usize::from(out);
        }
    })
    .expect("the firmware ran");
    r.lost = report.housekeeping.tm_lost;
    r
}

/// The squared Ω errors of `sc` run without faults and without part `part` at all (the
/// reference for the estimate after an exclusion: the same motion and seed, one part fewer),
/// at the rows whose times are `at` (s; matched to the nearest set).
pub fn errors_without_part(sc: &Scenario, part: usize, at: &[(f64, f64)]) -> Vec<f64> {
    let mut reference = sc.clone();
    reference.faults.clear();
    reference.parts.remove(part);
    let loaded = reference.arrangement().load("arrangement.toml").unwrap();
    let config = firmware_config(&reference, &loaded, Alignment::Interpolate).unwrap();
    let mut by_time = Vec::new();
    run_firmware(
        &reference,
        &config,
        reference.samples() as u32,
        &mut |_, m, tr| {
            let e = &m.estimate;
            let err2: f64 = (0..3)
                .map(|k| (f64::from(e.omega[k]) - tr.omega[k]).powi(2))
                .sum();
            by_time.push((m.t as f64 * 1e-9, err2));
        },
    )
    .expect("the firmware ran");
    at.iter()
        .filter_map(|(t, _)| {
            let k = by_time.partition_point(|(u, _)| u < t);
            [k.checked_sub(1), Some(k)]
                .into_iter()
                .flatten()
                .filter_map(|i| by_time.get(i))
                .min_by(|a, b| (a.0 - t).abs().total_cmp(&(b.0 - t).abs()))
                .map(|(_, e)| *e)
        })
        .collect()
}
