//! Noise-free: random arrangements and random fields are reproduced to single-precision
//! accuracy, both models, m = 3 and m > 3, in f32 (the target scalar) and f64.

mod common;

use common::*;
use estimator_core::linalg::Sym3;
use estimator_core::{Estimator, Flags, Model, Options};
use proptest::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

struct Case {
    arr: estimator_core::Arrangement<CAP>,
    sigma0: [f64; 3],
    domega: [f64; 3],
    omega: [f64; 3],
    a: Sym3<f64>,
    p: Vec<f64>,
}

fn case(seed: u64, n: usize, model: Model) -> Case {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let arr = random_arrangement(&mut rng, n, model, NOISE);
    let sigma0 = uniform3(&mut rng, 10.0);
    let domega = uniform3(&mut rng, 5.0);
    let dir = unit(&mut rng);
    let mag = rng.gen_range(0.5..6.0);
    let omega = [dir[0] * mag, dir[1] * mag, dir[2] * mag];
    let a = Sym3::skew_squared(&omega);
    let p = outputs(&arr, &sigma0, &domega, &a);
    Case {
        arr,
        sigma0,
        domega,
        omega,
        a,
        p,
    }
}

use rand::Rng;

/// Relative error bound for single precision through a well-conditioned solve.
const TOL_F32: f64 = 1e-4;
const TOL_F64: f64 = 1e-8;
/// Channel noise of the random arrangements.
const NOISE: f64 = 0.01;

fn run<T: estimator_core::Real>(
    c: &Case,
    model: Model,
    p: &[f64],
) -> estimator_core::Estimate<f64> {
    // The rate hint picks the branch and the sign. With m > 3 an approximate gyro reading
    // (10 % off) is enough; with m = 3 every branch fits a single sample exactly and mirror
    // branches can lie arbitrarily close to the truth, so the hint is the true rate (as the
    // tracker's prediction would be): branch *tracking* is tested on sequences elsewhere.
    let m3 = c.arr.len() == model.min_channels();
    let hint = if m3 {
        c.omega
    } else {
        [c.omega[0] * 1.1, c.omega[1] * 0.95, c.omega[2] * 1.05]
    };
    let options = Options {
        raw: true,
        initial_omega: Some(hint),
        ..Default::default()
    };
    let mut est = Estimator::<T, CAP>::new(&c.arr, model, options).unwrap();
    let p: Vec<T> = p.iter().map(|v| T::of(*v)).collect();
    let e = est.update(0.0, &p);
    let f = |v: [T; 3]| [v[0].to_f64(), v[1].to_f64(), v[2].to_f64()];
    estimator_core::Estimate::<f64> {
        sigma0: f(e.sigma0),
        domega: f(e.domega),
        omega: f(e.omega),
        field: e.field.cast(),
        flags: e.flags,
        ..Default::default()
    }
}

fn errors(e: &estimator_core::Estimate<f64>, c: &Case) -> [f64; 4] {
    let fe = e
        .field
        .0
        .iter()
        .zip(c.a.0.iter())
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    [
        dist(&e.sigma0, &c.sigma0),
        dist(&e.domega, &c.domega),
        dist(&e.omega, &c.omega),
        fe,
    ]
}

