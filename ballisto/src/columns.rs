//! Streaming reader of named numeric columns of a CSV file (estimates, truth): one row at a
//! time, so memory does not grow with the record.

use std::collections::HashMap;
use std::path::Path;

/// Reads the columns `names` (in that order) of every row.
pub(crate) struct Columns {
    rdr: csv::Reader<Box<dyn std::io::Read + Send>>,
    record: csv::StringRecord,
    index: Vec<usize>,
    name: String,
}

impl Columns {
    /// Opens `path` and finds the columns; an error names the file and the missing column.
    pub(crate) fn open(path: &Path, names: &[&str]) -> Result<Self, String> {
        let name = path.display().to_string();
        let input =
            crate::text_input::open_text(path).map_err(|e| format!("{name}: cannot open: {e}"))?;
        let mut rdr = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .from_reader(input);
        let header: HashMap<String, usize> = rdr
            .headers()
            .map_err(|e| format!("{name}: cannot read the header: {e}"))?
            .iter()
            .enumerate()
            .map(|(i, h)| (h.to_string(), i))
            .collect();
        let index = names
            .iter()
            .map(|c| {
                header
                    .get(*c)
                    .copied()
                    .ok_or_else(|| format!("{name}: no column \"{c}\""))
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Columns {
            rdr,
            record: csv::StringRecord::new(),
            index,
            name,
        })
    }

    /// The next row's values into `out` (one per column asked for); `false` at the end. An
    /// error names the file and line.
    pub(crate) fn next_into(&mut self, out: &mut [f64]) -> Result<bool, String> {
        self.next_row(out, false)
    }

    /// As [`Self::next_into`], an empty field read as NaN (a value not there at that row).
    pub(crate) fn next_with_gaps(&mut self, out: &mut [f64]) -> Result<bool, String> {
        self.next_row(out, true)
    }

    fn next_row(&mut self, out: &mut [f64], gaps: bool) -> Result<bool, String> {
        let more = self
            .rdr
            .read_record(&mut self.record)
            .map_err(|e| format!("{}: {e}", self.name))?;
        if !more {
            return Ok(false);
        }
        let line = self.record.position().map(|p| p.line()).unwrap_or(0);
        for (o, &i) in out.iter_mut().zip(self.index.iter()) {
            let f = self.record.get(i).unwrap_or("");
            if gaps && f.is_empty() {
                *o = f64::NAN;
                continue;
            }
            *o = f
                .parse::<f64>()
                .map_err(|_| format!("{} line {line}: \"{f}\" is not a number", self.name))?;
        }
        Ok(true)
    }

    /// The bytes of the file read so far (decompressed).
    pub(crate) fn bytes_read(&self) -> u64 {
        self.rdr.position().byte()
    }

    /// The file's name, for messages.
    pub(crate) fn name(&self) -> &str {
        &self.name
    }
}

/// The column names of the CSV file `path`'s header.
pub(crate) fn header(path: &Path) -> Result<Vec<String>, String> {
    let name = path.display().to_string();
    let input =
        crate::text_input::open_text(path).map_err(|e| format!("{name}: cannot open: {e}"))?;
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .from_reader(input);
    Ok(rdr
        .headers()
        .map_err(|e| format!("{name}: cannot read the header: {e}"))?
        .iter()
        .map(str::to_string)
        .collect())
}

/// True if the CSV file `path` can be opened and its header has every column of `names`.
pub(crate) fn has_columns(path: &Path, names: &[&str]) -> bool {
    Columns::open(path, names).is_ok()
}

/// Estimates and truth read in step: each estimates row with the truth row of the same `t`
/// (both files in time order; the truth may have rows the estimates do not).
pub(crate) struct Matched {
    truth: Columns,
    estimates: Columns,
    truth_row: Vec<f64>,
}

impl Matched {
    /// `columns` of both files (the first must be `t`); `extra` further columns of the
    /// estimates only (after `columns` in the estimates row).
    pub(crate) fn open(
        truth: &Path,
        estimates: &Path,
        columns: &[&str],
        extra: &[&str],
    ) -> Result<Self, String> {
        let all: Vec<&str> = columns.iter().chain(extra.iter()).copied().collect();
        Ok(Matched {
            truth: Columns::open(truth, columns)?,
            estimates: Columns::open(estimates, &all)?,
            truth_row: vec![f64::NEG_INFINITY; columns.len()],
        })
    }

    /// The bytes of the estimates file read so far.
    pub(crate) fn estimates_read(&self) -> u64 {
        self.estimates.bytes_read()
    }

    /// The next estimates row into `est` and its truth into `tru`; `false` at the end.
    pub(crate) fn next_into(&mut self, est: &mut [f64], tru: &mut [f64]) -> Result<bool, String> {
        if !self.estimates.next_into(est)? {
            return Ok(false);
        }
        let t = est[0];
        while self.truth_row[0] < t {
            if !self.truth.next_into(&mut self.truth_row)? {
                break;
            }
        }
        if self.truth_row[0].to_bits() != t.to_bits() {
            return Err(format!(
                "{}: t = {t} has no row in {}",
                self.estimates.name(),
                self.truth.name()
            ));
        }
        tru.copy_from_slice(&self.truth_row);
        Ok(true)
    }
}
