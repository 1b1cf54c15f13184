//! `ballisto calibrate --inertia`: identification without a reference (paper §6, source 2) —
//! a record of a torque-free tumble in free flight, the body's inertia given. The mathematics
//! is estimator-core's, the same the tests check (`identify::identify_tumble`): Euler's
//! equations carry the start rate to every set, the start rate is searched for (from the
//! estimator's own rates on the nominal geometry) with each channel's geometry solved over the
//! record at every trial, and the geometry is solved at the rate found with the rate's
//! uncertainty carried into it.
//!
//! A record that cannot decide is refused by name (exit 4, nothing written): the channel and
//! the parameter the motion does not determine (a tumble that keeps too close to a spin about
//! one principal axis, or too short), or the channel no start rate explains (a torque acted,
//! or the inertia is not the body's).

use std::error::Error;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

use ballisto_config::arrangement_file::{load_arrangement, ArrangementFile, HOST_CAP};
use estimator_core::identify::{
    identify_tumble, Body, ChannelFit, Param, Sets, Tolerance, TumbleError, TumbleFit,
};
use estimator_core::{Options, Sym3};

use crate::estimate::HostEstimator;
use crate::exit::Refused;
use crate::samples_csv::SamplesReader;

/// What `ballisto calibrate --inertia` does.
pub struct TumbleJob<'a> {
    /// Nominal arrangement file.
    pub arrangement: &'a Path,
    /// Samples file: the tumble (free flight, no torque).
    pub samples: &'a Path,
    /// Calibrated arrangement file to write.
    pub out: &'a Path,
    /// The body's inertia in the body frame, `[xx, yy, zz, xy, xz, yz]` (any unit: only the
    /// ratios matter).
    pub inertia: [f64; 6],
}

/// What it found, for the summary on stderr.
pub struct TumbleSummary {
    /// Sample sets in the record.
    pub sets: usize,
    /// The start rate found and its deviations (rad/s).
    pub omega0: ([f64; 3], [f64; 3]),
    /// Cost evaluations the search took.
    pub evaluations: u32,
    /// Per channel (name), the parameters not identified (kept nominal).
    pub held: Vec<(String, Vec<&'static str>)>,
    /// ρ of paper eq. 12 (m).
    pub rho: [f64; 3],
}

/// The record's sample sets with the estimator's rate at each.
struct Record {
    sets: Vec<(f64, Vec<f64>)>,
    rates: Vec<(f64, [f64; 3])>,
}

impl Sets for Record {
    fn for_each(&self, f: &mut dyn FnMut(f64, &[f64])) {
        for (t, p) in &self.sets {
            f(*t, p);
        }
    }

