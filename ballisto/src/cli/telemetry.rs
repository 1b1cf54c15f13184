//! `ballisto decode` and `compare`: a telemetry stream decoded, estimates against a truth or a reference.

use std::error::Error;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use ballisto::decode::{DecodeJob, LogTo};
use clap::Args;

use super::args::*;

/// `--time-offset`, of `decode` and `capture`.
#[derive(Args)]
pub struct TimeOffset {
    /// Seconds added to the on-board time (time since boot) of every packet.
    #[arg(
        long,
        value_name = "S",
        default_value = "0",
        allow_hyphen_values = true,
        value_parser = finite
    )]
    pub time_offset: f64,
}

/// The arguments of `ballisto decode`.
#[derive(Args)]
pub struct DecodeArgs {
    /// The raw stream; `-` reads stdin.
    #[arg(value_name = "FILE")]
    pub input: PathBuf,
    /// Estimates file to write, `-` for stdout (CSV: the estimates columns, then k,
    /// missing_parts, excluded_parts, excluded_channels).
    #[arg(long, value_name = "FILE.csv")]
    pub out: PathBuf,
    /// Write housekeeping, events and verification reports here (default: stdout).
    #[arg(long, value_name = "FILE.txt")]
    pub log: Option<PathBuf>,
    #[command(flatten)]
    pub offset: TimeOffset,
    /// Also write the stream's last identification solution (TM[200,128–129])
    /// as an arrangement file over the channel names of --arrangement.
    #[arg(long, value_name = "FILE.toml", requires = "arrangement")]
    pub calibration: Option<PathBuf>,
    /// The nominal arrangement the unit runs (its channel names), for --calibration.
    #[arg(long, value_name = "FILE.toml")]
    pub arrangement: Option<PathBuf>,
    /// Telecommands sent (frames as `ballisto tc` writes them; repeatable): each
    /// verification report names the command it answers, and a command with no report is
    /// listed.
    #[arg(long, value_name = "TC.bin")]
    pub commands: Vec<PathBuf>,
}

/// The arguments of `ballisto capture`.
#[derive(Args)]
pub struct CaptureArgs {
    /// The serial port (e.g. /dev/ttyUSB0; a pseudo-terminal such as QEMU's `-serial pty`),
    /// or a file that grows.
    #[arg(long, value_name = "PORT")]
    pub port: PathBuf,
    /// The port's baud rate (8N1; the STM32H743 board's link runs at 921 600).
    #[arg(long, value_name = "BAUD", default_value = "921600")]
    pub baud: u32,
    /// Estimates file to write as the reports arrive (must not exist).
    #[arg(long, value_name = "FILE.csv")]
    pub out: PathBuf,
    /// Housekeeping, events, verification reports and problems, as they arrive (must not
    /// exist).
    #[arg(long, value_name = "FILE.txt")]
    pub log: PathBuf,
    /// Also keep the raw bytes received (must not exist), for `ballisto decode` later.
    #[arg(long, value_name = "FILE.bin")]
    pub raw: Option<PathBuf>,
    #[command(flatten)]
    pub offset: TimeOffset,
    /// End after this many seconds without a byte (0: at a file's end); without it, run
    /// until interrupted.
    #[arg(long, value_name = "SECONDS", value_parser = non_negative_seconds)]
    pub idle: Option<f64>,
    /// Telecommand frames to send on the port once it is open (`ballisto tc`'s files;
    /// repeatable, sent in order).
    #[arg(long, value_name = "TC.bin")]
    pub send: Vec<PathBuf>,
}

/// `ballisto capture`.
pub fn capture(args: CaptureArgs, say: Say) -> Result<ExitCode, Box<dyn Error>> {
    for p in [Some(&args.out), Some(&args.log), args.raw.as_ref()]
        .into_iter()
        .flatten()
    {
        if ballisto::output::is_std(p) {
            return Err(Box::new(ballisto::exit::Usage(
                "capture writes files as the reports arrive: name --out, --log and --raw files"
                    .into(),
            )));
        }
    }
    let send = args
        .send
        .iter()
        .map(|f| ballisto::output::read_input(f))
        .collect::<Result<Vec<_>, _>>()?;
    let s = ballisto::capture::capture(&ballisto::capture::CaptureJob {
        port: &args.port,
        baud: args.baud,
        out: &args.out,
        log: &args.log,
        raw: args.raw.as_deref(),
        time_offset: args.offset.time_offset,
        idle: args.idle,
        send,
        progress: !say.quiet,
        on_open: &|| say.info(format!("{}: open, following the link", args.port.display())),
    })?;
    say.info(format!(
        "{}: {} bytes, {} packets, {} motion reports to {} ({} flagged), {} boots, {} problems, port reopened {} times",
        args.port.display(),
        s.bytes,
        s.packets,
        s.rows,
        args.out.display(),
        s.flagged,
        s.boots,
        s.problems,
        s.reopened
    ));
    Ok(if s.problems > 0 {
        ExitCode::from(ballisto::exit::DAMAGED_TELEMETRY)
    } else {
        ExitCode::SUCCESS
    })
}

