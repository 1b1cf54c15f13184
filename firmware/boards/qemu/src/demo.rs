//! The built-in scenario: what a board without accelerometers runs (QEMU in CI), and what
//! the host recomputes to check it, in two boots of the `tetra` board on the synthetic motion
//! of [`crate::synthetic`], whose true geometry is not the nominal one ([`truth`]:
//! u2 mounted 3 mm off).
//!
//! 1. Power-on, the store erased: the nominal arrangement, in free flight, for [`BOOT1_SETS`]
//!    sets; the ground identifies the geometry from a reference rate ([`identification`]:
//!    TC[200,8], the reference in TC[200,9] batches, TC[200,10]) and commits the solution
//!    (TC[200,11]) through the storage task. Then a reset.
//! 2. The calibration read back from the store, for [`SETS`] sets: one part silent for half a
//!    second ([`OUTAGE`]), one stuck for 0.4 s ([`STUCK`]), and a script of telecommands
//!    ([`SCRIPT`]) that exercises every path: mode changes, a housekeeping request, line
//!    noise, a damaged command, a model change, an exclusion.

use ballisto_link::identification::{ReferencePoint, POINT_LEN};
use ballisto_link::telecommand::{self, Command, ACK_ACCEPTANCE, ACK_COMPLETION};
use ballisto_link::{framing, Mode};
use embedded_io_async::{ErrorType, Read};
use estimator_core::Model;

use core::ops::Range;

use ballisto_link::CalibrationId;
use embedded_storage_async::nor_flash::NorFlash;
use estimator_core::Arrangement;

use ballisto_fw::calstore::{select_at_boot, CalibrationStore};
use ballisto_fw::config::{tetra, AppConfig, MAX_CHANNELS};
use ballisto_fw::time::{Nanos, TimeBase};

use crate::synthetic::{motion, Outage};

/// Sample sets of the second boot (10 s at 100 Hz).
pub const SETS: u32 = 1000;

/// Sample sets of the third boot, after the watchdog's reset (3 s at 100 Hz).
pub const BOOT3_SETS: u32 = 300;

/// Sample sets of the first boot, the identification's (28 s at 100 Hz: the window, the solve
/// — about 1.7 s of the QEMU board's M4F in soft f64, below the estimate — and the commit).
pub const BOOT1_SETS: u32 = 2800;

/// When the ground commits, after the window's last set (s): once the solution is reported, as
/// an operator who needs its number does (the QEMU board's solve takes about 1.7 s; the host's
/// none).
const COMMIT_AFTER_S: f64 = 4.0;

/// The part mounted off its nominal position, and by how much (m, body frame).
pub const MOUNTING_ERROR: (usize, [f64; 3]) = (2, [0.003, -0.002, 0.0]);

/// The identification window: from set 50 (0.5 s) for 20 s — about one period of the motion's
/// slowest component, so that Ω turns enough to tell a channel's position from its bias —
/// the reference every fifth set (20 Hz), four points per TC[200,9], each batch 50 ms after
/// its last point.
const WINDOW_FIRST: u32 = 50;
const WINDOW_SETS: u32 = 2000;
const REFERENCE_EVERY: u32 = 5;
const BATCH: u32 = 4;
/// TC[200,8]: the reference source, its period (50 ms) and the window (ms), which ends half a
/// period after a set, so that the same sets are in it wherever between two sets the command
/// is taken (on the host at a set's instant, on the board just before it).
const START: Command<'static> = Command::StartIdentification {
    period_ms: 50,
    window_ms: WINDOW_SETS * 10 + 5,
    inertia: None,
};

/// Part u3 silent from 4.0 s to 4.5 s.
pub const OUTAGE: Outage = Outage {
    part: 3,
    from: 4.0,
    to: 4.5,
};

/// Part u1's output stuck from 8.3 s to 8.7 s: the fault monitor isolates it (its own signal
/// frozen), the estimate goes on without it, and it is re-admitted once it moves again.
pub const STUCK: Outage = Outage {
    part: 1,
    from: 8.3,
    to: 8.7,
};

/// The configuration: the built-in `tetra` board.
pub fn config() -> AppConfig {
    tetra()
}

