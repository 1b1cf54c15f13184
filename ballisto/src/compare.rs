//! `ballisto compare`: RMS errors of an estimates file against a truth file, matched by column
//! name and by `t` (docs/formats.md: both files share the column names); or its Ω against a rate
//! reference (a gyro), on the reference's valid rows.

use std::error::Error;
use std::path::Path;

use crate::calibrate::reference_rate::{read_at, Dropped, Validity};
use crate::columns::{Columns, Matched};

/// RMS errors of one comparison.
#[derive(Clone, Debug, Default)]
pub struct Comparison {
    /// Rows compared.
    pub rows: usize,
    /// RMS of |σ0 error| (m/s²).
    pub sigma0: f64,
    /// RMS of |Ω′ error| (rad/s²).
    pub domega: f64,
    /// RMS of |Ω error| (rad/s).
    pub omega: f64,
    /// RMS of the Frobenius error of A (s⁻²).
    pub field: f64,
    /// Where the estimates carry deviations and flags: rows with no flag set whose σ0 (and,
    /// counted apart, whose Ω) error exceeds [`SILENT_SD`] reported standard deviations in
    /// some component (silently wrong rows).
    pub silent: Option<Silent>,
}

/// Counts of silently wrong rows (see [`Comparison::silent`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Silent {
    /// Rows with an unflagged σ0 error above [`SILENT_SD`] reported sd.
    pub sigma0: usize,
    /// Rows with an unflagged Ω error above [`SILENT_SD`] reported sd.
    pub omega: usize,
}

/// An error beyond this many reported standard deviations, unflagged, is silently wrong.
pub const SILENT_SD: f64 = 5.0;

/// The estimates' columns for [`Silent`]: deviations of σ0 and Ω, then the flags.
const DEVIATIONS: [&str; 7] = [
    "sd_sigma0_x",
    "sd_sigma0_y",
    "sd_sigma0_z",
    "sd_omega_x",
    "sd_omega_y",
    "sd_omega_z",
    "flags",
];

/// The compared columns, `t` first: σ0, Ω′, Ω, A.
const COLUMNS: [&str; 16] = [
    "t", "sigma0_x", "sigma0_y", "sigma0_z", "domega_x", "domega_y", "domega_z", "omega_x",
    "omega_y", "omega_z", "A_xx", "A_yy", "A_zz", "A_xy", "A_xz", "A_yz",
];

/// Compares `estimates` with `truth`, row by row (both in time order, matched by `t`;
/// memory does not grow with the files).
pub fn compare(truth: &Path, estimates: &Path) -> Result<Comparison, Box<dyn Error>> {
    compare_shown(truth, estimates, false)
}

/// [`compare`], with a progress bar on stderr (drawn only on a terminal) if `progress`.
pub fn compare_shown(
    truth: &Path,
    estimates: &Path,
    progress: bool,
) -> Result<Comparison, Box<dyn Error>> {
    let bar = crate::progress::reading(progress, estimates, "compare");
    let with_sd = crate::columns::has_columns(estimates, &DEVIATIONS);
    let extra: &[&str] = if with_sd { &DEVIATIONS } else { &[] };
    let mut rows_in = Matched::open(truth, estimates, &COLUMNS, extra)?;
    // The estimates row: COLUMNS, then (with deviations) DEVIATIONS.
    let (mut e, mut t) = (
        [0.0; COLUMNS.len() + DEVIATIONS.len()],
        [0.0; COLUMNS.len()],
    );
    let width = COLUMNS.len() + extra.len();
    let (sd_sigma0, sd_omega, flags) = (COLUMNS.len(), COLUMNS.len() + 3, COLUMNS.len() + 6);
    let mut sums = [0.0f64; 4];
    let mut rows = 0;
    let mut silent = Silent::default();
    while rows_in.next_into(&mut e[..width], &mut t)? {
        if rows % 4096 == 0 {
            bar.set_position(rows_in.estimates_read());
        }
        if with_sd && e[flags] == 0.0 {
            let beyond = |est: usize, sd: usize| {
                (0..3).any(|k| (e[est + k] - t[est + k]).abs() > SILENT_SD * e[sd + k])
            };
            // σ0 and Ω start at columns 1 and 7 of COLUMNS.
            silent.sigma0 += usize::from(beyond(1, sd_sigma0));
            silent.omega += usize::from(beyond(7, sd_omega));
        }
        for c in 1..16 {
            let d = e[c] - t[c];
            // Off-diagonals of A count twice in the Frobenius norm.
            let (g, w) = match c {
                1..=3 => (0, 1.0),
                4..=6 => (1, 1.0),
                7..=9 => (2, 1.0),
                10..=12 => (3, 1.0),
                _ => (3, 2.0),
            };
            sums[g] += w * d * d;
        }
        rows += 1;
    }
    bar.finish_and_clear();
    if rows == 0 {
        // An RMS of nothing would read as a perfect score.
        return Err(format!(
            "{}: no row matches a row of {} by t: nothing to compare",
            estimates.display(),
            truth.display()
        )
        .into());
    }
    let n = rows as f64;
    Ok(Comparison {
        rows,
        sigma0: (sums[0] / n).sqrt(),
        domega: (sums[1] / n).sqrt(),
        omega: (sums[2] / n).sqrt(),
        field: (sums[3] / n).sqrt(),
        silent: with_sd.then_some(silent),
    })
}

