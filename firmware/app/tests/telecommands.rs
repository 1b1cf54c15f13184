//! Telecommands end to end through the application: every command's effect and verification
//! reports, every kind of malformed command refused with its reason and without any change of
//! state, and the telemetry stream (CRC, contiguous sequence counts, layouts) decoded back.

use std::convert::Infallible;

use arbitrary_int::{u11, u14};
use ballisto_fw::app::{App, Incoming, Mode};
use ballisto_fw::config::{tetra, AppConfig, MAX_PARTS};
use ballisto_fw::identification::{Identification, Identifier, SET_QUEUE};
use ballisto_fw::sampler::{Health, HealthBoard, SampleSet};
use ballisto_fw::telemetry::Telemetry;
use ballisto_link::decode::{decode, Decoded, Report};
use ballisto_link::framing::{Deframed, Deframer};
use ballisto_link::telecommand::{fuzz_one, CHANNEL_LEN};
use ballisto_link::{service, subtype, ChannelSet, EventId, FailureCode, APID};
use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use estimator_core::Model;
use futures::executor::block_on;
use futures::FutureExt;
use spacepackets::ecss::tc::{AckFlags, PusTcCreator, PusTcSecondaryHeader};
use spacepackets::ecss::{CreatorConfig, MessageTypeId};
use spacepackets::SpHeader;

/// The link: everything written is kept.
#[derive(Default)]
struct Capture(Vec<u8>);

impl embedded_io_async::ErrorType for Capture {
    type Error = Infallible;
}

impl embedded_io_async::Write for Capture {
    async fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        self.0.extend_from_slice(buf);
        Ok(buf.len())
    }

    async fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

fn packets(stream: &[u8]) -> Vec<Decoded> {
    let mut d = Deframer::<400>::new();
    let mut out = Vec::new();
    for &b in stream {
        match d.push(b) {
            Deframed::Packet(n) => out.push(decode(d.packet(n)).expect("a valid packet")),
            Deframed::Garbage => panic!("garbage in the unit's own stream"),
            Deframed::Pending => {}
        }
    }
    out
}

/// A PUS-C telecommand to the unit, all acknowledgements requested.
fn tc(s: u8, st: u8, data: &[u8], seq: u16) -> Vec<u8> {
    let sp = SpHeader::new_for_unseg_tc(u11::new(APID), u14::new(seq), 0);
    let sec = PusTcSecondaryHeader::new(MessageTypeId::new(s, st), AckFlags::ALL, 0);
    PusTcCreator::new(sp, sec, data, CreatorConfig::default())
        .to_vec()
        .unwrap()
}

fn incoming(raw: &[u8]) -> Incoming {
    let mut i = Incoming::new();
    i.set_packet(raw);
    i
}

/// A sample set of a body spinning at 0.5 rad/s about z (all parts present).
fn set(cfg: &AppConfig, k: u32) -> SampleSet {
    let t = f64::from(k) * 0.01;
    let w = [0.0, 0.0, 0.5];
    let mut parts = [None; MAX_PARTS];
    for (i, p) in cfg.sampling.parts() {
        let mut v = [0.0f32; 3];
        for (axis, c) in p.channels.iter().enumerate() {
            let Some(c) = c else { continue };
            let ch = &cfg.arrangement.channels()[usize::from(*c)];
            let r = ch.position;
            // σ(R) = σ0 + Ω×(Ω×R) with σ0 = (0, 0, 0.1) (paper eq. 4, Ω′ = 0).
            let wr = [w[1] * r[2] - w[2] * r[1], w[2] * r[0] - w[0] * r[2], 0.0];
            let wwr = [
                w[1] * wr[2] - w[2] * wr[1],
                w[2] * wr[0] - w[0] * wr[2],
                w[0] * wr[1] - w[1] * wr[0],
            ];
            let sigma = [wwr[0], wwr[1], 0.1 + wwr[2] + 1e-4 * (t * 7.0).sin()];
            v[axis] = (0..3).map(|j| ch.axis[j] * sigma[j]).sum::<f64>() as f32;
        }
        parts[i] = Some(v);
    }
    SampleSet::new(k, u64::from(k) * 10_000_000, parts)
}

