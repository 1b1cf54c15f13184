//! Validation inside `ballisto calibrate`: part of the record's motion is held out of the fit
//! — every [`HOLD_EVERY`]th stretch of [`HOLD_BLOCK_S`] — and the nominal and the calibrated
//! geometry are scored on it alone: the readings' residual in the declared noise (the field
//! re-estimated per sample), Ω against the reference where one is given, and the share of rows
//! the estimator flags "residual high" with each file's declared noise. A calibration that
//! does not improve the held-out part is refused (`calibrate --force` writes it with the
//! warning in the file): a fit that follows one record's noise, or a model the record does
//! not fit, shows there and nowhere else.

use nalgebra::Vector3;

use super::fit::{self, Geometry, RateSource, Record};
use super::reference_rate::ReferenceAt;

/// Length of one stretch of motion, s: longer than the motion's own correlation (a stretch
/// held out is not interpolated from its neighbours), short enough that every kind of motion
/// in a record has stretches on both sides.
pub const HOLD_BLOCK_S: f64 = 2.0;
/// One stretch in this many is held out (a fifth of the motion).
pub const HOLD_EVERY: usize = 5;
/// Fewer held-out samples than this: the calibration is not validated (and says so).
pub const HOLD_MIN: usize = 100;

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
#[derive(Clone, Copy, Debug)]
pub struct Score {
    /// RMS over the channels of each channel's RMS residual over its declared noise.
    pub residual: f64,
    /// RMS of |Ω − reference| (rad/s) over the held-out samples the reference covers.
    pub omega: Option<f64>,
    /// Share of the held-out samples flagged residual high (64) by the estimator.
    pub flagged: f64,
}

/// The held-out part: the nominal and the calibrated geometry's scores.
#[derive(Clone, Copy, Debug)]
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
    /// reference, a lower Ω error.
    pub fn improved(&self) -> bool {
        let omega = match (self.nominal.omega, self.calibrated.omega) {
            (Some(n), Some(c)) => c < n,
            _ => true,
        };
        self.calibrated.residual < self.nominal.residual && omega
    }

    /// One sentence: the figures, nominal → calibrated.
    pub fn describe(&self) -> String {
        let omega = match (self.nominal.omega, self.calibrated.omega) {
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
    let omega = reference.and_then(|r| {
        let errors: Vec<f64> = held
            .iter()
            .filter(|&&k| r.covered[k])
            .map(|&k| (run[k].0 - r.omega[k]).norm_squared())
            .collect();
        (!errors.is_empty()).then(|| (errors.iter().sum::<f64>() / errors.len() as f64).sqrt())
    });
    let flag = estimator_core::Flags::RESIDUAL_HIGH;
    let flagged =
        held.iter().filter(|&&k| run[k].1 & flag != 0).count() as f64 / held.len().max(1) as f64;
    Ok(Score {
        residual,
        omega,
        flagged,
    })
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
}
