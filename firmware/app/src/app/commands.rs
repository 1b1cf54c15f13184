//! Executing an accepted telecommand: the mode, the model, the rate hint, channel exclusion,
//! a new arrangement, the telemetry rates, identification (`identify`), one-shot reports. On
//! failure nothing has changed.

use ballisto_link::telecommand::{self, Command};
use ballisto_link::verification::{config_error_code, not_ready};
use ballisto_link::{service, subtype, EventId, FailureCode, TimeCorrelation};
use embedded_io_async::Write;
use estimator_core::ConfigError;

use super::{App, Mode};
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
                let arrangement = self.estimation.estimator().arrangement().clone();
                self.estimation
                    .configure(&arrangement, model)
                    .map_err(refused)?;
                Some(self.reconfigured())
            }
            Command::SetHint(w) => {
                self.estimation
                    .set_hint(w.map(f64::from))
                    .map_err(|_| (FailureCode::NotFinite, 0))?;
                None
            }
            Command::Exclude(c) | Command::Include(c) => {
                let now = self.estimation.commanded();
                let commanded = match command {
                    Command::Exclude(_) => now.with(usize::from(c)),
                    _ => now.without(usize::from(c)),
                };
                self.estimation.set_commanded(commanded).map_err(refused)?;
                (commanded != now).then_some((EventId::ChannelsCommanded, now.0, commanded.0))
            }
            Command::LoadArrangement(data) => {
                self.load_arrangement(data)?;
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
            Command::StartIdentification { .. }
            | Command::ReferenceRate(_)
            | Command::ReportIdentification
            | Command::CommitCalibration { .. } => {
                self.identification_command(command, t, tm).await?;
                None
            }
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
    /// and handed to the estimator, which keeps its configuration if it refuses.
    pub(super) fn load_arrangement(&mut self, data: &[u8]) -> Result<(), (FailureCode, u32)> {
        let arrangement = telecommand::arrangement(data)?;
        let model = self.estimation.model();
        self.estimation
            .configure(&arrangement, model)
            .map_err(refused)?;
        // A commanded arrangement is no stored calibration: its identity is the command's data.
        self.calibration = ballisto_link::CalibrationId {
            source: ballisto_link::CalibrationSource::Commanded,
            id: 0,
            crc: ballisto_calstore::record::crc32(data),
        };
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
