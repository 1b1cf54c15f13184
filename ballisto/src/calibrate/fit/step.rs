//! One step of the geometry: the joint normal equations of every channel's parameters with the
//! field projected out, what the record determines, and the step within its trust region.

use crate::calibrate::scatter::Scatter;
use estimator_core::identify::{reading_gradient, Param};
use estimator_core::G0;
use nalgebra::{DMatrix, DVector, Matrix3, SVector, SymmetricEigen, Vector3};

use super::*;

/// Gauss–Newton steps per sample for σ0, Ω′ and Ω.
pub(super) const FIELD_ITERATIONS: usize = 6;

/// The tilt directions `u1, u2` perpendicular to the unit `a` (estimator-core's
/// [`estimator_core::identify::tilt_basis`]).
pub(super) fn tilt_basis(a: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let (u1, u2) = estimator_core::identify::tilt_basis(&(*a).into());
    (u1.into(), u2.into())
}

/// The channel's Jacobian row (in [`PARAMETERS`] order) at the specific force `f` seen at its
/// position, with `m` the field matrix (`f = σ0 + m R`): the channel model's gradient
/// ([`reading_gradient`]).
pub(super) fn jacobian(g: &Geometry, f: &Vector3<f64>, m: &Matrix3<f64>) -> SVector<f64, 7> {
    let (u1, u2) = estimator_core::identify::tilt_basis(&g.axis.into());
    let rows: [[f64; 3]; 3] = core::array::from_fn(|a| core::array::from_fn(|l| m[(a, l)]));
    SVector::<f64, 7>::from(reading_gradient(
        g.scale,
        &g.axis.into(),
        &(u1, u2),
        &rows,
        &(*f).into(),
    ))
}

