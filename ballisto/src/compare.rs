//! `ballisto compare`: RMS errors of an estimates file against a truth file, matched by column
//! name and by `t` (interfaces.md: both files share the column names).

use std::collections::HashMap;
use std::error::Error;
use std::path::Path;

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
}

/// Column index by name, and the rows (every field a number).
pub(crate) type Table = (HashMap<String, usize>, Vec<Vec<f64>>);

pub(crate) fn read(path: &Path) -> Result<Table, Box<dyn Error>> {
    let name = path.display().to_string();
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_path(path)
        .map_err(|e| format!("{name}: cannot open: {e}"))?;
    let header: HashMap<String, usize> = rdr
        .headers()
        .map_err(|e| format!("{name}: cannot read the header: {e}"))?
        .iter()
        .enumerate()
        .map(|(i, h)| (h.to_string(), i))
        .collect();
    let mut rows = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| format!("{name}: {e}"))?;
        let line = rec.position().map(|p| p.line()).unwrap_or(0);
        let row = rec
            .iter()
            .map(|f| {
                f.parse::<f64>()
                    .map_err(|_| format!("{name} line {line}: \"{f}\" is not a number"))
            })
            .collect::<Result<Vec<f64>, String>>()?;
        rows.push(row);
    }
    Ok((header, rows))
}

/// Compares `estimates` with `truth`.
pub fn compare(truth: &Path, estimates: &Path) -> Result<Comparison, Box<dyn Error>> {
    let (th, tr) = read(truth)?;
    let (eh, er) = read(estimates)?;
    let col = |h: &HashMap<String, usize>, file: &Path, c: &str| {
        h.get(c)
            .copied()
            .ok_or_else(|| format!("{}: no column \"{c}\"", file.display()))
    };
    let groups: [(&str, &[&str]); 4] = [
        ("sigma0", &["sigma0_x", "sigma0_y", "sigma0_z"]),
        ("domega", &["domega_x", "domega_y", "domega_z"]),
        ("omega", &["omega_x", "omega_y", "omega_z"]),
        ("A", &["A_xx", "A_yy", "A_zz", "A_xy", "A_xz", "A_yz"]),
    ];
    let (tt, et) = (col(&th, truth, "t")?, col(&eh, estimates, "t")?);
    let mut sums = [0.0f64; 4];
    let truth_by_t: HashMap<u64, &Vec<f64>> = tr.iter().map(|r| (r[tt].to_bits(), r)).collect();
    let mut rows = 0;
    for e in &er {
        let Some(t) = truth_by_t.get(&e[et].to_bits()) else {
            return Err(format!(
                "{}: t = {} has no row in {}",
                estimates.display(),
                e[et],
                truth.display()
            )
            .into());
        };
        for (g, (_, cols)) in groups.iter().enumerate() {
            for (k, c) in cols.iter().enumerate() {
                let d = e[col(&eh, estimates, c)?] - t[col(&th, truth, c)?];
                // Off-diagonals of A count twice in the Frobenius norm.
                sums[g] += if g == 3 && k >= 3 { 2.0 * d * d } else { d * d };
            }
        }
        rows += 1;
    }
    let n = rows.max(1) as f64;
    Ok(Comparison {
        rows,
        sigma0: (sums[0] / n).sqrt(),
        domega: (sums[1] / n).sqrt(),
        omega: (sums[2] / n).sqrt(),
        field: (sums[3] / n).sqrt(),
    })
}
