//! A calibrated arrangement (per-channel bias and scale, folded into the precomputation) fed
//! with what its parts report gives the same estimates as the ideal arrangement fed with the
//! corrected readings: both models, with a known Γ in model F, with a channel excluded, in a
//! sequence (so the tracker and rate filter see the same inputs). And the frame uncertainty
//! widens the reported deviations only.

mod common;

use common::*;
use estimator_core::linalg::Sym3;
use estimator_core::{Estimator, FrameUncertainty, Model, Options};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const NOISE: f64 = 0.01;

/// Rate and angular acceleration at time `t` of a smooth manoeuvre.
fn motion(t: f64) -> ([f64; 3], [f64; 3]) {
    (
        [1.2 + 0.4 * t.sin(), -0.7 + 0.3 * t, 0.9 * (0.5 * t).cos()],
        [0.4 * t.cos(), 0.3, -0.45 * (0.5 * t).sin()],
    )
}

fn check(model: Model, n: usize, seed: u64, gamma: Sym3<f64>, exclude: Option<usize>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let ideal_arr = random_arrangement(&mut rng, n, model, NOISE);
    let mut cal_arr = ideal_arr.clone();
    let mut cal = Vec::new();
    for i in 0..n {
        let bias = rng.gen_range(-0.3..0.3);
        let scale = rng.gen_range(0.98..1.02);
        cal_arr.set_calibration(i, bias, scale).unwrap();
        cal.push((bias, scale));
    }
    let options = Options {
        gamma,
        ..Options::default()
    };
    let mut ideal = Estimator::<f64, CAP>::new(&ideal_arr, model, options).unwrap();
    let mut calibrated = Estimator::<f64, CAP>::new(&cal_arr, model, options).unwrap();
    if let Some(i) = exclude {
        let mask = ideal.mask().without(i);
        ideal.set_mask(mask).unwrap();
        calibrated.set_mask(mask).unwrap();
    }
    let sigma0 = [0.3, -9.7, 1.1];
    for k in 0..300 {
        let t = k as f64 * 0.01;
        let (w, dw) = motion(t);
        let a = gamma.add_scaled(1.0, &Sym3::skew_squared(&w));
        let mut p = outputs(&ideal_arr, &sigma0, &dw, &a);
        let mut raw: Vec<f64> = p
            .iter()
            .zip(cal.iter())
            .map(|(v, (b, s))| s * v + b)
            .collect();
        for v in p.iter_mut().chain(raw.iter_mut()) {
            *v += NOISE * (rng.gen::<f64>() - 0.5);
        }
        if let Some(i) = exclude {
            // What an excluded channel reads does not matter.
            raw[i] = f64::NAN;
        }
        // The same noise draw for both: the corrected readings from the raw ones.
        let corrected: Vec<f64> = raw
            .iter()
            .zip(cal.iter())
            .map(|(v, (b, s))| (v - b) / s)
            .collect();
        let e1 = *ideal.update(t, &corrected);
        let e2 = *calibrated.update(t, &raw);
        for (x, y, what) in [
            (e1.sigma0, e2.sigma0, "σ0"),
            (e1.domega, e2.domega, "Ω′"),
            (e1.omega, e2.omega, "Ω"),
            (e1.sd_omega, e2.sd_omega, "sd Ω"),
        ] {
            assert!(
                dist(&x, &y) < 1e-9 * (1.0 + dist(&x, &[0.0; 3])),
                "{model:?} n = {n} t = {t}: {what} {x:?} vs {y:?}"
            );
        }
        assert_eq!(e1.flags, e2.flags, "t = {t}");
    }
}

#[test]
fn calibrated_readings_estimate_as_corrected_ones() {
    let gamma = Sym3([2e-6, -1e-6, -1e-6, 0.0, 3e-7, 0.0]);
    check(Model::General, 12, 1, Sym3::zero(), None);
    check(Model::General, 15, 2, Sym3::zero(), Some(4));
    check(Model::FreeFloat, 9, 3, gamma, None);
    check(Model::FreeFloat, 14, 4, gamma, Some(0));
}

