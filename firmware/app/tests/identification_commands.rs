//! The identification's telecommands through the application: malformed ones refused with
//! their reason, a window reported and committed through the store, windows at several
//! temperatures tracked.

mod common;

use ballisto_link::decode::{Decoded, Report};
use ballisto_link::{service, subtype, EventId, FailureCode};
use futures::executor::block_on;

use common::*;

#[test]
fn identification_commands_are_refused_with_their_reason() {
    let mut u = Unit::new();
    u.sets(5);
    for (what, raw, code, data) in bad_identification_commands() {
        let r = u.command(&raw);
        assert_eq!(r.len(), 1, "{what}");
        assert_eq!(
            verification(&r[0]),
            (subtype::NOT_ACCEPTED, Some((code, data))),
            "{what}"
        );
    }
    // Accepted, but nothing to do yet: no window started, no store.
    let b = service::BALLISTOMETER;
    let not_ready = |r: &[Decoded]| verification(r.last().unwrap());
    let no_window = Some((FailureCode::NotReady, 1));
    let pts = reference_data(&[(1_000_000_000, [0.0, 0.0, 0.5])]);
    assert_eq!(
        not_ready(&u.command(&tc(b, subtype::REFERENCE_RATE, &pts, 80))),
        (subtype::NOT_COMPLETED, no_window)
    );
    assert_eq!(
        not_ready(&u.command(&tc(b, subtype::REPORT_IDENTIFICATION, &[], 81))),
        (subtype::NOT_COMPLETED, no_window)
    );
    assert_eq!(
        not_ready(&u.command(&tc(b, subtype::COMMIT_CALIBRATION, &[0, 1], 82))),
        (subtype::NOT_COMPLETED, Some((FailureCode::NotReady, 6)))
    );
    // A tumble's window longer than the room for its means: 12 channels, means of 40 ms at
    // 100 Hz, 2 048 of them, 81.92 s. Refused naming the longest that fits; that one starts.
    let tumble = |window_ms: u32| {
        let mut d = start_data(2, 40, window_ms);
        for v in [1.0f32, 1.8, 2.5, 0.0, 0.0, 0.0] {
            d.extend_from_slice(&v.to_be_bytes());
        }
        tc(b, subtype::START_IDENTIFICATION, &d, 83)
    };
    assert_eq!(
        not_ready(&u.command(&tumble(82_000))),
        (
            subtype::NOT_COMPLETED,
            Some((
                FailureCode::NotReady,
                ballisto_link::verification::not_ready::WINDOW_TOO_LONG | 81
            ))
        )
    );
    assert_eq!(not_ready(&u.command(&tumble(81_000))).0, subtype::COMPLETED);
}

