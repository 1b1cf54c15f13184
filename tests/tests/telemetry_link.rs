//! The firmware's spacecraft link on the simulated rig: telecommands arriving on the uplink
//! in the middle of a run (mode, a refused exclusion, a housekeeping request, line noise,
//! a damaged command) and the decoded downlink that shows their effect; fault events.

use arbitrary_int::{u11, u14};
use ballisto::decode::decode_stream;
use ballisto_fw::config::Alignment;
use ballisto_link::decode::Report;
use ballisto_link::framing;
use ballisto_link::{service, subtype, EventId, FailureCode, APID};
use hal_sim::firmware_host::{firmware_config, run_firmware_with};
use hal_sim::scenario::Scenario;
use spacepackets::ecss::tc::{AckFlags, PusTcCreator, PusTcSecondaryHeader};
use spacepackets::ecss::{CreatorConfig, MessageTypeId};
use spacepackets::SpHeader;

/// A COBS-framed PUS-C telecommand to the unit.
fn frame(s: u8, st: u8, data: &[u8], seq: u16) -> Vec<u8> {
    let sp = SpHeader::new_for_unseg_tc(u11::new(APID), u14::new(seq), 0);
    let sec = PusTcSecondaryHeader::new(MessageTypeId::new(s, st), AckFlags::ALL, 7);
    let raw = PusTcCreator::new(sp, sec, data, CreatorConfig::default())
        .to_vec()
        .unwrap();
    let mut out = vec![0u8; framing::max_encoded_len(raw.len())];
    let n = framing::encode(&raw, &mut out).unwrap();
    out.truncate(n);
    out
}

