//! Probe (issue 17): which parts the fault monitor takes out in fault-free runs of the mixed
//! layout, and for how long, and when the rows flagged 64 fall (per second of the run).
//!
//! `cargo run --release -p e2e-tests --example mixed_probe`
use ballisto_fw::config::Alignment;
use hal_sim::firmware_host::{firmware_config, for_each_channel, run_firmware};

fn main() {
    if let Some(seed) = std::env::var("PARITY").ok().and_then(|s| s.parse().ok()) {
        parity_over_time(seed);
        return;
    }
    for seed in 1000..1020u64 {
        let sc = e2e_tests::faults::mixed(seed);
        let loaded = sc.arrangement().load("arrangement.toml").unwrap();
        let config = firmware_config(&sc, &loaded, Alignment::Interpolate).unwrap();
        let mut out = [0usize; 8];
        let mut first = [f64::NAN; 8];
        let mut flagged = 0;
        let mut hist = [0usize; 12];
        run_firmware(&sc, &config, sc.samples() as u32, &mut |_, m, tr| {
            // The set's simulated instant (the report's `t` is on-board time, from boot).
            let t = tr.t;
            let f = m.estimate.flags.has(estimator_core::Flags::RESIDUAL_HIGH);
            flagged += usize::from(f);
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
        println!("seed {seed}: rows out per part {out:?}, from {first:?}, flagged 64 {flagged} per second {hist:?}");
    }
}

/// `PARITY=SEED`: the parity space's χ² per 0.2 s of one fault-free run (mean over the sets,
/// against its degrees of freedom) and, per part, how much of it that part's removal explains.
fn parity_over_time(seed: u64) {
    use estimator_core::parity::Parity;
    use estimator_core::ChannelMask;
    let sc = e2e_tests::faults::mixed(seed);
    let loaded = sc.arrangement().load("arrangement.toml").unwrap();
    let config = firmware_config(&sc, &loaded, Alignment::Interpolate).unwrap();
    let n = loaded.names.len();
    let mut part = vec![0u8; n];
    for (i, p) in config.sampling.parts() {
        for c in p.channels.iter().flatten() {
            part[usize::from(*c)] = i as u8;
        }
    }
    let par = Parity::<f64, { hal_sim::arrangement_file::HOST_CAP }>::build(
        &loaded.arrangement,
        ChannelMask::all(n),
        &part,
    )
    .unwrap();
    let mut acc = (0.0, [0.0; 8], 0usize);
    let mut p = vec![f64::NAN; n];
    run_firmware(&sc, &config, sc.samples() as u32, &mut |set, _, tr| {
        let t = tr.t;
        for_each_channel(&config.sampling, set, |c, x| p[c] = f64::from(x));
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
                "t {t:5.2}: χ² {:6.1} (dof {}), explained by each part {parts:?}",
                acc.0 / k,
                par.dof()
            );
            acc = (0.0, [0.0; 8], 0);
        }
    })
    .unwrap();
}
