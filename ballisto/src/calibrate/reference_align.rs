//! What a real reference brings with it: a gyro's bias, its time offset against the
//! accelerometers, and its frame's rotation against the array.
//!
//! - **Bias**: in the static poses the reference reads its bias (and the Earth's rate, below
//!   a MEMS gyro's bias). Its mean over the poses, the deviation from their scatter (which
//!   holds a drifting bias's instability). Motion cannot tell it: a bias across a rotation
//!   looks like a turn of the frame, and the fit absorbs it (`ground-calibration`, 0.02 rad/s
//!   and a fixed-axis spin: the frame turned 4.4 mrad, motion saw 5 % of the bias).
//! - **Time offset**: with the geometry fitted to the reference, the array measures Ω on its
//!   own: per motion sample the field σ0, Ω′, Ω by Gauss–Newton from the reference's Ω (the
//!   sign is the reference's). A reference whose row stamped `t` reads the body's rate at
//!   `t − τ` differs from it by `Ω_ref − Ω ≈ b − τ Ω′` (Ω′ the array's own, `b` what bias is
//!   left), linear least squares weighted by each sample's Ω variance, over the samples whose
//!   centripetal reading stands out of the noise. Consecutive samples share their errors, so
//!   the deviation comes from the scatter of [`BATCHES`] batches of equal weight. The fit
//!   absorbs part of an offset, so the caller alternates fit and estimate (see
//!   [`super::calibrate_files`]).
//! - **Rotation**: not seen this way either — the fit has turned the whole geometry into the
//!   reference's frame. It is the mean rotation of the fitted geometry against the nominal
//!   one ([`super::frame::rotation`]), reported, not removed: the calibrated arrangement's
//!   frame is the reference's.

use nalgebra::{Matrix4, Vector3, Vector4};

use super::fit::{self, Geometry, Pose, Record};
use super::reference_rate::ReferenceAt;

/// Contiguous batches of motion whose estimates' scatter gives the offset's deviation.
pub const BATCHES: usize = 10;
/// Fewest motion samples with a determined Ω in every batch.
const MIN_PER_BATCH: usize = 30;
/// A bias this many deviations from zero is removed from the reference before the fit.
pub const SIGNIFICANT: f64 = 3.0;
/// A sample is used for the offset where its centripetal reading `|Ω|² · arm` is this many
/// times the channels' median noise.
pub const CENTRIPETAL_SNR: f64 = 10.0;
/// Fewest static poses for a bias (and its scatter).
const MIN_POSES: usize = 3;

/// The reference's bias at rest: the mean over the static poses of the reference's rows in
/// them, and its deviation per axis from the poses' scatter; `None` with fewer than
/// `MIN_POSES` (3) poses the reference covers.
pub fn rest_bias(reference: &ReferenceAt, poses: &[Pose]) -> Option<(Vector3<f64>, Vector3<f64>)> {
    let means: Vec<Vector3<f64>> = poses
        .iter()
        .filter_map(|p| {
            let rows: Vec<&Vector3<f64>> = p
                .samples
                .clone()
                .filter(|&k| reference.covered[k])
                .map(|k| &reference.omega[k])
                .collect();
            (2 * rows.len() >= p.samples.len() && !rows.is_empty())
                .then(|| rows.iter().copied().sum::<Vector3<f64>>() / rows.len() as f64)
        })
        .collect();
    if means.len() < MIN_POSES {
        return None;
    }
    let n = means.len() as f64;
    let mean = means.iter().sum::<Vector3<f64>>() / n;
    let var = means
        .iter()
        .map(|m| (m - mean).component_mul(&(m - mean)))
        .sum::<Vector3<f64>>()
        / (n - 1.0);
    Some((mean, (var / n).map(f64::sqrt)))
}

/// One sample's difference `Ω_ref − Ω`, the array's Ω′, and the weight `1 / var(Ω)`.
type Point = (Vector3<f64>, Vector3<f64>, f64);

