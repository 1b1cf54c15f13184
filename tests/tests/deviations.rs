//! The reported standard deviations are calibrated: the RMS of error / deviation (per
//! component, raw output) is close to 1 on the families of the accuracy tests, for σ0, Ω′, Ω
//! and the components of A.

use ballisto_config::arrangement_file::HOST_CAP;
use e2e_tests::cases::{make, Family, MotionKind};
use estimator_core::{Estimator, Model, Options};

/// RMS of the normalised errors of σ0, Ω′, Ω (raw output).
fn z_rms(f: Family, m: MotionKind, model: Model, seed: u64) -> [f64; 4] {
    z_rms_mode(f, m, model, seed, true)
}

/// RMS of the normalised errors of σ0, Ω′, Ω; `raw = false`: Ω is the filtered rate.
fn z_rms_mode(f: Family, m: MotionKind, model: Model, seed: u64, raw: bool) -> [f64; 4] {
    let case = make(f, m, model, seed, 1500);
    let options = Options {
        raw,
        initial_omega: Some(case.truth[0].omega),
        ..Default::default()
    };
    let mut e =
        Estimator::<f64, HOST_CAP>::new(&case.loaded.arrangement, case.model, options).unwrap();
    let mut z = [0.0f64; 4];
    let mut na = 0.0;
    let mut n = 0.0;
    for (tr, p) in case.truth.iter().zip(case.outputs.iter()) {
        let r = e.update(tr.t, p);
        for k in 0..3 {
            z[0] += ((r.sigma0[k] - tr.sigma0[k]) / r.sd_sigma0[k]).powi(2);
            z[1] += ((r.domega[k] - tr.domega[k]) / r.sd_domega[k]).powi(2);
            z[2] += ((r.omega[k] - tr.omega[k]) / r.sd_omega[k]).powi(2);
        }
        for k in 0..6 {
            z[3] += ((r.field.0[k] - tr.field.0[k]) / r.sd_field.0[k]).powi(2);
        }
        n += 3.0;
        na += 6.0;
    }
    let out = [
        (z[0] / n).sqrt(),
        (z[1] / n).sqrt(),
        (z[2] / n).sqrt(),
        (z[3] / na).sqrt(),
    ];
    println!(
        "{} raw={raw}: RMS(error/sd) σ0 {:.2}  Ω′ {:.2}  Ω {:.2}  A {:.2}",
        case.name, out[0], out[1], out[2], out[3]
    );
    out
}

#[test]
fn deviations_match_the_errors() {
    for (f, m, model, seed) in [
        (Family::Tetrahedron, MotionKind::Tumble, Model::General, 1),
        (Family::Irregular, MotionKind::Tumble, Model::General, 5),
        (
            Family::MixedNoise,
            MotionKind::Manoeuvre,
            Model::General,
            12,
        ),
        (Family::Tetrahedron, MotionKind::Tumble, Model::FreeFloat, 2),
        (
            Family::Irregular,
            MotionKind::Manoeuvre,
            Model::FreeFloat,
            6,
        ),
    ] {
        for z in z_rms(f, m, model, seed) {
            assert!((0.85..1.2).contains(&z), "RMS(error/sd) = {z}");
        }
    }
}

/// With m = 3 (9 channels, model F) the solve is close to branch points now and then, where
/// first-order deviations are too small: reported, and bounded loosely.
#[test]
fn nine_channel_deviations_are_reported() {
    for z in z_rms(Family::NineChannel, MotionKind::Tumble, Model::FreeFloat, 8) {
        assert!((0.85..2.0).contains(&z), "RMS(error/sd) = {z}");
    }
}

/// The filtered rate's deviation (the chosen hypothesis' filter variance, one scalar for the
/// three components) must not be optimistic (RMS(error/sd) ≤ 1.25); it errs on the safe side
/// (0.75–0.79 on these cases when this test was written: the filter ignores the correlation
/// between successive Ω′ terms of its prediction), and must stay within 40 % of the errors.
#[test]
fn filtered_rate_deviation_matches_its_errors() {
    for (f, m, model, seed) in [
        (Family::Tetrahedron, MotionKind::Tumble, Model::General, 1),
        (
            Family::Irregular,
            MotionKind::Manoeuvre,
            Model::FreeFloat,
            6,
        ),
        (
            Family::MixedNoise,
            MotionKind::Manoeuvre,
            Model::General,
            12,
        ),
    ] {
        let z = z_rms_mode(f, m, model, seed, false)[2];
        assert!((0.6..1.25).contains(&z), "filtered Ω: RMS(error/sd) = {z}");
    }
}
