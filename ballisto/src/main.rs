//! `ballisto`: the host binary (docs/formats.md).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use ballisto::calibrate::reference_rate::Validity;
use ballisto::estimate::{estimate_files, EstimateJob, Precision, FLAG_NAMES};
use ballisto_fw::config::Alignment;
use clap::{Args, Parser, Subcommand, ValueEnum};
use estimator_core::Model;

const FLAGS_HELP: &str = "The flags column of estimates.csv is a bit set:
  1   sign unresolved: Ω may be −Ω (steady spin, no hint yet)
  2   no real solution for a: least-squares fallback used
  4   ill-conditioned: the a solve is nearly singular (rate near zero or at a frame plane)
  8   channel(s) excluded (which: the excluded column, bit i = the file's i-th channel)
  16  branch ambiguous: another branch is nearly as consistent
  32  input invalid: a reading was missing (empty field) or absurd (128); the row is the
      prediction
  64  residual high: χ² above its 99.99 % point, or (model G) the fault monitor's window
      or mean test inconsistent with no part isolated (fault suspected)
  128 reading absurd: beyond twice its part's full scale (`range`), or 10 000 m/s^2 where
      none is declared: read as missing (32 is set too), counted in a warning
Model G: with redundancy to spare (16 or more channels for tri-axial parts) a part the fault
monitor isolates from the measurements is left out of the estimate (flag 8, the excluded
column) until its readings fit again; with 12 channels, the readings are tested against the
known gravity gradient (flag 64). Model F: no such test.";

const SIM_HELP: &str = "Named scenarios:
  tetra-orbit         4 x ADXL355 on a tetrahedron (SPI, external sync), torque-free tumble in orbit
  nine-channel        9-channel ballistometer from 6 x ADXL355, free-float tumble
  ground-spin-mixed   2 x ADXL355 (SPI) + 2 x LIS3DH (I2C, own clocks), ground turntable spin-up
  tetra-orbit-faults  tetra-orbit with a stuck part, a bias jump, a dead part and corrupted bytes
  ground-calibration  6 parts with datasheet errors (4 x ADXL355, 2 x LIS3DH), ground calibration schedule, reference gyro
  orbit-identify      4 x ADXL355 with datasheet errors, tumble with attitude-control torque in orbit, reference gyro at 20 Hz
  ground-thermal      4 x ADXL355 with datasheet errors and temperature coefficients, calibration schedule three times in a chamber ramping -10 to +50 degC, reference gyro
  tetra-orbit-thermal the same parts tumbling in orbit for 3 h through a +-20 degC orbit thermal cycle (boot on ground-thermal's calibration with --calibration; --identify tracks the coefficients in flight)
The scenario file format: hal-sim/scenarios/README.md.";

const DECODE_HELP: &str = "Packet layouts: docs/telemetry.md. Exit status: 0 all packets intact and
contiguous, 1 an input is wrong (unreadable, empty, an output that is an input), 2 the command
line is wrong, 3 damaged frames or sequence gaps (listed on stderr; the good packets are written).";

const TC_HELP: &str =
    "Each command is checked by the unit's own acceptance before it is written: a command
the unit would refuse is an error, and nothing is written. Frames are COBS between zero
delimiters (docs/telemetry.md), as the unit reads its command link; several commands in one
run get consecutive sequence counts from --sequence. Binary frames are not written to a
terminal: name --out FILE, redirect, or use --hex. Example:
  ballisto tc --sequence 7 exclude u1.x --arrangement arrangement.toml --out exclude.bin";

/// Which rows of a reference rate file are valid, beyond its own flag columns.
#[derive(Args, Clone, Debug, Default)]
struct ReferenceValidity {
    /// Flags beside the reference (CSV: t with the reference's times, then columns named
    /// `valid` — 0 leaves the row out — or ending in `_saturated` — not 0 leaves it out), e.g.
    /// reference_flags.csv.
    #[arg(long, value_name = "FLAGS.csv", requires = "reference")]
    reference_flags: Option<PathBuf>,
    /// The reference gyro's range, rad/s: rows with an axis at 99 % of it or beyond are
    /// clipped readings and left out.
    #[arg(long, value_name = "RAD_S", requires = "reference", allow_negative_numbers = true, value_parser = positive_rate)]
    reference_range: Option<f64>,
}

/// A gyro's range: a positive number of rad/s.
fn positive_rate(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(r) if r.is_finite() && r > 0.0 => Ok(r),
        _ => Err(format!(
            "\"{s}\": the gyro's range must be a positive number of rad/s"
        )),
    }
}

/// A relative deviation: a number above 0 and below 1.
/// `--inertia`: three principal moments or the six components of a symmetric tensor.
fn inertia(s: &str) -> Result<[f64; 6], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>().map_err(|e| format!("{x:?}: {e}")))
        .collect::<Result<_, _>>()?;
    if !v.iter().all(|x| x.is_finite()) {
        return Err("every component must be a finite number".into());
    }
    match v.len() {
        3 => Ok([v[0], v[1], v[2], 0.0, 0.0, 0.0]),
        6 => Ok([v[0], v[1], v[2], v[3], v[4], v[5]]),
        n => Err(format!("{n} numbers: give XX,YY,ZZ or XX,YY,ZZ,XY,XZ,YZ")),
    }
}

fn relative_sd(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(r) if r > 0.0 && r < 1.0 => Ok(r),
        _ => Err(format!(
            "\"{s}\": a relative deviation is a number above 0 and below 1 (0.005 for 0.5 %)"
        )),
    }
}

/// A probability strictly between 0 and 1.
fn probability(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(p) if p > 0.0 && p < 1.0 => Ok(p),
        _ => Err(format!(
            "\"{s}\": a probability is a number above 0 and below 1 (0.001 for one row in a thousand)"
        )),
    }
}

/// Three alert limits `S0,DW,W`: positive numbers (`inf` for none).
fn alert_limits(s: &str) -> Result<[f64; 3], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let bad = || {
        format!(
            "\"{s}\": three positive numbers SIGMA0,DOMEGA,OMEGA are expected (m/s², rad/s², rad/s; inf for no limit)"
        )
    };
    if parts.len() != 3 {
        return Err(bad());
    }
    let mut v = [0.0; 3];
    for (o, p) in v.iter_mut().zip(&parts) {
        *o = p.parse::<f64>().ok().filter(|v| *v > 0.0).ok_or_else(bad)?;
    }
    Ok(v)
}

