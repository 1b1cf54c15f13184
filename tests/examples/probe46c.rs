use e2e_tests::nine::{self, Params};
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let layout: u64 = args[1].parse().unwrap();
    let slow = args[2] == "slow";
    let raw = args.get(3).is_none_or(|a| a != "fused");
    let p = Params {
        rate_hz: 1000.0,
        noise: 2e-3,
        arm: 0.12,
        seconds: 20.0,
        seed: layout,
        manoeuvre: slow,
    };
    let case = nine::make_random(p, layout, slow);
    let rows = case.forward(raw);
    let fused = case.forward(false);
    let mut n = 0;
    for ((r, f), tr) in rows.iter().zip(fused.iter()).zip(case.truth.iter()) {
        let z: Vec<f64> = (0..3)
            .map(|i| (r.omega[i] - tr.omega[i]) / r.sd_omega[i])
            .collect();
        if r.flags.0 == 0 && z.iter().any(|v| v.abs() > 5.0) {
            n += 1;
            if n % 20 == 1 {
                let d = (0..3)
                    .map(|i| (r.omega[i] - f.omega[i]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                println!("t={:.3} z={:.1?} sd={:.3?} err={:.3?} fused_err={:.3?} fused_sd={:.3?} |raw-fused|={:.3} margin={:.1}", tr.t, z, r.sd_omega, (0..3).map(|i| r.omega[i]-tr.omega[i]).collect::<Vec<_>>(), (0..3).map(|i| f.omega[i]-tr.omega[i]).collect::<Vec<_>>(), f.sd_omega, d, r.branch_margin);
            }
        }
    }
    println!("{n} silent");
}
