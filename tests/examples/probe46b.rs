use e2e_tests::nine::{self, Params};
use estimator_core::{Estimator, Model};
use hal_sim::arrangement_file::HOST_CAP;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let layout: u64 = args[1].parse().unwrap();
    let slow = args[2] == "slow";
    let t0: f64 = args[3].parse().unwrap();
    let t1: f64 = args[4].parse().unwrap();
    let p = Params { rate_hz: 1000.0, noise: 2e-3, arm: 0.12, seconds: t1 + 0.01, seed: if layout == 0 { 1 } else { layout }, manoeuvre: slow };
    let case = if layout == 0 { nine::make(p) } else { nine::make_random(p, layout, slow) };
    let mut o = case.options; o.raw = true;
    let mut e = Estimator::<f64, HOST_CAP>::new(&case.loaded.arrangement, Model::FreeFloat, o).unwrap();
    for (tr, p) in case.truth.iter().zip(case.outputs.iter()) {
        let r = *e.update(tr.t, p);
        if tr.t >= t0 && tr.t <= t1 {
            let (st, cands) = e.debug_states();
            let d = |a: &[f64;3], b: &[f64;3]| (0..3).map(|i| (a[i]-b[i]).powi(2)).sum::<f64>().sqrt();
            println!("t={:.3} out_err={:.3} flags={} margin={:.1} truth={:.3?} dtruth={:.2?}", tr.t, d(&r.omega,&tr.omega), r.flags.0, r.branch_margin, tr.omega, tr.domega);
            let nb = r.branches as usize;
            for (i, c) in cands.iter().enumerate().take(nb) {
                let neg = c.omega.map(|v| -v);
                println!("   cand {i}: |Ω-tr| {:.3} / {:.3} (neg) sdw {:.3} dΩ err {:.2} sdd {:.2} fit {:.2}", d(&c.omega,&tr.omega), d(&neg,&tr.omega), c.omega_var.sqrt(), d(&c.domega,&tr.domega), c.domega_var.sqrt(), c.fit);
            }
            for s in st.iter().filter(|s| s.cost < 0.01 || std::env::var("ALL").is_ok()) {
                println!("   st c{} s{:+} cost {:.1} |Ω-tr| {:.3} |Ω′-tr| {:.2} P [{:.2e} {:.2e} {:.2e}]", s.candidate, s.sign, s.cost, d(&s.omega,&tr.omega), d(&s.domega,&tr.domega), s.p_ww[0][0], s.p_wd[0][0], s.p_dd[0][0]);
            }
        }
    }
}
