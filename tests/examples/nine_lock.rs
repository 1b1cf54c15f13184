//! Branch lock of the nine-channel ballistometer (issue 15): one case of the family (nine
//! single-axis channels, ~1 mm / ~1° mounting jitter, torque-free tumble or manoeuvre at
//! |Ω| ≈ 2.2 rad/s, a correct initial Ω), estimated raw through the forward path (the
//! firmware's) and the smoothed one (`ballisto estimate`'s), against the truth and, with `ML=1`,
//! the truth-started per-sample maximum likelihood of `tests/`.
//!
//! `cargo run --release -p e2e-tests --example nine_lock -- RATE_HZ NOISE ARM SECONDS SEED [tumble|manoeuvre]`
//!
//! Prints per path: Ω RMS, the share of rows more than 1 rad/s off, flagged rows, and rows off by
//! more than 5 reported sd with no flag ("silent"). `WINDOW=SAMPLES` (with `ML=1`) also prints
//! the Ω RMS of both per window; `TRACE=T0,T1` the candidates and hypotheses (cost, candidate
//! and sign, Ω and Ω′ error, filter deviation) of the forward path between those times;
//! `SILENT=1` every silent row, `DIAG=1` per row the root separation and
//! the errors of the truth-nearest and the chosen root, `FILTERED=1` the filtered outputs,
//! `BIAS=1` / `MLBIAS=1` 0.1 s means of the errors, `TWOSTATE=1` a single-hypothesis probe
//! with Ω′ as a filter state (`SJ` its jerk density, `PROBEWIN=1` per 0.25 s), `MONITOR=1`
//! the rows the lock monitor flagged and how far off they are, `SWITCH=W` how many silent rows
//! fall within `W` samples after a switch of the chosen candidate and how many unflagged rows
//! a flag there would add.

use e2e_tests::nine::{self, Params, Score};
use estimator_core::smoother::StepRecord;
use estimator_core::{Estimate, Estimator, Model};
use hal_sim::arrangement_file::HOST_CAP;

fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt()
}

fn env_pair(name: &str) -> Option<(f64, f64)> {
    let v = std::env::var(name).ok()?;
    let (a, b) = v.split_once(',')?;
    Some((a.parse().ok()?, b.parse().ok()?))
}

/// A candidate root for the probe: Ω, Ω′ and their per-component variances.
type Root = ([f64; 3], [f64; 3], f64, f64);

// With `TWOSTATE=1`: every sample's candidates.
thread_local! {
    static CANDS: std::cell::RefCell<Option<Vec<Vec<Root>>>> =
        const { std::cell::RefCell::new(None) };
}

/// A feasibility probe, not the estimator: one hypothesis, a rate filter with Ω′ as a state
/// (constant Ω′, white jerk of spectral density `SJ`), choosing each sample the signed root
/// nearest its prediction. Returns the chosen roots.
fn two_state(case: &nine::Case, cands: &[Vec<Root>]) -> Vec<[f64; 3]> {
    let sj: f64 = std::env::var("SJ")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(25.0);
    let use_d = std::env::var_os("NOD").is_none();
    let mut w = case.truth[0].omega;
    let mut d = case.truth[0].domega;
    let (mut pww, mut pwd, mut pdd) = (1e-4, 0.0, 1.0);
    let mut out = Vec::with_capacity(cands.len());
    let mut last_t = case.truth[0].t;
    for (tr, cs) in case.truth.iter().zip(cands.iter()) {
        let dt = tr.t - last_t;
        last_t = tr.t;
        for k in 0..3 {
            w[k] += d[k] * dt;
        }
        pww += 2.0 * dt * pwd + dt * dt * pdd + sj * dt * dt * dt / 3.0;
        pwd += dt * pdd + sj * dt * dt / 2.0;
        pdd += sj * dt;
        // (cost, signed Ω, signed Ω′, their variances)
        let mut best: Option<(f64, Root)> = None;
        for (o, dd, rw, rd) in cs {
            for sg in [1.0, -1.0] {
                let z = [sg * o[0], sg * o[1], sg * o[2]];
                let zd = [sg * dd[0], sg * dd[1], sg * dd[2]];
                let nu2: f64 = (0..3).map(|k| (z[k] - w[k]).powi(2)).sum();
                let cost = nu2 / (pww + rw) + 3.0 * (pww + rw).ln();
                if best.is_none_or(|b| cost < b.0) {
                    best = Some((cost, (z, zd, *rw, *rd)));
                }
            }
        }
        let Some((_, (z, zd, rw, rd))) = best else {
            out.push(w);
            continue;
        };
        let mut p = (pww, pwd, pdd);
        measure(&mut w, &mut d, &mut p, &z, rw, true);
        if use_d {
            measure(&mut w, &mut d, &mut p, &zd, rd, false);
        }
        (pww, pwd, pdd) = p;
        out.push(z);
    }
    out
}

