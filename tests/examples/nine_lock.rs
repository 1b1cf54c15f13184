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
//! the Ω RMS of both per window; `TRACE=T0,T1` the candidates and hypotheses of the forward path
//! between those times.

use ballisto::estimate::HostEstimator;
use estimator_core::smoother::StepRecord;
use estimator_core::{Estimate, Estimator, Model, Options};
use hal_sim::arrangement_file::HOST_CAP;
use hal_sim::ideal::simulate_outputs;
use hal_sim::motion::{Environment, Motion, Rotation, Torque, Truth};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt()
}

fn env_pair(name: &str) -> Option<(f64, f64)> {
    let v = std::env::var(name).ok()?;
    let (a, b) = v.split_once(',')?;
    Some((a.parse().ok()?, b.parse().ok()?))
}

/// The forward path, printing the candidates and hypotheses within `trace`.
fn forward(
    loaded: &hal_sim::arrangement_file::LoadedArrangement,
    truth: &[Truth],
    outputs: &[Vec<f64>],
    options: Options,
    trace: Option<(f64, f64)>,
) -> Vec<Estimate<f64>> {
    let mut e = Estimator::<f64, HOST_CAP>::new(&loaded.arrangement, Model::FreeFloat, options)
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
                "silent t {:.3} off {:.3} sd {:.4} |Ω| {:.2} cands",
                tr.t,
                dist(&r.omega, &w),
                r.sd_omega.iter().fold(0.0f64, |m, v| m.max(*v)),
                dist(&w, &[0.0; 3])
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
                    " cand off {d:.3} dΩ′ {:.3} fit {:.1} Ω {:.4} {:.4} {:.4} Ω′ {:.3} {:.3} {:.3} |",
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
                print!(" ({:.1}, off {:.2})", s.cost, dist(&s.omega, &w));
            }
            println!(
                " best {} error {:.3} model sd {:.4} best sd {:.4}",
                rec.best,
                dist(&r.omega, &w),
                e.rate_model_variance().sqrt(),
                rec.states[rec.best as usize].var.sqrt()
            );
        }
        rows.push(r);
    }
    rows
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 6 {
        eprintln!("usage: nine_lock RATE_HZ NOISE ARM SECONDS SEED [tumble|manoeuvre]");
        std::process::exit(2);
    }
    let num = |i: usize| -> f64 { a[i].parse().expect("a number") };
    let (rate, noise, arm, secs) = (num(1), num(2), num(3), num(4));
    let seed: u64 = a[5].parse().expect("a seed");
    let manoeuvre = a.get(6).is_some_and(|s| s == "manoeuvre");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut file = test_fixtures::families::nine_channel(arm, noise);
    // Mounting jitter: ±1 mm, axes turned by up to ±1° about each axis.
    for ch in file.channels.iter_mut() {
        for v in ch.position.iter_mut() {
            *v += rng.gen_range(-1e-3..1e-3);
        }
        let t: [f64; 3] = core::array::from_fn(|_| rng.gen_range(-0.017..0.017));
        let s = ch.axis;
        let n = [
            s[0] + t[1] * s[2] - t[2] * s[1],
            s[1] + t[2] * s[0] - t[0] * s[2],
            s[2] + t[0] * s[1] - t[1] * s[0],
        ];
        let l = dist(&n, &[0.0; 3]);
        ch.axis = [n[0] / l, n[1] / l, n[2] / l];
    }
    let loaded = file.load("nine").expect("arrangement");
    let dir = test_fixtures::families::random_rotation(&mut rng)[0];
    let w = 2.2;
    let motion = Motion {
        rotation: Rotation::Euler {
            inertia: [1.0, 1.8, 2.5],
            torque: if manoeuvre {
                Torque::Sinusoid {
                    amplitude: [1.5, 2.0, 2.5],
                    frequency: 0.3,
                    phase: [0.0, 1.0, 2.0],
                }
            } else {
                Torque::None
            },
        },
        environment: Environment::Space,
        omega0: [dir[0] * w, dir[1] * w, dir[2] * w],
        attitude0: [1.0, 0.0, 0.0, 0.0],
        origin_offset: [0.0; 3],
        non_grav: [0.0; 3],
        burns: Vec::new(),
    };
    let dt = 1.0 / rate;
    let truth = motion.run(dt, (secs * rate) as usize, 4);
    let outputs = simulate_outputs(&loaded, &truth, true, seed ^ 0x5eed);
    let options = Options {
        raw: true,
        initial_omega: Some(truth[0].omega),
        ..Default::default()
    };
    let ml: Option<Vec<f64>> = std::env::var_os("ML").map(|_| {
        let ml = e2e_tests::ml::MlReference::new(&loaded, Model::FreeFloat);
        truth
            .iter()
            .zip(outputs.iter())
            .map(|(tr, p)| dist(&ml.estimate(p, &tr.omega).omega, &tr.omega).powi(2))
            .collect()
    });
    if let Some(ml) = &ml {
        let rms = (ml.iter().sum::<f64>() / ml.len() as f64).sqrt();
        println!("truth-started ML: Ω RMS {rms:.4}");
    }
    let window: Option<usize> = std::env::var("WINDOW").ok().and_then(|v| v.parse().ok());
    let forward_rows = forward(&loaded, &truth, &outputs, options, env_pair("TRACE"));
    let mut smoothed = Vec::with_capacity(truth.len());
    {
        let mut e =
            HostEstimator::<f64>::new(&loaded, Model::FreeFloat, options).expect("estimator");
        let mut emit = |_t: f64, r: &Estimate<f64>| smoothed.push(*r);
        for (tr, p) in truth.iter().zip(outputs.iter()) {
            e.push(tr.t, p, &mut emit);
        }
        e.finish(&mut emit);
    }
    for (label, rows) in [("raw forward", &forward_rows), ("raw smoothed", &smoothed)] {
        let err2: Vec<f64> = rows
            .iter()
            .zip(truth.iter())
            .map(|(r, tr)| dist(&r.omega, &tr.omega).powi(2))
            .collect();
        let off = err2.iter().filter(|e| **e > 1.0).count();
        let flagged = rows.iter().filter(|r| r.flags.0 != 0).count();
        let silent = rows
            .iter()
            .zip(truth.iter())
            .filter(|(r, tr)| {
                r.flags.0 == 0
                    && (0..3).any(|i| (r.omega[i] - tr.omega[i]).abs() > 5.0 * r.sd_omega[i])
            })
            .count();
        if let (Some(ml), Some(len)) = (&ml, window) {
            for k0 in (0..rows.len()).step_by(len.max(1)) {
                let k1 = (k0 + len).min(rows.len());
                let (se, sm): (f64, f64) = (err2[k0..k1].iter().sum(), ml[k0..k1].iter().sum());
                let n = (k1 - k0) as f64;
                println!(
                    "  t {:.2} Ω RMS {:.4} ML {:.4} ratio {:.2}",
                    k0 as f64 * dt,
                    (se / n).sqrt(),
                    (sm / n).sqrt(),
                    (se / sm).sqrt()
                );
            }
        }
        // RMS of Ω's error over its reported deviation, per component, over all rows.
        let z2: f64 = rows
            .iter()
            .zip(truth.iter())
            .map(|(r, tr)| {
                (0..3)
                    .map(|i| ((r.omega[i] - tr.omega[i]) / r.sd_omega[i]).powi(2))
                    .sum::<f64>()
                    / 3.0
            })
            .sum();
        println!(
            "{label}: rows {} Ω RMS {:.4} off>1 {:.1}% flagged {flagged} silent {silent} z {:.2}",
            rows.len(),
            (err2.iter().sum::<f64>() / rows.len() as f64).sqrt(),
            100.0 * off as f64 / rows.len() as f64,
            (z2 / rows.len() as f64).sqrt(),
        );
    }
}
