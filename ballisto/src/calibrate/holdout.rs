//! Validation inside `ballisto calibrate`: part of the record's motion is held out of the fit
//! — every [`HOLD_EVERY`]th stretch of [`HOLD_BLOCK_S`] — and the nominal and the calibrated
//! geometry are scored on it alone: the readings' residual in the declared noise (the field
//! re-estimated per sample), Ω against the reference where one is given, and the share of rows
//! the estimator flags "residual high" with each file's declared noise. A calibration that
//! does not improve the held-out part is refused (`calibrate --force` writes it with the
//! warning in the file): a fit that follows one record's noise, or a model the record does
//! not fit, shows there and nowhere else.

use std::cmp::Ordering;

use nalgebra::Vector3;

use super::fit::{self, Geometry, RateSource, Record, Tolerance};
use super::reference_rate::ReferenceAt;
use super::{reference_rate, CalibrateJob};
use estimator_core::Model;

/// Length of one stretch of motion, s: longer than the motion's own correlation (a stretch
/// held out is not interpolated from its neighbours), short enough that every kind of motion
/// in a record has stretches on both sides.
pub const HOLD_BLOCK_S: f64 = 2.0;
/// One stretch in this many is held out (a fifth of the motion).
pub const HOLD_EVERY: usize = 5;
/// Fewer held-out samples than this: the calibration is not validated (and says so).
pub const HOLD_MIN: usize = 100;
/// Standard errors by which the calibrated Ω error must exceed the nominal one on the held-out
/// stretches to count as higher ([`Validation::omega_higher`]; one-sided, about 2.5 % by
/// chance on a normal mean).
pub const SIGNIFICANT: f64 = 2.0;

/// The motion samples fitted and those held out: stretches of [`HOLD_BLOCK_S`] counted from
/// the first motion sample, every [`HOLD_EVERY`]th held out.
pub fn split(motion: &[usize], times: &[f64]) -> (Vec<usize>, Vec<usize>) {
    let Some(&first) = motion.first() else {
        return (Vec::new(), Vec::new());
    };
    let t0 = times[first];
    motion.iter().partition(|&&k| {
        let block = ((times[k] - t0) / HOLD_BLOCK_S) as usize;
        block % HOLD_EVERY != HOLD_EVERY - 1
    })
}

/// One estimator run over the record: Ω and the flags per sample.
pub type Run = [(Vector3<f64>, u16)];

/// One geometry's figures on the held-out samples.
#[derive(Clone, Debug)]
pub struct Score {
    /// RMS over the channels of each channel's RMS residual over its declared noise.
    pub residual: f64,
    /// RMS of |Ω − reference| (rad/s) over the held-out samples the reference covers.
    pub omega: Option<f64>,
    /// Per held-out stretch, the mean of |Ω − reference|² (rad²/s²) over its covered samples
    /// (stretches in time order; none without a reference).
    pub omega_stretches: Vec<f64>,
    /// Share of the held-out samples flagged residual high (64) by the estimator.
    pub flagged: f64,
}

/// The held-out part: the nominal and the calibrated geometry's scores.
#[derive(Clone, Debug)]
pub struct Validation {
    /// Held-out samples.
    pub samples: usize,
    /// With the nominal geometry (the arrangement file's, its declared noise).
    pub nominal: Score,
    /// With the calibrated geometry (the noise it declares).
    pub calibrated: Score,
}

impl Validation {
    /// Whether the calibration improves the held-out part: a lower residual and, with a
    /// reference, an Ω error not higher ([`Self::omega_higher`]).
    pub fn improved(&self) -> bool {
        self.calibrated.residual < self.nominal.residual && !self.omega_higher()
    }

    /// Whether the calibrated Ω error on the held-out part is higher than the nominal one by
    /// more than the comparison can tell from chance ([`paired`]: both geometries on the same
    /// stretches). With fewer than three stretches any excess counts. A few per cent either
    /// way on ten stretches of hand-held motion is chance: on the MIMU4444 board the
    /// estimate's Ω error there is a quarter of |Ω| (the model's misfit in fast motion)
    /// whatever the geometry, and a plain comparison refused or accepted the same calibration
    /// with the noise it declares.
    pub fn omega_higher(&self) -> bool {
        let (n, c) = (
            &self.nominal.omega_stretches,
            &self.calibrated.omega_stretches,
        );
        self.omega_not_lower()
            && (n.len() != c.len() || n.len() < 3 || paired(c, n) == Ordering::Greater)
    }

    /// Whether, with a reference, the calibrated Ω error on the held-out part is higher than
    /// the nominal one at all (by chance or not).
    pub fn omega_not_lower(&self) -> bool {
        matches!((self.nominal.omega, self.calibrated.omega), (Some(n), Some(c)) if c > n)
    }

