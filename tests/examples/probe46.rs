use e2e_tests::nine::{self, Params};
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let layout: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(0);
    let slow = args.get(2).is_some_and(|s| s == "slow");
    let p = Params {
        rate_hz: 1000.0,
        noise: 2e-3,
        arm: 0.12,
        seconds: 20.0,
        seed: if layout == 0 { 1 } else { layout },
        manoeuvre: slow,
    };
    let case = if layout == 0 {
        nine::make(p)
    } else {
        nine::make_random(p, layout, slow)
    };
    let rows = case.forward(true);
    let ml = case.ml_errors();
    let mut last_bad = false;
    for (k, (r, tr)) in rows.iter().zip(case.truth.iter()).enumerate() {
        let e = (0..3)
            .map(|i| (r.omega[i] - tr.omega[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        let bad = e > std::env::var("TH")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(1.0);
        if bad != last_bad {
            println!("t={:.3} err={:.3} ml={:.3} flags={} margin={:.1} omega={:.3?} truth={:.3?} sd={:.3}", tr.t, e, ml[k][2].sqrt(), r.flags.0, r.branch_margin, r.omega, tr.omega, r.sd_omega[0]);
        }
        last_bad = bad;
    }
}
