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
//! last crossing, `WTH` the crossing weight counted as a crossing). `WIN=SAMPLES` prints the Ω
//! RMS of each per window, `RANGE=T0,T1` the rows where the plain passes differ, `DUMP=1` the
//! silently wrong rows of the two-way output, `TRUTHSTART=1` starts the backward pass at the
//! truth.

use e2e_tests::nine::{self, Params, Score};
use estimator_core::smoother::StepRecord;
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
    let case = nine::make(p);
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
    let ml_rms: [f64; 3] =
        core::array::from_fn(|i| (ml.iter().map(|e| e[i]).sum::<f64>() / n as f64).sqrt());
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
    for (name, rows) in [
        ("forward", &fwd),
        ("backward", &bwd),
        ("smoothed", &smoothed),
        ("by margin", &by_margin),
        ("oracle of the two", &oracle),
        ("fused", &fused),
        ("by time", &by_time),
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