/// The board as built: [`config`] with part [`MOUNTING_ERROR`]'s channels off their nominal
/// position (what the synthetic parts read; the estimator knows only the nominal geometry
/// until it is identified).
pub fn truth() -> AppConfig {
    let mut config = config();
    let (part, offset) = MOUNTING_ERROR;
    let channels = config.sampling.parts[part].map_or([None; 3], |p| p.channels);
    let mut arrangement = Arrangement::<MAX_CHANNELS>::new();
    for (c, ch) in config.arrangement.channels().iter().enumerate() {
        let mut position = ch.position;
        if channels.contains(&Some(c as u8)) {
            for (x, d) in position.iter_mut().zip(offset) {
                *x += d;
            }
        }
        // The nominal channels are valid and a few mm change none of that.
        let _ = arrangement.push(position, ch.axis, ch.noise);
    }
    config.arrangement = arrangement;
    config
}

/// A boot on `flash` (`range` of it, whole sectors): the configuration with the arrangement
/// the store gives (the nominal one on an erased store), its identity and the store, which
/// the board's storage task takes.
pub async fn boot<F: NorFlash>(
    flash: F,
    range: Range<u32>,
) -> Result<(AppConfig, CalibrationId, CalibrationStore<F>), &'static str> {
    let mut config = config();
    let mut store = CalibrationStore::new(flash, range).map_err(|_| "store range")?;
    let (arrangement, id, _) = select_at_boot(&mut store, &config.arrangement).await;
    config.arrangement = arrangement;
    Ok((config, id, store))
}