#[test]
fn commands_on_the_uplink_take_effect_and_are_verified_on_the_downlink() {
    let sc = Scenario::load("tetra-orbit").unwrap();
    let loaded = sc.arrangement().load("arrangement.toml").unwrap();
    let config = firmware_config(&sc, &loaded, Alignment::Interpolate).unwrap();
    let b = service::BALLISTOMETER;
    let mut damaged = frame(b, subtype::SET_MODE, &[0], 4);
    damaged[3] ^= 0x40;
    let uplink = vec![
        (5.0, frame(b, subtype::SET_MODE, &[0], 1)),
        (6.0, frame(b, subtype::SET_MODE, &[1], 2)),
        // Line noise with a delimiter in it, then a command whose octets were damaged.
        (7.0, vec![0x55, 0xAA, 0x00, 0x13]),
        (7.005, damaged),
        (
            8.0,
            frame(service::HOUSEKEEPING, subtype::HK_ONE_SHOT, &[1, 0, 2], 5),
        ),
        // Model G needs all 12 channels: excluded all the same, in model F.
        (9.0, frame(b, subtype::EXCLUDE, &[0], 6)),
    ];
    let mut truth = Vec::new();
    let mut telemetry = Vec::new();
    let report = run_firmware_with(
        &sc,
        &config,
        sc.samples() as u32,
        &uplink,
        &mut telemetry,
        &mut |s, _, tr| {
            truth.push((s.k, tr.omega));
        },
    )
    .unwrap();
    assert_eq!(report.telemetry_bytes, telemetry.len() as u64);
    let stream = decode_stream(&telemetry);
    assert!(stream.problems.is_empty(), "{:?}", stream.problems);

    // Standby from 5 s to 6 s: no estimates for those 100 sets, then back to operate.
    let motions: Vec<_> = stream
        .packets
        .iter()
        .filter_map(|p| match &p.report {
            Report::Motion(m) => Some((p.t, m)),
            _ => None,
        })
        .collect();
    assert_eq!(motions.len(), 2001 - 100);
    assert_eq!(truth.len(), motions.len());
    let gap: Vec<u32> = motions
        .windows(2)
        .filter(|w| w[1].1.k != w[0].1.k + 1)
        .map(|w| w[1].1.k - w[0].1.k)
        .collect();
    assert_eq!(gap, [101]);
    // After the restart (hint = the last Ω before standby), the estimates follow the truth.
    let after: Vec<f64> = motions
        .iter()
        .zip(truth.iter())
        .filter(|(m, _)| m.1.k > 700)
        .map(|(m, (_, w))| {
            (0..3)
                .map(|j| (f64::from(m.1.estimate.omega[j]) - w[j]).powi(2))
                .sum::<f64>()
        })
        .collect();
    let rms = (after.iter().sum::<f64>() / after.len() as f64).sqrt();
    assert!(rms < 5e-3, "Ω RMS after the restart {rms:.2e} rad/s");

    let log: Vec<String> = stream
        .packets
        .iter()
        .filter_map(|p| ballisto::decode::log_line(p, -0.05))
        .filter(|l| !l.contains(" HK ") || l.contains("tc_accepted=3"))
        .collect();
    let verifications: Vec<(u16, u8, Option<FailureCode>)> = stream
        .packets
        .iter()
        .filter_map(|p| match &p.report {
            Report::Verification(v) => Some((
                v.request.sequence & 0x3FFF,
                v.subtype,
                v.failure.map(|f| f.0),
            )),
            _ => None,
        })
        .collect();
    assert_eq!(
        verifications,
        [
            (1, 1, None),
            (1, 7, None),
            (2, 1, None),
            (2, 7, None),
            (4, 2, Some(FailureCode::Checksum)),
            (5, 1, None),
            (5, 7, None),
            (6, 1, None),
            (6, 7, None),
        ],
        "{log:#?}"
    );
    let events: Vec<(EventId, u32, u32)> = stream
        .packets
        .iter()
        .filter_map(|p| match &p.report {
            Report::Event(e) => Some((e.id, e.a, e.b)),
            _ => None,
        })
        .collect();
    assert_eq!(
        events[1..],
        [
            (EventId::ModeChanged, 1, 0),
            (EventId::ModeChanged, 0, 1),
            (EventId::FrameRejected, 1, 1),
            (EventId::FrameRejected, 1, 2),
            (EventId::ChannelsCommanded, 0, 1),
            (EventId::ModelSwitched, 0, 1),
        ],
        "{log:#?}"
    );
    // The requested report counts what came before it: 3 accepted, 1 refused, 2 garbage
    // frames ("55 AA" and "13" are not COBS; the damaged command's leading delimiter ends the
    // noise, so the command itself arrives whole and fails its CRC).
    let hk = &report.housekeeping;
    assert_eq!(
        (hk.tc_accepted, hk.tc_rejected, hk.frames_garbage),
        (4, 1, 2)
    );
    assert_eq!(hk.excluded_channels, ballisto_link::ChannelSet(1));
    assert_eq!(hk.model, 1, "model F in force");
    assert!(log.iter().any(|l| l.contains("HK") && l.contains("tc_accepted=3 tc_rejected=1 frames_garbage=2")), "{log:#?}");
}

