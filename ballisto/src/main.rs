//! `ballisto`: the host binary (interfaces.md).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use ballisto::estimate::{estimate_files, EstimateJob, Precision, FLAG_NAMES};
use ballisto_fw::config::Alignment;
use clap::{Parser, Subcommand, ValueEnum};
use estimator_core::Model;

const FLAGS_HELP: &str = "The flags column of estimates.csv is a bit set:
  1   sign unresolved: Ω may be −Ω (steady spin, no hint yet)
  2   no real solution for a: least-squares fallback used
  4   ill-conditioned: the a solve is nearly singular (rate near zero or at a frame plane)
  8   channel(s) excluded (which: the excluded column, bit i = the file's i-th channel)
  16  branch ambiguous: another branch is nearly as consistent
  32  input invalid: a reading was missing (empty field); the row is the prediction
  64  residual high: χ² above its 99.9 % point, or (model G) the fault monitor's window
      inconsistent with no part isolated (fault suspected)
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
The scenario file format: hal-sim/scenarios/README.md.";

const DECODE_HELP: &str = "Packet layouts: docs/telemetry.md. Exit status: 0 all packets intact and
contiguous, 1 error (file), 2 damaged frames or sequence gaps (listed on stderr).";

/// `--model` (interfaces.md).
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
    about = "Ballistometer host tools: σ0, Ω′ and Ω from accelerometers alone"
)]
struct Cli {
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
        /// Samples file (CSV: t and one column per channel).
        #[arg(long, value_name = "FILE.csv")]
        samples: PathBuf,
        /// Estimates file to write (CSV: the interfaces.md columns, then chi2, dof, branches,
        /// frame, the standard deviations — with the arrangement's frame uncertainty when it
        /// has one — epsilon, and the gravity gradient gamma_* with sd_gamma_*, model G only).
        #[arg(long, value_name = "FILE.csv")]
        out: PathBuf,
        /// Model: general (9-column, N >= 12) or free-float (N >= 9); default: the file's, else general.
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
        /// gyro sent by telecommand, commit, reset, and run the scenario again on the stored
        /// calibration (the first boot's telemetry in telemetry-identify.bin).
        #[arg(long, requires = "firmware")]
        identify: bool,
    },
    /// Decode a telemetry stream (COBS-framed PUS packets, as `sim --firmware` writes in
    /// telemetry.bin or the unit sends on its link): motion reports to an estimates file,
    /// housekeeping, events and verification reports to readable text. Every frame's CRC
    /// and the sequence count are checked; exit status 2 if anything was damaged or lost
    /// (the good packets are still written).
    #[command(after_help = DECODE_HELP)]
    Decode {
        /// The raw stream.
        #[arg(value_name = "FILE")]
        input: PathBuf,
        /// Estimates file to write (CSV: the estimates columns, then k, missing_parts,
        /// excluded_parts, excluded_channels).
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
        /// Also write the stream's last identification solution (TM[200,128–129], issue 16)
        /// as an arrangement file over the channel names of --arrangement.
        #[arg(long, value_name = "FILE.toml", requires = "arrangement")]
        calibration: Option<PathBuf>,
        /// The nominal arrangement the unit runs (its channel names), for --calibration.
        #[arg(long, value_name = "FILE.toml")]
        arrangement: Option<PathBuf>,
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
        /// it Ω comes from the estimator (self-calibration).
        #[arg(long, value_name = "REFERENCE.csv")]
        reference: Option<PathBuf>,
        /// What may change: a comma-separated subset of bias, scale, axis, position.
        #[arg(long, value_name = "LIST", default_value = "bias,scale,axis,position")]
        fit: String,
        /// Model of the estimator in self-calibration, and the one written into the file;
        /// default: the file's, else general.
        #[arg(long, value_enum)]
        model: Option<ModelArg>,
        /// A report for people (Markdown): per channel the identified values, their standard
        /// deviations and the residual before and after; with REPORT.png beside it (the
        /// residuals per sample and per channel, before and after).
        #[arg(long, value_name = "REPORT.md")]
        report: Option<PathBuf>,
    },
    /// The centre of mass relative to the instrument origin (paper eq. 12) over sliding
    /// windows: t, rho_x.., f_x.., sd_rho_x.. (interfaces.md); empty fields where a window's
    /// rotation cannot separate ρ from f.
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
    /// RMS errors of an estimates file against a truth file (matched by column name and t).
    Compare {
        /// Truth file (CSV, as written by the simulator).
        truth: PathBuf,
        /// Estimates file (CSV, as written by `ballisto estimate`).
        estimates: PathBuf,
    },
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

