//! Telecommands end to end through the application: every command's effect and verification
//! reports, every kind of malformed command refused with its reason and without any change of
//! state, and the telemetry stream (CRC, contiguous sequence counts, layouts) decoded back.

mod common;

use arbitrary_int::{u11, u14};
use ballisto_fw::app::Incoming;
use ballisto_fw::config::{tetra, AppConfig};
use ballisto_link::decode::{Decoded, Report};
use ballisto_link::telecommand::{fuzz_one, CHANNEL_LEN};
use ballisto_link::{service, subtype, ChannelSet, EventId, FailureCode};
use estimator_core::Model;
use futures::executor::block_on;
use spacepackets::ecss::tc::{AckFlags, PusTcCreator, PusTcSecondaryHeader};
use spacepackets::ecss::{CreatorConfig, MessageTypeId};
use spacepackets::SpHeader;

use common::*;

#[test]
fn the_stream_decodes_with_contiguous_counts_and_the_estimates_sent() {
    let mut u = Unit::new();
    u.sets(250);
    let all = u.all();
    for (i, p) in all.iter().enumerate() {
        assert_eq!(usize::from(p.sequence), i, "sequence count");
    }
    assert!(matches!(all[0].report, Report::Event(e) if e.id == EventId::Boot));
    let hk: Vec<_> = all
        .iter()
        .filter_map(|p| match &p.report {
            Report::Housekeeping(h) => Some(h),
            _ => None,
        })
        .collect();
    // One at boot and one per second (100 sets).
    assert_eq!(hk.len(), 3);
    assert_eq!(hk[2].estimates, 200);
    assert_eq!((hk[2].channels, hk[2].model, hk[2].mode), (12, 1, 1));
    let motions: Vec<_> = all
        .iter()
        .filter_map(|p| match &p.report {
            Report::Motion(m) => Some((p.t, m)),
            _ => None,
        })
        .collect();
    assert_eq!(motions.len(), 250);
    for (k, (t, m)) in motions.iter().enumerate() {
        assert_eq!(m.k as usize, k);
        assert!((t - k as f64 * 0.01).abs() < 1e-7);
    }
    // The estimate is the spin: Ω = (0, 0, ±0.5) within the noise-free solve's precision.
    let w = motions[249].1.estimate.omega;
    assert!(
        (w[2].abs() - 0.5).abs() < 1e-3 && w[0].abs() < 1e-3,
        "{w:?}"
    );
}

