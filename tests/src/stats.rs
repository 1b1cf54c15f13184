//! Error statistics of estimates against truth.

/// RMS of the Euclidean error of 3-vectors.
pub fn rms3(est: &[[f64; 3]], truth: &[[f64; 3]]) -> f64 {
    let n = est.len().min(truth.len()).max(1);
    let s: f64 = est
        .iter()
        .zip(truth.iter())
        .map(|(a, b)| (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2))
        .sum();
    (s / n as f64).sqrt()
}

/// RMS of the Frobenius error of symmetric matrices `[xx, yy, zz, xy, xz, yz]`.
pub fn rms_sym(est: &[[f64; 6]], truth: &[[f64; 6]]) -> f64 {
    let n = est.len().min(truth.len()).max(1);
    let s: f64 = est
        .iter()
        .zip(truth.iter())
        .map(|(a, b)| {
            (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>()
                + 2.0 * (3..6).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>()
        })
        .sum();
    (s / n as f64).sqrt()
}
