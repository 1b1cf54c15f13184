//! Every configuration error, with the message that names what is wrong; nothing accepted is
//! lost when a reconfiguration fails.

use estimator_core::linalg::Sym3;
use estimator_core::{Arrangement, ChannelMask, ConfigError, Estimator, Model, Options, Unknown};

fn tetra() -> Arrangement<32> {
    let mut a = Arrangement::<32>::new();
    let k = 0.1;
    for v in [[k, k, k], [k, -k, -k], [-k, k, -k], [-k, -k, k]] {
        for axis in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] {
            a.push(v, axis, 0.01).unwrap();
        }
    }
    a
}

#[test]
fn bad_channels_are_named() {
    let mut a = Arrangement::<4>::new();
    assert_eq!(
        a.push([0.0; 3], [0.0; 3], 0.1),
        Err(ConfigError::AxisZero { channel: 0 })
    );
    assert_eq!(
        a.push([0.0; 3], [f64::NAN, 1.0, 0.0], 0.1),
        Err(ConfigError::AxisNotFinite { channel: 0 })
    );
    assert_eq!(
        a.push([f64::INFINITY, 0.0, 0.0], [1.0, 0.0, 0.0], 0.1),
        Err(ConfigError::PositionNotFinite { channel: 0 })
    );
    assert_eq!(
        a.push([0.0; 3], [1.0, 0.0, 0.0], 0.0),
        Err(ConfigError::NoiseInvalid { channel: 0 })
    );
    assert_eq!(
        a.push([0.0; 3], [1.0, 0.0, 0.0], f64::NAN),
        Err(ConfigError::NoiseInvalid { channel: 0 })
    );
    assert!(a.is_empty(), "a rejected channel must not be added");
    for _ in 0..4 {
        a.push([0.1, 0.0, 0.0], [0.0, 2.0, 0.0], 0.1).unwrap();
    }
    assert_eq!(
        a.channels()[0].axis,
        [0.0, 1.0, 0.0],
        "axis normalised on load"
    );
    assert_eq!(
        a.push([0.0; 3], [1.0, 0.0, 0.0], 0.1),
        Err(ConfigError::TooManyChannels { capacity: 4 })
    );
    assert_eq!(
        ConfigError::AxisZero { channel: 3 }.to_string(),
        "channel 3: axis has zero length"
    );
}

#[test]
fn too_few_channels_for_each_model() {
    let mut a = Arrangement::<32>::new();
    for i in 0..10 {
        let t = i as f64;
        a.push(
            [0.1 * t.cos(), 0.1 * t.sin(), 0.05 * (t - 4.0)],
            [t.sin(), t.cos(), 0.3],
            0.01,
        )
        .unwrap();
    }
    let e = Estimator::<f64, 32>::new(&a, Model::General, Options::default())
        .err()
        .unwrap();
    assert_eq!(
        e,
        ConfigError::TooFewChannels {
            model: Model::General,
            have: 10,
            need: 12
        }
    );
    assert_eq!(
        e.to_string(),
        "model general needs at least 12 channels, 10 are included"
    );
}

#[test]
fn planar_arrangement_names_the_unobservable_unknown() {
    // Every seismic point in the plane z = 0: s_z R_z = 0 for every channel.
    let mut a = Arrangement::<32>::new();
    for i in 0..6 {
        let t = i as f64;
        let pos = [0.1 * t.cos(), 0.1 * t.sin(), 0.0];
        for axis in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] {
            a.push(pos, axis, 0.01).unwrap();
        }
    }
    let e = Estimator::<f64, 32>::new(&a, Model::General, Options::default())
        .err()
        .unwrap();
    assert_eq!(
        e,
        ConfigError::NotObservable {
            unknown: Unknown::D(2)
        }
    );
    assert_eq!(
        e.to_string(),
        "d_z is not observable: every channel has s_z·R_z = 0"
    );
}

#[test]
fn no_axis_along_x_names_sigma0_x() {
    let mut a = Arrangement::<32>::new();
    for i in 0..12 {
        let t = i as f64;
        a.push(
            [0.1 * t.cos(), 0.1 * t.sin(), 0.03 * t],
            [0.0, t.cos(), t.sin()],
            0.01,
        )
        .unwrap();
    }
    let e = Estimator::<f64, 32>::new(&a, Model::FreeFloat, Options::default())
        .err()
        .unwrap();
    assert_eq!(
        e,
        ConfigError::NotObservable {
            unknown: Unknown::Sigma0(0)
        }
    );
    assert_eq!(
        e.to_string(),
        "σ0_x is not observable: every channel has s_x = 0"
    );
}

