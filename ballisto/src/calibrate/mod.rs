//! `ballisto calibrate`: each channel's position, axis, scale and bias identified from a
//! record (static poses and motion; paper §6), written as an arrangement file
//! (docs/formats.md) with standard deviations; what the record does not determine keeps its
//! nominal value and is named.
//!
//! - [`poses`] finds the static poses;
//! - [`fit`] identifies the geometry (alternating field and per-channel Gauss–Newton);
//! - [`kinematics`] ties self-calibration's Ω′ to the change of its Ω (the axes' rotation
//!   against the lever arms, which the per-sample field otherwise absorbs);
//! - [`reference_rate`] reads a reference rate file and brings it to the sample instants;
//! - [`reference_align`] estimates the reference's bias, time offset and frame rotation;
//! - [`holdout`] holds part of the motion out of the fit and scores both geometries on it;
//! - [`thinning`] keeps a long record's motion to what the fit needs;
//! - [`tumble`] identifies without a reference from a torque-free tumble in free flight, the
//!   inertia given (`--inertia`; estimator-core's identification, as on board);
//! - this module reads the files, runs the fit and writes the calibrated arrangement.

pub mod fit;
pub mod frame;
pub mod holdout;
pub mod kinematics;
pub mod poses;
mod record;
pub mod reference_align;
pub mod reference_rate;
pub mod report;
pub mod scatter;
pub mod thermal;
pub mod thinning;
pub mod tumble;

use std::error::Error;
use std::path::Path;

use ballisto_config::arrangement_file::{
    ArrangementFile, ChannelSpec, LoadedArrangement, HOST_CAP,
};
use estimator_core::{Arrangement, Flags, Model, Options};
use nalgebra::{Matrix3, Vector3};

use crate::estimate::HostEstimator;
use fit::{FitSet, Geometry, Identification, RateSource, Record, Tolerance};

/// Window (s) over which a pose must stay within the noise.
pub const POSE_WINDOW_S: f64 = 0.5;
/// Shortest static pose used (s).
pub const POSE_MIN_S: f64 = 1.0;
/// A reference rate above this (rad/s) means the body turns.
pub const REFERENCE_REST_RATE: f64 = 0.05;

/// What `ballisto calibrate` does.
pub struct CalibrateJob<'a> {
    /// Nominal arrangement file.
    pub arrangement: &'a Path,
    /// Samples file (the calibration record).
    pub samples: &'a Path,
    /// Calibrated arrangement file to write.
    pub out: &'a Path,
    /// Reference rate file, if any.
    pub reference: Option<&'a Path>,
    /// Which of the reference's rows are valid (its flags, the gyro's range).
    pub reference_validity: reference_rate::Validity<'a>,
    /// How well the reference's scale is known (relative deviation per axis); `None`: exact,
    /// Ω is the reference's. With a deviation the reference is a reading of Ω whose common
    /// scale is fitted, and the array's size held at the drawing's ([`fit::RatePrior`]).
    pub reference_scale_sd: Option<f64>,
    /// What may change.
    pub fit: FitSet,
    /// The model for the estimator in self-calibration (overrides the file's).
    pub model: Option<Model>,
    /// A report for people (Markdown), if wanted.
    pub report: Option<&'a Path>,
    /// Write the calibration even when it does not improve the held-out part of the record
    /// (with the warning in the file).
    pub force: bool,
    /// Show a progress bar (on a terminal).
    pub progress: bool,
}

/// What a calibration found, for the summary on stderr.
pub struct CalibrationSummary {
    /// Static poses used.
    pub poses: usize,
    /// Samples in motion in the record.
    pub motion: usize,
    /// Of them, those the fit used, and the thinning factor ([`thinning`]; 1: all used).
    pub motion_used: (usize, usize),
    /// The identification.
    pub identification: Identification,
    /// Channel names.
    pub names: Vec<String>,
    /// The model written into the file.
    pub model: Model,
    /// What makes the calibration doubtful (residuals above the noise, parameters far
    /// outside their tolerance), one sentence each.
    pub warnings: Vec<String>,
    /// The reference rows left out (flagged invalid, at the gyro's range), one sentence.
    pub reference_dropped: Option<String>,
    /// The reference's bias, time offset and frame rotation ([`reference_align`]).
    pub reference_found: Option<reference_align::Found>,
    /// The held-out part's figures, or why the calibration could not be validated.
    pub validation: Result<holdout::Validation, String>,
    /// The temperature coefficients, where the record has temperatures
    /// ([`thermal`]).
    pub thermal: Option<thermal::Found>,
}

