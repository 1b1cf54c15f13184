//! Probe (issue 17): which parts the fault monitor takes out in fault-free runs of the mixed
//! layout, and for how long, and when the rows flagged 64 fall (per second of the run).
//!
//! `cargo run --release -p e2e-tests --example mixed_probe`; `PARITY=SEED` the parity χ² per
//! 0.2 s of one run (with `BIAS=PART,K` a bias jump of K σ of one ADXL355 sample on that part
//! from 3 s) and the fault monitor's level and verdict on it; `ERR=SEED` each part's error
//! against eq. (4) in its declared noise per 0.2 s (`LATEST=1`: the unaligned reference);
//! `REMOVE=PART SEED=S` one fault-free run without that part, its Ω error per 0.25 s and every
//! silently wrong row (with `HOST=1`: the same run through `ballisto sim --firmware`, then
//! `ballisto estimate` (f32) on the samples the firmware read, both compared with the truth).
use ballisto_fw::config::Alignment;
use hal_sim::firmware_host::{firmware_config, for_each_channel, run_firmware};

fn main() {
    if let Some(seed) = std::env::var("ERR").ok().and_then(|s| s.parse().ok()) {
        error_over_time(seed, std::env::var("LATEST").is_ok());
        return;
    }
    if let Some(seed) = std::env::var("PARITY").ok().and_then(|s| s.parse().ok()) {
        parity_over_time(seed);
        return;
    }
    // `REMOVE=PART SEED=S`: one run without that part, its Ω error per 0.25 s.
    if let Ok(r) = std::env::var("REMOVE") {
        let part: usize = r.parse().unwrap();
        let seed: u64 = std::env::var("SEED").unwrap().parse().unwrap();
        let mut sc = e2e_tests::faults::mixed(seed);
        sc.parts.remove(part);
        if std::env::var("HOST").is_ok() {
            firmware_and_host(&sc);
            return;
        }
        let loaded = sc.arrangement().load("arrangement.toml").unwrap();
        let config = firmware_config(&sc, &loaded, Alignment::Interpolate).unwrap();
        run_firmware(&sc, &config, sc.samples() as u32, &mut |_, m, tr| {
            let e = &m.estimate;
            let (err, silent) = e2e_tests::faults::firmware_omega_error(e, tr.omega);
            if ((tr.t * 100.0).round() as u64).is_multiple_of(25) || silent {
                println!(
                    "t {:.2} |Ω| {:.3} err {err:.4} sd {:.1e} flags {} silent {silent}",
                    tr.t,
                    (tr.omega.iter().map(|x| x * x).sum::<f64>()).sqrt(),
                    e.sd_omega[0],
                    e.flags.0
                );
            }
        })
        .unwrap();
        return;
    }
    for seed in 1000..1020u64 {
        let sc = e2e_tests::faults::mixed(seed);
        let loaded = sc.arrangement().load("arrangement.toml").unwrap();
        let config = firmware_config(&sc, &loaded, Alignment::Interpolate).unwrap();
        let mut out = [0usize; 8];
        let mut first = [f64::NAN; 8];
        let mut flagged = 0;
        let mut ambiguous = 0;
        let mut hist = [0usize; 12];
        run_firmware(&sc, &config, sc.samples() as u32, &mut |_, m, tr| {
            // The set's simulated instant (the report's `t` is on-board time, from boot).
            let t = tr.t;
            let f = m.estimate.flags.has(estimator_core::Flags::RESIDUAL_HIGH);
            flagged += usize::from(f);
            ambiguous += usize::from(
                m.estimate
                    .flags
                    .has(estimator_core::Flags::BRANCH_AMBIGUOUS),
            );
            if f {
                hist[(t as usize).min(11)] += 1;
            }
            for p in 0..8 {
                if m.excluded.0 & (1 << p) != 0 {
                    out[p] += 1;
                    if first[p].is_nan() {
                        first[p] = t;
                    }
                }
            }
        })
        .unwrap();
        println!("seed {seed}: rows out per part {out:?}, from {first:?}, flagged 64 {flagged} per second {hist:?}, branch ambiguous {ambiguous}");
    }
}

