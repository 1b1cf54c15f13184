//! What the application reports: housekeeping, motion, events, verification — its own state
//! mapped into the link's reports (`ballisto_link` imports nothing from the application).

use ballisto_link::{
    service, subtype, ChannelSet, Event, EventId, FailureCode, Housekeeping, LoopCounters,
    ModelCode, MotionReport, PartCounters, PartSet, PartState, RequestId, Verification,
};
use embedded_io_async::Write;

use super::commands::CommandEvent;
use super::{App, Mode, VERSION};
use crate::config::MAX_PARTS;
use crate::estimation::SetEstimate;
use crate::sampler::{LoopHealth, PartHealth};
use crate::telemetry::Telemetry;
use crate::time::Nanos;

impl App {
    /// The counters an observer sees (see [`super::Status`]).
    pub(super) fn status<W: Write>(&self, tm: &Telemetry<W>) -> super::Status {
        super::Status {
            sampling: self.health.sampling,
            estimates: self.estimates,
            tc_accepted: self.tc_accepted,
            tc_rejected: self.tc_rejected,
            frames_garbage: self.frames_garbage,
            tm_sent: tm.sent(),
            tm_lost: tm.lost(),
        }
    }

    /// The housekeeping report as of now.
    pub fn housekeeping(&self, tm_lost: u32) -> Housekeeping {
        Housekeeping {
            version: VERSION,
            mode: self.mode as u8,
            model: self.model_code() as u8,
            channels: self.estimation.channels() as u8,
            rate_hz: self.rate_hz,
            motion_every: self.motion_every,
            housekeeping_every: self.housekeeping_every,
            sampling: loop_counters(&self.health.sampling),
            estimates: self.estimates,
            excluded_parts: self.estimation.excluded_parts(),
            commanded_out: self.estimation.commanded(),
            excluded_channels: self.estimation.excluded_channels(),
            tc_accepted: self.tc_accepted,
            tc_rejected: self.tc_rejected,
            frames_garbage: self.frames_garbage,
            tm_lost,
            parts: self.health.parts.map(|p| part_counters(p.as_ref())),
            calibration: Some(self.calibration),
            boot: Some((self.boot_info, self.time)),
            test: Some(self.estimation.consistency_test()),
            temperatures: Some(*self.estimation.temperatures()),
        }
    }

    /// The model in use, as the link codes it.
    fn model_code(&self) -> ModelCode {
        ModelCode::from(self.estimation.estimator().model())
    }

    pub(super) async fn send_housekeeping<W: Write>(&mut self, t: Nanos, tm: &mut Telemetry<W>) {
        let lost = tm.lost();
        let framed = tm.stage(t, service::HOUSEKEEPING, subtype::HK_REPORT, |buf| {
            self.housekeeping(lost).encode(buf)
        });
        tm.transmit(framed).await;
    }

    pub(super) async fn send_motion<W: Write>(&self, tm: &mut Telemetry<W>, motion: &SetEstimate) {
        let excluded = self.estimation.excluded_channels();
        let context = (self.mode, self.model_code());
        let framed = tm.stage(motion.t, service::HOUSEKEEPING, subtype::HK_REPORT, |buf| {
            motion_report(motion, excluded, context).encode(buf)
        });
        tm.transmit(framed).await;
    }

    pub(super) async fn event<W: Write>(
        &self,
        t: Nanos,
        tm: &mut Telemetry<W>,
        id: EventId,
        a: u32,
        b: u32,
    ) {
        let mut data = [0u8; 16];
        let n = (Event { id, a, b }).encode(&mut data);
        if let Some(bytes) = n.and_then(|n| data.get(..n)) {
            tm.send(t, service::EVENT, id.severity(), bytes).await;
        }
    }

    pub(super) async fn verify<W: Write>(
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

    /// The event of a new configuration (channels, model).
    pub(super) fn reconfigured(&self) -> CommandEvent {
        let channels = self.estimation.channels() as u32;
        (EventId::Reconfigured, channels, self.model_code() as u32)
    }

    /// Parts marked down or answering again since the last set.
    pub(super) async fn part_events<W: Write>(&mut self, t: Nanos, tm: &mut Telemetry<W>) {
        for i in 0..MAX_PARTS {
            let now = part_state(self.health.parts[i].as_ref());
            if now != PartState::Absent && now != self.parts_seen[i] {
                self.parts_seen[i] = now;
                let id = match now {
                    PartState::Down => {
                        warn!("part {} is down (no valid reads)", i);
                        EventId::PartDown
                    }
                    _ => {
                        info!("part {} answers again", i);
                        EventId::PartUp
                    }
                };
                self.event(t, tm, id, i as u32, 0).await;
            }
        }
    }

    /// Parts excluded or included by the estimation in this set (`before`: the parts excluded
    /// before it).
    pub(super) async fn exclusion_events<W: Write>(
        &self,
        t: Nanos,
        tm: &mut Telemetry<W>,
        before: PartSet,
        motion: &SetEstimate,
    ) {
        if motion.excluded == before {
            return;
        }
        let id = if !motion.excluded.minus(before).is_empty() {
            EventId::PartsExcluded
        } else {
            EventId::PartsIncluded
        };
        let out = self.estimation.excluded_channels();
        if id == EventId::PartsExcluded {
            warn!(
                "parts {:#x} excluded from the solve, channels out {:#x}",
                motion.excluded.0, out.0
            );
        } else {
            info!(
                "parts included again: excluded {:#x}, channels out {:#x}",
                motion.excluded.0, out.0
            );
        }
        let (parts, channels) = (u32::from(motion.excluded.0), out.0);
        self.event(t, tm, id, parts, channels).await;
    }

    /// Instants skipped or sets dropped since the last housekeeping report.
    pub(super) async fn loss_event<W: Write>(&mut self, t: Nanos, tm: &mut Telemetry<W>) {
        let s = &self.health.sampling;
        let lost = (s.skipped, s.dropped);
        if lost != self.lost_seen {
            self.lost_seen = lost;
            warn!(
                "sample sets lost since boot: {} instants skipped, {} sets dropped",
                lost.0, lost.1
            );
            self.event(t, tm, EventId::SetsLost, lost.0, lost.1).await;
        }
    }
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

/// The motion report of one output of the estimation, made in `context` (mode, model).
pub fn motion_report(
    motion: &SetEstimate,
    excluded_channels: ChannelSet,
    context: (Mode, ModelCode),
) -> MotionReport {
    MotionReport {
        k: motion.k,
        estimate: motion.estimate,
        missing_parts: motion.missing,
        excluded_parts: motion.excluded,
        excluded_channels,
        context: Some(context),
    }
}
