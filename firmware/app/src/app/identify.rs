//! The identification's telecommands (TC[200,8–11]) and reports (TM[200,128–129]), and the
//! commit of a solution through the storage task with its completion reported when the store
//! answers.

use ballisto_link::identification::IdentifiedChannel;
use ballisto_link::telecommand::Command;
use ballisto_link::verification::{config_error_code, not_ready};
use ballisto_link::{service, subtype, EventId, FailureCode, RequestId};
use embedded_io_async::Write;
use estimator_core::identify::{IdentifyError, PARAMS};

use super::App;
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

impl App {
    /// TC[200,8–10] (TC[200,11] is handled before execution: its completion comes from the
    /// storage task).
    pub(super) async fn identification_command<W: Write>(
        &mut self,
        command: Command<'_>,
        t: Nanos,
        tm: &mut Telemetry<W>,
    ) -> Result<(), (FailureCode, u32)> {
        match command {
            Command::StartIdentification {
                period_ms,
                window_ms,
            } => {
                let channels = self.estimation.channels();
                let rate = self.rate_hz;
                self.identification
                    .start(t, period_ms, window_ms, channels, rate);
                info!("identification window of {} ms started", window_ms);
            }
            Command::ReferenceRate(data) => {
                if !self.identification.started() {
                    return Err((FailureCode::NotReady, not_ready::NO_WINDOW));
                }
                self.identification
                    .on_points(ballisto_link::identification::points(data));
            }
            Command::ReportIdentification => self.report_identification(t, tm).await?,
            _ => {}
        }
        Ok(())
    }

    /// Says that a storage task takes commits (the board has a writable store).
    pub fn set_store_writable(&mut self, writable: bool) {
        self.store = if writable { Store::Idle } else { Store::None };
    }

    /// A commit for the storage task, if one was accepted since the last call.
    pub fn take_commit(&mut self) -> Option<CommitRequest> {
        self.outbox.take()
    }

    /// TC[200,10]: solves the window and sends the summary and every channel.
    async fn report_identification<W: Write>(
        &mut self,
        t: Nanos,
        tm: &mut Telemetry<W>,
    ) -> Result<(), (FailureCode, u32)> {
        let arrangement = self.estimation.estimator().arrangement();
        let (id, summary) = self.identification.solve(arrangement).map_err(|e| {
            let data = match e {
                None => not_ready::NO_WINDOW,
                Some(IdentifyError::TooFewSets { have }) => {
                    not_ready::TOO_FEW_SETS | have.min(0xFFFF)
                }
                Some(IdentifyError::NotConverged { channel }) => {
                    not_ready::NOT_CONVERGED | channel as u32
                }
                // The sums are started with the arrangement's channel count.
                Some(IdentifyError::ChannelCount { .. }) => not_ready::NO_WINDOW,
            };
            (FailureCode::NotReady, data)
        })?;
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
        let Some(id) = self.identification.solution(solution) else {
            return refuse(not_ready::NO_SUCH_SOLUTION);
        };
        for (c, f) in id.channels().iter().enumerate() {
            if !(f.residual_rms <= RESIDUAL_LIMIT * f.channel.noise) {
                return refuse(not_ready::RESIDUAL_HIGH | c as u32);
            }
        }
        let arrangement = id.arrangement().map_err(|e| {
            (
                FailureCode::NotReady,
                not_ready::INVALID | (config_error_code(&e) >> 16),
            )
        })?;
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
