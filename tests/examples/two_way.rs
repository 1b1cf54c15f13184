//! Probe (issue 15): the same estimator run forward and on the time-reversed record (the
//! readings of the reversed motion are the reversed readings: Ω → −Ω, Ω′ and σ0 unchanged), and
//! per-row combinations of the two, against the truth-started ML.
//!
//! `cargo run --release -p e2e-tests --example two_way -- RATE NOISE ARM SECONDS SEED [tumble|manoeuvre]`
//!
//! Prints, against the ML: the plain forward and backward passes, `ballisto estimate`'s two-way
//! output ("smoothed"), the plain passes picked by margin, the oracle of the two (per row the
//! one nearer the truth: the bound of any per-row pick), and two rules tried and left out
//! ("fused": the trackers' per-candidate costs summed; "by time": the pass further from its
//! last crossing, `WTH` the crossing weight counted as a crossing; "by centre" / "hybrid
//! centre": from the centre of the last crossing zone, `FB=1` zones with a fallback row only;
//! "split": each stretch of disagreement split at its centre, `DTH` the disagreement in
//! combined deviations; "bridge": a cubic Hermite bridge across each stretch from `NB` rows on
//! either side; "beam": a beam of (Ω, Ω′) filters over the plain passes' choices, decided over
//! the whole record — `estimator_core::path_choice` applied to the plain passes, `SJRATE` its
//! jerk density per sample rate, `DTH` as for "split" (default 0); "beam all": the same over
//! every signed candidate of every sample, `SJ` its jerk density (default: a grid, the cheapest
//! path's), `PASSSIGN=1` only the signs the passes hold, `HYBRID=1` every candidate only where
//! the passes offer `path_choice` a choice and the margin rule's pass elsewhere, `LEVELS=a,b,..`
//! a multiple-model beam (each hypothesis at one of these multiples of the jerk density,
//! `SWITCH` the cost of changing level), `LAGS=0,10,..` the beam's output with a fixed lag
//! of so many samples (row k as traced back from the best hypothesis at row k + lag; 0: the
//! causal filter, no look-ahead, what a forward-only estimator can do), `HINTSD` the
//! start hint's deviation (default 0.01 rad/s), `BWIN=SAMPLES`
//! its Ω RMS per window). `WIN=SAMPLES` prints the Ω
//! RMS of each per window, `RANGE=T0,T1` the rows where the plain passes differ, `DUMP=1` the
//! silently wrong rows of the two-way output, `DUMPC=T0,T1` every candidate's Ω error per row
//! ("oracle all" is the candidate nearest the truth per row), `TRUTHSTART=1` starts the backward pass at the
//! truth.

// A probe indexes parallel per-row tables by row number.
#![allow(clippy::needless_range_loop)]

use e2e_tests::nine::{self, Params, Score};
use estimator_core::path_choice::{self, Links, PathChoice, PathState};
use estimator_core::smoother::StepRecord;
use estimator_core::two_way;
use estimator_core::{Estimate, Estimator, Model, Options};
use hal_sim::arrangement_file::HOST_CAP;

fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt()
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let p = Params {
        rate_hz: a[1].parse().unwrap(),
        noise: a[2].parse().unwrap(),
        arm: a[3].parse().unwrap(),
        seconds: a[4].parse().unwrap(),
        seed: a[5].parse().unwrap(),
        manoeuvre: a.get(6).is_some_and(|m| m == "manoeuvre"),
    };
    // `FIRMWARE=1`: the readings the firmware got on `nine-channel` at RATE (the other
    // arguments ignored).
    let case = if std::env::var_os("FIRMWARE").is_some() {
        nine::firmware_readings(p.rate_hz)
    } else {
        nine::make(p)
    };
    let fwd = case.forward(true);
    let n = fwd.len();
    let t_end = case.truth[n - 1].t;
    let start = if std::env::var_os("TRUTHSTART").is_some() {
        case.truth[n - 1].omega
    } else {
        fwd[n - 1].omega
    };
    let opts = Options {
        raw: true,
        initial_omega: Some(start.map(|v| -v)),
        ..case.options
    };
    let mut e =
        Estimator::<f64, HOST_CAP>::new(&case.loaded.arrangement, Model::FreeFloat, opts).unwrap();
    let mut bwd: Vec<Estimate<f64>> = (0..n)
        .rev()
        .map(|k| *e.update(t_end - case.truth[k].t, &case.outputs[k]))
        .collect();
    bwd.reverse();
    for r in bwd.iter_mut() {
        r.omega = r.omega.map(|v| -v);
    }
    let ml = case.ml_errors();
    let ml_rms = nine::rms_of(&ml);
    let by_margin: Vec<Estimate<f64>> = (0..n)
        .map(|k| {
            if fwd[k].branch_margin >= bwd[k].branch_margin {
                fwd[k]
            } else {
                bwd[k]
            }
        })
        .collect();
    let oracle: Vec<Estimate<f64>> = (0..n)
        .map(|k| {
            let w = case.truth[k].omega;
            if dist(&fwd[k].omega, &w) <= dist(&bwd[k].omega, &w) {
                fwd[k]
            } else {
                bwd[k]
            }
        })
        .collect();
    let smoothed = case.smoothed(true);
    // Per-candidate two-filter fusion of the plain passes' hypotheses.
    type Summ = (Vec<[f64; 3]>, Vec<Estimate<f64>>, Vec<[f64; 2]>, f64);
    let run = |order: &mut dyn Iterator<Item = usize>, hint: [f64; 3], rev: bool| -> Vec<Summ> {
        let opts = Options {
            raw: true,
            initial_omega: Some(hint),
            ..case.options
        };
        let mut e =
            Estimator::<f64, HOST_CAP>::new(&case.loaded.arrangement, Model::FreeFloat, opts)
                .unwrap();
        let mut rec = Box::new(StepRecord::<f64>::default());
        let mut out = Vec::new();
        for k in order {
            let t = if rev {
                t_end - case.truth[k].t
            } else {
                case.truth[k].t
            };
            e.update_with(t, &case.outputs[k], Some(&mut rec));
            let nc = rec.n_candidates as usize;
            let mut om = Vec::new();
            let mut ce = Vec::new();
            let mut cost = vec![[f64::INFINITY; 2]; nc];
            for c in 0..nc {
                om.push(rec.candidates[c].omega);
                ce.push(rec.candidates[c]);
            }
            for st in rec.states.iter().take(rec.n_states as usize) {
                let c = st.candidate as usize;
                let si = usize::from(st.sign < 0);
                if c < nc {
                    cost[c][si] = cost[c][si].min(st.cost);
                }
            }
            let mut wmax: f64 = 0.0;
            for i in 0..nc {
                if rec.candidates[i].flags.has(estimator_core::Flags::FALLBACK) {
                    wmax = 1.0;
                }
                let ai = rec.candidates[i].a;
                let mut best = f64::INFINITY;
                for j in 0..nc {
                    if j == i {
                        continue;
                    }
                    let aj = rec.candidates[j].a;
                    let dm: f64 = (0..3).map(|q| (ai[q] - aj[q]).powi(2)).sum();
                    let dp: f64 = (0..3).map(|q| (ai[q] + aj[q]).powi(2)).sum();
                    best = best.min(dm.min(dp));
                }
                if best.is_finite() && best > 0.0 {
                    let wsum: f64 = rec.widening[i].iter().sum();
                    wmax = wmax.max(4.0 * wsum / best);
                }
            }
            out.push((om, ce, cost, wmax));
        }
        out
    };
    let f_s = run(&mut (0..n), case.options.initial_omega.unwrap(), false);
    let mut b_s = run(&mut (0..n).rev(), fwd[n - 1].omega.map(|v| -v), true);
    b_s.reverse();
    let cap: f64 = std::env::var("CAP")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(200.0);
    let fused: Vec<Estimate<f64>> = (0..n)
        .map(|k| {
            let (fo, fe, fc, _) = &f_s[k];
            let (bo, _, bc, _) = &b_s[k];
            let mut best = (f64::INFINITY, 0usize, 1.0);
            for c in 0..fo.len() {
                for (si, sg) in [(0usize, 1.0), (1, -1.0)] {
                    let f = fc[c][si].min(cap);
                    // the backward candidate with the same Ω (up to sign), in forward time
                    let mut b = cap;
                    for (cb, w) in bo.iter().enumerate() {
                        for (sbi, sb) in [(0usize, 1.0), (1, -1.0)] {
                            // forward-time Ω of backward state = -sb * w
                            let wf = w.map(|v| -sb * v);
                            let target = fo[c].map(|v| sg * v);
                            if dist(&wf, &target) < 1e-6 + 1e-3 * dist(&target, &[0.0; 3]) {
                                b = b.min(bc[cb][sbi].min(cap));
                            }
                        }
                    }
                    if f + b < best.0 {
                        best = (f + b, c, sg);
                    }
                }
            }
            let mut est = fe[best.1];
            est.omega = est.omega.map(|v| best.2 * v);
            est
        })
        .collect();
    if let Some(w) = std::env::var("WIN")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
    {
        for (c, chunk) in smoothed.chunks(w).enumerate() {
            let k0 = c * w;
            let (mut se, mut sm, mut sf, mut sb) = (0.0, 0.0, 0.0, 0.0);
            for (j, r) in chunk.iter().enumerate() {
                let tr = &case.truth[k0 + j];
                se += dist(&r.omega, &tr.omega).powi(2);
                sf += dist(&fwd[k0 + j].omega, &tr.omega).powi(2);
                sb += dist(&bwd[k0 + j].omega, &tr.omega).powi(2);
                sm += ml[k0 + j][2];
            }
            let m = chunk.len() as f64;
            println!(
                "t {:.2}: two-way {:.4} fwd {:.4} bwd {:.4} ML {:.4} |Ω′| {:.2}",
                case.truth[k0].t,
                (se / m).sqrt(),
                (sf / m).sqrt(),
                (sb / m).sqrt(),
                (sm / m).sqrt(),
                dist(&case.truth[k0].domega, &[0.0; 3])
            );
        }
    }
    if let Some((t0, t1)) = std::env::var("RANGE").ok().and_then(|v| {
        let (a, b) = v.split_once(',')?;
        Some((a.parse::<f64>().ok()?, b.parse::<f64>().ok()?))
    }) {
        for k in 0..n {
            let tr = &case.truth[k];
            if tr.t < t0 || tr.t > t1 || dist(&fwd[k].omega, &bwd[k].omega) < 1e-9 {
                continue;
            }
            println!(
                "t {:.3} fwd err {:.3} m {:5.1} | bwd err {:.3} m {:5.1} | ML {:.3} | sd {:.3} | sep {:.3}",
                tr.t,
                dist(&fwd[k].omega, &tr.omega),
                fwd[k].branch_margin,
                dist(&bwd[k].omega, &tr.omega),
                bwd[k].branch_margin,
                ml[k][2].sqrt(),
                fwd[k].sd_omega[0],
                dist(&fwd[k].omega, &bwd[k].omega)
            );
        }
    }
    if std::env::var_os("DUMP").is_some() {
        let mut last = -1.0;
        for (k, r) in smoothed.iter().enumerate() {
            let tr = &case.truth[k];
            let silent = r.flags.0 == 0
                && (0..3).any(|i| (r.omega[i] - tr.omega[i]).abs() > 5.0 * r.sd_omega[i]);
            if silent && tr.t - last > 0.02 {
                last = tr.t;
                println!(
                    "t {:.3} sd {:.3} out flags {} m {:.1} err {:.2} | fwd flags {} m {:.1} err {:.2} | bwd flags {} m {:.1} err {:.2}",
                    tr.t, r.sd_omega[0], r.flags.0, r.branch_margin, dist(&r.omega, &tr.omega),
                    fwd[k].flags.0, fwd[k].branch_margin, dist(&fwd[k].omega, &tr.omega),
                    bwd[k].flags.0, bwd[k].branch_margin, dist(&bwd[k].omega, &tr.omega)
                );
            }
        }
    }
    let wth: f64 = std::env::var("WTH")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0.5);
    let crossing: Vec<bool> = f_s.iter().map(|x| x.3 >= wth).collect();
    let mut since = vec![f64::INFINITY; n];
    let mut last = f64::NEG_INFINITY;
    for k in 0..n {
        if crossing[k] {
            last = case.truth[k].t;
        }
        since[k] = case.truth[k].t - last;
    }
    let mut until = vec![f64::INFINITY; n];
    let mut next = f64::INFINITY;
    for k in (0..n).rev() {
        if crossing[k] {
            next = case.truth[k].t;
        }
        until[k] = next - case.truth[k].t;
    }
    println!(
        "crossing rows: {:.2} %",
        100.0 * crossing.iter().filter(|c| **c).count() as f64 / n as f64
    );
    let by_time: Vec<Estimate<f64>> = (0..n)
        .map(|k| {
            if since[k] > until[k] {
                fwd[k]
            } else if until[k] > since[k] {
                bwd[k]
            } else if fwd[k].branch_margin >= bwd[k].branch_margin {
                fwd[k]
            } else {
                bwd[k]
            }
        })
        .collect();
    let hybrid: Vec<Estimate<f64>> = (0..n)
        .map(|k| {
            let (mf, mb) = (fwd[k].branch_margin, bwd[k].branch_margin);
            if (mf - mb).abs() >= 16.0 || since[k] == until[k] {
                if mf >= mb {
                    fwd[k]
                } else {
                    bwd[k]
                }
            } else if since[k] > until[k] {
                fwd[k]
            } else {
                bwd[k]
            }
        })
        .collect();
    if let Some((t0, t1)) = std::env::var("ZONE").ok().and_then(|v| {
        let (a, b) = v.split_once(',')?;
        Some((a.parse::<f64>().ok()?, b.parse::<f64>().ok()?))
    }) {
        for k in 0..n {
            let tr = &case.truth[k];
            if tr.t < t0 || tr.t > t1 || k % 5 != 0 {
                continue;
            }
            println!(
                "t {:.3} w {:.2} nc {} | fwd {:.3} m {:5.1} | bwd {:.3} m {:5.1} | ML {:.3}",
                tr.t,
                f_s[k].3,
                f_s[k].0.len(),
                dist(&fwd[k].omega, &tr.omega),
                fwd[k].branch_margin,
                dist(&bwd[k].omega, &tr.omega),
                bwd[k].branch_margin,
                ml[k][2].sqrt()
            );
        }
    }
    // Crossing centres: runs of w >= WTH merged across short gaps, w-weighted mean time.
    let mut runs: Vec<(usize, usize)> = Vec::new();
    let mut k = 0;
    while k < n {
        if crossing[k] {
            let s0 = k;
            while k < n && crossing[k] {
                k += 1;
            }
            runs.push((s0, k));
        } else {
            k += 1;
        }
    }
    let mut merged: Vec<(usize, usize)> = Vec::new();
    for r in runs {
        if let Some(last) = merged.last_mut() {
            let gap = r.0 - last.1;
            let shorter = (last.1 - last.0).min(r.1 - r.0);
            if gap <= 3usize.max(shorter / 2) {
                last.1 = r.1;
                continue;
            }
        }
        merged.push(r);
    }
    let need_fallback = std::env::var_os("FB").is_some();
    let centres: Vec<f64> = merged
        .iter()
        .filter(|&&(a, b)| {
            !need_fallback
                || (a..b).any(|k| {
                    f_s[k]
                        .1
                        .iter()
                        .any(|c| c.flags.has(estimator_core::Flags::FALLBACK))
                })
        })
        .map(|&(a, b)| {
            let (mut sw, mut st) = (0.0, 0.0);
            for k in a..b {
                let w = f_s[k].3.min(1.0);
                sw += w;
                st += w * case.truth[k].t;
            }
            st / sw
        })
        .collect();
    let mut since_c = vec![f64::INFINITY; n];
    let mut until_c = vec![f64::INFINITY; n];
    for k in 0..n {
        let t = case.truth[k].t;
        for &c in &centres {
            if c <= t {
                since_c[k] = since_c[k].min(t - c);
            } else {
                until_c[k] = until_c[k].min(c - t);
            }
        }
    }
    println!("{} crossing centres", centres.len());
    let by_centre: Vec<Estimate<f64>> = (0..n)
        .map(|k| {
            if since_c[k] > until_c[k] {
                fwd[k]
            } else {
                bwd[k]
            }
        })
        .collect();
    let hybrid_c: Vec<Estimate<f64>> = (0..n)
        .map(|k| {
            let (mf, mb) = (fwd[k].branch_margin, bwd[k].branch_margin);
            if (mf - mb).abs() >= 16.0 {
                if mf >= mb {
                    fwd[k]
                } else {
                    bwd[k]
                }
            } else if since_c[k] > until_c[k] {
                fwd[k]
            } else {
                bwd[k]
            }
        })
        .collect();
    // Disagreement stretches: maximal runs of rows that disagree or lie in a crossing zone,
    // holding a disagreement; split at the w-weighted mean time: forward before, backward after.
    let dth: f64 = std::env::var("DTH")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(5.0);
    let sdd = |a: &Estimate<f64>, b: &Estimate<f64>| {
        (0..3).any(|i| {
            (a.omega[i] - b.omega[i]).abs()
                > dth * (a.sd_omega[i].powi(2) + b.sd_omega[i].powi(2)).sqrt()
        })
    };
    let disagree: Vec<bool> = (0..n).map(|k| sdd(&fwd[k], &bwd[k])).collect();
    let mut split_pick: Vec<Estimate<f64>> = (0..n)
        .map(|k| {
            if fwd[k].branch_margin >= bwd[k].branch_margin {
                fwd[k]
            } else {
                bwd[k]
            }
        })
        .collect();
    let mut k = 0;
    let mut stretches = 0;
    while k < n {
        if disagree[k] || crossing[k] {
            let a = k;
            while k < n && (disagree[k] || crossing[k]) {
                k += 1;
            }
            if (a..k).any(|j| disagree[j]) {
                stretches += 1;
                let (mut sw, mut st) = (0.0, 0.0);
                for j in a..k {
                    let w = f_s[j].3.min(1.0) + 1e-9;
                    sw += w;
                    st += w * case.truth[j].t;
                }
                let split = st / sw;
                for j in a..k {
                    split_pick[j] = if case.truth[j].t < split {
                        fwd[j]
                    } else {
                        bwd[j]
                    };
                }
            }
        } else {
            k += 1;
        }
    }
    println!("{stretches} disagreement stretches");
    // Hermite bridge across each run of disagreement, from the agreeing rows on both sides.
    let nb: usize = std::env::var("NB")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(5);
    let mut bridge_pick = by_margin.clone();
    let mut k = 0;
    let mut bridged = 0;
    while k < n {
        if !(disagree[k] || crossing[k]) {
            k += 1;
            continue;
        }
        let a = k;
        while k < n && (disagree[k] || crossing[k]) {
            k += 1;
        }
        let b = k; // run [a, b)
        if a < nb || b + nb > n || !(a..b).any(|j| disagree[j]) {
            continue;
        }
        let side = |r: std::ops::Range<usize>| {
            let m = r.len() as f64;
            let mut w = [0.0; 3];
            let mut d = [0.0; 3];
            let mut t = 0.0;
            for j in r {
                for i in 0..3 {
                    w[i] += fwd[j].omega[i] / m;
                    d[i] += fwd[j].domega[i] / m;
                }
                t += case.truth[j].t / m;
            }
            (t, w, d)
        };
        let (t0, w0, d0) = side(a - nb..a);
        let (t1, w1, d1) = side(b..b + nb);
        let h = t1 - t0;
        bridged += 1;
        for j in a..b {
            let s = (case.truth[j].t - t0) / h;
            let (h00, h10, h01, h11) = (
                2.0 * s * s * s - 3.0 * s * s + 1.0,
                s * s * s - 2.0 * s * s + s,
                -2.0 * s * s * s + 3.0 * s * s,
                s * s * s - s * s,
            );
            let pred: [f64; 3] = core::array::from_fn(|i| {
                h00 * w0[i] + h10 * h * d0[i] + h01 * w1[i] + h11 * h * d1[i]
            });
            bridge_pick[j] = if dist(&fwd[j].omega, &pred) <= dist(&bwd[j].omega, &pred) {
                fwd[j]
            } else {
                bwd[j]
            };
        }
    }
    println!("{bridged} runs bridged");
    let times: Vec<f64> = case.truth.iter().map(|r| r.t).collect();
    let picks = beam(&fwd, &bwd, &times);
    let beam_pick: Vec<Estimate<f64>> = (0..n)
        .map(|k| if picks[k] { bwd[k] } else { fwd[k] })
        .collect();
    let all: Vec<Vec<(Estimate<f64>, [f64; 3])>> = {
        let opts = Options {
            raw: true,
            ..case.options
        };
        let mut e =
            Estimator::<f64, HOST_CAP>::new(&case.loaded.arrangement, Model::FreeFloat, opts)
                .unwrap();
        let mut rec = Box::new(StepRecord::<f64>::default());
        (0..n)
            .map(|k| {
                e.update_with(case.truth[k].t, &case.outputs[k], Some(&mut rec));
                (0..rec.n_candidates as usize)
                    .map(|c| (rec.candidates[c], rec.widening[c]))
                    .collect()
            })
            .collect()
    };
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok());
    let rate = 1.0 / (times[1] - times[0]);
    let rd = {
        let v: Vec<f64> = fwd
            .iter()
            .map(|e| e.sd_domega.iter().map(|s| s * s).sum::<f64>() / 3.0)
            .collect();
        let mut v = v;
        v.sort_by(|a, b| a.partial_cmp(b).unwrap());
        v[v.len() / 2]
    };
    let grid: Vec<f64> = if let Some(v) = env("SJ") {
        vec![v]
    } else if let Some(c) = env("SJRATE") {
        vec![c * rate]
    } else if let Some(m) = env("SJN") {
        vec![rd * rate / (m * m)]
    } else {
        vec![10.0, 30.0, 100.0, 300.0, 1000.0]
    };
    // (per row the candidate and sign, the path's cost, the jerk density)
    type Run = (Vec<(usize, f64)>, f64, f64);
    // The estimate a beam pick stands for: the combined passes (`HYBRID`'s settled rows), the
    // candidate with the sign taken, or the forward pass where the row has no such candidate.
    let taken = |k: usize, (c, sg): (usize, f64)| -> Estimate<f64> {
        if c == usize::MAX {
            return two_way::combine(&fwd[k], &bwd[k]);
        }
        match all[k].get(c) {
            Some((e, _)) => {
                let mut e = *e;
                e.omega = e.omega.map(|v| sg * v);
                e
            }
            None => fwd[k],
        }
    };
    let mut best_run: Option<Run> = None;
    for &sj in &grid {
        let (p, c, back) = beam_all(
            &all,
            &times,
            case.options.initial_omega.unwrap(),
            sj,
            (&fwd, &bwd),
        );
        println!("SJ {sj}: path cost {c:.1}");
        if let Ok(lags) = std::env::var("LAGS") {
            for lag in lags.split(',').filter_map(|x| x.parse::<usize>().ok()) {
                let picks = lagged(&back, lag);
                let rows: Vec<Estimate<f64>> = (0..n).map(|k| taken(k, picks[k])).collect();
                let r = Score::of(&rows, &case.truth).rms();
                println!(
                    "  lag {lag:>5} ({:.3} s): σ0 {:.2} Ω′ {:.2} Ω {:.2} ×ML",
                    lag as f64 / rate,
                    r[0] / ml_rms[0],
                    r[1] / ml_rms[1],
                    r[2] / ml_rms[2]
                );
            }
        }
        if best_run.as_ref().is_none_or(|b| c < b.1) {
            best_run = Some((p, c, sj));
        }
    }
    let (picks_all, _, sj_best) = best_run.unwrap();
    println!("SJ chosen {sj_best}");
    let beam_all_pick: Vec<Estimate<f64>> = (0..n).map(|k| taken(k, picks_all[k])).collect();
    if let Some(w) = std::env::var("BWIN")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
    {
        for k0 in (0..n).step_by(w) {
            let k1 = (k0 + w).min(n);
            let m = (k1 - k0) as f64;
            let e = |rows: &[Estimate<f64>]| {
                ((k0..k1)
                    .map(|k| dist(&rows[k].omega, &case.truth[k].omega).powi(2))
                    .sum::<f64>()
                    / m)
                    .sqrt()
            };
            let mlw = ((k0..k1).map(|k| ml[k][2]).sum::<f64>() / m).sqrt();
            println!(
                "t {:.2}: beam all {:.4} smoothed {:.4} fwd {:.4} bwd {:.4} ML {:.4} cands {}",
                case.truth[k0].t,
                e(&beam_all_pick),
                e(&smoothed),
                e(&fwd),
                e(&bwd),
                mlw,
                all[k0].len()
            );
        }
    }
    // The oracle over every signed candidate (per row the one nearest the truth), and where
    // the excess over the ML lies: fallback rows (no real root) against rows with roots.
    let oracle_all: Vec<Estimate<f64>> = (0..n)
        .map(|k| {
            let mut best = fwd[k];
            let mut bd = f64::INFINITY;
            for (e, _) in &all[k] {
                for sg in [1.0, -1.0] {
                    let mut z = *e;
                    z.omega = e.omega.map(|v| sg * v);
                    let d = dist(&z.omega, &case.truth[k].omega);
                    if d < bd {
                        bd = d;
                        best = z;
                    }
                }
            }
            best
        })
        .collect();
    {
        let (mut fb, mut nf, mut mfb, mut mnf, mut nfb) = (0.0, 0.0, 0.0, 0.0, 0usize);
        for k in 0..n {
            let e = dist(&oracle_all[k].sigma0, &case.truth[k].sigma0).powi(2);
            let is_fb = all[k]
                .iter()
                .any(|(c, _)| c.flags.has(estimator_core::Flags::FALLBACK));
            if is_fb {
                fb += e;
                mfb += ml[k][0];
                nfb += 1;
            } else {
                nf += e;
                mnf += ml[k][0];
            }
        }
        println!(
            "oracle all, σ0 sum sq: fallback rows ({nfb}) {fb:.4e} vs ML {mfb:.4e}; root rows {nf:.4e} vs ML {mnf:.4e}"
        );
    }
    if let Some((t0, t1)) = std::env::var("DUMPC").ok().and_then(|v| {
        let (a, b) = v.split_once(',')?;
        Some((a.parse::<f64>().ok()?, b.parse::<f64>().ok()?))
    }) {
        for k in 0..n {
            let t = case.truth[k].t;
            if t < t0 || t > t1 {
                continue;
            }
            let mut line = format!(
                "{t:.3} |W| {:.3} chosen {:.4} ML {:.4}:",
                case.truth[k]
                    .omega
                    .iter()
                    .map(|v| v * v)
                    .sum::<f64>()
                    .sqrt(),
                dist(&beam_all_pick[k].omega, &case.truth[k].omega),
                ml[k][2].sqrt()
            );
            for (e, wd) in &all[k] {
                let ep = dist(&e.omega, &case.truth[k].omega);
                let en = dist(&e.omega.map(|v| -v), &case.truth[k].omega);
                line += &format!(
                    " [{:.4}{} sd {:.4} w {:.4}]",
                    ep.min(en),
                    if e.flags.has(estimator_core::Flags::FALLBACK) {
                        " fb"
                    } else {
                        ""
                    },
                    e.sd_omega[0],
                    wd.iter().sum::<f64>().sqrt()
                );
            }
            println!("{line}");
        }
    }
    for (name, rows) in [
        ("beam", &beam_pick),
        ("beam all", &beam_all_pick),
        ("oracle all", &oracle_all),
        ("bridge", &bridge_pick),
        ("split", &split_pick),
        ("by centre", &by_centre),
        ("hybrid centre", &hybrid_c),
        ("forward", &fwd),
        ("backward", &bwd),
        ("smoothed", &smoothed),
        ("by margin", &by_margin),
        ("oracle of the two", &oracle),
        ("fused", &fused),
        ("by time", &by_time),
        ("hybrid", &hybrid),
    ] {
        let s = Score::of(rows, &case.truth);
        let r = s.rms();
        println!(
            "{name:>18}: σ0 {:.2} Ω′ {:.2} Ω {:.2} ×ML (Ω {:.4}), off {:.2} %, flagged {:.1} %, silent {}",
            r[0] / ml_rms[0],
            r[1] / ml_rms[1],
            r[2] / ml_rms[2],
            r[2],
            s.pct(s.off),
            s.pct(s.flagged),
            s.silent
        );
    }
}

