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
//! handled one at a time and a command never meets a half-processed set. Its rooms: this file
//! (the state and what happens per set and per command), [`commands`] (executing a command),
//! [`reports`] (the application's state as the link's reports), [`uplink`] (the command link),
//! [`task`] (the task and its links; observers subscribe to [`Observations`]).

mod awaited;
mod commands;
mod identify;
mod reports;
mod task;
mod uplink;

use ballisto_link::telecommand::{self, Accepted, Context};
use ballisto_link::{
    subtype, BootEvent, BootInfo, CalibrationId, EventId, ModelCode, PartState, TimeCorrelation,
    FORMAT_VERSION,
};
use embassy_sync::blocking_mutex::raw::RawMutex;
use embedded_io_async::Write;
use estimator_core::ConfigError;

pub use identify::RESIDUAL_LIMIT;
pub use reports::{motion_report, part_state};
pub use task::{app_task, Links, Observation, Observations, Status};
pub use uplink::{uplink_task, Incoming, COMMAND_QUEUE};

use crate::config::{AppConfig, MAX_PARTS};
use crate::estimation::Estimation;
use crate::sampler::{Health, HealthBoard, SampleSet};
use crate::storage::CommitRequest;
use crate::telemetry::Telemetry;
use crate::time::Nanos;

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
    /// The calibration the arrangement in use comes from (housekeeping reports it).
    calibration: CalibrationId,
    /// This boot's count and cause (the board's; housekeeping and the reset event report it).
    boot_info: BootInfo,
    /// The spacecraft time of the boot, once TC[9,128] has given it.
    time: TimeCorrelation,
    /// Identification in flight (TC[200,8–11]).
    identification: identify::IdentificationLink,
    /// The storage task's state, and a commit waiting to be sent to it.
    store: identify::Store,
    outbox: Option<CommitRequest>,
    /// What the command being executed reports once its configuration is built (set by
    /// `execute`), and the command waiting for it.
    deferring: Option<awaited::Deferred>,
    awaited: Option<awaited::Awaited>,
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
            calibration: CalibrationId::default(),
            boot_info: BootInfo::default(),
            time: TimeCorrelation::default(),
            identification: identify::IdentificationLink::default(),
            store: identify::Store::None,
            outbox: None,
            deferring: None,
            awaited: None,
        })
    }

    /// Takes `builds` as the estimator's second configuration buffer
    /// ([`Estimation::attach_builds`]): with [`Builds::background`] the board must run
    /// [`Builds::run`] in a task of lower priority than this one's.
    pub fn attach_builds(&mut self, builds: &'static crate::estimation::Builds) {
        self.estimation.attach_builds(builds);
    }

    /// Says which calibration the configuration's arrangement is (the board's choice at boot
    /// between the stored calibration and the built-in one: `calstore::select_at_boot`).
    pub fn set_calibration(&mut self, calibration: CalibrationId) {
        self.calibration = calibration;
    }

    /// The calibration in use.
    pub fn calibration(&self) -> CalibrationId {
        self.calibration
    }

    /// Says how many times the unit has booted since power was applied and why this boot
    /// happened (the board reads its reset controller before the application starts).
    pub fn set_boot_info(&mut self, boot: BootInfo) {
        self.boot_info = boot;
    }

    /// The time correlation (TC[9,128]).
    pub fn time_correlation(&self) -> TimeCorrelation {
        self.time
    }

    /// The estimation (model, mask, counters).
    pub fn estimation(&self) -> &Estimation {
        &self.estimation
    }

    /// The mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Announces the start: the boot event (the telemetry format, the version, the channels,
    /// the reset cause and the boot count) and a first housekeeping report.
    pub async fn boot<W: Write>(&mut self, t: Nanos, tm: &mut Telemetry<W>) {
        let [a, b, c] = VERSION;
        let channels = self.estimation.channels();
        let BootInfo { count, cause } = self.boot_info;
        let (version, boot) = BootEvent {
            format: FORMAT_VERSION,
            version: VERSION,
            channels: u8::try_from(channels).unwrap_or(u8::MAX),
            cause,
            count: u16::try_from(count).unwrap_or(u16::MAX),
        }
        .words();
        info!(
            "boot {} since power-on ({:?}): version {}.{}.{}, {} channels, model {:?}",
            count,
            cause,
            a,
            b,
            c,
            channels,
            self.estimation.estimator().model()
        );
        self.event(t, tm, EventId::Boot, version, boot).await;
        self.send_housekeeping(t, tm).await;
    }

    /// One sample set, with the sampler's health after it (read from `health`); returns what
    /// an observer may see of it (the set, its estimate in operate mode, the counters).
    pub async fn on_set<M: RawMutex, W: Write>(
        &mut self,
        set: &SampleSet,
        health: &HealthBoard<M>,
        tm: &mut Telemetry<W>,
    ) -> Observation {
        health.latest_into(&mut self.health);
        self.part_events(set.t, tm).await;
        if self
            .estimation
            .observe_temperatures(set.temperature_reads, &set.temperatures)
        {
            self.identification_temperatures(set.t);
        }
        let mut motion = None;
        if self.mode == Mode::Operate {
            let excluded_before = self.estimation.excluded_parts();
            let m = self.estimation.process(set);
            self.estimates = self.estimates.wrapping_add(1);
            // After the estimate: the identification only reads the channel vector.
            self.identification_set(set.t, m.estimate.omega);
            for (id, a, b) in self
                .estimation
                .fault_events(m.verdict)
                .into_iter()
                .flatten()
            {
                self.event(set.t, tm, id, a, b).await;
            }
            self.exclusion_events(set.t, tm, excluded_before, &m).await;
            self.since_motion += 1;
            if self.since_motion >= self.motion_every {
                self.since_motion = 0;
                self.send_motion(tm, &m).await;
            }
            motion = Some(m);
        }
        // A commanded configuration built by the builder task is taken at a set (in standby
        // too), and its command completed.
        if self.mode != Mode::Operate {
            self.estimation.poll_order();
        }
        self.complete_awaited(set.t, tm).await;
        // Exclusions (or a command) left the configured model unobservable, or no longer do.
        if let Some((before, after)) = self.estimation.take_model_switch() {
            let (before, after) = (ModelCode::from(before), ModelCode::from(after));
            warn!("model in force {:?} -> {:?}", before, after);
            self.event(
                set.t,
                tm,
                EventId::ModelSwitched,
                before as u32,
                after as u32,
            )
            .await;
        }
        self.since_housekeeping += 1;
        if self.since_housekeeping >= self.housekeeping_every {
            self.since_housekeeping = 0;
            self.send_housekeeping(set.t, tm).await;
            self.loss_event(set.t, tm).await;
        }
        Observation {
            set: *set,
            motion,
            status: self.status(tm),
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
                warn!(
                    "telecommand refused: {:?}, data {}",
                    rejected.code, rejected.data
                );
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
        let deferred = match command {
            // Completed when the identification task has solved (`on_solved`).
            telecommand::Command::ReportIdentification => {
                Some(self.request_solution(request, ack_completion))
            }
            // Completed when the store answers (`on_commit_reply`).
            telecommand::Command::CommitCalibration { solution } => {
                Some(self.commit_calibration(solution, request, ack_completion))
            }
            _ => None,
        };
        if let Some(outcome) = deferred {
            if let Err(failure) = outcome {
                self.verify(t, tm, subtype::NOT_COMPLETED, request, Some(failure))
                    .await;
            }
            return;
        }
        let (st, failure) = match self.execute(command, t, tm).await {
            Ok(_) if self.deferring.is_some() => {
                // Completed when its configuration is built (`complete_awaited`).
                self.awaited = self.deferring.take().map(|report| awaited::Awaited {
                    request,
                    ack: ack_completion,
                    report,
                });
                return;
            }
            Ok(event) => {
                if let Some((id, a, b)) = event {
                    self.event(t, tm, id, a, b).await;
                }
                if !ack_completion {
                    return;
                }
                (subtype::COMPLETED, None)
            }
            Err(failure) => (subtype::NOT_COMPLETED, Some(failure)),
        };
        self.verify(t, tm, st, request, failure).await;
    }

    /// A command-link frame that was no packet (`reason` 1) or too short to answer (2):
    /// counted and reported.
    async fn frame_rejected<W: Write>(&mut self, t: Nanos, tm: &mut Telemetry<W>, reason: u32) {
        self.frames_garbage = self.frames_garbage.wrapping_add(1);
        let n = self.frames_garbage;
        warn!(
            "command-link frame rejected (reason {}), {} since boot",
            reason, n
        );
        self.event(t, tm, EventId::FrameRejected, reason, n).await
    }
}