fn health(cfg: &AppConfig) -> Health {
    let mut h = Health::default();
    for (i, _) in cfg.sampling.parts() {
        h.parts[i] = Some(ballisto_fw::sampler::PartHealth {
            running: true,
            ..Default::default()
        });
    }
    h
}

/// Model F (9 channels needed) so that up to three of the 12 channels can be spared.
fn config() -> AppConfig {
    let mut cfg = tetra();
    cfg.model = Model::FreeFloat;
    cfg
}

struct Unit {
    cfg: AppConfig,
    app: App,
    tm: Telemetry<Capture>,
    k: u32,
    /// The identification task's queues and state; the task runs after each set and command
    /// (its lower priority on the board) while `identifying` is set.
    identifier: &'static Identifier,
    window: Box<Identification>,
    identifying: bool,
    /// Every part's temperature (°C, NaN: none read) and the bias it adds to every reading
    /// per °C from 25 °C.
    thermal: (f32, f32),
}

impl Unit {
    fn new() -> Self {
        Self::with(config())
    }

    fn with(cfg: AppConfig) -> Self {
        let mut app = App::new(&cfg, Mode::Operate).unwrap();
        let identifier: &'static Identifier = Box::leak(Box::new(Identifier::new()));
        app.attach_identifier(identifier);
        let mut tm = Telemetry::new(Capture::default());
        let mut unit = Unit {
            cfg,
            app,
            tm: Telemetry::new(Capture::default()),
            k: 0,
            identifier,
            window: Box::new(Identification::new()),
            identifying: true,
            thermal: (f32::NAN, 0.0),
        };
        block_on(unit.app.boot(0, &mut tm));
        unit.tm = tm;
        unit
    }

    fn sets(&mut self, n: u32) {
        for _ in 0..n {
            let mut s = set(&self.cfg, self.k);
            let (celsius, bias_tc) = self.thermal;
            if celsius.is_finite() {
                for (part, v) in s.parts.iter_mut().enumerate() {
                    if let Some(v) = v {
                        v.iter_mut().for_each(|x| *x += bias_tc * (celsius - 25.0));
                        s.temperatures[part] = celsius;
                    }
                }
                s.temperature_reads = self.k + 1;
            }
            let board = HealthBoard::<NoopRawMutex>::new();
            board.publish(health(&self.cfg));
            block_on(self.app.on_set(&s, &board, &mut self.tm));
            self.k += 1;
            self.identification_task();
        }
    }

    /// The identification task, if it runs: everything queued to it; a solution it hands over
    /// goes to the application at once (its task waits for it beside sets and commands).
    fn identification_task(&mut self) {
        if self.identifying {
            self.identifier.run_now(&mut self.window);
        }
        if let Some(solved) = self.identifier.solved().now_or_never() {
            block_on(self.app.on_solved(solved, 0, &mut self.tm));
        }
    }

    /// Sends a command; returns the packets it caused.
    fn command(&mut self, raw: &[u8]) -> Vec<Decoded> {
        self.command_at(raw, 0)
    }

    /// Sends a command that arrives `t` ns after boot; returns the packets it caused.
    fn command_at(&mut self, raw: &[u8], t: u64) -> Vec<Decoded> {
        let before = self.tm.link().0.len();
        block_on(self.app.on_incoming(&incoming(raw), t, &mut self.tm));
        self.identification_task();
        packets(&self.tm.link().0[before..])
    }

    fn all(&mut self) -> Vec<Decoded> {
        packets(&self.tm.link().0)
    }
}

