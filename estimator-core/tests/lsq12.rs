//! Model G's `A` equals the 12-unknown linear least squares (σ0, Ω′, six components of A) at
//! the optimum: an independent check of the 9-column + quadratic path (the 12-unknown solve
//! exists only here, in the tests).

mod common;

use common::*;
use estimator_core::linalg::{cross, Sym3};
use estimator_core::{Estimator, Model, Options};
use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

#[test]
fn general_model_matches_twelve_unknown_least_squares_with_noise() {
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    let mut checked = 0;
    for trial in 0..60 {
        let n = rng.gen_range(13..=24);
        let noise = 0.01;
        let arr = random_arrangement(&mut rng, n, Model::General, noise);
        let sigma0 = uniform3(&mut rng, 5.0);
        let domega = uniform3(&mut rng, 3.0);
        let d = unit(&mut rng);
        let omega = [d[0] * 3.0, d[1] * 3.0, d[2] * 3.0];
        let a = Sym3::skew_squared(&omega);
        let mut p = outputs(&arr, &sigma0, &domega, &a);
        for v in p.iter_mut() {
            *v += noise * rng.gen_range(-1.7..1.7);
        }
        // 12-unknown weighted linear least squares.
        let mut g = DMatrix::<f64>::zeros(n, 12);
        let mut y = DVector::<f64>::zeros(n);
        for (i, c) in arr.channels().iter().enumerate() {
            let (s, r) = (c.axis, c.position);
            let rxs = cross(&r, &s);
            let row = [
                s[0],
                s[1],
                s[2],
                rxs[0],
                rxs[1],
                rxs[2],
                s[0] * r[0],
                s[1] * r[1],
                s[2] * r[2],
                s[0] * r[1] + s[1] * r[0],
                s[0] * r[2] + s[2] * r[0],
                s[1] * r[2] + s[2] * r[1],
            ];
            for (j, v) in row.iter().enumerate() {
                g[(i, j)] = v / c.noise;
            }
            y[i] = p[i] / c.noise;
        }
        let x = g.svd(true, true).solve(&y, 1e-12).unwrap();
        let lsq = [x[6], x[7], x[8], x[9], x[10], x[11]];

        let options = Options {
            raw: true,
            initial_omega: Some(omega),
            ..Default::default()
        };
        let mut est = Estimator::<f64, CAP>::new(&arr, Model::General, options).unwrap();
        let e = est.update(0.0, &p);
        let scale = lsq.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        for (k, (got, want)) in e.field.0.iter().zip(lsq.iter()).enumerate() {
            assert!(
                (got - want).abs() <= 1e-7 * scale,
                "trial {trial} (N = {n}): A[{k}] = {got} but 12-unknown least squares gives {want}"
            );
        }
        for k in 0..3 {
            assert!(
                (e.sigma0[k] - x[k]).abs() <= 1e-7 * scale,
                "trial {trial}: σ0 differs"
            );
            assert!(
                (e.domega[k] - x[3 + k]).abs() <= 1e-7 * scale,
                "trial {trial}: Ω′ differs"
            );
        }
        checked += 1;
    }
    assert_eq!(checked, 60);
}
