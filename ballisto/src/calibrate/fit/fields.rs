//! The field at each sample for a geometry: the poses' gravity, the motion's σ0, Ω′ and Ω
//! (Gauss–Newton per sample), outliers set aside.

use crate::calibrate::scatter::Scatter;
use estimator_core::G0;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use super::*;

/// The gravity direction of each pose (|g| = G0), by least squares over the channels.
pub(in crate::calibrate) fn pose_gravity(
    geo: &[Geometry],
    poses: &[Pose],
    scatter: &Scatter,
) -> Vec<Vector3<f64>> {
    poses
        .iter()
        .map(|pose| {
            let mut a = Matrix3::zeros();
            let mut b = Vector3::zeros();
            for (i, (g, m)) in geo.iter().zip(pose.mean.iter()).enumerate() {
                if !m.is_finite() {
                    continue;
                }
                let k = g.axis * g.scale;
                let w = scatter.pose_weight(i, pose.samples.len());
                a += k * k.transpose() * w;
                b += k * ((m - g.bias) * w);
            }
            let v = a.lu().solve(&b).unwrap_or_else(Vector3::zeros);
            if v.norm() > 0.0 {
                v * (G0 / v.norm())
            } else {
                v
            }
        })
        .collect()
}

/// Ω at every motion sample from the source, before any refinement.
pub(super) fn initial_rates(
    geo: &[Geometry],
    record: &Record,
    rate: &RateSource,
) -> Result<Vec<Option<Vector3<f64>>>, String> {
    Ok(match rate {
        RateSource::Reference(w) => record.motion.iter().map(|&k| Some(w[k])).collect(),
        RateSource::Estimator(run) => {
            let all = run(geo)?;
            record.motion.iter().map(|&k| all[k]).collect()
        }
    })
}

/// The field at every motion sample of `record` with Ω estimated by the array itself (σ0, Ω′
/// and Ω by Gauss–Newton from `seeds`; `None` where the sample's readings do not fit).
pub fn array_fields(
    geo: &[Geometry],
    record: &Record,
    seeds: &[Option<Vector3<f64>>],
) -> Vec<Option<Field>> {
    motion_fields(geo, record, seeds, true)
}

/// The derivative of a channel's centripetal reading `k·(Ω×(Ω×R))` with respect to Ω.
pub(super) fn centripetal_gradient(
    k: &Vector3<f64>,
    r: &Vector3<f64>,
    w: &Vector3<f64>,
) -> Vector3<f64> {
    k * w.dot(r) + r * k.dot(w) - w * (2.0 * k.dot(r))
}

