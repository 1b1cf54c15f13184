//! The application task: sample sets in, estimates, housekeeping and events out, telecommands
//! executed and verified (PUS services 1, 3, 5, 17 and the ballistometer's 200).
//!
//! ```text
//! sampling task ──SampleSet──▶ ┌──────────┐ ──motion / housekeeping / events──▶ Telemetry ─▶ link
//! uplink task ────Incoming───▶ │   App    │ ──verification (TM[1,x])─────────▶
//! health board ─────────────▶  └──────────┘
//! ```
//!
//! One task owns the estimator, the mode and the telemetry, so commands and sample sets are
//! handled one at a time and a command never meets a half-processed set.

use ballisto_link::framing::{Decoder, Deframed};
use ballisto_link::ids::TC_MAX;
use ballisto_link::telecommand::{self, Accepted, Command, Context};
use ballisto_link::verification::config_error_code;
use ballisto_link::{
    service, subtype, Event, EventId, FailureCode, Housekeeping, LoopCounters, ModelCode,
    MotionReport, PartCounters, PartState, RequestId, Verification,
};
use embassy_futures::select::{select, Either};
use embassy_sync::blocking_mutex::raw::RawMutex;
use embassy_sync::channel::Receiver;
use embassy_sync::zerocopy_channel::{self, Sender};
use embedded_io_async::{Read, Write};
use estimator_core::ConfigError;

use crate::config::{AppConfig, MAX_PARTS};
use crate::estimation::{Estimation, Motion, Tap};
use crate::sampler::{Health, HealthBoard, LoopHealth, PartHealth, SampleSet};
use crate::telemetry::Telemetry;
use crate::time::{Nanos, TimeBase};

/// The firmware version reported in housekeeping and the boot event.
pub const VERSION: [u8; 3] = [
    parse_u8(env!("CARGO_PKG_VERSION_MAJOR")),
    parse_u8(env!("CARGO_PKG_VERSION_MINOR")),
    parse_u8(env!("CARGO_PKG_VERSION_PATCH")),
];

const fn parse_u8(s: &str) -> u8 {
    let b = s.as_bytes();
    let mut v = 0u8;
    let mut i = 0;
    while i < b.len() {
        v = v * 10 + (b[i] - b'0');
        i += 1;
    }
    v
}

/// Operating mode (the link's codes).
pub use ballisto_link::Mode;

/// One telecommand packet as received, or the news that a frame was garbage. Filled in place
/// in the slot of a zero-copy channel (a packet is up to [`TC_MAX`] octets).
pub struct Incoming {
    len: u16,
    garbage: bool,
    bytes: [u8; TC_MAX],
}

impl Default for Incoming {
    fn default() -> Self {
        Self::new()
    }
}

impl Incoming {
    /// An empty slot.
    pub const fn new() -> Self {
        Incoming {
            len: 0,
            garbage: false,
            bytes: [0; TC_MAX],
        }
    }

    /// Holds a received packet (one longer than [`TC_MAX`] is garbage).
    pub fn set_packet(&mut self, packet: &[u8]) {
        match self.bytes.get_mut(..packet.len()) {
            Some(dst) => {
                dst.copy_from_slice(packet);
                self.len = packet.len() as u16;
                self.garbage = false;
            }
            None => self.set_garbage(),
        }
    }

    /// Decodes one byte from the line into this slot; true once it holds a whole packet or
    /// the news of a garbage frame.
    pub fn push(&mut self, decoder: &mut Decoder, byte: u8) -> bool {
        match decoder.push(byte, &mut self.bytes) {
            Deframed::Pending => false,
            Deframed::Packet(len) => {
                self.len = len as u16;
                self.garbage = false;
                true
            }
            Deframed::Garbage => {
                self.set_garbage();
                true
            }
        }
    }

    /// Holds the news of a garbage frame.
    pub fn set_garbage(&mut self) {
        self.len = 0;
        self.garbage = true;
    }

