//! The identification from where the alternations ended.

use crate::calibrate::scatter::Scatter;

use super::*;

/// Where the alternations ended: the geometry, self-calibration's Ω per motion sample, the
/// weights, the last step (its deviations and what it held), the residuals before, and how
/// it converged.
pub(super) struct Fitted {
    pub(super) geo: Vec<Geometry>,
    pub(super) omega: Option<Vec<Option<Vector3<f64>>>>,
    pub(super) scatter: Scatter,
    pub(super) step: JointStep,
    pub(super) residual_before: Residuals,
    pub(super) iterations: usize,
    pub(super) last_step: f64,
}

/// The identification from where the alternations ended: the size held with a reference of
/// inexact scale ([`RatePrior`]), self-calibration's kinematic tie, the residuals after, each
/// channel's parameters and deviations, the frame's uncertainty and the conventions held.
pub(super) fn finish(
    nominal: &[Geometry],
    record: &Record,
    rate: &RateSource,
    tol: &Tolerance,
    fitted: Fitted,
) -> Result<Identification, String> {
    let Fitted {
        mut geo,
        omega,
        scatter,
        step,
        residual_before,
        iterations,
        last_step,
    } = fitted;
    let n = nominal.len();
    // With a reference of inexact scale, its common factor and the array's size are one
    // freedom ([`RatePrior`]): the size is held at the drawing's and the factor follows
    // (exact for the array's own Ω: its readings do not change).
    let prior = record.rate_prior.map(|p| {
        let k = size(nominal) / size(&geo);
        grow(&mut geo, k);
        RatePrior {
            scale: p.scale / k.sqrt(),
            ..p
        }
    });
    let kinematic = match &omega {
        Some(w) => tie_kinematics(&mut geo, record, w),
        None => None,
    };
    for (g, w) in geo.iter_mut().zip(scatter.white.iter()) {
        // The geometry's noise is the white noise again (the motion's scatter was the fit's
        // weight).
        g.noise = *w;
    }
    let fitted = Record {
        rate_prior: prior,
        ..*record
    };
    let residual_after = residuals(&geo, &fitted, rate)?;
    let channels = (0..n)
        .map(|i| Identified {
            geometry: geo[i],
            sd: core::array::from_fn(|j| step.sd[7 * i + j]),
            held: step.held[i].clone(),
            residual_rms: (
                residual_before.per_channel[i],
                residual_after.per_channel[i],
            ),
            rest_scatter: scatter.at_rest(i),
        })
        .collect();
    let mut frame = crate::calibrate::frame::uncertainty(&geo, &step.error_covariance(n), tol);
    let mut conventions = step.common;
    if let Some(p) = prior {
        // The size is held as a gauge is: only as good as the drawing.
        frame.size = frame
            .size
            .hypot(crate::calibrate::frame::held_size(&geo, tol));
        conventions.push(format!(
            "the array's size: held at the drawing's (with a reference of inexact scale the size and the reference's common scale factor are one freedom; the factor is fitted: {:.4})",
            p.scale
        ));
    }
    if let Some(k) = kinematic.as_ref().filter(|k| k.holds()) {
        frame.relative_rotation = k.sd.max();
    }
    Ok(Identification {
        channels,
        conventions,
        reference_scale: prior.map(|p| p.scale),
        tolerance: *tol,
        iterations,
        last_step,
        frame,
        residuals: (residual_before, residual_after),
        kinematic,
    })
}