#[test]
fn radial_only_arrangement_names_angular_acceleration() {
    // Every axis along its position vector: R × s = 0, Ω′ invisible.
    let mut a = Arrangement::<32>::new();
    for i in 0..12 {
        let t = i as f64 * 0.7;
        let dir = [
            t.cos() * (0.3 * t).cos(),
            t.sin() * (0.3 * t).cos(),
            (0.3 * t).sin(),
        ];
        a.push([0.1 * dir[0], 0.1 * dir[1], 0.1 * dir[2]], dir, 0.01)
            .unwrap();
    }
    let e = Estimator::<f64, 32>::new(&a, Model::FreeFloat, Options::default())
        .err()
        .unwrap();
    assert!(
        matches!(
            e,
            ConfigError::NotObservable {
                unknown: Unknown::DOmega(_)
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("every channel has (R×s)_"), "{e}");
}

#[test]
fn degenerate_combination_is_named() {
    // Every seismic point in the plane x = 0.1 m: the d_x column (s_x R_x) is 0.1 × the σ0_x
    // column (s_x): neither is zero, their combination is unobservable.
    let mut a = Arrangement::<32>::new();
    for i in 0..14 {
        let t = i as f64 * 0.9;
        a.push(
            [0.1, 0.1 * t.cos(), 0.1 * t.sin()],
            [t.sin() + 0.2, t.cos(), (2.0 * t).sin()],
            0.01,
        )
        .unwrap();
    }
    let e = Estimator::<f64, 32>::new(&a, Model::General, Options::default())
        .err()
        .unwrap();
    let ConfigError::Degenerate {
        involved,
        condition,
        frame,
    } = e
    else {
        panic!("expected Degenerate, got {e}")
    };
    assert_eq!(frame, 0);
    assert!(condition > 1e6, "{condition}");
    // σ0_x is column 0, d_x column 6.
    assert_eq!(involved & (1 | 1 << 6), 1 | 1 << 6, "{e}");
    let msg = e.to_string();
    assert!(
        msg.starts_with("the combination of σ0_x")
            && msg.contains("d_x")
            && msg.contains("is not observable"),
        "{msg}"
    );
}

#[test]
fn bad_options_and_masks_are_rejected_and_keep_the_configuration() {
    let a = tetra();
    let mut est = Estimator::<f64, 32>::new(&a, Model::General, Options::default()).unwrap();
    let before = est.condition(0);
    let bad_hint = Options {
        initial_omega: Some([f64::NAN, 0.0, 0.0]),
        ..Default::default()
    };
    assert_eq!(
        est.configure(&a, Model::General, ChannelMask::all(12), bad_hint),
        Err(ConfigError::NotFinite {
            what: "initial omega"
        })
    );
    assert_eq!(
        est.set_hint(Some([0.0, f64::INFINITY, 0.0])),
        Err(ConfigError::NotFinite { what: "rate hint" })
    );
    assert_eq!(
        est.set_gamma(&Sym3([f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0])),
        Err(ConfigError::NotFinite {
            what: "gravity gradient Γ"
        })
    );
    assert_eq!(
        est.set_mask(ChannelMask(1 << 20 | 0xfff)),
        Err(ConfigError::NoSuchChannel { channel: 20 })
    );
    // Excluding a channel leaves 11 < 12: refused, and the estimator still has its 12 channels.
    assert_eq!(
        est.set_mask(ChannelMask::all(12).without(3)),
        Err(ConfigError::TooFewChannels {
            model: Model::General,
            have: 11,
            need: 12
        })
    );
    assert_eq!(est.mask(), ChannelMask::all(12));
    assert_eq!(est.condition(0), before);
    // It still estimates.
    let p = vec![1.0; 12];
    assert!(est.update(0.0, &p).is_finite());
}

#[test]
fn non_finite_samples_give_a_flagged_prediction_not_nan() {
    let a = tetra();
    let mut est = Estimator::<f32, 32>::new(&a, Model::General, Options::default()).unwrap();
    let mut p = vec![0.5f32; 12];
    let _ = est.update(0.0, &p);
    p[4] = f32::NAN;
    let e = est.update(0.01, &p);
    assert!(e.is_finite());
    assert!(e.flags.has(estimator_core::Flags::INPUT_INVALID));
    let e = est.update(0.02, &p[..5]);
    assert!(
        e.is_finite() && e.flags.has(estimator_core::Flags::INPUT_INVALID),
        "short sample"
    );
    // A first sample that cannot be used: nothing is known, and the branch margin agrees with
    // the branch flag (flag 16 exactly when the margin is below 16).
    let mut est = Estimator::<f32, 32>::new(&a, Model::General, Options::default()).unwrap();
    let e = est.update(0.0, &p);
    assert!(e.flags.has(estimator_core::Flags::INPUT_INVALID));
    assert_eq!(
        e.flags.has(estimator_core::Flags::BRANCH_AMBIGUOUS),
        e.branch_margin < 16.0,
        "margin {}",
        e.branch_margin
    );
}

#[test]
fn readings_of_excluded_channels_are_not_used_even_when_nan() {
    let a = tetra();
    let mask = ChannelMask::all(12).without(2);
    let run = |bad: f32| {
        let mut est = Estimator::<f32, 32>::new(&a, Model::FreeFloat, Options::default()).unwrap();
        est.set_mask(mask).unwrap();
        let mut out = Vec::new();
        for k in 0..20 {
            let t = f64::from(k) * 0.01;
            let mut p: Vec<f32> = (0..12)
                .map(|i| 0.3 + 0.01 * i as f32 + 0.002 * k as f32)
                .collect();
            p[2] = bad;
            out.push(*est.update(t, &p));
        }
        out
    };
    let (with_nan, with_value) = (run(f32::NAN), run(123.0));
    for (x, y) in with_nan.iter().zip(with_value.iter()) {
        assert!(x.is_finite());
        assert!(
            !x.flags.has(estimator_core::Flags::INPUT_INVALID),
            "{:#x}",
            x.flags.0
        );
        assert_eq!(x.sigma0, y.sigma0);
        assert_eq!(x.omega, y.omega);
    }
}