    /// The packet, or `None` for a garbage frame.
    pub fn packet(&self) -> Option<&[u8]> {
        (!self.garbage).then(|| &self.bytes[..usize::from(self.len).min(TC_MAX)])
    }
}

/// Slots between the uplink and the application task.
pub const COMMAND_QUEUE: usize = 1;

/// The uplink task: the command link's byte stream, decoded straight into the free command
/// slot, → the application task. While the application still holds the slot, bytes wait in
/// the link's receive buffer. Ends when the link ends (or fails).
pub async fn uplink_task<R: Read, M: RawMutex>(mut link: R, mut commands: Sender<'_, M, Incoming>) {
    let mut decoder = Decoder::new();
    let mut chunk = [0u8; 32];
    loop {
        let n = match link.read(&mut chunk).await {
            Ok(0) | Err(_) => return,
            Ok(n) => n,
        };
        for &b in chunk.iter().take(n) {
            if commands.send().await.push(&mut decoder, b) {
                commands.send_done();
            }
        }
    }
}

/// The application: estimation, mode, telemetry settings and counters.
pub struct App {
    estimation: Estimation,
    mode: Mode,
    rate_hz: f32,
    motion_every: u16,
    housekeeping_every: u16,
    since_motion: u16,
    since_housekeeping: u16,
    estimates: u32,
    tc_accepted: u32,
    tc_rejected: u32,
    frames_garbage: u32,
    parts_seen: [PartState; MAX_PARTS],
    lost_seen: (u32, u32),
    health: Health,
}

impl App {
    /// The application for a configuration, in `mode`; one motion report per set and one
    /// housekeeping report per second.
    pub fn new(config: &AppConfig, mode: Mode) -> Result<Self, ConfigError> {
        let mut parts_seen = [PartState::Absent; MAX_PARTS];
        for (i, _) in config.sampling.parts() {
            parts_seen[i] = PartState::Running;
        }
        Ok(App {
            estimation: Estimation::new(config)?,
            mode,
            rate_hz: config.sampling.rate_hz,
            motion_every: 1,
            housekeeping_every: (libm::roundf(config.sampling.rate_hz) as u16).max(1),
            since_motion: 0,
            since_housekeeping: 0,
            estimates: 0,
            tc_accepted: 0,
            tc_rejected: 0,
            frames_garbage: 0,
            parts_seen,
            lost_seen: (0, 0),
            health: Health::default(),
        })
    }

    /// The estimation (model, mask, counters).
    pub fn estimation(&self) -> &Estimation {
        &self.estimation
    }

    /// The mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Announces the start: the boot event and a first housekeeping report.
    pub async fn boot<W: Write>(&mut self, t: Nanos, tm: &mut Telemetry<W>) {
        let [a, b, c] = VERSION;
        let version = (u32::from(a) << 16) | (u32::from(b) << 8) | u32::from(c);
        let channels = self.estimation.channels() as u32;
        self.event(t, tm, EventId::Boot, version, channels).await;
        self.send_housekeeping(t, tm).await;
    }

    /// One sample set, with the sampler's health after it (read from `health`).
    pub async fn on_set<M: RawMutex, W: Write, K: Tap>(
        &mut self,
        set: &SampleSet,
        health: &HealthBoard<M>,
        tm: &mut Telemetry<W>,
        tap: &mut K,
    ) {
        health.latest_into(&mut self.health);
        self.part_events(set.t, tm).await;
        if self.mode == Mode::Operate {
            tap.sample_set(set).await;
            let excluded_before = self.estimation.excluded_parts();
            let motion = self.estimation.process(set);
            self.estimates = self.estimates.wrapping_add(1);
            tap.motion(&motion).await;
            self.exclusion_events(set.t, tm, excluded_before, &motion)
                .await;
            self.since_motion += 1;
            if self.since_motion >= self.motion_every {
                self.since_motion = 0;
                self.send_motion(tm, &motion).await;
            }
        }
        self.since_housekeeping += 1;
        if self.since_housekeeping >= self.housekeeping_every {
            self.since_housekeeping = 0;
            self.send_housekeeping(set.t, tm).await;
            self.loss_event(set.t, tm).await;
        }
    }