#[test]
fn every_command_is_verified_and_takes_effect() {
    let mut u = Unit::new();
    u.sets(10);
    let ok = |r: &[Decoded]| {
        assert_eq!(verification(&r[0]), (subtype::ACCEPTED, None));
        assert_eq!(verification(r.last().unwrap()), (subtype::COMPLETED, None));
    };
    let b = service::BALLISTOMETER;

    let r = u.command(&tc(b, subtype::EXCLUDE, &[3], 1));
    ok(&r);
    assert_eq!(u.app.estimation().excluded_channels(), ChannelSet(1 << 3));
    assert!(
        matches!(r[1].report, Report::Event(e) if e.id == EventId::ChannelsCommanded && e.a == 0 && e.b == 1 << 3),
        "{:?}",
        r[1]
    );
    let r = u.command(&tc(b, subtype::INCLUDE, &[3], 2));
    ok(&r);
    assert_eq!(u.app.estimation().excluded_channels(), ChannelSet(0));
    assert!(
        matches!(r[1].report, Report::Event(e) if e.id == EventId::ChannelsCommanded && e.a == 1 << 3 && e.b == 0)
    );
    // Including a channel that is in: completed, no event.
    let r = u.command(&tc(b, subtype::INCLUDE, &[3], 2));
    ok(&r);
    assert_eq!(r.len(), 2, "{r:?}");

    let r = u.command(&tc(b, subtype::SET_MODE, &[0], 3));
    ok(&r);
    assert!(
        matches!(r[1].report, Report::Event(e) if e.id == EventId::ModeChanged && e.a == 1 && e.b == 0)
    );
    let before = motion_values(&mut u).len();
    u.sets(5);
    assert_eq!(
        motion_values(&mut u).len(),
        before,
        "no estimates in standby"
    );
    ok(&u.command(&tc(b, subtype::SET_MODE, &[1], 4)));
    u.sets(5);
    assert_eq!(motion_values(&mut u).len(), before + 5);

    let r = u.command(&tc(b, subtype::SET_MODEL, &[0], 5));
    ok(&r);
    assert_eq!(u.app.estimation().estimator().model(), Model::General);
    assert!(
        matches!(r[1].report, Report::Event(e) if e.id == EventId::Reconfigured && e.a == 12 && e.b == 0)
    );

    let hint: Vec<u8> = [0.0f32, 0.0, 0.5]
        .iter()
        .flat_map(|v| v.to_be_bytes())
        .collect();
    ok(&u.command(&tc(b, subtype::SET_HINT, &hint, 6)));

    // The same geometry, shifted by 1 cm in x: accepted, and the estimator has it.
    let data = shifted_arrangement(&u.cfg, 0.01);
    assert_eq!(data.len(), 1 + 12 * CHANNEL_LEN);
    assert_eq!(u.app.calibration(), ballisto_link::CalibrationId::default());
    ok(&u.command(&tc(b, subtype::LOAD_ARRANGEMENT, &data, 7)));
    let got = u.app.estimation().estimator().arrangement().channels()[0].position[0];
    assert!((got - (u.cfg.arrangement.channels()[0].position[0] + 0.01)).abs() < 1e-6);
    // Its identity in housekeeping: commanded, with the CRC-32 of the command's data.
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC).checksum(&data);
    assert_eq!(
        u.app.calibration(),
        ballisto_link::CalibrationId {
            source: ballisto_link::CalibrationSource::Commanded,
            id: 0,
            crc,
        }
    );
    assert_eq!(u.app.housekeeping(0).calibration, Some(u.app.calibration()));

    ok(&u.command(&tc(b, subtype::SET_RATES, &[0, 10, 0, 50], 8)));
    let before = motion_values(&mut u).len();
    u.sets(100);
    assert_eq!(motion_values(&mut u).len(), before + 10);

    let r = u.command(&tc(
        service::HOUSEKEEPING,
        subtype::HK_ONE_SHOT,
        &[1, 0, 2],
        9,
    ));
    assert!(
        matches!(&r[1].report, Report::Housekeeping(h) if h.tc_accepted == 10 && h.motion_every == 10)
    );
    let r = u.command(&tc(service::TEST, subtype::ARE_YOU_ALIVE, &[], 10));
    assert!(matches!(r[1].report, Report::Alive));
    ok(&r);
}

