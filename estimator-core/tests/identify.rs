//! The identification from a known field (paper §6, `estimator_core::identify`): in a
//! manoeuvre exact without noise and with deviations that describe the errors with noise; in
//! a torque-free tumble and a single-axis spin what the motion cannot show held and named.

// Index loops over the three axes, as in the crate.
#![allow(clippy::needless_range_loop)]

use estimator_core::identify::{field_terms, identify, FieldSums, Param, Tolerance};
use estimator_core::{Arrangement, Channel, Sym3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr_free::normal;

const CAP: usize = 24;

/// The residual of a noise-free fit: the cost comes from the sums (`Σp² − 2qᵀg + qᵀMq`),
/// which cancel to ~10⁻¹⁴ of `Σp²`, an RMS floor of a few 10⁻⁸ m/s² here (the noise is
/// 1.5e-3).
const NOISE_FREE_RESIDUAL: f64 = 1e-6;

/// Box–Muller, so that the test needs no distribution crate.
mod rand_distr_free {
    use rand::Rng;
    pub fn normal(rng: &mut impl Rng) -> f64 {
        let (u, v): (f64, f64) = (rng.gen_range(1e-300..1.0), rng.gen());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

/// One channel's truth: scale, unit axis, position from the instrument origin, bias.
#[derive(Clone, Copy)]
struct Truth {
    scale: f64,
    axis: [f64; 3],
    position: [f64; 3],
    bias: f64,
}

/// Four tri-axial parts on a tetrahedron (12 channels), each part turned differently.
fn nominal() -> Arrangement<CAP> {
    let mut a = Arrangement::new();
    let v = [
        [0.0866, 0.0866, 0.0866],
        [0.0866, -0.0866, -0.0866],
        [-0.0866, 0.0866, -0.0866],
        [-0.0866, -0.0866, 0.0866],
    ];
    for (k, p) in v.iter().enumerate() {
        let (c, s) = ((0.4 * k as f64).cos(), (0.4 * k as f64).sin());
        for ax in [
            [c, s, 0.0],
            [-s * 0.8, c * 0.8, 0.6],
            [s * 0.6, -c * 0.6, 0.8],
        ] {
            a.push(*p, ax, 1.5e-3).unwrap();
        }
    }
    a
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / n, v[1] / n, v[2] / n]
}

/// Datasheet-like errors: scale 1 %, axes 5 mrad, positions 0.5 mm, biases 0.25 m/s² (1 sd).
fn perturbed(a: &Arrangement<CAP>, rng: &mut ChaCha8Rng) -> Vec<Truth> {
    a.channels()
        .iter()
        .map(|c| Truth {
            scale: 1.0 + 0.01 * normal(rng),
            axis: unit([
                c.axis[0] + 5e-3 * normal(rng),
                c.axis[1] + 5e-3 * normal(rng),
                c.axis[2] + 5e-3 * normal(rng),
            ]),
            position: [
                c.position[0] + 5e-4 * normal(rng),
                c.position[1] + 5e-4 * normal(rng),
                c.position[2] + 5e-4 * normal(rng),
            ],
            bias: 0.25 * normal(rng),
        })
        .collect()
}

/// The arrangement a ground calibration gave: nominal geometry, the true scales (in free
/// fall the scale is held: it is one product with the distance to the centre of mass).
fn ground(a: &Arrangement<CAP>, truth: &[Truth]) -> Arrangement<CAP> {
    let mut g = a.clone();
    for (i, t) in truth.iter().enumerate() {
        g.set_calibration(i, 0.0, t.scale).unwrap();
    }
    g
}

/// The motion of a record.
#[derive(Clone, Copy, PartialEq)]
enum Motion {
    /// Torque-free tumble of an asymmetric body.
    Tumble,
    /// The same body with attitude-control torques (three sines).
    Manoeuvre,
    /// A steady spin about z.
    Spin,
}

/// Ω′ of a body with principal inertia `i` (Euler's equations) at time `t`.
fn euler(i: &[f64; 3], w: &[f64; 3], t: f64, motion: Motion) -> [f64; 3] {
    let tau = if motion == Motion::Manoeuvre {
        [
            0.5 * (0.7 * t).sin(),
            0.4 * (1.1 * t + 1.0).sin(),
            0.3 * (1.7 * t + 2.0).sin(),
        ]
    } else {
        [0.0; 3]
    };
    [
        ((i[1] - i[2]) * w[1] * w[2] + tau[0]) / i[0],
        ((i[2] - i[0]) * w[2] * w[0] + tau[1]) / i[1],
        ((i[0] - i[1]) * w[0] * w[1] + tau[2]) / i[2],
    ]
}

/// Sums over `seconds` at 100 Hz of `motion`, readings of `truth` with the centre of mass at `com`, white noise `noise`.
fn record(
    truth: &[Truth],
    com: [f64; 3],
    seconds: f64,
    noise: f64,
    motion: Motion,
    rng: &mut ChaCha8Rng,
) -> FieldSums<CAP> {
    let inertia = [1.0, 1.8, 2.5];
    let mut w = if motion == Motion::Spin {
        [0.0, 0.0, 2.0]
    } else {
        [0.3, 1.7, -0.6]
    };
    let dt = 0.01;
    let mut sums = FieldSums::new();
    sums.clear(truth.len());
    let gamma = Sym3([0.0; 6]);
    let mut p = vec![0.0f64; truth.len()];
    for step in 0..(seconds / dt) as usize {
        let t = step as f64 * dt;
        let dw = euler(&inertia, &w, t, motion);
        let k = field_terms(&w, &dw, &gamma);
        for (pi, t) in p.iter_mut().zip(truth) {
            let r = [
                t.position[0] - com[0],
                t.position[1] - com[1],
                t.position[2] - com[2],
            ];
            let mut v = 0.0;
            for j in 0..3 {
                for l in 0..3 {
                    v += t.axis[j] * r[l] * k[3 * j + l];
                }
            }
            *pi = t.scale * v + t.bias + noise * normal(rng);
        }
        assert!(sums.add(&k, &p));
        // RK4 of Euler's equations.
        let f = |w: &[f64; 3], t: f64| euler(&inertia, w, t, motion);
        let add = |a: &[f64; 3], b: &[f64; 3], h: f64| {
            [a[0] + h * b[0], a[1] + h * b[1], a[2] + h * b[2]]
        };
        let k1 = f(&w, t);
        let k2 = f(&add(&w, &k1, dt / 2.0), t + dt / 2.0);
        let k3 = f(&add(&w, &k2, dt / 2.0), t + dt / 2.0);
        let k4 = f(&add(&w, &k3, dt), t + dt);
        for c in 0..3 {
            w[c] += dt / 6.0 * (k1[c] + 2.0 * k2[c] + 2.0 * k3[c] + k4[c]);
        }
    }
    sums
}

/// The error of every parameter of every channel in the identification's own terms: scale,
/// the two tilts (the axis error projected on the fit's tilt directions is not exposed, so the
/// tilt is the angle between the axes, compared with the larger tilt deviation), position
/// (each component, less the common offset the convention leaves), bias.
struct Errors {
    tilt: Vec<f64>,
    position: Vec<f64>,
    bias: Vec<f64>,
}

fn errors(com: [f64; 3], noise: f64, seed: u64) -> Errors {
    let a = nominal();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let truth = perturbed(&a, &mut rng);
    let sums = record(&truth, com, 60.0, noise, Motion::Manoeuvre, &mut rng);
    let id = identify(&sums, &ground(&a, &truth), &Tolerance::DATASHEET).expect("identified");
    let fits = id.channels();
    let offset: Vec<[f64; 3]> = fits
        .iter()
        .zip(&truth)
        .map(|(f, t)| {
            [
                f.channel.position[0] - t.position[0],
                f.channel.position[1] - t.position[1],
                f.channel.position[2] - t.position[2],
            ]
        })
        .collect();
    let mean: Vec<f64> = (0..3)
        .map(|l| offset.iter().map(|o| o[l]).sum::<f64>() / offset.len() as f64)
        .collect();
    let mut e = Errors {
        tilt: vec![],
        position: vec![],
        bias: vec![],
    };
    for ((f, t), o) in fits.iter().zip(&truth).zip(&offset) {
        assert_eq!(
            f.held,
            Param::Scale.bit(),
            "a manoeuvre determines all but the scale"
        );
        assert_eq!(f.channel.scale, t.scale);
        let c = f.channel.axis;
        let d = (0..3).map(|k| c[k] * t.axis[k]).sum::<f64>().min(1.0);
        // The angle between two axes has two tilt components: its mean square is the sum of
        // their variances.
        e.tilt
            .push(d.acos() / (f.sd[1] * f.sd[1] + f.sd[2] * f.sd[2]).sqrt());
        for l in 0..3 {
            e.position.push((o[l] - mean[l]) / f.sd[3 + l]);
        }
        e.bias.push((f.channel.bias - t.bias) / f.sd[6]);
    }
    // ρ (paper eq. 12, the origin from the centre of mass, which is at `com`), through the
    // same convention.
    for l in 0..3 {
        let want = -(com[l] + mean[l]);
        assert!(
            (id.rho[l] - want).abs() < 5.0 * id.rho_sd[l].max(1e-9),
            "rho {l}: {} against {want}",
            id.rho[l]
        );
    }
    e
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

/// Without noise, in a manoeuvre (torques on), every parameter comes back (positions up to the common offset the
/// convention leaves, which is the mounting errors' weighted mean).
#[test]
fn noise_free_tumble_recovers_every_parameter() {
    let a = nominal();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let truth = perturbed(&a, &mut rng);
    let com = [0.02, -0.01, 0.03];
    let sums = record(&truth, com, 60.0, 0.0, Motion::Manoeuvre, &mut rng);
    let id = identify(&sums, &ground(&a, &truth), &Tolerance::DATASHEET).expect("identified");
    let fits = id.channels();
    let off0: Vec<f64> = (0..3)
        .map(|l| fits[0].channel.position[l] - truth[0].position[l])
        .collect();
    for (i, (f, t)) in fits.iter().zip(&truth).enumerate() {
        assert_eq!(f.held, Param::Scale.bit(), "channel {i}");
        assert_eq!(f.channel.scale, t.scale, "scale {i} held");
        assert!((f.channel.bias - t.bias).abs() < 1e-9, "bias {i}");
        for k in 0..3 {
            assert!((f.channel.axis[k] - t.axis[k]).abs() < 1e-9, "axis {i}");
            let off = f.channel.position[k] - t.position[k];
            assert!(
                (off - off0[k]).abs() < 1e-10,
                "position {i}: {off} vs {}",
                off0[k]
            );
            assert!(
                off.abs() < 2e-3,
                "the common offset is a mounting error's size"
            );
        }
        assert!(
            f.residual_rms < NOISE_FREE_RESIDUAL,
            "residual {i}: {}",
            f.residual_rms
        );
    }
    for l in 0..3 {
        assert!((id.rho[l] + off0[l] + com[l]).abs() < 1e-10);
    }
    // The calibrated arrangement carries it, with a frame uncertainty.
    let cal = id
        .arrangement(&id.frame_uncertainty())
        .expect("arrangement");
    assert_eq!(cal.len(), a.len());
    assert!(cal.frame_uncertainty().translation > 0.0);
}

/// With noise (6 seeds × 12 channels, a manoeuvre) the errors are described by the reported deviations:
/// RMS(error / sd) within 25 % of 1 per kind of parameter.
#[test]
fn noisy_tumble_deviations_describe_the_errors() {
    let com = [0.02, -0.01, 0.03];
    let (mut t, mut p, mut b) = (vec![], vec![], vec![]);
    for seed in 1..=6 {
        let e = errors(com, 1.5e-3, seed);
        t.extend(e.tilt);
        p.extend(e.position);
        b.extend(e.bias);
    }
    // The tilt is an angle of two components (a chi with 2 dof: RMS 1 when described).
    for (name, v) in [("tilt", &t), ("position", &p), ("bias", &b)] {
        let r = rms(v);
        println!("{name}: RMS(error / sd) = {r:.3} over {}", v.len());
        assert!((0.75..1.25).contains(&r), "{name}: {r}");
    }
}

/// With the scales off (an uncalibrated part's 1 %), the scale is held at the arrangement's
/// value and named, and the lever arm takes the product: the readings are still explained to
/// round-off, which is what the estimate in free fall needs.
#[test]
fn a_wrong_scale_is_held_and_the_product_identified() {
    let a = nominal();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let truth = perturbed(&a, &mut rng);
    let sums = record(
        &truth,
        [0.01, 0.0, -0.02],
        60.0,
        0.0,
        Motion::Manoeuvre,
        &mut rng,
    );
    let id = identify(&sums, &a, &Tolerance::DATASHEET).expect("identified");
    for (i, (f, t)) in id.channels().iter().zip(&truth).enumerate() {
        assert!(f.is_held(Param::Scale), "channel {i}");
        assert_eq!(f.channel.scale, 1.0);
        assert!(
            f.residual_rms < NOISE_FREE_RESIDUAL,
            "channel {i}: residual {}",
            f.residual_rms
        );
        assert!((f.channel.bias - t.bias).abs() < 1e-9, "bias {i}");
    }
}

/// A torque-free tumble conserves energy and angular momentum: `Σ Iᵢωᵢ²` and `Σ Iᵢ²ωᵢ²` are
/// constant, so of the three `ωᵢ²` only one combination varies and the rest is a constant —
/// which a bias absorbs. One combination of each channel's tilt, position and bias is not in
/// the data: one parameter per channel (besides the scale) is held and named, and the
/// readings are explained to round-off all the same.
#[test]
fn a_torque_free_tumble_leaves_one_combination_per_channel() {
    let a = nominal();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let truth = perturbed(&a, &mut rng);
    let sums = record(
        &truth,
        [0.02, -0.01, 0.03],
        60.0,
        0.0,
        Motion::Tumble,
        &mut rng,
    );
    let id = identify(&sums, &ground(&a, &truth), &Tolerance::DATASHEET).expect("identified");
    for (i, f) in id.channels().iter().enumerate() {
        let held: Vec<&str> = Param::ALL
            .iter()
            .filter(|p| f.is_held(**p) && **p != Param::Scale)
            .map(|p| p.name())
            .collect();
        assert_eq!(held.len(), 1, "channel {i}: held {held:?}");
        assert!(
            f.residual_rms < NOISE_FREE_RESIDUAL,
            "channel {i}: residual {}",
            f.residual_rms
        );
    }
}

/// A steady spin about z shows no lever arm along z and no scale of a channel along z:
/// those are held at nominal and named; the biases are still determined.
#[test]
fn single_axis_spin_holds_what_it_cannot_show() {
    let a = nominal();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let truth = perturbed(&a, &mut rng);
    let sums = record(&truth, [0.0; 3], 30.0, 1.5e-3, Motion::Spin, &mut rng);
    let id = identify(&sums, &a, &Tolerance::DATASHEET).expect("identified");
    for (i, f) in id.channels().iter().enumerate() {
        assert!(f.is_held(Param::PositionZ), "channel {i}: z position held");
        assert!(!f.is_held(Param::Bias), "channel {i}: bias determined");
        assert_eq!(
            f.channel.position[2],
            a.channels()[i].position[2],
            "held at nominal"
        );
        assert_eq!(
            f.sd[Param::PositionZ as usize],
            Tolerance::DATASHEET.position
        );
    }
}

#[test]
fn too_few_sets_and_a_channel_mismatch_are_refused() {
    let a = nominal();
    let mut sums = FieldSums::<CAP>::new();
    sums.clear(a.len());
    assert!(matches!(
        identify(&sums, &a, &Tolerance::DATASHEET),
        Err(estimator_core::identify::IdentifyError::TooFewSets { have: 0 })
    ));
    sums.clear(3);
    assert!(matches!(
        identify(&sums, &a, &Tolerance::DATASHEET),
        Err(estimator_core::identify::IdentifyError::ChannelCount {
            sums: 3,
            arrangement: 12
        })
    ));
}

/// Why free flight cannot give the scale (the Fisher bound is infinite, not just large): a
/// channel reads `c s·(L (R − c_m))`, so its scale and its lever arm from the centre of mass
/// are one product. Identified from a noise-free manoeuvre with every scale held at 1 while
/// the parts' are 1 ± 1 %, every channel still fits the record to the round-off, its axis
/// and bias come out exact, and its lever arm comes out as the true one times the true scale:
/// any scale explains the record as well as the true one, so the record carries no
/// information on it. What the estimate needs — the product — is exact, so Ω′ and Ω are, and
/// σ0 at the origin the identified geometry defines; the held scales' share of where that
/// origin is sits in the frame's translation (`Identified::frame_uncertainty`).
#[test]
fn in_free_flight_the_scale_is_one_product_with_the_lever_arm() {
    let a = nominal();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let truth = perturbed(&a, &mut rng);
    assert!(truth.iter().any(|t| (t.scale - 1.0).abs() > 5e-3));
    let com = [0.02, -0.01, 0.03];
    let sums = record(&truth, com, 60.0, 0.0, Motion::Manoeuvre, &mut rng);
    // The nominal geometry with every scale at 1 (no ground calibration).
    let id = identify(&sums, &a, &Tolerance::DATASHEET).expect("identified");
    for (i, (f, t)) in id.channels().iter().zip(&truth).enumerate() {
        assert!(f.is_held(Param::Scale), "channel {i}");
        assert_eq!(
            f.channel.scale, 1.0,
            "channel {i}: the scale stays at the nominal 1"
        );
        assert!(
            f.residual_rms < NOISE_FREE_RESIDUAL,
            "channel {i}: the record is explained without its scale: {}",
            f.residual_rms
        );
        assert!((f.channel.bias - t.bias).abs() < 1e-9, "bias {i}");
        for k in 0..3 {
            assert!((f.channel.axis[k] - t.axis[k]).abs() < 1e-9, "axis {i}");
            // The lever arm from the identified centre of mass (at −ρ) is the true one
            // times the true scale.
            let arm = f.channel.position[k] + id.rho[k];
            let want = t.scale * (t.position[k] - com[k]);
            assert!(
                (arm - want).abs() < 1e-9,
                "channel {i} lever arm {k}: {arm} against scale × true {want}"
            );
        }
    }
}

/// The frame's reported deviations describe the identified geometry's common errors: over six
/// seeds, the frame rotation and the rotation of the axes against the lever arms fitted to the
/// identified − true geometry (`motions::rotation`), divided by the reported deviations, have
/// an RMS near 1 per component (neither hidden nor claimed many times too large).
#[test]
fn the_frame_uncertainty_describes_the_frame_errors() {
    use estimator_core::frame_uncertainty::motions;
    let com = [0.02, -0.01, 0.03];
    let (mut rot, mut rel) = (vec![], vec![]);
    for seed in 1..=6u64 {
        let a = nominal();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let truth = perturbed(&a, &mut rng);
        let sums = record(&truth, com, 60.0, 1.5e-3, Motion::Manoeuvre, &mut rng);
        let id = identify(&sums, &ground(&a, &truth), &Tolerance::DATASHEET).expect("identified");
        let true_channels: Vec<Channel> = truth
            .iter()
            .map(|t| Channel {
                position: t.position,
                axis: t.axis,
                noise: 1.5e-3,
                bias: t.bias,
                scale: t.scale,
            })
            .collect();
        let found: Vec<Channel> = id.channels().iter().map(|f| f.channel).collect();
        let (r, d) = motions::rotation(&true_channels, &found, &Tolerance::DATASHEET).unwrap();
        let frame = id.frame_uncertainty();
        rot.extend(r.iter().map(|v| v / frame.rotation));
        rel.extend(d.iter().map(|v| v / frame.relative_rotation));
    }
    for (name, v) in [("rotation", &rot), ("relative rotation", &rel)] {
        let r = rms(v);
        println!("{name}: RMS(error / sd) = {r:.3} over {}", v.len());
        assert!((0.33..1.5).contains(&r), "{name}: {r}");
    }
}
