use e2e_tests::cases::{make, Family, MotionKind};
use estimator_core::{Estimator, Model, Options};
use estimator_core::smoother::StepRecord;
use hal_sim::arrangement_file::HOST_CAP;
#[test] fn b() {
    let case = make(Family::NineChannel, MotionKind::Manoeuvre, Model::FreeFloat, 9, 1500);
    let mut e = Estimator::<f64, HOST_CAP>::new(&case.loaded.arrangement, case.model, Options { raw: true, ..Default::default() }).unwrap();
    let mut rec = StepRecord::default();
    for (k, (tr, p)) in case.truth.iter().zip(case.outputs.iter()).enumerate() {
        let r = e.update_with(tr.t, p, Some(&mut rec));
        let d = ((r.omega[0]-tr.omega[0]).powi(2)+(r.omega[1]-tr.omega[1]).powi(2)+(r.omega[2]-tr.omega[2]).powi(2)).sqrt();
        if (44..70).contains(&k) {
            if k > 70 { break; }
            let mut s = format!("k={k} err={d:.2} true Ω={:.2?} Ω′={:.2?} |", tr.omega, tr.domega);
            for c in 0..rec.n_candidates as usize { let ce = &rec.candidates[c]; s += &format!(" c{c}: Ω={:.2?} Ω′={:.2?} sd={:.2}", ce.omega, ce.domega, ce.sd_omega[0]); }
            s += " | states:";
            for st in &rec.states[..rec.n_states as usize] { s += &format!(" ({}{} {:.1} w={:.2?})", st.candidate, if st.sign>0 {'+'} else {'-'}, st.cost, st.omega); }
            println!("{s}");
        }
    }
}