/// What arrives on the uplink.
#[derive(Clone, Copy, Debug)]
pub enum Step {
    /// A telecommand TC[service, subtype] with application data, all acknowledgements asked.
    Command(Command<'static>),
    /// The same, its CRC damaged on the line.
    Damaged(Command<'static>),
    /// Line noise.
    Noise(&'static [u8]),
    /// TC[200,9]: the reference rate (the synthetic motion's Ω) at `points` sample instants,
    /// every `every`-th from set `first`, on the unit's time.
    Reference {
        /// The set of the first point.
        first: u32,
        /// Sets between points.
        every: u32,
        /// Points (at most `MAX_POINTS`).
        points: u32,
    },
}

/// A script: its `i`-th step (seconds after the first instant, what arrives), in time order.
pub type Script = fn(usize) -> Option<(f64, Step)>;

/// [`SCRIPT`] as a [`Script`] (the second boot's uplink).
pub fn script(i: usize) -> Option<(f64, Step)> {
    SCRIPT.get(i).copied()
}

/// The first boot's uplink: the identification, as the ground runs it. TC[200,8] just before
/// the window; the reference, every fifth set of the window, in batches of four points each
/// sent 50 ms after its last point; TC[200,10] after the last batch; TC[200,11] committing
/// solution 1 once it is reported.
pub fn identification(i: usize) -> Option<(f64, Step)> {
    let batches = WINDOW_SETS.div_ceil(REFERENCE_EVERY * BATCH) as usize;
    let at = |set: u32| f64::from(set) * 0.01;
    let last = WINDOW_FIRST + WINDOW_SETS;
    match i {
        0 => Some((at(WINDOW_FIRST) - 0.005, Step::Command(START))),
        i if i <= batches => {
            let first = WINDOW_FIRST + (i as u32 - 1) * REFERENCE_EVERY * BATCH;
            let points = BATCH.min((last - first).div_ceil(REFERENCE_EVERY));
            let end = first + (points - 1) * REFERENCE_EVERY;
            let step = Step::Reference {
                first,
                every: REFERENCE_EVERY,
                points,
            };
            Some((at(end) + 0.055, step))
        }
        i if i == batches + 1 => Some((
            at(last) + 0.205,
            Step::Command(Command::ReportIdentification),
        )),
        i if i == batches + 2 => Some((
            at(last) + COMMIT_AFTER_S,
            Step::Command(Command::CommitCalibration { solution: 1 }),
        )),
        _ => None,
    }
}

/// An uplink on which nothing arrives.
pub fn quiet(_: usize) -> Option<(f64, Step)> {
    None
}

/// The uplink script: (seconds after the first instant, what arrives). Times sit between
/// two sample instants, so a command is handled between the same two sets on every machine.
pub const SCRIPT: [(f64, Step); 9] = [
    (2.005, Step::Command(Command::SetMode(Mode::Standby))),
    (2.505, Step::Command(Command::SetMode(Mode::Operate))),
    (3.005, Step::Command(Command::ReportHousekeeping)),
    (3.505, Step::Noise(&[0x55, 0xAA, 0x00, 0x13])),
    (3.605, Step::Damaged(Command::SetModel(Model::FreeFloat))),
    (6.005, Step::Command(Command::SetModel(Model::FreeFloat))),
    (7.005, Step::Command(Command::Exclude(11))),
    (8.005, Step::Command(Command::Include(11))),
    (9.005, Step::Command(Command::AreYouAlive)),
];

/// Octets of the largest application data a step carries: four reference points.
const DATA_MAX: usize = 1 + BATCH as usize * POINT_LEN;

/// The frame of a script step with sequence count `seq`, the first sample instant at `t0`
/// and sets `period` apart (the reference's times); its length.
pub fn frame(step: Step, seq: u16, t0: Nanos, period: Nanos, out: &mut [u8]) -> usize {
    let mut points = [0u8; DATA_MAX];
    let (command, damaged) = match step {
        Step::Noise(bytes) => {
            let n = bytes.len().min(out.len());
            out[..n].copy_from_slice(&bytes[..n]);
            return n;
        }
        Step::Command(c) => (c, false),
        Step::Damaged(c) => (c, true),
        Step::Reference {
            first,
            every,
            points: n,
        } => {
            let n = n.min(BATCH);
            points[0] = n as u8;
            for (j, chunk) in points[1..]
                .chunks_exact_mut(POINT_LEN)
                .take(n as usize)
                .enumerate()
            {
                let set = u64::from(first + j as u32 * every);
                let (_, _, omega) = motion(ballisto_fw::time::seconds(set * period));
                let point = ReferencePoint {
                    t: t0 + set * period,
                    omega: omega.map(|w| w as f32),
                };
                chunk.copy_from_slice(&point.encode());
            }
            let len = 1 + n as usize * POINT_LEN;
            (Command::ReferenceRate(&points[..len]), false)
        }
    };
    let mut raw = [0u8; 16 + DATA_MAX];
    // Every acknowledgement asked (start and progress too: accepted, not reported).
    let ack = ACK_ACCEPTANCE | 0x4 | 0x2 | ACK_COMPLETION;
    let Some(n) = telecommand::build_command(&mut raw, seq, ack, &command) else {
        return 0;
    };
    if damaged {
        raw[n - 1] ^= 0x5A;
    }
    framing::encode(&raw[..n], out).unwrap_or(0)
}

/// The uplink of the built-in scenario: each step of a [`Script`] once the time base reaches
/// it, then nothing.
pub struct ScriptedUplink<'a, T> {
    time: &'a T,
    t0: Nanos,
    period: Nanos,
    script: Script,
    next: usize,
    /// The step on the line, and how much of it has been read.
    frame: [u8; FRAME_MAX],
    len: usize,
    sent: usize,
}

/// Octets of the longest framed step.
const FRAME_MAX: usize = 2 * (16 + DATA_MAX);

impl<'a, T: TimeBase> ScriptedUplink<'a, T> {
    /// `script`, its times counted from the first sample instant `t0`, sets `period` apart.
    pub fn new(time: &'a T, t0: Nanos, period: Nanos, script: Script) -> Self {
        ScriptedUplink {
            time,
            t0,
            period,
            script,
            next: 0,
            frame: [0; FRAME_MAX],
            len: 0,
            sent: 0,
        }
    }
}

impl<T> ErrorType for ScriptedUplink<'_, T> {
    type Error = core::convert::Infallible;
}

impl<T: TimeBase> Read for ScriptedUplink<'_, T> {
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        if self.sent == self.len {
            let Some((at, step)) = (self.script)(self.next) else {
                return core::future::pending().await;
            };
            let at = self.t0 + (at * 1e9) as Nanos;
            while self.time.now() < at {
                embassy_futures::yield_now().await;
            }
            self.next += 1;
            self.len = frame(
                step,
                self.next as u16,
                self.t0,
                self.period,
                &mut self.frame,
            );
            self.sent = 0;
        }
        // As a line delivers it: as much of the frame as the reader takes.
        let n = buf.len().min(self.len - self.sent);
        buf[..n].copy_from_slice(&self.frame[self.sent..self.sent + n]);
        self.sent += n;
        Ok(n)
    }
}