/// One scalar-per-axis Kalman update of the probe's state (Ω `w`, Ω′ `d`, covariance `p` =
/// (P_ww, P_wd, P_dd)) by a measurement `z` of Ω (`of_rate`) or of Ω′, variance `r`.
fn measure(
    w: &mut [f64; 3],
    d: &mut [f64; 3],
    p: &mut (f64, f64, f64),
    z: &[f64; 3],
    r: f64,
    of_rate: bool,
) {
    let (a, b, c) = *p;
    // P Hᵀ for H = [1 0] (Ω) or [0 1] (Ω′).
    let (hw, hd) = if of_rate { (a, b) } else { (b, c) };
    let s = if of_rate { a } else { c } + r;
    let (kw, kd) = (hw / s, hd / s);
    let x = if of_rate { &*w } else { &*d };
    let nu: [f64; 3] = core::array::from_fn(|k| z[k] - x[k]);
    for k in 0..3 {
        w[k] += kw * nu[k];
        d[k] += kd * nu[k];
    }
    *p = (a - kw * hw, b - kw * hd, c - kd * hd);
}

/// The forward path, printing the candidates and hypotheses within `trace`.
fn forward(case: &nine::Case, trace: Option<(f64, f64)>) -> Vec<Estimate<f64>> {
    let (truth, outputs) = (&case.truth, &case.outputs);
    let options = estimator_core::Options {
        raw: std::env::var_os("FILTERED").is_none(),
        ..case.options
    };
    let mut e =
        Estimator::<f64, HOST_CAP>::new(&case.loaded.arrangement, Model::FreeFloat, options)
            .expect("arrangement");
    let mut rec = StepRecord::<f64>::default();
    let mut rows = Vec::with_capacity(truth.len());
    for (tr, p) in truth.iter().zip(outputs.iter()) {
        let r = *e.update_with(tr.t, p, Some(&mut rec));
        let w = tr.omega;
        let silent =
            r.flags.0 == 0 && (0..3).any(|i| (r.omega[i] - w[i]).abs() > 5.0 * r.sd_omega[i]);
        if std::env::var_os("DIAG").is_some() {
            // t, candidates, closest root pair / sd, truth-nearest candidate's error / sd,
            // chosen error / sd, flags.
            let nc = rec.n_candidates as usize;
            let cs = &rec.candidates[..nc];
            let sdm = |c: &Estimate<f64>| c.sd_omega.iter().fold(0.0f64, |m, v| m.max(*v));
            let sdist =
                |a: &[f64; 3], b: &[f64; 3]| dist(a, b).min(dist(&[-a[0], -a[1], -a[2]], b));
            let mut sep = f64::INFINITY;
            for i in 0..nc {
                for j in (i + 1)..nc {
                    sep = sep.min(sdist(&cs[i].omega, &cs[j].omega) / sdm(&cs[i]).max(sdm(&cs[j])));
                }
            }
            let near = cs
                .iter()
                .map(|c| sdist(&c.omega, &w) / sdm(c))
                .fold(f64::INFINITY, f64::min);
            let near_abs = cs
                .iter()
                .map(|c| sdist(&c.omega, &w))
                .fold(f64::INFINITY, f64::min);
            print!("diagabs {near_abs:.5} {:.5} ", dist(&r.omega, &w));
            println!(
                "diag {:.4} {} {:.2} {:.2} {:.2} {}",
                tr.t,
                nc,
                sep,
                near,
                dist(&r.omega, &w) / sdm(&r),
                r.flags.0
            );
        }
        if silent && std::env::var_os("SILENT").is_some() {
            print!(
                "silent t {:.3} off {:.3} sd {:.4} |Ω| {:.2} |Ω′| {:.2} Ω′ off {:.2} cands",
                tr.t,
                dist(&r.omega, &w),
                r.sd_omega.iter().fold(0.0f64, |m, v| m.max(*v)),
                dist(&w, &[0.0; 3]),
                dist(&tr.domega, &[0.0; 3]),
                dist(&r.domega, &tr.domega)
            );
            for c in rec.candidates.iter().take(rec.n_candidates as usize) {
                let neg = [-c.omega[0], -c.omega[1], -c.omega[2]];
                let d = dist(&c.omega, &w).min(dist(&neg, &w));
                let dr = dist(&c.omega, &r.omega).min(dist(&neg, &r.omega));
                print!(
                    " [truth {d:.3} chosen {dr:.3} sd {:.4} {:.4} {:.4} branches {}]",
                    c.sd_omega[0], c.sd_omega[1], c.sd_omega[2], c.branches
                );
            }
            print!(" states");
            for s in rec.states.iter().take(rec.n_states as usize) {
                print!(
                    " ({:.1} c{} off {:.2})",
                    s.cost,
                    s.candidate,
                    dist(&s.omega, &w)
                );
            }
            println!();
        }
        if trace.is_some_and(|(a, b)| tr.t >= a && tr.t <= b) {
            print!("t {:.3} |", tr.t);
            for c in rec.candidates.iter().take(rec.n_candidates as usize) {
                let neg = [-c.omega[0], -c.omega[1], -c.omega[2]];
                let d = dist(&c.omega, &w).min(dist(&neg, &w));
                print!(
                    " cand off {d:.3} sd {:.3} dΩ′ {:.3} fit {:.1} Ω {:.4} {:.4} {:.4} Ω′ {:.3} {:.3} {:.3} |",
                    (c.sd_omega.iter().map(|x| x * x).sum::<f64>() / 3.0).sqrt(),
                    dist(&c.domega, &tr.domega),
                    c.chi2,
                    c.omega[0],
                    c.omega[1],
                    c.omega[2],
                    c.domega[0],
                    c.domega[1],
                    c.domega[2]
                );
            }
            for s in rec.states.iter().take(rec.n_states as usize) {
                print!(
                    " ({:.1}, c{}{} off {:.2} Ω′ off {:.2} sd {:.3})",
                    s.cost,
                    s.candidate,
                    if s.sign > 0 { '+' } else { '-' },
                    dist(&s.omega, &w),
                    dist(&s.domega, &tr.domega),
                    s.var.sqrt()
                );
            }
            println!(
                " best {} error {:.3} model sd {:.4} best sd {:.4} flags {} margin {:.1}",
                rec.best,
                dist(&r.omega, &w),
                e.rate_model_variance().sqrt(),
                rec.states[rec.best as usize].var.sqrt(),
                r.flags.0,
                r.branch_margin
            );
        }
        if CANDS.with(|c| c.borrow().is_some()) {
            let list: Vec<Root> = rec
                .candidates
                .iter()
                .take(rec.n_candidates as usize)
                .map(|c| {
                    let v = |s: &[f64; 3]| s.iter().map(|x| x * x).sum::<f64>() / 3.0;
                    (c.omega, c.domega, v(&c.sd_omega), v(&c.sd_domega))
                })
                .collect();
            CANDS.with(|c| c.borrow_mut().as_mut().unwrap().push(list));
        }
        if std::env::var_os("MONITOR").is_some() {
            // The lock monitor's verdicts: rows it flagged (margin 0 with the branch flag; the
            // tracker's own margin is 0 only on exact ties) and how far off they are.
            let z = (0..3)
                .map(|i| ((r.omega[i] - w[i]) / r.sd_omega[i].max(1e-12)).abs())
                .fold(0.0f64, f64::max);
            let by_monitor =
                r.branch_margin == 0.0 && r.flags.has(estimator_core::Flags::BRANCH_AMBIGUOUS);
            MON.with(|m| {
                let mut m = m.borrow_mut();
                let k = usize::from(by_monitor);
                m[k].0 += 1;
                m[k].1 += usize::from(z > 3.0);
                m[k].2 += usize::from(dist(&r.omega, &w) > 1.0);
            });
        }
        if let Some(window) = std::env::var("SWITCH")
            .ok()
            .and_then(|v| v.parse::<usize>().ok())
        {
            // Would a flag for a switch of the chosen candidate within the last `window`
            // samples catch the silent rows, and what would it cost? (Issue 15 analysis.)
            let chosen = rec.states[rec.best as usize].candidate;
            SWITCH.with(|sw| {
                let mut sw = sw.borrow_mut();
                if sw.0.is_some_and(|c| c != chosen) {
                    sw.1 = 0;
                } else {
                    sw.1 = sw.1.saturating_add(1);
                }
                sw.0 = Some(chosen);
                let recent = sw.1 < window;
                let flagged = r.flags.0 != 0;
                sw.2[0] += usize::from(silent);
                sw.2[1] += usize::from(silent && recent);
                sw.2[2] += usize::from(!flagged && recent);
                sw.2[3] += 1;
            });
        }
        rows.push(r);
    }
    rows
}