    /// One sentence: the figures, nominal → calibrated.
    pub fn describe(&self) -> String {
        let omega = match (self.nominal.omega, self.calibrated.omega) {
            (Some(n), Some(c)) if self.omega_not_lower() && !self.omega_higher() => format!(
                ", Ω against the reference {n:.3e} → {c:.3e} rad/s (higher, within the scatter of its {} stretches)",
                self.calibrated.omega_stretches.len()
            ),
            (Some(n), Some(c)) => format!(", Ω against the reference {n:.3e} → {c:.3e} rad/s"),
            _ => String::new(),
        };
        format!(
            "held out of the fit ({} samples: every {HOLD_EVERY}th {HOLD_BLOCK_S} s of motion), nominal → calibrated: residual {:.2} → {:.2} of the declared noise{omega}, rows flagged residual high {:.1} % → {:.1} %",
            self.samples,
            self.nominal.residual,
            self.calibrated.residual,
            100.0 * self.nominal.flagged,
            100.0 * self.calibrated.flagged
        )
    }
}

/// Whether the mean square errors `a` are higher (`Greater`) or lower (`Less`) than `b`
/// beyond chance, or neither (`Equal`), paired by stretch (the same stretches in both, in the
/// same order): the mean of the stretches' differences against [`SIGNIFICANT`] of its
/// standard errors. Fewer than two stretches tell nothing (`Equal`).
pub fn paired(a: &[f64], b: &[f64]) -> Ordering {
    let d: Vec<f64> = a.iter().zip(b).map(|(a, b)| a - b).collect();
    if d.len() < 2 {
        return Ordering::Equal;
    }
    let k = d.len() as f64;
    let mean = d.iter().sum::<f64>() / k;
    let var = d.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (k - 1.0);
    let bound = SIGNIFICANT * (var / k).sqrt();
    if mean > bound {
        Ordering::Greater
    } else if mean < -bound {
        Ordering::Less
    } else {
        Ordering::Equal
    }
}

/// Scores `geo` on the held-out samples `held` of `record`: `run` is the estimator over the
/// whole record on `geo` (with the noise `geo` declares), `declared` the noise each channel's
/// residual is measured in (the same for both geometries compared).
pub fn score(
    geo: &[Geometry],
    declared: &[f64],
    record: &Record,
    held: &[usize],
    run: &Run,
    reference: Option<&ReferenceAt>,
) -> Result<Score, String> {
    let held_record = Record {
        poses: &[],
        motion: held,
        ..*record
    };
    let residuals = match reference {
        Some(r) => fit::residuals(geo, &held_record, &RateSource::Reference(&r.omega))?,
        None => {
            let rates = |_: &[Geometry]| Ok(run.iter().map(|(w, _)| Some(*w)).collect());
            fit::residuals(geo, &held_record, &RateSource::Estimator(&rates))?
        }
    };
    let ratios: Vec<f64> = residuals
        .per_channel
        .iter()
        .zip(declared.iter())
        .map(|(r, n)| r / n)
        .filter(|x| x.is_finite())
        .collect();
    let residual = (ratios.iter().map(|x| x * x).sum::<f64>() / ratios.len().max(1) as f64).sqrt();
    // Per stretch (held-out samples closer than a stretch's length in time), the sum of the
    // squared Ω errors and their count.
    let mut stretches: Vec<(f64, usize)> = Vec::new();
    if let Some(r) = reference {
        let mut last = f64::NEG_INFINITY;
        for &k in held {
            let t = record.times[k];
            if t - last > HOLD_BLOCK_S || stretches.is_empty() {
                stretches.push((0.0, 0));
            }
            last = t;
            match stretches.last_mut() {
                Some(s) if r.covered[k] => {
                    s.0 += (run[k].0 - r.omega[k]).norm_squared();
                    s.1 += 1;
                }
                _ => {}
            }
        }
    }
    stretches.retain(|s| s.1 > 0);
    let (sum, count) = stretches
        .iter()
        .fold((0.0, 0), |(a, n), s| (a + s.0, n + s.1));
    let omega = (count > 0).then(|| (sum / count as f64).sqrt());
    let omega_stretches = stretches.iter().map(|s| s.0 / s.1 as f64).collect();
    let flag = estimator_core::Flags::RESIDUAL_HIGH;
    let flagged =
        held.iter().filter(|&&k| run[k].1 & flag != 0).count() as f64 / held.len().max(1) as f64;
    Ok(Score {
        residual,
        omega,
        omega_stretches,
        flagged,
    })
}

/// What the held-out validation needs: the record and its split motion, the rate source, the
/// nominal geometry with the declared noise, and how to run the estimator on it.
pub struct HeldOut<'a> {
    /// The record (its whole motion).
    pub record: &'a Record<'a>,
    /// The motion the check fits on.
    pub fit_motion: &'a [usize],
    /// The motion held out of it.
    pub held_out: &'a [usize],
    /// Where Ω comes from.
    pub source: &'a RateSource<'a>,
    /// The nominal geometry.
    pub nominal: &'a [Geometry],
    /// Each channel's declared noise.
    pub declared: &'a [f64],
    /// Channel names.
    pub names: &'a [String],
    /// The estimator's model.
    pub model: Model,
    /// The reference rate at the sample instants, if any.
    pub reference: Option<&'a reference_rate::ReferenceAt>,
}