impl CalibrationSummary {
    /// "N samples in motion", with how many of them the fit used where it thinned them.
    pub fn motion_described(&self) -> String {
        match self.motion_used {
            (_, 1) => format!("{} samples in motion", self.motion),
            (used, factor) => format!(
                "{} samples in motion ({used} of them fitted: the first 1/{factor} of every {} s stretch, at most {} in all)",
                self.motion,
                holdout::HOLD_BLOCK_S,
                thinning::MAX_MOTION
            ),
        }
    }
}

/// A channel's residual may exceed its declared noise by this factor before the record is
/// said not to fit the model.
pub const RESIDUAL_FACTOR: f64 = 2.0;
/// An identified parameter more than this many tolerances from nominal is doubted.
pub const IMPLAUSIBLE_TOLERANCES: f64 = 5.0;

/// One channel of an identification in flight (estimator-core's, on board or on the ground)
/// as the arrangement file writes it: the identified geometry, bias and scale, and the
/// deviation of each parameter the window determined — a held one gets no `*_sd` key (not
/// identified: kept at the value in use). `name` and `range` are the nominal file's.
pub fn identified_channel(
    name: &str,
    range: Option<f64>,
    fit: &estimator_core::identify::ChannelFit,
) -> ChannelSpec {
    use estimator_core::identify::Param;
    let free = |p: Param| !fit.is_held(p);
    let (c, sd) = (&fit.channel, fit.sd);
    ChannelSpec {
        name: name.to_string(),
        position: c.position,
        axis: c.axis,
        noise: Some(c.noise),
        bias: Some(c.bias),
        scale: Some(c.scale),
        position_sd: (free(Param::PositionX) && free(Param::PositionY) && free(Param::PositionZ))
            .then_some([sd[3], sd[4], sd[5]]),
        axis_sd: (free(Param::TiltA) && free(Param::TiltB)).then_some(sd[1].max(sd[2])),
        bias_sd: free(Param::Bias).then_some(sd[6]),
        scale_sd: free(Param::Scale).then_some(sd[0]),
        range,
        // Temperature coefficients: written by `ballisto calibrate` where its record
        // determines them (`thermal`); a bias and scale found at the record's temperature
        // are not those of another file's `t_ref`.
        t_ref: None,
        bias_tc: None,
        scale_tc: None,
    }
}

/// Checks the identification against what a sound record gives, and says what it doubts:
/// a channel whose residual exceeds [`RESIDUAL_FACTOR`] × its noise (the fit then weighed
/// its data by their measured scatter: [`scatter`]); a parameter more than
/// [`IMPLAUSIBLE_TOLERANCES`] tolerances from nominal points to something the model lacks
/// (a time lag between parts or against the reference, filtering, a wrong nominal).
fn plausibility(
    id: &Identification,
    nominal: &[Geometry],
    names: &[String],
    tol: &Tolerance,
) -> Vec<String> {
    let mut warnings = Vec::new();
    let mut misfit = Vec::new();
    let mut far = Vec::new();
    for ((c, n0), name) in id.channels.iter().zip(nominal.iter()).zip(names.iter()) {
        let ratio = c.residual_rms.1 / n0.noise;
        if ratio > RESIDUAL_FACTOR {
            misfit.push(format!("{name} {ratio:.1}×"));
        }
        let g = &c.geometry;
        let moved = [
            ((g.scale - n0.scale).abs() / tol.scale, "scale"),
            (g.axis.angle(&n0.axis) / tol.axis, "axis"),
            ((g.bias - n0.bias).abs() / tol.bias, "bias"),
            ((g.position - n0.position).norm() / tol.position, "position"),
        ];
        for (m, what) in moved {
            if m > IMPLAUSIBLE_TOLERANCES {
                far.push(format!("{name} {what} {m:.0}×"));
            }
        }
    }
    if !misfit.is_empty() {
        warnings.push(format!(
            "the residuals exceed the declared noise ({}): the record does not fit the model to its noise; the fit weighed each channel's motion samples and pose means by their measured scatter, and the deviations are that weighting's",
            misfit.join(", ")
        ));
    }
    if !far.is_empty() {
        warnings.push(format!(
            "parameters moved far beyond their tolerances ({}; tolerances: scale {}, axis {} rad, bias {} m/s², position {} m): suspect a time lag or filtering the model lacks, or a wrong nominal geometry, before using this file",
            far.join(", "),
            tol.scale,
            tol.axis,
            tol.bias,
            tol.position
        ));
    }
    warnings
}