thread_local! {
    /// The last chosen candidate, samples since it last changed, and the counts: silent rows,
    /// silent rows within the window after a switch, unflagged rows within it, all rows.
    static SWITCH: std::cell::RefCell<(Option<u8>, usize, [usize; 4])> =
        const { std::cell::RefCell::new((None, 0, [0; 4])) };
}

thread_local! {
    /// Per class (0: not flagged by the monitor, 1: flagged by it): rows, rows > 3 sd off,
    /// rows > 1 rad/s off.
    static MON: std::cell::RefCell<[(usize, usize, usize); 2]> =
        const { std::cell::RefCell::new([(0, 0, 0); 2]) };
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 6 {
        eprintln!("usage: nine_lock RATE_HZ NOISE ARM SECONDS SEED [tumble|manoeuvre]");
        std::process::exit(2);
    }
    let num = |i: usize| -> f64 { a[i].parse().expect("a number") };
    let params = Params {
        rate_hz: num(1),
        noise: num(2),
        arm: num(3),
        seconds: num(4),
        seed: a[5].parse().expect("a seed"),
        manoeuvre: a.get(6).is_some_and(|s| s == "manoeuvre"),
    };
    // `FIRMWARE=1`: the readings the firmware got on `nine-channel` at RATE_HZ (the other
    // arguments ignored).
    let case = if std::env::var_os("FIRMWARE").is_some() {
        nine::firmware_readings(params.rate_hz)
    } else {
        nine::make(params)
    };
    let ml = std::env::var_os("ML").map(|_| case.ml_errors());
    if let Some(ml) = &ml {
        let n = ml.len() as f64;
        let rms: [f64; 3] =
            core::array::from_fn(|i| (ml.iter().map(|e| e[i]).sum::<f64>() / n).sqrt());
        println!(
            "truth-started ML: σ0 {:.4e} Ω′ {:.4} Ω {:.4}",
            rms[0], rms[1], rms[2]
        );
    }
    if std::env::var_os("MLBIAS").is_some() {
        // The truth-started ML's Ω′ and σ0 errors averaged over 0.1 s windows.
        let ml = e2e_tests::ml::MlReference::new(&case.loaded, Model::FreeFloat);
        let n = ((0.1 * params.rate_hz) as usize).max(1);
        let (mut a2, mut s2, mut p2, mut k) = (0.0, 0.0, 0.0, 0usize);
        let mut per = 0.0;
        for (ts, ps) in case.truth.chunks(n).zip(case.outputs.chunks(n)) {
            let mut m = [0.0; 6];
            for (tr, p) in ts.iter().zip(ps.iter()) {
                let e = ml.estimate(p, &tr.omega);
                for i in 0..3 {
                    m[i] += (e.domega[i] - tr.domega[i]) / ts.len() as f64;
                    m[3 + i] += (e.sigma0[i] - tr.sigma0[i]) / ts.len() as f64;
                    per += (e.domega[i] - tr.domega[i]).powi(2);
                }
                p2 += 1.0;
            }
            a2 += m[..3].iter().map(|v| v * v).sum::<f64>();
            s2 += m[3..].iter().map(|v| v * v).sum::<f64>();
            k += 1;
        }
        println!(
            "ML: per-sample Ω′ RMS {:.4}; 0.1 s means: Ω′ {:.4}, σ0 {:.4e}",
            (per / p2).sqrt(),
            (a2 / k as f64).sqrt(),
            (s2 / k as f64).sqrt()
        );
    }
    let window: Option<usize> = std::env::var("WINDOW").ok().and_then(|v| v.parse().ok());
    if std::env::var_os("TWOSTATE").is_some() {
        CANDS.with(|c| *c.borrow_mut() = Some(Vec::new()));
    }
    let forward_rows = forward(&case, env_pair("TRACE"));
    if std::env::var_os("SWITCH").is_some() {
        SWITCH.with(|sw| {
            let c = sw.borrow().2;
            println!(
                "switch window: {} of {} silent rows within it; {} unflagged rows of {} would be flagged",
                c[1], c[0], c[2], c[3]
            );
        });
    }
    if std::env::var_os("MONITOR").is_some() {
        MON.with(|m| {
            let m = m.borrow();
            println!(
                "lock monitor (forward): flagged {} rows, {} of them > 3 sd off, {} > 1 rad/s off; \
                 other rows {}, {} > 3 sd off, {} > 1 rad/s off",
                m[1].0, m[1].1, m[1].2, m[0].0, m[0].1, m[0].2
            );
        });
    }
    if let Some(cands) = CANDS.with(|c| c.borrow_mut().take()) {
        let chosen = two_state(&case, &cands);
        let e2: f64 = chosen
            .iter()
            .zip(case.truth.iter())
            .map(|(z, tr)| dist(z, &tr.omega).powi(2))
            .sum();
        let near: f64 = cands
            .iter()
            .zip(case.truth.iter())
            .map(|(cs, tr)| {
                cs.iter()
                    .map(|c| {
                        let m = [-c.0[0], -c.0[1], -c.0[2]];
                        dist(&c.0, &tr.omega).min(dist(&m, &tr.omega)).powi(2)
                    })
                    .fold(f64::INFINITY, f64::min)
            })
            .filter(|v| v.is_finite())
            .sum();
        if std::env::var_os("PROBEWIN").is_some() {
            let m = (0.25 / (case.truth[1].t - case.truth[0].t)) as usize;
            for (k, (zs, (cs, ts))) in chosen
                .chunks(m)
                .zip(cands.chunks(m).zip(case.truth.chunks(m)))
                .enumerate()
            {
                let (mut a, mut b, mut nb) = (0.0, 0.0, 0usize);
                for (z, (c, tr)) in zs.iter().zip(cs.iter().zip(ts.iter())) {
                    a += dist(z, &tr.omega).powi(2);
                    b += c
                        .iter()
                        .map(|c| {
                            let m = [-c.0[0], -c.0[1], -c.0[2]];
                            dist(&c.0, &tr.omega).min(dist(&m, &tr.omega)).powi(2)
                        })
                        .fold(f64::INFINITY, f64::min);
                    nb += usize::from(c.len() == 1);
                }
                let n = zs.len() as f64;
                println!(
                    "  t {:.2} probe {:.3} nearest {:.3} single-root rows {nb}",
                    k as f64 * 0.25,
                    (a / n).sqrt(),
                    (b / n).sqrt()
                );
            }
        }
        let n = chosen.len() as f64;
        println!(
            "two-state probe: Ω RMS {:.4} (truth-nearest root {:.4})",
            (e2 / n).sqrt(),
            (near / n).sqrt()
        );
    }
    let raw = std::env::var_os("FILTERED").is_none();
    let smoothed = case.smoothed(raw);
    for (label, rows) in [("raw forward", &forward_rows), ("raw smoothed", &smoothed)] {
        if let (Some(ml), Some(len)) = (&ml, window) {
            for k0 in (0..rows.len()).step_by(len.max(1)) {
                let k1 = (k0 + len).min(rows.len());
                let se: f64 = rows[k0..k1]
                    .iter()
                    .zip(case.truth[k0..k1].iter())
                    .map(|(r, tr)| dist(&r.omega, &tr.omega).powi(2))
                    .sum();
                let sm: f64 = ml[k0..k1].iter().map(|e| e[2]).sum();
                let n = (k1 - k0) as f64;
                println!(
                    "  t {:.2} Ω RMS {:.4} ML {:.4} ratio {:.2}",
                    case.truth[k0].t,
                    (se / n).sqrt(),
                    (sm / n).sqrt(),
                    (se / sm).sqrt()
                );
            }
        }
        if std::env::var_os("BIAS").is_some() {
            // Ω′ and σ0 errors averaged over 0.1 s windows (white errors shrink by √n).
            let n = ((0.1 * params.rate_hz) as usize).max(1);
            let (mut a2, mut s2, mut w2, mut k) = (0.0, 0.0, 0.0, 0);
            for (rs, ts) in rows.chunks(n).zip(case.truth.chunks(n)) {
                let mut m = [0.0; 9];
                for (r, tr) in rs.iter().zip(ts.iter()) {
                    for i in 0..3 {
                        m[i] += (r.domega[i] - tr.domega[i]) / rs.len() as f64;
                        m[3 + i] += (r.sigma0[i] - tr.sigma0[i]) / rs.len() as f64;
                        m[6 + i] += (r.omega[i] - tr.omega[i]) / rs.len() as f64;
                    }
                }
                a2 += m[..3].iter().map(|v| v * v).sum::<f64>();
                s2 += m[3..6].iter().map(|v| v * v).sum::<f64>();
                w2 += m[6..].iter().map(|v| v * v).sum::<f64>();
                k += 1;
            }
            let k = k as f64;
            println!(
                "  0.1 s means: Ω′ error RMS {:.4}, σ0 {:.4e}, Ω {:.4} ({n} samples each)",
                (a2 / k).sqrt(),
                (s2 / k).sqrt(),
                (w2 / k).sqrt()
            );
        }
        let s = Score::of(rows, &case.truth);
        let [e0, e1, e2] = s.rms();
        println!(
            "{label}: rows {} σ0 {e0:.4e} Ω′ {e1:.4} Ω RMS {e2:.4} off>1 {:.1}% flagged {} ambiguous {} silent {} z {:.2} margin mismatches {}",
            s.rows,
            s.pct(s.off),
            s.flagged,
            s.ambiguous,
            s.silent,
            s.z_rms(),
            s.margin_mismatch
        );
    }
}