/// TC[200,6]'s application data: `cfg`'s arrangement with every channel moved by `dx` in x.
fn shifted_arrangement(cfg: &AppConfig, dx: f64) -> Vec<u8> {
    let channels = cfg.arrangement.channels();
    let mut data = vec![channels.len() as u8];
    for ch in channels {
        let p = [ch.position[0] + dx, ch.position[1], ch.position[2]];
        for v in p.iter().chain(ch.axis.iter()).chain([ch.noise].iter()) {
            data.extend((*v as f32).to_be_bytes());
        }
    }
    data
}

fn verification(p: &Decoded) -> (u8, Option<(FailureCode, u32)>) {
    match &p.report {
        Report::Verification(v) => (v.subtype, v.failure),
        other => panic!("not a verification report: {other:?}"),
    }
}

fn motion_values(unit: &mut Unit) -> Vec<[f32; 9]> {
    unit.all()
        .iter()
        .filter_map(|p| match &p.report {
            Report::Motion(m) => {
                let e = &m.estimate;
                let mut v = [0.0; 9];
                v[..3].copy_from_slice(&e.sigma0);
                v[3..6].copy_from_slice(&e.domega);
                v[6..].copy_from_slice(&e.omega);
                Some(v)
            }
            _ => None,
        })
        .collect()
}

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

/// A deterministic mutation run of the parser (the fuzz target's body): flipped bits, cut
/// and extended packets of every command, none panics, and a mutated packet with a valid CRC
/// that is still accepted is a well-formed command.
/// A deterministic xorshift64 sequence from `x` (not zero).
fn xorshift(mut x: u64) -> impl FnMut() -> u64 {
    move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    }
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

/// TC[200,9] application data: `points` as (on-board ns, Ω).
fn reference_data(points: &[(u64, [f32; 3])]) -> Vec<u8> {
    let mut d = vec![points.len() as u8];
    for &(t, omega) in points {
        d.extend_from_slice(&ballisto_link::identification::ReferencePoint { t, omega }.encode());
    }
    d
}

/// TC[200,8] application data: source, period (ms), window (ms).
fn start_data(source: u8, period_ms: u16, window_ms: u32) -> Vec<u8> {
    let mut d = vec![source];
    d.extend_from_slice(&period_ms.to_be_bytes());
    d.extend_from_slice(&window_ms.to_be_bytes());
    d
}

