//! The identification's telecommands (TC[200,8–11]) and reports (TM[200,128–129]), and the
//! commit of a solution through the storage task with its completion reported when the store
//! answers. The window's work is the identification task's (`crate::identification::task`):
//! here, the sets and orders queued to it and the solution it hands back.

use ballisto_link::identification::{IdentifiedChannel, ReferencePoint, MAX_POINTS};
use ballisto_link::telecommand::Command;
use ballisto_link::verification::{config_error_code, not_ready};
use ballisto_link::{service, subtype, EventId, FailureCode, RequestId};
use embedded_io_async::Write;
use estimator_core::identify::{Identified, IdentifyError, TumbleError, PARAMS};
use estimator_core::FrameUncertainty;

use super::App;
use crate::config::MAX_CHANNELS;
use crate::identification::{
    longest_window_ms, Identifier, Order, Solved, ThermalTracking, Unsolved,
};
use crate::storage::{CommitReply, CommitRequest};
use crate::telemetry::Telemetry;
use crate::time::Nanos;

/// A channel whose residual over the window exceeds this multiple of its noise is not
/// explained by the field: its solution is not committed.
pub const RESIDUAL_LIMIT: f64 = 3.0;

/// Where commits go.
#[derive(Debug, Default)]
pub(super) enum Store {
    /// The unit has no writable calibration store.
    #[default]
    None,
    /// Ready.
    Idle,
    /// A commit is in progress: its telecommand and whether completion is to be reported.
    Busy(RequestId, bool),
}

/// The application's side of identification in flight.
#[derive(Default)]
pub(super) struct IdentificationLink {
    /// The identification task's queues (the board's).
    task: Option<&'static Identifier>,
    /// The window commanded: its start and end on the unit's time.
    window: Option<(Nanos, Nanos)>,
    /// Sets of the window that found the queue full.
    lost: u32,
    /// The TC[200,10] whose solve the task is doing, and whether its completion is reported.
    solving: Option<(RequestId, bool)>,
    /// The last solution reported, under its number.
    solution: Option<(u16, Identified<MAX_CHANNELS>, FrameUncertainty<f64>)>,
    /// The window's temperatures and every channel's bias against them across windows.
    pub(super) thermal: ThermalTracking,
}

impl IdentificationLink {
    /// The task, or the refusal of a command that needs it.
    fn task(&self) -> Result<&'static Identifier, (FailureCode, u32)> {
        self.task
            .ok_or((FailureCode::NotReady, not_ready::NO_IDENTIFICATION_TASK))
    }

    /// Queues `order`, or refuses the command (the task has not taken the last ones yet).
    fn post(&self, order: Order) -> Result<(), (FailureCode, u32)> {
        if self.task()?.post(order) {
            Ok(())
        } else {
            Err((FailureCode::NotReady, not_ready::IDENTIFICATION_BUSY))
        }
    }
}

/// The refusal of a solve that found no solution, naming what the data could not decide.
fn unsolved(e: Unsolved) -> (FailureCode, u32) {
    let identify = |e: IdentifyError| match e {
        IdentifyError::TooFewSets { have } => not_ready::TOO_FEW_SETS | have.min(0xFFFF),
        IdentifyError::NotConverged { channel } => not_ready::NOT_CONVERGED | channel as u32,
        // The sums are started with the arrangement's channel count.
        IdentifyError::ChannelCount { .. } => not_ready::NO_WINDOW,
    };
    let data = match e {
        Unsolved::NoWindow => not_ready::NO_WINDOW,
        Unsolved::Identify(e) | Unsolved::Tumble(TumbleError::Identify(e)) => identify(e),
        // No start rate explains the kept sets: the field does not explain that channel.
        Unsolved::Tumble(TumbleError::NotDetermined { channel, .. }) => {
            not_ready::RESIDUAL_HIGH | channel as u32
        }
        Unsolved::Tumble(TumbleError::MotionUncertain { channel, param, .. }) => {
            not_ready::MOTION_UNCERTAIN | ((param as u32) << 8) | channel as u32
        }
        Unsolved::Tumble(TumbleError::NotExcited { channel, param }) => {
            not_ready::NOT_EXCITED | ((param as u32) << 8) | channel as u32
        }
        Unsolved::Tumble(TumbleError::Ambiguous { .. }) => not_ready::MOTION_AMBIGUOUS,
        // Acceptance checked the inertia.
        Unsolved::Tumble(TumbleError::Inertia) => not_ready::INVALID,
    };
    (FailureCode::NotReady, data)
}

impl App {
    /// Takes `identifier` as the identification task's queues: the board must run
    /// [`Identifier::run`] in a task of lower priority than this one's. Without it TC[200,8–10]
    /// are refused (not ready, `NO_IDENTIFICATION_TASK`).
    pub fn attach_identifier(&mut self, identifier: &'static Identifier) {
        self.identification.task = Some(identifier);
    }