    /// One telecommand (or garbage) from the uplink, received at `t`.
    pub async fn on_incoming<W: Write>(
        &mut self,
        incoming: &Incoming,
        t: Nanos,
        tm: &mut Telemetry<W>,
    ) {
        let Some(raw) = incoming.packet() else {
            return self.frame_rejected(t, tm, 1).await;
        };
        let ctx = Context {
            channels: self.estimation.channels(),
        };
        let accepted = match telecommand::parse(raw, ctx) {
            Ok(a) => a,
            Err(rejected) => {
                self.tc_rejected = self.tc_rejected.wrapping_add(1);
                return match rejected.request {
                    Some(request) => {
                        let failure = Some((rejected.code, rejected.data));
                        self.verify(t, tm, subtype::NOT_ACCEPTED, request, failure)
                            .await
                    }
                    None => self.frame_rejected(t, tm, 2).await,
                };
            }
        };
        self.tc_accepted = self.tc_accepted.wrapping_add(1);
        let Accepted {
            request,
            ack_acceptance,
            ack_completion,
            command,
        } = accepted;
        if ack_acceptance {
            self.verify(t, tm, subtype::ACCEPTED, request, None).await;
        }
        match self.execute(command, t, tm).await {
            Ok(()) if ack_completion => self.verify(t, tm, subtype::COMPLETED, request, None).await,
            Ok(()) => {}
            Err(failure) => {
                self.verify(t, tm, subtype::NOT_COMPLETED, request, Some(failure))
                    .await
            }
        }
    }

    /// A command-link frame that was no packet (`reason` 1) or too short to answer (2):
    /// counted and reported.
    async fn frame_rejected<W: Write>(&mut self, t: Nanos, tm: &mut Telemetry<W>, reason: u32) {
        self.frames_garbage = self.frames_garbage.wrapping_add(1);
        let n = self.frames_garbage;
        self.event(t, tm, EventId::FrameRejected, reason, n).await
    }

    /// Executes an accepted command; on failure nothing has changed.
    async fn execute<W: Write>(
        &mut self,
        command: Command<'_>,
        t: Nanos,
        tm: &mut Telemetry<W>,
    ) -> Result<(), (FailureCode, u32)> {
        match command {
            Command::SetMode(mode) => {
                if mode != self.mode {
                    let old = self.mode;
                    self.mode = mode;
                    if mode == Mode::Operate {
                        self.estimation.restart();
                        self.since_motion = 0;
                    }
                    self.event(t, tm, EventId::ModeChanged, old as u32, mode as u32)
                        .await;
                }
            }
            Command::SetModel(model) => {
                let arrangement = self.estimation.estimator().arrangement().clone();
                self.estimation
                    .configure(&arrangement, model)
                    .map_err(refused)?;
                self.reconfigured(t, tm).await;
            }
            Command::SetHint(w) => {
                self.estimation
                    .set_hint(w.map(f64::from))
                    .map_err(|_| (FailureCode::NotFinite, 0))?;
            }
            Command::Exclude(c) | Command::Include(c) => {
                let bit = 1u32 << c;
                let commanded = match command {
                    Command::Exclude(_) => self.estimation.commanded() | bit,
                    _ => self.estimation.commanded() & !bit,
                };
                self.estimation.set_commanded(commanded).map_err(refused)?;
            }
            Command::LoadArrangement(data) => {
                self.load_arrangement(data)?;
                self.reconfigured(t, tm).await;
            }
            Command::SetRates {
                motion_every,
                housekeeping_every,
            } => {
                self.motion_every = motion_every;
                self.housekeeping_every = housekeeping_every;
                self.since_motion = 0;
                self.since_housekeeping = 0;
            }
            Command::ReportHousekeeping => self.send_housekeeping(t, tm).await,
            Command::AreYouAlive => tm.send(t, service::TEST, subtype::ALIVE, &[]).await,
        }
        Ok(())
    }

