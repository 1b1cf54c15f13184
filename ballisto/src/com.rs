//! `ballisto com`: the centre of mass relative to the instrument origin (paper §7–8).
//!
//! Paper eq. (12) for a rigid mount: `σ0 = (Γ + {Ω′} + {Ω}²) ρ + f = (A + {Ω′}) ρ + f`. The
//! numbers written are the ρ of this equation (docs/formats.md): the instrument origin's
//! position relative to the centre of mass — hal-sim's `origin_offset` — so the centre of
//! mass lies at −ρ from the origin. Over a window in which the non-gravitational specific
//! force `f` is constant in the body frame, the estimator's σ0, Ω′ and A give a linear least
//! squares in the six unknowns (ρ, f), weighted by the reported deviations of σ0 (A and Ω′
//! are taken as exact: their errors times ρ, centimetres, are below σ0's). Rows the
//! estimator flags as undecided or inconsistent (residual high) are left out. A window whose rotation does not separate ρ
//! from f (`A + {Ω′}` constant, e.g. no rotation) writes empty fields, not a guess.

use std::error::Error;
use std::io::Write;
use std::path::Path;

use ballisto_config::arrangement_file::load_arrangement;
use estimator_core::{Estimate, Flags, Model, Options};
use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};

use crate::estimate::HostEstimator;
use crate::samples_csv::SamplesReader;

/// What ρ is, wherever ballisto writes one (`com`'s columns, `decode`'s identification
/// summary and calibration header): one convention, paper eq. 12's, as hal-sim's
/// `origin_offset` and the identification's telemetry (format 4) carry it.
pub const RHO_MEANING: &str =
    "rho (paper eq. 12) is the instrument origin seen from the centre of mass, which is at -rho from the origin";

/// The columns of the output (docs/formats.md).
pub const COLUMNS: &str = "t,rho_x,rho_y,rho_z,f_x,f_y,f_z,sd_rho_x,sd_rho_y,sd_rho_z";

/// A window's normal equations whose reciprocal condition (smallest over largest
/// eigenvalue) is below this cannot separate ρ from f.
pub const MIN_RECIPROCAL_CONDITION: f64 = 1e-10;

/// What `ballisto com` found.
#[derive(Clone, Debug, Default)]
pub struct ComSummary {
    /// Windows written.
    pub windows: usize,
    /// Windows that could not separate ρ from f (empty fields).
    pub undetermined: usize,
    /// The model used.
    pub model: Option<Model>,
    /// Why the model differs from the file's, if it does (said once, after the run).
    pub model_note: Option<String>,
    /// What looks implausible in the inputs ([`crate::plausibility`]).
    pub warnings: Vec<String>,
}

struct Row {
    t: f64,
    sigma0: Vector3<f64>,
    m: Matrix3<f64>,
    /// Variance of `m`'s noise (sum over its entries), from the reported deviations of A
    /// and Ω′.
    m_noise: f64,
    sd: Vector3<f64>,
}

/// A window separates ρ from f only if `A + {Ω′}` is this many times larger (RMS over the
/// window) than its own noise: otherwise the fit would regress on noise.
pub const MIN_EXCITATION: f64 = 3.0;