/// The identification's commands refused at acceptance, each with its reason.
fn bad_identification_commands() -> Vec<(&'static str, Vec<u8>, FailureCode, u32)> {
    let b = service::BALLISTOMETER;
    let p = |t: u64| (t, [0.0f32, 0.0, 0.5]);
    let mut bad_pfield = reference_data(&[p(1_000_000_000)]);
    bad_pfield[1] = 0x2E;
    let mut nan = reference_data(&[p(1_000_000_000), p(1_010_000_000)]);
    nan[1 + 20 + 8 + 4..1 + 20 + 8 + 8].copy_from_slice(&f32::NAN.to_be_bytes());
    let many: Vec<_> = (0..17).map(|i| p(1_000_000_000 + i * 10_000_000)).collect();
    // Source 2: the window, then the inertia (xx, yy, zz, xy, xz, yz).
    let tumble = |j: [f32; 6]| {
        let mut d = start_data(2, 100, 10_000);
        for v in j {
            d.extend_from_slice(&v.to_be_bytes());
        }
        d
    };
    vec![
        (
            "source 3",
            tc(
                b,
                subtype::START_IDENTIFICATION,
                &start_data(3, 50, 10_000),
                60,
            ),
            FailureCode::OutOfRange,
            0,
        ),
        (
            "tumble source without the inertia",
            tc(
                b,
                subtype::START_IDENTIFICATION,
                &start_data(2, 50, 10_000),
                60,
            ),
            FailureCode::DataLength,
            31,
        ),
        (
            "tumble with an inertia that is no body's",
            tc(
                b,
                subtype::START_IDENTIFICATION,
                &tumble([1.0, 1.8, 2.5, 3.0, 0.0, 0.0]),
                60,
            ),
            FailureCode::OutOfRange,
            3,
        ),
        (
            "tumble with a NaN in the inertia",
            tc(
                b,
                subtype::START_IDENTIFICATION,
                &tumble([1.0, 1.8, f32::NAN, 0.0, 0.0, 0.0]),
                60,
            ),
            FailureCode::NotFinite,
            5,
        ),
        (
            "period 0",
            tc(
                b,
                subtype::START_IDENTIFICATION,
                &start_data(1, 0, 10_000),
                61,
            ),
            FailureCode::OutOfRange,
            1,
        ),
        (
            "window 0",
            tc(b, subtype::START_IDENTIFICATION, &start_data(1, 50, 0), 62),
            FailureCode::OutOfRange,
            2,
        ),
        (
            "window over an hour",
            tc(
                b,
                subtype::START_IDENTIFICATION,
                &start_data(1, 50, 3_600_001),
                63,
            ),
            FailureCode::OutOfRange,
            2,
        ),
        (
            "start too short",
            tc(b, subtype::START_IDENTIFICATION, &[1, 0, 50], 64),
            FailureCode::DataLength,
            7,
        ),
        (
            "no points",
            tc(b, subtype::REFERENCE_RATE, &[0], 65),
            FailureCode::OutOfRange,
            0,
        ),
        (
            "17 points",
            tc(b, subtype::REFERENCE_RATE, &reference_data(&many), 66),
            FailureCode::OutOfRange,
            0,
        ),
        (
            "points cut short",
            tc(
                b,
                subtype::REFERENCE_RATE,
                &reference_data(&[p(1)])[..15],
                67,
            ),
            FailureCode::DataLength,
            21,
        ),
        (
            "not CUC",
            tc(b, subtype::REFERENCE_RATE, &bad_pfield, 68),
            FailureCode::OutOfRange,
            1,
        ),
        (
            "time going back",
            tc(
                b,
                subtype::REFERENCE_RATE,
                &reference_data(&[p(2_000_000_000), p(1_000_000_000)]),
                69,
            ),
            FailureCode::OutOfRange,
            5,
        ),
        (
            "Ω not finite",
            tc(b, subtype::REFERENCE_RATE, &nan, 70),
            FailureCode::NotFinite,
            7,
        ),
        (
            "Ω over 50 rad/s",
            tc(
                b,
                subtype::REFERENCE_RATE,
                &reference_data(&[(1, [0.0, 51.0, 0.0])]),
                71,
            ),
            FailureCode::OutOfRange,
            3,
        ),
        (
            "report with data",
            tc(b, subtype::REPORT_IDENTIFICATION, &[0], 72),
            FailureCode::DataLength,
            0,
        ),
        (
            "commit without its solution",
            tc(b, subtype::COMMIT_CALIBRATION, &[1], 73),
            FailureCode::DataLength,
            2,
        ),
    ]
}

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