    /// TC[200,6] execution: the arrangement built (on the stack, not in the task's state)
    /// and handed to the estimator, which keeps its configuration if it refuses.
    fn load_arrangement(&mut self, data: &[u8]) -> Result<(), (FailureCode, u32)> {
        let arrangement = telecommand::arrangement(data)?;
        let model = self.estimation.estimator().model();
        self.estimation
            .configure(&arrangement, model)
            .map_err(refused)
    }

    /// The housekeeping report as of now.
    pub fn housekeeping(&self, tm_lost: u32) -> Housekeeping {
        Housekeeping {
            version: VERSION,
            mode: self.mode as u8,
            model: ModelCode::from(self.estimation.estimator().model()) as u8,
            channels: self.estimation.channels() as u8,
            rate_hz: self.rate_hz,
            motion_every: self.motion_every,
            housekeeping_every: self.housekeeping_every,
            sampling: loop_counters(&self.health.sampling),
            estimates: self.estimates,
            excluded_parts: self.estimation.excluded_parts() as u8,
            commanded_out: self.estimation.commanded(),
            excluded_channels: self.estimation.excluded_channels(),
            tc_accepted: self.tc_accepted,
            tc_rejected: self.tc_rejected,
            frames_garbage: self.frames_garbage,
            tm_lost,
            parts: self.health.parts.map(|p| part_counters(p.as_ref())),
        }
    }

    async fn send_housekeeping<W: Write>(&mut self, t: Nanos, tm: &mut Telemetry<W>) {
        let lost = tm.lost();
        let framed = tm.stage(t, service::HOUSEKEEPING, subtype::HK_REPORT, |buf| {
            self.housekeeping(lost).encode(buf)
        });
        tm.transmit(framed).await;
    }

    async fn send_motion<W: Write>(&self, tm: &mut Telemetry<W>, motion: &Motion) {
        let excluded = self.estimation.excluded_channels();
        let framed = tm.stage(motion.t, service::HOUSEKEEPING, subtype::HK_REPORT, |buf| {
            motion_report(motion, excluded).encode(buf)
        });
        tm.transmit(framed).await;
    }

    async fn event<W: Write>(&self, t: Nanos, tm: &mut Telemetry<W>, id: EventId, a: u32, b: u32) {
        let mut data = [0u8; 16];
        let n = (Event { id, a, b }).encode(&mut data);
        if let Some(bytes) = n.and_then(|n| data.get(..n)) {
            tm.send(t, service::EVENT, id.severity(), bytes).await;
        }
    }

    async fn verify<W: Write>(
        &self,
        t: Nanos,
        tm: &mut Telemetry<W>,
        st: u8,
        request: RequestId,
        failure: Option<(FailureCode, u32)>,
    ) {
        let mut data = [0u8; 16];
        let report = Verification {
            subtype: st,
            request,
            failure,
        };
        let n = report.encode(&mut data);
        if let Some(bytes) = n.and_then(|n| data.get(..n)) {
            tm.send(t, service::VERIFICATION, st, bytes).await;
        }
    }

    async fn reconfigured<W: Write>(&mut self, t: Nanos, tm: &mut Telemetry<W>) {
        let channels = self.estimation.channels() as u32;
        let model = ModelCode::from(self.estimation.estimator().model()) as u32;
        self.event(t, tm, EventId::Reconfigured, channels, model)
            .await;
    }

    /// Parts marked down or answering again since the last set.
    async fn part_events<W: Write>(&mut self, t: Nanos, tm: &mut Telemetry<W>) {
        for i in 0..MAX_PARTS {
            let now = part_state(self.health.parts[i].as_ref());
            if now != PartState::Absent && now != self.parts_seen[i] {
                self.parts_seen[i] = now;
                let id = match now {
                    PartState::Down => EventId::PartDown,
                    _ => EventId::PartUp,
                };
                self.event(t, tm, id, i as u32, 0).await;
            }
        }
    }