impl ReferenceValidity {
    fn validity(&self) -> Validity<'_> {
        Validity {
            flags: self.reference_flags.as_deref(),
            range: self.reference_range,
        }
    }
}

/// `--model` (docs/formats.md).
#[derive(Clone, Copy, Debug, ValueEnum)]
enum ModelArg {
    /// Model G: 9 linear unknowns, N >= 12.
    General,
    /// Model F: free float, N >= 9.
    FreeFloat,
}

impl From<ModelArg> for Model {
    fn from(m: ModelArg) -> Self {
        match m {
            ModelArg::General => Model::General,
            ModelArg::FreeFloat => Model::FreeFloat,
        }
    }
}

/// `--precision`.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum PrecisionArg {
    /// As on the target.
    F32,
    /// The host's.
    F64,
}

/// `--align` (with `sim --firmware`).
#[derive(Clone, Copy, Debug, ValueEnum)]
enum AlignArg {
    /// Timestamped FIFO samples interpolated to the instants.
    Interpolate,
    /// The latest output as if sampled at the instant (the unaligned reference).
    Latest,
}

#[derive(Parser)]
#[command(
    name = "ballisto",
    version,
    about = "Ballistometer host tools: σ0, Ω′ and Ω from accelerometers alone",
    after_help = ballisto::exit::HELP
)]
struct Cli {
    /// Say nothing but warnings and errors (no summaries, no notices).
    #[arg(short, long, global = true, conflicts_with = "verbose")]
    quiet: bool,
    /// Say more: timings, every problem listed, the calibration's alternations.
    #[arg(short, long, global = true)]
    verbose: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Estimate σ0, Ω′, Ω and A for every row of a samples file.
    #[command(after_help = FLAGS_HELP)]
    Estimate {
        /// Arrangement file (TOML).
        #[arg(long, value_name = "FILE.toml")]
        arrangement: PathBuf,
        /// Samples file (CSV: t and one column per channel); `-` reads stdin.
        #[arg(long, value_name = "FILE.csv")]
        samples: PathBuf,
        /// Estimates file to write, `-` for stdout (CSV: the docs/formats.md columns, then chi2, dof, branches,
        /// frame, the standard deviations — with the arrangement's frame uncertainty when it
        /// has one — epsilon, and the gravity gradient gamma_* with sd_gamma_*, model G only).
        #[arg(long, value_name = "FILE.csv")]
        out: PathBuf,
        /// Model: general (9-column, N >= 12) or free-float (N >= 9); default: the file's, else
        /// general unless model G would resolve the field poorly on this arrangement (then
        /// free-float, said on stderr).
        #[arg(long, value_enum)]
        model: Option<ModelArg>,
        /// Approximate angular rate at the first sample, rad/s, "X,Y,Z": settles the sign and the starting branch.
        #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
        initial_omega: Option<String>,
        /// Per-sample estimates without temporal filtering (continuity still picks sign and branch).
        #[arg(long)]
        raw: bool,
        /// Scalar of the sample loop: f64 (default) or f32 (as on the target).
        #[arg(long, value_enum, default_value = "f64")]
        precision: PrecisionArg,
        /// Alert limits of the protection levels "SIGMA0,DOMEGA,OMEGA" (m/s², rad/s², rad/s;
        /// `inf` for none): a row whose level is above its limit, or that has none, gets flag
        /// 256. Default: no alert.
        #[arg(long, value_name = "S0,DW,W", value_parser = alert_limits)]
        alert_limits: Option<[f64; 3]>,
        /// The probability that an output's error exceeds its protection level at a row.
        #[arg(long, value_name = "P", default_value = "0.001", allow_negative_numbers = true, value_parser = probability)]
        missed: f64,
    },
    /// Simulate a scenario: parts read through their simulated buses; writes arrangement.toml,
    /// samples.csv and truth.csv (with --estimate also estimates.csv and estimates.png).
    #[command(after_help = SIM_HELP)]
    Sim {
        /// A named scenario or a scenario file (TOML).
        #[arg(long, value_name = "NAME|FILE")]
        scenario: String,
        /// Output directory (created if missing).
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
        /// Also run the estimator: estimates.csv, errors against the truth, estimates.png.
        #[arg(long)]
        estimate: bool,
        /// Run the firmware (its sampling and estimation tasks on the simulated buses) instead
        /// of the bench reader: samples.csv and estimates.csv are what the firmware produced.
        #[arg(long)]
        firmware: bool,
        /// With --firmware: how samples of free-running parts are aligned to the sample
        /// instants: interpolate (timestamped FIFO samples) or latest (the unaligned reference).
        #[arg(long, value_enum, default_value = "interpolate")]
        align: AlignArg,
        /// With --firmware: identify in flight first (paper §6) with the scenario's reference
        /// gyro sent by telecommand (or, without one, in its torque-free tumble), commit,
        /// reset, and run the scenario again on the stored calibration (the first boot's
        /// telemetry in telemetry-identify.bin). Where the scenario's temperature changes,
        /// windows spread over the run (one per 15 minutes): the unit tracks each channel's
        /// bias against its temperature and the commit takes the coefficients it decides.
        #[arg(long, requires = "firmware")]
        identify: bool,
        /// With --firmware: send the telecommand frames of FILE (as `ballisto tc` writes them)
        /// on the unit's command link at scenario time SECONDS; repeatable. The unit's
        /// verification reports are in telemetry.bin (`ballisto decode --commands FILE`).
        #[arg(
            long,
            value_name = "SECONDS:FILE",
            requires = "firmware",
            conflicts_with = "identify"
        )]
        uplink: Vec<String>,
        /// With --firmware: the unit's calibration store holds this calibrated arrangement
        /// (`ballisto calibrate`'s output over the scenario's channels, its temperature
        /// coefficients included), committed on the ground as calibration 1: the unit boots
        /// on it (with --identify, the first boot does).
        #[arg(long, value_name = "FILE.toml", requires = "firmware")]
        calibration: Option<PathBuf>,
    },
    /// Decode a telemetry stream (COBS-framed PUS packets, as `sim --firmware` writes in
    /// telemetry.bin or the unit sends on its link): motion reports to an estimates file,
    /// housekeeping, events and verification reports to readable text. Every frame's CRC
    /// and the sequence count are checked; exit status 3 if anything was damaged or lost
    /// (the good packets are still written).
    #[command(after_help = DECODE_HELP)]
    Decode {
        /// The raw stream; `-` reads stdin.
        #[arg(value_name = "FILE")]
        input: PathBuf,
        /// Estimates file to write, `-` for stdout (CSV: the estimates columns, then k,
        /// missing_parts, excluded_parts, excluded_channels).
        #[arg(long, value_name = "FILE.csv")]
        out: PathBuf,
        /// Write housekeeping, events and verification reports here (default: stdout).
        #[arg(long, value_name = "FILE.txt")]
        log: Option<PathBuf>,
        /// Seconds added to the on-board time (time since boot) of every packet.
        #[arg(
            long,
            value_name = "S",
            default_value = "0",
            allow_hyphen_values = true
        )]
        time_offset: f64,
        /// Also write the stream's last identification solution (TM[200,128–129])
        /// as an arrangement file over the channel names of --arrangement.
        #[arg(long, value_name = "FILE.toml", requires = "arrangement")]
        calibration: Option<PathBuf>,
        /// The nominal arrangement the unit runs (its channel names), for --calibration.
        #[arg(long, value_name = "FILE.toml")]
        arrangement: Option<PathBuf>,
        /// Telecommands sent (frames as `ballisto tc` writes them; repeatable): each
        /// verification report names the command it answers, and a command with no report is
        /// listed.
        #[arg(long, value_name = "TC.bin")]
        commands: Vec<PathBuf>,
    },
    /// Identify every channel's position, axis, scale and bias from a record of static poses
    /// and motion (paper §6); writes a calibrated arrangement file with standard deviations
    /// and the frame's uncertainty (frame_*_sd). What the record does not determine keeps its
    /// nominal value and is named; a record that determines fewer than half the parameters
    /// is refused.
    Calibrate {
        /// Nominal arrangement file (TOML): the geometry as drawn.
        #[arg(long, value_name = "NOMINAL.toml")]
        arrangement: PathBuf,
        /// The calibration record (samples CSV): any mix of static poses and motion.
        #[arg(long, value_name = "RECORD.csv")]
        samples: PathBuf,
        /// Calibrated arrangement file to write.
        #[arg(long, value_name = "CALIBRATED.toml")]
        out: PathBuf,
        /// Reference rate file (CSV: t, omega_x, omega_y, omega_z; rad/s, body frame); without
        /// it Ω comes from the estimator (self-calibration). Rows whose `valid` column is 0 or
        /// whose `*_saturated` columns are not 0 are left out.
        #[arg(long, value_name = "REFERENCE.csv")]
        reference: Option<PathBuf>,
        #[command(flatten)]
        validity: ReferenceValidity,
        /// How well the reference's scale factors are known, relative (e.g. 0.005): the
        /// reference is then a reading of Ω rather than Ω itself, its common scale factor is
        /// fitted and the array's size held at the drawing's. For a gyro whose scale factors
        /// are not calibrated; without it the reference's scale is taken as exact.
        #[arg(long, value_name = "REL", requires = "reference", allow_negative_numbers = true, value_parser = relative_sd)]
        reference_scale_sd: Option<f64>,
        /// What may change: a comma-separated subset of bias, scale, axis, position.
        #[arg(long, value_name = "LIST", default_value = "bias,scale,axis,position")]
        fit: String,
        /// Model of the estimator in self-calibration, and the one written into the file;
        /// default as for estimate.
        #[arg(long, value_enum)]
        model: Option<ModelArg>,
        /// A report for people (Markdown): per channel the identified values, their standard
        /// deviations and the residual before and after; with REPORT.png beside it (the
        /// residuals per sample and per channel, before and after).
        #[arg(long, value_name = "REPORT.md")]
        report: Option<PathBuf>,
        /// Write the calibration even when it does not improve the part of the record held
        /// out of the fit (every fifth 2 s of motion); the warning goes into the file.
        #[arg(long)]
        force: bool,
        /// Without a reference, from a torque-free tumble in free flight: the body's inertia
        /// in the body frame, XX,YY,ZZ or XX,YY,ZZ,XY,XZ,YZ (any unit: only the ratios
        /// matter). The record is then fitted with the motion Euler's equations give (paper
        /// §6); a record that cannot decide is refused, naming the channel and parameter.
        #[arg(long, value_name = "XX,YY,ZZ[,XY,XZ,YZ]", value_parser = inertia,
              conflicts_with_all = ["reference", "reference_scale_sd", "report", "force", "model"])]
        inertia: Option<[f64; 6]>,
    },
    /// Where the centre of mass is (paper eq. 12's ρ: the instrument origin seen from the
    /// centre of mass, which is at −ρ) over sliding windows: t, rho_x.., f_x.., sd_rho_x..
    /// (docs/formats.md); empty fields where a window's rotation cannot separate ρ from f.
    Com {
        /// Arrangement file (TOML).
        #[arg(long, value_name = "FILE.toml")]
        arrangement: PathBuf,
        /// Samples file (CSV).
        #[arg(long, value_name = "FILE.csv")]
        samples: PathBuf,
        /// Output file (CSV).
        #[arg(long, value_name = "COM.csv")]
        out: PathBuf,
        /// Window length, s (one window every half window).
        #[arg(long, value_name = "SECONDS", default_value = "10")]
        window: f64,
        /// Model; default as for estimate.
        #[arg(long, value_enum)]
        model: Option<ModelArg>,
    },
    /// RMS errors of an estimates file against a truth file (matched by column name and t);
    /// with --reference, its Ω against a rate reference (a gyro: RMS and median per axis, on
    /// the reference's valid rows).
    Compare {
        /// TRUTH.csv ESTIMATES.csv (the truth as the simulator writes it, the estimates as
        /// `ballisto estimate` does); with --reference, ESTIMATES.csv alone.
        #[arg(value_name = "FILES", num_args = 1..=2, required = true)]
        files: Vec<PathBuf>,
        /// Reference rate file (CSV: t, omega_x, omega_y, omega_z; rad/s, body frame) to score
        /// Ω against, in place of a truth file.
        #[arg(long, value_name = "REFERENCE.csv")]
        reference: Option<PathBuf>,
        #[command(flatten)]
        validity: ReferenceValidity,
    },
    /// Build telecommands for the unit (PUS packets, COBS-framed as on its command link):
    /// to a file, or stdout.
    #[command(after_help = TC_HELP)]
    Tc {
        /// Where to write the frames (default: stdout, `-`).
        #[arg(long, value_name = "TC.bin", global = true, default_value = "-")]
        out: PathBuf,
        /// Sequence count of the (first) packet, 0–16383: the verification reports carry it.
        #[arg(long, value_name = "N", global = true, default_value = "0")]
        sequence: u16,
        /// Verification reports asked for: acceptance, completion (comma-separated), or none.
        #[arg(
            long,
            value_name = "LIST",
            global = true,
            default_value = "acceptance,completion"
        )]
        ack: String,
        /// Write the frames as hexadecimal text, one per line, instead of binary.
        #[arg(long, global = true)]
        hex: bool,
        #[command(subcommand)]
        command: TcCommand,
    },
}