/// The frame uncertainty changes the deviations, never the estimate, and only widens them.
#[test]
fn frame_uncertainty_widens_deviations_and_changes_nothing_else() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let arr = random_arrangement(&mut rng, 12, Model::General, NOISE);
    let mut wide = arr.clone();
    wide.set_frame_uncertainty(FrameUncertainty {
        rotation: 1e-3,
        translation: 2e-4,
        size: 1e-3,
        relative_rotation: 2e-3,
    })
    .unwrap();
    assert!(wide
        .set_frame_uncertainty(FrameUncertainty {
            rotation: f64::NAN,
            translation: 0.0,
            size: 0.0,
            relative_rotation: 0.0,
        })
        .is_err());
    let mut a = Estimator::<f32, CAP>::new(&arr, Model::General, Options::default()).unwrap();
    let mut b = Estimator::<f32, CAP>::new(&wide, Model::General, Options::default()).unwrap();
    let sigma0 = [0.3, -9.7, 1.1];
    let mut last = None;
    for k in 0..200 {
        let t = k as f64 * 0.01;
        let (w, dw) = motion(t);
        let p: Vec<f32> = outputs(&arr, &sigma0, &dw, &Sym3::skew_squared(&w))
            .iter()
            .map(|v| *v as f32)
            .collect();
        let e1 = *a.update(t, &p);
        let e2 = *b.update(t, &p);
        assert_eq!(e1.omega, e2.omega);
        assert_eq!(e1.sigma0, e2.sigma0);
        assert_eq!(e1.field.0, e2.field.0);
        assert_eq!(e1.flags, e2.flags);
        for i in 0..3 {
            assert!(e2.sd_sigma0[i] >= e1.sd_sigma0[i]);
            assert!(e2.sd_omega[i] >= e1.sd_omega[i]);
            assert!(e2.sd_domega[i] >= e1.sd_domega[i]);
        }
        // σ0 ≈ g: a 1 mrad frame adds ≈ 1e-2 m/s² across it.
        assert!(e2.sd_sigma0[0] > 5e-3, "{:?}", e2.sd_sigma0);
        last = Some(e2);
    }
    // Unusable samples hold the last output, widened once, not again.
    let last = last.unwrap();
    for t in [2.0, 2.01] {
        let held = *b.update(t, &[f32::NAN; 12]);
        assert!(held.flags.has(estimator_core::Flags::INPUT_INVALID));
        assert_eq!(held.sd_sigma0, last.sd_sigma0);
        assert_eq!(held.sd_omega, last.sd_omega);
    }
}

/// The first-order effects the frame uncertainty assumes (`frame_uncertainty` module doc),
/// against the estimator itself: noise-free readings of one geometry estimated with the same
/// geometry turned — all of it by δ (every output turns by δ), or the axes by ½ d against the
/// lever arms by −½ d (σ0 turns by ½ d, Ω′ moves by `−½ (|Ω|² d + (Ω·d) Ω)`, Ω stays to
/// first order).
#[test]
fn turned_geometries_move_the_estimate_as_the_frame_uncertainty_says() {
    use estimator_core::linalg::{cross, dot};
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let truth = random_arrangement(&mut rng, 15, Model::General, NOISE);
    let turn = |v: &[f64; 3], d: &[f64; 3], k: f64| {
        let c = cross(d, v);
        [v[0] + k * c[0], v[1] + k * c[1], v[2] + k * c[2]]
    };
    let turned = |axes: f64, arms: f64, d: &[f64; 3]| {
        let mut a = estimator_core::Arrangement::<CAP>::new();
        for c in truth.channels() {
            a.push(turn(&c.position, d, arms), turn(&c.axis, d, axes), c.noise)
                .unwrap();
        }
        a
    };
    let d = [4e-4, -7e-4, 5e-4];
    let raw = Options {
        raw: true,
        ..Options::default()
    };
    let mut base = Estimator::<f64, CAP>::new(&truth, Model::General, raw).unwrap();
    let mut joint = Estimator::<f64, CAP>::new(&turned(1.0, 1.0, &d), Model::General, raw).unwrap();
    let mut relative =
        Estimator::<f64, CAP>::new(&turned(0.5, -0.5, &d), Model::General, raw).unwrap();
    let sigma0 = [0.3, -9.7, 1.1];
    for k in 0..150 {
        let t = k as f64 * 0.01;
        let (w, dw) = motion(t);
        let p = outputs(&truth, &sigma0, &dw, &Sym3::skew_squared(&w));
        let e0 = *base.update(t, &p);
        let ej = *joint.update(t, &p);
        let er = *relative.update(t, &p);
        if k < 50 {
            continue;
        }
        let close = |got: [f64; 3], from: [f64; 3], want: [f64; 3], what: &str| {
            let change = [got[0] - from[0], got[1] - from[1], got[2] - from[2]];
            let scale = dist(&want, &[0.0; 3]).max(1e-6);
            assert!(
                dist(&change, &want) < 0.05 * scale,
                "t = {t}: {what} moved {change:?}, expected {want:?}"
            );
        };
        let moved = |v: &[f64; 3], k: f64| {
            let c = cross(&d, v);
            [k * c[0], k * c[1], k * c[2]]
        };
        close(ej.sigma0, e0.sigma0, moved(&e0.sigma0, 1.0), "joint: σ0");
        close(ej.omega, e0.omega, moved(&e0.omega, 1.0), "joint: Ω");
        close(er.sigma0, e0.sigma0, moved(&e0.sigma0, 0.5), "relative: σ0");
        // Ω stays to first order in the centripetal term; the rest of the least squares leaks
        // a tenth of the joint rotation's effect into it on this arrangement (linear in d:
        // measured the same at a tenth of d). Not carried by the widening.
        let joint_omega = dist(&moved(&e0.omega, 1.0), &[0.0; 3]);
        assert!(
            dist(&er.omega, &e0.omega) < 0.15 * joint_omega,
            "t = {t}: relative: Ω moved {} against {joint_omega} for the joint rotation",
            dist(&er.omega, &e0.omega)
        );
        let w = e0.omega;
        let (w2, wd) = (dot(&w, &w), dot(&w, &d));
        let want = [
            -0.5 * (w2 * d[0] + wd * w[0]),
            -0.5 * (w2 * d[1] + wd * w[1]),
            -0.5 * (w2 * d[2] + wd * w[2]),
        ];
        close(er.domega, e0.domega, want, "relative: Ω′");
    }
}