/// Runs `ballisto calibrate`.
pub fn calibrate_files(job: &CalibrateJob) -> Result<CalibrationSummary, Box<dyn Error>> {
    check_paths(job)?;
    let record::Prepared {
        file,
        loaded,
        names,
        times,
        rows,
        nominal,
        poses,
        in_pose,
        read_reference,
        reference,
        reference_dropped,
        thermal_found,
    } = record::prepare(job)?;
    let tolerance = Tolerance::default();
    let bar = progress_bar(job);
    let parts = record::RecordParts {
        times: &times,
        rows: &rows,
        poses: &poses,
        in_pose: &in_pose,
        nominal: &nominal,
    };
    let (reference, alignment, offset_rotation_sd) = record::align_reference(
        job,
        &parts,
        read_reference.as_ref(),
        reference,
        &tolerance,
        &bar,
    )?;
    let motion = record::motion_of(&in_pose, reference.as_ref());
    let motion_total = motion.len();
    let (motion, thinned) = thinning::thin(&motion, &times);
    let (fit_motion, held_out) = holdout::split(&motion, &times);
    let (model, model_note) =
        ballisto_config::model_choice::recommend(job.model, &loaded, job.arrangement)?;
    bar.set_message("fit on the whole record");
    let whole_progress = |it: usize| bar.set_position(it as u64);
    let record = Record {
        rows: &rows,
        times: &times,
        poses: &poses,
        motion: &motion,
        gamma: Matrix3::zeros(),
        progress: &whole_progress,
        rate_prior: reference
            .as_ref()
            .and_then(|r| rate_prior(&r.omega, job.reference_scale_sd)),
    };
    let run_estimator = |geo: &[Geometry]| estimator_rates(geo, &names, model, &times, &rows);
    let declared = loaded.noises();
    let source = match &reference {
        Some(r) => RateSource::Reference(&r.omega),
        None => RateSource::Estimator(&run_estimator),
    };
    let mut identification = fit::identify(&nominal, &record, &source, job.fit, &tolerance)
        .map_err(|e| format!("{}: {e}", job.samples.display()))?;
    refuse_unless_determined(
        &identification,
        job,
        poses.len(),
        motion.len(),
        reference_dropped.as_deref(),
    )?;
    // The reference's offset is known only so well, and the frame turns with it.
    let frame = &mut identification.frame;
    frame.rotation = frame.rotation.hypot(offset_rotation_sd.0);
    frame.relative_rotation = frame.relative_rotation.hypot(offset_rotation_sd.1);
    let noise = written_noise(&identification, &declared);
    let validation = holdout::validate_on_held_out(
        &holdout::HeldOut {
            record: &record,
            fit_motion: &fit_motion,
            held_out: &held_out,
            source: &source,
            nominal: &nominal,
            declared: &declared,
            names: &names,
            model,
            reference: reference.as_ref(),
        },
        job,
        &tolerance,
        &bar,
    );
    bar.finish_and_clear();
    let reference_found = job
        .reference
        .map(|_| reference_found(&identification, &nominal, alignment, &tolerance));
    let mut warnings = plausibility(&identification, &nominal, &names, &tolerance);
    warnings.extend(validation_warning(&validation, job)?);
    warnings.extend(crate::plausibility::arrangement(
        &loaded,
        &job.arrangement.display().to_string(),
    ));
    if let Some(note) = model_note {
        warnings.push(note);
    }
    warnings.extend(thermal_warnings(
        thermal_found.as_ref(),
        &names,
        &loaded,
        job,
    ));
    let text = calibrated_file(
        &file,
        &identification,
        thermal_found.as_ref(),
        &noise,
        model,
        job,
        &warnings
            .iter()
            .map(|w| format!("WARNING: {w}"))
            .chain(reference_found.as_ref().map(|f| f.describe()))
            .collect::<Vec<_>>(),
    )?;
    crate::output::write(job.out, text.as_bytes())?;
    let summary = CalibrationSummary {
        poses: poses.len(),
        motion: motion_total,
        motion_used: (motion.len(), thinned),
        identification,
        names,
        model,
        warnings,
        reference_dropped,
        reference_found,
        validation,
        thermal: thermal_found,
    };
    if let Some(path) = job.report {
        write_report(&summary, &times, job, path)?;
    }
    Ok(summary)
}

