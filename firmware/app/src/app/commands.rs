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

impl App {
    /// Executes an accepted command; on failure nothing has changed.
    pub(super) async fn execute<W: Write>(
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
                    info!("mode {:?} -> {:?}", old, mode);
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
                let now = self.estimation.commanded();
                let commanded = match command {
                    Command::Exclude(_) => now.with(usize::from(c)),
                    _ => now.without(usize::from(c)),
                };
                self.estimation.set_commanded(commanded).map_err(refused)?;
                if commanded != now {
                    self.event(t, tm, EventId::ChannelsCommanded, now.0, commanded.0)
                        .await;
                }
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
            Command::StartIdentification { .. }
            | Command::ReferenceRate(_)
            | Command::ReportIdentification
            | Command::CommitCalibration { .. } => {
                self.identification_command(command, t, tm).await?
            }
            Command::ReportHousekeeping => self.send_housekeeping(t, tm).await,
            Command::SetTime(spacecraft) => {
                // The command's time is the spacecraft's at its reception, `t` on the unit's.
                let epoch = spacecraft
                    .checked_sub(ballisto_link::cuc::cuc_ticks(t))
                    .ok_or((FailureCode::NotReady, not_ready::TIME_BEFORE_BOOT))?;
                self.time = TimeCorrelation::at(epoch);
            }
            Command::AreYouAlive => tm.send(t, service::TEST, subtype::ALIVE, &[]).await,
        }
        Ok(())
    }

    /// TC[200,6] execution: the arrangement built (on the stack, not in the task's state)
    /// and handed to the estimator, which keeps its configuration if it refuses.
    pub(super) fn load_arrangement(&mut self, data: &[u8]) -> Result<(), (FailureCode, u32)> {
        let arrangement = telecommand::arrangement(data)?;
        let model = self.estimation.estimator().model();
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
