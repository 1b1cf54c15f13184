use e2e_tests::nine::{self, Params};
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let layout: u64 = args[1].parse().unwrap();
    let slow = args[2] == "slow";
    let t1: f64 = args[3].parse().unwrap();
    let step: usize = args[4].parse().unwrap();
    let p = Params {
        rate_hz: 1000.0,
        noise: 2e-3,
        arm: 0.12,
        seconds: t1,
        seed: layout,
        manoeuvre: slow,
    };
    let case = nine::make_random(p, layout, slow);
    let fused = case.forward(false);
    for (k, (f, tr)) in fused.iter().zip(case.truth.iter()).enumerate() {
        if k % step == 0 {
            let e: Vec<f64> = (0..3).map(|i| f.omega[i] - tr.omega[i]).collect();
            println!(
                "t={:.3} err={:.4?} sd={:.4?} flags={} |Ω′|={:.3}",
                tr.t,
                e,
                f.sd_omega,
                f.flags.0,
                (0..3).map(|i| tr.domega[i].powi(2)).sum::<f64>().sqrt()
            );
        }
    }
}