    /// TC[200,8–9] (TC[200,10] and TC[200,11] are handled before execution: their completions
    /// come from the identification and storage tasks).
    pub(super) fn identification_command(
        &mut self,
        command: Command<'_>,
        t: Nanos,
    ) -> Result<(), (FailureCode, u32)> {
        match command {
            Command::StartIdentification {
                period_ms,
                window_ms,
                inertia,
            } => {
                let arrangement = self.estimation.estimator().arrangement().clone();
                if inertia.is_some() {
                    let longest = longest_window_ms(arrangement.len(), period_ms, self.rate_hz);
                    if window_ms > longest {
                        let seconds = (longest / 1000).min(0xFFFF);
                        return Err((FailureCode::NotReady, not_ready::WINDOW_TOO_LONG | seconds));
                    }
                }
                self.identification.post(Order::Start {
                    now: t,
                    period_ms,
                    window_ms,
                    rate_hz: self.rate_hz,
                    arrangement,
                    inertia,
                })?;
                let end = t + u64::from(window_ms) * 1_000_000;
                self.identification.window = Some((t, end));
                self.identification.lost = 0;
                self.identification.thermal.start();
                info!("identification window of {} ms started", window_ms);
            }
            Command::ReferenceRate(data) => {
                if self.identification.window.is_none() {
                    return Err((FailureCode::NotReady, not_ready::NO_WINDOW));
                }
                let points: heapless::Vec<ReferencePoint, MAX_POINTS> =
                    ballisto_link::identification::points(data)
                        .take(MAX_POINTS)
                        .collect();
                self.identification.post(Order::Points(points))?;
            }
            _ => {}
        }
        Ok(())
    }

    /// A set's channel vector for the window, if one is open at `t`, with the estimate's rate
    /// `omega`: queued to the task, or counted as lost if the queue is full (the estimate
    /// never waits for the task).
    pub(super) fn identification_set(&mut self, t: Nanos, omega: [f32; 3]) {
        let link = &mut self.identification;
        let (Some(task), Some((start, end))) = (link.task, link.window) else {
            return;
        };
        if t >= start && t <= end && !task.post_set(t, self.estimation.readings(), omega) {
            link.lost = link.lost.wrapping_add(1);
        }
    }

    /// The parts' temperatures after a new read at `t`: into the window's, if one is open.
    pub(super) fn identification_temperatures(&mut self, t: Nanos) {
        let link = &mut self.identification;
        if link
            .window
            .is_some_and(|(start, end)| t >= start && t <= end)
        {
            link.thermal.observe(self.estimation.temperatures());
        }
    }

    /// TC[200,10]: asks the task to solve the window; the summary, every channel and the
    /// completion are sent when it has ([`App::on_solved`]).
    pub(super) fn request_solution(
        &mut self,
        request: RequestId,
        ack_completion: bool,
    ) -> Result<(), (FailureCode, u32)> {
        let link = &mut self.identification;
        link.task()?;
        if link.solving.is_some() {
            return Err((FailureCode::NotReady, not_ready::IDENTIFICATION_BUSY));
        }
        if link.window.is_none() {
            return Err(unsolved(Unsolved::NoWindow));
        }
        link.post(Order::Solve { lost: link.lost })?;
        link.solving = Some((request, ack_completion));
        Ok(())
    }

