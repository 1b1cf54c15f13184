//! The reference rate file (interfaces.md): `t, omega_x, omega_y, omega_z` (rad/s, body; more
//! columns may follow), brought to the samples' instants by linear interpolation.

use std::error::Error;
use std::path::Path;

use nalgebra::Vector3;

/// The reference at the sample instants.
pub struct ReferenceAt {
    /// Ω at each sample (zero where not covered).
    pub omega: Vec<Vector3<f64>>,
    /// Whether the reference covers the sample (it lies between two reference rows).
    pub covered: Vec<bool>,
}

/// The rows of a reference rate file: times (s, increasing) and Ω (rad/s, body).
pub struct Reference {
    /// Times, s.
    pub t: Vec<f64>,
    /// Ω at each time, rad/s.
    pub omega: Vec<Vector3<f64>>,
}

/// Reads `path` and interpolates it to `times` (not across a gap of more than 1.5 median
/// intervals: rows left out mean "no reference here"). Errors name the file and line; a
/// reference that covers less than half of the samples is refused (it does not overlap the
/// record).
pub fn read_at(path: &Path, times: &[f64]) -> Result<ReferenceAt, Box<dyn Error>> {
    let name = path.display().to_string();
    let Reference {
        t: t_ref,
        omega: w_ref,
    } = read(path)?;

    // A reference with rows left out (e.g. where a gyro saturated) does not cover the gap:
    // an interval longer than 1.5 times the median one is not interpolated across.
    let mut steps: Vec<f64> = t_ref.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    let longest = 1.5 * steps[steps.len() / 2];
    let mut omega = Vec::with_capacity(times.len());
    let mut covered = Vec::with_capacity(times.len());
    let mut j = 0;
    for &t in times {
        while j + 2 < t_ref.len() && t_ref[j + 1] < t {
            j += 1;
        }
        let (t0, t1) = (t_ref[j], t_ref[j + 1]);
        let inside = t >= t0 - 1e-9 && t <= t1 + 1e-9 && t1 - t0 <= longest;
        covered.push(inside);
        omega.push(if inside {
            let u = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
            w_ref[j] * (1.0 - u) + w_ref[j + 1] * u
        } else {
            Vector3::zeros()
        });
    }
    let n = covered.iter().filter(|c| **c).count();
    if 2 * n < times.len() {
        return Err(format!(
            "{name}: covers {n} of the {} sample instants ({:.3}–{:.3} s against {:.3}–{:.3} s): it does not overlap the record",
            times.len(),
            t_ref[0],
            t_ref[t_ref.len() - 1],
            times.first().copied().unwrap_or(0.0),
            times.last().copied().unwrap_or(0.0)
        )
        .into());
    }
    Ok(ReferenceAt { omega, covered })
}

/// Reads a reference rate file: errors name the file and line (a missing column, a field that
/// is not a finite number, a time that does not increase, fewer than two rows).
pub fn read(path: &Path) -> Result<Reference, Box<dyn Error>> {
    let name = path.display().to_string();
    let mut rdr = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .from_path(path)
        .map_err(|e| format!("{name}: cannot open: {e}"))?;
    let header = rdr
        .headers()
        .map_err(|e| format!("{name} line 1: cannot read the header: {e}"))?
        .clone();
    let col = |c: &str| {
        header.iter().position(|h| h.trim() == c).ok_or_else(|| {
            format!("{name} line 1: no column \"{c}\" (expected t, omega_x, omega_y, omega_z)")
        })
    };
    let cols = [col("t")?, col("omega_x")?, col("omega_y")?, col("omega_z")?];
    let mut t_ref: Vec<f64> = Vec::new();
    let mut w_ref: Vec<Vector3<f64>> = Vec::new();
    for (i, rec) in rdr.records().enumerate() {
        let line = i + 2;
        let rec = rec.map_err(|e| format!("{name} line {line}: {e}"))?;
        let mut v = [0.0; 4];
        for (x, &c) in v.iter_mut().zip(cols.iter()) {
            let field = rec.get(c).unwrap_or("").trim();
            *x = field
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("{name} line {line}: \"{field}\" is not a finite number"))?;
        }
        if t_ref.last().is_some_and(|&t0| v[0] <= t0) {
            return Err(format!("{name} line {line}: t = {} does not increase", v[0]).into());
        }
        t_ref.push(v[0]);
        w_ref.push(Vector3::new(v[1], v[2], v[3]));
    }
    if t_ref.len() < 2 {
        return Err(format!("{name}: fewer than two rows").into());
    }
    Ok(Reference {
        t: t_ref,
        omega: w_ref,
    })
}
