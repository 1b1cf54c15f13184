//! The small symmetric positive definite solves of a channel's fit.

use super::model::PARAMS;
use crate::real::Real;

// A 7×7 (and, for the tumble's search and the frame's motions, 10×10) Cholesky of our own, not nalgebra's: estimator-core has no nalgebra in its target
// build (its SVD is its own, `svd.rs`), and the flight image had 244 B of flash left when this
// was written; these three functions are 40 lines.

/// Cholesky factor (lower) of the leading `n × n` block of the symmetric `a`, in place;
/// `false` unless positive definite with every pivot above 10⁻¹³ of the largest diagonal (in
/// f32, 100 × its epsilon: 1.2 × 10⁻⁵).
#[inline]
pub(crate) fn cholesky<T: Real, const N: usize>(a: &mut [[T; N]; N], n: usize) -> bool {
    let top = (0..n).map(|i| a[i][i]).fold(T::ZERO, T::max);
    if !(top > T::ZERO) || !top.is_finite() {
        return false;
    }
    let floor = T::of(1e-13).max(T::of(100.0) * T::EPSILON) * top;
    for j in 0..n {
        let mut d = a[j][j];
        for k in 0..j {
            d -= a[j][k] * a[j][k];
        }
        if !(d > floor) {
            return false;
        }
        let d = d.sqrt();
        a[j][j] = d;
        for i in (j + 1)..n {
            let mut s = a[i][j];
            for k in 0..j {
                s -= a[i][k] * a[j][k];
            }
            a[i][j] = s / d;
        }
    }
    true
}

/// Solves `L Lᵀ x = b` with the factor [`cholesky`] left in `l`.
#[inline]
pub(crate) fn cholesky_solve<T: Real, const N: usize>(
    l: &[[T; N]; N],
    n: usize,
    b: &[T; N],
) -> [T; N] {
    // The products summed first, then taken from the right-hand side.
    let mut y = [T::ZERO; N];
    for i in 0..n {
        let mut s = T::ZERO;
        for k in 0..i {
            s += l[i][k] * y[k];
        }
        y[i] = (b[i] - s) / l[i][i];
    }
    let mut x = [T::ZERO; N];
    for i in (0..n).rev() {
        let mut s = T::ZERO;
        for k in (i + 1)..n {
            s += l[k][i] * x[k];
        }
        x[i] = (y[i] - s) / l[i][i];
    }
    x
}

/// The inverse of the symmetric positive definite `a`; `None` unless [`cholesky`] factors it.
pub(crate) fn invert_spd<T: Real, const N: usize>(a: &[[T; N]; N]) -> Option<[[T; N]; N]> {
    let mut l = *a;
    if !cholesky(&mut l, N) {
        return None;
    }
    let mut inv = [[T::ZERO; N]; N];
    for c in 0..N {
        let mut e = [T::ZERO; N];
        e[c] = T::ONE;
        let x = cholesky_solve(&l, N, &e);
        for (row, v) in inv.iter_mut().zip(x) {
            row[c] = v;
        }
    }
    Some(inv)
}

/// `(L Lᵀ)⁻¹` at `(k, k)`.
#[inline]
pub(super) fn inverse_diagonal(l: &[[f64; PARAMS]; PARAMS], n: usize, k: usize) -> f64 {
    let mut e = [0.0; PARAMS];
    e[k] = 1.0;
    cholesky_solve(l, n, &e)[k]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cholesky_solves_and_refuses_a_singular_matrix() {
        let mut a = [[0.0; PARAMS]; PARAMS];
        for i in 0..PARAMS {
            for j in 0..PARAMS {
                a[i][j] =
                    1.0 / (1.0 + (i as f64 - j as f64).abs()) + if i == j { 1.0 } else { 0.0 };
            }
        }
        let orig = a;
        let b = [1.0, -2.0, 0.5, 3.0, 0.0, 1.0, -1.0];
        assert!(cholesky(&mut a, PARAMS));
        let x = cholesky_solve(&a, PARAMS, &b);
        for i in 0..PARAMS {
            let r: f64 = (0..PARAMS).map(|j| orig[i][j] * x[j]).sum();
            assert!((r - b[i]).abs() < 1e-12);
        }
        let mut s = [[0.0; PARAMS]; PARAMS];
        s[0][0] = 1.0;
        s[0][1] = 1.0;
        s[1][0] = 1.0;
        s[1][1] = 1.0;
        assert!(!cholesky(&mut s, 2));
    }
}
