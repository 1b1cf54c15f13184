use ballisto_fw::config::Alignment;
use hal_sim::firmware_host::{firmware_config, run_firmware};
fn main() {
    let mut sc = e2e_tests::faults::mixed(2002);
    sc.parts.remove(5);
    let loaded = sc.arrangement().load("arrangement.toml").unwrap();
    let config = firmware_config(&sc, &loaded, Alignment::Interpolate).unwrap();
    let mut k = 0;
    run_firmware(&sc, &config, sc.samples() as u32, &mut |_, m, tr| {
        let (err, s) = e2e_tests::faults::firmware_omega_error(&m.estimate, tr.omega);
        let e = &m.estimate;
        if s || (k % 50 == 0) {
            println!("k={k} t={:.3} err={err:.3} silent={s} flags={} margin={:.1} |Ω|={:.2} sd={:.3?} Ω′={:.2?}", tr.t, e.flags.0, e.branch_margin, (tr.omega.iter().map(|v| v*v).sum::<f64>()).sqrt(), e.sd_omega, tr.domega);
        }
        k += 1;
    }).unwrap();
}
