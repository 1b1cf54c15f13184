//! Thin singular value decomposition (one-sided Jacobi) and the orthogonal complement of its
//! range, in `f64`. Used only when the arrangement, channel mask or frame changes — never in the
//! sample loop. One-sided Jacobi is chosen for its accuracy on small matrices and its short code.

use crate::real::Real;

/// Most columns a design matrix has (model G: σ0, Ω′, d).
pub const MAX_COLS: usize = 9;

/// Thin SVD `G = U diag(s) Vᵀ` of an `n × k` matrix given by columns.
pub struct Svd<const CAP: usize> {
    /// Left singular vectors, as columns (`k` of them, length `n`).
    pub u: [[f64; CAP]; MAX_COLS],
    /// Singular values, descending.
    pub s: [f64; MAX_COLS],
    /// Right singular vectors: `v[row][col]`, `k × k`.
    pub v: [[f64; MAX_COLS]; MAX_COLS],
    /// Rows.
    pub n: usize,
    /// Columns.
    pub k: usize,
}

impl<const CAP: usize> Svd<CAP> {
    /// Decomposes the `n × k` matrix whose column `j` is `cols[j][..n]`.
    /// Requires `n <= CAP`, `k <= MAX_COLS`, `k <= n` (callers check; out-of-range sizes are clamped).
    pub fn new(cols: &[[f64; CAP]; MAX_COLS], n: usize, k: usize) -> Self {
        let n = n.min(CAP);
        let k = k.min(MAX_COLS).min(n);
        let mut u = *cols;
        let mut v = [[0.0; MAX_COLS]; MAX_COLS];
        for (j, row) in v.iter_mut().enumerate().take(k) {
            row[j] = 1.0;
        }
        for _sweep in 0..60 {
            let mut rotated = false;
            for p in 0..k {
                for q in (p + 1)..k {
                    let (mut alpha, mut beta, mut gamma) = (0.0, 0.0, 0.0);
                    for i in 0..n {
                        alpha += u[p][i] * u[p][i];
                        beta += u[q][i] * u[q][i];
                        gamma += u[p][i] * u[q][i];
                    }
                    if gamma == 0.0 || libm::fabs(gamma) <= 1e-15 * Real::sqrt(alpha * beta) {
                        continue;
                    }
                    rotated = true;
                    let zeta = (beta - alpha) / (2.0 * gamma);
                    let t = libm::copysign(1.0, zeta)
                        / (libm::fabs(zeta) + Real::sqrt(1.0 + zeta * zeta));
                    let c = 1.0 / Real::sqrt(1.0 + t * t);
                    let s = c * t;
                    for i in 0..n {
                        let (a, b) = (u[p][i], u[q][i]);
                        u[p][i] = c * a - s * b;
                        u[q][i] = s * a + c * b;
                    }
                    for row in v.iter_mut().take(k) {
                        let (a, b) = (row[p], row[q]);
                        row[p] = c * a - s * b;
                        row[q] = s * a + c * b;
                    }
                }
            }
            if !rotated {
                break;
            }
        }
        let mut s = [0.0; MAX_COLS];
        for j in 0..k {
            let norm = Real::sqrt(u[j][..n].iter().map(|x| x * x).sum::<f64>());
            s[j] = norm;
            if norm > 0.0 {
                for x in u[j][..n].iter_mut() {
                    *x /= norm;
                }
            }
        }
        // Sort descending (selection sort: k <= 9).
        for a in 0..k {
            let mut best = a;
            for b in (a + 1)..k {
                if s[b] > s[best] {
                    best = b;
                }
            }
            if best != a {
                s.swap(a, best);
                u.swap(a, best);
                for row in v.iter_mut().take(k) {
                    row.swap(a, best);
                }
            }
        }
        Svd { u, s, v, n, k }
    }

    /// `(n, k)` within the capacities (as `new` made them): stated again here so that the
    /// compiler sees every index below is in range and emits no bounds-check panic paths.
    fn dims(&self) -> (usize, usize) {
        let n = self.n.min(CAP);
        (n, self.k.min(MAX_COLS).min(n))
    }

    /// Ratio of largest to smallest singular value (infinite when the smallest is 0).
    pub fn condition(&self) -> f64 {
        if self.k == 0 {
            return f64::INFINITY;
        }
        let smallest = self.s[self.k - 1];
        if smallest > 0.0 {
            self.s[0] / smallest
        } else {
            f64::INFINITY
        }
    }

