use e2e_tests::cases::{make, Family, MotionKind};
use estimator_core::{Estimator, Model, Options};
use hal_sim::arrangement_file::HOST_CAP;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let fam = match args[1].as_str() {
        "irregular" => Family::Irregular,
        "tetra" => Family::Tetrahedron,
        "nine" => Family::NineChannel,
        _ => Family::MixedNoise,
    };
    let motion = if args[2] == "tumble" {
        MotionKind::Tumble
    } else {
        MotionKind::Manoeuvre
    };
    let model = if args[3] == "g" {
        Model::General
    } else {
        Model::FreeFloat
    };
    let seed: u64 = args[4].parse().unwrap();
    let case = make(fam, motion, model, seed, 1500);
    let o = Options {
        raw: true,
        ..Default::default()
    };
    let mut e = Estimator::<f64, HOST_CAP>::new(&case.loaded.arrangement, case.model, o).unwrap();
    let ml = e2e_tests::ml::MlReference::new(&case.loaded, case.model);
    let mut rows = vec![];
    for (k, (tr, p)) in case.truth.iter().zip(case.outputs.iter()).enumerate() {
        let r = *e.update(tr.t, p);
        let m = ml.estimate(p, &tr.omega);
        let es = (0..3)
            .map(|i| (r.sigma0[i] - tr.sigma0[i]).powi(2))
            .sum::<f64>();
        let ms = (0..3)
            .map(|i| (m.sigma0[i] - tr.sigma0[i]).powi(2))
            .sum::<f64>();
        let ew = (0..3)
            .map(|i| (r.omega[i] - tr.omega[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        let mw = (0..3)
            .map(|i| (m.omega[i] - tr.omega[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        rows.push((
            es - ms,
            k,
            tr.t,
            ew,
            mw,
            r.flags.0,
            r.branch_margin,
            r.branches,
        ));
    }
    let tot: f64 = rows.iter().map(|r| r.0).sum();
    rows.sort_by(|a, b| b.0.total_cmp(&a.0));
    println!("excess σ0² sum {tot:.4}");
    for r in rows.iter().take(15) {
        println!("{:?}", r);
    }
}
