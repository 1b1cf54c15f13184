//! Named numeric columns of a CSV file, read whole (the end-to-end tests' estimates, truth and
//! reference files; gzip-compressed or not).

use std::path::Path;

/// Every row's values of the columns `names` (in that order); an empty or non-numeric field
/// reads as NaN. Panics, naming it, on a missing file or column (a test's own files).
pub fn read_columns(path: &Path, names: &[&str]) -> Vec<Vec<f64>> {
    // Through the tool's own reader: a recording may be stored gzip-compressed.
    let bytes = ballisto::output::read_input(path).unwrap_or_else(|e| panic!("{e}"));
    let text = String::from_utf8(bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let idx: Vec<usize> = names
        .iter()
        .map(|n| {
            header
                .iter()
                .position(|h| h == n)
                .unwrap_or_else(|| panic!("{}: no column {n}", path.display()))
        })
        .collect();
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            idx.iter()
                .map(|&i| f.get(i).and_then(|v| v.parse().ok()).unwrap_or(f64::NAN))
                .collect()
        })
        .collect()
}
