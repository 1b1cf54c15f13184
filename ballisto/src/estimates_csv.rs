//! The estimates file (docs/formats.md) and the truth file share these column names.

use std::io::Write;

use estimator_core::{Estimate, Real};

use crate::decimal::{push_f64, push_int};

/// The contract columns, in order (docs/formats.md).
pub const COLUMNS: [&str; 17] = [
    "t", "sigma0_x", "sigma0_y", "sigma0_z", "domega_x", "domega_y", "domega_z", "omega_x",
    "omega_y", "omega_z", "A_xx", "A_yy", "A_zz", "A_xy", "A_xz", "A_yz", "flags",
];

/// Extra columns that follow the contract ones.
pub const EXTRA_COLUMNS: [&str; 20] = [
    "chi2",
    "dof",
    "branches",
    "frame",
    "sd_sigma0_x",
    "sd_sigma0_y",
    "sd_sigma0_z",
    "sd_domega_x",
    "sd_domega_y",
    "sd_domega_z",
    "sd_omega_x",
    "sd_omega_y",
    "sd_omega_z",
    "epsilon",
    "sd_A_xx",
    "sd_A_yy",
    "sd_A_zz",
    "sd_A_xy",
    "sd_A_xz",
    "sd_A_yz",
];

/// The gravity gradient of model G (docs/formats.md: `Γ = A − {Ω}²`, empty under model F) and
/// its standard deviations, after [`EXTRA_COLUMNS`].
pub const GAMMA_COLUMNS: [&str; 12] = [
    "gamma_xx",
    "gamma_yy",
    "gamma_zz",
    "gamma_xy",
    "gamma_xz",
    "gamma_yz",
    "sd_gamma_xx",
    "sd_gamma_yy",
    "sd_gamma_zz",
    "sd_gamma_xy",
    "sd_gamma_xz",
    "sd_gamma_yz",
];

/// The branch tracker's cost margin of the best competing branch (docs/formats.md), after
/// [`GAMMA_COLUMNS`]; empty when the record does not carry it (a motion report of the
/// 142-octet layout).
pub const MARGIN_COLUMNS: [&str; 1] = ["branch_margin"];

/// docs/formats.md: bit i set when the i-th channel of the arrangement file is out of the
/// estimate at that row (by fault isolation, a part missing, or by command); after
/// [`MARGIN_COLUMNS`].
pub const EXCLUDED_COLUMNS: [&str; 1] = ["excluded"];

/// docs/formats.md (the `pl_*` columns) and docs/integrity.md: the protection levels of σ0 (m/s²), Ω′ (rad/s²) and
/// Ω (rad/s), after [`EXCLUDED_COLUMNS`]; empty where there is no bound.
pub const PROTECTION_COLUMNS: [&str; 3] = ["pl_sigma0", "pl_domega", "pl_omega"];

/// Writes the header line.
pub fn write_header<W: Write>(w: &mut W) -> std::io::Result<()> {
    writeln!(
        w,
        "{},{},{},{},{},{}",
        COLUMNS.join(","),
        EXTRA_COLUMNS.join(","),
        GAMMA_COLUMNS.join(","),
        MARGIN_COLUMNS.join(","),
        EXCLUDED_COLUMNS.join(","),
        PROTECTION_COLUMNS.join(",")
    )
}

/// Writes one row (the text `Display` gives each number; see `crate::decimal`); `gamma`:
/// the estimate is model G's, whose gravity gradient fills [`GAMMA_COLUMNS`] (else empty);
/// `excluded`: the channels out of it ([`EXCLUDED_COLUMNS`]).
pub fn write_row<W: Write, T: Real>(
    w: &mut W,
    t: f64,
    e: &Estimate<T>,
    gamma: bool,
    excluded: u64,
) -> std::io::Result<()> {
    let mut line = Vec::with_capacity(768);
    format_row(&mut line, t, e, gamma, excluded);
    w.write_all(&line)
}

