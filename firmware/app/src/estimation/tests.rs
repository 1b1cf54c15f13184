//! The estimation's bookkeeping: exclusions, model switches, the builder task.

extern crate std;
use super::*;
use crate::config::tetra;
use estimator_core::{Flags, Model};

fn set(k: u32, part0: bool) -> SampleSet {
    // The same small change in every part's reading each set (a uniform σ0: consistent),
    // so that no part repeats its values (the fault monitor's stuck check).
    let d = 1e-4 * (k % 7) as f32;
    let mut parts = [Some([0.1 + d, 0.2 - d, 9.8 + d]); MAX_PARTS];
    if !part0 {
        parts[0] = None;
    }
    SampleSet::new(k, u64::from(k) * 10_000_000, parts)
}

/// Model G on all twelve channels again, and the return from model F reported once.
fn back_in_model_g(e: &mut Estimation) {
    assert_eq!(e.estimator().model(), Model::General);
    assert_eq!(e.estimator().mask(), ChannelMask::all(12));
    assert_eq!(
        e.take_model_switch(),
        Some((Model::FreeFloat, Model::General))
    );
    assert_eq!(e.take_model_switch(), None);
}

#[test]
fn a_part_missing_for_several_sets_is_excluded_and_later_included() {
    let mut cfg = tetra();
    cfg.model = Model::FreeFloat;
    let mut e = Estimation::new(&cfg).unwrap();
    for k in 0..5 {
        assert_eq!(e.process(&set(k, true)).excluded, PartSet(0));
    }
    let gap = 5 + u32::from(EXCLUDE_AFTER);
    for k in 5..gap {
        let m = e.process(&set(k, false));
        assert_eq!(m.missing, PartSet(1));
        let excluded = k + 1 == gap;
        assert_eq!(m.excluded, PartSet(u8::from(excluded)), "set {k}");
        // Missing before the exclusion: the flagged prediction; after: an estimate.
        assert_eq!(m.estimate.flags.has(Flags::INPUT_INVALID), !excluded);
        assert_eq!(m.estimate.flags.has(Flags::CHANNELS_EXCLUDED), excluded);
    }
    let back = gap + u32::from(INCLUDE_AFTER);
    for k in gap..back {
        let m = e.process(&set(k, true));
        assert_eq!(m.excluded, PartSet(u8::from(k + 1 < back)), "set {k}");
    }
    assert_eq!(e.estimator().mask(), ChannelMask::all(12));
}

/// With a part dead, twelve channels leave model G unobservable: the part is
/// excluded all the same and the estimate made in model F on the nine left (instead of the
/// flagged prediction held for as long as the part is dead); back in model G once the part
/// has answered for [`INCLUDE_AFTER`] sets. Each switch is reported once.
#[test]
fn model_g_switches_to_model_f_while_a_part_is_out_and_back() {
    let mut e = Estimation::new(&tetra()).unwrap();
    assert_eq!(e.estimator().model(), Model::General);
    let gap = 5 + u32::from(EXCLUDE_AFTER);
    for k in 0..gap {
        let m = e.process(&set(k, k < 5));
        let out = k + 1 == gap;
        assert_eq!(m.excluded, PartSet(u8::from(out)), "set {k}");
        assert_eq!(m.estimate.flags.has(Flags::INPUT_INVALID), k >= 5 && !out);
        assert!(m.estimate.is_finite());
    }
    assert_eq!(e.estimator().model(), Model::FreeFloat);
    assert_eq!(e.model(), Model::General, "the configured model is kept");
    assert_eq!(
        e.take_model_switch(),
        Some((Model::General, Model::FreeFloat))
    );
    assert_eq!(e.take_model_switch(), None);
    // Dead 20 sets more, then good: back in after INCLUDE_AFTER good sets.
    let back = gap + 20 + u32::from(INCLUDE_AFTER);
    for k in gap..back {
        let m = e.process(&set(k, k >= gap + 20));
        assert_eq!(m.excluded, PartSet(u8::from(k + 1 < back)), "set {k}");
        assert!(m.estimate.is_finite());
        if k < gap + 20 {
            assert!(m.estimate.flags.has(Flags::CHANNELS_EXCLUDED), "set {k}");
            assert!(!m.estimate.flags.has(Flags::INPUT_INVALID), "set {k}");
        }
    }
    back_in_model_g(&mut e);
}

/// The tetrahedron's estimation with a builder task's buffer (the test builds at once with
/// `Builds::build_now` where the board's task would build).
fn with_builder() -> (Estimation, &'static Builds) {
    let builds: &'static Builds = std::boxed::Box::leak(std::boxed::Box::new(Builds::background()));
    let mut e = Estimation::new(&tetra()).unwrap();
    e.attach_builds(builds);
    (e, builds)
}