/// Weighted least squares for `x = (b, τ)` in `Ω_ref − Ω = b − τ Ω′`.
fn solve(points: &[Point]) -> Option<Vector4<f64>> {
    let mut a = Matrix4::zeros();
    let mut rhs = Vector4::zeros();
    for (e, d, w) in points {
        for i in 0..3 {
            let mut h = Vector4::zeros();
            h[i] = 1.0;
            h[3] = -d[i];
            a += h * h.transpose() * *w;
            rhs += h * (e[i] * w);
        }
    }
    a.cholesky().map(|c| c.solve(&rhs))
}

/// The reference's time offset against the array with the geometry `geo` fitted to it
/// (`reference`: Ω per sample of the record), s, with its deviation and the samples used;
/// `None` where too few motion samples determine Ω to tell.
pub fn offset(
    geo: &[Geometry],
    record: &Record,
    reference: &[Vector3<f64>],
) -> Option<(f64, f64, usize)> {
    let seeds: Vec<Option<Vector3<f64>>> =
        record.motion.iter().map(|&k| Some(reference[k])).collect();
    let fields = fit::array_fields(geo, record, &seeds);
    // Where the centripetal readings are within the noise the per-sample solve keeps the
    // reference's Ω (MIMU4444 between its static poses: differences of 1e-8 rad/s against a
    // claimed deviation of 4e-3): only samples whose centripetal term stands out are used.
    let arm =
        (geo.iter().map(|g| g.position.norm_squared()).sum::<f64>() / geo.len() as f64).sqrt();
    let mut noise: Vec<f64> = geo.iter().map(|g| g.noise).collect();
    noise.sort_by(f64::total_cmp);
    let least_rate_sq = CENTRIPETAL_SNR * noise[noise.len() / 2] / arm.max(f64::MIN_POSITIVE);
    let points: Vec<Point> = record
        .motion
        .iter()
        .zip(fields.iter())
        .filter(|(&k, _)| reference[k].norm_squared() >= least_rate_sq)
        .filter_map(|(&k, f)| {
            let f = f.as_ref()?;
            (f.omega_var.is_finite() && f.omega_var > 0.0)
                .then(|| (reference[k] - f.omega, f.domega, 3.0 / f.omega_var))
        })
        .collect();
    if points.len() < BATCHES * MIN_PER_BATCH {
        return None;
    }
    let x = solve(&points)?;
    // Batches of equal weight, not of equal count (a few fast turns carry most of it).
    let total: f64 = points.iter().map(|p| p.2).sum();
    let mut batches = Vec::with_capacity(BATCHES);
    let (mut start, mut acc) = (0, 0.0);
    for (j, p) in points.iter().enumerate() {
        acc += p.2;
        let full = acc >= total * (batches.len() + 1) as f64 / BATCHES as f64
            && j + 1 - start >= MIN_PER_BATCH;
        if full || j + 1 == points.len() {
            if j + 1 - start >= MIN_PER_BATCH {
                batches.extend(solve(&points[start..=j]).map(|b| b[3]));
            }
            start = j + 1;
        }
    }
    log::debug!("reference offset: {} s, batches {batches:?}", x[3]);
    if batches.len() < BATCHES - 1 {
        return None;
    }
    let nb = batches.len() as f64;
    let mean = batches.iter().sum::<f64>() / nb;
    let var = batches.iter().map(|b| (b - mean).powi(2)).sum::<f64>() / (nb - 1.0);
    Some((x[3], (var / nb).sqrt(), points.len()))
}

/// Passes of fit and offset estimate at most: the first removes most of an offset, the
/// second measures the share the fit absorbs, the third confirms what is left is small.
pub const PASSES: usize = 6;
/// The alternation stops when what a pass finds is below this many of its deviations.
const SETTLED: f64 = 0.3;
/// The share of an offset the fit absorbs is taken as at most this (beyond, the passes are
/// not converging geometrically and each removes only what it finds).
const MAX_RATIO: f64 = 0.9;

/// The reference with its bias and offset removed, what was removed, and the deviations the
/// offset's uncertainty adds to the calibrated frame's rotations (rad).
pub struct Aligned {
    /// The reference at the sample instants, bias and offset removed.
    pub reference: ReferenceAt,
    /// What was found and removed.
    pub alignment: Alignment,
    /// The frame rotation's deviation due to the offset's.
    pub rotation_sd: f64,
    /// The deviation of the axes' rotation against the lever arms due to the offset's.
    pub relative_rotation_sd: f64,
}

