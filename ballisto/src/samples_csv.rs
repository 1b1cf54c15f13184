//! Streaming reader of the samples file (docs/formats.md): header `t,<channel names...>` in any
//! channel order, one row per sample set. Memory does not grow with the file.
//!
//! An empty field means "channel not available at this sample": it is passed on as NaN and the
//! estimator outputs its prediction for that row, flagged `INPUT_INVALID` (bit 5). Optional
//! columns `temp_<channel>` carry a channel's temperature (°C; empty: not read at that row),
//! `var_<channel>` a reading's noise variance over the channel's declared one (empty: 1).

use std::fmt;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use hal_sim::motion::Truth;

use crate::plausibility::AbsurdCount;

/// An error in a samples file, naming the file and line.
#[derive(Debug)]
pub struct SamplesError {
    /// File.
    pub file: String,
    /// Line (1-based), if known.
    pub line: Option<u64>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for SamplesError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(l) => write!(f, "{} line {}: {}", self.file, l, self.message),
            None => write!(f, "{}: {}", self.file, self.message),
        }
    }
}

impl std::error::Error for SamplesError {}

/// Reads rows of a samples file into channel order.
pub struct SamplesReader<R: std::io::Read> {
    rdr: csv::Reader<R>,
    /// For each channel (estimator order), its column in the file.
    column: Vec<usize>,
    t_column: usize,
    file: String,
    last_t: Option<(f64, u64)>,
    record: csv::StringRecord,
    /// Per channel: the largest plausible magnitude ([`crate::plausibility`]).
    bounds: Vec<f64>,
    /// Per channel: readings beyond its bound, read as missing.
    absurd: Vec<AbsurdCount>,
    /// Whether the last row read had one.
    row_absurd: bool,
    /// For each channel, its temperature's column, if the file has one.
    temp_column: Vec<Option<usize>>,
    /// For each channel, its variance's column, if the file has one.
    var_column: Vec<Option<usize>>,
}

impl SamplesReader<Box<dyn std::io::Read + Send>> {
    /// Opens `path` (stdin for `-`) and matches its header against the channel `names`.
    pub fn open(path: &Path, names: &[String]) -> Result<Self, SamplesError> {
        let file = path.display().to_string();
        let reader = crate::text_input::open_text(path).map_err(|e| SamplesError {
            file: file.clone(),
            line: None,
            message: format!("cannot open: {e}"),
        })?;
        Self::new(reader, &file, names)
    }
}

impl<R: std::io::Read> SamplesReader<R> {
    /// Wraps a reader; `file` names it in errors.
    pub fn new(reader: R, file: &str, names: &[String]) -> Result<Self, SamplesError> {
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(true)
            // Fields are trimmed where they are read (`str::trim`, as `Trim::All` would):
            // the reader's own trimming allocates a record per row.
            .comment(Some(b'#'))
            .from_reader(reader);
        let err = |message: String| SamplesError {
            file: file.to_string(),
            line: Some(1),
            message,
        };
        let header = rdr
            .headers()
            .map_err(|e| err(format!("cannot read the header: {e}")))?
            .clone();
        let mut t_column = None;
        let mut column = vec![usize::MAX; names.len()];
        let mut temp_column = vec![None; names.len()];
        let mut var_column = vec![None; names.len()];
        for (i, h) in header.iter().map(str::trim).enumerate() {
            if h == "t" {
                if t_column.replace(i).is_some() {
                    return Err(err("column \"t\" appears twice".into()));
                }
                continue;
            }
            let of = |prefix: &str| {
                h.strip_prefix(prefix)
                    .and_then(|n| names.iter().position(|m| m == n))
            };
            let slot = match (names.iter().position(|n| n == h), of("temp_"), of("var_")) {
                (Some(c), _, _) => &mut column[c],
                (None, Some(c), _) => temp_column[c].get_or_insert(usize::MAX),
                (None, None, Some(c)) => var_column[c].get_or_insert(usize::MAX),
                (None, None, None) => {
                    return Err(err(format!(
                        "column \"{h}\" is not a channel of the arrangement, nor a channel's temperature (temp_<channel>) or variance (var_<channel>)"
                    )))
                }
            };
            if *slot != usize::MAX {
                return Err(err(format!("column \"{h}\" appears twice")));
            }
            *slot = i;
        }
        let t_column = t_column.ok_or_else(|| err("the header has no \"t\" column".into()))?;
        if let Some(c) = column.iter().position(|&c| c == usize::MAX) {
            return Err(err(format!(
                "channel \"{}\" has no column in the header",
                names[c]
            )));
        }
        Ok(SamplesReader {
            rdr,
            column,
            t_column,
            file: file.to_string(),
            last_t: None,
            record: csv::StringRecord::new(),
            bounds: vec![f64::INFINITY; names.len()],
            absurd: vec![AbsurdCount::default(); names.len()],
            row_absurd: false,
            temp_column,
            var_column,
        })
    }