/// The identification summary (TM[200,128]) among `packets`.
fn summary_in(packets: &[Decoded]) -> Option<ballisto_link::identification::IdentificationSummary> {
    packets.iter().find_map(|p| match p.report {
        Report::IdentificationSummary(s) => Some(s),
        _ => None,
    })
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

/// The window's work is the identification task's, below the estimate: with the task stalled
/// every set is still estimated and reported at once; the sets beyond the task's queue are lost
/// to the window and counted in its summary (`not_covered`); an order beyond the queue and a
/// second solve before the first is answered are refused as busy; once the task runs, the
/// solution is reported. A unit without the task refuses the window by name.
#[test]
fn the_estimate_never_waits_for_the_identification_task() {
    use ballisto_link::verification::not_ready;
    let b = service::BALLISTOMETER;
    let busy = Some((FailureCode::NotReady, not_ready::IDENTIFICATION_BUSY));
    let last = |r: &[Decoded]| verification(r.last().unwrap());
    let motion = |r: &[Decoded]| {
        r.iter()
            .filter(|p| matches!(p.report, Report::Motion(_)))
            .count()
    };
    let mut u = Unit::new();
    u.identifying = false;
    let r = u.command(&tc(
        b,
        subtype::START_IDENTIFICATION,
        &start_data(1, 50, 4_000),
        90,
    ));
    assert_eq!(last(&r).0, subtype::COMPLETED);
    // 40 sets while the task does nothing: each estimated and reported.
    let before = u.all().len();
    u.sets(40);
    assert_eq!(motion(&u.all()[before..]), 40);
    let pts = |from: u64| -> Vec<u8> {
        let p: Vec<_> = (0..4)
            .map(|i| (from + i * 50_000_000, [0.0f32, 0.0, 0.5]))
            .collect();
        reference_data(&p)
    };
    // The start and one batch fill the task's two order slots; the next batch is refused.
    let r = u.command(&tc(b, subtype::REFERENCE_RATE, &pts(0), 91));
    assert_eq!(last(&r).0, subtype::COMPLETED);
    let r = u.command(&tc(b, subtype::REFERENCE_RATE, &pts(200_000_000), 92));
    assert_eq!(last(&r), (subtype::NOT_COMPLETED, busy));
    // The task runs again: the rest of the window goes through.
    u.identifying = true;
    u.identification_task();
    for (seq, batch) in (93..).zip(1..10u64) {
        u.sets(20);
        u.command(&tc(
            b,
            subtype::REFERENCE_RATE,
            &pts(batch * 200_000_000),
            seq,
        ));
    }
    // A solve asked while the task is stalled; a second one is busy.
    u.identifying = false;
    let r = u.command(&tc(b, subtype::REPORT_IDENTIFICATION, &[], 110));
    assert_eq!(
        r.iter().map(verification).collect::<Vec<_>>(),
        vec![(subtype::ACCEPTED, None)]
    );
    let r = u.command(&tc(b, subtype::REPORT_IDENTIFICATION, &[], 111));
    assert_eq!(last(&r), (subtype::NOT_COMPLETED, busy));
    let before = u.all().len();
    u.sets(1);
    u.identifying = true;
    u.identification_task();
    let r = u.all()[before..].to_vec();
    let summary = summary_in(&r).expect("the summary once the task has solved");
    assert!(
        summary.not_covered >= (40 - SET_QUEUE) as u32,
        "the sets lost on the way are counted: {summary:?}"
    );
    assert!(summary.sets > 100, "{summary:?}");

    // No identification task: the window is refused by name.
    let cfg = config();
    let mut app = App::new(&cfg, Mode::Operate).unwrap();
    let mut tm = Telemetry::new(Capture::default());
    block_on(app.boot(0, &mut tm));
    let raw = tc(
        b,
        subtype::START_IDENTIFICATION,
        &start_data(1, 50, 4_000),
        5,
    );
    block_on(app.on_incoming(&incoming(&raw), 0, &mut tm));
    let r = packets(&tm.link().0);
    assert_eq!(
        last(&r),
        (
            subtype::NOT_COMPLETED,
            Some((FailureCode::NotReady, not_ready::NO_IDENTIFICATION_TASK))
        )
    );
}

/// TC[9,128] correlates the unit's time to the spacecraft's: the boot's spacecraft time
/// (given minus the unit's time at reception) is in housekeeping from then on; a time before
/// the unit's own time since boot is refused with its reason and changes nothing.
#[test]
fn the_spacecraft_time_sets_the_time_correlation() {
    use ballisto_link::cuc::cuc_ticks;
    use ballisto_link::verification::not_ready;
    let mut u = Unit::new();
    u.sets(10);
    let boot = |u: &Unit| u.app.housekeeping(0).boot.expect("format 2 housekeeping").1;
    assert!(!boot(&u).set, "not correlated before the command");
    let cuc = |ticks: u64| ticks.to_be_bytes()[1..].to_vec();
    let received = 2_500_000_000; // ns after boot
                                  // 1000.5 s of spacecraft time at reception.
    let spacecraft = (1000 << 24) + (1 << 23);
    let refused = u.command_at(
        &tc(
            service::TIME,
            subtype::SET_TIME,
            &cuc(cuc_ticks(received) - 1),
            1,
        ),
        received,
    );
    assert_eq!(verification(&refused[0]), (subtype::ACCEPTED, None));
    assert_eq!(
        verification(refused.last().unwrap()),
        (
            subtype::NOT_COMPLETED,
            Some((FailureCode::NotReady, not_ready::TIME_BEFORE_BOOT))
        )
    );
    assert!(!boot(&u).set, "a refused time changes nothing");
    let r = u.command_at(
        &tc(service::TIME, subtype::SET_TIME, &cuc(spacecraft), 2),
        received,
    );
    assert_eq!(verification(r.last().unwrap()), (subtype::COMPLETED, None));
    let time = boot(&u);
    assert!(time.set);
    assert!((time.epoch_seconds() - 998.0).abs() < 1e-6, "{time:?}");
    // Housekeeping carries it on the link.
    let r = u.command(&tc(
        service::HOUSEKEEPING,
        subtype::HK_ONE_SHOT,
        &[1, 0, 2],
        3,
    ));
    let Report::Housekeeping(h) = &r[1].report else {
        panic!("no housekeeping: {:?}", r[1]);
    };
    assert_eq!(h.boot.map(|b| b.1), Some(time));
    // A wrong length is refused at acceptance.
    let short = u.command(&tc(service::TIME, subtype::SET_TIME, &[0; 6], 4));
    assert_eq!(
        verification(&short[0]),
        (subtype::NOT_ACCEPTED, Some((FailureCode::DataLength, 7)))
    );
}

/// With the builder task (a board without a double-precision FPU) a commanded
/// change is accepted at once and completed at the first set after its configuration is built
/// — the event with it — while the estimates go on (the channel on its way out read as
/// missing: flagged predictions, finite); another configuration command meanwhile is refused
/// as not ready. A refused change completes as refused, nothing changed. A channel back in to
/// the configuration set aside is swapped in and completed at once.
#[test]
fn commanded_changes_built_in_the_background_complete_once_in_force() {
    use ballisto_fw::estimation::Builds;
    use ballisto_link::verification::not_ready;
    use std::future::Future;
    use std::task::{Context, Poll};
    let builds: &'static Builds = Box::leak(Box::new(Builds::background()));
    let mut u = Unit::with(tetra());
    u.app.attach_builds(builds);
    u.sets(10);
    let mut builder = Box::pin(builds.run());
    let waker = futures::task::noop_waker();
    let mut cx = Context::from_waker(&waker);
    let b = service::BALLISTOMETER;
    let since = |u: &mut Unit, n: usize| u.all()[n..].to_vec();

    let r = u.command(&tc(b, subtype::EXCLUDE, &[3], 1));
    assert_eq!(r.len(), 1, "accepted, not completed yet: {r:?}");
    assert_eq!(verification(&r[0]), (subtype::ACCEPTED, None));
    let n = u.all().len();
    u.sets(5);
    let waiting: Vec<_> = since(&mut u, n)
        .into_iter()
        .filter_map(|p| match p.report {
            Report::Motion(m) => Some(m.estimate),
            _ => None,
        })
        .collect();
    assert_eq!(waiting.len(), 5, "an estimate every set");
    for e in &waiting {
        assert!(e.flags.has(estimator_core::Flags::INPUT_INVALID));
        assert!(e.omega.iter().chain(e.sigma0.iter()).all(|v| v.is_finite()));
    }
    assert_eq!(u.app.estimation().excluded_channels(), ChannelSet(0));
    assert_eq!(u.app.estimation().estimator().model(), Model::General);

    let r = u.command(&tc(b, subtype::SET_MODEL, &[1], 2));
    assert_eq!(verification(&r[0]), (subtype::ACCEPTED, None));
    assert_eq!(
        verification(r.last().unwrap()),
        (
            subtype::NOT_COMPLETED,
            Some((FailureCode::NotReady, not_ready::CONFIGURATION_BUSY))
        )
    );

    assert!(matches!(builder.as_mut().poll(&mut cx), Poll::Pending));
    let n = u.all().len();
    u.sets(1);
    let r = since(&mut u, n);
    assert!(
        r.iter().any(|p| matches!(p.report, Report::Event(e)
            if e.id == EventId::ChannelsCommanded && e.a == 0 && e.b == 1 << 3)),
        "{r:?}"
    );
    assert!(
        r.iter().any(|p| matches!(&p.report, Report::Verification(v)
            if v.subtype == subtype::COMPLETED && v.request.sequence & 0x3FFF == 1)),
        "{r:?}"
    );
    let e = u.app.estimation();
    assert_eq!(e.excluded_channels(), ChannelSet(1 << 3));
    assert_eq!(e.estimator().model(), Model::FreeFloat, "eleven channels");

    // A model change, then the channel back: each completed once built.
    let r = u.command(&tc(b, subtype::SET_MODEL, &[1], 3));
    assert_eq!(r.len(), 1, "{r:?}");
    u.sets(3);
    assert_eq!(u.app.estimation().model(), Model::General, "not yet");
    assert!(matches!(builder.as_mut().poll(&mut cx), Poll::Pending));
    let n = u.all().len();
    u.sets(1);
    let r = since(&mut u, n);
    let model_f = ballisto_link::ModelCode::from(Model::FreeFloat) as u32;
    assert!(
        r.iter().any(|p| matches!(p.report, Report::Event(e)
            if e.id == EventId::Reconfigured && e.a == 12 && e.b == model_f)),
        "{r:?}"
    );
    assert_eq!(u.app.estimation().model(), Model::FreeFloat);

    // Eight channels would be left: refused once built, nothing changed.
    for (seq, c) in [(4u16, 0u8), (5, 1)] {
        u.command(&tc(b, subtype::EXCLUDE, &[c], seq));
        assert!(matches!(builder.as_mut().poll(&mut cx), Poll::Pending));
        u.sets(1);
    }
    assert_eq!(u.app.estimation().excluded_channels(), ChannelSet(0b1011));
    u.command(&tc(b, subtype::EXCLUDE, &[2], 6));
    assert!(matches!(builder.as_mut().poll(&mut cx), Poll::Pending));
    let n = u.all().len();
    u.sets(1);
    let r = since(&mut u, n);
    assert!(
        r.iter().any(|p| matches!(&p.report, Report::Verification(v)
            if v.subtype == subtype::NOT_COMPLETED && v.request.sequence & 0x3FFF == 6
                && matches!(v.failure, Some((FailureCode::Refused, _))))),
        "{r:?}"
    );
    assert_eq!(u.app.estimation().excluded_channels(), ChannelSet(0b1011));
    let n = u.all().len();
    u.sets(2);
    assert!(since(&mut u, n).iter().all(|p| match p.report {
        Report::Motion(m) => !m.estimate.flags.has(estimator_core::Flags::INPUT_INVALID),
        _ => true,
    }));

    // A channel back in, to the configuration set aside when it went out: swapped in at once,
    // completed with the command, nothing asked of the builder.
    let r = u.command(&tc(b, subtype::INCLUDE, &[1], 7));
    assert_eq!(verification(r.last().unwrap()), (subtype::COMPLETED, None));
    assert!(
        r.iter().any(|p| matches!(p.report, Report::Event(e)
            if e.id == EventId::ChannelsCommanded && e.a == 0b1011 && e.b == 0b1001)),
        "{r:?}"
    );
    assert_eq!(u.app.estimation().excluded_channels(), ChannelSet(0b1001));
    assert!(!builds.build_now(), "nothing was built");
}

/// Issue 17, the builder's state machine under any order of events: random configuration
/// commands (exclude, include, model, a shifted arrangement), sample sets with part 3 dropping
/// out and back, and builds at random moments. Every configuration command accepted gets
/// exactly one completion or failure report; the estimates stay finite;
/// and once the builder has caught up and the part is back, the channels out are exactly the
/// ones the completed commands left out.
#[test]
fn random_commands_sets_and_builds_keep_every_command_answered() {
    use ballisto_fw::estimation::Builds;
    let mut rnd = xorshift(0x9E37_79B9_7F4A_7C15);
    let b = service::BALLISTOMETER;
    for run in 0..12 {
        let builds: &'static Builds = Box::leak(Box::new(Builds::background()));
        let mut u = Unit::with(tetra());
        u.app.attach_builds(builds);
        let data = shifted_arrangement(&u.cfg, 0.002);
        let mut sent: Vec<u16> = Vec::new();
        let mut seq = 1u16;
        for step in 0..400 {
            match rnd() % 10 {
                0 | 1 => {
                    let c = (rnd() % 12) as u8;
                    let st = if rnd().is_multiple_of(2) {
                        subtype::EXCLUDE
                    } else {
                        subtype::INCLUDE
                    };
                    u.command(&tc(b, st, &[c], seq));
                    sent.push(seq);
                    seq += 1;
                }
                2 => {
                    u.command(&tc(b, subtype::SET_MODEL, &[(rnd() % 2) as u8], seq));
                    sent.push(seq);
                    seq += 1;
                }
                3 => {
                    u.command(&tc(b, subtype::LOAD_ARRANGEMENT, &data, seq));
                    sent.push(seq);
                    seq += 1;
                }
                4..=6 => {
                    builds.build_now();
                }
                _ => {}
            }
            // Part 3 silent now and then (the sets of `set` carry every part).
            let s = set(&u.cfg, u.k);
            let mut s = s;
            if (step / 40) % 3 == 1 {
                s.parts[3] = None;
            }
            let board = HealthBoard::<NoopRawMutex>::new();
            board.publish(health(&u.cfg));
            block_on(u.app.on_set(&s, &board, &mut u.tm));
            u.k += 1;
        }
        // Catch up: the part back, the builder free to finish.
        for _ in 0..300 {
            builds.build_now();
            u.sets(1);
        }
        let all = u.all();
        let mut answered: Vec<u16> = Vec::new();
        for p in &all {
            match &p.report {
                Report::Verification(v) if v.subtype != subtype::ACCEPTED => {
                    answered.push(v.request.sequence & 0x3FFF);
                }
                Report::Motion(m) => {
                    let e = &m.estimate;
                    assert!(
                        e.omega.iter().chain(e.sigma0.iter()).all(|v| v.is_finite()),
                        "run {run}: {e:?}"
                    );
                }
                _ => {}
            }
        }
        // A command refused as busy is answered before the one being built.
        answered.sort_unstable();
        assert_eq!(answered, sent, "run {run}: one answer per command");
        assert!(!u.app.estimation().order_awaited(), "run {run}");
        assert_eq!(
            u.app.estimation().excluded_channels(),
            u.app.estimation().commanded(),
            "run {run}: only the commanded channels out once the part is back"
        );
        // Every channel back by command, then one out: the commands are what is in force.
        let step = |u: &mut Unit, st: u8, c: u8, seq: u16| {
            u.command(&tc(b, st, &[c], seq));
            builds.build_now();
            u.sets(1);
        };
        for c in 0..12u8 {
            if u.app.estimation().commanded().contains(usize::from(c)) {
                step(&mut u, subtype::INCLUDE, c, seq);
                seq += 1;
            }
        }
        assert_eq!(u.app.estimation().excluded_channels(), ChannelSet(0));
        let c = (run % 12) as u8;
        step(&mut u, subtype::EXCLUDE, c, seq);
        let e = u.app.estimation();
        assert_eq!(e.commanded(), ChannelSet(1 << c), "run {run}");
        assert_eq!(e.excluded_channels(), ChannelSet(1 << c), "run {run}");
    }
}