/// The frame's rotation and the axes' rotation against the lever arms (rad) of a fitted
/// geometry against the nominal one ([`super::frame::rotation`]).
pub type Turn = (Vector3<f64>, Vector3<f64>);

/// One fit of the geometry to a reference: its [`Turn`] and the offset left ([`offset`]);
/// `None` where the fit does not converge.
pub type FitTo<'a> = dyn Fn(&ReferenceAt) -> Option<(Option<Turn>, Option<(f64, f64, usize)>)> + 'a;

/// Removes the reference's bias (at rest, where significant) and its time offset:
/// `load(offset)` reads the reference with its rows shifted by `offset`, `fit_to` fits the
/// geometry to it. The fit absorbs a share `q` of an offset (the geometry turns to follow a
/// lagging rate), so each pass finds `q` times the last one's: the rest of the geometric
/// series, `offset / (1 − q)`, is removed at once, and the deviation of what is found scales
/// the same way (MIMU4444: q up to 0.65; eight passes without it did not settle). The frame's
/// rotation follows the offset, so its deviation carries the offset's through the slope two
/// fits at different offsets show (one more fit where the first pass settled).
pub fn align(
    first: ReferenceAt,
    poses: &[Pose],
    load: impl Fn(f64) -> Result<ReferenceAt, Box<dyn std::error::Error>>,
    fit_to: &FitTo,
) -> Result<Aligned, Box<dyn std::error::Error>> {
    let mut alignment = Alignment {
        bias: rest_bias(&first, poses),
        ..Default::default()
    };
    let bias = match alignment.bias {
        Some((b, sd)) if (0..3).any(|i| b[i].abs() > SIGNIFICANT * sd[i]) => {
            alignment.bias_removed = true;
            b
        }
        _ => Vector3::zeros(),
    };
    let without_bias = |mut r: ReferenceAt| {
        r.omega.iter_mut().for_each(|w| *w -= bias);
        r
    };
    let mut r = without_bias(first);
    let mut removed = 0.0;
    let mut last: Option<f64> = None;
    // The offset applied and the frame's rotation the fit gave, per fit.
    let mut turned: Vec<(f64, Turn)> = Vec::new();
    for _ in 0..PASSES {
        let Some((rotation, found)) = fit_to(&r) else {
            break;
        };
        turned.extend(rotation.map(|rot| (removed, rot)));
        let Some((offset, sd, samples)) = found else {
            break;
        };
        let ratio = last
            .map(|l| offset / l)
            .filter(|q| (0.0..=MAX_RATIO).contains(q))
            .unwrap_or(0.0);
        last = Some(offset);
        removed += offset / (1.0 - ratio);
        alignment.offset = Some((removed, sd / (1.0 - ratio), samples));
        r = without_bias(load(removed)?);
        if offset.abs() <= SETTLED * sd {
            break;
        }
    }
    let (mut rotation_sd, mut relative_rotation_sd) = (0.0, 0.0);
    if let Some((_, sd, _)) = alignment.offset {
        if turned.len() == 1 && sd > 0.0 {
            let probe = without_bias(load(removed + sd)?);
            if let Some((Some(rot), _)) = fit_to(&probe) {
                turned.push((removed + sd, rot));
            }
        }
        if let [(t0, r0), (t1, r1), ..] = turned.as_slice() {
            if t1 != t0 {
                rotation_sd = (r1.0 - r0.0).norm() / (t1 - t0).abs() * sd;
                relative_rotation_sd = (r1.1 - r0.1).norm() / (t1 - t0).abs() * sd;
            }
        }
    }
    log::debug!("reference alignment: {alignment:?}, frame rotation per offset: {turned:?}");
    Ok(Aligned {
        reference: r,
        alignment,
        rotation_sd,
        relative_rotation_sd,
    })
}

/// The reference's bias and time offset as the calibration found and removed them.
#[derive(Clone, Copy, Debug, Default)]
pub struct Alignment {
    /// Bias at rest, rad/s (reference axes), and its deviation per axis; `None` with too few
    /// static poses.
    pub bias: Option<(Vector3<f64>, Vector3<f64>)>,
    /// Whether the bias was significant and removed before the fit.
    pub bias_removed: bool,
    /// Time offset, s (positive: the reference's row stamped `t` is the rate at `t − offset`,
    /// the reference lags), its deviation, and the motion samples that determined it —
    /// removed before the fit; `None` where the motion does not determine it.
    pub offset: Option<(f64, f64, usize)>,
}

