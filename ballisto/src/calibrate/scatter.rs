//! How far each kind of datum scatters about the model, per channel: the weights of the fit
//! (variance components, estimated from the fit's own residuals as in Helmert's method).
//!
//! A static pose's mean reading carries the white noise averaged over its samples and a floor
//! the averaging does not remove (the parts' nonlinearity, temperature, the pose not quite
//! still); a motion sample carries the white noise and whatever the model leaves out in
//! motion. With the datasheet's noise as the weight of both, a real record's motion — its
//! residual 15–25 × the noise on the MIMU4444 board, white from sample to sample, and
//! thousands of samples against twenty poses — outweighs the poses in every parameter it
//! touches: the scales and axes the poses fix to a few mg were dragged by the motion's
//! misfit, and six combinations the motion sees only through the axes' milliradian tilts
//! (each axis group's common translation) ran 6–14 mm from the drawing. Weighted by what each
//! kind of datum actually scatters, the poses fix what they see and the motion adds what only
//! it sees, at its real deviation.

use super::fit::{Field, Geometry, Record};
use nalgebra::Vector3;

/// A weight is re-estimated only when it changes by more than this factor (its square root
/// for a scatter): below, the record fits the declared noise well enough (simulated white
/// noise: the motion's residual within 10 % of it) and the fit is not run again.
pub const REWEIGHT_FACTOR: f64 = 2.0;

/// Each channel's scatter by kind of datum (m/s²).
#[derive(Clone, Debug)]
pub struct Scatter {
    /// White noise per sample: the declared (or measured at rest) noise.
    pub white: Vec<f64>,
    /// Floor of a pose mean's scatter: what averaging over the pose's samples does not remove.
    pub pose: Vec<f64>,
    /// A motion sample's scatter about the model (never below `white`).
    pub motion: Vec<f64>,
}

impl Scatter {
    /// White noise only: the geometries' `noise`.
    pub fn white(geo: &[Geometry]) -> Self {
        let white: Vec<f64> = geo.iter().map(|g| g.noise).collect();
        Scatter {
            pose: vec![0.0; white.len()],
            motion: white.clone(),
            white,
        }
    }

    /// Weight of channel `i`'s mean over a pose of `len` samples: `1 / (white² / len + pose²)`.
    pub fn pose_weight(&self, i: usize, len: usize) -> f64 {
        1.0 / (self.white[i] * self.white[i] / len as f64 + self.pose[i] * self.pose[i])
    }

    /// The scatter of `geo`'s residuals on `record` (with the motion `fields` fitted for it and
    /// each pose's `gravity`): per channel the RMS over the motion samples, corrected for the
    /// field's `unknowns` per sample, and the floor of the pose means (their mean square less
    /// the averaged white noise, corrected for the gravity direction's two unknowns).
    pub fn measured(
        &self,
        geo: &[Geometry],
        record: &Record,
        fields: &[Option<Field>],
        gravity: &[Vector3<f64>],
        unknowns: usize,
    ) -> Scatter {
        let n = geo.len();
        let present = |row: &[f64]| row.iter().filter(|p| p.is_finite()).count() as f64;
        // Per channel: the sum over the poses of the squared residual (corrected for the
        // gravity direction's unknowns) and of what the averaged white noise explains.
        let mut pose_sum = vec![0.0; n];
        let mut pose_white = vec![0.0; n];
        let mut pose_count = vec![0usize; n];
        for (pose, gk) in record.poses.iter().zip(gravity.iter()) {
            let m = present(&pose.mean);
            if m <= 2.0 {
                continue;
            }
            let share = (m - 2.0) / m;
            for (i, (g, mean)) in geo.iter().zip(pose.mean.iter()).enumerate() {
                let r = mean - g.reading(gk);
                if r.is_finite() {
                    let averaged = self.white[i] * self.white[i] / pose.samples.len() as f64;
                    pose_sum[i] += r * r / share;
                    pose_white[i] += averaged;
                    pose_count[i] += 1;
                }
            }
        }
        let q = unknowns as f64;
        let mut sum = vec![0.0; n];
        let mut count = vec![0usize; n];
        for (&k, field) in record.motion.iter().zip(fields.iter()) {
            let Some(field) = field else {
                continue;
            };
            let row = &record.rows[k];
            let m = present(row);
            if m <= q {
                continue;
            }
            let share = (m - q) / m;
            let fm = field.m(&record.gamma);
            for (i, (g, p)) in geo.iter().zip(row.iter()).enumerate() {
                let e = p - field.reading(g, &fm);
                if e.is_finite() {
                    sum[i] += e * e / share;
                    count[i] += 1;
                }
            }
        }
        Scatter {
            white: self.white.clone(),
            pose: (0..n)
                .map(|i| match pose_count[i] {
                    0 => self.pose[i],
                    // A floor only where the white noise cannot explain the residuals: their
                    // sum beyond 3 deviations of its χ² (twenty poses' sum scatters by a
                    // third; a chance excess would reweight a record that fits).
                    c if pose_sum[i] > pose_white[i] * (1.0 + 3.0 * (2.0 / c as f64).sqrt()) => {
                        ((pose_sum[i] - pose_white[i]) / c as f64).sqrt()
                    }
                    _ => 0.0,
                })
                .collect(),
            motion: (0..n)
                .map(|i| match count[i] {
                    0 => self.motion[i],
                    c => (sum[i] / c as f64).sqrt().max(self.white[i]),
                })
                .collect(),
        }
    }