    /// Pseudo-inverse `G⁺ = V diag(1/s) Uᵀ` into `out[row][..n]` (`k` rows).
    pub fn pseudo_inverse(&self, out: &mut [[f64; CAP]]) {
        let (n, k) = self.dims();
        for (r, out_row) in out.iter_mut().enumerate().take(k) {
            for i in 0..n {
                let mut acc = 0.0;
                for j in 0..k {
                    if self.s[j] > 0.0 {
                        acc += self.v[r][j] / self.s[j] * self.u[j][i];
                    }
                }
                out_row[i] = acc;
            }
        }
    }

    /// Orthonormal basis of the orthogonal complement of the range of `U` (the left null space
    /// of `G`): `n − k` vectors written as rows of `out`. Householder QR of `U`, then the last
    /// `n − k` columns of `Q`.
    pub fn left_null_space(&self, out: &mut [[f64; CAP]]) {
        let (n, k) = self.dims();
        let mut a = self.u; // columns, reduced in place
        let mut refl = [[0.0; CAP]; MAX_COLS];
        for j in 0..k {
            // Reflector for a[j][j..n].
            let norm = Real::sqrt(a[j][j..n].iter().map(|x| x * x).sum::<f64>());
            let alpha = if a[j][j] > 0.0 { -norm } else { norm };
            let mut vj = [0.0; CAP];
            vj[j..n].copy_from_slice(&a[j][j..n]);
            vj[j] -= alpha;
            let vnorm2: f64 = vj[j..n].iter().map(|x| x * x).sum();
            if vnorm2 > 0.0 {
                let inv = 1.0 / Real::sqrt(vnorm2);
                for x in vj[j..n].iter_mut() {
                    *x *= inv;
                }
            }
            for col in a.iter_mut().take(k).skip(j) {
                let d: f64 = (j..n).map(|i| vj[i] * col[i]).sum();
                for i in j..n {
                    col[i] -= 2.0 * d * vj[i];
                }
            }
            refl[j] = vj;
        }
        for (c, out_row) in (k..n).zip(out.iter_mut()) {
            let mut e = [0.0; CAP];
            e[c] = 1.0;
            for vj in refl[..k].iter().rev() {
                let d: f64 = (0..n).map(|i| vj[i] * e[i]).sum();
                for i in 0..n {
                    e[i] -= 2.0 * d * vj[i];
                }
            }
            out_row[..n].copy_from_slice(&e[..n]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn test_matrix() -> ([[f64; 8]; MAX_COLS], usize, usize) {
        let mut cols = [[0.0; 8]; MAX_COLS];
        let (n, k) = (8, 4);
        let mut seed = 12345u64;
        for col in cols.iter_mut().take(k) {
            for x in col.iter_mut().take(n) {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                *x = ((seed >> 33) as f64 / (1u64 << 31) as f64) - 0.5;
            }
        }
        (cols, n, k)
    }

    #[test]
    fn reconstructs_and_pseudo_inverse_is_left_inverse() {
        let (cols, n, k) = test_matrix();
        let svd = Svd::<8>::new(&cols, n, k);
        for j in 0..k {
            for i in 0..n {
                let rec: f64 = (0..k).map(|l| svd.u[l][i] * svd.s[l] * svd.v[j][l]).sum();
                assert!((rec - cols[j][i]).abs() < 1e-12);
            }
        }
        let mut pinv = [[0.0; 8]; MAX_COLS];
        svd.pseudo_inverse(&mut pinv);
        for r in 0..k {
            for c in 0..k {
                let v: f64 = (0..n).map(|i| pinv[r][i] * cols[c][i]).sum();
                let want = if r == c { 1.0 } else { 0.0 };
                assert!((v - want).abs() < 1e-12, "pinv*G [{r}][{c}] = {v}");
            }
        }
    }

    #[test]
    fn null_space_is_orthonormal_and_orthogonal_to_range() {
        let (cols, n, k) = test_matrix();
        let svd = Svd::<8>::new(&cols, n, k);
        let mut null = [[0.0; 8]; 8];
        svd.left_null_space(&mut null);
        for a in 0..n - k {
            for b in 0..n - k {
                let d: f64 = (0..n).map(|i| null[a][i] * null[b][i]).sum();
                assert!((d - if a == b { 1.0 } else { 0.0 }).abs() < 1e-12);
            }
            for col in cols.iter().take(k) {
                let d: f64 = (0..n).map(|i| null[a][i] * col[i]).sum();
                assert!(d.abs() < 1e-12);
            }
        }
    }
}