    /// Whether the file has a temperature column for `channel`.
    pub fn has_temperature(&self, channel: usize) -> bool {
        self.temp_column.get(channel).is_some_and(Option::is_some)
    }

    /// The last row's temperatures into `last` (channel order, °C), where the row has one;
    /// elsewhere `last` keeps what it held. Errors: a field that is not a number, or not a
    /// temperature a part can report (`estimator_core::thermal::plausible`).
    pub fn temperatures(&self, last: &mut [f64]) -> Result<(), SamplesError> {
        let line = self.record.position().map(|p| p.line());
        for (t, c) in last.iter_mut().zip(&self.temp_column) {
            let Some(c) = *c else { continue };
            let field = self.record.get(c).map_or("", str::trim);
            if field.is_empty() {
                continue;
            }
            let v: f64 = field.parse().unwrap_or(f64::NAN);
            if !estimator_core::thermal::plausible(v) {
                return Err(SamplesError {
                    file: self.file.clone(),
                    line,
                    message: format!(
                        "\"{field}\" in column {} is not a temperature (°C, −100 to 200)",
                        c + 1
                    ),
                });
            }
            *t = v;
        }
        Ok(())
    }

    /// Whether the file has a variance column (`var_<channel>`).
    pub fn has_variance(&self) -> bool {
        self.var_column.iter().any(Option::is_some)
    }

    /// The last row's noise variances into `out` (channel order, over each channel's declared
    /// one; 1 where the row or the file has none). Errors: a field that is not a finite
    /// positive number.
    pub fn variances(&self, out: &mut [f64]) -> Result<(), SamplesError> {
        let line = self.record.position().map(|p| p.line());
        for (v, c) in out.iter_mut().zip(&self.var_column) {
            *v = 1.0;
            let Some(c) = *c else { continue };
            let field = self.record.get(c).map_or("", str::trim);
            if field.is_empty() {
                continue;
            }
            match field.parse::<f64>() {
                Ok(x) if x.is_finite() && x > 0.0 => *v = x,
                _ => {
                    return Err(SamplesError {
                        file: self.file.clone(),
                        line,
                        message: format!(
                            "\"{field}\" in column {} is not a variance (a finite number above 0)",
                            c + 1
                        ),
                    })
                }
            }
        }
        Ok(())
    }

    /// Reads a reading no part of full scale `ranges[channel]` can give
    /// ([`crate::plausibility::reading_bounds`]) as missing (NaN), and counts it
    /// ([`Self::absurd_warnings`], [`Self::row_absurd`]).
    pub fn with_ranges(mut self, ranges: &[f64]) -> Self {
        self.bounds = crate::plausibility::reading_bounds(ranges);
        self
    }

    /// A warning per channel (`names`, in channel order) with readings read as missing for
    /// being absurd ([`crate::plausibility::absurd`]).
    pub fn absurd_warnings(&self, names: &[String]) -> Vec<String> {
        crate::plausibility::absurd(&self.absurd, names, &self.bounds)
    }

    /// Whether the last row read had a reading beyond its bound.
    pub fn row_absurd(&self) -> bool {
        self.row_absurd
    }

    /// The bytes of the file read so far (decompressed).
    pub fn bytes_read(&self) -> u64 {
        self.rdr.position().byte()
    }

