use ballisto::samples_csv::SamplesReader;
use estimator_core::{Estimator, Model, Options};
use hal_sim::arrangement_file::{load_arrangement, HOST_CAP};
fn main() {
    let dir = std::path::Path::new("../shared/data/realdata/mimu4444_exp6");
    let loaded = load_arrangement(&dir.join("arrangement.toml")).unwrap();
    let mut reader = SamplesReader::open(&dir.join("samples.csv"), &loaded.names).unwrap();
    let raw = std::env::args().nth(1).is_some_and(|a| a == "raw");
    let mut e = Estimator::<f64, HOST_CAP>::new(&loaded.arrangement, Model::FreeFloat, Options { raw, ..Default::default() }).unwrap();
    let mut row = vec![0.0; loaded.names.len()];
    let mut k = 0;
    while let Some(t) = reader.next_row(&mut row).unwrap() {
        let r = *e.update(t, &row);
        let big = r.omega.iter().map(|v| v*v).sum::<f64>().sqrt() > 25.0; if big && k % 3 == 0 && k < 400 {
            let (st, _) = e.debug_states();
            for (i, c) in e.debug_states().1.iter().enumerate().take(r.branches as usize) { println!("   cand {i} Ω={:.2?} var={:.2e} fit={:.1}", c.omega, c.omega_cov.trace()/3.0, c.fit); }
            for s in e.debug_states().0 { println!("   st Ω={:.2?} Ω′={:.1?} cost={:.1} c{} s{}", s.omega, s.domega, s.cost, s.candidate, s.sign); }
            println!("k={k} t={t:.3} Ω={:.2?} sd={:.2?} flags={} margin={:.1} n={} br={}", r.omega, r.sd_omega, r.flags.0, r.branch_margin, st.len(), r.branches);
        }
        k += 1;
        if k > 1500 { break; }
    }
}