/// The telecommands of `ballisto tc` (docs/telemetry.md, "Telecommands").
#[derive(Subcommand)]
enum TcCommand {
    /// TC[200,1]: standby (sampling, housekeeping) or operate (estimating).
    Mode {
        /// standby or operate.
        #[arg(value_enum)]
        mode: ModeArg,
    },
    /// TC[200,2]: the estimator model.
    Model {
        /// general or free-float.
        #[arg(value_enum)]
        model: ModelArg,
    },
    /// TC[200,3]: an approximate Ω (rad/s, body) to settle sign and branch.
    Hint {
        /// "X,Y,Z" in rad/s (each at most 50).
        #[arg(value_name = "X,Y,Z", allow_hyphen_values = true)]
        omega: String,
    },
    /// TC[200,4]: take a channel out of the solve.
    Exclude {
        /// The channel: its index (file order, sensors expanded x, y, z) or, with
        /// --arrangement, its name.
        channel: String,
        /// The unit's arrangement file: channel names, and the range of the index.
        #[arg(long, value_name = "FILE.toml")]
        arrangement: Option<PathBuf>,
    },
    /// TC[200,5]: put a commanded-out channel back.
    Include {
        /// The channel: index or, with --arrangement, name.
        channel: String,
        /// The unit's arrangement file.
        #[arg(long, value_name = "FILE.toml")]
        arrangement: Option<PathBuf>,
    },
    /// TC[200,6]: load a geometry (positions, axes, noise) for the unit's channels.
    LoadArrangement {
        /// Arrangement file (TOML), e.g. `ballisto calibrate`'s output.
        #[arg(value_name = "FILE.toml")]
        arrangement: PathBuf,
    },
    /// TC[200,7]: telemetry rates.
    Rates {
        /// Sample sets per motion report (1 = every set; at most 10 000).
        #[arg(long, value_name = "N")]
        motion_every: u16,
        /// Sample sets per housekeeping report.
        #[arg(long, value_name = "N")]
        housekeeping_every: u16,
    },
    /// TC[200,8]: start an identification window with a reference rate sent by TC[200,9], or
    /// with --inertia without one, in a torque-free tumble.
    Identify {
        /// The reference's period on the bus, ms (a longer interval is a gap); with --inertia,
        /// the interval the unit averages into one kept set (short: the motion's curvature
        /// within a mean grows with its square; 40 ms at 100 Hz).
        #[arg(long, value_name = "MS")]
        period_ms: u16,
        /// The window's length from reception, s (at most one hour).
        #[arg(long, value_name = "SECONDS")]
        window: f64,
        /// Without a reference (source 2): the body's inertia in the body frame, XX,YY,ZZ or
        /// XX,YY,ZZ,XY,XZ,YZ (only the ratios matter); the motion must be torque-free.
        #[arg(long, value_name = "XX,YY,ZZ[,XY,XZ,YZ]", value_parser = inertia)]
        inertia: Option<[f64; 6]>,
    },
    /// TC[200,9]: reference rate points from a file (CSV: t, omega_x, omega_y, omega_z; t on
    /// the unit's clock, s since boot), 16 points per packet.
    Reference {
        /// Reference rate file.
        #[arg(value_name = "REFERENCE.csv")]
        file: PathBuf,
        /// First time to send, s.
        #[arg(long, value_name = "S", default_value = "0")]
        from: f64,
        /// Last time to send, s.
        #[arg(long, value_name = "S", default_value = "inf")]
        to: f64,
    },
    /// TC[200,10]: solve the identification window and report the solution.
    ReportIdentification,
    /// TC[200,11]: commit a reported solution to the calibration store.
    Commit {
        /// The solution number its TM[200,128] gave.
        solution: u16,
    },
    /// TC[3,27]: report housekeeping now.
    Housekeeping,
    /// TC[9,128]: the spacecraft time at the command's reception (s; CUC 4+3).
    SetTime {
        /// Seconds of the spacecraft's time scale.
        #[arg(value_name = "SECONDS")]
        seconds: f64,
    },
    /// TC[17,1]: are you alive.
    Ping,
}

