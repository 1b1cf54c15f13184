//! The reference rate file (docs/formats.md): `t, omega_x, omega_y, omega_z` (rad/s, body; more
//! columns may follow), with the rows a real reference cannot vouch for left out (a gyro that
//! saturated, a reading at its range: [`Validity`]), brought to the samples' instants by linear
//! interpolation.

use std::error::Error;
use std::path::Path;

use nalgebra::Vector3;

/// The reference at the sample instants.
pub struct ReferenceAt {
    /// Ω at each sample (zero where not covered).
    pub omega: Vec<Vector3<f64>>,
    /// Whether the reference covers the sample (it lies between two valid reference rows).
    pub covered: Vec<bool>,
    /// The reference rows left out, and why.
    pub dropped: Dropped,
}

/// The valid rows of a reference rate file: times (s, increasing) and Ω (rad/s, body).
pub struct Reference {
    /// Times, s.
    pub t: Vec<f64>,
    /// Ω at each time, rad/s.
    pub omega: Vec<Vector3<f64>>,
}

/// What says a reference row is not to be used. Columns named `valid` (0: invalid) or ending
/// in `_saturated` (not 0: invalid) say so wherever they are: in the reference file itself or
/// in [`Validity::flags`].
#[derive(Clone, Copy, Debug, Default)]
pub struct Validity<'a> {
    /// A flags file beside the reference (CSV: `t` with the reference's times, then flag
    /// columns), e.g. `reference_flags.csv` with `gyro_saturated`.
    pub flags: Option<&'a Path>,
    /// The gyro's range, rad/s: a row with an axis at [`RANGE_SHARE`] of it or beyond is a
    /// clipped reading.
    pub range: Option<f64>,
}

/// A reference axis at this share of the gyro's range or beyond is taken as clipped.
pub const RANGE_SHARE: f64 = 0.99;

/// Reference rows left out, by reason.
#[derive(Clone, Debug, Default)]
pub struct Dropped {
    /// Rows in the file.
    pub rows: usize,
    /// Per reason (a flag column's name, or the range), the rows it left out (a row counts
    /// once, under its first reason).
    pub reasons: Vec<(String, usize)>,
}

impl Dropped {
    /// Rows left out.
    pub fn total(&self) -> usize {
        self.reasons.iter().map(|(_, n)| n).sum()
    }

    fn count(&mut self, reason: &str) {
        match self.reasons.iter_mut().find(|(r, _)| r == reason) {
            Some((_, n)) => *n += 1,
            None => self.reasons.push((reason.to_string(), 1)),
        }
    }

    /// One sentence for the user, e.g. "3 352 of 37 439 reference rows left out
    /// (gyro_saturated 3 352)"; `None` when none was.
    pub fn describe(&self, file: &Path) -> Option<String> {
        (self.total() > 0).then(|| {
            let why: Vec<String> = self
                .reasons
                .iter()
                .map(|(r, n)| format!("{r} {n}"))
                .collect();
            format!(
                "{}: {} of {} reference rows left out ({})",
                file.display(),
                self.total(),
                self.rows,
                why.join(", ")
            )
        })
    }
}

/// Reads `path` (its rows valid by `validity`) and interpolates it to `times` (not across a
/// gap of more than 1.5 median intervals: rows left out mean "no reference here"). Errors name
/// the file and line; a reference whose valid rows span less than half of the samples is
/// refused (it does not overlap the record).
pub fn read_at(
    path: &Path,
    validity: &Validity,
    times: &[f64],
) -> Result<ReferenceAt, Box<dyn Error>> {
    let (reference, dropped) = read(path, validity)?;
    reference.at(times, &dropped, path)
}

