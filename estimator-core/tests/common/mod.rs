//! Helpers shared by estimator-core's integration tests: random arrangements and fields, the
//! ideal outputs of paper eq. (4).
#![allow(dead_code)]

use estimator_core::linalg::{cross, dot, Sym3};
use estimator_core::{Arrangement, Model};
use rand::Rng;

pub const CAP: usize = 32;

/// Ideal output of a channel (paper eq. 4): `p = s·σ0 + (R × s)·Ω′ + s·A R`.
pub fn ideal(
    pos: &[f64; 3],
    axis: &[f64; 3],
    sigma0: &[f64; 3],
    domega: &[f64; 3],
    a: &Sym3<f64>,
) -> f64 {
    dot(axis, sigma0) + dot(&cross(pos, axis), domega) + dot(axis, &a.mul_vec(pos))
}

/// A vector with components uniform in `(−half, half)`, drawn x, y, z in turn.
pub fn uniform3<R: Rng>(rng: &mut R, half: f64) -> [f64; 3] {
    core::array::from_fn(|_| rng.gen_range(-half..half))
}

pub fn unit<R: Rng>(rng: &mut R) -> [f64; 3] {
    loop {
        let v = uniform3(rng, 1.0);
        let n: f64 = dot(&v, &v);
        if n > 0.05 && n <= 1.0 {
            let n = n.sqrt();
            return [v[0] / n, v[1] / n, v[2] / n];
        }
    }
}

/// A random arrangement of `n` channels (positions within ±0.2 m, random axes) that the model
/// accepts.
pub fn random_arrangement<R: Rng>(
    rng: &mut R,
    n: usize,
    model: Model,
    noise: f64,
) -> Arrangement<CAP> {
    loop {
        let mut arr = Arrangement::<CAP>::new();
        for _ in 0..n {
            let pos = uniform3(rng, 0.2);
            arr.push(pos, unit(rng), noise).unwrap();
        }
        if estimator_core::Estimator::<f64, CAP>::new(&arr, model, Default::default()).is_ok() {
            return arr;
        }
    }
}

/// Outputs of every channel for a field.
pub fn outputs(
    arr: &Arrangement<CAP>,
    sigma0: &[f64; 3],
    domega: &[f64; 3],
    a: &Sym3<f64>,
) -> Vec<f64> {
    arr.channels()
        .iter()
        .map(|c| ideal(&c.position, &c.axis, sigma0, domega, a))
        .collect()
}

pub fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}