/// `REMOVE=… HOST=1`: `sc` through the firmware and then `ballisto estimate`, each compared with
/// the truth (Ω RMS, silently wrong rows).
fn firmware_and_host(sc: &hal_sim::scenario::Scenario) {
    let dir = std::env::temp_dir().join(format!("mixed-probe-{}", std::process::id()));
    let host = e2e_tests::faults::firmware_then_host(sc, &dir);
    for (name, path) in [
        ("firmware", dir.join("estimates.csv")),
        ("ballisto estimate", host),
    ] {
        let c = ballisto::compare::compare(&dir.join("truth.csv"), &path).unwrap();
        println!(
            "{name}: {} rows, Ω RMS {:.3} rad/s, silently wrong (Ω) {:?}",
            c.rows,
            c.omega,
            c.silent.map(|s| s.omega)
        );
    }
    if std::env::var("KEEP").is_ok() {
        println!("kept in {}", dir.display());
    } else {
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// Each channel's part (index in the configuration), channels the parts do not feed 0.
fn channel_parts(config: &ballisto_fw::config::AppConfig) -> Vec<usize> {
    let mut part = vec![0; config.arrangement.len()];
    for (i, p) in config.sampling.parts() {
        for c in p.channels.iter().flatten() {
            part[usize::from(*c)] = i;
        }
    }
    part
}

/// `PARITY=SEED`: the parity space's χ² per 0.2 s of one fault-free run (mean over the sets,
/// against its degrees of freedom) and, per part, how much of it that part's removal explains.
fn parity_over_time(seed: u64) {
    use estimator_core::parity::Parity;
    use estimator_core::ChannelMask;
    let mut sc = e2e_tests::faults::mixed(seed);
    let loaded = sc.arrangement().load("arrangement.toml").unwrap();
    // `BIAS=PART,K`: a bias jump of K σ of one ADXL355 sample on that part from 3 s.
    if let Ok(b) = std::env::var("BIAS") {
        let (part, k) = b.split_once(',').unwrap();
        let part: usize = part.parse().unwrap();
        let k: f64 = k.parse().unwrap();
        let mut f = e2e_tests::faults::bias_jump(k * loaded.arrangement.channels()[0].noise);
        f.part = sc.parts[part].name.clone();
        f.start = 3.0;
        sc.faults.push(f);
    }
    let config = firmware_config(&sc, &loaded, Alignment::Interpolate).unwrap();
    let n = loaded.names.len();
    let part: Vec<u8> = channel_parts(&config).iter().map(|&i| i as u8).collect();
    let par = Parity::<f64, { hal_sim::arrangement_file::HOST_CAP }>::build(
        &loaded.arrangement,
        ChannelMask::all(n),
        &part,
    )
    .unwrap();
    let mut acc = (0.0, [0.0; 8], 0usize);
    let mut p = vec![f64::NAN; n];
    let mut mon = estimator_core::fault_monitor::FaultMonitor::<
        f64,
        { hal_sim::arrangement_file::HOST_CAP },
    >::new(Default::default(), 100.0);
    mon.set_parity(Some(par.clone()));
    run_firmware(&sc, &config, sc.samples() as u32, &mut |set, _, tr| {
        let t = tr.t;
        for_each_channel(&config.sampling, set, |c, x| p[c] = f64::from(x));
        let v = mon.step(&p);
        if let Some(s) = par.evaluate(&p) {
            acc.0 += s.chi2;
            for q in 0..8 {
                acc.1[q] += s.chi2 - s.without[q];
            }
            acc.2 += 1;
        }
        if (t * 100.0).round() as u64 % 20 == 19 && acc.2 > 0 {
            let k = acc.2 as f64;
            let parts: Vec<String> = acc.1.iter().map(|x| format!("{:.1}", x / k)).collect();
            println!(
                "t {t:5.2}: χ² {:6.1} (dof {}), explained by each part {parts:?} level {:.3} {v:?}",
                acc.0 / k,
                par.dof(),
                mon.level()
            );
            acc = (0.0, [0.0; 8], 0);
        }
    })
    .unwrap();
}

/// `ERR=SEED`: per part, the RMS and mean of (reading − eq. (4)) / declared noise per 0.2 s.
fn error_over_time(seed: u64, latest: bool) {
    let sc = e2e_tests::faults::mixed(seed);
    let loaded = sc.arrangement().load("arrangement.toml").unwrap();
    let al = if latest {
        Alignment::Latest
    } else {
        Alignment::Interpolate
    };
    let config = firmware_config(&sc, &loaded, al).unwrap();
    let n = loaded.names.len();
    let part = channel_parts(&config);
    let ch = loaded.arrangement.channels().to_vec();
    let mut acc = ([0.0f64; 8], [0.0f64; 8], [0usize; 8]);
    let mut p = vec![f64::NAN; n];
    run_firmware(&sc, &config, sc.samples() as u32, &mut |set, _, tr| {
        let t = tr.t;
        p.iter_mut().for_each(|x| *x = f64::NAN);
        for_each_channel(&config.sampling, set, |c, x| p[c] = f64::from(x));
        for c in 0..n {
            if p[c].is_finite() {
                let e = (p[c] - tr.channel(&ch[c].position, &ch[c].axis)) / ch[c].noise;
                acc.0[part[c]] += e * e;
                acc.1[part[c]] += e;
                acc.2[part[c]] += 1;
            }
        }
        if (t * 100.0).round() as u64 % 20 == 19 {
            let s: Vec<String> = (0..8)
                .map(|q| {
                    format!(
                        "{:.2}/{:+.2}",
                        (acc.0[q] / acc.2[q].max(1) as f64).sqrt(),
                        acc.1[q] / acc.2[q].max(1) as f64
                    )
                })
                .collect();
            println!("t {t:5.2}: rms/mean per part {s:?}");
            acc = ([0.0; 8], [0.0; 8], [0; 8]);
        }
    })
    .unwrap();
}
