//! The closed form finds every real branch: compared with a brute-force multi-start search
//! (Gauss–Newton from a dense set of starting points on spheres of several radii).

mod common;

use common::uniform3;
use estimator_core::internals::quadratic::{closed_form, gauss_newton, residual2, MAX_ROOTS};
use estimator_core::linalg::{add, norm2, sub, Sym3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn random_forms(rng: &mut ChaCha8Rng) -> [Sym3<f64>; 3] {
    core::array::from_fn(|_| Sym3(core::array::from_fn(|_| rng.gen_range(-1.0..1.0))))
}

/// Every distinct (up to sign) exact solution found by brute force.
fn brute_force(m: &[Sym3<f64>; 3], p: &[f64; 3], scale: f64) -> Vec<[f64; 3]> {
    let mut found: Vec<[f64; 3]> = Vec::new();
    let k = 12;
    for r in [0.3, 1.0, 3.0] {
        for i in 0..k {
            for j in 0..2 * k {
                let th = std::f64::consts::PI * (i as f64 + 0.5) / k as f64;
                let ph = std::f64::consts::PI * j as f64 / k as f64;
                let s = [
                    r * scale * th.sin() * ph.cos(),
                    r * scale * th.sin() * ph.sin(),
                    r * scale * th.cos(),
                ];
                let (a, res) = gauss_newton(m, p, &s, 200);
                if res < 1e-20 * (1.0 + p.iter().map(|x| x * x).sum::<f64>()) {
                    let tol = 1e-8 * norm2(&a).max(1e-30);
                    if !found
                        .iter()
                        .any(|b| norm2(&sub(&a, b)) < tol || norm2(&add(&a, b)) < tol)
                    {
                        found.push(a);
                    }
                }
            }
        }
    }
    found
}

#[test]
fn closed_form_finds_every_branch_found_by_brute_force() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut total_roots = 0;
    let mut multi = 0;
    for trial in 0..200 {
        let m = random_forms(&mut rng);
        let a = uniform3(&mut rng, 2.0);
        let p = [m[0].quad(&a), m[1].quad(&a), m[2].quad(&a)];
        let mut out = [[0.0; 3]; MAX_ROOTS];
        let n = closed_form(&m, &p, &mut out);
        let brute = brute_force(&m, &p, norm2(&a).sqrt());
        for b in &brute {
            let tol = 1e-6 * norm2(b);
            let hit = out[..n]
                .iter()
                .any(|c| norm2(&sub(b, c)) < tol || norm2(&add(b, c)) < tol);
            assert!(
                hit,
                "trial {trial}: brute-force root {b:?} missing from closed form {:?}",
                &out[..n]
            );
        }
        for c in &out[..n] {
            assert!(
                residual2(&m, &p, c) < 1e-16 * (1.0 + norm2(&p)),
                "trial {trial}: closed-form root {c:?} does not fit"
            );
        }
        total_roots += brute.len();
        if brute.len() > 1 {
            multi += 1;
        }
    }
    // The comparison must have had something to find: many cases with several branches.
    assert!(
        multi > 50,
        "only {multi} cases with several branches ({total_roots} roots)"
    );
}

/// Model G: every null-space form `M_k` has a zero diagonal (a diagonal `{a}²` is absorbed by
/// `d`), which is what makes the off-diagonals of A a linear solve; and Kelvin's decomposition
/// inverts `o = ε (a₁a₂, a₁a₃, a₂a₃)`.
#[test]
fn general_model_forms_have_zero_diagonal_and_kelvin_inverts() {
    use estimator_core::estimator::FRAME_QUATERNIONS;
    use estimator_core::internals::design::Projection;
    use estimator_core::internals::quadratic::kelvin;
    use estimator_core::linalg::quat_to_mat;
    use estimator_core::{Arrangement, ChannelMask, Model};
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for _ in 0..20 {
        let mut arr = Arrangement::<32>::new();
        for _ in 0..15 {
            let p = uniform3(&mut rng, 0.2);
            let s = uniform3(&mut rng, 1.0);
            arr.push(p, s, 0.01).unwrap();
        }
        for (f, q) in FRAME_QUATERNIONS.iter().enumerate() {
            let mut pr = Projection::<f64, 32>::empty();
            pr.build(
                &arr,
                ChannelMask::all(15),
                Model::General,
                &quat_to_mat(*q),
                f as u8,
            )
            .unwrap();
            assert!(pr.has_lin_o);
            for mk in &pr.mq[..pr.m] {
                let scale = mk.0.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                for d in &mk.0[..3] {
                    assert!(d.abs() <= 1e-12 * scale.max(1.0), "diagonal {d} vs {scale}");
                }
            }
        }
    }
    for _ in 0..100 {
        let a = uniform3(&mut rng, 2.0);
        for eps in [1.0, -1.0] {
            let o = [eps * a[0] * a[1], eps * a[0] * a[2], eps * a[1] * a[2]];
            let (b, e) = kelvin(&o).unwrap();
            assert_eq!(e, eps);
            let d1 = norm2(&sub(&a, &b)).min(norm2(&add(&a, &b)));
            assert!(d1 < 1e-20, "{a:?} vs {b:?}");
        }
    }
    assert!(kelvin(&[1.0, 0.0, 2.0]).is_none());
}