/// Appends one row, its line end included, to `line`.
fn format_row<T: Real>(line: &mut Vec<u8>, t: f64, e: &Estimate<T>, gamma: bool, excluded: u64) {
    let real = |line: &mut Vec<u8>, v: f64| {
        line.push(b',');
        push_f64(line, v);
    };
    push_f64(line, t);
    for v in e.sigma0.iter().chain(e.domega.iter()).chain(e.omega.iter()) {
        real(line, v.to_f64());
    }
    for v in e.field.0.iter() {
        real(line, v.to_f64());
    }
    line.push(b',');
    push_int(line, e.flags.0);
    real(line, e.chi2.to_f64());
    for v in [e.dof, e.branches, e.frame] {
        line.push(b',');
        push_int(line, v);
    }
    for v in e
        .sd_sigma0
        .iter()
        .chain(e.sd_domega.iter())
        .chain(e.sd_omega.iter())
    {
        real(line, v.to_f64());
    }
    line.push(b',');
    push_int(line, e.epsilon);
    for v in e.sd_field.0.iter() {
        real(line, v.to_f64());
    }
    if gamma {
        let (g, sd) = e.gravity_gradient();
        for v in g.0.iter().chain(sd.0.iter()) {
            real(line, v.to_f64());
        }
    } else {
        line.extend_from_slice(&[b','; GAMMA_COLUMNS.len()]);
    }
    let margin = e.branch_margin.to_f64();
    if margin.is_finite() {
        real(line, margin);
    } else {
        line.push(b',');
    }
    line.push(b',');
    push_int(line, excluded);
    match &e.protection {
        Some(pl) => pl.iter().for_each(|v| real(line, v.to_f64())),
        None => line.extend_from_slice(&[b','; PROTECTION_COLUMNS.len()]),
    }
    line.push(b'\n');
}

/// Rows handed to the writing thread at a time (with at most two batches queued, the memory
/// in flight is a few hundred KB whatever the record's length).
const BATCH: usize = 512;

/// A batch of rows on its way to the writing thread.
type Batch<T> = Vec<(f64, Estimate<T>, u64, bool)>;

/// An estimates file written on a thread of its own: the caller estimates while the rows
/// before are formatted and written (on two cores `ballisto estimate` then runs at the speed
/// of the slower half instead of the sum; docs/validation.md, "Speed of the ground tool"). Rows are written in order; the
/// first write error ends the thread and is returned by the next [`Self::push`] or by
/// [`Self::finish`].
pub struct ThreadedWriter<T> {
    batch: Batch<T>,
    tx: Option<std::sync::mpsc::SyncSender<Batch<T>>>,
    thread: Option<std::thread::JoinHandle<std::io::Result<()>>>,
}

impl<T: Real + Send + 'static> ThreadedWriter<T> {
    /// Writes the header, then every row pushed, to `w`.
    pub fn new<W: Write + Send + 'static>(mut w: W) -> Self {
        let (tx, rx) = std::sync::mpsc::sync_channel::<Batch<T>>(2);
        let thread = std::thread::spawn(move || {
            write_header(&mut w)?;
            let mut text = Vec::with_capacity(768 * BATCH);
            for batch in rx {
                text.clear();
                for (t, e, excluded, gamma) in &batch {
                    format_row(&mut text, *t, e, *gamma, *excluded);
                }
                w.write_all(&text)?;
            }
            w.flush()
        });
        ThreadedWriter {
            batch: Vec::with_capacity(BATCH),
            tx: Some(tx),
            thread: Some(thread),
        }
    }

    /// Queues one row (`excluded`: the channels out of it, bit per channel; `gamma` as in
    /// [`write_row`]: the row's estimate is model G's).
    pub fn push(
        &mut self,
        t: f64,
        e: &Estimate<T>,
        excluded: u64,
        gamma: bool,
    ) -> std::io::Result<()> {
        self.batch.push((t, *e, excluded, gamma));
        if self.batch.len() >= BATCH {
            self.send()?;
        }
        Ok(())
    }

    fn send(&mut self) -> std::io::Result<()> {
        let batch = std::mem::replace(&mut self.batch, Vec::with_capacity(BATCH));
        let sent = self.tx.as_ref().map(|tx| tx.send(batch).is_ok());
        if sent == Some(true) {
            return Ok(());
        }
        // The thread ended early: its error.
        self.join()
    }

    fn join(&mut self) -> std::io::Result<()> {
        self.tx = None;
        match self.thread.take().map(|h| h.join()) {
            Some(Ok(r)) => r,
            Some(Err(_)) => Err(std::io::Error::other("the writing thread panicked")),
            None => Err(std::io::Error::other("the writing thread has ended")),
        }
    }

    /// Writes what is queued, flushes and ends the thread.
    pub fn finish(mut self) -> std::io::Result<()> {
        if !self.batch.is_empty() {
            self.send()?;
        }
        self.join()
    }
}