impl Reference {
    /// The reference (read from `path`, `dropped` its rows left out) interpolated to `times`,
    /// as [`read_at`] does: a calibration that shifts the reference's times reads the file once.
    pub fn at(
        &self,
        times: &[f64],
        dropped: &Dropped,
        path: &Path,
    ) -> Result<ReferenceAt, Box<dyn Error>> {
        let name = path.display().to_string();
        let (t_ref, w_ref) = (&self.t, &self.omega);
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
            // Within an interval that is no gap, or at a valid row's own instant.
            let at_row = (t - t0).abs() <= 1e-9 || (t - t1).abs() <= 1e-9;
            let inside = at_row || (t >= t0 && t <= t1 && t1 - t0 <= longest);
            covered.push(inside);
            omega.push(if inside {
                let u = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
                w_ref[j] * (1.0 - u) + w_ref[j + 1] * u
            } else {
                Vector3::zeros()
            });
        }
        // Overlap, not coverage: the rows left out are reported, not refused.
        let (first, last) = (t_ref[0], t_ref[t_ref.len() - 1]);
        let n = times.iter().filter(|&&t| t >= first && t <= last).count();
        if 2 * n < times.len() {
            let left_out = dropped
                .describe(path)
                .map(|d| format!("; {d}"))
                .unwrap_or_default();
            return Err(format!(
            "{name}: spans {n} of the {} sample instants ({:.3}–{:.3} s against {:.3}–{:.3} s): it does not overlap the record{left_out}",
            times.len(),
            t_ref[0],
            t_ref[t_ref.len() - 1],
            times.first().copied().unwrap_or(0.0),
            times.last().copied().unwrap_or(0.0)
        )
        .into());
        }
        Ok(ReferenceAt {
            omega,
            covered,
            dropped: dropped.clone(),
        })
    }
}

/// The flag columns of a header: (index, name, whether a 0 means invalid — `valid` — or a
/// non-zero value does — `*_saturated`).
fn flag_columns(header: &csv::StringRecord) -> Vec<(usize, String, bool)> {
    header
        .iter()
        .enumerate()
        .filter_map(|(i, h)| {
            let h = h.trim();
            if h == "valid" {
                Some((i, h.to_string(), true))
            } else if h.ends_with("_saturated") {
                Some((i, h.to_string(), false))
            } else {
                None
            }
        })
        .collect()
}

/// The first flag of `rec` that makes it invalid; an error names the field.
fn invalid_by<'a>(
    rec: &csv::StringRecord,
    flags: &'a [(usize, String, bool)],
    at: &str,
) -> Result<Option<&'a str>, String> {
    for (i, name, zero_invalid) in flags {
        let field = rec.get(*i).unwrap_or("").trim();
        let v = field
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("{at}: {name} \"{field}\" is not a finite number"))?;
        if (v == 0.0) == *zero_invalid {
            return Ok(Some(name));
        }
    }
    Ok(None)
}

type Input = Box<dyn std::io::Read + Send>;

fn open(path: &Path) -> Result<(csv::Reader<Input>, csv::StringRecord), String> {
    let name = path.display().to_string();
    let input =
        crate::text_input::open_text(path).map_err(|e| format!("{name}: cannot open: {e}"))?;
    let mut rdr = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .from_reader(input);
    let header = rdr
        .headers()
        .map_err(|e| format!("{name} line 1: cannot read the header: {e}"))?
        .clone();
    Ok((rdr, header))
}

/// The rows a flags file marks invalid: (t, reason) in file order. Errors name the file and
/// line (no `t`, no flag column, a field that is not a number).
fn flagged_times(path: &Path) -> Result<Vec<(f64, String)>, String> {
    let name = path.display().to_string();
    let (mut rdr, header) = open(path)?;
    let t_col = header
        .iter()
        .position(|h| h.trim() == "t")
        .ok_or_else(|| format!("{name} line 1: no column \"t\""))?;
    let flags = flag_columns(&header);
    if flags.is_empty() {
        return Err(format!(
            "{name} line 1: no flag column (\"valid\", or a name ending in \"_saturated\")"
        ));
    }
    let mut out = Vec::new();
    for (i, rec) in rdr.records().enumerate() {
        let at = format!("{name} line {}", i + 2);
        let rec = rec.map_err(|e| format!("{at}: {e}"))?;
        let field = rec.get(t_col).unwrap_or("").trim();
        let t = field
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("{at}: t \"{field}\" is not a finite number"))?;
        if let Some(why) = invalid_by(&rec, &flags, &at)? {
            out.push((t, why.to_string()));
        }
    }
    Ok(out)
}