#[test]
fn a_dead_part_is_reported_down_and_up_again() {
    let sc = Scenario::load("tetra-orbit-faults").unwrap();
    let loaded = sc.arrangement().load("arrangement.toml").unwrap();
    let config = firmware_config(&sc, &loaded, Alignment::Interpolate).unwrap();
    let mut telemetry = Vec::new();
    let samples = sc.samples() as u32;
    run_firmware_with(
        &sc,
        &config,
        samples,
        &[],
        &mut telemetry,
        &mut |_, _, _| {},
    )
    .unwrap();
    let stream = decode_stream(&telemetry);
    assert!(stream.problems.is_empty(), "{:?}", stream.problems);
    let events: Vec<(f64, EventId, u32)> = stream
        .packets
        .iter()
        .filter_map(|p| match &p.report {
            Report::Event(e) if e.id != EventId::Boot => Some((p.t - 0.05, e.id, e.a)),
            _ => None,
        })
        .collect();
    // The stuck part (5–6 s) and the bias jump (from 10 s) are seen by model G's known-field
    // test: a suspicion opens within 0.1 s of each. The first closes when the stuck
    // part is taken out; the second stands to the end, also through the dead part's outage,
    // when model F on the nine channels left has no test (`Suspicion`).
    let suspicions: Vec<(f64, u32)> = events
        .iter()
        .filter(|e| e.1 == EventId::FaultSuspected)
        .map(|e| (e.0, e.2))
        .collect();
    assert_eq!(suspicions.len(), 3, "{suspicions:?}");
    assert_eq!(
        (suspicions[0].1, suspicions[1].1, suspicions[2].1),
        (1, 0, 1)
    );
    assert!((5.0..5.1).contains(&suspicions[0].0), "{suspicions:?}");
    assert!((5.0..5.2).contains(&suspicions[1].0), "{suspicions:?}");
    assert!((10.0..10.1).contains(&suspicions[2].0), "{suspicions:?}");
    // The stuck part (u1) is named from its own signal within 0.1 s of the 10 sets it takes.
    let named: Vec<&(f64, EventId, u32)> = events
        .iter()
        .filter(|e| e.1 == EventId::PartIsolated)
        .collect();
    assert_eq!(named.len(), 1, "{events:?}");
    assert_eq!(named[0].2, 1);
    assert!((5.09..5.2).contains(&named[0].0), "{named:?}");
    let isolated_at = named[0].0;
    let events: Vec<(f64, EventId, u32)> = events
        .into_iter()
        .filter(|e| e.1 != EventId::FaultSuspected && e.1 != EventId::PartIsolated)
        .collect();
    // Twelve channels less a part do not carry model G: each part out (u1 while stuck, u3
    // while dead from 14 s to 15 s and for 100 good sets after) puts the estimate in model F
    // on the nine left, and its return back in model G, each reported. u3 is marked
    // down after 10 failed reads and up when it answers.
    use EventId::*;
    let expected: [(EventId, u32, f64); 10] = [
        (PartsExcluded, 0b10, isolated_at),
        (ModelSwitched, 0, isolated_at),
        (PartsIncluded, 0, 6.0),
        (ModelSwitched, 1, 6.0),
        (PartsExcluded, 0b1000, 14.04),
        (ModelSwitched, 0, 14.04),
        (PartDown, 3, 14.09),
        (PartUp, 3, 15.0),
        (PartsIncluded, 0, 15.99),
        (ModelSwitched, 1, 15.99),
    ];
    assert_eq!(events.len(), expected.len(), "{events:?}");
    for (e, (id, a, t)) in events.iter().zip(expected) {
        assert_eq!((e.1, e.2), (id, a), "{events:?}");
        assert!((e.0 - t).abs() < 0.015, "{e:?} expected at {t} s");
    }
    // Housekeeping during the outage shows the part down with its missed sets.
    let down = stream.packets.iter().find_map(|p| match &p.report {
        Report::Housekeeping(h) if p.t - 0.05 > 14.2 && p.t - 0.05 < 15.0 => Some(*h),
        _ => None,
    });
    let down = down.expect("a housekeeping report during the outage");
    let u3 = down.parts[3];
    assert_eq!(u3.state, ballisto_link::PartState::Down);
    assert!(u3.missed >= 10 && u3.implausible >= 10, "{down:?}");
    // The consistency test it says is run: model G's known field on the twelve channels, none
    // on the nine left in model F (issue 17: "say when no test is possible").
    use ballisto_link::ConsistencyTest;
    assert_eq!(down.test, Some(ConsistencyTest::None), "{down:?}");
    let before = stream.packets.iter().find_map(|p| match &p.report {
        Report::Housekeeping(h) if p.t > 1.5 && p.t < 4.5 => Some(*h),
        _ => None,
    });
    let before = before.expect("a housekeeping report before the faults");
    assert_eq!(before.test, Some(ConsistencyTest::KnownField), "{before:?}");
}