    /// The identification task's queues, if the board attached them.
    pub fn identifier(&self) -> Option<&'static Identifier> {
        self.identification.task
    }

    /// The solve asked for, as the task hands it over (the application task waits for it
    /// beside sets and commands): its reports and completion, or its failure.
    pub async fn on_solved<W: Write>(&mut self, solved: Solved, t: Nanos, tm: &mut Telemetry<W>) {
        let Some((request, ack)) = self.identification.solving.take() else {
            return;
        };
        match self.report_identification(solved, t, tm).await {
            Ok(()) if ack => self.verify(t, tm, subtype::COMPLETED, request, None).await,
            Ok(()) => {}
            Err(failure) => {
                self.verify(t, tm, subtype::NOT_COMPLETED, request, Some(failure))
                    .await
            }
        }
    }

    /// Says that a storage task takes commits (the board has a writable store).
    pub fn set_store_writable(&mut self, writable: bool) {
        self.store = if writable { Store::Idle } else { Store::None };
    }

    /// A commit for the storage task, if one was accepted since the last call.
    pub fn take_commit(&mut self) -> Option<CommitRequest> {
        self.outbox.take()
    }

    /// A solve's outcome: the summary and every channel sent, the solution kept under its
    /// number; or why there is none.
    async fn report_identification<W: Write>(
        &mut self,
        solved: Solved,
        t: Nanos,
        tm: &mut Telemetry<W>,
    ) -> Result<(), (FailureCode, u32)> {
        let (solution, frame, summary) = solved.map_err(unsolved)?;
        let (_, id, _) = self
            .identification
            .solution
            .insert((summary.solution, solution, frame));
        info!(
            "identification {}: {} sets, origin from the centre of mass (rho) {} {} {} m",
            summary.solution, summary.sets, summary.rho[0], summary.rho[1], summary.rho[2]
        );
        // Encoded in the writer's own buffer (`Telemetry::stage`), as every report.
        let framed = tm.stage(
            t,
            service::BALLISTOMETER,
            subtype::IDENTIFICATION_SUMMARY,
            |buf| summary.encode(buf),
        );
        tm.transmit(framed).await;
        for (c, f) in id.channels().iter().enumerate() {
            let ch = &f.channel;
            let report = IdentifiedChannel {
                solution: summary.solution,
                channel: c as u8,
                held: f.held,
                position: ch.position.map(|v| v as f32),
                axis: ch.axis.map(|v| v as f32),
                bias: ch.bias as f32,
                scale: ch.scale as f32,
                sd: core::array::from_fn::<f32, PARAMS, _>(|k| f.sd[k] as f32),
                residual_rms: f.residual_rms as f32,
                noise: ch.noise as f32,
            };
            let framed = tm.stage(
                t,
                service::BALLISTOMETER,
                subtype::IDENTIFIED_CHANNEL,
                |buf| report.encode(buf),
            );
            tm.transmit(framed).await;
        }
        // Each channel's bias against temperature across the windows (TM[200,130]).
        let estimation = &self.estimation;
        let thermal = &mut self.identification.thermal;
        let added = thermal.add_solution(id, |c| estimation.part_of(c), RESIDUAL_LIMIT);
        let in_use = estimation.estimator().arrangement();
        for c in 0..id.channels().len() {
            let r = thermal.report(summary.solution, c, estimation.part_of(c), added, in_use);
            let framed = tm.stage(t, service::BALLISTOMETER, subtype::THERMAL_TRACK, |buf| {
                r.encode(buf)
            });
            tm.transmit(framed).await;
        }
        Ok(())
    }

    /// TC[200,11]: hands solution `solution` to the storage task; its completion is reported
    /// when the store answers ([`App::on_commit_reply`]).
    pub(super) fn commit_calibration(
        &mut self,
        solution: u16,
        request: RequestId,
        ack_completion: bool,
    ) -> Result<(), (FailureCode, u32)> {
        let refuse = |data| Err((FailureCode::NotReady, data));
        match self.store {
            Store::None => return refuse(not_ready::NO_STORE),
            Store::Busy(..) => return refuse(not_ready::STORE_BUSY),
            Store::Idle => {}
        }
        let Some((_, id, frame)) = self
            .identification
            .solution
            .as_ref()
            .filter(|(n, _, _)| *n == solution)
        else {
            return refuse(not_ready::NO_SUCH_SOLUTION);
        };
        for (c, f) in id.channels().iter().enumerate() {
            if !(f.residual_rms <= RESIDUAL_LIMIT * f.channel.noise) {
                return refuse(not_ready::RESIDUAL_HIGH | c as u32);
            }
        }
        let mut arrangement = id.arrangement(frame).map_err(|e| {
            (
                FailureCode::NotReady,
                not_ready::INVALID | (config_error_code(&e) >> 16),
            )
        })?;
        // The window saw the readings brought to each channel's `t_ref` (temperature
        // compensation): the bias and scale found are at `t_ref`, and the coefficients in use
        // go into the record with them.
        let in_use = self.estimation.estimator().arrangement();
        for c in 0..arrangement.len() {
            let _ = arrangement.set_thermal(c, in_use.thermal(c));
        }
        // Where the windows at different temperatures decide a channel's line, its bias at
        // `t_ref` and its coefficient are the line's.
        let tracked = self.identification.thermal.apply(&mut arrangement, in_use);
        if tracked > 0 {
            info!(
                "commit: {} channels' bias coefficients from the thermal track",
                tracked
            );
        }
        self.store = Store::Busy(request, ack_completion);
        // Sent by the task loop (`take_commit`) right after this command.
        self.outbox = Some(CommitRequest { arrangement });
        Ok(())
    }

    /// The store's answer to the commit in progress: its completion report and, when stored,
    /// the `calibration-stored` event. The calibration is used from the next boot.
    pub async fn on_commit_reply<W: Write>(
        &mut self,
        reply: CommitReply,
        t: Nanos,
        tm: &mut Telemetry<W>,
    ) {
        let Store::Busy(request, ack) = core::mem::take(&mut self.store) else {
            return;
        };
        self.store = Store::Idle;
        match reply {
            CommitReply::Stored { id, crc } => {
                info!(
                    "calibration {} stored (CRC {:x}); used from the next boot",
                    id, crc
                );
                self.event(t, tm, EventId::CalibrationStored, id, crc).await;
                if ack {
                    self.verify(t, tm, subtype::COMPLETED, request, None).await;
                }
            }
            CommitReply::Failed(code) => {
                warn!("calibration commit failed ({}); the stored one stays", code);
                let failure = Some((FailureCode::StoreFailed, code));
                self.verify(t, tm, subtype::NOT_COMPLETED, request, failure)
                    .await;
            }
        }
    }
}
