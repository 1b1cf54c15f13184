//! `ballisto sim`: a scenario through the bench reader or the firmware, and its summary.

use std::error::Error;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use ballisto::estimate::FLAG_NAMES;
use ballisto_fw::config::Alignment;
use clap::Args;

use super::args::*;

/// The arguments of `ballisto sim`.
#[derive(Args)]
pub struct SimArgs {
    /// A named scenario or a scenario file (TOML).
    #[arg(long, value_name = "NAME|FILE")]
    pub scenario: String,
    /// Output directory (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Also run the estimator: estimates.csv, errors against the truth, estimates.png.
    #[arg(long)]
    pub estimate: bool,
    /// Run the firmware (its sampling and estimation tasks on the simulated buses) instead
    /// of the bench reader: samples.csv and estimates.csv are what the firmware produced.
    #[arg(long)]
    pub firmware: bool,
    /// With --firmware: how samples of free-running parts are aligned to the sample
    /// instants: interpolate (timestamped FIFO samples) or latest (the unaligned reference).
    #[arg(long, value_enum, default_value = "interpolate")]
    pub align: AlignArg,
    /// With --firmware: identify in flight first (paper §6) with the scenario's reference
    /// gyro sent by telecommand (or, without one, in its torque-free tumble), commit,
    /// reset, and run the scenario again on the stored calibration (the first boot's
    /// telemetry in telemetry-identify.bin). Where the scenario's temperature changes,
    /// windows spread over the run (one per 15 minutes): the unit tracks each channel's
    /// bias against its temperature and the commit takes the coefficients it decides.
    #[arg(long, requires = "firmware")]
    pub identify: bool,
    /// With --firmware: send the telecommand frames of FILE (as `ballisto tc` writes them)
    /// on the unit's command link at scenario time SECONDS; repeatable. The unit's
    /// verification reports are in telemetry.bin (`ballisto decode --commands FILE`).
    #[arg(
        long,
        value_name = "SECONDS:FILE",
        requires = "firmware",
        conflicts_with = "identify"
    )]
    pub uplink: Vec<String>,
    /// With --firmware: the unit's calibration store holds this calibrated arrangement
    /// (`ballisto calibrate`'s output over the scenario's channels, its temperature
    /// coefficients included), committed on the ground as calibration 1: the unit boots
    /// on it (with --identify, the first boot does).
    #[arg(long, value_name = "FILE.toml", requires = "firmware")]
    pub calibration: Option<PathBuf>,
    /// With --estimate or --firmware: keep only arrangement.toml, truth_geometry.toml and
    /// estimates.png (and the summary); the records (samples, truth, estimates, telemetry)
    /// are written to a scratch directory and removed — for a long run looked at, not kept.
    #[arg(long)]
    pub plot_only: bool,
}

/// Above this, the size of a run's files is said before it starts (bytes).
const SAY_SIZE_ABOVE: u64 = 100_000_000;

/// `ballisto sim`.
pub fn sim(args: SimArgs, say: Say, started: Instant) -> Result<ExitCode, Box<dyn Error>> {
    let SimArgs {
        scenario,
        out,
        estimate,
        firmware,
        align,
        identify,
        uplink,
        calibration,
        plot_only,
    } = args;
    if plot_only && !(estimate || firmware) {
        return Err(Box::new(ballisto::exit::Usage(
            "--plot-only keeps the plot, which needs --estimate or --firmware".into(),
        )));
    }
    let alignment = match align {
        AlignArg::Interpolate => Alignment::Interpolate,
        AlignArg::Latest => Alignment::Latest,
    };
    // A scenario file or an uplink file in the output directory is not overwritten.
    std::fs::create_dir_all(&out)
        .map_err(|e| format!("{}: cannot create the directory: {e}", out.display()))?;
    let outputs: Vec<PathBuf> = ballisto::sim::OUTPUTS.iter().map(|f| out.join(f)).collect();
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
    let job = ballisto::sim::SimJob {
        scenario: &sc,
        out: &out,
        estimate,
        progress: !say.quiet,
        firmware: firmware.then_some(alignment),
        identify,
        uplink,
        calibration: calibration.as_deref(),
    };
    let sizes = ballisto::sim::expected_sizes(&job);
    let total: u64 = sizes.iter().map(|(_, b)| b).sum();
    if total > SAY_SIZE_ABOVE {
        let each: Vec<String> = sizes
            .iter()
            .map(|(f, b)| format!("{f} {}", megabytes(*b)))
            .collect();
        say.info(format!(
            "ballisto sim: {} sample sets: about {} of records ({}){}",
            sc.samples(),
            megabytes(total),
            each.join(", "),
            if plot_only {
                ", written to a scratch directory and removed at the end (--plot-only)"
            } else {
                "; --plot-only keeps only the plot and the summary"
            }
        ));
    }
    let r = if plot_only {
        ballisto::sim::run_sim_keeping_the_plot(&job)?
    } else {
        ballisto::sim::run_sim(&job)?
    };
    print_sim(say, &scenario, &sc, &r, identify, started);
    Ok(ExitCode::SUCCESS)
}

/// `bytes` as megabytes (or gigabytes), rounded for a person.
fn megabytes(bytes: u64) -> String {
    if bytes >= 1_000_000_000 {
        format!("{:.1} GB", bytes as f64 / 1e9)
    } else {
        format!("{:.0} MB", bytes as f64 / 1e6)
    }
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