/// The joint normal equations of all channels' parameters (7 per channel, [`PARAMETERS`]
/// order) with the field projected out (variable projection): per pose its gravity
/// direction (2 unknowns: the magnitude is [`G0`]), per motion sample σ0 and Ω′ (6). Each
/// row of data adds `JᵀWJ − (JᵀWH)(HᵀWH)⁻¹(HᵀWJ)` with `H` the field's columns, so the
/// geometry step accounts for what the field can absorb, and the inverse of the result is
/// the geometry's covariance with the field unknown.
pub(super) fn joint_normal_equations(
    geo: &[Geometry],
    record: &Record,
    fields: &[Option<Field>],
    gravity: &[Vector3<f64>],
    with_omega: bool,
    scatter: &Scatter,
) -> (DMatrix<f64>, DVector<f64>) {
    let n = geo.len();
    let mut normal = DMatrix::<f64>::zeros(7 * n, 7 * n);
    let mut rhs = DVector::<f64>::zeros(7 * n);
    // `prior`: a reading of Ω (the field's last three unknowns): its residual and weight.
    let mut add = |rows: &[DataRow], q: usize, prior: Option<(Vector3<f64>, f64)>| {
        let mut s = DMatrix::<f64>::zeros(q, q);
        let mut c = DMatrix::<f64>::zeros(7 * n, q);
        let mut hc = DVector::<f64>::zeros(q);
        if let Some((e, weight)) = prior {
            for i in 0..3 {
                s[(6 + i, 6 + i)] += weight;
                hc[6 + i] += e[i] * weight;
            }
        }
        for row in rows {
            let (i, w, e) = (row.channel, row.weight, row.residual);
            let hv = DVector::from_column_slice(&row.field);
            s += &hv * hv.transpose() * w;
            hc += &hv * (w * e);
            for a in 0..7 {
                let ja = row.jacobian[a] * w;
                rhs[7 * i + a] += ja * e;
                for b in 0..7 {
                    normal[(7 * i + a, 7 * i + b)] += ja * row.jacobian[b];
                }
                for (col, hq) in row.field.iter().enumerate() {
                    c[(7 * i + a, col)] += ja * hq;
                }
            }
        }
        // normal −= C S⁺ Cᵀ, rhs −= C S⁺ (HᵀWe). The pseudo-inverse: near rest the
        // centripetal columns vanish and S is singular (the field then has fewer freedoms).
        let tiny = s.diagonal().max() * 1e-8;
        let Ok(s_pinv) = s.pseudo_inverse(tiny) else {
            return;
        };
        let s_inv_ct = &s_pinv * c.transpose();
        normal.gemm(-1.0, &c, &s_inv_ct, 1.0);
        rhs.gemv(-1.0, &c, &(&s_pinv * hc), 1.0);
    };
    let mut rows = Vec::with_capacity(n);
    for (pose, gk) in record.poses.iter().zip(gravity.iter()) {
        rows.clear();
        let (u1, u2) = tilt_basis(&gk.normalize());
        for (i, g) in geo.iter().enumerate() {
            let p = pose.mean[i];
            if !p.is_finite() {
                continue;
            }
            let w = scatter.pose_weight(i, pose.samples.len());
            let k = g.axis * g.scale;
            let j = jacobian(g, gk, &Matrix3::zeros());
            rows.push(DataRow {
                channel: i,
                weight: w,
                jacobian: j,
                residual: p - g.reading(gk),
                field: vec![G0 * k.dot(&u1), G0 * k.dot(&u2)],
            });
        }
        add(&rows, 2, None);
    }
    for (&t, field) in record.motion.iter().zip(fields.iter()) {
        let Some(field) = field else {
            continue;
        };
        rows.clear();
        let m = field.m(&record.gamma);
        for (i, g) in geo.iter().enumerate() {
            let p = record.rows[t][i];
            if !p.is_finite() {
                continue;
            }
            let w = 1.0 / (g.noise * g.noise);
            let k = g.axis * g.scale;
            let rk = g.position.cross(&k);
            let f = field.sigma0 + m * g.position;
            let j = jacobian(g, &f, &m);
            let mut h = vec![k.x, k.y, k.z, rk.x, rk.y, rk.z];
            if with_omega {
                h.extend_from_slice(centripetal_gradient(&k, &g.position, &field.omega).as_slice());
            }
            rows.push(DataRow {
                channel: i,
                weight: w,
                jacobian: j,
                residual: p - g.reading(&f),
                field: h,
            });
        }
        let prior = record.rate_prior.filter(|_| with_omega).map(|p| {
            let (w, weight) = p.at(t);
            (w - field.omega, weight)
        });
        add(&rows, if with_omega { 9 } else { 6 }, prior);
    }
    (normal, rhs)
}

/// One joint Gauss–Newton step and what it says about observability.
#[derive(Clone, Default)]
pub(super) struct JointStep {
    pub(super) delta: Vec<f64>,
    pub(super) sd: Vec<f64>,
    /// Per channel: held directions that are its own.
    pub(super) held: Vec<Vec<String>>,
    /// Held directions shared by many channels (freedoms of the whole arrangement).
    pub(super) common: Vec<String>,
    /// The identified directions (columns; tolerance-scaled fitted parameters).
    pub(super) basis: DMatrix<f64>,
    /// The held directions that are not conventions (their tolerance enters the deviations).
    pub(super) held_basis: DMatrix<f64>,
    /// The parameters moved (7 per channel).
    pub(super) fitted: Vec<bool>,
    /// Covariance of the fitted parameters (tolerance-scaled, in their order): the identified
    /// directions' from the data, the held directions' one tolerance.
    pub(super) cov: DMatrix<f64>,
    /// The gauge directions (columns, tolerance-scaled fitted parameters): held by
    /// convention, so only as good as the nominal geometry (one tolerance).
    pub(super) gauge_basis: DMatrix<f64>,
}

impl JointStep {
    /// Covariance (tolerance-scaled, all 7 parameters of every channel) of the geometry's
    /// error against the truth: the data's where identified; one tolerance along held
    /// directions, gauges and parameters not fitted (they keep the nominal values, which are
    /// as good as the mounting).
    pub(super) fn error_covariance(&self, n: usize) -> DMatrix<f64> {
        let idx: Vec<usize> = (0..7 * n).filter(|&p| self.fitted[p]).collect();
        let mut c = DMatrix::identity(7 * n, 7 * n);
        if self.cov.nrows() != idx.len() {
            return c;
        }
        let g = &self.cov + &self.gauge_basis * self.gauge_basis.transpose();
        for (a, &pa) in idx.iter().enumerate() {
            for (b, &pb) in idx.iter().enumerate() {
                c[(pa, pb)] = g[(a, b)];
            }
        }
        c
    }
}