/// Runs `ballisto com` (see the module doc): windows of `window` s, one every half window.
pub fn com_files(
    arrangement: &Path,
    samples: &Path,
    out: &Path,
    window: f64,
    model: Option<Model>,
) -> Result<ComSummary, Box<dyn Error>> {
    if !(window.is_finite() && window > 0.0) {
        return Err(format!("--window {window}: must be a positive number of seconds").into());
    }
    crate::output::check_distinct(&[out], &[arrangement, samples])?;
    let loaded = load_arrangement(arrangement)?;
    let (model, model_note) =
        ballisto_config::model_choice::recommend(model, &loaded, arrangement)?;
    let mut est = HostEstimator::<f64>::new(&loaded, model, Options::default())
        .map_err(|e| format!("{}: {e}", arrangement.display()))?;
    let mut reader = SamplesReader::open(samples, &loaded.names)?.with_ranges(&loaded.ranges);
    let mut rows: Vec<Row> = Vec::new();
    let undecided = Flags::FALLBACK
        | Flags::ILL_CONDITIONED
        | Flags::BRANCH_AMBIGUOUS
        | Flags::INPUT_INVALID
        | Flags::SIGN_UNRESOLVED
        | Flags::RESIDUAL_HIGH;
    let mut span: Option<(f64, f64)> = None;
    let mut emit = |t: f64, e: &Estimate<f64>| {
        span = Some(span.map_or((t, t), |(a, _)| (a, t)));
        if e.flags.0 & undecided != 0 {
            return;
        }
        let a = e.field.to_mat();
        let w = Vector3::from(e.domega);
        let f = &e.sd_field.0;
        let m_noise = f[0] * f[0]
            + f[1] * f[1]
            + f[2] * f[2]
            + 2.0 * (f[3] * f[3] + f[4] * f[4] + f[5] * f[5])
            + 2.0 * e.sd_domega.iter().map(|v| v * v).sum::<f64>();
        rows.push(Row {
            t,
            sigma0: Vector3::from(e.sigma0),
            m: Matrix3::from_row_slice(&a.concat()) + w.cross_matrix(),
            m_noise,
            sd: Vector3::from(e.sd_sigma0),
        });
    };
    let mut p = vec![0.0; loaded.names.len()];
    while let Some(t) = reader.next_row(&mut p)? {
        est.push(t, &p, &mut emit);
    }
    est.finish(&mut emit);
    let Some((t0, t1)) = span else {
        return Err(format!(
            "{}: no sample rows after the header: nothing written",
            samples.display()
        )
        .into());
    };
    // Written beside the final path, put in place once complete (`crate::output`).
    let (pending, mut w) = crate::output::create(out)?;
    writeln!(w, "{COLUMNS}")?;
    let mut summary = ComSummary {
        model: Some(model),
        model_note,
        ..Default::default()
    };
    summary.warnings.extend(crate::plausibility::arrangement(
        &loaded,
        &arrangement.display().to_string(),
    ));
    summary
        .warnings
        .extend(reader.absurd_warnings(&loaded.names));
    let mut start = t0;
    let mut first = 0;
    while start + window <= t1 + 1e-9 || (start == t0 && t1 - t0 < window) {
        while first < rows.len() && rows[first].t < start {
            first += 1;
        }
        let inside = rows[first..].iter().take_while(|r| r.t < start + window);
        let centre = start + window / 2.0;
        match solve_window(inside) {
            Some((x, sd)) => writeln!(
                w,
                "{centre},{},{},{},{},{},{},{},{},{}",
                x[0], x[1], x[2], x[3], x[4], x[5], sd[0], sd[1], sd[2]
            )?,
            None => {
                summary.undetermined += 1;
                writeln!(w, "{centre},,,,,,,,,")?;
            }
        }
        summary.windows += 1;
        if t1 - t0 < window {
            break;
        }
        start += window / 2.0;
    }
    crate::output::finish(pending, w)?;
    Ok(summary)
}

/// The weighted least squares of one window: (ρ, f) and the deviations of ρ, or `None` if
/// the window does not separate them (too few rows, `A + {Ω′}` within
/// [`MIN_EXCITATION`] × its noise, or a singular system).
fn solve_window<'a>(rows: impl Iterator<Item = &'a Row>) -> Option<(Vector6<f64>, Vector3<f64>)> {
    let mut n = Matrix6::<f64>::zeros();
    let mut b = Vector6::<f64>::zeros();
    let mut count = 0;
    let (mut size, mut noise) = (0.0, 0.0);
    for r in rows {
        size += r.m.norm_squared();
        noise += r.m_noise;
        for i in 0..3 {
            let sd = r.sd[i];
            if !(sd.is_finite() && sd > 0.0) {
                continue;
            }
            let h = Vector6::new(r.m[(i, 0)], r.m[(i, 1)], r.m[(i, 2)], 0.0, 0.0, 0.0)
                + Vector6::ith(3 + i, 1.0);
            let wgt = 1.0 / (sd * sd);
            n += h * h.transpose() * wgt;
            b += h * (r.sigma0[i] * wgt);
            count += 1;
        }
    }
    let excited = size > MIN_EXCITATION * MIN_EXCITATION * noise;
    if count < 12 || !excited {
        return None;
    }
    let eig = n.symmetric_eigenvalues();
    let separable = eig.min() > MIN_RECIPROCAL_CONDITION * eig.max();
    if !separable {
        return None;
    }
    let cov = n.try_inverse()?;
    let x = cov * b;
    let sd = Vector3::new(cov[(0, 0)], cov[(1, 1)], cov[(2, 2)]).map(|v| v.max(0.0).sqrt());
    x.iter().all(|v| v.is_finite()).then_some((x, sd))
}