/// The decoder reads the motion report of telemetry format 3 (160 octets: the protection
/// levels), format 2's (148: mode and model; the levels' cells empty), the layout before it
/// (146: no context) and the one before the branch margin (142: the margin is absent, NaN, and
/// the estimates file's cell empty); any other length is refused.
#[test]
fn motion_reports_of_every_layout_decode() {
    use ballisto_link::decode::{decode, DecodeError};
    use ballisto_link::ids::TM_MAX;
    use ballisto_link::motion::{
        MOTION_LEN, MOTION_LEN_NO_CONTEXT, MOTION_LEN_NO_MARGIN, MOTION_LEN_NO_PROTECTION,
    };
    use ballisto_link::{tm, ChannelSet, Mode, ModelCode, MotionReport, PartSet};
    let m = MotionReport {
        k: 9,
        estimate: estimator_core::Estimate {
            omega: [1.0, 2.0, 3.0],
            branch_margin: 33.0,
            protection: Some([0.5, 0.25, 0.125]),
            ..Default::default()
        },
        missing_parts: PartSet(0),
        excluded_parts: PartSet(0),
        excluded_channels: ChannelSet(5),
        context: Some((Mode::Operate, ModelCode::FreeFloat)),
    };
    let packet = |len: usize| {
        let mut p = [0u8; TM_MAX];
        let n = tm::build(
            &mut p,
            1,
            0,
            service::HOUSEKEEPING,
            subtype::HK_REPORT,
            0,
            |d| m.encode(d).map(|_| len),
        )
        .unwrap();
        p[..n].to_vec()
    };
    let operate = Some((Mode::Operate, ModelCode::FreeFloat));
    let levels = Some([0.5, 0.25, 0.125]);
    for (len, margin, context, protection) in [
        (MOTION_LEN, Some(33.0), operate, levels),
        (MOTION_LEN_NO_PROTECTION, Some(33.0), operate, None),
        (MOTION_LEN_NO_CONTEXT, Some(33.0), None, None),
        (MOTION_LEN_NO_MARGIN, None, None, None),
    ] {
        let Report::Motion(r) = decode(&packet(len)).expect("decodes").report else {
            panic!("not a motion report");
        };
        assert_eq!(r.context, context);
        assert_eq!(r.estimate.protection, protection);
        assert_eq!((r.k, r.estimate.omega), (9, [1.0, 2.0, 3.0]));
        assert_eq!(r.excluded_channels.0, 5);
        match margin {
            Some(v) => assert_eq!(r.estimate.branch_margin, v),
            None => assert!(r.estimate.branch_margin.is_nan()),
        }
        let mut row = Vec::new();
        let excluded = u64::from(r.excluded_channels.0);
        ballisto::estimates_csv::write_row(&mut row, 0.0, &r.estimate, false, excluded).unwrap();
        let row = String::from_utf8(row).unwrap();
        let mut fields = row.trim_end_matches('\n').rsplit(',');
        let pl: Vec<&str> = fields.by_ref().take(3).collect();
        let expected: Vec<String> = match protection {
            Some(p) => p.iter().rev().map(|v| format!("{v}")).collect(),
            None => vec![String::new(); 3],
        };
        assert_eq!(pl, expected, "the protection levels");
        assert_eq!(fields.next(), Some("5"), "the excluded column");
        let margin_field = fields.next().unwrap().to_string();
        assert_eq!(
            margin_field,
            margin.map_or(String::new(), |v| format!("{v}"))
        );
    }
    assert!(matches!(
        decode(&packet(MOTION_LEN - 1)),
        Err(DecodeError::Data(..))
    ));
}

/// The decoder reads the housekeeping report with the consistency test (284 octets), the layout
/// before it (283: the test unknown), and the one before the calibration identity (261: the
/// identity unknown); any other length is refused; a source or test code it does not know is
/// refused too.
#[test]
fn housekeeping_with_and_without_the_calibration_identity_decodes() {
    use ballisto_link::decode::{decode, DecodeError};
    use ballisto_link::housekeeping::{
        HOUSEKEEPING_LEN, HOUSEKEEPING_LEN_NO_CALIBRATION, HOUSEKEEPING_LEN_NO_TEST,
    };
    use ballisto_link::ids::TM_MAX;
    use ballisto_link::{tm, CalibrationId, CalibrationSource, ConsistencyTest, Housekeeping};
    let id = CalibrationId {
        source: CalibrationSource::Flash,
        id: 42,
        crc: 0xDEAD_BEEF,
    };
    let hk = Housekeeping {
        channels: 12,
        estimates: 77,
        calibration: Some(id),
        test: Some(ConsistencyTest::KnownField),
        ..Default::default()
    };
    let packet = |len: usize, patch: Option<(usize, u8)>| {
        let mut p = [0u8; TM_MAX];
        let n = tm::build(
            &mut p,
            1,
            0,
            service::HOUSEKEEPING,
            subtype::HK_REPORT,
            0,
            |d| {
                hk.encode(d)?;
                if let Some((at, v)) = patch {
                    d[at] = v;
                }
                Some(len)
            },
        )
        .unwrap();
        p[..n].to_vec()
    };
    for (len, expected, test) in [
        (
            HOUSEKEEPING_LEN,
            Some(id),
            Some(ConsistencyTest::KnownField),
        ),
        (HOUSEKEEPING_LEN_NO_TEST, Some(id), None),
        (HOUSEKEEPING_LEN_NO_CALIBRATION, None, None),
    ] {
        let Report::Housekeeping(h) = decode(&packet(len, None)).expect("decodes").report else {
            panic!("not housekeeping");
        };
        assert_eq!((h.channels, h.estimates), (12, 77));
        assert_eq!((h.calibration, h.test), (expected, test));
    }
    assert!(matches!(
        decode(&packet(HOUSEKEEPING_LEN_NO_TEST - 1, None)),
        Err(DecodeError::Data(..))
    ));
    // Test code 9 at offset 283: refused.
    assert!(matches!(
        decode(&packet(HOUSEKEEPING_LEN, Some((283, 9)))),
        Err(DecodeError::Data(..))
    ));
    // Source code 7 at offset 261: refused, not guessed.
    assert!(matches!(
        decode(&packet(HOUSEKEEPING_LEN, Some((261, 7)))),
        Err(DecodeError::Data(..))
    ));
}