/// Ω of an estimates file against a rate reference (a gyro), on the rows the reference's valid
/// rows cover.
#[derive(Clone, Debug, Default)]
pub struct RateComparison {
    /// Rows of the estimates file.
    pub rows: usize,
    /// Rows compared (covered by valid reference rows).
    pub compared: usize,
    /// The reference rows left out, and why.
    pub dropped: Dropped,
    /// Per axis: RMS of the Ω error, rad/s.
    pub rms: [f64; 3],
    /// Per axis: median of |Ω error|, rad/s.
    pub median: [f64; 3],
    /// RMS of |Ω error| (the vector's length), rad/s.
    pub rms_norm: f64,
    /// Median of |Ω error|, rad/s.
    pub median_norm: f64,
}

/// Compares the Ω of `estimates` with the reference rate file `reference` (its valid rows by
/// `validity`, interpolated to the estimates' times; the reference format of docs/formats.md).
/// A progress bar on stderr (drawn only on a terminal) if `progress`, over the estimates read.
pub fn compare_reference(
    reference: &Path,
    validity: &Validity,
    estimates: &Path,
    progress: bool,
) -> Result<RateComparison, Box<dyn Error>> {
    let bar = crate::progress::reading(progress, estimates, "compare");
    let mut cols = Columns::open(estimates, &["t", "omega_x", "omega_y", "omega_z"])?;
    let (mut times, mut omega) = (Vec::new(), Vec::new());
    let mut row = [0.0; 4];
    while cols.next_into(&mut row)? {
        if times.len() % 4096 == 0 {
            bar.set_position(cols.bytes_read());
        }
        times.push(row[0]);
        omega.push([row[1], row[2], row[3]]);
    }
    bar.finish_and_clear();
    if times.is_empty() {
        return Err(format!("{}: no rows: nothing to compare", estimates.display()).into());
    }
    let r = read_at(reference, validity, &times)?;
    let mut errors: Vec<[f64; 3]> = Vec::with_capacity(times.len());
    for ((w, wr), covered) in omega.iter().zip(r.omega.iter()).zip(r.covered.iter()) {
        if *covered {
            errors.push(core::array::from_fn(|i| w[i] - wr[i]));
        }
    }
    if errors.is_empty() {
        return Err(format!(
            "{}: no row of {} falls between two valid reference rows: nothing to compare",
            reference.display(),
            estimates.display()
        )
        .into());
    }
    let n = errors.len() as f64;
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let norms: Vec<f64> = errors
        .iter()
        .map(|e| (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt())
        .collect();
    Ok(RateComparison {
        rows: times.len(),
        compared: errors.len(),
        rms: core::array::from_fn(|i| (errors.iter().map(|e| e[i] * e[i]).sum::<f64>() / n).sqrt()),
        median: core::array::from_fn(|i| median(errors.iter().map(|e| e[i].abs()).collect())),
        rms_norm: (norms.iter().map(|x| x * x).sum::<f64>() / n).sqrt(),
        median_norm: median(norms),
        dropped: r.dropped,
    })
}
