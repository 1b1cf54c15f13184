//! The truth file of a simulated record (interfaces.md): the estimate columns up to `A_yz`,
//! then the attitude.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use hal_sim::motion::Truth;

use crate::estimates_csv;

/// Writes a truth file (same column names as the estimates file).
pub fn write_truth(path: &Path, truth: &[Truth]) -> std::io::Result<()> {
    let mut w = BufWriter::new(File::create(path)?);
    write_truth_header(&mut w)?;
    for tr in truth {
        write_truth_row(&mut w, tr)?;
    }
    w.flush()
}

/// Columns of the truth file after the estimate columns: the attitude (body → inertial
/// quaternion).
pub const TRUTH_EXTRA_COLUMNS: [&str; 4] = ["q_w", "q_x", "q_y", "q_z"];

/// The header of a truth file: the estimate columns up to `A_yz`, then the attitude.
pub fn write_truth_header(w: &mut impl Write) -> std::io::Result<()> {
    writeln!(
        w,
        "{},{}",
        estimates_csv::COLUMNS[..16].join(","),
        TRUTH_EXTRA_COLUMNS.join(",")
    )
}

/// One row of a truth file.
pub fn write_truth_row(w: &mut impl Write, tr: &Truth) -> std::io::Result<()> {
    write!(w, "{}", tr.t)?;
    for v in tr
        .sigma0
        .iter()
        .chain(tr.domega.iter())
        .chain(tr.omega.iter())
        .chain(tr.field.0.iter())
        .chain(tr.attitude.iter())
    {
        write!(w, ",{v}")?;
    }
    writeln!(w)
}