/// With a builder task the exclusion's configuration is built beside the one in
/// force. Until it is built the estimates go on every set — the configured model, the
/// leaving part read as missing: flagged predictions, finite — and none uses a half-built
/// configuration; the first set after the build is made in model F without the part. The
/// return, once the part has answered for `INCLUDE_AFTER` sets, swaps model G's
/// configuration back from the buffer at once, with no build.
#[test]
fn an_exclusion_built_in_the_background_never_stops_the_estimates() {
    let (mut e, builds) = with_builder();
    let part0 = ChannelMask(0b111);
    let gap = 5 + u32::from(EXCLUDE_AFTER);
    for k in 0..gap + 30 {
        let m = e.process(&set(k, k < 5));
        assert_eq!(
            m.excluded,
            PartSet::EMPTY,
            "set {k}: not out before it is built"
        );
        assert_eq!(m.model, Model::General, "set {k}");
        assert!(m.estimate.is_finite(), "set {k}");
        assert_eq!(
            m.estimate.flags.has(Flags::INPUT_INVALID),
            k >= 5,
            "set {k}"
        );
        let leaving = if k + 1 >= gap { part0 } else { ChannelMask(0) };
        assert_eq!(e.channels_leaving(), leaving, "set {k}");
    }
    assert_eq!(e.take_model_switch(), None);
    // The builder runs (once it has the processor): the configuration is built.
    assert!(builds.build_now());
    assert!(!builds.build_now(), "one build asked for");
    let k = gap + 30;
    let m = e.process(&set(k, false));
    assert_eq!(m.excluded, PartSet(1));
    assert_eq!(m.model, Model::FreeFloat);
    assert!(m.estimate.flags.has(Flags::CHANNELS_EXCLUDED));
    assert!(!m.estimate.flags.has(Flags::INPUT_INVALID));
    assert_eq!(e.channels_leaving(), ChannelMask(0));
    assert_eq!(
        e.take_model_switch(),
        Some((Model::General, Model::FreeFloat))
    );
    // Back without the builder: model G's configuration was set aside at the swap.
    let back = k + 1 + u32::from(INCLUDE_AFTER);
    for k in k + 1..back {
        let m = e.process(&set(k, true));
        assert_eq!(m.excluded, PartSet(u8::from(k + 1 < back)), "set {k}");
        assert!(m.estimate.is_finite(), "set {k}");
    }
    back_in_model_g(&mut e);
}

/// A part back before its exclusion's configuration is built: the change is abandoned —
/// the estimator keeps its configuration and the part, and the build, when the builder
/// gets to it, is not swapped in.
#[test]
fn an_exclusion_no_longer_wanted_is_not_swapped_in() {
    let (mut e, builds) = with_builder();
    let gap = 5 + u32::from(EXCLUDE_AFTER);
    for k in 0..gap {
        e.process(&set(k, k < 5));
    }
    assert_eq!(e.channels_leaving(), ChannelMask(0b111), "asked for");
    let m = e.process(&set(gap, true));
    assert_eq!(e.channels_leaving(), ChannelMask(0), "no longer wanted");
    assert!(!m.estimate.flags.has(Flags::INPUT_INVALID));
    assert!(builds.build_now(), "the builder gets to it");
    for k in gap + 1..gap + 20 {
        let m = e.process(&set(k, true));
        assert_eq!(m.excluded, PartSet::EMPTY, "set {k}");
        assert_eq!(m.model, Model::General, "set {k}");
        assert!(!m.estimate.flags.has(Flags::INPUT_INVALID), "set {k}");
    }
    assert_eq!(e.estimator().mask(), ChannelMask::all(12));
    assert_eq!(e.take_model_switch(), None);
}

/// Eighteen channels: the tetrahedron and two more parts on the axes (the host simulator's
/// `tetra-orbit` with two ADXL355s added).
fn eighteen() -> AppConfig {
    eighteen_turned(0)
}

/// [`eighteen`] with the two added parts' axes turned by `turn` places (another
/// arrangement of the same channels).
fn eighteen_turned(turn: usize) -> AppConfig {
    let mut cfg = tetra();
    let extra = cfg.sampling.parts[0].expect("part 0");
    for (i, pos) in [[0.12, 0.0, 0.0], [0.0, 0.0, -0.12]].iter().enumerate() {
        let mut channels = [None; 3];
        for (k, ch) in channels.iter_mut().enumerate() {
            let mut axis = [0.0; 3];
            axis[(k + i + turn) % 3] = 1.0;
            let noise = cfg.arrangement.channels()[0].noise;
            *ch = cfg
                .arrangement
                .push(*pos, axis, noise)
                .ok()
                .map(|c| c as u8);
        }
        cfg.sampling.parts[4 + i] = Some(crate::config::PartConfig { channels, ..extra });
    }
    cfg
}

