//! Where exclusions leave model G unobservable the estimator takes the channels in
//! model F (`Estimator::set_mask_in`), reports it, and returns to model G when it can.

mod common;

use common::{outputs, CAP};
use estimator_core::linalg::Sym3;
use estimator_core::{
    Arrangement, ChannelMask, ConfigError, Estimator, Model, Options, SpareConfig,
};

/// Four tri-axial parts at the vertices of a tetrahedron (12 channels, model G's minimum).
fn tetra() -> Arrangement<CAP> {
    let mut a = Arrangement::<CAP>::new();
    let k = 0.1;
    for v in [[k, k, k], [k, -k, -k], [-k, k, -k], [-k, -k, k]] {
        for axis in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] {
            a.push(v, axis, 1e-3).unwrap();
        }
    }
    a
}

#[test]
fn a_part_out_of_twelve_channels_switches_model_g_to_model_f_and_back() {
    let arr = tetra();
    let omega = [0.3, -1.1, 0.7];
    let mut est = Estimator::<f64, CAP>::new(
        &arr,
        Model::General,
        Options {
            initial_omega: Some(omega),
            ..Options::default()
        },
    )
    .unwrap();
    let without_part_1 = ChannelMask::all(12).without(3).without(4).without(5);
    // Model G cannot use 9 channels: set_mask refuses, set_mask_in takes them in model F.
    assert!(est.set_mask(without_part_1).is_err());
    assert_eq!(
        est.set_mask_in(without_part_1, Model::General),
        Ok(Model::FreeFloat)
    );
    assert_eq!(
        (est.model(), est.mask()),
        (Model::FreeFloat, without_part_1)
    );
    // The free-float field (Γ = 0: A = {Ω}²) from the nine channels, the dead part's readings
    // NaN: the rate near the hint is recovered.
    let a = Sym3::skew_squared(&omega);
    let (sigma0, domega) = ([0.2, 0.1, -0.4], [0.5, 0.0, -0.3]);
    let mut p = outputs(&arr, &sigma0, &domega, &a);
    p[3..6].fill(f64::NAN);
    let e = *est.update(0.0, &p);
    assert!(!e.flags.has(estimator_core::Flags::INPUT_INVALID));
    let err: f64 = (0..3)
        .map(|i| (e.omega[i] - omega[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(err < 1e-6, "Ω error {err}, {:?}", e.omega);
    // Eight channels: neither model; the preferred model's error, nothing changed.
    let eight = without_part_1.without(0);
    assert_eq!(
        est.set_mask_in(eight, Model::General),
        Err(ConfigError::TooFewChannels {
            model: Model::General,
            have: 8,
            need: 12
        })
    );
    assert_eq!(
        (est.model(), est.mask()),
        (Model::FreeFloat, without_part_1)
    );
    // Every channel back: model G again. Model F preferred is never switched.
    assert_eq!(
        est.set_mask_in(ChannelMask::all(12), Model::General),
        Ok(Model::General)
    );
    assert_eq!(est.model(), Model::General);
    assert_eq!(
        est.set_mask_in(ChannelMask::all(12), Model::FreeFloat),
        Ok(Model::FreeFloat)
    );
    assert!(est.set_mask_in(eight, Model::FreeFloat).is_err());
    assert_eq!(est.model(), Model::FreeFloat);
}

/// The double buffer: the switch to model F sets model G's configuration aside, and the
/// return swaps it back (no precomputation); a refused mask changes neither buffer.
#[test]
fn the_return_to_model_g_swaps_its_configuration_back() {
    let arr = tetra();
    let mut est = Estimator::<f32, CAP>::new(&arr, Model::General, Options::default()).unwrap();
    let mut spare = SpareConfig::new();
    assert_eq!(spare.holds(), None);
    let all = ChannelMask::all(12);
    let nine = all.without(3).without(4).without(5);
    let keep = |est: &mut Estimator<f32, CAP>, spare: &mut SpareConfig<f32, CAP>, m| {
        est.set_mask_keeping(m, Model::General, spare)
    };
    assert_eq!(keep(&mut est, &mut spare, nine), Ok(Model::FreeFloat));
    assert_eq!(spare.holds(), Some((Model::General, all)));
    // Eight channels: refused, both buffers as they were.
    assert!(keep(&mut est, &mut spare, nine.without(0)).is_err());
    assert_eq!((est.model(), est.mask()), (Model::FreeFloat, nine));
    assert_eq!(spare.holds(), Some((Model::General, all)));
    // Back: model G's configuration swapped in, model F's set aside.
    assert_eq!(keep(&mut est, &mut spare, all), Ok(Model::General));
    assert_eq!((est.model(), est.mask()), (Model::General, all));
    assert_eq!(spare.holds(), Some((Model::FreeFloat, nine)));
    // The swapped-in configuration estimates as a freshly built one.
    let mut fresh = Estimator::<f32, CAP>::new(&arr, Model::General, Options::default()).unwrap();
    let p: Vec<f32> = (0..12).map(|i| 0.3 + 0.01 * i as f32).collect();
    let (a, b) = (*est.update(0.0, &p), *fresh.update(0.0, &p));
    assert_eq!(
        (a.omega, a.sigma0, a.flags.0),
        (b.omega, b.sigma0, b.flags.0)
    );
    spare.clear();
    assert_eq!(spare.holds(), None);
}

/// Issue 17, the precomputation outside the sample loop: a configuration built in the spare
/// slot while the estimator goes on estimating leaves the estimator untouched, and swapped in
/// it estimates exactly as one configured in place; the configuration it replaced is set
/// aside. A refused build leaves the slot as it was; an empty slot swaps nothing in.
#[test]
fn a_configuration_built_beside_the_estimator_is_swapped_in_whole() {
    let arr = tetra();
    let mut est = Estimator::<f32, CAP>::new(&arr, Model::General, Options::default()).unwrap();
    let mut spare = SpareConfig::new();
    assert_eq!(est.swap_in(&mut spare), None, "nothing to swap in");
    assert_eq!(est.model(), Model::General);
    let all = ChannelMask::all(12);
    let nine = all.without(3).without(4).without(5);
    let p: Vec<f32> = (0..12).map(|i| 0.3 + 0.01 * i as f32).collect();
    let before = *est.update(0.0, &p);
    let built = spare.build(est.arrangement(), Model::General, nine, est.options());
    assert_eq!(
        built,
        Ok(Model::FreeFloat),
        "nine channels do not carry model G"
    );
    assert_eq!(spare.holds(), Some((Model::FreeFloat, nine)));
    // The estimator in force is untouched by the build.
    assert_eq!((est.model(), est.mask()), (Model::General, all));
    let mut twin = Estimator::<f32, CAP>::new(&arr, Model::General, Options::default()).unwrap();
    let _ = twin.update(0.0, &p);
    let (a, b) = (*est.update(0.01, &p), *twin.update(0.01, &p));
    assert_eq!((a.omega, a.flags.0), (b.omega, b.flags.0));
    assert!(before.is_finite());
    // A refused build (eight channels): the slot keeps what it held.
    let eight = nine.without(0);
    assert!(spare
        .build(est.arrangement(), Model::General, eight, est.options())
        .is_err());
    assert_eq!(spare.holds(), Some((Model::FreeFloat, nine)));
    // Swapped in: model F in force, model G set aside; it estimates as one set in place.
    assert_eq!(est.swap_in(&mut spare), Some(Model::FreeFloat));
    assert_eq!((est.model(), est.mask()), (Model::FreeFloat, nine));
    assert_eq!(spare.holds(), Some((Model::General, all)));
    let mut fresh = Estimator::<f32, CAP>::new(&arr, Model::General, Options::default()).unwrap();
    assert_eq!(
        fresh.set_mask_in(nine, Model::General),
        Ok(Model::FreeFloat)
    );
    let (a, b) = (*est.update(0.0, &p), *fresh.update(0.0, &p));
    assert_eq!(
        (a.omega, a.sigma0, a.flags.0),
        (b.omega, b.sigma0, b.flags.0)
    );
}