    fn rates(&self, f: &mut dyn FnMut(f64, &[f64; 3])) {
        for (t, w) in &self.rates {
            f(*t, w);
        }
    }
}

/// Runs it (see the module doc).
pub fn calibrate_tumble(job: &TumbleJob) -> Result<TumbleSummary, Box<dyn Error>> {
    crate::output::check_distinct(&[job.out], &[job.arrangement, job.samples])?;
    let loaded = load_arrangement(job.arrangement)?;
    let (model, _) = ballisto_config::model_choice::recommend(None, &loaded, job.arrangement)?;
    let mut reader = SamplesReader::open(job.samples, &loaded.names)?.with_ranges(&loaded.ranges);
    let mut est = HostEstimator::<f64>::new(&loaded, model, Options::default())
        .map_err(|e| format!("{}: {e}", job.arrangement.display()))?;
    let mut record = Record {
        sets: Vec::new(),
        rates: Vec::new(),
    };
    let mut p = vec![0.0; loaded.names.len()];
    let mut rates = Vec::new();
    while let Some(t) = reader.next_row(&mut p)? {
        record.sets.push((t, p.clone()));
        est.push(t, &p, |t, e| rates.push((t, e.omega)));
    }
    est.finish(|t, e| rates.push((t, e.omega)));
    // The estimator's rates where they are finite: the search's start.
    record.rates = rates
        .into_iter()
        .filter(|(_, w)| w.iter().all(|v| v.is_finite()))
        .collect();
    let Some(&(_, start)) = record.rates.first() else {
        return Err(format!(
            "{}: no sample rows the estimator could use: nothing written",
            job.samples.display()
        )
        .into());
    };
    let body = Body {
        inertia: Sym3(job.inertia),
        gamma: Sym3([0.0; 6]),
    };
    let nominal = &loaded.arrangement;
    let fit = identify_tumble(&record, &body, &start, nominal, &Tolerance::DATASHEET)
        .map_err(|e| Refused(refusal(&e, &loaded.names)))?;
    let file = arrangement_file(&fit, &loaded.names, job.arrangement)?;
    let mut header = format!(
        "# Identified without a reference (paper §6): a torque-free tumble, the inertia given, \
         {} sample sets of {}; nominal geometry {}.\n",
        record.sets.len(),
        job.samples.display(),
        job.arrangement.display()
    );
    let rho = fit.identified.rho;
    let _ = writeln!(
        header,
        "# Start rate found [{:.5}, {:.5}, {:.5}] rad/s, sd [{:.1e}, {:.1e}, {:.1e}].",
        fit.omega0[0],
        fit.omega0[1],
        fit.omega0[2],
        fit.omega0_sd[0],
        fit.omega0_sd[1],
        fit.omega0_sd[2]
    );
    let _ = writeln!(
        header,
        "# rho = [{:.6}, {:.6}, {:.6}] m: {}.\n# A missing *_sd key means that parameter was not identified.",
        rho[0],
        rho[1],
        rho[2],
        crate::com::RHO_MEANING
    );
    // Written beside the final path, put in place once complete (`crate::output`).
    let (pending, mut w) = crate::output::create(job.out)?;
    w.write_all((header + &file.to_toml()).as_bytes())?;
    crate::output::finish(pending, w)?;
    let held = fit
        .identified
        .channels()
        .iter()
        .zip(&loaded.names)
        .map(|(f, name)| (name.clone(), held_names(f)))
        .collect();
    Ok(TumbleSummary {
        sets: record.sets.len(),
        omega0: (fit.omega0, fit.omega0_sd),
        evaluations: fit.evaluations,
        held,
        rho,
    })
}

/// Why the record gives no solution, naming the channel (and parameter).
fn refusal(e: &TumbleError, names: &[String]) -> String {
    let name = |c: usize| names.get(c).map_or("?", String::as_str);
    match e {
        TumbleError::Inertia => "--inertia: not positive definite: not a body's inertia".into(),
        TumbleError::Identify(e) => {
            format!("the geometry's solve at the start rate found failed: {e:?}")
        }
        TumbleError::NotDetermined { channel, ratio } => format!(
            "no start rate explains the record: {} keeps a residual of {ratio:.1} × its noise \
             (a torque acted during the record, the inertia is not the body's, or the record \
             is too short to find the motion)",
            name(*channel)
        ),
        TumbleError::NotExcited { channel, param } => format!(
            "the motion does not determine most of the geometry (fewer than half of what a \
             tumble can; {}'s {} among what it does not): a longer record, or a tumble further \
             from a spin about one axis",
            name(*channel),
            param.name()
        ),
        TumbleError::Ambiguous { omega0: [a, b] } => format!(
            "two motions explain the record at the noise, with geometries apart by more than \
             half a tolerance: start rates [{:.4}, {:.4}, {:.4}] and [{:.4}, {:.4}, {:.4}] \
             rad/s — the record does not decide between them: a longer record, or another \
             tumble",
            a[0], a[1], a[2], b[0], b[1], b[2]
        ),
        TumbleError::MotionUncertain {
            channel,
            param,
            ratio,
        } => format!(
            "the motion does not determine {}'s {} (the start rate's uncertainty moves it by \
             {ratio:.1} × half its tolerance): a torque-free tumble that stays near a spin \
             about one principal axis, or a short one, cannot — a longer, livelier tumble or a \
             reference rate can",
            name(*channel),
            param.name()
        ),
    }
}

/// The parameters of a fit held at nominal, by name.
fn held_names(f: &ChannelFit) -> Vec<&'static str> {
    Param::ALL
        .iter()
        .filter(|p| f.is_held(**p))
        .map(|p| p.name())
        .collect()
}

/// The calibrated arrangement file: the nominal file's channel names and ranges, the
/// identified geometry with the deviations of what the record determined, the frame's
/// uncertainty.
fn arrangement_file(
    fit: &TumbleFit<HOST_CAP>,
    names: &[String],
    arrangement: &Path,
) -> Result<ArrangementFile, Box<dyn Error>> {
    let nominal = ArrangementFile::read(arrangement)?;
    let specs = nominal.expanded_channels(&arrangement.display().to_string())?;
    let channels = fit
        .identified
        .channels()
        .iter()
        .zip(specs.iter().zip(names))
        .map(|(f, (spec, name))| super::identified_channel(name, spec.range, f))
        .collect();
    let frame = fit.identified.frame_uncertainty();
    Ok(ArrangementFile {
        model: nominal.model.clone(),
        frame_rotation_sd: Some(frame.rotation),
        frame_translation_sd: Some(frame.translation),
        frame_size_sd: Some(frame.size),
        frame_relative_rotation_sd: Some(frame.relative_rotation),
        channels,
        sensors: Vec::new(),
    })
}