    /// Reads the next row into `out` (channel order, NaN for empty fields); returns its time,
    /// or `None` at the end of the file.
    pub fn next_row(&mut self, out: &mut [f64]) -> Result<Option<f64>, SamplesError> {
        let ok = self
            .rdr
            .read_record(&mut self.record)
            .map_err(|e| SamplesError {
                file: self.file.clone(),
                line: e.position().map(|p| p.line()),
                message: match e.kind() {
                    csv::ErrorKind::UnequalLengths {
                        expected_len, len, ..
                    } => {
                        format!("{len} fields, the header has {expected_len}")
                    }
                    _ => e.to_string(),
                },
            })?;
        if !ok {
            return Ok(None);
        }
        let line = self.record.position().map(|p| p.line()).unwrap_or(0);
        let err = |message: String| SamplesError {
            file: self.file.clone(),
            line: Some(line),
            message,
        };
        let tf = self.record[self.t_column].trim();
        let t: f64 = tf
            .parse()
            .map_err(|_| err(format!("t = \"{tf}\" is not a number")))?;
        if !t.is_finite() {
            return Err(err(format!("t = \"{tf}\" is not finite")));
        }
        if let Some((t0, l0)) = self.last_t {
            if t <= t0 {
                return Err(err(format!(
                    "t = {t} does not increase (line {l0} has t = {t0})"
                )));
            }
        }
        self.last_t = Some((t, line));
        self.row_absurd = false;
        for (i, (o, &c)) in out.iter_mut().zip(self.column.iter()).enumerate() {
            let field = self.record[c].trim();
            *o = if field.is_empty() {
                f64::NAN
            } else {
                let v: f64 = field
                    .parse()
                    .map_err(|_| err(format!("\"{field}\" in column {} is not a number", c + 1)))?;
                if !v.is_finite() {
                    return Err(err(format!(
                        "\"{field}\" in column {} is not finite",
                        c + 1
                    )));
                }
                if v.abs() > self.bounds[i] {
                    let a = &mut self.absurd[i];
                    a.count += 1;
                    a.largest = a.largest.max(v.abs());
                    self.row_absurd = true;
                    f64::NAN
                } else {
                    v
                }
            };
        }
        Ok(Some(t))
    }
}

/// Writes a samples file.
pub fn write_samples(
    path: &Path,
    names: &[String],
    truth: &[Truth],
    outputs: &[Vec<f64>],
) -> std::io::Result<()> {
    let mut w = BufWriter::new(File::create(path)?);
    writeln!(w, "t,{}", names.join(","))?;
    for (tr, row) in truth.iter().zip(outputs.iter()) {
        write_row(&mut w, tr.t, row.iter().copied().map(Some))?;
    }
    w.flush()
}

/// One row: `t`, then each channel's value, or an empty field where it has none.
pub fn write_row(
    w: &mut impl Write,
    t: f64,
    values: impl IntoIterator<Item = Option<f64>>,
) -> std::io::Result<()> {
    write!(w, "{t}")?;
    for v in values {
        match v {
            Some(v) => write!(w, ",{v}")?,
            None => write!(w, ",")?,
        }
    }
    writeln!(w)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reader(text: &str) -> SamplesReader<&[u8]> {
        let names = ["a".to_string(), "b".to_string()];
        SamplesReader::new(text.as_bytes(), "s.csv", &names).unwrap()
    }

    #[test]
    fn variances_are_read_where_given_and_one_elsewhere() {
        let mut r = reader("t,a,b,var_b\n0,1,2,0.625\n0.01,1,2,\n");
        assert!(r.has_variance());
        let (mut row, mut var) = ([0.0; 2], [0.0; 2]);
        r.next_row(&mut row).unwrap();
        r.variances(&mut var).unwrap();
        assert_eq!(var, [1.0, 0.625]);
        r.next_row(&mut row).unwrap();
        r.variances(&mut var).unwrap();
        assert_eq!(var, [1.0, 1.0]);
        assert!(!reader("t,a,b\n0,1,2\n").has_variance());
    }

    #[test]
    fn a_bad_variance_names_the_file_the_line_and_the_field() {
        for bad in ["0", "-1", "nan", "x", "inf"] {
            let text = format!("t,a,b,var_a\n0,1,2,1\n0.01,1,2,{bad}\n");
            let mut r = reader(&text);
            let (mut row, mut var) = ([0.0; 2], [0.0; 2]);
            r.next_row(&mut row).unwrap();
            r.variances(&mut var).unwrap();
            r.next_row(&mut row).unwrap();
            let e = r.variances(&mut var).unwrap_err().to_string();
            assert!(
                e.contains("s.csv") && e.contains('3') && e.contains(bad),
                "{e}"
            );
            assert!(e.contains("not a variance"), "{e}");
        }
        let twice = SamplesReader::new(
            "t,a,b,var_a,var_a\n".as_bytes(),
            "s.csv",
            &["a".to_string(), "b".to_string()],
        );
        assert!(twice.err().unwrap().to_string().contains("appears twice"));
    }
}