/// The step with the parameters the record does not determine to half their tolerance held
/// at their present values (nominal, when decided at the start) and named: the least
/// determined parameters are set aside until every remaining one is (a parameter can become
/// determined once a correlated one is held).
pub(super) fn decided_step(
    normal: &DMatrix<f64>,
    rhs: &DVector<f64>,
    n: usize,
    kinds: &[bool; 7],
    tol: &Tolerance,
) -> JointStep {
    let mut fitted: Vec<bool> = (0..7 * n).map(|p| kinds[p % 7]).collect();
    let mut set_aside: Vec<usize> = Vec::new();
    loop {
        let mut step = truncated_step(normal, rhs, n, &fitted, tol, None);
        // Scaled deviation of every fitted parameter (NaN: mostly in a held direction).
        let scaled: Vec<(usize, f64)> = (0..7 * n)
            .filter(|&p| fitted[p])
            .map(|p| {
                let z = step.sd[p] / tol.of(p % 7);
                (p, if z.is_nan() { f64::INFINITY } else { z })
            })
            .filter(|(_, z)| *z > 0.5)
            .collect();
        // A bias is told from the scale only by readings of different size: where a
        // channel's scale or axis is held, its bias (estimated as if they were exact) is
        // held too, rather than reported with a deviation that ignores theirs.
        let dependent: Vec<usize> = (0..n)
            .map(|i| 7 * i + Param::Bias as usize)
            .filter(|&b| {
                fitted[b] && (0..3).any(|j| kinds[j] && !fitted[b - Param::Bias as usize + j])
            })
            .collect();
        if scaled.is_empty() && !dependent.is_empty() {
            for p in dependent {
                fitted[p] = false;
                set_aside.push(p);
            }
            continue;
        }
        if scaled.is_empty() {
            for &p in &set_aside {
                step.held[p / 7].push(PARAMETERS[p % 7].to_string());
            }
            for h in step.held.iter_mut() {
                h.sort();
                h.dedup();
            }
            return step;
        }
        // All the hopeless ones at once, else the least determined one.
        let hopeless: Vec<usize> = scaled
            .iter()
            .filter(|(_, z)| *z > 2.0)
            .map(|(p, _)| *p)
            .collect();
        let drop = if hopeless.is_empty() {
            vec![scaled
                .iter()
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map_or(0, |(p, _)| *p)]
        } else {
            hopeless
        };
        for p in drop {
            fitted[p] = false;
            set_aside.push(p);
        }
    }
}