/// The validation's warning, if any: a calibration that does not improve the held-out part
/// of the record is refused unless forced (then said), one whose Ω there is no better than
/// the nominal geometry's is said.
fn validation_warning(
    validation: &Result<holdout::Validation, String>,
    job: &CalibrateJob,
) -> Result<Option<String>, Box<dyn Error>> {
    if let Some(v) = validation.as_ref().ok().filter(|v| !v.improved()) {
        let sentence = format!(
            "the calibration does not improve the part of the record held out of the fit ({})",
            v.describe()
        );
        if !job.force {
            return Err(crate::exit::Refused(format!(
                "{}: {sentence}: nothing written (--force writes it with this warning)",
                job.samples.display()
            ))
            .into());
        }
        return Ok(Some(sentence));
    } else if let Some(v) = validation.as_ref().ok().filter(|v| v.omega_not_lower()) {
        return Ok(Some(format!(
            "Ω on the part of the record held out of the fit is no better than with the nominal geometry ({})",
            v.describe()
        )));
    }
    Ok(None)
}

/// The report for people (Markdown at `path`, its residual plot beside it as `.png`).
fn write_report(
    summary: &CalibrationSummary,
    times: &[f64],
    job: &CalibrateJob,
    path: &Path,
) -> Result<(), Box<dyn Error>> {
    // The PNG beside the Markdown, same name (`REPORT.png`).
    let png = path.with_extension("png");
    let (plot, _) = crate::output::Pending::new(&png)?;
    report::residual_png(summary, times, plot.path())?;
    plot.commit()?;
    let png_name = png.file_name().map(|n| n.to_string_lossy().into_owned());
    let markdown = report::markdown(summary, job, png_name.as_deref());
    crate::output::write(path, markdown.as_bytes())?;
    Ok(())
}

/// What the fit found of the reference: its alignment, the frame rotation of the identified
/// geometry against the nominal one (with its deviation), its scale.
fn reference_found(
    id: &Identification,
    nominal: &[Geometry],
    alignment: reference_align::Alignment,
    tolerance: &Tolerance,
) -> reference_align::Found {
    let geo: Vec<Geometry> = id.channels.iter().map(|c| c.geometry).collect();
    reference_align::Found {
        alignment,
        rotation: frame::rotation(nominal, &geo, tolerance).map(|(r, _)| (r, id.frame.rotation)),
        scale: id.reference_scale,
    }
}

/// No output of `job` is one of its inputs or another output (the report's PNG included).
fn check_paths(job: &CalibrateJob) -> Result<(), Box<dyn Error>> {
    let png = job.report.map(|r| r.with_extension("png"));
    let outputs: Vec<&Path> = std::iter::once(job.out)
        .chain(job.report)
        .chain(png.as_deref())
        .collect();
    let inputs: Vec<&Path> = [job.arrangement, job.samples]
        .into_iter()
        .chain(job.reference)
        .collect();
    crate::output::check_distinct(&outputs, &inputs)?;
    Ok(())
}

/// The progress bar of a calibration: the reference's alignment (its fits one after the
/// other, in the first stage), the whole-record fit, the fit without the held-out stretches
/// (their alternations, at most [`fit::MAX_ALTERNATIONS`] each), then the scoring.
fn progress_bar(job: &CalibrateJob) -> indicatif::ProgressBar {
    let stage_len = fit::MAX_ALTERNATIONS as u64;
    crate::progress::bar(
        job.progress,
        2 * stage_len + 1,
        "{msg:40} {bar:30} {pos}/{len} ({elapsed})",
    )
}

