//! Executing an accepted telecommand: the mode, the model, the rate hint, channel exclusion,
//! a new arrangement, the telemetry rates, identification (`identify`), one-shot reports. On
//! failure nothing has changed.

use ballisto_link::telecommand::{self, Command};
use ballisto_link::verification::{config_error_code, not_ready};
use ballisto_link::{service, subtype, EventId, FailureCode, TimeCorrelation};
use embedded_io_async::Write;
use estimator_core::ConfigError;

use super::{App, Mode};
use crate::estimation::Applied;
use crate::telemetry::Telemetry;
use crate::time::Nanos;

/// An event a command causes (its id and its two words), sent before its completion report.
pub(super) type CommandEvent = (EventId, u32, u32);

impl App {
    /// Executes an accepted command and returns the event it causes, if any (the caller sends
    /// it: one await point in the application's state machine instead of one per command,
    /// 88 B of flash for the channels-commanded event alone); on failure nothing has changed.
    pub(super) async fn execute<W: Write>(
        &mut self,
        command: Command<'_>,
        t: Nanos,
        tm: &mut Telemetry<W>,
    ) -> Result<Option<CommandEvent>, (FailureCode, u32)> {
        let event = match command {
            Command::SetMode(mode) => {
                if mode != self.mode {
                    let old = self.mode;
                    self.mode = mode;
                    if mode == Mode::Operate {
                        self.estimation.restart();
                        self.since_motion = 0;
                    }
                    info!("mode {:?} -> {:?}", old, mode);
                    return Ok(Some((EventId::ModeChanged, old as u32, mode as u32)));
                }
                None
            }
            Command::SetModel(model) => {
                self.configuration_free()?;
                let arrangement = self.estimation.estimator().arrangement().clone();
                let applied = self
                    .estimation
                    .configure(arrangement, model)
                    .map_err(refused)?;
                if applied == Applied::WhenBuilt {
                    return Ok(self.defer_reconfigured(None));
                }
                let _ = applied;
                Some(self.reconfigured())
            }
            Command::SetHint(w) => {
                self.estimation
                    .set_hint(w.map(f64::from))
                    .map_err(|_| (FailureCode::NotFinite, 0))?;
                None
            }
            Command::Exclude(c) | Command::Include(c) => {
                self.configuration_free()?;
                let now = self.estimation.commanded();
                let commanded = match command {
                    Command::Exclude(_) => now.with(usize::from(c)),
                    _ => now.without(usize::from(c)),
                };
                let applied = self.estimation.set_commanded(commanded).map_err(refused)?;
                if applied == Applied::WhenBuilt {
                    self.deferring = Some(super::awaited::Deferred::ChannelsCommanded {
                        before: now,
                        after: commanded,
                    });
                    return Ok(None);
                }
                let _ = applied;
                (commanded != now).then_some((EventId::ChannelsCommanded, now.0, commanded.0))
            }
            Command::LoadArrangement(data) => {
                self.configuration_free()?;
                let (applied, calibration) = self.load_arrangement(data)?;
                // The windows' biases were found with the arrangement replaced.
                self.identification.thermal.forget();
                if applied == Applied::WhenBuilt {
                    return Ok(self.defer_reconfigured(Some(calibration)));
                }
                let _ = applied;
                self.calibration = calibration;
                Some(self.reconfigured())
            }
            Command::SetRates {
                motion_every,
                housekeeping_every,
            } => {
                self.motion_every = motion_every;
                self.housekeeping_every = housekeeping_every;
                self.since_motion = 0;
                self.since_housekeeping = 0;
                None
            }
            Command::StartIdentification { .. } | Command::ReferenceRate(_) => {
                self.identification_command(command, t)?;
                None
            }
            // Handled before execution (`App::on_incoming`): completed by their tasks.
            Command::ReportIdentification | Command::CommitCalibration { .. } => None,
            Command::ReportHousekeeping => {
                self.send_housekeeping(t, tm).await;
                None
            }
            Command::SetTime(spacecraft) => {
                // The command's time is the spacecraft's at its reception, `t` on the unit's.
                let epoch = spacecraft
                    .checked_sub(ballisto_link::cuc::cuc_ticks(t))
                    .ok_or((FailureCode::NotReady, not_ready::TIME_BEFORE_BOOT))?;
                self.time = TimeCorrelation::at(epoch);
                None
            }
            Command::AreYouAlive => {
                tm.send(t, service::TEST, subtype::ALIVE, &[]).await;
                None
            }
        };
        Ok(event)
    }

    /// TC[200,6] execution: the arrangement built (on the stack, not in the task's state)
    /// and handed to the estimator, which keeps its configuration if it refuses; when it takes
    /// effect, and the arrangement's calibration identity (the command's data: a commanded
    /// arrangement is no stored calibration).
    pub(super) fn load_arrangement(
        &mut self,
        data: &[u8],
    ) -> Result<(Applied, ballisto_link::CalibrationId), (FailureCode, u32)> {
        let arrangement = telecommand::arrangement(data)?;
        let model = self.estimation.model();
        let applied = self
            .estimation
            .configure(arrangement, model)
            .map_err(refused)?;
        let calibration = ballisto_link::CalibrationId {
            source: ballisto_link::CalibrationSource::Commanded,
            id: 0,
            crc: ballisto_calstore::record::crc32(data),
        };
        Ok((applied, calibration))
    }

    /// A new model or arrangement (`calibration`: the new arrangement's identity) to be built
    /// by the builder task: its `reconfigured` event comes with the command's completion.
    fn defer_reconfigured(
        &mut self,
        calibration: Option<ballisto_link::CalibrationId>,
    ) -> Option<CommandEvent> {
        self.deferring = Some(super::awaited::Deferred::Reconfigured { calibration });
        None
    }

    /// A configuration command may run: none is being built (with the builder task).
    fn configuration_free(&self) -> Result<(), (FailureCode, u32)> {
        if self.estimation.order_awaited() {
            return Err((FailureCode::NotReady, not_ready::CONFIGURATION_BUSY));
        }
        Ok(())
    }
}

/// The completion failure of a configuration the estimator refused (it keeps the old one).
pub(super) fn refused(e: ConfigError) -> (FailureCode, u32) {
    warn!(
        "configuration refused by the estimator (the old one stays): {:?}",
        e
    );
    (FailureCode::Refused, config_error_code(&e))
}
