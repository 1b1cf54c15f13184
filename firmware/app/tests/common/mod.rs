//! The harness of the application's end-to-end tests: a unit (the application, its
//! telemetry and its identification task) fed sample sets and telecommands, and the decoded
//! stream. Each test binary uses part of it.
#![allow(dead_code)]

use std::convert::Infallible;

use arbitrary_int::{u11, u14};
use ballisto_fw::app::{App, Incoming, Mode};
use ballisto_fw::config::{tetra, AppConfig, MAX_PARTS};
use ballisto_fw::identification::{Identification, Identifier};
use ballisto_fw::sampler::{Health, HealthBoard, SampleSet};
use ballisto_fw::telemetry::Telemetry;
use ballisto_link::decode::{decode, Decoded, Report};
use ballisto_link::framing::{Deframed, Deframer};
use ballisto_link::{service, subtype, FailureCode, APID};
use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use estimator_core::Model;
use futures::executor::block_on;
use futures::FutureExt;
use spacepackets::ecss::tc::{AckFlags, PusTcCreator, PusTcSecondaryHeader};
use spacepackets::ecss::{CreatorConfig, MessageTypeId};
use spacepackets::SpHeader;

/// The link: everything written is kept.
#[derive(Default)]
pub struct Capture(pub Vec<u8>);

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

pub fn packets(stream: &[u8]) -> Vec<Decoded> {
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
pub fn tc(s: u8, st: u8, data: &[u8], seq: u16) -> Vec<u8> {
    let sp = SpHeader::new_for_unseg_tc(u11::new(APID), u14::new(seq), 0);
    let sec = PusTcSecondaryHeader::new(MessageTypeId::new(s, st), AckFlags::ALL, 0);
    PusTcCreator::new(sp, sec, data, CreatorConfig::default())
        .to_vec()
        .unwrap()
}

pub fn incoming(raw: &[u8]) -> Incoming {
    let mut i = Incoming::new();
    i.set_packet(raw);
    i
}

/// A sample set of a body spinning at 0.5 rad/s about z (all parts present).
pub fn set(cfg: &AppConfig, k: u32) -> SampleSet {
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

pub fn health(cfg: &AppConfig) -> Health {
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
pub fn config() -> AppConfig {
    let mut cfg = tetra();
    cfg.model = Model::FreeFloat;
    cfg
}

pub struct Unit {
    pub cfg: AppConfig,
    pub app: App,
    pub tm: Telemetry<Capture>,
    pub k: u32,
    /// The identification task's queues and state; the task runs after each set and command
    /// (its lower priority on the board) while `identifying` is set.
    pub identifier: &'static Identifier,
    pub window: Box<Identification>,
    pub identifying: bool,
    /// Every part's temperature (°C, NaN: none read) and the bias it adds to every reading
    /// per °C from 25 °C.
    pub thermal: (f32, f32),
}

impl Unit {
    pub fn new() -> Self {
        Self::with(config())
    }

    pub fn with(cfg: AppConfig) -> Self {
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

    pub fn sets(&mut self, n: u32) {
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
    pub fn identification_task(&mut self) {
        if self.identifying {
            self.identifier.run_now(&mut self.window);
        }
        if let Some(solved) = self.identifier.solved().now_or_never() {
            block_on(self.app.on_solved(solved, 0, &mut self.tm));
        }
    }

    /// Sends a command; returns the packets it caused.
    pub fn command(&mut self, raw: &[u8]) -> Vec<Decoded> {
        self.command_at(raw, 0)
    }

    /// Sends a command that arrives `t` ns after boot; returns the packets it caused.
    pub fn command_at(&mut self, raw: &[u8], t: u64) -> Vec<Decoded> {
        let before = self.tm.link().0.len();
        block_on(self.app.on_incoming(&incoming(raw), t, &mut self.tm));
        self.identification_task();
        packets(&self.tm.link().0[before..])
    }

    pub fn all(&mut self) -> Vec<Decoded> {
        packets(&self.tm.link().0)
    }
}

/// TC[200,6]'s application data: `cfg`'s arrangement with every channel moved by `dx` in x.
pub fn shifted_arrangement(cfg: &AppConfig, dx: f64) -> Vec<u8> {
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

pub fn verification(p: &Decoded) -> (u8, Option<(FailureCode, u32)>) {
    match &p.report {
        Report::Verification(v) => (v.subtype, v.failure),
        other => panic!("not a verification report: {other:?}"),
    }
}

pub fn motion_values(unit: &mut Unit) -> Vec<[f32; 9]> {
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

/// A deterministic mutation run of the parser (the fuzz target's body): flipped bits, cut
/// and extended packets of every command, none panics, and a mutated packet with a valid CRC
/// that is still accepted is a well-formed command.
/// A deterministic xorshift64 sequence from `x` (not zero).
pub fn xorshift(mut x: u64) -> impl FnMut() -> u64 {
    move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    }
}

/// TC[200,9] application data: `points` as (on-board ns, Ω).
pub fn reference_data(points: &[(u64, [f32; 3])]) -> Vec<u8> {
    let mut d = vec![points.len() as u8];
    for &(t, omega) in points {
        d.extend_from_slice(&ballisto_link::identification::ReferencePoint { t, omega }.encode());
    }
    d
}

/// TC[200,8] application data: source, period (ms), window (ms).
pub fn start_data(source: u8, period_ms: u16, window_ms: u32) -> Vec<u8> {
    let mut d = vec![source];
    d.extend_from_slice(&period_ms.to_be_bytes());
    d.extend_from_slice(&window_ms.to_be_bytes());
    d
}

/// The identification summary (TM[200,128]) among `packets`.
pub fn summary_in(
    packets: &[Decoded],
) -> Option<ballisto_link::identification::IdentificationSummary> {
    packets.iter().find_map(|p| match p.report {
        Report::IdentificationSummary(s) => Some(s),
        _ => None,
    })
}

/// The identification's commands refused at acceptance, each with its reason.
pub fn bad_identification_commands() -> Vec<(&'static str, Vec<u8>, FailureCode, u32)> {
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
