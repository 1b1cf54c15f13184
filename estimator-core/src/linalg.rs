//! Small fixed-size linear algebra: 3-vectors, 3×3 matrices, symmetric 3×3 matrices.
//!
//! Plain arrays and free functions: no allocation, no panics (all indices are constants).

use crate::real::Real;

/// A 3-vector.
pub type Vec3<T> = [T; 3];
/// A 3×3 matrix, row-major.
pub type Mat3<T> = [[T; 3]; 3];

/// True if no element is NaN or infinite, in one comparison: `x·0` is ±0 for finite `x` and
/// NaN otherwise, so the sum of the products is zero exactly when every element is finite.
#[inline]
pub fn all_finite<T: Real>(x: &[T]) -> bool {
    let mut acc = T::ZERO;
    for v in x {
        acc += *v * T::ZERO;
    }
    acc == T::ZERO
}

/// `a · b`.
#[inline]
pub fn dot<T: Real>(a: &Vec3<T>, b: &Vec3<T>) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `a × b`.
#[inline]
pub fn cross<T: Real>(a: &Vec3<T>, b: &Vec3<T>) -> Vec3<T> {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `|a|²`.
#[inline]
pub fn norm2<T: Real>(a: &Vec3<T>) -> T {
    dot(a, a)
}

/// `k a`.
#[inline]
pub fn scale<T: Real>(k: T, a: &Vec3<T>) -> Vec3<T> {
    [k * a[0], k * a[1], k * a[2]]
}

/// `a + b`.
#[inline]
pub fn add<T: Real>(a: &Vec3<T>, b: &Vec3<T>) -> Vec3<T> {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// `a − b`.
#[inline]
pub fn sub<T: Real>(a: &Vec3<T>, b: &Vec3<T>) -> Vec3<T> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `M v`.
#[inline]
pub fn mat_vec<T: Real>(m: &Mat3<T>, v: &Vec3<T>) -> Vec3<T> {
    [dot(&m[0], v), dot(&m[1], v), dot(&m[2], v)]
}

/// `Mᵀ v`.
#[inline]
pub fn mat_t_vec<T: Real>(m: &Mat3<T>, v: &Vec3<T>) -> Vec3<T> {
    [
        m[0][0] * v[0] + m[1][0] * v[1] + m[2][0] * v[2],
        m[0][1] * v[0] + m[1][1] * v[1] + m[2][1] * v[2],
        m[0][2] * v[0] + m[1][2] * v[1] + m[2][2] * v[2],
    ]
}

/// Determinant of a 3×3 matrix.
#[inline]
pub fn det3<T: Real>(m: &Mat3<T>) -> T {
    dot(&m[0], &cross(&m[1], &m[2]))
}

/// Adjugate (transposed cofactor matrix): `M adj(M) = det(M) I`.
#[inline]
pub fn adjugate<T: Real>(m: &Mat3<T>) -> Mat3<T> {
    // Columns of adj are the cross products of rows.
    let c0 = cross(&m[1], &m[2]);
    let c1 = cross(&m[2], &m[0]);
    let c2 = cross(&m[0], &m[1]);
    [
        [c0[0], c1[0], c2[0]],
        [c0[1], c1[1], c2[1]],
        [c0[2], c1[2], c2[2]],
    ]
}

/// A symmetric 3×3 matrix stored as `[xx, yy, zz, xy, xz, yz]`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sym3<T>(pub [T; 6]);

impl<T: Real> Sym3<T> {
    /// The zero matrix.
    pub const fn zero() -> Self {
        Sym3([T::ZERO; 6])
    }

    /// Builds from a full matrix, averaging the off-diagonal pairs.
    pub fn from_mat(m: &Mat3<T>) -> Self {
        let h = T::of(0.5);
        Sym3([
            m[0][0],
            m[1][1],
            m[2][2],
            h * (m[0][1] + m[1][0]),
            h * (m[0][2] + m[2][0]),
            h * (m[1][2] + m[2][1]),
        ])
    }

    /// The full matrix.
    pub fn to_mat(&self) -> Mat3<T> {
        let s = &self.0;
        [[s[0], s[3], s[4]], [s[3], s[1], s[5]], [s[4], s[5], s[2]]]
    }

    /// `aᵀ S a`.
    #[inline]
    pub fn quad(&self, a: &Vec3<T>) -> T {
        let s = &self.0;
        let two = T::of(2.0);
        s[0] * a[0] * a[0]
            + s[1] * a[1] * a[1]
            + s[2] * a[2] * a[2]
            + two * (s[3] * a[0] * a[1] + s[4] * a[0] * a[2] + s[5] * a[1] * a[2])
    }

    /// `aᵀ S a` from the precomputed products `o = [a₀², a₁², a₂², 2a₀a₁, 2a₀a₂, 2a₁a₂]`
    /// ([`outer6`]): six multiply-adds, for many forms with the same `a`.
    #[inline]
    pub fn quad_outer(&self, o: &[T; 6]) -> T {
        let s = &self.0;
        s[0] * o[0] + s[1] * o[1] + s[2] * o[2] + s[3] * o[3] + s[4] * o[4] + s[5] * o[5]
    }

    /// `aᵀ S b`.
    #[inline]
    pub fn bilinear(&self, a: &Vec3<T>, b: &Vec3<T>) -> T {
        dot(a, &self.mul_vec(b))
    }

    /// `S a`.
    #[inline]
    pub fn mul_vec(&self, a: &Vec3<T>) -> Vec3<T> {
        let s = &self.0;
        [
            s[0] * a[0] + s[3] * a[1] + s[4] * a[2],
            s[3] * a[0] + s[1] * a[1] + s[5] * a[2],
            s[4] * a[0] + s[5] * a[1] + s[2] * a[2],
        ]
    }

    /// Trace.
    #[inline]
    pub fn trace(&self) -> T {
        self.0[0] + self.0[1] + self.0[2]
    }

    /// `self + k other`.
    #[inline]
    pub fn add_scaled(&self, k: T, other: &Self) -> Self {
        let mut r = *self;
        for (ri, oi) in r.0.iter_mut().zip(other.0.iter()) {
            *ri += k * *oi;
        }
        r
    }

    /// `self + g gᵀ` (rank-one update, for normal equations `JᵀJ`).
    #[inline]
    pub fn add_outer(&mut self, g: &Vec3<T>) {
        // The products by 1 are exact and folded away.
        self.add_outer_scaled(T::ONE, g);
    }

    /// `self + k g gᵀ`.
    #[inline]
    pub fn add_outer_scaled(&mut self, k: T, g: &Vec3<T>) {
        let kg = [k * g[0], k * g[1], k * g[2]];
        self.0[0] += kg[0] * g[0];
        self.0[1] += kg[1] * g[1];
        self.0[2] += kg[2] * g[2];
        self.0[3] += kg[0] * g[1];
        self.0[4] += kg[0] * g[2];
        self.0[5] += kg[1] * g[2];
    }

    /// `k self`.
    #[inline]
    pub fn scaled(&self, k: T) -> Self {
        let mut r = *self;
        for ri in r.0.iter_mut() {
            *ri *= k;
        }
        r
    }

    /// Converts between scalar types.
    pub fn cast<B: Real>(&self) -> Sym3<B> {
        let mut r = Sym3::<B>::zero();
        for (ri, si) in r.0.iter_mut().zip(self.0.iter()) {
            *ri = B::of(si.to_f64());
        }
        r
    }

    /// `{a}² = a aᵀ − |a|² I` (the paper's centripetal term for `a = Ω`).
    pub fn skew_squared(a: &Vec3<T>) -> Self {
        let n = norm2(a);
        Sym3([
            a[0] * a[0] - n,
            a[1] * a[1] - n,
            a[2] * a[2] - n,
            a[0] * a[1],
            a[0] * a[2],
            a[1] * a[2],
        ])
    }

    /// `V S Vᵀ` (`V` orthogonal: a change of basis).
    pub fn rotate(&self, v: &Mat3<T>) -> Self {
        let m = self.to_mat();
        let mut vm = [[T::ZERO; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                vm[i][j] = v[i][0] * m[0][j] + v[i][1] * m[1][j] + v[i][2] * m[2][j];
            }
        }
        let mut r = [[T::ZERO; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                r[i][j] = vm[i][0] * v[j][0] + vm[i][1] * v[j][1] + vm[i][2] * v[j][2];
            }
        }
        Sym3::from_mat(&r)
    }

    /// The sensor form `Q = ½(s Rᵀ + R sᵀ) − (s·R) I`, so that `s·{a}² R = aᵀ Q a`
    /// (paper section 7: `½ a·({s}{R} + {R}{s}) a`).
    pub fn sensor_form(s: &Vec3<T>, r: &Vec3<T>) -> Self {
        let h = T::of(0.5);
        let sr = dot(s, r);
        Sym3([
            s[0] * r[0] - sr,
            s[1] * r[1] - sr,
            s[2] * r[2] - sr,
            h * (s[0] * r[1] + r[0] * s[1]),
            h * (s[0] * r[2] + r[0] * s[2]),
            h * (s[1] * r[2] + r[1] * s[2]),
        ])
    }

    /// Solves `S x = b` for a symmetric positive definite `S` from its six distinct cofactors;
    /// `None` unless `det S > 1e-12 (tr S / 3)³` (not positive definite to working precision)
    /// or if the solution is not finite.
    pub fn solve(&self, b: &Vec3<T>) -> Option<Vec3<T>> {
        self.solve_with_trace(b).map(|(x, _)| x)
    }

    /// [`Sym3::solve`], also returning `tr S⁻¹` (free from the same cofactors).
    pub fn solve_with_trace(&self, b: &Vec3<T>) -> Option<(Vec3<T>, T)> {
        let s = &self.0;
        let (Sym3([c00, c11, c22, c01, c02, c12]), det) = self.cofactors();
        let t = (s[0] + s[1] + s[2]) / T::of(3.0);
        if !(det > T::of(1e-12) * t * t * t) {
            return None;
        }
        let inv = T::ONE / det;
        let x = [
            (c00 * b[0] + c01 * b[1] + c02 * b[2]) * inv,
            (c01 * b[0] + c11 * b[1] + c12 * b[2]) * inv,
            (c02 * b[0] + c12 * b[1] + c22 * b[2]) * inv,
        ];
        let tr = (c00 + c11 + c22) * inv;
        (x.iter().all(|v| v.is_finite()) && tr.is_finite()).then_some((x, tr))
    }

    /// The cofactor matrix (symmetric: six distinct cofactors) and the determinant.
    #[inline]
    pub(crate) fn cofactors(&self) -> (Sym3<T>, T) {
        let s = &self.0;
        let c = Sym3([
            s[1] * s[2] - s[5] * s[5],
            s[0] * s[2] - s[4] * s[4],
            s[0] * s[1] - s[3] * s[3],
            s[4] * s[5] - s[3] * s[2],
            s[3] * s[5] - s[1] * s[4],
            s[3] * s[4] - s[0] * s[5],
        ]);
        let det = s[0] * c.0[0] + s[3] * c.0[3] + s[4] * c.0[4];
        (c, det)
    }

    /// The determinant.
    pub fn det(&self) -> T {
        self.cofactors().1
    }

    /// Inverse from the cofactors; `None` when `|det|` is not above `tiny`.
    pub fn inverse(&self, tiny: T) -> Option<Self> {
        let (c, det) = self.cofactors();
        if !(det.abs() > tiny) || !det.is_finite() {
            return None;
        }
        Some(c.scaled(T::ONE / det))
    }
}

/// Standard deviations of the components of `{w}²` (`[xx, yy, zz, xy, xz, yz]`) for a rate `w`
/// with covariance `c` (first order: `d{w}² = dw wᵀ + w dwᵀ − 2 (w·dw) I`).
pub fn skew_squared_sd<T: Real>(w: &Vec3<T>, c: &Sym3<T>) -> Sym3<T> {
    let two = T::of(2.0);
    let z = T::ZERO;
    // Rows of ∂{w}²/∂w.
    let rows = [
        [z, -two * w[1], -two * w[2]],
        [-two * w[0], z, -two * w[2]],
        [-two * w[0], -two * w[1], z],
        [w[1], w[0], z],
        [w[2], z, w[0]],
        [z, w[2], w[1]],
    ];
    let mut out = Sym3::zero();
    for (o, r) in out.0.iter_mut().zip(rows.iter()) {
        *o = c.quad(r).max(T::ZERO).sqrt();
    }
    out
}

/// [`skew_squared_sd`] for an isotropic covariance `var · I`: `sd = √var · |row|` for each
/// row of `∂{w}²/∂w`.
pub fn skew_squared_sd_isotropic<T: Real>(w: &Vec3<T>, var: T) -> Sym3<T> {
    let s = var.max(T::ZERO).sqrt();
    let two_s = T::of(2.0) * s;
    let (w0, w1, w2) = (w[0] * w[0], w[1] * w[1], w[2] * w[2]);
    let (r01, r02, r12) = ((w0 + w1).sqrt(), (w0 + w2).sqrt(), (w1 + w2).sqrt());
    Sym3([
        two_s * r12,
        two_s * r02,
        two_s * r01,
        s * r01,
        s * r02,
        s * r12,
    ])
}

/// The products of `a` used by [`Sym3::quad_outer`].
#[inline]
pub fn outer6<T: Real>(a: &Vec3<T>) -> [T; 6] {
    let two = T::of(2.0);
    [
        a[0] * a[0],
        a[1] * a[1],
        a[2] * a[2],
        two * a[0] * a[1],
        two * a[0] * a[2],
        two * a[1] * a[2],
    ]
}

/// Solves `M x = b` for a general 3×3 `M` by Cramer's rule; `None` if (nearly) singular
/// relative to the size of `M`.
pub fn solve3<T: Real>(m: &Mat3<T>, b: &Vec3<T>) -> Option<Vec3<T>> {
    let det = det3(m);
    let mut big = T::ZERO;
    for row in m {
        big = big.max(norm2(row));
    }
    let scale3 = big * big.sqrt();
    if !(det.abs() > T::of(1e-12) * scale3) || !det.is_finite() {
        return None;
    }
    let adj = adjugate(m);
    let x = scale(T::ONE / det, &mat_vec(&adj, b));
    if x.iter().all(|v| v.is_finite()) {
        Some(x)
    } else {
        None
    }
}

/// Rotation matrix (rows = frame axes in body coordinates) of a unit quaternion `[w, x, y, z]`,
/// normalised here.
pub fn quat_to_mat(q: [f64; 4]) -> Mat3<f64> {
    let n = Real::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    let (w, x, y, z) = (q[0] / n, q[1] / n, q[2] / n, q[3] / n);
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

/// `∂Ω/∂A` at `w` (3 × 6, columns for `A`'s `[xx, yy, zz, xy, xz, yz]`), from the first order
/// of `ΩΩᵀ = M`, `M = (A − Γ) − ½ tr(A − Γ) I`: `dΩ = (dM Ω − Ω (Ωᵀ dM Ω)/(2|Ω|²)) / |Ω|²` with
/// `dM = dA − ½ tr(dA) I`. `None` at `w = 0` (no first order there).
pub fn omega_jacobian<T: Real>(w: &Vec3<T>) -> Option<[[T; 6]; 3]> {
    let w2 = norm2(w);
    if !(w2 > T::ZERO) {
        return None;
    }
    let half = T::of(0.5);
    let two = T::of(2.0);
    // `dM Ω` and `Ωᵀ dM Ω` for a unit step of each component.
    let dmw: [(Vec3<T>, T); 6] = [
        (
            [half * w[0], -half * w[1], -half * w[2]],
            w[0] * w[0] - half * w2,
        ),
        (
            [-half * w[0], half * w[1], -half * w[2]],
            w[1] * w[1] - half * w2,
        ),
        (
            [-half * w[0], -half * w[1], half * w[2]],
            w[2] * w[2] - half * w2,
        ),
        ([w[1], w[0], T::ZERO], two * w[0] * w[1]),
        ([w[2], T::ZERO, w[0]], two * w[0] * w[2]),
        ([T::ZERO, w[2], w[1]], two * w[1] * w[2]),
    ];
    let inv = T::ONE / w2;
    let mut jac = [[T::ZERO; 6]; 3];
    for (col, (d, q)) in dmw.iter().enumerate() {
        let k = *q * half * inv;
        for r in 0..3 {
            jac[r][col] = (d[r] - w[r] * k) * inv;
        }
    }
    Some(jac)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn symmetric_solve_matches_cramer_and_rejects_singular() {
        let s = Sym3([4.0, 3.0, 2.5, 0.7, -0.4, 0.9]);
        let b = [1.0, -2.0, 0.5];
        let x = s.solve(&b).unwrap();
        let y = solve3(&s.to_mat(), &b).unwrap();
        for i in 0..3 {
            assert!((x[i] - y[i]).abs() < 1e-12);
        }
        // Rank one (singular) and indefinite: rejected.
        let v = [1.0, 2.0, -1.0];
        let mut r1 = Sym3::zero();
        r1.add_outer(&v);
        assert!(r1.solve(&b).is_none());
        assert!(Sym3([1.0, -1.0, 1.0, 0.0, 0.0, 0.0]).solve(&b).is_none());
    }

    #[test]
    fn isotropic_skew_squared_sd_matches_the_general_form() {
        let w = [0.3, -1.2, 2.0];
        let var = 0.04;
        let a = skew_squared_sd_isotropic(&w, var);
        let b = skew_squared_sd(&w, &Sym3([var, var, var, 0.0, 0.0, 0.0]));
        for i in 0..6 {
            assert!((a.0[i] - b.0[i]).abs() < 1e-12, "{i}");
        }
    }

    #[test]
    fn sensor_form_matches_double_cross() {
        let s = [0.3, -0.5, 0.81];
        let r = [0.12, 0.07, -0.2];
        let a = [1.3, -0.4, 2.2];
        let q = Sym3::sensor_form(&s, &r).quad(&a);
        let direct = dot(&s, &cross(&a, &cross(&a, &r)));
        assert!((q - direct).abs() < 1e-12, "{q} vs {direct}");
    }

    #[test]
    fn rotate_preserves_trace_and_quadratic() {
        let m = Sym3([1.0, 2.0, -3.0, 0.5, -0.2, 0.7]);
        let v = quat_to_mat([0.9, 0.1, -0.3, 0.2]);
        let r = m.rotate(&v);
        assert!((r.trace() - m.trace()).abs() < 1e-12);
        let a = [0.3, 0.4, -1.0];
        let va = mat_vec(&v, &a);
        assert!((r.quad(&va) - m.quad(&a)).abs() < 1e-12);
    }
}