/// Probe: `estimator_core::path_choice` over the two plain passes, offering the backward pass
/// wherever the two differ by more than `DTH` combined deviations (default 0: wherever they
/// differ), with a jerk density of `SJRATE` × rate. Returns per row whether the backward pass
/// is taken.
fn beam(fwd: &[Estimate<f64>], bwd: &[Estimate<f64>], t: &[f64]) -> Vec<bool> {
    let rate = 1.0 / (t[1] - t[0]);
    let sj: f64 = std::env::var("SJRATE")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .unwrap_or(path_choice::JERK_PER_SAMPLE)
        * rate;
    let dth: f64 = std::env::var("DTH")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0.0);
    let n = fwd.len();
    let mut path = PathChoice::with_jerk(sj, None);
    let mut links = vec![Links::default(); n];
    for k in 0..n {
        let dt = if k == 0 { 0.0 } else { t[k] - t[k - 1] };
        let differ = (0..3).any(|i| {
            (fwd[k].omega[i] - bwd[k].omega[i]).abs()
                > dth * (fwd[k].sd_omega[i].powi(2) + bwd[k].sd_omega[i].powi(2)).sqrt()
        });
        if differ {
            path.step(dt, &[fwd[k], bwd[k]], &mut links[k]);
        } else {
            path.step(dt, &[fwd[k]], &mut links[k]);
        }
    }
    let mut picks = vec![0u8; n];
    PathChoice::decide(&links, &mut picks);
    picks.iter().map(|p| *p == 1).collect()
}