/// `tc mode`.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum ModeArg {
    /// Sampling and housekeeping only.
    Standby,
    /// Estimating at sample rate.
    Operate,
}

fn parse_vec3(s: &str) -> Result<[f64; 3], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!(
            "--initial-omega \"{s}\": expected three numbers X,Y,Z"
        ));
    }
    let mut v = [0.0; 3];
    for (o, p) in v.iter_mut().zip(parts.iter()) {
        let x: f64 = p
            .parse()
            .map_err(|_| format!("--initial-omega \"{s}\": \"{p}\" is not a number"))?;
        *o = x;
        if !x.is_finite() {
            return Err(format!("--initial-omega \"{s}\": \"{p}\" is not finite"));
        }
    }
    Ok(v)
}

fn parse_fit(s: &str) -> Result<ballisto::calibrate::fit::FitSet, String> {
    let mut fit = ballisto::calibrate::fit::FitSet {
        bias: false,
        scale: false,
        axis: false,
        position: false,
    };
    for item in s.split(',').map(str::trim) {
        match item {
            "bias" => fit.bias = true,
            "scale" => fit.scale = true,
            "axis" => fit.axis = true,
            "position" => fit.position = true,
            other => {
                return Err(format!(
                    "--fit \"{s}\": \"{other}\" is not one of bias, scale, axis, position"
                ))
            }
        }
    }
    Ok(fit)
}

