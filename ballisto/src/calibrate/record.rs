//! The calibration record as the fit takes it: the files read, the noise, the static poses,
//! the reference at the sample instants, and, where the record has temperatures, each
//! channel's coefficients with the whole record brought to its `t_ref`.

use std::error::Error;
use std::path::Path;

use ballisto_config::arrangement_file::{ArrangementFile, LoadedArrangement};
use nalgebra::Vector3;

use nalgebra::Matrix3;

use super::fit::{self, Geometry, Pose, RateSource, Record, Tolerance};
use super::{frame, reference_align, thinning};
use super::{
    poses, reference_rate, thermal, CalibrateJob, POSE_MIN_S, POSE_WINDOW_S, REFERENCE_REST_RATE,
};
use crate::samples_csv::SamplesReader;

/// What [`prepare`] read and found.
pub(super) struct Prepared {
    /// The nominal arrangement file, and loaded.
    pub file: ArrangementFile,
    pub loaded: LoadedArrangement,
    /// Channel names.
    pub names: Vec<String>,
    /// Sample times and rows (temperature-corrected where the record has temperatures).
    pub times: Vec<f64>,
    pub rows: Vec<Vec<f64>>,
    /// The nominal geometry with each channel's noise (the file's, or the record's).
    pub nominal: Vec<Geometry>,
    /// The static poses, and which samples are in one.
    pub poses: Vec<Pose>,
    pub in_pose: Vec<bool>,
    /// The reference as read (for the alignment's shifted looks), and at the sample instants.
    pub read_reference: Option<(reference_rate::Reference, reference_rate::Dropped)>,
    pub reference: Option<reference_rate::ReferenceAt>,
    /// The reference rows left out, one sentence.
    pub reference_dropped: Option<String>,
    /// The temperature coefficients, where the record has temperatures.
    pub thermal_found: Option<thermal::Found>,
}

/// Reads the files of `job` and prepares the record (module doc); errors name the file.
pub(super) fn prepare(job: &CalibrateJob) -> Result<Prepared, Box<dyn Error>> {
    let file = ArrangementFile::read(job.arrangement)?;
    let loaded = file.load(&job.arrangement.display().to_string())?;
    let names = loaded.names.clone();
    let (times, rows, temps) = read_record(job.samples, &names)?;
    if rows.len() < 200 {
        return Err(format!(
            "{}: {} sample sets are too few to calibrate from (at least 200: static poses of {POSE_MIN_S} s, or motion)",
            job.samples.display(),
            rows.len()
        )
        .into());
    }
    let rate_hz = (rows.len() - 1) as f64 / (times[times.len() - 1] - times[0]);
    let nominal: Vec<Geometry> = loaded
        .arrangement
        .channels()
        .iter()
        .map(|c| Geometry {
            position: Vector3::from(c.position),
            axis: Vector3::from(c.axis),
            scale: c.scale,
            bias: c.bias,
            noise: c.noise,
        })
        .collect();
    // Read once: the alignment below interpolates it again at shifted times.
    let read_reference = match job.reference {
        Some(path) => Some(reference_rate::read(path, &job.reference_validity)?),
        None => None,
    };
    let reference = match (job.reference, &read_reference) {
        (Some(path), Some((r, dropped))) => Some(r.at(&times, dropped, path)?),
        _ => None,
    };
    let reference_dropped = job
        .reference
        .zip(reference.as_ref())
        .and_then(|(path, r)| r.dropped.describe(path));
    let rate_ok: Option<Vec<bool>> = reference.as_ref().map(|r| {
        r.omega
            .iter()
            .zip(r.covered.iter())
            .map(|(w, c)| *c && w.norm() < REFERENCE_REST_RATE)
            .collect()
    });
    let noise = noise_levels(&loaded, &rows, rate_hz);
    let nominal: Vec<Geometry> = nominal
        .into_iter()
        .zip(noise.iter())
        .map(|(g, &noise)| Geometry { noise, ..g })
        .collect();
    let window = ((POSE_WINDOW_S * rate_hz).round() as usize).max(5);
    let min_len = ((POSE_MIN_S * rate_hz).round() as usize).max(window);
    let poses = poses::find_poses(&rows, &noise, rate_ok.as_deref(), window, min_len);
    // A record with temperatures: each channel's coefficients from its static poses, and the
    // whole record brought to each channel's `t_ref` before everything else.
    let thermal_found = match &temps {
        Some(temps) => Some(
            thermal::identify(&nominal, &rows, temps, &poses, job.fit).map_err(|e| {
                format!(
                    "{}: the temperature coefficients: {e}",
                    job.samples.display()
                )
            })?,
        ),
        None => None,
    };
    let (rows, poses) = match (&temps, &thermal_found) {
        (Some(temps), Some(found)) => {
            let rows = thermal::corrected(&rows, temps, &found.thermal(), &found.bias);
            let poses = poses::remeasured(&poses, &rows);
            (rows, poses)
        }
        _ => (rows, poses),
    };
    let in_pose = {
        let mut v = vec![false; rows.len()];
        for p in &poses {
            v[p.samples.clone()].iter_mut().for_each(|x| *x = true);
        }
        v
    };
    Ok(Prepared {
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
    })
}

/// Sample times and rows, and each row's temperatures (per channel, °C: the last read, NaN
/// before the first; `None` if the record has no temperature column).
type Samples = (Vec<f64>, Vec<Vec<f64>>, Option<Vec<Vec<f64>>>);

