//! The joint fit on synthetic records.

use super::*;
use estimator_core::G0;
use nalgebra::SymmetricEigen;

/// The joint normal matrix with the field projected out is positive semi-definite (a
/// Schur complement), to round-off.
#[test]
fn the_projected_normal_matrix_is_positive_semidefinite() {
    let mut x = 0x9E37_79B9_7F4A_7C15u64;
    let mut u = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let geo: Vec<Geometry> = (0..12)
        .map(|i| {
            let c = [
                [1.0, 1.0, 1.0],
                [1.0, -1.0, -1.0],
                [-1.0, 1.0, -1.0],
                [-1.0, -1.0, 1.0],
            ][i / 3];
            let mut axis = Vector3::new(u() * 0.01, u() * 0.01, u() * 0.01);
            axis[i % 3] = 1.0;
            Geometry {
                position: Vector3::from(c) * 0.1,
                axis: axis.normalize(),
                scale: 1.0,
                bias: 0.0,
                noise: 1e-3,
            }
        })
        .collect();
    let n_samples = 2000;
    let rows: Vec<Vec<f64>> = (0..n_samples)
        .map(|_| (0..12).map(|_| u() * 10.0).collect())
        .collect();
    let motion: Vec<usize> = (0..n_samples).collect();
    let poses: Vec<Pose> = (0..10)
        .map(|k| Pose {
            samples: k * 300..(k + 1) * 300,
            mean: (0..12).map(|_| u() * 10.0).collect(),
        })
        .collect();
    let gravity: Vec<Vector3<f64>> = (0..10)
        .map(|_| Vector3::new(u(), u(), u()).normalize() * G0)
        .collect();
    let record = Record {
        rows: &rows,
        times: &[],
        poses: &poses,
        motion: &motion,
        gamma: Matrix3::zeros(),
        progress: &|_| {},
        rate_prior: None,
    };
    let fields: Vec<Option<Field>> = (0..n_samples)
        .map(|_| {
            Some(Field {
                sigma0: Vector3::new(u(), u(), u()) * 20.0,
                domega: Vector3::new(u(), u(), u()) * 4.0,
                omega: Vector3::new(u(), u(), u()) * 6.0,
                omega_var: 0.0,
            })
        })
        .collect();
    for with_omega in [false, true] {
        let (normal, _) = joint_normal_equations(
            &geo,
            &record,
            &fields,
            &gravity,
            with_omega,
            &Scatter::white(&geo),
        );
        let tol = Tolerance::default();
        let d = DVector::from_fn(84, |p, _| tol.of(p % 7));
        let ns = DMatrix::from_fn(84, 84, |a, b| normal[(a, b)] * d[a] * d[b]);
        let e = SymmetricEigen::new(ns).eigenvalues;
        println!(
            "with_omega {with_omega}: eigenvalues {:.3e} .. {:.3e}",
            e.min(),
            e.max()
        );
        assert!(
            e.min() > -1e-9 * e.max(),
            "min {:e} max {:e}",
            e.min(),
            e.max()
        );
    }
}