/// The step restricted to the fitted parameters and to the directions the data determine to
/// half the tolerance (eigen-decomposition of the tolerance-scaled normal matrix); the
/// standard deviations of the identified parameters (NaN for a parameter that is mostly in a
/// held direction).
pub(super) fn truncated_step(
    normal: &DMatrix<f64>,
    rhs: &DVector<f64>,
    n: usize,
    fitted: &[bool],
    tol: &Tolerance,
    frozen: Option<&JointStep>,
) -> JointStep {
    let fitted = frozen.map_or(fitted, |f| &f.fitted[..]);
    let idx: Vec<usize> = (0..7 * n).filter(|&p| fitted[p]).collect();
    let q = idx.len();
    let mut out = JointStep {
        delta: vec![0.0; 7 * n],
        sd: vec![f64::NAN; 7 * n],
        held: vec![Vec::new(); n],
        common: Vec::new(),
        basis: DMatrix::zeros(0, 0),
        held_basis: DMatrix::zeros(0, 0),
        fitted: fitted.to_vec(),
        cov: DMatrix::zeros(0, 0),
        gauge_basis: DMatrix::zeros(0, 0),
    };
    if q == 0 {
        return out;
    }
    let d = DVector::from_iterator(q, idx.iter().map(|&p| tol.of(p % 7)));
    let ns = DMatrix::from_fn(q, q, |a, b| normal[(idx[a], idx[b])] * d[a] * d[b]);
    let bs = DVector::from_fn(q, |a, _| rhs[idx[a]] * d[a]);
    if let Some(f) = frozen {
        // The identified subspace decided before: Gauss–Newton within it.
        let v = &f.basis;
        let nr = v.transpose() * &ns * v;
        let br = v.transpose() * &bs;
        if let Some(chol) = nr.clone().cholesky() {
            let x = v * chol.solve(&br);
            let cov = v * chol.inverse() * v.transpose() + &f.held_basis * f.held_basis.transpose();
            out.held = f.held.clone();
            out.common = f.common.clone();
            out.basis = f.basis.clone();
            out.held_basis = f.held_basis.clone();
            out.gauge_basis = f.gauge_basis.clone();
            for a in 0..q {
                out.delta[idx[a]] = x[a] * d[a];
                if !f.sd[idx[a]].is_nan() {
                    out.sd[idx[a]] = cov[(a, a)].max(0.0).sqrt() * d[a];
                }
            }
            out.cov = cov;
            return out;
        }
    }
    let eig = SymmetricEigen::new(ns);
    if log::log_enabled!(log::Level::Debug) {
        let mut l: Vec<f64> = eig.eigenvalues.iter().copied().collect();
        l.sort_by(f64::total_cmp);
        log::debug!(
            "largest eigenvalue {:.3e}, smallest {:?}",
            l[l.len() - 1],
            l[..l.len().min(10)]
                .iter()
                .map(|v| format!("{v:.2e}"))
                .collect::<Vec<_>>()
        );
    }
    let mut x = DVector::zeros(q);
    let mut var = DVector::<f64>::zeros(q);
    let mut mostly_held = vec![false; q];
    let mut kept = Vec::new();
    let mut held_dirs = Vec::new();
    let mut gauges = Vec::new();
    let mut gauge_share = vec![0.0; q];
    let lambda_max = eig.eigenvalues.max().max(0.0);
    for (e, &lambda) in eig.eigenvalues.iter().enumerate() {
        let v = eig.eigenvectors.column(e);
        // Identified: the data's standard deviation along v is at most half the tolerance.
        if lambda >= 4.0 {
            kept.push(e);
            x += v * (v.dot(&bs) / lambda);
            for a in 0..q {
                var[a] += v[a] * v[a] / lambda;
            }
            continue;
        }
        // A freedom no such record can fix (the data say nothing at all along it: a
        // gauge) is a convention; a direction the record determines, but not to half the
        // tolerance, is held at nominal and its tolerance counted in the deviations.
        if lambda < GAUGE_EIGENVALUE * lambda_max {
            gauges.push(e);
            for a in 0..q {
                gauge_share[a] += v[a] * v[a];
            }
        } else {
            held_dirs.push(e);
            for a in 0..q {
                var[a] += v[a] * v[a];
            }
        }
    }
    // A parameter mostly inside the gauges is not identified at all; one that shares a
    // little of a gauge (each position's part of the common translation) is identified
    // relative to the convention.
    for a in 0..q {
        if gauge_share[a] > HELD_SHARE {
            mostly_held[a] = true;
        }
    }
    if !gauges.is_empty() {
        let mut kinds: Vec<&str> = gauges
            .iter()
            .flat_map(|&e| {
                let v = eig.eigenvectors.column(e);
                (0..q)
                    .filter(move |&a| v[a] * v[a] > 0.01)
                    .map(|a| PARAMETERS[idx[a] % 7])
                    .collect::<Vec<_>>()
            })
            .collect();
        kinds.sort();
        kinds.dedup();
        out.common.push(if kinds.iter().all(|k| k.starts_with("position")) && gauges.len() <= 3 {
            "the common translation of all positions: not observable from accelerometers (σ0 absorbs it); the origin is held where the nominal positions put it".to_string()
        } else {
            format!(
                "{} combinations of {} that this record cannot tell apart (held at nominal: among them the common translation, and without a reference the common rotation and size)",
                gauges.len(),
                kinds.join(", ")
            )
        });
    }
    for a in 0..q {
        out.delta[idx[a]] = x[a] * d[a];
        if !mostly_held[a] {
            out.sd[idx[a]] = var[a].max(0.0).sqrt() * d[a];
        }
    }
    out.basis = eig.eigenvectors.select_columns(kept.iter());
    out.held_basis = eig.eigenvectors.select_columns(held_dirs.iter());
    out.gauge_basis = eig.eigenvectors.select_columns(gauges.iter());
    let inverse = DMatrix::from_diagonal(&DVector::from_iterator(
        kept.len(),
        kept.iter().map(|&e| 1.0 / eig.eigenvalues[e]),
    ));
    out.cov =
        &out.basis * inverse * out.basis.transpose() + &out.held_basis * out.held_basis.transpose();
    out
}