/// Readings consistent with a uniform specific force (no rotation), `part0` absent.
fn consistent_set(cfg: &AppConfig, k: u32, part0: bool) -> SampleSet {
    let d = 1e-3 * f64::from(k % 7);
    let f = [0.1 + d, 0.2 - d, 9.8 + d];
    let mut parts = [None; MAX_PARTS];
    for (i, p) in cfg.sampling.parts() {
        let mut v = [0.0f32; 3];
        for (x, c) in v.iter_mut().zip(p.channels.iter()) {
            if let Some(c) = c {
                let a = cfg.arrangement.channels()[usize::from(*c)].axis;
                *x = (a[0] * f[0] + a[1] * f[1] + a[2] * f[2]) as f32;
            }
        }
        parts[i] = (i != 0 || part0).then_some(v);
    }
    SampleSet::new(k, u64::from(k) * 10_000_000, parts)
}

/// With redundancy (N = 18) the fault monitor's parity space is built by the builder task
/// with the exclusion's configuration, not in the sample path: at the swap the monitor
/// tests the fifteen channels left with it, and the one for all eighteen is set aside; the
/// part's return takes that one back (and sets the other aside) with no build at all.
#[test]
fn the_parity_space_is_built_with_the_configuration_in_the_background() {
    let cfg = eighteen();
    let builds: &'static Builds = std::boxed::Box::leak(std::boxed::Box::new(Builds::background()));
    let mut e = Estimation::new(&cfg).unwrap();
    e.attach_builds(builds);
    let all = ChannelMask::all(18);
    let without0 = all.without(0).without(1).without(2);
    assert_eq!(e.consistency_test(), ballisto_link::ConsistencyTest::Parity);
    let gap = 5 + u32::from(EXCLUDE_AFTER);
    for k in 0..gap {
        let m = e.process(&consistent_set(&cfg, k, k < 5));
        assert_eq!(m.excluded, PartSet::EMPTY, "set {k}");
    }
    assert_eq!(builds.parity_held(), None, "asked for, not built");
    assert!(builds.build_now());
    assert_eq!(
        builds.parity_held(),
        Some(without0),
        "built with the configuration"
    );
    let m = e.process(&consistent_set(&cfg, gap, false));
    assert_eq!(m.excluded, PartSet(1));
    assert_eq!(m.model, Model::General, "fifteen channels carry model G");
    assert_eq!(e.consistency_test(), ballisto_link::ConsistencyTest::Parity);
    assert_eq!(
        builds.parity_held(),
        Some(all),
        "the one replaced, set aside"
    );
    // Back after INCLUDE_AFTER good sets, with no build: the configuration and the
    // parity space set aside are swapped back.
    let back = gap + 1 + u32::from(INCLUDE_AFTER);
    let mut k = gap + 1;
    while k < back {
        e.process(&consistent_set(&cfg, k, true));
        k += 1;
    }
    assert!(!builds.build_now(), "nothing asked of the builder");
    assert_eq!(e.excluded_parts(), PartSet::EMPTY, "back at set {k}");
    assert_eq!(e.estimator().mask(), all);
    assert_eq!(e.consistency_test(), ballisto_link::ConsistencyTest::Parity);
    assert_eq!(builds.parity_held(), Some(without0), "swapped back");
    for k in k..k + 20 {
        let m = e.process(&consistent_set(&cfg, k, true));
        assert!(!m.estimate.flags.has(Flags::RESIDUAL_HIGH), "set {k}");
    }
}

/// A new arrangement commanded with a builder task: the parity space built with its
/// configuration is the one installed (the channels tested are the same as before, which
/// must not keep the old arrangement's): readings consistent with the new arrangement are
/// not flagged once it is in force.
#[test]
fn a_new_arrangement_built_in_the_background_brings_its_own_parity_space() {
    let (cfg, turned) = (eighteen(), eighteen_turned(1));
    let builds: &'static Builds = std::boxed::Box::leak(std::boxed::Box::new(Builds::background()));
    let mut e = Estimation::new(&cfg).unwrap();
    e.attach_builds(builds);
    for k in 0..50 {
        let m = e.process(&consistent_set(&cfg, k, true));
        assert!(!m.estimate.flags.has(Flags::RESIDUAL_HIGH), "set {k}");
    }
    let applied = e.configure(turned.arrangement.clone(), Model::General);
    assert_eq!(applied, Ok(Applied::WhenBuilt));
    assert!(builds.build_now());
    // Set 50 is tested before the swap, by the old arrangement's parity space.
    e.process(&consistent_set(&turned, 50, true));
    assert_eq!(e.take_order_outcome(), Some(Ok(())));
    for k in 51..300 {
        let m = e.process(&consistent_set(&turned, k, true));
        assert!(!m.estimate.flags.has(Flags::RESIDUAL_HIGH), "set {k}");
    }
}
