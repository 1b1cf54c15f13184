//! Probe (issue 17): which parts the fault monitor takes out in fault-free runs of the mixed
//! layout, and for how long, and when the rows flagged 64 fall (per second of the run).
//!
//! `cargo run --release -p e2e-tests --example mixed_probe`
use ballisto_fw::config::Alignment;
use hal_sim::firmware_host::{firmware_config, run_firmware};

fn main() {
    for seed in 1000..1020u64 {
        let sc = e2e_tests::faults::mixed(seed);
        let loaded = sc.arrangement().load("arrangement.toml").unwrap();
        let config = firmware_config(&sc, &loaded, Alignment::Interpolate).unwrap();
        let mut out = [0usize; 8];
        let mut first = [f64::NAN; 8];
        let mut flagged = 0;
        let mut hist = [0usize; 12];
        run_firmware(&sc, &config, sc.samples() as u32, &mut |_, m, _| {
            let t = m.t as f64 * 1e-9;
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
