//! The command line: the subcommands, their options and the parsers of their values.

use std::path::PathBuf;

use ballisto::calibrate::reference_rate::Validity;
use clap::{Args, Subcommand, ValueEnum};
use estimator_core::Model;

pub use super::estimate::{CalibrateArgs, ComArgs, EstimateArgs};
pub use super::sim::SimArgs;
pub use super::tc::TcArgs;
pub use super::telemetry::{CaptureArgs, CompareArgs, DecodeArgs};

pub const FLAGS_HELP: &str = "The flags column of estimates.csv is a bit set:
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

pub const SIM_HELP: &str = "Named scenarios:
  tetra-orbit         4 x ADXL355 on a tetrahedron (SPI, external sync), torque-free tumble in orbit
  nine-channel        9-channel ballistometer from 6 x ADXL355, free-float tumble
  ground-spin-mixed   2 x ADXL355 (SPI) + 2 x LIS3DH (I2C, own clocks), ground turntable spin-up
  tetra-orbit-faults  tetra-orbit with a stuck part, a bias jump, a dead part and corrupted bytes
  ground-calibration  6 parts with datasheet errors (4 x ADXL355, 2 x LIS3DH), ground calibration schedule, reference gyro
  orbit-identify      4 x ADXL355 with datasheet errors, tumble with attitude-control torque in orbit, reference gyro at 20 Hz
  ground-thermal      4 x ADXL355 with datasheet errors and temperature coefficients, calibration schedule three times in a chamber ramping -10 to +50 degC, reference gyro
  tetra-orbit-thermal the same parts tumbling in orbit for 3 h through a +-20 degC orbit thermal cycle (boot on ground-thermal's calibration with --calibration; --identify tracks the coefficients in flight)
The scenario file format: hal-sim/scenarios/README.md.";

pub const DECODE_HELP: &str =
    "Packet layouts: docs/telemetry.md. Exit status: 0 all packets intact and
contiguous, 1 an input is wrong (unreadable, empty, an output that is an input), 2 the command
line is wrong, 3 damaged frames or sequence gaps (listed on stderr; the good packets are written).";

pub const TC_HELP: &str =
    "Each command is checked by the unit's own acceptance before it is written: a command
the unit would refuse is an error, and nothing is written. Frames are COBS between zero
delimiters (docs/telemetry.md), as the unit reads its command link; several commands in one
run get consecutive sequence counts from --sequence. Binary frames are not written to a
terminal: name --out FILE, redirect, or use --hex. Example:
  ballisto tc --sequence 7 exclude u1.x --arrangement arrangement.toml --out exclude.bin";

/// Which rows of a reference rate file are valid, beyond its own flag columns.
#[derive(Args, Clone, Debug, Default)]
pub struct ReferenceValidity {
    /// Flags beside the reference (CSV: t with the reference's times, then columns named
    /// `valid` — 0 leaves the row out — or ending in `_saturated` — not 0 leaves it out), e.g.
    /// reference_flags.csv.
    #[arg(long, value_name = "FLAGS.csv", requires = "reference")]
    pub reference_flags: Option<PathBuf>,
    /// The reference gyro's range, rad/s: rows with an axis at 99 % of it or beyond are
    /// clipped readings and left out.
    #[arg(long, value_name = "RAD_S", requires = "reference", allow_negative_numbers = true, value_parser = positive_rate)]
    pub reference_range: Option<f64>,
}

/// A gyro's range: a positive number of rad/s.
pub fn positive_rate(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(r) if r.is_finite() && r > 0.0 => Ok(r),
        _ => Err(format!(
            "\"{s}\": the gyro's range must be a positive number of rad/s"
        )),
    }
}

/// A relative deviation: a number above 0 and below 1.
/// A finite number (an option's value: NaN or infinity would make every result NaN).
pub fn finite(s: &str) -> Result<f64, String> {
    let x: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("\"{s}\" is not a number"))?;
    if !x.is_finite() {
        return Err(format!("\"{s}\" is not a finite number"));
    }
    Ok(x)
}

/// A finite duration above zero, in seconds.
pub fn positive_seconds(s: &str) -> Result<f64, String> {
    match finite(s)? {
        x if x > 0.0 => Ok(x),
        _ => Err(format!("\"{s}\" is not a duration above 0 s")),
    }
}

/// A finite duration of zero or more seconds.
pub fn non_negative_seconds(s: &str) -> Result<f64, String> {
    match finite(s)? {
        x if x >= 0.0 => Ok(x),
        _ => Err(format!("\"{s}\" is not a duration of 0 s or more")),
    }
}

/// A time, or `inf` for no end.
pub fn time_or_inf(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if x == f64::INFINITY => Ok(x),
        _ => finite(s),
    }
}

/// `--inertia`: three principal moments or the six components of a symmetric tensor.
pub fn inertia(s: &str) -> Result<[f64; 6], String> {
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

pub fn relative_sd(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(r) if r > 0.0 && r < 1.0 => Ok(r),
        _ => Err(format!(
            "\"{s}\": a relative deviation is a number above 0 and below 1 (0.005 for 0.5 %)"
        )),
    }
}

/// A probability strictly between 0 and 1.
pub fn probability(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(p) if p > 0.0 && p < 1.0 => Ok(p),
        _ => Err(format!(
            "\"{s}\": a probability is a number above 0 and below 1 (0.001 for one row in a thousand)"
        )),
    }
}