/// What is said on stderr besides errors and warnings (`--quiet`, `--verbose`).
#[derive(Clone, Copy)]
struct Say {
    quiet: bool,
    verbose: bool,
}

impl Say {
    /// A summary or notice: left out with `--quiet`.
    fn info(self, text: impl std::fmt::Display) {
        if !self.quiet {
            eprintln!("{text}");
        }
    }

    /// A detail: only with `--verbose`.
    fn detail(self, text: impl std::fmt::Display) {
        if self.verbose {
            eprintln!("{text}");
        }
    }
}

/// Problems listed without `--verbose`.
const PROBLEMS_LISTED: usize = 10;

fn run(cli: Cli) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let say = Say {
        quiet: cli.quiet,
        verbose: cli.verbose,
    };
    let started = std::time::Instant::now();
    match cli.command {
        Command::Estimate {
            arrangement,
            samples,
            out,
            model,
            initial_omega,
            raw,
            precision,
            alert_limits,
            missed,
        } => {
            let model = model.map(Model::from);
            let initial_omega = initial_omega.as_deref().map(parse_vec3).transpose()?;
            let precision = match precision {
                PrecisionArg::F64 => Precision::F64,
                PrecisionArg::F32 => Precision::F32,
            };
            let job = EstimateJob {
                arrangement: &arrangement,
                samples: &samples,
                out: &out,
                model,
                options: estimator_core::Options {
                    raw,
                    initial_omega,
                    missed,
                    alert_limits: alert_limits.unwrap_or([f64::INFINITY; 3]),
                    ..Default::default()
                },
                precision,
            };
            let s = estimate_files(&job)?;
            if let Some(note) = &s.model_note {
                say.info(format!(
                    "ballisto estimate: {}: {note}",
                    arrangement.display()
                ));
            }
            for w in &s.warnings {
                eprintln!("ballisto estimate: WARNING: {w}");
            }
            say.info(format!(
                "ballisto estimate: {} rows, {} channels, model {} -> {}",
                s.rows,
                s.channels,
                s.model.map(|m| m.name()).unwrap_or("?"),
                out.display()
            ));
            for (bit, name) in FLAG_NAMES {
                let c = s.flag_counts[bit.trailing_zeros() as usize];
                if c > 0 {
                    say.info(format!("  {c:>8} rows flagged {name} ({bit})"));
                }
            }
            let secs = started.elapsed().as_secs_f64();
            say.detail(format!(
                "  {secs:.2} s wall time, {:.0} rows/s",
                s.rows as f64 / secs.max(1e-9)
            ));
            Ok(ExitCode::SUCCESS)
        }
        Command::Calibrate {
            arrangement,
            samples,
            out,
            reference,
            validity,
            reference_scale_sd,
            fit,
            model,
            report,
            force,
            inertia,
        } => {
            if let Some(inertia) = inertia {
                let s = ballisto::calibrate::tumble::calibrate_tumble(
                    &ballisto::calibrate::tumble::TumbleJob {
                        arrangement: &arrangement,
                        samples: &samples,
                        out: &out,
                        inertia,
                    },
                )?;
                let (w, sd) = s.omega0;
                say.info(format!(
                    "ballisto calibrate: torque-free tumble, {} sample sets, start rate [{:.4}, {:.4}, {:.4}] rad/s (sd {:.1e} {:.1e} {:.1e}) after {} evaluations, rho [{:.4}, {:.4}, {:.4}] m -> {}",
                    s.sets,
                    w[0],
                    w[1],
                    w[2],
                    sd[0],
                    sd[1],
                    sd[2],
                    s.evaluations,
                    s.rho[0],
                    s.rho[1],
                    s.rho[2],
                    out.display()
                ));
                for (name, held) in &s.held {
                    say.info(format!(
                        "  {name}: not identified (kept nominal): {}",
                        held.join(", ")
                    ));
                }
                return Ok(ExitCode::SUCCESS);
            }
            let fit = parse_fit(&fit)?;
            let model = model.map(Model::from);
            let s = ballisto::calibrate::calibrate_files(&ballisto::calibrate::CalibrateJob {
                arrangement: &arrangement,
                samples: &samples,
                out: &out,
                reference: reference.as_deref(),
                reference_validity: validity.validity(),
                reference_scale_sd,
                fit,
                model,
                report: report.as_deref(),
                force,
                progress: !say.quiet,
            })?;
            if let Some(d) = &s.reference_dropped {
                say.info(format!("ballisto calibrate: {d}"));
            }
            say.info(format!(
                "ballisto calibrate: {} static poses, {}, {} alternations, model {} -> {}",
                s.poses,
                s.motion_described(),
                s.identification.iterations,
                s.model.name(),
                out.display()
            ));
            if let Some(f) = &s.reference_found {
                say.info(format!("  {}", f.describe()));
            }
            match &s.validation {
                Ok(v) => say.info(format!("  validated: {}", v.describe())),
                Err(why) => say.info(format!("  not validated: {why}")),
            }
            if let Some(t) = &s.thermal {
                let found = t.thermal().iter().filter(|c| c.is_some()).count();
                say.info(format!(
                    "  temperature coefficients: {found} of {} channels identified from {} static poses over {:.1} °C (each with its deviation in the file's header)",
                    t.channels.len(),
                    t.poses.0,
                    t.poses.1
                ));
            }
            for w in &s.warnings {
                eprintln!("  WARNING: {w}");
            }
            for c in &s.identification.conventions {
                say.info(format!("  held by convention: {c}"));
            }
            for (name, c) in s.names.iter().zip(s.identification.channels.iter()) {
                if !c.held.is_empty() {
                    say.info(format!(
                        "  {name}: not identified (kept nominal): {}",
                        c.held.join("; ")
                    ));
                }
            }
            say.detail(format!(
                "  {:.2} s wall time",
                started.elapsed().as_secs_f64()
            ));
            Ok(ExitCode::SUCCESS)
        }
        Command::Com {
            arrangement,
            samples,
            out,
            window,
            model,
        } => {
            let model = model.map(Model::from);
            let s = ballisto::com::com_files(&arrangement, &samples, &out, window, model)?;
            if let Some(note) = &s.model_note {
                say.info(format!("ballisto com: {}: {note}", arrangement.display()));
            }
            for w in &s.warnings {
                eprintln!("ballisto com: WARNING: {w}");
            }
            say.info(format!(
                "ballisto com: {} windows of {window} s ({} could not separate rho from f), model {} -> {} ({})",
                s.windows,
                s.undetermined,
                s.model.map(|m| m.name()).unwrap_or("?"),
                out.display(),
                ballisto::com::RHO_MEANING
            ));
            Ok(ExitCode::SUCCESS)
        }
        Command::Sim {
            scenario,
            out,
            estimate,
            firmware,
            align,
            identify,
            uplink,
            calibration,
        } => {
            let alignment = match align {
                AlignArg::Interpolate => Alignment::Interpolate,
                AlignArg::Latest => Alignment::Latest,
            };
            // A scenario file or an uplink file in the output directory is not overwritten.
            std::fs::create_dir_all(&out)
                .map_err(|e| format!("{}: cannot create the directory: {e}", out.display()))?;
            let outputs: Vec<PathBuf> =
                ballisto::sim::OUTPUTS.iter().map(|f| out.join(f)).collect();
            let outputs: Vec<&Path> = outputs.iter().map(PathBuf::as_path).collect();
            let uplink = uplink
                .iter()
                .map(|u| parse_uplink(u))
                .collect::<Result<Vec<_>, _>>()?;
            let inputs: Vec<&Path> = std::iter::once(Path::new(&scenario))
                .chain(uplink.iter().map(|(_, file)| *file))
                .chain(calibration.as_deref())
                .collect();
            ballisto::output::check_distinct(&outputs, &inputs)?;
            let sc = hal_sim::scenario::Scenario::load(&scenario)?;
            let uplink = uplink
                .into_iter()
                .map(|(at, file)| read_uplink(at, file))
                .collect::<Result<Vec<_>, _>>()?;
            let r = ballisto::sim::run_sim(&ballisto::sim::SimJob {
                scenario: &sc,
                out: &out,
                estimate,
                progress: !say.quiet,
                firmware: firmware.then_some(alignment),
                identify,
                uplink,
                calibration: calibration.as_deref(),
            })?;
            print_sim(say, &scenario, &sc, &r, identify, started);
            Ok(ExitCode::SUCCESS)
        }
        Command::Decode {
            input,
            out,
            log,
            time_offset,
            calibration,
            arrangement,
            commands,
        } => {
            // Every output checked against every input before anything is written.
            let outputs: Vec<&Path> = std::iter::once(out.as_path())
                .chain(log.as_deref())
                .chain(calibration.as_deref())
                .collect();
            let inputs: Vec<&Path> = std::iter::once(input.as_path())
                .chain(arrangement.as_deref())
                .chain(commands.iter().map(PathBuf::as_path))
                .collect();
            ballisto::output::check_distinct(&outputs, &inputs)?;
            let mut sent = std::collections::HashMap::new();
            for c in &commands {
                let bytes = ballisto::output::read_input(c)?;
                sent.extend(ballisto::tc::sent(&bytes, &c.display().to_string())?);
            }
            let (stream, rows, text) =
                ballisto::decode::decode_file(&input, &out, log.as_deref(), time_offset, &sent)?;
            if let (Some(cal), Some(nominal)) = (&calibration, &arrangement) {
                let file = ballisto::decode::identified_arrangement(&stream, &input, nominal)?;
                ballisto::output::write(cal, file.as_bytes())?;
                say.info(format!(
                    "{}: identification solution written",
                    cal.display()
                ));
            }
            if log.is_none() {
                if ballisto::output::is_std(&out) {
                    // The estimates own stdout: the log goes with the diagnostics.
                    if !say.quiet {
                        eprint!("{text}");
                    }
                } else {
                    print!("{text}");
                }
            }
            say.info(format!(
                "{}: {} packets, {rows} motion reports to {}, {} problems",
                input.display(),
                stream.packets.len(),
                out.display(),
                stream.problems.len()
            ));
            let listed = if say.verbose {
                stream.problems.len()
            } else {
                PROBLEMS_LISTED
            };
            for p in stream.problems.iter().take(listed) {
                eprintln!("ballisto: {}: {p}", input.display());
            }
            if stream.problems.len() > listed {
                eprintln!(
                    "ballisto: {}: {} more problems (-v lists them all; the log has every one)",
                    input.display(),
                    stream.problems.len() - listed
                );
            }
            Ok(if stream.problems.is_empty() {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(ballisto::exit::DAMAGED_TELEMETRY)
            })
        }
        Command::Compare {
            files,
            reference: Some(reference),
            validity,
        } => {
            let [estimates] = files.as_slice() else {
                return Err(Box::new(ballisto::exit::Usage(
                    "compare --reference REFERENCE.csv takes the estimates file alone (no truth file)".into(),
                )));
            };
            let c =
                ballisto::compare::compare_reference(&reference, &validity.validity(), estimates)?;
            if let Some(d) = c.dropped.describe(&reference) {
                say.info(format!("ballisto compare: {d}"));
            }
            println!(
                "rows compared: {} of {} (the others not between two valid reference rows)",
                c.compared, c.rows
            );
            for (i, axis) in ["x", "y", "z"].iter().enumerate() {
                println!(
                    "omega_{axis}  RMS error {:.3e} rad/s, median |error| {:.3e} rad/s",
                    c.rms[i], c.median[i]
                );
            }
            println!(
                "|omega|   RMS error {:.3e} rad/s, median {:.3e} rad/s",
                c.rms_norm, c.median_norm
            );
            Ok(ExitCode::SUCCESS)
        }
        Command::Compare {
            files,
            reference: None,
            ..
        } => {
            let [truth, estimates] = files.as_slice() else {
                return Err(Box::new(ballisto::exit::Usage(
                    "compare takes TRUTH.csv ESTIMATES.csv (or --reference REFERENCE.csv ESTIMATES.csv)".into(),
                )));
            };
            let c = ballisto::compare::compare(truth, estimates)?;
            println!("rows compared: {}", c.rows);
            println!("RMS error  sigma0 {:.3e} m/s^2", c.sigma0);
            println!("RMS error  domega {:.3e} rad/s^2", c.domega);
            println!("RMS error  omega  {:.3e} rad/s", c.omega);
            println!("RMS error  A      {:.3e} 1/s^2", c.field);
            if let Some(s) = c.silent {
                println!(
                    "unflagged rows with an error above {} reported sd: sigma0 {}, omega {}",
                    ballisto::compare::SILENT_SD,
                    s.sigma0,
                    s.omega
                );
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Tc {
            out,
            sequence,
            ack,
            hex,
            command,
        } => {
            let ack = ballisto::tc::ack_flags(&ack)?;
            let frames = telecommands(command, sequence, ack, say)?;
            let bytes = if hex {
                ballisto::tc::hex(&frames).into_bytes()
            } else {
                frames
                    .iter()
                    .flat_map(|f| f.frame.iter().copied())
                    .collect()
            };
            if ballisto::output::is_std(&out) && !hex {
                use std::io::IsTerminal;
                if std::io::stdout().is_terminal() {
                    return Err("refusing to write binary telecommand frames to a terminal: name --out FILE, redirect stdout, or add --hex".into());
                }
            }
            ballisto::output::write(&out, &bytes)?;
            for f in &frames {
                say.info(format!("ballisto tc: {} -> {}", f.text, out.display()));
            }
            Ok(ExitCode::SUCCESS)
        }
    }
}

/// The frames of a `tc` command: consecutive sequence counts from `sequence`.
fn telecommands(
    command: TcCommand,
    sequence: u16,
    ack: u8,
    say: Say,
) -> Result<Vec<ballisto::tc::Framed>, Box<dyn std::error::Error>> {
    use ballisto::tc;
    use ballisto_link::telecommand::Command as Tc;
    if sequence > 0x3FFF {
        return Err(format!("--sequence {sequence}: at most 16383 (14 bits)").into());
    }
    let one = |c: Tc, channels: Option<usize>| tc::frame(&c, sequence, ack, channels);
    let frames = match command {
        TcCommand::Mode { mode } => vec![one(
            Tc::SetMode(match mode {
                ModeArg::Standby => ballisto_link::Mode::Standby,
                ModeArg::Operate => ballisto_link::Mode::Operate,
            }),
            None,
        )?],
        TcCommand::Model { model } => vec![one(Tc::SetModel(model.into()), None)?],
        TcCommand::Hint { omega } => {
            let w = parse_vec3(&omega).map_err(|e| e.replace("--initial-omega", "hint"))?;
            vec![one(Tc::SetHint(w.map(|v| v as f32)), None)?]
        }
        TcCommand::Exclude {
            channel,
            arrangement,
        } => {
            let (c, channels) = tc::channel_index(&channel, arrangement.as_deref())?;
            vec![one(Tc::Exclude(c), channels)?]
        }
        TcCommand::Include {
            channel,
            arrangement,
        } => {
            let (c, channels) = tc::channel_index(&channel, arrangement.as_deref())?;
            vec![one(Tc::Include(c), channels)?]
        }
        TcCommand::LoadArrangement { arrangement } => {
            let (data, warnings) = tc::arrangement_data(&arrangement)?;
            for w in warnings {
                eprintln!("ballisto tc: WARNING: {w}");
            }
            vec![one(Tc::LoadArrangement(&data), None)?]
        }
        TcCommand::Rates {
            motion_every,
            housekeeping_every,
        } => vec![one(
            Tc::SetRates {
                motion_every,
                housekeeping_every,
            },
            None,
        )?],
        TcCommand::Identify {
            period_ms,
            window,
            inertia,
        } => {
            let ms = (window * 1000.0).round();
            if !(ms >= 1.0 && ms <= f64::from(u32::MAX)) {
                return Err(format!("--window {window}: not a window length in seconds").into());
            }
            vec![one(
                Tc::StartIdentification {
                    period_ms,
                    window_ms: ms as u32,
                    inertia: inertia.map(|j| j.map(|v| v as f32)),
                },
                None,
            )?]
        }
        TcCommand::Reference { file, from, to } => {
            let batches = tc::reference_batches(&file, from, to)?;
            say.detail(format!(
                "ballisto tc: {}: {} packets of reference points",
                file.display(),
                batches.len()
            ));
            batches
                .iter()
                .enumerate()
                .map(|(i, data)| {
                    tc::frame(
                        &Tc::ReferenceRate(data),
                        sequence.wrapping_add(i as u16) & 0x3FFF,
                        ack,
                        None,
                    )
                })
                .collect::<Result<_, _>>()?
        }
        TcCommand::ReportIdentification => vec![one(Tc::ReportIdentification, None)?],
        TcCommand::Commit { solution } => {
            vec![one(Tc::CommitCalibration { solution }, None)?]
        }
        TcCommand::Housekeeping => vec![one(Tc::ReportHousekeeping, None)?],
        TcCommand::SetTime { seconds } => {
            vec![one(Tc::SetTime(tc::time_ticks(seconds)?), None)?]
        }
        TcCommand::Ping => vec![one(Tc::AreYouAlive, None)?],
    };
    Ok(frames)
}

/// `--uplink SECONDS:FILE`: the scenario time and the file.
fn parse_uplink(arg: &str) -> Result<(f64, &Path), String> {
    let (at, file) = arg
        .split_once(':')
        .ok_or_else(|| format!("--uplink \"{arg}\": expected SECONDS:FILE"))?;
    let at: f64 = at
        .trim()
        .parse()
        .ok()
        .filter(|t: &f64| t.is_finite() && *t >= 0.0)
        .ok_or_else(|| format!("--uplink \"{arg}\": \"{at}\" is not a time in seconds"))?;
    Ok((at, Path::new(file)))
}

/// An uplink file's bytes, to be sent at scenario time `at`.
fn read_uplink(at: f64, file: &Path) -> Result<(f64, Vec<u8>), String> {
    let bytes = ballisto::output::read_input(file)?;
    if bytes.is_empty() {
        return Err(format!("{}: empty: no telecommand to send", file.display()));
    }
    Ok((at, bytes))
}

/// `sim`'s summary (stderr: its results are the files).
fn print_sim(
    say: Say,
    scenario: &str,
    sc: &hal_sim::scenario::Scenario,
    r: &ballisto::sim::SimReport,
    identify: bool,
    started: std::time::Instant,
) {
    say.info(format!("ballisto sim: {scenario}: {}", sc.description));
    say.info(format!(
        "  {} sample sets at {} Hz ({} s), {} parts, {} channels, {:.2} s wall time",
        r.samples,
        sc.rate,
        sc.duration,
        r.parts.len(),
        r.channels,
        started.elapsed().as_secs_f64()
    ));
    for (name, bytes, busy) in &r.buses {
        say.info(format!(
            "  bus {name}: {bytes} bytes, {:.1} us busy per sample set",
            busy / r.samples as f64 * 1e6
        ));
    }
    for p in r.parts.iter().filter(|p| p.errors > 0) {
        say.info(format!(
            "  part {}: {} of {} reads failed (empty fields)",
            p.name, p.errors, p.reads
        ));
    }
    if !sc.faults.is_empty() {
        say.info(format!("  faults scheduled: {}", sc.faults.len()));
    }
    if let Some(fw) = &r.firmware {
        print_firmware(say, sc, fw);
    }
    for line in &r.identification {
        // The first boot's identification (`--identify`, the calibration it booted on first),
        // or the stored calibration booted on (`--calibration`).
        let what = if identify { "identify" } else { "calibration" };
        say.info(format!("  {what}: {line}"));
    }
    if let Some(c) = &r.errors {
        say.info(format!(
            "  RMS error  sigma0 {:.3e} m/s^2  domega {:.3e} rad/s^2  omega {:.3e} rad/s  A {:.3e} 1/s^2",
            c.sigma0, c.domega, c.omega, c.field
        ));
        for (bit, name) in FLAG_NAMES {
            let c = r.flag_counts[bit.trailing_zeros() as usize];
            if c > 0 {
                say.info(format!("  {c:>8} rows flagged {name} ({bit})"));
            }
        }
    }
    for f in &r.files {
        say.info(format!("  wrote {}", f.display()));
    }
}

/// The firmware's own counts and figures.
fn print_firmware(
    say: Say,
    sc: &hal_sim::scenario::Scenario,
    fw: &hal_sim::firmware_host::FirmwareReport,
) {
    let l = &fw.sampling;
    say.info(format!(
        "  firmware: {} sets sampled, {} instants skipped (overrun), {} sets dropped (queue full), {} SYNC errors",
        l.sets, l.skipped, l.dropped, l.sync_errors
    ));
    for ((p, h), u) in sc.parts.iter().zip(&fw.parts).zip(&fw.clock_uncertainty) {
        let clock = match u {
            Some(u) => format!(", conversion time known to +-{:.1} us", u * 1e6),
            None => String::new(),
        };
        say.info(format!(
            "  part {}: {} reads, {} bus errors, {} implausible, {} sets missed, {} resyncs, {} failed starts{clock}",
            p.name, h.reads, h.bus_errors, h.implausible, h.missed, h.resyncs, h.failed_starts
        ));
    }
    say.detail(format!(
        "  task futures {} + {} + {} bytes (sampling, application, uplink), application state {} bytes (estimation {})",
        fw.task_sizes.0,
        fw.task_sizes.1,
        fw.task_sizes.2,
        fw.app_size,
        fw.estimation_size
    ));
    let h = &fw.housekeeping;
    say.info(format!(
        "  telemetry: {} bytes in telemetry.bin ({:.0} bytes/s), {} estimates, {} telecommands accepted, {} refused, {} packets lost",
        fw.telemetry_bytes,
        fw.telemetry_bytes as f64 / (f64::from(l.sets.max(1)) / sc.rate),
        h.estimates,
        h.tc_accepted,
        h.tc_rejected,
        h.tm_lost
    ));
}

/// `-v`'s log: the library's `log::debug!` lines on stderr (the calibration's alternations).
struct StderrLog;

impl log::Log for StderrLog {
    fn enabled(&self, metadata: &log::Metadata) -> bool {
        metadata.target().starts_with("ballisto")
    }

    fn log(&self, record: &log::Record) {
        if self.enabled(record.metadata()) {
            eprintln!("  [{}] {}", record.target(), record.args());
        }
    }

    fn flush(&self) {}
}

static STDERR_LOG: StderrLog = StderrLog;

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => e.exit(),
        Err(e) if e.kind() == clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            // Bare `ballisto` (or `ballisto tc`): the help as clap lays it out, on stderr.
            eprint!("{}", e.render());
            return ExitCode::from(ballisto::exit::USAGE);
        }
        Err(e) => {
            // docs/formats.md: an error is one sentence on stderr (clap's own spans lines).
            eprintln!("ballisto: {}", one_line(&e.to_string()));
            return ExitCode::from(ballisto::exit::USAGE);
        }
    };
    if cli.verbose && log::set_logger(&STDERR_LOG).is_ok() {
        log::set_max_level(log::LevelFilter::Debug);
    }
    match run(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("ballisto: {e}");
            ExitCode::from(ballisto::exit::code_of(e.as_ref()))
        }
    }
}

/// A command-line error of clap's as one line: its lines joined, without the pointer to
/// `--help` (e.g. "invalid value 'x' for '--model <MODEL>' [possible values: general,
/// free-float]").
fn one_line(text: &str) -> String {
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with("For more information"))
        .map(|l| l.strip_prefix("error: ").unwrap_or(l))
        .collect::<Vec<_>>()
        .join(" ")
}