    /// Whether `other` changes some channel's weight (a motion sample's, or a pose mean's
    /// over `pose_len` samples) by more than [`REWEIGHT_FACTOR`].
    pub fn reweights(&self, other: &Scatter, pose_len: usize) -> bool {
        let far = |a: f64, b: f64| a > REWEIGHT_FACTOR * b || b > REWEIGHT_FACTOR * a;
        (0..self.white.len()).any(|i| {
            far(
                self.motion[i] * self.motion[i],
                other.motion[i] * other.motion[i],
            ) || far(
                1.0 / self.pose_weight(i, pose_len),
                1.0 / other.pose_weight(i, pose_len),
            )
        })
    }

    /// Channel `i`'s scatter per sample at rest: its white noise and the floor its pose means
    /// show, `√(white² + pose²)` (m/s²).
    pub fn at_rest(&self, i: usize) -> f64 {
        self.white[i].hypot(self.pose[i])
    }

    /// Sets every geometry's `noise` to its channel's motion scatter (what the per-sample
    /// field solves and the estimator weigh by).
    pub fn weigh_motion(&self, geo: &mut [Geometry]) {
        for (g, s) in geo.iter_mut().zip(self.motion.iter()) {
            g.noise = *s;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn white(noise: f64, n: usize) -> Scatter {
        Scatter {
            white: vec![noise; n],
            pose: vec![0.0; n],
            motion: vec![noise; n],
        }
    }

    #[test]
    fn the_scatter_at_rest_adds_the_floor_to_the_white_noise() {
        let mut s = white(0.03, 1);
        assert_eq!(s.at_rest(0), 0.03);
        s.pose[0] = 0.04;
        assert!((s.at_rest(0) - 0.05).abs() < 1e-12);
    }

    #[test]
    fn a_pose_mean_averages_the_white_noise_but_not_the_floor() {
        let mut s = white(0.01, 1);
        assert!((s.pose_weight(0, 100) - 1e6).abs() < 1e-6);
        s.pose[0] = 0.001;
        assert!((s.pose_weight(0, 100) - 1.0 / 2e-6).abs() < 1e-3);
    }

    #[test]
    fn only_a_weight_changed_by_more_than_the_factor_reweights() {
        let base = white(0.01, 2);
        let mut near = base.clone();
        near.motion[1] = 0.013; // variance × 1.69
        near.pose[0] = 0.0005; // a 100-sample pose's variance × 1.25
        assert!(!base.reweights(&near, 100));
        let mut motion = base.clone();
        motion.motion[1] = 0.015; // × 2.25
        assert!(base.reweights(&motion, 100));
        let mut pose = base.clone();
        pose.pose[0] = 0.002; // × 5
        assert!(base.reweights(&pose, 100));
    }
}