impl Alignment {
    /// One phrase for the user.
    pub fn describe(&self) -> String {
        let v = |x: &Vector3<f64>| format!("[{:.1e}, {:.1e}, {:.1e}]", x.x, x.y, x.z);
        let bias = match self.bias {
            Some((b, sd)) => format!(
                "bias at rest {} ± {} rad/s ({})",
                v(&b),
                v(&sd),
                if self.bias_removed {
                    "removed before the fit"
                } else {
                    "not significant, not removed"
                }
            ),
            None => "bias not determined (fewer than 3 static poses)".into(),
        };
        let offset = match self.offset {
            Some((t, sd, n)) => format!(
                "time offset {:.2} ± {:.2} ms (the reference {}; from {n} motion samples; removed before the fit)",
                t * 1e3,
                sd * 1e3,
                if t >= 0.0 { "lagging" } else { "leading" }
            ),
            None => "time offset not determined by the record's motion".into(),
        };
        format!("{bias}, {offset}")
    }
}

/// What a calibration found of its reference.
#[derive(Clone, Copy, Debug)]
pub struct Found {
    /// Bias and time offset.
    pub alignment: Alignment,
    /// The reference frame's rotation against the nominal arrangement (rad, a rotation
    /// vector) and its deviation (the calibrated frame's rotation sd); `None` where the
    /// geometry cannot tell it.
    pub rotation: Option<(Vector3<f64>, f64)>,
    /// Its common scale factor as fitted, where its scale was not taken as exact
    /// ([`super::fit::RatePrior`]).
    pub scale: Option<f64>,
}

impl Found {
    /// One sentence for the user.
    pub fn describe(&self) -> String {
        let mut text = format!("the reference: {}", self.alignment.describe());
        if let Some(c) = self.scale {
            text.push_str(&format!(
                "; its common scale factor {c:.4} (fitted, the array's size held at the drawing's)"
            ));
        }
        if let Some((r, sd)) = self.rotation {
            let axis = r / r.norm().max(f64::MIN_POSITIVE);
            text.push_str(&format!(
                "; its frame is turned {:.2} mrad (sd {:.2}) about [{:.3}, {:.3}, {:.3}] from the nominal arrangement's, and the calibrated arrangement is in the reference's frame",
                r.norm() * 1e3,
                sd * 1e3,
                axis.x,
                axis.y,
                axis.z
            ));
        }
        text
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibrate::reference_rate::Dropped;

    /// A reference reading `bias` plus a wobble of ±1e-4 rad/s, covering every sample.
    fn reference(bias: Vector3<f64>, n: usize) -> ReferenceAt {
        ReferenceAt {
            omega: (0..n)
                .map(|k| bias + Vector3::repeat(if k % 2 == 0 { 1e-4 } else { -1e-4 }))
                .collect(),
            covered: vec![true; n],
            dropped: Dropped::default(),
        }
    }

    fn poses(count: usize) -> Vec<Pose> {
        (0..count)
            .map(|p| Pose {
                samples: p * 100..p * 100 + 50,
                mean: Vec::new(),
            })
            .collect()
    }

    #[test]
    fn the_bias_at_rest_is_the_mean_over_the_poses() {
        let bias = Vector3::new(0.01, -0.02, 0.015);
        let (found, sd) = rest_bias(&reference(bias, 1000), &poses(5)).unwrap();
        assert!((found - bias).norm() < 1e-12, "{found}");
        assert!(sd.iter().all(|s| s.is_finite() && *s < 1e-9), "{sd}");
        // A pose the reference does not cover is left out; fewer than three poses: no bias.
        let mut r = reference(bias, 1000);
        r.covered[100..150].iter_mut().for_each(|c| *c = false);
        r.covered[200..250].iter_mut().for_each(|c| *c = false);
        r.covered[300..350].iter_mut().for_each(|c| *c = false);
        assert!(rest_bias(&r, &poses(5)).is_none());
        assert!(rest_bias(&reference(bias, 1000), &poses(2)).is_none());
    }
}
