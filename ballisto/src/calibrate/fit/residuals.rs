//! What a geometry leaves unexplained in a record.

use crate::calibrate::scatter::Scatter;

use super::*;

/// What a geometry leaves unexplained in a record (the field re-estimated for it).
#[derive(Clone, Debug, Default)]
pub struct Residuals {
    /// Per channel, the RMS residual (m/s²): motion samples one by one, each pose by its
    /// mean weighted by its samples.
    pub per_channel: Vec<f64>,
    /// Per sample used (its index in the record), the RMS over the channels of the residual
    /// (m/s²); in a pose, of the pose's mean residual (what the noise does not average away).
    pub per_sample: Vec<(usize, f64)>,
}

/// The residuals of every channel with the geometry `geo` ([`Residuals`]).
pub fn residuals(
    geo: &[Geometry],
    record: &Record,
    rate: &RateSource,
) -> Result<Residuals, String> {
    let omega = initial_rates(geo, record, rate)?;
    let fields = motion_fields(geo, record, &omega, omega_unknown(rate, record));
    let gravity = pose_gravity(geo, record.poses, &Scatter::white(geo));
    let n = geo.len();
    let mut sum = vec![0.0; n];
    let mut count = vec![0usize; n];
    let mut per_sample = Vec::new();
    for (pose, gk) in record.poses.iter().zip(gravity.iter()) {
        let res: Vec<f64> = (0..n).map(|i| pose.mean[i] - geo[i].reading(gk)).collect();
        for (i, r) in res.iter().enumerate() {
            if r.is_finite() {
                sum[i] += r * r * pose.samples.len() as f64;
                count[i] += pose.samples.len();
            }
        }
        if let Some(v) = finite_rms(&res) {
            per_sample.extend(pose.samples.clone().map(|k| (k, v)));
        }
    }
    for (&k, field) in record.motion.iter().zip(fields.iter()) {
        let Some(field) = field else {
            continue;
        };
        let m = field.m(&record.gamma);
        let res: Vec<f64> = (0..n)
            .map(|i| {
                let g = &geo[i];
                record.rows[k][i] - field.reading(g, &m)
            })
            .collect();
        for (i, r) in res.iter().enumerate() {
            if r.is_finite() {
                sum[i] += r * r;
                count[i] += 1;
            }
        }
        if let Some(v) = finite_rms(&res) {
            per_sample.push((k, v));
        }
    }
    per_sample.sort_by_key(|(k, _)| *k);
    let per_channel = sum
        .iter()
        .zip(count.iter())
        .map(|(s, &c)| {
            if c > 0 {
                (s / c as f64).sqrt()
            } else {
                f64::NAN
            }
        })
        .collect();
    Ok(Residuals {
        per_channel,
        per_sample,
    })
}

/// The RMS of the finite values of `r` (`None` if there are none).
pub(super) fn finite_rms(r: &[f64]) -> Option<f64> {
    let (s, c) = r
        .iter()
        .filter(|v| v.is_finite())
        .fold((0.0, 0usize), |(s, c), v| (s + v * v, c + 1));
    (c > 0).then(|| (s / c as f64).sqrt())
}