/// TC[200,6] arriving while model F stands in for the configured model G (a channel of the
/// twelve excluded by command: model G unobservable on eleven): the new arrangement is taken,
/// the configured model stays G, model F stays in force while the exclusion does, and the
/// `reconfigured` event says F. When the channel is put back, model G returns — on the new
/// arrangement, not on a configuration set aside before the load (the spare configuration,
/// where the build has it, is dropped by the load).
#[test]
fn an_arrangement_loaded_while_model_f_stands_in_keeps_the_configured_model_and_the_exclusion() {
    let mut u = Unit::with(tetra());
    u.sets(10);
    let b = service::BALLISTOMETER;
    let ok = |r: &[Decoded]| {
        assert_eq!(verification(&r[0]), (subtype::ACCEPTED, None));
        assert_eq!(verification(r.last().unwrap()), (subtype::COMPLETED, None));
    };
    assert_eq!(u.app.estimation().estimator().model(), Model::General);
    ok(&u.command(&tc(b, subtype::EXCLUDE, &[3], 1)));
    assert_eq!(u.app.estimation().estimator().model(), Model::FreeFloat);
    u.sets(5);

    let shift = 0.01;
    let data = shifted_arrangement(&u.cfg, shift);
    let r = u.command(&tc(b, subtype::LOAD_ARRANGEMENT, &data, 2));
    ok(&r);
    let model_f = ballisto_link::ModelCode::from(Model::FreeFloat) as u32;
    assert!(
        r.iter().any(|p| matches!(p.report, Report::Event(e)
            if e.id == EventId::Reconfigured && e.a == 12 && e.b == model_f)),
        "{r:?}"
    );
    let e = u.app.estimation();
    assert_eq!(e.model(), Model::General, "the configured model");
    assert_eq!(
        e.estimator().model(),
        Model::FreeFloat,
        "the model in force"
    );
    assert_eq!(e.excluded_channels(), ChannelSet(1 << 3));
    let x0 = u.cfg.arrangement.channels()[0].position[0] + shift;
    assert!((e.estimator().arrangement().channels()[0].position[0] - x0).abs() < 1e-6);
    let before = motion_values(&mut u).len();
    u.sets(5);
    let after = motion_values(&mut u);
    assert_eq!(after.len(), before + 5);
    assert!(after.iter().flatten().all(|v| v.is_finite()));

    ok(&u.command(&tc(b, subtype::INCLUDE, &[3], 3)));
    let e = u.app.estimation();
    assert_eq!(e.estimator().model(), Model::General);
    assert_eq!(e.excluded_channels(), ChannelSet(0));
    assert!(
        (e.estimator().arrangement().channels()[0].position[0] - x0).abs() < 1e-6,
        "model G back on the loaded arrangement"
    );
}