/// What the record's temperatures leave unsaid: coefficients the file had and a record
/// without temperatures cannot carry, or channels whose coefficients the record does not
/// determine.
fn thermal_warnings(
    thermal_found: Option<&thermal::Found>,
    names: &[String],
    loaded: &LoadedArrangement,
    job: &CalibrateJob,
) -> Option<String> {
    match thermal_found {
        None => {
            let with_coefficients: Vec<&str> = names
                .iter()
                .enumerate()
                .filter(|(c, _)| loaded.arrangement.thermal(*c).is_some())
                .map(|(_, n)| n.as_str())
                .collect();
            if !with_coefficients.is_empty() {
                return Some(format!(
                    "{}: the temperature coefficients of {} are not written: the record has no temperatures (temp_<channel> columns), and the bias and scale found are the record's, at its temperatures",
                    job.arrangement.display(),
                    with_coefficients.join(", ")
                ));
            }
        }
        Some(found) => {
            let not: Vec<String> = names
                .iter()
                .zip(&found.channels)
                .filter_map(|(n, c)| match c {
                    thermal::ChannelThermal::NotDetermined(why) => Some(format!("{n} ({why})")),
                    thermal::ChannelThermal::Identified { .. } => None,
                })
                .collect();
            if !not.is_empty() {
                return Some(format!(
                    "temperature coefficients not determined by the record, not written: {}; their bias and scale are the record's, at its temperatures",
                    not.join(", ")
                ));
            }
        }
    }
    None
}

/// Refuses a fit that does not converge, or a record that determines fewer than half the
/// parameters asked for (what it does determine are then combinations the fit can only split
/// arbitrarily): `poses` static poses and `motion` samples in motion, `reference_dropped` the
/// reference rows left out.
fn refuse_unless_determined(
    id: &Identification,
    job: &CalibrateJob,
    poses: usize,
    motion: usize,
    reference_dropped: Option<&str>,
) -> Result<(), Box<dyn Error>> {
    // A record that leaves most parameters undetermined (or all of them) is not a calibration:
    // what it does determine are combinations (one pose: bias with scale and axis) that the fit can only
    // split arbitrarily.
    let held = held_counts(id, job.fit);
    let (identified, fitted) = held
        .iter()
        .fold((0, 0), |(i, f), (_, h, n)| (i + n - h, f + n));
    if 2 * identified < fitted {
        let what: Vec<String> = held
            .iter()
            .filter(|(_, h, _)| *h > 0)
            .map(|(kind, h, n)| format!("{kind} {h} of {n}"))
            .collect();
        return Err(crate::exit::Refused(format!(
            "{}: the record is not exciting enough: it determines only {identified} of the {fitted} parameters ({} static poses, {} samples in motion; not determined: {}), and a calibration needs static poses in at least 6 well-spread attitudes, or rotation about several axes with a reference rate: nothing written",
            job.samples.display(),
            poses,
            motion,
            what.join(", ")
        ))
        .into());
    }
    let converged = id.last_step <= fit::CONVERGED_STEP;
    if !converged {
        return Err(crate::exit::Refused(format!(
            "{}: the identification did not converge ({} alternations, the last still moved a parameter by {:.3} of its tolerance; {} static poses, {} samples in motion{}): nothing written",
            job.samples.display(),
            id.iterations,
            id.last_step,
            poses,
            motion,
            match (reference_dropped, job.reference) {
                (_, None) => "; a reference rate would help".to_string(),
                (Some(d), _) => format!("; {d}"),
                (None, Some(_)) => String::new(),
            }
        ))
        .into());
    }
    Ok(())
}

/// Per kind of parameter (scale, axis, bias, position) asked for by `fit`: how many of the
/// channels' parameters are not identified, of how many.
fn held_counts(id: &Identification, fit: FitSet) -> Vec<(&'static str, usize, usize)> {
    let kinds: [(&str, &[usize], bool); 4] = [
        ("scale", &[0], fit.scale),
        ("axis", &[1, 2], fit.axis),
        ("bias", &[6], fit.bias),
        ("position", &[3, 4, 5], fit.position),
    ];
    kinds
        .iter()
        .filter(|(_, _, asked)| *asked)
        .map(|(kind, params, _)| {
            let n = id.channels.len() * params.len();
            let held = id
                .channels
                .iter()
                .flat_map(|c| params.iter().map(move |&j| c.sd[j]))
                .filter(|s| !s.is_finite())
                .count();
            (*kind, held, n)
        })
        .collect()
}

