//! `ballisto compare`: RMS errors of an estimates file against a truth file, matched by column
//! name and by `t` (interfaces.md: both files share the column names).

use std::error::Error;
use std::path::Path;

use crate::columns::Matched;

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
