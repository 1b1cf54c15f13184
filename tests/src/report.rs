//! Rows of the validation report's tables. A test prints one row per figure it holds to a bar
//! (or reports without one); `scripts/validate.sh` gathers the rows of a section into its table
//! (case, parts, figure, measured, bound, verdict) and folds every other printed line into the
//! section's test output.

use std::fmt::Display;

/// The prefix `scripts/validate.sh` picks the rows out by.
pub const PREFIX: &str = "report: ";

/// What the parts of a case were.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Parts {
    /// Noise and clock offsets only.
    Ideal,
    /// Each part's bias, scale, axis and position errors drawn from its datasheet.
    Datasheet,
    /// Recordings of real parts.
    Real,
}

impl Parts {
    fn label(self) -> &'static str {
        match self {
            Parts::Ideal => "ideal",
            Parts::Datasheet => "datasheet-realistic",
            Parts::Real => "real",
        }
    }
}

/// Prints a row: `case`, its `parts`, the `figure` and its `measured` value, the `bound` it
/// is held to and whether it `holds`. Returns `holds`, for the test's assertion.
pub fn row(
    case: &str,
    parts: Parts,
    figure: &str,
    measured: impl Display,
    bound: &str,
    holds: bool,
) -> bool {
    println!(
        "{PREFIX}| {case} | {} | {figure} | {measured} | {bound} | {} |",
        parts.label(),
        if holds { "pass" } else { "FAIL" }
    );
    holds
}

/// Prints a row of a figure reported without a bar.
pub fn figure(case: &str, parts: Parts, figure: &str, measured: impl Display) {
    println!(
        "{PREFIX}| {case} | {} | {figure} | {measured} | — | reported |",
        parts.label()
    );
}

/// Prints a row of the RMS errors of σ0, Ω′ and Ω over those of ideal parts on the same
/// motion, held to `limit`; returns whether all three hold (a NaN does not).
pub fn over_ideal(case: &str, parts: Parts, ratios: &[f64; 3], limit: f64) -> bool {
    row(
        case,
        parts,
        "RMS error σ0 / Ω′ / Ω over ideal parts",
        format!("{:.2} / {:.2} / {:.2}", ratios[0], ratios[1], ratios[2]),
        &format!("≤ {limit}"),
        ratios.iter().all(|r| *r <= limit),
    )
}

/// Prints a row of the rows silently wrong (off by more than 5 reported deviations without a
/// flag), held to one in `per` of `rows`; returns whether it holds.
pub fn silent(case: &str, parts: Parts, silent: usize, rows: usize, per: usize) -> bool {
    row(
        case,
        parts,
        "rows silently wrong",
        format!("{silent} of {rows}"),
        &format!("≤ 1 in {per}"),
        silent * per <= rows,
    )
}

/// Prints a row of a case refused by name (`reason`): an outcome the sweep allows.
pub fn refused(case: &str, parts: Parts, reason: impl Display) {
    row(
        case,
        parts,
        "outcome",
        format!("refused: {reason}"),
        "identified, or refused by name",
        true,
    );
}