/// Ω per sample from the host estimator (f64, smoothed) on the geometry `geo`: `None` where
/// the estimator does not decide it (fallback, ill-conditioned, branch ambiguous, input
/// invalid).
pub fn estimator_rates(
    geo: &[Geometry],
    names: &[String],
    model: Model,
    times: &[f64],
    rows: &[Vec<f64>],
) -> Result<fit::Rates, String> {
    let undecided =
        Flags::FALLBACK | Flags::ILL_CONDITIONED | Flags::BRANCH_AMBIGUOUS | Flags::INPUT_INVALID;
    Ok(estimator_run(geo, names, model, times, rows)?
        .into_iter()
        .map(|(w, flags)| (flags & undecided == 0).then_some(w))
        .collect())
}

/// The host estimator (f64, smoothed, no fault isolation) over the record on the geometry
/// `geo` with the noise it declares: Ω and the flags per sample.
pub fn estimator_run(
    geo: &[Geometry],
    names: &[String],
    model: Model,
    times: &[f64],
    rows: &[Vec<f64>],
) -> Result<Vec<(Vector3<f64>, u16)>, String> {
    let mut arrangement = Arrangement::<HOST_CAP>::new();
    for g in geo {
        let i = arrangement
            .push(g.position.into(), g.axis.into(), g.noise)
            .map_err(|e| format!("the geometry being identified: {e}"))?;
        arrangement
            .set_calibration(i, g.bias, g.scale)
            .map_err(|e| format!("the geometry being identified: {e}"))?;
    }
    let loaded = LoadedArrangement {
        names: names.to_vec(),
        arrangement,
        model: Some(model),
        noise_given: true,
        // Fault isolation is off here (below): no range limits.
        ranges: vec![f64::INFINITY; names.len()],
        unoriented: Vec::new(),
    };
    // The geometry is what is being fitted: every sample is inconsistent with the nominal
    // geometry, so fault isolation would take parts out.
    let mut est = HostEstimator::<f64>::new(&loaded, model, Options::default())
        .map_err(|e| format!("the estimator on the geometry being identified: {e}"))?
        .without_fault_isolation();
    let mut out = Vec::with_capacity(rows.len());
    let mut emit = |_: f64, e: &estimator_core::Estimate<f64>| {
        out.push((Vector3::from(e.omega), e.flags.0));
    };
    for (t, row) in times.iter().zip(rows.iter()) {
        est.push(*t, row, &mut emit);
    }
    est.finish(&mut emit);
    Ok(out)
}

/// The noise each calibrated channel declares: a reading's scatter at rest about the
/// calibrated geometry — its white noise and the floor its pose means show (the model error
/// that remains when the model holds) — never below the noise the nominal file `declared`.
///
/// Not the residual in motion: on the MIMU4444 board that is 10–15 × the rest level and
/// structured (the parts' filtering of motion too fast for 62.5 Hz: a filtered `ΩΩᵀ` is not
/// the square of a filtered Ω), not white noise on each reading. Declared as the noise, it
/// widened the Ω filter's measurement noise until the filter lagged the hand-held motion (Ω
/// RMS 8.27 rad/s over exp1's hand-held phase against 7.69 for the same geometry with the
/// rest level; 8.04 against 7.39 on exp5 calibrated on exp2) and overstated Ω's deviation at
/// rest 2–5 × (RMS error/sd 0.18–0.48), while every hand-held row was flagged "residual high"
/// either way. At the rest level the flag says where the model does not fit.
fn written_noise(id: &Identification, declared: &[f64]) -> Vec<f64> {
    id.channels
        .iter()
        .zip(declared.iter())
        .map(|(c, &d)| {
            if c.rest_scatter.is_finite() {
                c.rest_scatter.max(d)
            } else {
                d
            }
        })
        .collect()
}