fn run(cli: Cli) -> Result<ExitCode, Box<dyn std::error::Error>> {
    match cli.command {
        Command::Estimate {
            arrangement,
            samples,
            out,
            model,
            initial_omega,
            raw,
            precision,
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
                    ..Default::default()
                },
                precision,
            };
            let s = estimate_files(&job)?;
            eprintln!(
                "ballisto estimate: {} rows, {} channels, model {} -> {}",
                s.rows,
                s.channels,
                s.model.map(|m| m.name()).unwrap_or("?"),
                out.display()
            );
            for (bit, name) in FLAG_NAMES {
                let c = s.flag_counts[bit.trailing_zeros() as usize];
                if c > 0 {
                    eprintln!("  {c:>8} rows flagged {name} ({bit})");
                }
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Calibrate {
            arrangement,
            samples,
            out,
            reference,
            fit,
            model,
            report,
        } => {
            let fit = parse_fit(&fit)?;
            let model = model.map(Model::from);
            let s = ballisto::calibrate::calibrate_files(&ballisto::calibrate::CalibrateJob {
                arrangement: &arrangement,
                samples: &samples,
                out: &out,
                reference: reference.as_deref(),
                fit,
                model,
                report: report.as_deref(),
            })?;
            eprintln!(
                "ballisto calibrate: {} static poses, {} samples in motion, {} alternations, model {} -> {}",
                s.poses,
                s.motion,
                s.identification.iterations,
                s.model.name(),
                out.display()
            );
            for w in &s.warnings {
                eprintln!("  WARNING: {w}");
            }
            for c in &s.identification.conventions {
                eprintln!("  held by convention: {c}");
            }
            for (name, c) in s.names.iter().zip(s.identification.channels.iter()) {
                if !c.held.is_empty() {
                    eprintln!(
                        "  {name}: not identified (kept nominal): {}",
                        c.held.join("; ")
                    );
                }
            }
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
            eprintln!(
                "ballisto com: {} windows of {window} s ({} could not separate rho from f), model {} -> {}",
                s.windows,
                s.undetermined,
                s.model.map(|m| m.name()).unwrap_or("?"),
                out.display()
            );
            Ok(ExitCode::SUCCESS)
        }
        Command::Sim {
            scenario,
            out,
            estimate,
            firmware,
            align,
            identify,
        } => {
            let alignment = match align {
                AlignArg::Interpolate => Alignment::Interpolate,
                AlignArg::Latest => Alignment::Latest,
            };
            let sc = hal_sim::scenario::Scenario::load(&scenario)?;
            let started = std::time::Instant::now();
            let r = ballisto::sim::run_sim(&ballisto::sim::SimJob {
                scenario: &sc,
                out: &out,
                estimate,
                progress: true,
                firmware: firmware.then_some(alignment),
                identify,
            })?;
            println!("ballisto sim: {scenario}: {}", sc.description);
            println!(
                "  {} sample sets at {} Hz ({} s), {} parts, {} channels, {:.2} s wall time",
                r.samples,
                sc.rate,
                sc.duration,
                r.parts.len(),
                r.channels,
                started.elapsed().as_secs_f64()
            );
            for (name, bytes, busy) in &r.buses {
                println!(
                    "  bus {name}: {bytes} bytes, {:.1} us busy per sample set",
                    busy / r.samples as f64 * 1e6
                );
            }
            for p in r.parts.iter().filter(|p| p.errors > 0) {
                println!(
                    "  part {}: {} of {} reads failed (empty fields)",
                    p.name, p.errors, p.reads
                );
            }
            if !sc.faults.is_empty() {
                println!("  faults scheduled: {}", sc.faults.len());
            }
            if let Some(fw) = &r.firmware {
                print_firmware(&sc, fw);
            }
            for line in &r.identification {
                println!("  identify: {line}");
            }
            if let Some(c) = &r.errors {
                println!(
                    "  RMS error  sigma0 {:.3e} m/s^2  domega {:.3e} rad/s^2  omega {:.3e} rad/s  A {:.3e} 1/s^2",
                    c.sigma0, c.domega, c.omega, c.field
                );
                for (bit, name) in FLAG_NAMES {
                    let c = r.flag_counts[bit.trailing_zeros() as usize];
                    if c > 0 {
                        println!("  {c:>8} rows flagged {name} ({bit})");
                    }
                }
            }
            for f in &r.files {
                println!("  wrote {}", f.display());
            }
            Ok(ExitCode::SUCCESS)
        }
        Command::Decode {
            input,
            out,
            log,
            time_offset,
            calibration,
            arrangement,
        } => {
            // Every output checked against every input before anything is written.
            let outputs: Vec<&Path> = std::iter::once(out.as_path())
                .chain(log.as_deref())
                .chain(calibration.as_deref())
                .collect();
            let inputs: Vec<&Path> = std::iter::once(input.as_path())
                .chain(arrangement.as_deref())
                .collect();
            ballisto::output::check_distinct(&outputs, &inputs)?;
            let (stream, rows, text) =
                ballisto::decode::decode_file(&input, &out, log.as_deref(), time_offset)?;
            if let (Some(cal), Some(nominal)) = (&calibration, &arrangement) {
                let file = ballisto::decode::identified_arrangement(&stream, &input, nominal)?;
                ballisto::output::write(cal, file.as_bytes())?;
                eprintln!("{}: identification solution written", cal.display());
            }
            if log.is_none() {
                print!("{text}");
            }
            eprintln!(
                "{}: {} packets, {rows} motion reports to {}, {} problems",
                input.display(),
                stream.packets.len(),
                out.display(),
                stream.problems.len()
            );
            for p in &stream.problems {
                eprintln!("ballisto: {}: {p}", input.display());
            }
            Ok(if stream.problems.is_empty() {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(2)
            })
        }
        Command::Compare { truth, estimates } => {
            let c = ballisto::compare::compare(&truth, &estimates)?;
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
    }
}

/// The firmware's own counts and figures.
fn print_firmware(sc: &hal_sim::scenario::Scenario, fw: &hal_sim::firmware_host::FirmwareReport) {
    let l = &fw.sampling;
    println!(
        "  firmware: {} sets sampled, {} instants skipped (overrun), {} sets dropped (queue full), {} SYNC errors",
        l.sets, l.skipped, l.dropped, l.sync_errors
    );
    for ((p, h), u) in sc.parts.iter().zip(&fw.parts).zip(&fw.clock_uncertainty) {
        let clock = match u {
            Some(u) => format!(", conversion time known to +-{:.1} us", u * 1e6),
            None => String::new(),
        };
        println!(
            "  part {}: {} reads, {} bus errors, {} implausible, {} sets missed, {} resyncs, {} failed starts{clock}",
            p.name, h.reads, h.bus_errors, h.implausible, h.missed, h.resyncs, h.failed_starts
        );
    }
    println!(
        "  task futures {} + {} + {} bytes (sampling, application, uplink), application state {} bytes (estimation {}); host CPU per set: cargo bench -p hal-sim --bench firmware_per_set",
        fw.task_sizes.0,
        fw.task_sizes.1,
        fw.task_sizes.2,
        fw.app_size,
        fw.estimation_size
    );
    let h = &fw.housekeeping;
    println!(
        "  telemetry: {} bytes in telemetry.bin ({:.0} bytes/s), {} estimates, {} telecommands accepted, {} refused, {} packets lost",
        fw.telemetry_bytes,
        fw.telemetry_bytes as f64 / (f64::from(l.sets.max(1)) / sc.rate),
        h.estimates,
        h.tc_accepted,
        h.tc_rejected,
        h.tm_lost
    );
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => e.exit(),
        Err(e) => {
            // interfaces.md: an error is one sentence on stderr (clap's own spans lines).
            eprintln!("ballisto: {}", one_line(&e.to_string()));
            return ExitCode::from(2);
        }
    };
    match run(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("ballisto: {e}");
            ExitCode::FAILURE
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