/// Probe: the beam over every signed candidate of every row (not only the passes' choices),
/// each hypothesis a `path_choice::PathState` with jerk density `sj`. `cands[k]`: the
/// candidates of row k with their crossing widening (added to Ω's variance unless `NOWIDEN`);
/// `PER` hypotheses per signed candidate, `BEAM` in all; `PASSSIGN=1` only the signs the passes
/// hold. Returns the chosen (candidate index, sign) per row and the path's total cost.
fn beam_all(
    cands: &[Vec<(Estimate<f64>, [f64; 3])>],
    t: &[f64],
    hint: [f64; 3],
    sj: f64,
    passes: (&[Estimate<f64>], &[Estimate<f64>]),
) -> (Vec<(usize, f64)>, f64, Back) {
    let env = |k: &str, d: usize| {
        std::env::var(k)
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(d)
    };
    let (width, per_out) = (env("BEAM", 16), env("PER", 2));
    let widen = std::env::var_os("NOWIDEN").is_none();
    let signs_from_passes = std::env::var_os("PASSSIGN").is_some();
    let hybrid = std::env::var_os("HYBRID").is_some();
    // Jerk levels (multiples of `sj`) and the cost of a switch between them (probe: a
    // multiple-model beam).
    let levels: Vec<f64> = std::env::var("LEVELS")
        .ok()
        .map(|v| v.split(',').filter_map(|x| x.parse().ok()).collect())
        .unwrap_or_else(|| vec![1.0]);
    let switch: f64 = std::env::var("SWITCH")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10.0);
    // (state, predecessor, candidate and sign, level)
    type H = (PathState, usize, (usize, f64), usize);
    let n = cands.len();
    let mut total = f64::NAN;
    let mut back: Back = Vec::with_capacity(n);
    let mut hs: Vec<H> = Vec::new();
    let mut level_rows = vec![0usize; levels.len()];
    for (k, cs) in cands.iter().enumerate() {
        let dt = if k == 0 { 0.0 } else { t[k] - t[k - 1] };
        // The signed candidates of this row as estimates (sd widened).
        let mut signed = Vec::new();
        let (pf, pb) = (&passes.0[k], &passes.1[k]);
        if hybrid && !two_way::offers_choice(pf, pb) {
            signed.push(((usize::MAX, 1.0), two_way::combine(pf, pb)));
        }
        for (ci, (e, wd)) in cs.iter().enumerate() {
            if hybrid && !signed.is_empty() {
                break;
            }
            for sg in [1.0, -1.0] {
                let mut z = *e;
                z.omega = e.omega.map(|v| sg * v);
                if widen {
                    z.sd_omega = core::array::from_fn(|i| (e.sd_omega[i].powi(2) + wd[i]).sqrt());
                }
                let along =
                    |p: &Estimate<f64>| (0..3).map(|i| z.omega[i] * p.omega[i]).sum::<f64>();
                if signs_from_passes && along(&passes.0[k]) < 0.0 && along(&passes.1[k]) < 0.0 {
                    continue;
                }
                signed.push(((ci, sg), z));
            }
        }
        let mut next: Vec<H> = Vec::new();
        if hs.is_empty() {
            for &(pick, z) in &signed {
                for l in 0..levels.len() {
                    let mut s = PathState::at(&z);
                    // The hint (the record's initial rate) as one more measurement of Ω at the
                    // start, to `HINTSD` rad/s.
                    let hinted = Estimate {
                        omega: hint,
                        sd_omega: [std::env::var("HINTSD")
                            .ok()
                            .and_then(|v| v.parse().ok())
                            .unwrap_or(1e-2); 3],
                        sd_domega: [1e3; 3],
                        ..z
                    };
                    s = s.step(0.0, 0.0, &hinted);
                    next.push((s, 0, pick, l));
                }
            }
        }
        for (hi, h) in hs.iter().enumerate() {
            for &(pick, z) in &signed {
                for (l, lv) in levels.iter().enumerate() {
                    let mut s = h.0.step(dt, sj * lv, &z);
                    if l != h.3 {
                        s = PathState::with_cost(&s, s.cost() + switch);
                    }
                    next.push((s, hi, pick, l));
                }
            }
        }
        next.sort_by(|a, b| a.0.cost().total_cmp(&b.0.cost()));
        let mut kept: Vec<H> = Vec::new();
        for h in next {
            if kept.iter().filter(|k| k.2 == h.2 && k.3 == h.3).count() < per_out {
                kept.push(h);
            }
            if kept.len() >= width {
                break;
            }
        }
        if kept.is_empty() {
            back.push(hs.iter().enumerate().map(|(i, h)| (i, h.2)).collect());
            continue;
        }
        total = kept[0].0.cost();
        level_rows[kept[0].3] += 1;
        back.push(kept.iter().map(|h| (h.1, h.2)).collect());
        hs = kept;
    }
    if levels.len() > 1 {
        println!("rows whose best hypothesis is at each level: {level_rows:?}");
    }
    let mut out = vec![(0, 1.0); n];
    let mut j = 0;
    for k in (0..n).rev() {
        let (from, pick) = back[k][j];
        out[k] = pick;
        j = from;
    }
    (out, total, back)
}

/// The beam's links per row: per kept hypothesis (best first), its predecessor and pick.
type Back = Vec<Vec<(usize, (usize, f64))>>;

/// The picks a fixed-lag output of the beam makes: row k as traced back from the best
/// hypothesis at row k + `lag` (0: the causal filter, the best hypothesis at each row).
fn lagged(back: &Back, lag: usize) -> Vec<(usize, f64)> {
    let n = back.len();
    (0..n)
        .map(|k| {
            let top = (k + lag).min(n - 1);
            let mut j = 0;
            let mut pick = (0, 1.0);
            for r in (k..=top).rev() {
                let (from, p) = back[r][j.min(back[r].len() - 1)];
                pick = p;
                j = from;
            }
            pick
        })
        .collect()
}