/// Runs the estimator in scalar `T` and checks every output against the truth within
/// `tol` relative, plus what rounding at `T`'s precision costs on this arrangement and field:
/// the error of the f64 estimator when the inputs are perturbed at the level of `T`'s rounding
/// (relative `EPSILON`, times √N for the accumulation in `W p`), ×10. Near a branch point or an
/// ill-conditioned geometry this allowance grows; on well-conditioned cases it is tiny.
fn check<T: estimator_core::Real>(c: &Case, model: Model, tol: f64) -> Result<(), TestCaseError> {
    let e = run::<T>(c, model, &c.p);
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let pmax = c.p.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let level = T::EPSILON.to_f64() * pmax * (c.p.len() as f64).sqrt();
    let mut rounding = [0.0f64; 4];
    for _ in 0..4 {
        let pp: Vec<f64> =
            c.p.iter()
                .map(|v| v + level * rng.gen_range(-1.0..1.0))
                .collect();
        let r = errors(&run::<f64>(c, model, &pp), c);
        for (a, b) in rounding.iter_mut().zip(r.iter()) {
            *a = a.max(*b);
        }
    }
    let norm = |v: &[f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let an: f64 = c.a.0.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let scales = [norm(&c.sigma0), norm(&c.domega), norm(&c.omega), an];
    let err = errors(&e, c);
    for (k, what) in ["σ0", "Ω′", "Ω", "A"].iter().enumerate() {
        // Flagged ill-conditioned (the a solve nearly singular, e.g. near a branch point): the
        // estimator says its answer is fragile and makes no single-precision claim there; such
        // cases are counted by `ill_conditioned_cases_are_rare`.
        if e.flags.has(Flags::ILL_CONDITIONED) {
            return Ok(());
        }
        let allow = tol * scales[k].max(1.0) + 10.0 * rounding[k];
        prop_assert!(
            err[k] <= allow,
            "{what}: error {:.3e} > allowed {:.3e}; estimate {:?}",
            err[k],
            allow,
            e
        );
    }
    prop_assert!(!e.flags.has(Flags::SIGN_UNRESOLVED));
    Ok(())
}

/// 64 cases per property from a fixed seed, so that every run (CI's too) tests the same
/// cases; `PROPTEST_RNG_SEED=<u64>` explores others. A random run found one case
/// over the f32 allowance (`free_float_m3_f32`, seed 12842777805399392453: Ω′ off by 3.9e-3
/// rad/s², 2e-3 relative, against 2.9e-3 allowed — the f32 arithmetic of the precomputed
/// solve, which the allowance's input rounding does not model; 25 × below what the channels'
/// noise does to Ω′): `docs/estimator.md` says so, the allowance is not widened for it.
fn config() -> ProptestConfig {
    let default = ProptestConfig::default();
    let rng_seed = match std::env::var_os("PROPTEST_RNG_SEED") {
        Some(_) => default.rng_seed,
        None => proptest::test_runner::RngSeed::Fixed(0x0B41_1157),
    };
    ProptestConfig {
        cases: 64,
        rng_seed,
        ..default
    }
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn general_m3_f32(seed in any::<u64>()) { check::<f32>(&case(seed, 12, Model::General), Model::General, TOL_F32)?; }
    #[test]
    fn general_m3_f64(seed in any::<u64>()) { check::<f64>(&case(seed, 12, Model::General), Model::General, TOL_F64)?; }
    #[test]
    fn general_m_gt3_f32(seed in any::<u64>(), n in 13usize..=24) { check::<f32>(&case(seed, n, Model::General), Model::General, TOL_F32)?; }
    #[test]
    fn general_m_gt3_f64(seed in any::<u64>(), n in 13usize..=24) { check::<f64>(&case(seed, n, Model::General), Model::General, TOL_F64)?; }
    #[test]
    fn free_float_m3_f32(seed in any::<u64>()) { check::<f32>(&case(seed, 9, Model::FreeFloat), Model::FreeFloat, TOL_F32)?; }
    #[test]
    fn free_float_m3_f64(seed in any::<u64>()) { check::<f64>(&case(seed, 9, Model::FreeFloat), Model::FreeFloat, TOL_F64)?; }
    #[test]
    fn free_float_m_gt3_f32(seed in any::<u64>(), n in 10usize..=24) { check::<f32>(&case(seed, n, Model::FreeFloat), Model::FreeFloat, TOL_F32)?; }
    #[test]
    fn free_float_m_gt3_f64(seed in any::<u64>(), n in 10usize..=24) { check::<f64>(&case(seed, n, Model::FreeFloat), Model::FreeFloat, TOL_F64)?; }
}

/// How often the f32 per-sample solve flags a random (arrangement, field) pair ill-conditioned;
/// those are exempt from the accuracy claim above, so they must stay rare.
#[test]
fn ill_conditioned_cases_are_rare() {
    for (n, model) in [
        (12, Model::General),
        (9, Model::FreeFloat),
        (16, Model::General),
        (12, Model::FreeFloat),
    ] {
        let trials = 400;
        let mut flagged = 0;
        for seed in 0..trials {
            let c = case(seed, n, model);
            if run::<f32>(&c, model, &c.p)
                .flags
                .has(Flags::ILL_CONDITIONED)
            {
                flagged += 1;
            }
        }
        let frac = flagged as f64 / trials as f64;
        println!(
            "N = {n}, {model:?}: {flagged}/{trials} flagged ill-conditioned ({:.1} %)",
            100.0 * frac
        );
        assert!(
            frac < 0.05,
            "N = {n}, {model:?}: {:.1} % of random cases flagged ill-conditioned",
            100.0 * frac
        );
    }
}

/// Model F with a known gravity-gradient tensor Γ (exaggerated so it matters): the field
/// `A = Γ + {Ω}²` and every output are reproduced; ignoring Γ biases them.
#[test]
fn free_float_with_known_gamma() {
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    let arr = random_arrangement(&mut rng, 12, Model::FreeFloat, NOISE);
    let gamma = Sym3([0.4, -0.1, -0.3, 0.05, -0.02, 0.07]); // traceless
    let omega = [0.8, -1.1, 0.6];
    let sigma0 = [0.2, -0.1, 9.0];
    let domega = [0.3, 0.1, -0.2];
    let a = gamma.add_scaled(1.0, &Sym3::skew_squared(&omega));
    let p = outputs(&arr, &sigma0, &domega, &a);
    let run = |g: Sym3<f64>| {
        let options = Options {
            raw: true,
            initial_omega: Some(omega),
            gamma: g,
            ..Options::default()
        };
        let mut est = Estimator::<f64, CAP>::new(&arr, Model::FreeFloat, options).unwrap();
        *est.update(0.0, &p)
    };
    let e = run(gamma);
    assert!(dist(&e.omega, &omega) < 1e-8, "{:?}", e.omega);
    assert!(dist(&e.sigma0, &sigma0) < 1e-8 && dist(&e.domega, &domega) < 1e-8);
    for (got, want) in e.field.0.iter().zip(a.0.iter()) {
        assert!((got - want).abs() < 1e-8);
    }
    let biased = run(Sym3::zero());
    assert!(
        dist(&biased.omega, &omega) > 1e-3,
        "Γ must matter in this test"
    );
}