    /// Parts excluded or included by the estimation in this set (`before`: the parts excluded
    /// before it).
    async fn exclusion_events<W: Write>(
        &self,
        t: Nanos,
        tm: &mut Telemetry<W>,
        before: u32,
        motion: &Motion,
    ) {
        if motion.excluded == before {
            return;
        }
        let id = if motion.excluded & !before != 0 {
            EventId::PartsExcluded
        } else {
            EventId::PartsIncluded
        };
        let out = self.estimation.excluded_channels();
        self.event(t, tm, id, motion.excluded, out).await;
    }

    /// Instants skipped or sets dropped since the last housekeeping report.
    async fn loss_event<W: Write>(&mut self, t: Nanos, tm: &mut Telemetry<W>) {
        let s = &self.health.sampling;
        let lost = (s.skipped, s.dropped);
        if lost != self.lost_seen {
            self.lost_seen = lost;
            self.event(t, tm, EventId::SetsLost, lost.0, lost.1).await;
        }
    }
}

/// The completion failure of a configuration the estimator refused (it keeps the old one).
fn refused(e: ConfigError) -> (FailureCode, u32) {
    (FailureCode::Refused, config_error_code(&e))
}

/// The state of a part slot on the link: absent, or running / down by its health.
pub fn part_state(part: Option<&PartHealth>) -> PartState {
    match part {
        None => PartState::Absent,
        Some(p) if p.running => PartState::Running,
        Some(_) => PartState::Down,
    }
}

/// A part slot's housekeeping entry: its state and counters (zero for an absent slot).
fn part_counters(part: Option<&PartHealth>) -> PartCounters {
    let c = part.copied().unwrap_or_default();
    PartCounters {
        state: part_state(part),
        reads: c.reads,
        bus_errors: c.bus_errors,
        implausible: c.implausible,
        missed: c.missed,
        failed_starts: c.failed_starts,
        resyncs: c.resyncs,
    }
}

/// The sampling loop's housekeeping entry.
fn loop_counters(l: &LoopHealth) -> LoopCounters {
    LoopCounters {
        sets: l.sets,
        skipped: l.skipped,
        dropped: l.dropped,
        sync_errors: l.sync_errors,
    }
}

/// The motion report of one output of the estimation.
pub fn motion_report(motion: &Motion, excluded_channels: u32) -> MotionReport {
    MotionReport {
        k: motion.k,
        estimate: motion.estimate,
        missing_parts: motion.missing as u8,
        excluded_parts: motion.excluded as u8,
        excluded_channels,
    }
}

/// The application task: boots, then handles sample sets and telecommands as they come.
/// Returns after the set of index `sets − 1` (a finite run), or never.
#[allow(clippy::too_many_arguments)]
pub async fn app_task<M, W, K, T, const Q: usize>(
    app: &mut App,
    time: &T,
    samples: Receiver<'_, M, SampleSet, Q>,
    mut commands: zerocopy_channel::Receiver<'_, M, Incoming>,
    health: &HealthBoard<M>,
    tm: &mut Telemetry<W>,
    tap: &mut K,
    sets: Option<u32>,
) where
    M: RawMutex,
    W: Write,
    K: Tap,
    T: TimeBase,
{
    app.boot(time.now(), tm).await;
    loop {
        match select(samples.receive(), commands.receive()).await {
            Either::First(set) => {
                app.on_set(&set, health, tm, tap).await;
                if sets.is_some_and(|n| set.k + 1 >= n) {
                    tm.flush().await;
                    return;
                }
            }
            Either::Second(incoming) => {
                app.on_incoming(incoming, time.now(), tm).await;
                commands.receive_done();
            }
        }
    }
}
