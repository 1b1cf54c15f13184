//! `ballisto estimate`, `calibrate` and `com`: the estimator and the identification over files.

use std::error::Error;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use ballisto::estimate::{estimate_files, EstimateJob, Precision, FLAG_NAMES};
use clap::Args;
use estimator_core::Model;

use super::args::*;

/// The arguments of `ballisto estimate`.
#[derive(Args)]
pub struct EstimateArgs {
    /// Arrangement file (TOML).
    #[arg(long, value_name = "FILE.toml")]
    pub arrangement: PathBuf,
    /// Samples file (CSV: t and one column per channel); `-` reads stdin.
    #[arg(long, value_name = "FILE.csv")]
    pub samples: PathBuf,
    /// Estimates file to write, `-` for stdout (CSV: the docs/formats.md columns, then chi2, dof, branches,
    /// frame, the standard deviations — with the arrangement's frame uncertainty when it
    /// has one — epsilon, and the gravity gradient gamma_* with sd_gamma_*, model G only).
    #[arg(long, value_name = "FILE.csv")]
    pub out: PathBuf,
    /// Model: general (9-column, N >= 12) or free-float (N >= 9); default: the file's, else
    /// general unless model G would resolve the field poorly on this arrangement (then
    /// free-float, said on stderr).
    #[arg(long, value_enum)]
    pub model: Option<ModelArg>,
    /// Approximate angular rate at the first sample, rad/s, "X,Y,Z": settles the sign and the starting branch.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub initial_omega: Option<String>,
    /// Per-sample estimates without temporal filtering (continuity still picks sign and branch).
    #[arg(long)]
    pub raw: bool,
    /// Scalar of the sample loop: f64 (default) or f32 (as on the target).
    #[arg(long, value_enum, default_value = "f64")]
    pub precision: PrecisionArg,
    /// Alert limits of the protection levels "SIGMA0,DOMEGA,OMEGA" (m/s², rad/s², rad/s;
    /// `inf` for none): a row whose level is above its limit, or that has none, gets flag
    /// 256. Default: no alert.
    #[arg(long, value_name = "S0,DW,W", value_parser = alert_limits)]
    pub alert_limits: Option<[f64; 3]>,
    /// The probability that an output's error exceeds its protection level at a row.
    #[arg(long, value_name = "P", default_value = "0.001", allow_negative_numbers = true, value_parser = probability)]
    pub missed: f64,
}

/// `ballisto estimate`.
pub fn estimate(
    args: EstimateArgs,
    say: Say,
    started: Instant,
) -> Result<ExitCode, Box<dyn Error>> {
    let EstimateArgs {
        arrangement,
        samples,
        out,
        model,
        initial_omega,
        raw,
        precision,
        alert_limits,
        missed,
    } = args;
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
        progress: !say.quiet,
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

/// The arguments of `ballisto calibrate`.
#[derive(Args)]
pub struct CalibrateArgs {
    /// Nominal arrangement file (TOML): the geometry as drawn.
    #[arg(long, value_name = "NOMINAL.toml")]
    pub arrangement: PathBuf,
    /// The calibration record (samples CSV): any mix of static poses and motion.
    #[arg(long, value_name = "RECORD.csv")]
    pub samples: PathBuf,
    /// Calibrated arrangement file to write.
    #[arg(long, value_name = "CALIBRATED.toml")]
    pub out: PathBuf,
    /// Reference rate file (CSV: t, omega_x, omega_y, omega_z; rad/s, body frame); without
    /// it Ω comes from the estimator (self-calibration). Rows whose `valid` column is 0 or
    /// whose `*_saturated` columns are not 0 are left out.
    #[arg(long, value_name = "REFERENCE.csv")]
    pub reference: Option<PathBuf>,
    #[command(flatten)]
    pub validity: ReferenceValidity,
    /// How well the reference's scale factors are known, relative (e.g. 0.005): the
    /// reference is then a reading of Ω rather than Ω itself, its common scale factor is
    /// fitted and the array's size held at the drawing's. For a gyro whose scale factors
    /// are not calibrated; without it the reference's scale is taken as exact.
    #[arg(long, value_name = "REL", requires = "reference", allow_negative_numbers = true, value_parser = relative_sd)]
    pub reference_scale_sd: Option<f64>,
    /// What may change: a comma-separated subset of bias, scale, axis, position.
    #[arg(long, value_name = "LIST", default_value = "bias,scale,axis,position")]
    pub fit: String,
    /// Model of the estimator in self-calibration, and the one written into the file;
    /// default as for estimate.
    #[arg(long, value_enum)]
    pub model: Option<ModelArg>,
    /// A report for people (Markdown): per channel the identified values, their standard
    /// deviations and the residual before and after; with REPORT.png beside it (the
    /// residuals per sample and per channel, before and after).
    #[arg(long, value_name = "REPORT.md")]
    pub report: Option<PathBuf>,
    /// Write the calibration even when it does not improve the part of the record held
    /// out of the fit (every fifth 2 s of motion); the warning goes into the file.
    #[arg(long)]
    pub force: bool,
    /// Without a reference, from a torque-free tumble in free flight: the body's inertia
    /// in the body frame, XX,YY,ZZ or XX,YY,ZZ,XY,XZ,YZ (any unit: only the ratios
    /// matter). The record is then fitted with the motion Euler's equations give (paper
    /// §6); a record that cannot decide is refused, naming the channel and parameter.
    #[arg(long, value_name = "XX,YY,ZZ[,XY,XZ,YZ]", value_parser = inertia,
          conflicts_with_all = ["reference", "reference_scale_sd", "report", "force", "model"])]
    pub inertia: Option<[f64; 6]>,
}

/// `ballisto calibrate`.
pub fn calibrate(
    args: CalibrateArgs,
    say: Say,
    started: Instant,
) -> Result<ExitCode, Box<dyn Error>> {
    let CalibrateArgs {
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
    } = args;
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

/// The arguments of `ballisto com`.
#[derive(Args)]
pub struct ComArgs {
    /// Arrangement file (TOML).
    #[arg(long, value_name = "FILE.toml")]
    pub arrangement: PathBuf,
    /// Samples file (CSV).
    #[arg(long, value_name = "FILE.csv")]
    pub samples: PathBuf,
    /// Output file (CSV).
    #[arg(long, value_name = "COM.csv")]
    pub out: PathBuf,
    /// Window length, s (one window every half window).
    #[arg(long, value_name = "SECONDS", default_value = "10", value_parser = positive_seconds)]
    pub window: f64,
    /// Model; default as for estimate.
    #[arg(long, value_enum)]
    pub model: Option<ModelArg>,
}

/// `ballisto com`.
pub fn com(args: ComArgs, say: Say) -> Result<ExitCode, Box<dyn Error>> {
    let ComArgs {
        arrangement,
        samples,
        out,
        window,
        model,
    } = args;
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
