//! Probe (issues 15 and 17): one run of the 24-channel mixed layout through the firmware,
//! traced — every `STEP`-th set (default 10) and every silently wrong one: the true and
//! estimated Ω′ and Ω, the reported deviation, flags and excluded parts. `HOST=T0,T1` instead
//! runs estimator-core (f64, raw) on the firmware's readings and prints, within T0–T1 s, each
//! candidate's distance from the truth with either sign and the tracker's hypotheses (cost,
//! candidate and sign, distance, deviation). This is how the spin-up's held wrong sign was
//! traced (README, "Fault detection").
//!
//! `cargo run --release -p e2e-tests --example mixed_trace -- [KIND|none] [PART] [START] [SEED]`
//! (KIND a hal-sim fault kind, e.g. `bias-jump`, 3 s from START on part PART; defaults
//! `bias-jump 2 4.0 2003`; `SIGMAS=K` makes a bias jump K σ of one ADXL355 sample instead of
//! 0.1 m/s²; `REMOVE=PART` runs the layout without that part).
use ballisto_fw::config::Alignment;
use estimator_core::smoother::StepRecord;
use estimator_core::{Estimator, Model, Options};
use hal_sim::firmware_host::{firmware_config, for_each_channel, run_firmware};

fn main() {
    let step: u64 = std::env::var("STEP")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(10);
    let host: Option<(f64, f64)> = std::env::var("HOST").ok().map(|s| {
        let v: Vec<f64> = s.split(',').map(|x| x.parse().unwrap()).collect();
        (v[0], v[1])
    });
    let a: Vec<String> = std::env::args().collect();
    let kind = a.get(1).cloned().unwrap_or("bias-jump".into());
    let part: usize = a.get(2).and_then(|s| s.parse().ok()).unwrap_or(2);
    let start: f64 = a.get(3).and_then(|s| s.parse().ok()).unwrap_or(4.0);
    let seed: u64 = a.get(4).and_then(|s| s.parse().ok()).unwrap_or(2003);
    let mut sc = e2e_tests::faults::mixed(seed);
    // `REMOVE=PART`: the layout without that part.
    if let Some(r) = std::env::var("REMOVE")
        .ok()
        .and_then(|s| s.parse::<usize>().ok())
    {
        sc.parts.remove(r);
    }
    let loaded = sc.arrangement().load("arrangement.toml").unwrap();
    let sigma = loaded.arrangement.channels()[0].noise;
    if let Some((_, mut f)) = e2e_tests::faults::kinds(sigma)
        .into_iter()
        .find(|(_, s)| s.kind == kind)
    {
        f.part = sc.parts[part].name.clone();
        f.start = start;
        f.end = Some(start + 3.0);
        // `SIGMAS=K`: a bias of K σ (of one ADXL355 sample) instead of 0.1 m/s².
        if let Some(k) = std::env::var("SIGMAS")
            .ok()
            .and_then(|s| s.parse::<f64>().ok())
        {
            f.bias = e2e_tests::faults::bias_jump(k * sigma).bias;
        }
        sc.faults.push(f);
    }
    let config = firmware_config(&sc, &loaded, Alignment::Interpolate).unwrap();
    let n = loaded.names.len();
    let mut est = Estimator::<f64, { hal_sim::arrangement_file::HOST_CAP }>::new(
        &loaded.arrangement,
        Model::General,
        Options {
            raw: true,
            ..Options::default()
        },
    )
    .unwrap();
    let mut p = vec![f64::NAN; n];
    let mut rec = StepRecord::<f64>::default();
    run_firmware(&sc, &config, sc.samples() as u32, &mut |set, m, tr| {
        // The set's simulated instant (the report's `t` is on-board time, from boot).
        let t = tr.t;
        if let Some((t0, t1)) = host {
            for_each_channel(&config.sampling, set, |c, x| p[c] = f64::from(x));
            let r = *est.update_with(t, &p, Some(&mut rec));
            if t >= t0 && t <= t1 {
                let w = tr.omega;
                let d = |x: &[f64; 3]| ((0..3).map(|k| (x[k] - w[k]).powi(2)).sum::<f64>()).sqrt();
                print!(
                    "host t {t:5.2} off {:.3} sd {:.1e} flags {} margin {:.1} mvar {:.2e} cands",
                    d(&r.omega),
                    r.sd_omega[0],
                    r.flags.0,
                    r.branch_margin,
                    est.rate_model_variance()
                );
                for c in rec.candidates.iter().take(rec.n_candidates as usize) {
                    let neg = c.omega.map(|v| -v);
                    print!(" [+{:.3} -{:.3} sd {:.3}]", d(&c.omega), d(&neg), c.sd_omega[0]);
                }
                print!(" states");
                for s in rec.states.iter().take(rec.n_states as usize) {
                    print!(" ({:.1} c{}{} off {:.3} sd {:.3})", s.cost, s.candidate, if s.sign > 0 { '+' } else { '-' }, d(&s.omega), s.var.sqrt());
                }
                println!();
            }
            return;
        }
        let e = &m.estimate;
        let (err, silent) = e2e_tests::faults::firmware_omega_error(e, tr.omega);
        if silent || ((t * 100.0).round() as u64).is_multiple_of(step) {
            println!(
                "dw true {:6.3} {:6.3} {:6.3} est {:6.3} {:6.3} {:6.3} t {t:6.2} true {:7.3} {:7.3} {:7.3} est {:7.3} {:7.3} {:7.3} sd {:.2e} err {err:.3} chi2 {:.1} flags {:3} excl {:08b} silent {silent} verdict {:?}",
                tr.domega[0], tr.domega[1], tr.domega[2], e.domega[0], e.domega[1], e.domega[2], tr.omega[0], tr.omega[1], tr.omega[2], e.omega[0], e.omega[1], e.omega[2], e.sd_omega[0], e.chi2, e.flags.0, m.excluded.0, m.verdict
            );
        }
    })
    .unwrap();
}