/// `ballisto decode` follows each report kind's message type counter (telemetry format 2): a
/// lost packet is named by its kind as well as counted by the sequence count; a boot event
/// starts the counters again; a format-1 stream (every counter 0) shows no gaps.
#[test]
fn the_decoder_names_the_kind_of_each_lost_report() {
    use ballisto_link::ids::TM_MAX;
    use ballisto_link::{tm, Event, Housekeeping};
    // (sequence, type counter, the packet: an event `id` or, with `None`, housekeeping).
    let packet = |seq: u16, counter: u16, event: Option<EventId>| {
        let mut p = [0u8; TM_MAX];
        let (s, st) = match event {
            Some(id) => (service::EVENT, id.severity()),
            None => (service::HOUSEKEEPING, subtype::HK_REPORT),
        };
        let n = tm::build(&mut p, seq, counter, s, st, 0, |d| match event {
            Some(id) => Event { id, a: 1, b: 2 }.encode(d),
            None => Housekeeping::default().encode(d),
        })
        .unwrap();
        let mut out = vec![0u8; framing::max_encoded_len(n)];
        let m = framing::encode(&p[..n], &mut out).unwrap();
        out.truncate(m);
        out
    };
    let mode = Some(EventId::ModeChanged);
    let stream = |packets: &[(u16, u16, Option<EventId>)]| {
        let bytes: Vec<u8> = packets
            .iter()
            .flat_map(|&(seq, c, e)| packet(seq, c, e))
            .collect();
        decode_stream(&bytes)
    };
    // The event of sequence count 3 (its kind's third, counter 2) is lost.
    let lossy = stream(&[
        (0, 0, mode),
        (1, 0, None),
        (2, 1, mode),
        (4, 1, None),
        (5, 3, mode),
        (6, 2, None),
    ]);
    assert_eq!(lossy.packets.len(), 6);
    assert_eq!(lossy.problems.len(), 2, "{:?}", lossy.problems);
    assert!(lossy.problems[0].contains("sequence count 4 where 3 was due (1 packets lost)"));
    let (s, st) = (service::EVENT, EventId::ModeChanged.severity());
    assert!(
        lossy.problems[1].contains(&format!(
            "TM[{s},{st}] message type counter 3 where 2 was due (1 of that kind lost)"
        )),
        "{:?}",
        lossy.problems
    );
    // A boot event starts every count again; format 1 carries 0 throughout.
    let rebooted = stream(&[
        (0, 0, mode),
        (1, 1, mode),
        (2, 0, Some(EventId::Boot)),
        (3, 0, mode),
        (4, 1, mode),
    ]);
    assert!(rebooted.problems.is_empty(), "{:?}", rebooted.problems);
    let format1 = stream(&[(0, 0, mode), (1, 0, None), (2, 0, mode), (3, 0, mode)]);
    assert!(format1.problems.is_empty(), "{:?}", format1.problems);
}