/// The same fit on the record without the held-out stretches, and both geometries (nominal
/// and that fit's) scored on them; or why the record cannot be validated so.
pub fn validate_on_held_out(
    h: &HeldOut,
    job: &CalibrateJob,
    tolerance: &Tolerance,
    bar: &indicatif::ProgressBar,
) -> Result<Validation, String> {
    let stage_len = fit::MAX_ALTERNATIONS as u64;
    let check_progress = |it: usize| bar.set_position(stage_len + it as u64);
    // Validation: the same fit on the record without the held-out stretches, both geometries
    // scored on them. The file written is the fit on the whole record (it is at least as well
    // determined; held-out stretches can hold the ramps that separate the axes' rotation from
    // the lever arms: the self-calibrated Ω of `ground-calibration` went from 1.0 to 1.85 ×
    // ideal parts when the file was the fit without them).
    let check = if h.held_out.len() < HOLD_MIN {
        Err(format!(
            "the record's motion is too short to hold {} samples of it out of the fit",
            HOLD_MIN
        ))
    } else {
        bar.set_position(stage_len);
        bar.set_message("fit without the held-out stretches");
        let without = Record {
            motion: h.fit_motion,
            progress: &check_progress,
            ..*h.record
        };
        match fit::identify(h.nominal, &without, h.source, job.fit, tolerance) {
            Ok(c) if c.last_step <= fit::CONVERGED_STEP => Ok(c),
            Ok(c) => Err(format!(
                "the fit without the held-out stretches did not converge ({} alternations)",
                c.iterations
            )),
            Err(e) => Err(format!("the fit without the held-out stretches: {e}")),
        }
    };
    bar.set_position(2 * stage_len);
    bar.set_message("scoring the held-out stretches");
    match check {
        Err(why) => Err(why),
        Ok(check) => {
            let check_noise = super::written_noise(&check, h.declared);
            let nominal_geo: Vec<Geometry> = h
                .nominal
                .iter()
                .zip(h.declared.iter())
                .map(|(g, &noise)| Geometry { noise, ..*g })
                .collect();
            let calibrated_geo: Vec<Geometry> = check
                .channels
                .iter()
                .zip(check_noise.iter())
                .map(|(c, &noise)| Geometry {
                    noise,
                    ..c.geometry
                })
                .collect();
            let score = |geo: &[Geometry]| -> Result<Score, String> {
                let run =
                    super::estimator_run(geo, h.names, h.model, h.record.times, h.record.rows)?;
                score(geo, h.declared, h.record, h.held_out, &run, h.reference)
            };
            Ok(Validation {
                samples: h.held_out.len(),
                nominal: score(&nominal_geo)?,
                calibrated: score(&calibrated_geo)?,
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_fifth_stretch_of_motion_is_held_out() {
        // 100 Hz, motion from 10 s to 30 s with a pose between 20 and 22 s.
        let times: Vec<f64> = (0..3000).map(|k| k as f64 * 0.01).collect();
        let motion: Vec<usize> = (1000..2000).chain(2200..3000).collect();
        let (fitted, held) = split(&motion, &times);
        assert_eq!(fitted.len() + held.len(), motion.len());
        // Stretches 10–12, 12–14, …: the fifth (18–20 s) and the tenth (28–30 s) held out.
        assert!(held.iter().all(|&k| (1800..2000).contains(&k) || k >= 2800));
        assert_eq!(held.len(), 400);
        assert_eq!(split(&[], &times), (Vec::new(), Vec::new()));
    }

    /// A validation whose nominal and calibrated Ω errors per stretch are `n` and `c`.
    fn validation(n: &[f64], c: &[f64]) -> Validation {
        let score = |s: &[f64]| Score {
            residual: 1.0,
            omega: Some((s.iter().sum::<f64>() / s.len() as f64).sqrt()),
            omega_stretches: s.to_vec(),
            flagged: 0.0,
        };
        Validation {
            samples: 100 * n.len(),
            nominal: score(n),
            calibrated: score(c),
        }
    }

    #[test]
    fn a_higher_omega_counts_only_beyond_the_scatter_of_its_stretches() {
        let nominal = [20.0, 30.0, 25.0, 40.0, 35.0, 22.0];
        // Higher by 1 on average, the stretches' differences scattered by ±5: chance.
        let within = [26.0, 25.0, 31.0, 36.0, 41.0, 17.0];
        let v = validation(&nominal, &within);
        assert!(v.calibrated.omega > v.nominal.omega);
        assert!(!v.omega_higher());
        assert!(v
            .describe()
            .contains("within the scatter of its 6 stretches"));
        // Higher by 2 on every stretch: not chance.
        let beyond: Vec<f64> = nominal.iter().map(|x| x + 2.0).collect();
        assert!(validation(&nominal, &beyond).omega_higher());
        // Lower: never higher.
        let lower: Vec<f64> = nominal.iter().map(|x| x - 2.0).collect();
        assert!(!validation(&nominal, &lower).omega_higher());
        // Two stretches cannot show a scatter: any excess counts.
        assert!(validation(&[20.0, 30.0], &[30.0, 21.0]).omega_higher());
    }
}
