//! The truth file of a simulated record (docs/formats.md): the estimate columns up to `A_yz`,
//! then the attitude and the gravity gradient.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use estimator_core::Sym3;
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

/// The simulator's truth output: `truth.csv`, and `reference.csv` when the scenario has a
/// reference rate sensor.
pub struct TruthFiles<W: Write> {
    truth: W,
    reference: Option<(W, hal_sim::reference::ReferenceSensor)>,
}

impl<W: Write> TruthFiles<W> {
    /// Writes the headers; `reference` is the reference sensor's writer and model, if any.
    pub fn new(
        mut truth: W,
        reference: Option<(W, hal_sim::reference::ReferenceSensor)>,
    ) -> std::io::Result<Self> {
        write_truth_header(&mut truth)?;
        let mut reference = reference;
        if let Some((w, _)) = &mut reference {
            writeln!(w, "t,omega_x,omega_y,omega_z")?;
        }
        Ok(TruthFiles { truth, reference })
    }

    /// The truth of sample set `k` at time `t`.
    pub fn row(&mut self, k: usize, tr: &Truth) -> std::io::Result<()> {
        write_truth_row(&mut self.truth, tr)?;
        if let Some((w, sensor)) = &mut self.reference {
            if let Some(omega) = sensor.sample(k, tr) {
                writeln!(w, "{},{},{},{}", tr.t, omega[0], omega[1], omega[2])?;
            }
        }
        Ok(())
    }

    /// Flushes both files.
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.truth.flush()?;
        if let Some((w, _)) = &mut self.reference {
            w.flush()?;
        }
        Ok(())
    }
}

/// Columns of the truth file after the estimate columns: the attitude (body → inertial
/// quaternion).
pub const TRUTH_EXTRA_COLUMNS: [&str; 4] = ["q_w", "q_x", "q_y", "q_z"];

/// The header of a truth file: the estimate columns up to `A_yz`, the attitude, then the
/// gravity gradient `Γ = A − {Ω}²` under the estimates' names (`gamma_*`).
pub fn write_truth_header(w: &mut impl Write) -> std::io::Result<()> {
    writeln!(
        w,
        "{},{},{}",
        estimates_csv::COLUMNS[..16].join(","),
        TRUTH_EXTRA_COLUMNS.join(","),
        estimates_csv::GAMMA_COLUMNS[..6].join(",")
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
        .chain(
            tr.field
                .add_scaled(-1.0, &Sym3::skew_squared(&tr.omega))
                .0
                .iter(),
        )
    {
        write!(w, ",{v}")?;
    }
    writeln!(w)
}