/// The calibrated arrangement file's text: every channel as a `[[channel]]` table with its
/// identified geometry and standard deviations, after a header comment saying what was
/// identified from what.
fn calibrated_file(
    file: &ArrangementFile,
    id: &Identification,
    thermal_found: Option<&thermal::Found>,
    noise: &[f64],
    model: Model,
    job: &CalibrateJob,
    notes: &[String],
) -> Result<String, Box<dyn Error>> {
    let specs = file.expanded_channels(&job.arrangement.display().to_string())?;
    let coefficients = thermal_found.map_or(vec![None; specs.len()], thermal::Found::thermal);
    let channels: Vec<ChannelSpec> = specs
        .iter()
        .zip(id.channels.iter())
        .zip(noise.iter())
        .zip(&coefficients)
        .map(|(((spec, c), &noise), th)| {
            let mut fit = c.channel_fit(&id.tolerance);
            fit.channel.noise = noise;
            // The parts' full scale is not identified: kept from the nominal file.
            let mut out = identified_channel(&spec.name, spec.range, &fit);
            if let Some(th) = th {
                out.t_ref = Some(th.t_ref);
                out.bias_tc = Some(th.bias_tc);
                out.scale_tc = Some(th.scale_tc);
            }
            out
        })
        .collect();
    let out = ArrangementFile {
        model: Some(model.name().into()),
        frame_rotation_sd: Some(id.frame.rotation),
        frame_translation_sd: Some(id.frame.translation),
        frame_size_sd: Some(id.frame.size),
        frame_relative_rotation_sd: Some(id.frame.relative_rotation),
        channels,
        sensors: Vec::new(),
    };
    let mut header = format!(
        "# Calibrated by ballisto calibrate from {} ({}), nominal geometry {}.\n",
        job.samples.display(),
        match job.reference {
            Some(r) => format!("reference rate {}", r.display()),
            None => "self-calibration: Ω from the estimator".into(),
        },
        job.arrangement.display()
    );
    for note in notes {
        header.push_str(&format!("# {note}.\n"));
    }
    for c in &id.conventions {
        header.push_str(&format!("# Held by convention: {c}.\n"));
    }
    if let Some(found) = thermal_found {
        header.push_str(&format!(
            "# Temperature coefficients from {} static poses over {:.1} °C ({} Gauss–Newton steps); bias and scale are at each channel's t_ref.\n",
            found.poses.0, found.poses.1, found.steps
        ));
        for (name, c) in specs.iter().map(|c| &c.name).zip(&found.channels) {
            if let thermal::ChannelThermal::Identified { thermal: th, sd } = c {
                header.push_str(&format!(
                    "# {name}: bias_tc {:.4e} ± {:.1e} m/s² per °C, scale_tc {:.3e} ± {:.1e} per °C about {:.2} °C.\n",
                    th.bias_tc, sd.0, th.scale_tc, sd.1, th.t_ref
                ));
            }
        }
    }
    if let Some(k) = &id.kinematic {
        header.push_str(&format!("# Self-calibration: {}.\n", k.describe()));
    }
    for (name, c) in specs.iter().map(|c| &c.name).zip(id.channels.iter()) {
        if !c.held.is_empty() {
            header.push_str(&format!(
                "# {name}: not identified by this record (kept nominal): {}.\n",
                c.held.join("; ")
            ));
        }
    }
    header.push_str("# A missing *_sd key means that parameter was not identified.\n");
    Ok(header + &out.to_toml())
}

/// The deviation of a reference's Ω at rest taken for a reading of Ω (rad/s): a MEMS gyro's
/// noise over one sample (the MIMU4444's eight MPU9150 gyros spread by 0.01 rad/s RMS about
/// their mean, `reference_flags.csv`).
const REFERENCE_FLOOR: f64 = 0.01;

/// The reference `omega` as a reading of Ω with its scale known to `scale_sd` (relative, per
/// axis), where one is given.
fn rate_prior(omega: &[Vector3<f64>], scale_sd: Option<f64>) -> Option<fit::RatePrior<'_>> {
    scale_sd.map(|scale_sd| fit::RatePrior {
        omega,
        scale_sd,
        floor: REFERENCE_FLOOR,
        scale: 1.0,
    })
}