/// A window over a steady spin about z with the reference sent in batches: the report names
/// what a single-axis spin cannot show (every lever arm along z, the scale always), a commit
/// names the solution, waits for the store and is completed when it answers; a second commit
/// meanwhile, a wrong solution number and a failed store are refused with their reasons.
#[test]
fn a_window_is_reported_and_committed_through_the_store() {
    let mut u = Unit::new();
    u.app.set_store_writable(true);
    let b = service::BALLISTOMETER;
    u.sets(10);
    // 10 ms sets; reference every 50 ms, sent four points at a time. Solved by the
    // identification task; reported and completed as it hands the solution over.
    let mut seq = 90;
    let r = solved_window(&mut u, 0, &mut seq);
    let summary = summary_in(&r).expect("a summary");
    assert_eq!(summary.channels, 12);
    assert!(summary.sets > 300, "{summary:?}");
    assert_eq!(summary.points, 80);
    let channels: Vec<_> = r
        .iter()
        .filter_map(|p| match p.report {
            Report::IdentifiedChannel(c) => Some(c),
            _ => None,
        })
        .collect();
    assert_eq!(channels.len(), 12);
    for c in &channels {
        assert!(c.held & 1 != 0, "scale held: {c:?}");
        assert!(
            c.held & (1 << 5) != 0,
            "z lever arm held in a spin about z: {c:?}"
        );
        assert!(c.residual_rms < 1e-4, "{c:?}");
    }
    let verified: Vec<_> = r
        .iter()
        .filter(|p| matches!(p.report, Report::Verification(_)))
        .map(verification)
        .collect();
    assert_eq!(
        verified,
        vec![(subtype::ACCEPTED, None), (subtype::COMPLETED, None)]
    );
    let n = summary.solution;
    // Not the reported solution.
    let r = u.command(&tc(
        b,
        subtype::COMMIT_CALIBRATION,
        &(n + 1).to_be_bytes(),
        seq + 1,
    ));
    assert_eq!(
        verification(r.last().unwrap()),
        (subtype::NOT_COMPLETED, Some((FailureCode::NotReady, 4)))
    );
    // The commit goes to the store; no completion yet.
    let r = u.command(&tc(
        b,
        subtype::COMMIT_CALIBRATION,
        &n.to_be_bytes(),
        seq + 2,
    ));
    assert_eq!(
        r.iter().map(verification).map(|v| v.0).collect::<Vec<_>>(),
        vec![subtype::ACCEPTED]
    );
    let request = u.app.take_commit().expect("a commit for the storage task");
    assert_eq!(request.arrangement.len(), 12);
    assert!(u.app.take_commit().is_none());
    let r = u.command(&tc(
        b,
        subtype::COMMIT_CALIBRATION,
        &n.to_be_bytes(),
        seq + 3,
    ));
    assert_eq!(
        verification(r.last().unwrap()),
        (subtype::NOT_COMPLETED, Some((FailureCode::NotReady, 7)))
    );
    // The store answers: event and completion.
    let before = u.all().len();
    block_on(u.app.on_commit_reply(
        ballisto_fw::storage::CommitReply::Stored { id: 4, crc: 0xABCD },
        0,
        &mut u.tm,
    ));
    let r = &u.all()[before..];
    assert!(
        matches!(r[0].report, Report::Event(e) if e.id == EventId::CalibrationStored && e.a == 4 && e.b == 0xABCD)
    );
    assert_eq!(verification(&r[1]).0, subtype::COMPLETED);
    // A failed store.
    u.command(&tc(
        b,
        subtype::COMMIT_CALIBRATION,
        &n.to_be_bytes(),
        seq + 4,
    ));
    assert!(u.app.take_commit().is_some());
    let before = u.all().len();
    block_on(
        u.app
            .on_commit_reply(ballisto_fw::storage::CommitReply::Failed(1), 0, &mut u.tm),
    );
    let r = &u.all()[before..];
    assert_eq!(
        verification(&r[0]),
        (subtype::NOT_COMPLETED, Some((FailureCode::StoreFailed, 1)))
    );
    // The calibration in use is still the boot's: a commit is used from the next boot.
    assert_eq!(u.app.calibration(), ballisto_link::CalibrationId::default());
}

/// A 4 s window from the unit's time `start` ns (reference every 50 ms, four points a
/// telecommand), solved: the solve's packets.
fn solved_window(u: &mut Unit, start: u64, seq: &mut u16) -> Vec<Decoded> {
    let b = service::BALLISTOMETER;
    let r = u.command_at(
        &tc(
            b,
            subtype::START_IDENTIFICATION,
            &start_data(1, 50, 4_000),
            *seq,
        ),
        start,
    );
    assert_eq!(verification(r.last().unwrap()).0, subtype::COMPLETED);
    *seq += 1;
    for batch in 0..20u64 {
        u.sets(20);
        let pts: Vec<_> = (0..4)
            .map(|i| {
                (
                    start + 100_000_000 + (batch * 4 + i) * 50_000_000,
                    [0.0f32, 0.0, 0.5],
                )
            })
            .collect();
        u.command(&tc(b, subtype::REFERENCE_RATE, &reference_data(&pts), *seq));
        *seq += 1;
    }
    let r = u.command(&tc(b, subtype::REPORT_IDENTIFICATION, &[], *seq));
    *seq += 1;
    r
}

/// The thermal track reports (TM[200,130]) among `packets`.
fn tracks(packets: &[Decoded]) -> Vec<ballisto_link::identification::ThermalTrack> {
    packets
        .iter()
        .filter_map(|p| match p.report {
            Report::ThermalTrack(k) => Some(k),
            _ => None,
        })
        .collect()
}