/// Each bad command: the failure report it must produce.
fn bad_commands(cfg: &AppConfig) -> Vec<(&'static str, Vec<u8>, u8, FailureCode, u32)> {
    let b = service::BALLISTOMETER;
    let good = tc(b, subtype::EXCLUDE, &[3], 20);
    let mut bad_crc = good.clone();
    *bad_crc.last_mut().unwrap() ^= 1;
    let mut trailing = good.clone();
    trailing.push(0);
    let mut tm_type = good.clone();
    tm_type[0] &= !0x10;
    let mut pus_a = tc(b, subtype::EXCLUDE, &[3], 21);
    pus_a[6] = (pus_a[6] & 0x0F) | 0x10;
    let crc = spacepackets::crc::CRC_CCITT_FALSE.checksum(&pus_a[..pus_a.len() - 2]);
    let n = pus_a.len();
    pus_a[n - 2..].copy_from_slice(&crc.to_be_bytes());
    let wrong_apid = {
        let sp = SpHeader::new_for_unseg_tc(u11::new(0x123), u14::new(22), 0);
        let sec = PusTcSecondaryHeader::new(MessageTypeId::new(b, 4), AckFlags::ALL, 0);
        PusTcCreator::new(sp, sec, &[3], CreatorConfig::default())
            .to_vec()
            .unwrap()
    };
    let nan: Vec<u8> = [0.0f32, f32::NAN, 0.5]
        .iter()
        .flat_map(|v| v.to_be_bytes())
        .collect();
    let fast: Vec<u8> = [0.0f32, 0.0, 80.0]
        .iter()
        .flat_map(|v| v.to_be_bytes())
        .collect();
    let mut arrangement = vec![12u8];
    for (i, ch) in cfg.arrangement.channels().iter().enumerate() {
        let noise = if i == 5 { -1.0 } else { ch.noise };
        for v in ch
            .position
            .iter()
            .chain(ch.axis.iter())
            .chain([noise].iter())
        {
            arrangement.extend((*v as f32).to_be_bytes());
        }
    }
    // Every channel at the same point: Ω′ is not observable (the estimator refuses it).
    let mut collapsed = vec![12u8];
    for ch in cfg.arrangement.channels() {
        for v in [0.0, 0.0, 0.0]
            .iter()
            .chain(ch.axis.iter())
            .chain([ch.noise].iter())
        {
            collapsed.extend((*v as f32).to_be_bytes());
        }
    }
    let na = subtype::NOT_ACCEPTED;
    vec![
        (
            "truncated",
            good[..good.len() - 1].to_vec(),
            na,
            FailureCode::Truncated,
            good.len() as u32,
        ),
        (
            "trailing octet",
            trailing,
            na,
            FailureCode::TrailingOctets,
            good.len() as u32,
        ),
        ("bad CRC", bad_crc, na, FailureCode::Checksum, 0),
        (
            "telemetry type",
            tm_type,
            na,
            FailureCode::NotTelecommand,
            0,
        ),
        ("PUS-A", pus_a, na, FailureCode::PusVersion, 1),
        ("other APID", wrong_apid, na, FailureCode::WrongApid, 0x123),
        (
            "unknown subtype",
            tc(b, 99, &[], 23),
            na,
            FailureCode::UnknownCommand,
            200 << 8 | 99,
        ),
        (
            "unknown service",
            tc(8, 1, &[], 24),
            na,
            FailureCode::UnknownCommand,
            8 << 8 | 1,
        ),
        (
            "short data",
            tc(b, subtype::SET_HINT, &[0; 8], 25),
            na,
            FailureCode::DataLength,
            12,
        ),
        (
            "mode 2",
            tc(b, subtype::SET_MODE, &[2], 26),
            na,
            FailureCode::OutOfRange,
            0,
        ),
        (
            "model 7",
            tc(b, subtype::SET_MODEL, &[7], 27),
            na,
            FailureCode::OutOfRange,
            0,
        ),
        (
            "channel 12",
            tc(b, subtype::EXCLUDE, &[12], 28),
            na,
            FailureCode::OutOfRange,
            0,
        ),
        (
            "NaN hint",
            tc(b, subtype::SET_HINT, &nan, 29),
            na,
            FailureCode::NotFinite,
            1,
        ),
        (
            "80 rad/s hint",
            tc(b, subtype::SET_HINT, &fast, 30),
            na,
            FailureCode::OutOfRange,
            2,
        ),
        (
            "negative noise",
            tc(b, subtype::LOAD_ARRANGEMENT, &arrangement, 31),
            na,
            FailureCode::OutOfRange,
            1 + 7 * 5 + 6,
        ),
        (
            "9 channels",
            tc(
                b,
                subtype::LOAD_ARRANGEMENT,
                &arrangement[..1 + 9 * CHANNEL_LEN],
                32,
            ),
            na,
            FailureCode::DataLength,
            1 + 12 * CHANNEL_LEN as u32,
        ),
        (
            "zero decimation",
            tc(b, subtype::SET_RATES, &[0, 0, 0, 1], 33),
            na,
            FailureCode::OutOfRange,
            0,
        ),
        (
            "unknown SID",
            tc(service::HOUSEKEEPING, subtype::HK_ONE_SHOT, &[1, 0, 9], 34),
            na,
            FailureCode::OutOfRange,
            1,
        ),
        (
            "collapsed geometry",
            tc(b, subtype::LOAD_ARRANGEMENT, &collapsed, 35),
            subtype::NOT_COMPLETED,
            FailureCode::Refused,
            8 << 16,
        ),
    ]
}

