//! Telecommands whose configuration the builder task builds (a board
//! with [`crate::estimation::Builds::background`]): a model or arrangement change (TC[200,2],
//! TC[200,6]) or a channel taken out or put back (TC[200,4], TC[200,5]) is accepted at once and
//! completed — its event and TM[1,7], or TM[1,8] if the estimator refuses it — at the first
//! set after it is built and in force; the estimates go on meanwhile with the configuration in
//! force (a channel on its way out reads as missing). A second such command while one is
//! being built is refused (not ready, `CONFIGURATION_BUSY`).

use ballisto_link::{subtype, CalibrationId, ChannelSet, EventId, RequestId};
use embedded_io_async::Write;

use super::commands::refused;
use super::App;
use crate::telemetry::Telemetry;
use crate::time::Nanos;

/// What a command reports once its configuration is in force.
#[derive(Clone, Copy, Debug)]
pub(super) enum Deferred {
    /// A new model or arrangement (and the arrangement's calibration identity, if new).
    Reconfigured { calibration: Option<CalibrationId> },
    /// The channels out by command, before and after.
    ChannelsCommanded {
        before: ChannelSet,
        after: ChannelSet,
    },
}

/// The command being built: its request, whether its completion is to be reported, and what.
#[derive(Clone, Copy, Debug)]
pub(super) struct Awaited {
    pub request: RequestId,
    pub ack: bool,
    pub report: Deferred,
}

impl App {
    /// Completes the command being built once its configuration is: the event and TM[1,7], or
    /// TM[1,8] with the estimator's refusal (nothing changed).
    pub(super) async fn complete_awaited<W: Write>(&mut self, t: Nanos, tm: &mut Telemetry<W>) {
        let Some(outcome) = self.estimation.take_order_outcome() else {
            return;
        };
        let Some(Awaited {
            request,
            ack,
            report,
        }) = self.awaited.take()
        else {
            return;
        };
        match outcome {
            Ok(()) => {
                let event = match report {
                    Deferred::Reconfigured { calibration } => {
                        if let Some(c) = calibration {
                            self.calibration = c;
                        }
                        Some(self.reconfigured())
                    }
                    Deferred::ChannelsCommanded { before, after } => {
                        (before != after).then_some((EventId::ChannelsCommanded, before.0, after.0))
                    }
                };
                if let Some((id, a, b)) = event {
                    self.event(t, tm, id, a, b).await;
                }
                if ack {
                    self.verify(t, tm, subtype::COMPLETED, request, None).await;
                }
            }
            Err(e) => {
                let failure = Some(refused(e));
                self.verify(t, tm, subtype::NOT_COMPLETED, request, failure)
                    .await;
            }
        }
    }
}