/// `ballisto decode`.
pub fn decode(args: DecodeArgs, say: Say) -> Result<ExitCode, Box<dyn Error>> {
    let DecodeArgs {
        input,
        out,
        log,
        offset: TimeOffset { time_offset },
        calibration,
        arrangement,
        commands,
    } = args;
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
    let to_stdout = ballisto::output::is_std(&out);
    let log_to = match (&log, to_stdout, say.quiet) {
        (Some(path), _, _) => LogTo::File(path),
        // The estimates own stdout: the log goes with the diagnostics.
        (None, true, false) => LogTo::Stderr,
        (None, true, true) => LogTo::Nowhere,
        (None, false, _) => LogTo::Stdout,
    };
    let listed = if say.verbose {
        usize::MAX
    } else {
        PROBLEMS_LISTED
    };
    let found = ballisto::decode::decode_file(&DecodeJob {
        input: &input,
        out: &out,
        log: log_to,
        time_offset,
        sent: &sent,
        keep_problems: listed,
        progress: !say.quiet,
    })?;
    if let (Some(cal), Some(nominal)) = (&calibration, &arrangement) {
        let file =
            ballisto::decode::identified_arrangement(&found.identification, &input, nominal)?;
        ballisto::output::write(cal, file.as_bytes())?;
        say.info(format!(
            "{}: identification solution written",
            cal.display()
        ));
    }
    say.info(format!(
        "{}: {} packets, {} motion reports to {}, {} problems",
        input.display(),
        found.packets,
        found.rows,
        out.display(),
        found.problems
    ));
    for p in &found.listed {
        eprintln!("ballisto: {}: {p}", input.display());
    }
    let more = found.problems - found.listed.len() as u64;
    if more > 0 {
        eprintln!(
            "ballisto: {}: {more} more problems (-v lists them all; the log has every one)",
            input.display(),
        );
    }
    Ok(if found.problems == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(ballisto::exit::DAMAGED_TELEMETRY)
    })
}

/// The arguments of `ballisto compare`.
#[derive(Args)]
pub struct CompareArgs {
    /// TRUTH.csv ESTIMATES.csv (the truth as the simulator writes it, the estimates as
    /// `ballisto estimate` does); with --reference, ESTIMATES.csv alone.
    #[arg(value_name = "FILES", num_args = 1..=2, required = true)]
    pub files: Vec<PathBuf>,
    /// Reference rate file (CSV: t, omega_x, omega_y, omega_z; rad/s, body frame) to score
    /// Ω against, in place of a truth file.
    #[arg(long, value_name = "REFERENCE.csv")]
    pub reference: Option<PathBuf>,
    #[command(flatten)]
    pub validity: ReferenceValidity,
}

/// `ballisto compare`.
pub fn compare(args: CompareArgs, say: Say) -> Result<ExitCode, Box<dyn Error>> {
    match args {
        CompareArgs {
            files,
            reference: Some(reference),
            validity,
        } => {
            let [estimates] = files.as_slice() else {
                return Err(Box::new(ballisto::exit::Usage(
                "compare --reference REFERENCE.csv takes the estimates file alone (no truth file)".into(),
            )));
            };
            let c = ballisto::compare::compare_reference(
                &reference,
                &validity.validity(),
                estimates,
                !say.quiet,
            )?;
            if let Some(d) = c.dropped.describe(&reference) {
                say.info(format!("ballisto compare: {d}"));
            }
            let mut text = format!(
                "rows compared: {} of {} (the others not between two valid reference rows)\n",
                c.compared, c.rows
            );
            for (i, axis) in ["x", "y", "z"].iter().enumerate() {
                text += &format!(
                    "omega_{axis}  RMS error {:.3e} rad/s, median |error| {:.3e} rad/s\n",
                    c.rms[i], c.median[i]
                );
            }
            text += &format!(
                "|omega|   RMS error {:.3e} rad/s, median {:.3e} rad/s\n",
                c.rms_norm, c.median_norm
            );
            ballisto::output::signals::print(&text)?;
            Ok(ExitCode::SUCCESS)
        }
        CompareArgs {
            files,
            reference: None,
            ..
        } => {
            let [truth, estimates] = files.as_slice() else {
                return Err(Box::new(ballisto::exit::Usage(
                "compare takes TRUTH.csv ESTIMATES.csv (or --reference REFERENCE.csv ESTIMATES.csv)".into(),
            )));
            };
            let c = ballisto::compare::compare_shown(truth, estimates, !say.quiet)?;
            let mut text = format!(
                "rows compared: {}\nRMS error  sigma0 {:.3e} m/s^2\nRMS error  domega {:.3e} rad/s^2\nRMS error  omega  {:.3e} rad/s\nRMS error  A      {:.3e} 1/s^2\n",
                c.rows, c.sigma0, c.domega, c.omega, c.field
            );
            if let Some(s) = c.silent {
                text += &format!(
                    "unflagged rows with an error above {} reported sd: sigma0 {}, omega {}\n",
                    ballisto::compare::SILENT_SD,
                    s.sigma0,
                    s.omega
                );
            }
            ballisto::output::signals::print(&text)?;
            Ok(ExitCode::SUCCESS)
        }
    }
}