/// Applies a step in [`PARAMETERS`] order.
pub(super) fn apply(g: &mut Geometry, d: &SVector<f64, 7>) {
    let (u1, u2) = tilt_basis(&g.axis);
    g.scale += d[0];
    g.axis = (g.axis + u1 * d[1] + u2 * d[2]).normalize();
    g.position += Vector3::new(d[3], d[4], d[5]);
    g.bias += d[6];
}

/// What a cost is evaluated on: the record, the motion's Ω seeds, whether Ω is free, the
/// weights.
pub(super) struct Probe<'a> {
    pub(super) record: &'a Record<'a>,
    pub(super) seeds: &'a [Option<Vector3<f64>>],
    pub(super) free_omega: bool,
    pub(super) scatter: &'a Scatter,
}

impl<'a> Probe<'a> {
    /// A probe without Ω seeds (the field's own).
    pub(super) fn new(record: &'a Record<'a>, free_omega: bool, scatter: &'a Scatter) -> Self {
        Probe {
            record,
            seeds: &[],
            free_omega,
            scatter,
        }
    }
}

/// The step `step` taken from `geo` at `shrink` (the trust region), halved while it raises
/// the cost (at most [`MAX_HALVINGS`] times): the trial geometry, the scale taken, and the
/// cost before and after.
pub(super) fn line_search(
    geo: &[Geometry],
    step: &JointStep,
    probe: &Probe,
    shrink: f64,
) -> (Vec<Geometry>, f64, f64, f64) {
    let moved = |scale: f64| {
        let mut trial = geo.to_vec();
        for (i, g) in trial.iter_mut().enumerate() {
            let d = SVector::<f64, 7>::from_fn(|j, _| step.delta[7 * i + j] * scale);
            apply(g, &d);
        }
        trial
    };
    let cost_of = |g: &[Geometry]| {
        cost(
            g,
            probe.record,
            probe.seeds,
            probe.free_omega,
            probe.scatter,
        )
    };
    let before = cost_of(geo);
    let mut scale = shrink;
    let mut trial = moved(scale);
    let mut halvings = 0;
    let mut after = cost_of(&trial);
    while halvings < MAX_HALVINGS && after > before {
        scale *= 0.5;
        trial = moved(scale);
        after = cost_of(&trial);
        halvings += 1;
    }
    (trial, scale, before, after)
}

/// Refuses a geometry whose scale or bias has left any part's range after `it` alternations:
/// the record does not determine them.
pub(super) fn check_in_range(geo: &[Geometry], it: usize) -> Result<(), String> {
    if let Some((i, g)) = geo
        .iter()
        .enumerate()
        .find(|(_, g)| !(g.scale > 0.5 && g.scale < 2.0 && g.bias.is_finite()))
    {
        return Err(format!(
            "the identification diverged: after {} alternations channel {i} (arrangement order, from 0) has scale {:.3} and bias {:.3} m/s², outside any part's range; the record does not determine them (in free fall, without static poses, a channel's scale and its lever arm are seen only as their product): nothing written",
            it + 1,
            g.scale,
            g.bias
        ));
    }
    Ok(())
}