/// The whole record in memory (a calibration record is minutes long, not hours).
fn read_record(path: &Path, names: &[String]) -> Result<Samples, Box<dyn Error>> {
    let mut reader = SamplesReader::open(path, names)?;
    let with_temps = (0..names.len()).any(|c| reader.has_temperature(c));
    let mut times = Vec::new();
    let mut rows = Vec::new();
    let mut temps = Vec::new();
    let mut row = vec![0.0; names.len()];
    let mut last = vec![f64::NAN; names.len()];
    while let Some(t) = reader.next_row(&mut row)? {
        times.push(t);
        rows.push(row.clone());
        if with_temps {
            reader.temperatures(&mut last)?;
            temps.push(last.clone());
        }
    }
    Ok((times, rows, with_temps.then_some(temps)))
}

/// Each channel's noise: the file's if it gives one, else the quietest 10 % of half-second
/// windows of the record.
fn noise_levels(loaded: &LoadedArrangement, rows: &[Vec<f64>], rate_hz: f64) -> Vec<f64> {
    let n = loaded.names.len();
    if loaded.noise_given {
        return loaded
            .arrangement
            .channels()
            .iter()
            .map(|c| c.noise)
            .collect();
    }
    let w = ((POSE_WINDOW_S * rate_hz) as usize).max(5);
    (0..n)
        .map(|c| {
            let mut sds: Vec<f64> = rows
                .chunks(w)
                .filter(|ch| ch.len() == w)
                .map(|ch| {
                    let m = ch.iter().map(|r| r[c]).sum::<f64>() / w as f64;
                    (ch.iter().map(|r| (r[c] - m).powi(2)).sum::<f64>() / (w - 1) as f64).sqrt()
                })
                .filter(|s| s.is_finite() && *s > 0.0)
                .collect();
            sds.sort_by(f64::total_cmp);
            sds.get(sds.len() / 10).copied().unwrap_or(1.0)
        })
        .collect()
}

/// The parts of the record the fits read.
pub(super) struct RecordParts<'a> {
    pub times: &'a [f64],
    pub rows: &'a [Vec<f64>],
    pub poses: &'a [fit::Pose],
    pub in_pose: &'a [bool],
    pub nominal: &'a [Geometry],
}

/// The samples in motion (not in a pose), where the reference covers them if there is one.
pub(super) fn motion_of(
    in_pose: &[bool],
    reference: Option<&reference_rate::ReferenceAt>,
) -> Vec<usize> {
    (0..in_pose.len())
        .filter(|&k| !in_pose[k])
        .filter(|&k| reference.is_none_or(|r| r.covered[k]))
        .collect()
}

/// A real reference's bias (at rest) and time offset, fitted and removed
/// ([`reference_align`]): the reference at the sample instants after that, its alignment,
/// and the frame rotation's deviations it adds (total, relative); without a reference file,
/// the reference as it is.
pub(super) fn align_reference(
    job: &CalibrateJob,
    parts: &RecordParts,
    read_reference: Option<&(reference_rate::Reference, reference_rate::Dropped)>,
    reference: Option<reference_rate::ReferenceAt>,
    tolerance: &Tolerance,
    bar: &indicatif::ProgressBar,
) -> Result<AlignedReference, Box<dyn Error>> {
    let align_progress = |it: usize| bar.set_position(it as u64);
    // A real reference's bias (at rest) and time offset, fitted and removed
    // (reference_align).
    match (job.reference, read_reference, reference) {
        (Some(path), Some((read, dropped)), Some(first)) => {
            let load = |offset: f64| -> Result<reference_rate::ReferenceAt, Box<dyn Error>> {
                // The row stamped t + offset is the rate at t.
                let shifted: Vec<f64> = parts.times.iter().map(|t| t + offset).collect();
                read.at(&shifted, dropped, path)
            };
            let fit_to = |r: &reference_rate::ReferenceAt| {
                bar.set_message("aligning the reference");
                let (motion, _) = thinning::thin(&motion_of(parts.in_pose, Some(r)), parts.times);
                let record = Record {
                    rows: parts.rows,
                    times: parts.times,
                    poses: parts.poses,
                    motion: &motion,
                    gamma: Matrix3::zeros(),
                    progress: &align_progress,
                    // The offset from fits with the reference held exact: a reference of
                    // inexact scale is a reading of Ω only in the fit written (with Ω per sample
                    // in the alignment fits too, the hour's record took 95 s against 51).
                    rate_prior: None,
                };
                let source = RateSource::Reference(&r.omega);
                match fit::identify(parts.nominal, &record, &source, job.fit, tolerance) {
                    Ok(id) if id.last_step <= fit::CONVERGED_STEP => {
                        let geo: Vec<Geometry> = id.channels.iter().map(|c| c.geometry).collect();
                        Some((
                            frame::rotation(parts.nominal, &geo, tolerance),
                            reference_align::offset(&geo, &record, &r.omega),
                        ))
                    }
                    // A fit that does not converge is said by the fit below.
                    _ => None,
                }
            };
            let aligned = reference_align::align(first, parts.poses, load, &fit_to)?;
            Ok((
                Some(aligned.reference),
                aligned.alignment,
                (aligned.rotation_sd, aligned.relative_rotation_sd),
            ))
        }
        (_, _, reference) => Ok((reference, reference_align::Alignment::default(), (0.0, 0.0))),
    }
}

/// [`align_reference`]'s result: the reference, its alignment, the rotation's deviations.
pub(super) type AlignedReference = (
    Option<reference_rate::ReferenceAt>,
    reference_align::Alignment,
    (f64, f64),
);
