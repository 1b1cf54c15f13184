//! Experiment: the nine-channel ballistometer at a given rate, noise and arm (issue 15).
//! Usage: cargo run --release -p e2e-tests --example nine_lock -- RATE_HZ NOISE ARM SECONDS SEED [tumble|manoeuvre]

use ballisto::estimate::HostEstimator;
use estimator_core::{Estimator, Model, Options};
use hal_sim::arrangement_file::HOST_CAP;
use hal_sim::ideal::simulate_outputs;
use hal_sim::motion::{Environment, Motion, Rotation, Torque};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let rate: f64 = a[1].parse().unwrap();
    let noise: f64 = a[2].parse().unwrap();
    let arm: f64 = a[3].parse().unwrap();
    let secs: f64 = a[4].parse().unwrap();
    let seed: u64 = a[5].parse().unwrap();
    let manoeuvre = a.get(6).map(|s| s == "manoeuvre").unwrap_or(false);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut file = test_fixtures::families::nine_channel(arm, noise);
    for ch in file.channels.iter_mut() {
        for v in ch.position.iter_mut() {
            *v += rng.gen_range(-1e-3..1e-3);
        }
        let t: [f64; 3] = core::array::from_fn(|_| rng.gen_range(-0.017..0.017));
        let ax = ch.axis;
        let c = [
            t[1] * ax[2] - t[2] * ax[1],
            t[2] * ax[0] - t[0] * ax[2],
            t[0] * ax[1] - t[1] * ax[0],
        ];
        let n = [ax[0] + c[0], ax[1] + c[1], ax[2] + c[2]];
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        ch.axis = [n[0] / l, n[1] / l, n[2] / l];
    }
    let loaded = file.load("nine").unwrap();
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
    let n = (secs * rate) as usize;
    let truth = motion.run(dt, n, 4);
    let outputs = simulate_outputs(&loaded, &truth, true, seed ^ 0x5eed);
    let hint = Some(truth[0].omega);
    if std::env::var_os("ML").is_some() {
        let ml = e2e_tests::ml::MlReference::new(&loaded, Model::FreeFloat);
        let mut s2 = 0.0;
        let mut win = Vec::new();
        for (tr, p) in truth.iter().zip(outputs.iter()) {
            let m = ml.estimate(p, &tr.omega);
            let e = (0..3)
                .map(|i| (m.omega[i] - tr.omega[i]).powi(2))
                .sum::<f64>();
            s2 += e;
            win.push(e);
        }
        unsafe {
            std::env::set_var(
                "ML_WIN",
                win.iter()
                    .map(|v| v.to_string())
                    .collect::<Vec<_>>()
                    .join(","),
            )
        };
        println!("ML: Ω RMS {:.4}", (s2 / truth.len() as f64).sqrt());
    }
    for (label, smoothed) in [("raw forward", false), ("raw smoothed", true)] {
        let opts = Options {
            raw: true,
            initial_omega: hint,
            ..Default::default()
        };
        let mut rows = Vec::new();
        if smoothed {
            let mut e = HostEstimator::<f64>::new(&loaded, Model::FreeFloat, opts).unwrap();
            let mut emit = |_t: f64, r: &estimator_core::Estimate<f64>| rows.push(*r);
            for (tr, p) in truth.iter().zip(outputs.iter()) {
                e.push(tr.t, p, &mut emit);
            }
            e.finish(&mut emit);
        } else {
            let mut e =
                Estimator::<f64, HOST_CAP>::new(&loaded.arrangement, Model::FreeFloat, opts)
                    .unwrap();
            let trace: Option<(f64, f64)> = std::env::var("TRACE").ok().map(|v| {
                let mut it = v.split(',').map(|x| x.parse::<f64>().unwrap());
                (it.next().unwrap(), it.next().unwrap())
            });
            let mut rec = estimator_core::smoother::StepRecord::<f64>::default();
            for (tr, p) in truth.iter().zip(outputs.iter()) {
                let r = *e.update_with(tr.t, p, Some(&mut rec));
                if let Some((a, b)) = trace {
                    if tr.t >= a && tr.t <= b {
                        let w = tr.omega;
                        print!(
                            "t {:.3} true [{:.3} {:.3} {:.3}] cands",
                            tr.t, w[0], w[1], w[2]
                        );
                        for c in rec.candidates.iter().take(rec.n_candidates as usize) {
                            let o = c.omega;
                            let d = ((o[0] - w[0]).powi(2)
                                + (o[1] - w[1]).powi(2)
                                + (o[2] - w[2]).powi(2))
                            .sqrt();
                            let d2 = ((o[0] + w[0]).powi(2)
                                + (o[1] + w[1]).powi(2)
                                + (o[2] + w[2]).powi(2))
                            .sqrt();
                            print!(
                                " [{:.3} {:.3} {:.3} fit {:.1} d {:.3}]",
                                o[0],
                                o[1],
                                o[2],
                                c.chi2,
                                d.min(d2)
                            );
                        }
                        print!(" states");
                        for s in rec.states.iter().take(rec.n_states as usize) {
                            let o = s.omega;
                            let d = ((o[0] - w[0]).powi(2)
                                + (o[1] - w[1]).powi(2)
                                + (o[2] - w[2]).powi(2))
                            .sqrt();
                            print!(" ({:.1} d{:.2})", s.cost, d);
                        }
                        println!(
                            " mv {:.3e} best {} err {:.3}",
                            e.rate_model_variance(),
                            rec.best,
                            ((r.omega[0] - w[0]).powi(2)
                                + (r.omega[1] - w[1]).powi(2)
                                + (r.omega[2] - w[2]).powi(2))
                            .sqrt()
                        );
                    }
                }
                rows.push(r);
            }
        }
        let (mut off, mut silent, mut flagged, mut s2) = (0, 0, 0, 0.0);
        let mut first_off = None;
        for (k, (r, tr)) in rows.iter().zip(truth.iter()).enumerate() {
            let e: Vec<f64> = (0..3).map(|i| r.omega[i] - tr.omega[i]).collect();
            let en = e.iter().map(|x| x * x).sum::<f64>();
            s2 += en;
            if en.sqrt() > 1.0 {
                off += 1;
                first_off.get_or_insert(k);
            }
            if r.flags.0 != 0 {
                flagged += 1;
            } else if (0..3).any(|i| e[i].abs() > 5.0 * r.sd_omega[i]) {
                silent += 1;
            }
        }
        if let (Ok(w), Ok(ws)) = (std::env::var("ML_WIN"), std::env::var("WIN")) {
            let ml: Vec<f64> = w.split(',').map(|v| v.parse().unwrap()).collect();
            let len: usize = ws.parse().unwrap();
            for k0 in (0..rows.len()).step_by(len) {
                let k1 = (k0 + len).min(rows.len());
                let se: f64 = (k0..k1)
                    .map(|k| {
                        (0..3)
                            .map(|i| (rows[k].omega[i] - truth[k].omega[i]).powi(2))
                            .sum::<f64>()
                    })
                    .sum();
                let sm: f64 = ml[k0..k1].iter().sum();
                let fl = (k0..k1).filter(|&k| rows[k].flags.0 != 0).count();
                let wn = truth[k0].omega.iter().map(|x| x * x).sum::<f64>().sqrt();
                println!(
                    "  t {:.2} est {:.4} ml {:.4} ratio {:.2} flagged {} |w| {:.2}",
                    k0 as f64 * dt,
                    (se / (k1 - k0) as f64).sqrt(),
                    (sm / (k1 - k0) as f64).sqrt(),
                    (se / sm).sqrt(),
                    fl,
                    wn
                );
            }
        }
        println!(
            "{label}: rows {} Ω RMS {:.4} off>1 {:.1}% first off at {:?} s; flagged {} silent {}",
            rows.len(),
            (s2 / rows.len() as f64).sqrt(),
            100.0 * off as f64 / rows.len() as f64,
            first_off.map(|k| k as f64 * dt),
            flagged,
            silent
        );
    }
}