#[test]
fn malformed_commands_are_refused_with_their_reason_and_change_nothing() {
    let mut reference = Unit::new();
    let mut u = Unit::new();
    reference.sets(20);
    u.sets(20);
    for (what, raw, st, code, data) in bad_commands(&u.cfg) {
        let r = u.command(&raw);
        let last = verification(r.last().unwrap());
        assert_eq!(last, (st, Some((code, data))), "{what}");
        u.sets(3);
        reference.sets(3);
    }
    // Too many channels out for model F (9 needed): the fourth exclusion fails at completion.
    for (c, seq) in [(0u8, 40u16), (1, 41), (2, 42)] {
        let r = u.command(&tc(service::BALLISTOMETER, subtype::EXCLUDE, &[c], seq));
        assert_eq!(verification(r.last().unwrap()).0, subtype::COMPLETED);
    }
    let r = u.command(&tc(service::BALLISTOMETER, subtype::EXCLUDE, &[4], 43));
    let (st, failure) = verification(r.last().unwrap());
    assert_eq!(
        (st, failure.map(|f| (f.0, f.1 >> 16))),
        (subtype::NOT_COMPLETED, Some((FailureCode::Refused, 6)))
    );
    assert_eq!(u.app.estimation().excluded_channels(), ChannelSet(0b111));
    for (c, seq) in [(0u8, 44u16), (1, 45), (2, 46)] {
        u.command(&tc(service::BALLISTOMETER, subtype::INCLUDE, &[c], seq));
    }
    // Nothing the refused commands carried reached the estimator: the same estimates, bit for
    // bit, as the unit that received none of them (history is restarted by the exclusions,
    // so compare the sets before them).
    let (a, b) = (motion_values(&mut u), motion_values(&mut reference));
    assert_eq!(a.len(), b.len());
    assert_eq!(a, b);
    let hk = u.app.housekeeping(0);
    // 18 refused at acceptance; accepted: the refused geometry, 3 + 1 exclusions, 3 inclusions.
    assert_eq!((hk.tc_rejected, hk.tc_accepted), (18, 8));
    assert_eq!((hk.mode, hk.model, hk.motion_every), (1, 1, 1));
}

#[test]
fn garbage_on_the_link_is_counted_and_reported() {
    let mut u = Unit::new();
    let before = u.all().len();
    let mut garbage = Incoming::new();
    garbage.set_garbage();
    block_on(u.app.on_incoming(&garbage, 5, &mut u.tm));
    u.command(&[0x18, 0xBA]);
    let r = &u.all()[before..];
    assert!(
        matches!(r[0].report, Report::Event(e) if e.id == EventId::FrameRejected && e.a == 1 && e.b == 1)
    );
    assert!(
        matches!(r[1].report, Report::Event(e) if e.id == EventId::FrameRejected && e.a == 2 && e.b == 2)
    );
    assert_eq!(u.app.housekeeping(0).frames_garbage, 2);
}

#[test]
fn mutated_commands_never_panic() {
    let cfg = config();
    let mut seeds: Vec<Vec<u8>> = bad_commands(&cfg).into_iter().map(|c| c.1).collect();
    seeds.extend(bad_identification_commands().into_iter().map(|c| c.1));
    seeds.push(tc(
        service::BALLISTOMETER,
        subtype::REFERENCE_RATE,
        &reference_data(&[
            (1_000_000_000, [0.1, 0.2, 0.3]),
            (1_050_000_000, [0.1, 0.2, 0.3]),
        ]),
        2,
    ));
    seeds.push(tc(
        service::BALLISTOMETER,
        subtype::SET_RATES,
        &[0, 1, 0, 1],
        1,
    ));
    seeds.push(tc(
        service::TIME,
        subtype::SET_TIME,
        &[0, 0, 3, 232, 0, 0, 0],
        3,
    ));
    let mut rnd = xorshift(0x2545F4914F6CDD1D);
    let mut accepted = 0;
    for i in 0..200_000 {
        let mut p = seeds[i % seeds.len()].clone();
        match rnd() % 4 {
            0 => {
                let at = (rnd() as usize) % p.len();
                p[at] ^= 1 << (rnd() % 8);
            }
            1 => p.truncate((rnd() as usize) % (p.len() + 1)),
            2 => p.extend((0..rnd() % 8).map(|_| rnd() as u8)),
            _ => {
                let at = (rnd() as usize) % p.len();
                p[at] = rnd() as u8;
            }
        }
        accepted += usize::from(fuzz_one(&p));
    }
    // Mutations almost always break the CRC; the few accepted are counted, not forbidden.
    assert!(accepted < 2_000, "{accepted}");
}