/// Windows at 10, 25 and 40 °C with every bias moving by 1 mg per °C: each solution is followed
/// by every channel's track (TM[200,130]); a window solved twice joins once; the third window
/// decides the line, and the commit stores its coefficient (the scale's none) with the
/// solution; the held lever arms without a scale coefficient are said; a new arrangement starts
/// the track again.
#[test]
fn windows_at_different_temperatures_track_each_bias_and_the_commit_stores_it() {
    use ballisto_link::identification::{TRACK_ADDED, TRACK_DETERMINED, TRACK_SCALE_DRIFT};
    let bias_tc = 9.81e-3f32;
    let mut u = Unit::new();
    u.app.set_store_writable(true);
    u.sets(10);
    let mut seq = 90;
    let mut number = 0;
    for (w, celsius) in [10.0f32, 25.0, 40.0].into_iter().enumerate() {
        u.thermal = (celsius, bias_tc);
        let start = u64::from(u.k) * 10_000_000;
        let r = solved_window(&mut u, start, &mut seq);
        let summary = summary_in(&r).expect("a summary");
        number = summary.solution;
        let k = tracks(&r);
        assert_eq!(k.len(), 12, "window {w}");
        for t in &k {
            assert_eq!(t.solution, number);
            assert_eq!(t.state & TRACK_ADDED, TRACK_ADDED, "{t:?}");
            assert_eq!(usize::from(t.windows), w + 1);
            assert_eq!(t.window_temperature, celsius);
            assert_eq!(t.state & TRACK_DETERMINED != 0, w == 2, "{t:?}");
            // The spin about z holds every z lever arm, and no scale coefficient is in use.
            assert_ne!(t.state & TRACK_SCALE_DRIFT, 0, "{t:?}");
            if w == 0 {
                assert!(
                    t.bias_tc.is_nan() && t.span.is_nan(),
                    "no line from one window"
                );
            } else {
                assert!((t.bias_tc - bias_tc).abs() < 1e-5, "{t:?}");
                assert_eq!(t.span, 15.0 * w as f32);
            }
        }
    }
    // Solving the same window again reports the track, adds nothing.
    let again = u.command(&tc(
        service::BALLISTOMETER,
        subtype::REPORT_IDENTIFICATION,
        &[],
        seq,
    ));
    seq += 1;
    let k = tracks(&again);
    assert!(
        k.iter()
            .all(|t| t.state == TRACK_DETERMINED | TRACK_SCALE_DRIFT && t.windows == 3),
        "{k:?}"
    );
    number += 1;
    // The commit: the solution's geometry with the track's bias at t_ref and coefficient.
    u.command(&tc(
        service::BALLISTOMETER,
        subtype::COMMIT_CALIBRATION,
        &number.to_be_bytes(),
        seq,
    ));
    seq += 1;
    let request = u.app.take_commit().expect("a commit");
    for c in 0..12 {
        let th = request
            .arrangement
            .thermal(c)
            .expect("coefficients committed");
        assert!(
            (th.bias_tc - f64::from(bias_tc)).abs() < 1e-5,
            "{c}: {th:?}"
        );
        assert_eq!(th.scale_tc, 0.0);
        assert!((th.t_ref - 25.0).abs() < 1e-3, "{c}: {th:?}");
        // The bias at 25 °C is the one without temperature (the spin's σ0 along the axis).
        let at_ref = request.arrangement.channels()[c].bias;
        let axis_z = u.cfg.arrangement.channels()[c].axis[2];
        assert!(
            (at_ref - 0.1 * axis_z).abs() < 1e-4,
            "{c}: {at_ref} vs {}",
            0.1 * axis_z
        );
    }
    block_on(u.app.on_commit_reply(
        ballisto_fw::storage::CommitReply::Stored { id: 2, crc: 1 },
        0,
        &mut u.tm,
    ));
    // A new arrangement: the windows' biases were for the old one.
    let r = u.command(&tc(
        service::BALLISTOMETER,
        subtype::LOAD_ARRANGEMENT,
        &shifted_arrangement(&u.cfg.clone(), 0.0),
        seq,
    ));
    seq += 1;
    assert!(
        r.iter()
            .filter(|p| matches!(p.report, Report::Verification(_)))
            .all(|p| verification(p).1.is_none()),
        "{r:?}"
    );
    let start = u64::from(u.k) * 10_000_000;
    let k = tracks(&solved_window(&mut u, start, &mut seq));
    assert!(k.iter().all(|t| t.windows == 1), "{k:?}");
}