/// The field at every motion sample by least squares over the channels: σ0 and Ω′ with Ω
/// held at `omega` (a reference), or with `estimate_omega` σ0, Ω′ and Ω together (three
/// Gauss–Newton steps from `omega`: the sign of Ω does not matter, only `{Ω}²` enters).
pub(super) fn motion_fields(
    geo: &[Geometry],
    record: &Record,
    omega: &[Option<Vector3<f64>>],
    estimate_omega: bool,
) -> Vec<Option<Field>> {
    let mut fields: Vec<Option<Field>> = record
        .motion
        .iter()
        .zip(omega.iter())
        .map(|(&k, omega)| {
            let row = &record.rows[k];
            let mut field = Field {
                omega: (*omega)?,
                ..Default::default()
            };
            // σ0 and Ω′ with Ω held: linear.
            // Fixed-size matrices: the per-sample solves are most of a calibration's time
            // (dynamic ones spent a third of it in allocation and a general matrix product).
            let mut a = SMatrix::<f64, 6, 6>::zeros();
            let mut b = SVector::<f64, 6>::zeros();
            for (g, p) in geo.iter().zip(row.iter()).filter(|(_, p)| p.is_finite()) {
                let kv = g.axis * g.scale;
                let rk = g.position.cross(&kv);
                let h = SVector::<f64, 6>::new(kv.x, kv.y, kv.z, rk.x, rk.y, rk.z);
                let y = p - g.bias - kv.dot(&(field.m(&record.gamma) * g.position));
                let w = 1.0 / (g.noise * g.noise);
                a += h * h.transpose() * w;
                b += h * (y * w);
            }
            let x = a.lu().solve(&b)?;
            field.sigma0 = Vector3::new(x[0], x[1], x[2]);
            field.domega = Vector3::new(x[3], x[4], x[5]);
            if !estimate_omega {
                return Some(field);
            }
            // Then all nine by Gauss–Newton increments; directions the sample does not
            // determine (near rest the centripetal columns vanish) keep their value. A step
            // that does not lower the sample's residual is not taken (the per-sample problem
            // has mirror solutions and flat directions: undamped steps can climb), so the
            // field only ever improves on its start.
            let mut best = f64::INFINITY;
            let mut previous = field;
            for _ in 0..FIELD_ITERATIONS {
                let m = field.m(&record.gamma);
                let mut a = SMatrix::<f64, 9, 9>::zeros();
                let mut b = SVector::<f64, 9>::zeros();
                let mut ssr = 0.0;
                for (g, p) in geo.iter().zip(row.iter()).filter(|(_, p)| p.is_finite()) {
                    let kv = g.axis * g.scale;
                    let rk = g.position.cross(&kv);
                    let c = centripetal_gradient(&kv, &g.position, &field.omega);
                    let h = SVector::<f64, 9>::from_column_slice(&[
                        kv.x, kv.y, kv.z, rk.x, rk.y, rk.z, c.x, c.y, c.z,
                    ]);
                    let e = p - field.reading(g, &m);
                    let w = 1.0 / (g.noise * g.noise);
                    ssr += e * e * w;
                    a += h * h.transpose() * w;
                    b += h * (e * w);
                }
                if let Some(prior) = record.rate_prior {
                    let (w, weight) = prior.at(k);
                    let e = w - field.omega;
                    ssr += e.norm_squared() * weight;
                    for i in 0..3 {
                        a[(6 + i, 6 + i)] += weight;
                        b[6 + i] += e[i] * weight;
                    }
                }
                if ssr > best {
                    field = previous;
                    break;
                }
                best = ssr;
                let tiny = a.diagonal().max() * 1e-8;
                let inv = a.pseudo_inverse(tiny).ok()?;
                let d = inv * b;
                // A direction the sample does not determine (pseudo-inverse zero there)
                // leaves that part of Ω unknown, not exact.
                let determined = (6..9).all(|i| inv[(i, i)] > 0.0);
                field.omega_var = if determined {
                    inv[(6, 6)] + inv[(7, 7)] + inv[(8, 8)]
                } else {
                    f64::INFINITY
                };
                previous = field;
                field.sigma0 += Vector3::new(d[0], d[1], d[2]);
                field.domega += Vector3::new(d[3], d[4], d[5]);
                field.omega += Vector3::new(d[6], d[7], d[8]);
                // Converged: the step no longer moves Ω by a relevant amount.
                if d.rows(6, 3).norm_squared() <= 1e-12 * (1.0 + previous.omega.norm_squared()) {
                    break;
                }
            }
            Some(field)
        })
        .collect();
    if estimate_omega {
        reject_outliers(geo, record, &mut fields);
    }
    fields
}

/// Leaves out the motion samples whose field does not explain their readings: a whitened
/// residual above the 99.9 % point of χ² for the sample's degrees of freedom and 25× the
/// median sample's (a tail the model leaves on a fitting record is kept). Such a sample's
/// Ω started far from its own (at the onset of a rotation the estimator's rate is small and
/// the centripetal columns vanish) and the per-sample solve stays there: kept, a handful of
/// them biased a noise-free fit by 2e-6 of scale and stalled it. Only where the median sample
/// fits to its noise (χ² ≤ 2 dof): on a record the model does not fit (the real 62.5 Hz board:
/// residuals 5–15× the noise) the test cannot tell such a sample from the misfit, and leaving
/// out its worst-fitting samples made its self-calibrated Ω worse than the nominal geometry's
/// (7.79 against 6.44 rad/s RMS); on `ground-calibration` the χ² point alone (without the 25×
/// median) left out enough of the tail to throw the kinematic tie off by 1.5 rad.
pub(super) fn reject_outliers(geo: &[Geometry], record: &Record, fields: &mut [Option<Field>]) {
    let ssr: Vec<Option<f64>> = record
        .motion
        .iter()
        .zip(fields.iter())
        .map(|(&k, f)| f.as_ref().map(|f| sample_chi2(geo, record, k, f)))
        .collect();
    let mut sorted: Vec<f64> = ssr.iter().flatten().copied().collect();
    if sorted.is_empty() {
        return;
    }
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    let dof = geo.len().saturating_sub(9).max(1);
    if median > 2.0 * dof as f64 {
        return;
    }
    let gate = estimator_core::estimate::chi2_999(dof).max(25.0 * median);
    for (f, s) in fields.iter_mut().zip(ssr.iter()) {
        if s.is_some_and(|s| s > gate) {
            *f = None;
        }
    }
}
