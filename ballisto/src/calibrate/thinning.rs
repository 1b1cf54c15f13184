//! A long record's motion thinned to what the fit needs: the per-sample field solves of every
//! alternation are most of a calibration's time (a one-hour record at 62.5 Hz, 56 806 motion
//! samples: 72 s, of which the estimator's runs were 3 %), and a few minutes of varied motion
//! determine the geometry to well within the model error a real board leaves.
//!
//! Motion is cut into the validation's stretches of [`HOLD_BLOCK_S`] and each stretch keeps
//! its first part, so that the kept samples stay consecutive (self-calibration's kinematic tie
//! integrates Ω′ over runs of consecutive samples), every stretch of the record still
//! contributes, and every fifth stretch is still held out in the same share.

use super::holdout::HOLD_BLOCK_S;

/// Motion samples the fit uses at most.
pub const MAX_MOTION: usize = 20_000;

/// The motion samples kept (at most about [`MAX_MOTION`]) and the thinning factor (1: all
/// kept). `motion` indexes `times` in increasing order.
pub fn thin(motion: &[usize], times: &[f64]) -> (Vec<usize>, usize) {
    let factor = motion.len().div_ceil(MAX_MOTION).max(1);
    let Some(&first) = motion.first() else {
        return (Vec::new(), 1);
    };
    if factor == 1 {
        return (motion.to_vec(), 1);
    }
    let t0 = times[first];
    let stretch = |k: usize| ((times[k] - t0) / HOLD_BLOCK_S) as usize;
    let mut kept = Vec::with_capacity(motion.len() / factor + 1);
    let mut start = 0;
    while start < motion.len() {
        let s = stretch(motion[start]);
        let end = start
            + motion[start..]
                .iter()
                .take_while(|&&k| stretch(k) == s)
                .count();
        let keep = (end - start).div_ceil(factor);
        kept.extend_from_slice(&motion[start..start + keep]);
        start = end;
    }
    (kept, factor)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_short_record_keeps_all_its_motion() {
        let times: Vec<f64> = (0..5000).map(|k| k as f64 * 0.01).collect();
        let motion: Vec<usize> = (100..4000).collect();
        assert_eq!(thin(&motion, &times), (motion.clone(), 1));
    }

    #[test]
    fn a_long_record_keeps_the_first_part_of_every_stretch() {
        // One hour at 100 Hz, all of it motion.
        let times: Vec<f64> = (0..360_000).map(|k| k as f64 * 0.01).collect();
        let motion: Vec<usize> = (0..times.len()).collect();
        let (kept, factor) = thin(&motion, &times);
        assert_eq!(factor, 18);
        assert!(kept.len() <= MAX_MOTION + 1800, "{}", kept.len());
        // Every 2 s stretch (200 samples) keeps its first 12, consecutive.
        assert_eq!(kept.len(), 1800 * 12);
        assert_eq!(&kept[..13], &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 200]);
        // The held-out share stays a fifth.
        let (fitted, held) = super::super::holdout::split(&kept, &times);
        assert_eq!(held.len() * 5, fitted.len() + held.len());
    }
}