/// Three alert limits `S0,DW,W`: positive numbers (`inf` for none).
pub fn alert_limits(s: &str) -> Result<[f64; 3], String> {
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
    pub fn validity(&self) -> Validity<'_> {
        Validity {
            flags: self.reference_flags.as_deref(),
            range: self.reference_range,
        }
    }
}

/// `--model` (docs/formats.md).
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ModelArg {
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
pub enum PrecisionArg {
    /// As on the target.
    F32,
    /// The host's.
    F64,
}

/// `--align` (with `sim --firmware`).
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum AlignArg {
    /// Timestamped FIFO samples interpolated to the instants.
    Interpolate,
    /// The latest output as if sampled at the instant (the unaligned reference).
    Latest,
}

/// The subcommands.
#[derive(Subcommand)]
pub enum Command {
    /// Estimate σ0, Ω′, Ω and A for every row of a samples file.
    #[command(after_help = FLAGS_HELP)]
    Estimate(EstimateArgs),
    /// Simulate a scenario: parts read through their simulated buses; writes arrangement.toml,
    /// samples.csv and truth.csv (with --estimate also estimates.csv and estimates.png).
    #[command(after_help = SIM_HELP)]
    Sim(SimArgs),
    /// Decode a telemetry stream (COBS-framed PUS packets, as `sim --firmware` writes in
    /// telemetry.bin or the unit sends on its link): motion reports to an estimates file,
    /// housekeeping, events and verification reports to readable text. Every frame's CRC
    /// and the sequence count are checked; exit status 3 if anything was damaged or lost
    /// (the good packets are still written).
    #[command(after_help = DECODE_HELP)]
    Decode(DecodeArgs),
    /// Follow the unit's link live from a serial port (or a pseudo-terminal, or a file that
    /// grows): decoded as it arrives, every motion report to the estimates file and every
    /// other report to the log as it comes, a status line on a terminal; a port unplugged is
    /// waited for, a reset of the unit starts a new boot's rows; telecommand frames can be sent
    /// first. Ends after --idle seconds without a byte, or on Ctrl-C (the files then hold
    /// everything received).
    Capture(CaptureArgs),
    /// Identify every channel's position, axis, scale and bias from a record of static poses
    /// and motion (paper §6); writes a calibrated arrangement file with standard deviations
    /// and the frame's uncertainty (frame_*_sd). What the record does not determine keeps its
    /// nominal value and is named; a record that determines fewer than half the parameters
    /// is refused.
    Calibrate(CalibrateArgs),
    /// Where the centre of mass is (paper eq. 12's ρ: the instrument origin seen from the
    /// centre of mass, which is at −ρ) over sliding windows: t, rho_x.., f_x.., sd_rho_x..
    /// (docs/formats.md); empty fields where a window's rotation cannot separate ρ from f.
    Com(ComArgs),
    /// RMS errors of an estimates file against a truth file (matched by column name and t);
    /// with --reference, its Ω against a rate reference (a gyro: RMS and median per axis, on
    /// the reference's valid rows).
    Compare(CompareArgs),
    /// Build telecommands for the unit (PUS packets, COBS-framed as on its command link):
    /// to a file, or stdout.
    #[command(after_help = TC_HELP)]
    Tc(TcArgs),
    /// Shell completions for ballisto on stdout, e.g. `ballisto completions bash >
    /// ~/.local/share/bash-completion/completions/ballisto`.
    Completions {
        /// The shell.
        #[arg(value_enum)]
        shell: clap_complete::Shell,
    },
    /// The manual pages (roff): ballisto.1 and one per subcommand (ballisto-estimate.1, …),
    /// into a directory, e.g. `ballisto man --out ~/.local/share/man/man1`.
    Man {
        /// The directory to write them into (made if absent).
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
    },
}

/// The telecommands of `ballisto tc` (docs/telemetry.md, "Telecommands").
#[derive(Subcommand)]
pub enum TcCommand {
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
        #[arg(long, value_name = "SECONDS", value_parser = positive_seconds)]
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
        #[arg(long, value_name = "S", default_value = "0", allow_hyphen_values = true, value_parser = finite)]
        from: f64,
        /// Last time to send, s.
        #[arg(long, value_name = "S", default_value = "inf", allow_hyphen_values = true, value_parser = time_or_inf)]
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
        #[arg(value_name = "SECONDS", value_parser = finite)]
        seconds: f64,
    },
    /// TC[17,1]: are you alive.
    Ping,
}

/// `tc mode`.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ModeArg {
    /// Sampling and housekeeping only.
    Standby,
    /// Estimating at sample rate.
    Operate,
}

pub fn parse_vec3(s: &str) -> Result<[f64; 3], String> {
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

pub fn parse_fit(s: &str) -> Result<ballisto::calibrate::fit::FitSet, String> {
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
pub struct Say {
    pub quiet: bool,
    pub verbose: bool,
}

impl Say {
    /// A summary or notice: left out with `--quiet`.
    pub fn info(self, text: impl std::fmt::Display) {
        if !self.quiet {
            eprintln!("{text}");
        }
    }

    /// A detail: only with `--verbose`.
    pub fn detail(self, text: impl std::fmt::Display) {
        if self.verbose {
            eprintln!("{text}");
        }
    }
}

/// Problems listed without `--verbose`.
pub const PROBLEMS_LISTED: usize = 10;