/// Reads a reference rate file and keeps its valid rows (`validity`): errors name the file and
/// line (a missing column, a field that is not a finite number, a time that does not
/// increase, a flags row whose time is not the reference's, fewer than two valid rows).
pub fn read(path: &Path, validity: &Validity) -> Result<(Reference, Dropped), Box<dyn Error>> {
    let name = path.display().to_string();
    let (mut rdr, header) = open(path)?;
    let col = |c: &str| {
        header.iter().position(|h| h.trim() == c).ok_or_else(|| {
            format!("{name} line 1: no column \"{c}\" (expected t, omega_x, omega_y, omega_z)")
        })
    };
    let cols = [col("t")?, col("omega_x")?, col("omega_y")?, col("omega_z")?];
    let own_flags = flag_columns(&header);
    let mut t_ref: Vec<f64> = Vec::new();
    let mut w_ref: Vec<Vector3<f64>> = Vec::new();
    let mut why: Vec<Option<String>> = Vec::new();
    for (i, rec) in rdr.records().enumerate() {
        let at = format!("{name} line {}", i + 2);
        let rec = rec.map_err(|e| format!("{at}: {e}"))?;
        let mut v = [0.0; 4];
        for (x, &c) in v.iter_mut().zip(cols.iter()) {
            let field = rec.get(c).unwrap_or("").trim();
            *x = field
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("{at}: \"{field}\" is not a finite number"))?;
        }
        if t_ref.last().is_some_and(|&t0| v[0] <= t0) {
            return Err(format!("{at}: t = {} does not increase", v[0]).into());
        }
        let w = Vector3::new(v[1], v[2], v[3]);
        let clipped = validity
            .range
            .filter(|r| w.amax() >= RANGE_SHARE * r)
            .map(|r| format!("at the range ±{r} rad/s"));
        why.push(
            invalid_by(&rec, &own_flags, &at)?
                .map(str::to_string)
                .or(clipped),
        );
        t_ref.push(v[0]);
        w_ref.push(w);
    }
    if let Some(flags) = validity.flags {
        for (t, reason) in flagged_times(flags)? {
            // Same instants as the reference's (a flags file written beside it).
            let k = t_ref.partition_point(|&x| x < t - 1e-9);
            if k == t_ref.len() || (t_ref[k] - t).abs() > 1e-9 * t.abs().max(1.0) {
                return Err(format!(
                    "{}: t = {t} is not a time of {name} (a flags file carries the reference's times)",
                    flags.display()
                )
                .into());
            }
            why[k].get_or_insert(reason);
        }
    }
    let mut dropped = Dropped {
        rows: t_ref.len(),
        ..Dropped::default()
    };
    let (mut t_valid, mut w_valid) = (Vec::with_capacity(t_ref.len()), Vec::new());
    for ((t, w), why) in t_ref.iter().zip(w_ref.iter()).zip(why.iter()) {
        match why {
            Some(reason) => dropped.count(reason),
            None => {
                t_valid.push(*t);
                w_valid.push(*w);
            }
        }
    }
    if t_valid.len() < 2 {
        let left_out = dropped
            .describe(path)
            .map(|d| format!(" ({d})"))
            .unwrap_or_default();
        return Err(format!("{name}: fewer than two valid rows{left_out}").into());
    }
    Ok((
        Reference {
            t: t_valid,
            omega: w_valid,
        },
        dropped,
    ))
}
