//! How well the arrangement's frame is tied to the body: the part of a calibrated geometry's
//! error that is common to all channels.
//!
//! An identification (paper §6) fixes each channel's position and axis relative to the others
//! far better than it fixes the whole arrangement relative to the body. What no accelerometer
//! record can decide — the common translation of all positions, and without a reference rate
//! the common rotation and size — is held at the drawing's values by convention, and is then
//! only as good as the mounting. Such an error is common to every sample: it does not average
//! down, and a standard deviation that leaves it out is not honest (an estimate would be wrong
//! by many of its reported deviations, unflagged). So the reported deviations include it.
//!
//! A frame rotated by a small angle `δ`, translated by `t` and scaled by `1 + s` (positions)
//! changes the outputs by, to first order:
//! - σ0 (at the origin): `δ × σ0 + K t` with `K = A + {Ω′}` (the field's gradient, paper
//!   eq. 4: the specific force at `t` is `σ0 + K t`);
//! - Ω′: `δ × Ω′ − s Ω′` (the positions scale `{Ω′}` by `1 / (1 + s)`);
//! - Ω: `δ × Ω − ½ s Ω` (`{Ω}²` scales by `1 / (1 + s)`);
//! - A: `{δ} A − A {δ} − s A`.
//!
//! Without a reference rate there is a fourth freedom: the axes turned by `½ d` and the lever
//! arms by `−½ d` (so that `δ` is their mean rotation). With σ0, Ω′ and Ω all estimated per
//! sample it is absorbed to first order except through the centripetal term's shape, so a
//! self-calibration leaves it at the milliradian level. It changes σ0 by `½ d × σ0` and Ω′ by
//! `−½ (|Ω|² d + (Ω·d) Ω)`; Ω and A only through what the least squares leaks (a tenth of a
//! joint rotation's effect on Ω in the test), which is left out (checked against the
//! estimator on turned geometries: `tests/calibration.rs`).
//!
//! With `δ`, `d`, `t` independent and isotropic (standard deviations per axis) and `s`
//! independent, the variances add to the estimate's own. How large they are follows from an
//! identification's parameter errors ([`motions`]).

pub mod motions;

use crate::estimate::Estimate;
use crate::linalg::{Sym3, Vec3};
use crate::real::Real;

/// Standard deviations of the arrangement frame's common errors (0: the frame is exact, the
/// default; an uncalibrated arrangement carries no claim).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameUncertainty<T> {
    /// Common rotation, rad per axis.
    pub rotation: T,
    /// Common translation of the positions (the origin), m per axis.
    pub translation: T,
    /// Common relative size of the positions (dimensionless).
    pub size: T,
    /// Rotation of the axes relative to the lever arms, rad per axis (module doc).
    pub relative_rotation: T,
}

impl FrameUncertainty<f64> {
    /// True when every deviation is a finite number ≥ 0.
    pub fn is_valid(&self) -> bool {
        [
            self.rotation,
            self.translation,
            self.size,
            self.relative_rotation,
        ]
        .iter()
        .all(|v| v.is_finite() && *v >= 0.0)
    }

    /// The same in the sample-loop scalar.
    pub fn cast<T: Real>(&self) -> FrameUncertainty<T> {
        FrameUncertainty {
            rotation: T::of(self.rotation),
            translation: T::of(self.translation),
            size: T::of(self.size),
            relative_rotation: T::of(self.relative_rotation),
        }
    }
}

impl<T: Real> FrameUncertainty<T> {
    /// True when there is nothing to add.
    pub fn is_zero(&self) -> bool {
        self.rotation == T::ZERO
            && self.translation == T::ZERO
            && self.size == T::ZERO
            && self.relative_rotation == T::ZERO
    }

    /// Adds the frame's common errors (module doc) to the standard deviations of `e`.
    #[inline(never)]
    pub fn widen(&self, e: &mut Estimate<T>) {
        let rot2 = self.rotation * self.rotation;
        let tr2 = self.translation * self.translation;
        let s2 = self.size * self.size;
        // K = A + {Ω′}: row i's squared norm (the σ0 shift per unit translation along i's row).
        let a = e.field.to_mat();
        let dw = &e.domega;
        let k = [
            [a[0][0], a[0][1] - dw[2], a[0][2] + dw[1]],
            [a[1][0] + dw[2], a[1][1], a[1][2] - dw[0]],
            [a[2][0] - dw[1], a[2][1] + dw[0], a[2][2]],
        ];
        let mut var = [T::ZERO; 3];
        for (v, row) in var.iter_mut().zip(k.iter()) {
            *v = tr2 * (row[0] * row[0] + row[1] * row[1] + row[2] * row[2]);
        }
        let rel2 = self.relative_rotation * self.relative_rotation;
        let quarter = T::of(0.25);
        widen_vector(
            &mut e.sd_sigma0,
            &e.sigma0,
            rot2 + quarter * rel2,
            T::ZERO,
            &var,
        );
        // The relative rotation moves Ω′ by `−½ (|Ω|² I + ΩΩᵀ) d`: per component the squares
        // of that row, `¼ (|Ω|⁴ + 3 |Ω|² Ω_i²)`.
        let w = &e.omega;
        let w2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
        let c = quarter * rel2 * w2;
        let three = T::of(3.0);
        let relative = [
            c * (w2 + three * w[0] * w[0]),
            c * (w2 + three * w[1] * w[1]),
            c * (w2 + three * w[2] * w[2]),
        ];
        widen_vector(&mut e.sd_domega, &e.domega, rot2, s2, &relative);
        let none = [T::ZERO; 3];
        widen_vector(&mut e.sd_omega, &e.omega, rot2, quarter * s2, &none);
        widen_field(&mut e.sd_field, &e.field, rot2, s2);
    }
}

/// `sd_i² += rot² (|x|² − x_i²) + size x_i² + extra_i` (a rotation δ moves `x` by `δ × x`,
/// a size error scales it), as `rot² |x|² + (size − rot²) x_i²`.
fn widen_vector<T: Real>(sd: &mut Vec3<T>, x: &Vec3<T>, rot2: T, size: T, extra: &Vec3<T>) {
    let common = rot2 * (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
    let own = size - rot2;
    for i in 0..3 {
        let v = sd[i] * sd[i] + common + own * x[i] * x[i] + extra[i];
        // ≥ 0 in exact arithmetic; rounding must not make it a NaN.
        sd[i] = v.max(T::ZERO).sqrt();
    }
}

/// `A`'s deviations: the rotation `{δ}A − A{δ}` and the size `−s A`. For a rotation about
/// x that change is `[0, −2A_yz, 2A_yz, −A_xz, A_xy, A_yy − A_zz]` (`[xx, yy, zz, xy, xz, yz]`),
/// about y and z the same with the indices cycled; the squares summed over the three axes
/// are written out (one expression per component: the firmware's flash is counted).
fn widen_field<T: Real>(sd: &mut Sym3<T>, a: &Sym3<T>, rot2: T, s2: T) {
    let [xx, yy, zz, xy, xz, yz] = a.0;
    let four = T::of(4.0);
    let (xy2, xz2, yz2) = (xy * xy, xz * xz, yz * yz);
    let rotation = [
        four * (xz2 + xy2),
        four * (yz2 + xy2),
        four * (yz2 + xz2),
        xz2 + yz2 + (xx - yy) * (xx - yy),
        xy2 + yz2 + (zz - xx) * (zz - xx),
        xy2 + xz2 + (yy - zz) * (yy - zz),
    ];
    for ((s, x), r) in sd.0.iter_mut().zip(a.0.iter()).zip(rotation.iter()) {
        *s = (*s * *s + s2 * *x * *x + rot2 * *r).sqrt();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `{e}A − A{e}` for the unit vector `e` along `axis`, from the matrices (the reference
    /// for [`widen_field`]'s written-out squares).
    fn rotation_derivative(a: &Sym3<f64>, axis: usize) -> Sym3<f64> {
        let mut e = [0.0; 3];
        e[axis] = 1.0;
        let skew = [[0.0, -e[2], e[1]], [e[2], 0.0, -e[0]], [-e[1], e[0], 0.0]];
        let a = a.to_mat();
        let m = |i: usize, j: usize| -> f64 {
            (0..3)
                .map(|k| skew[i][k] * a[k][j] - a[i][k] * skew[k][j])
                .sum()
        };
        Sym3([m(0, 0), m(1, 1), m(2, 2), m(0, 1), m(0, 2), m(1, 2)])
    }

    fn rotate(x: &Vec3<f64>, d: &Vec3<f64>) -> Vec3<f64> {
        // x + δ × x
        [
            x[0] + d[1] * x[2] - d[2] * x[1],
            x[1] + d[2] * x[0] - d[0] * x[2],
            x[2] + d[0] * x[1] - d[1] * x[0],
        ]
    }

    /// The added variances are those of the outputs under random frame errors: a Monte Carlo
    /// of the first-order changes (module doc) over 20 000 draws matches the widened
    /// deviations to 3 %.
    #[test]
    fn widened_deviations_match_a_monte_carlo_of_the_frame_errors() {
        let fu = FrameUncertainty {
            rotation: 2e-3,
            translation: 3e-4,
            size: 1e-3,
            relative_rotation: 3e-3,
        };
        let mut e = Estimate::<f64> {
            sigma0: [0.3, -9.7, 1.2],
            domega: [0.8, -0.4, 2.0],
            omega: [1.5, 0.7, -2.2],
            ..Default::default()
        };
        e.field = Sym3::skew_squared(&e.omega);
        let base = e;
        fu.widen(&mut e);
        // Deterministic normal draws (xorshift + Box–Muller: no dependency in a no_std crate).
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut uniform = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let mut normal = || {
            let (u, v) = (uniform(), uniform());
            (-2.0 * u.ln()).sqrt() * (2.0 * core::f64::consts::PI * v).cos()
        };
        let n = 20_000;
        let mut acc = [[0.0f64; 3]; 3];
        let mut acc_field = [0.0f64; 6];
        for _ in 0..n {
            let d = [
                fu.rotation * normal(),
                fu.rotation * normal(),
                fu.rotation * normal(),
            ];
            let t = [
                fu.translation * normal(),
                fu.translation * normal(),
                fu.translation * normal(),
            ];
            let s = fu.size * normal();
            let rel = [
                fu.relative_rotation * normal(),
                fu.relative_rotation * normal(),
                fu.relative_rotation * normal(),
            ];
            let w = &base.omega;
            let w2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
            let wd = w[0] * rel[0] + w[1] * rel[1] + w[2] * rel[2];
            let k = base.field.mul_vec(&t);
            let dw_t = [
                base.domega[1] * t[2] - base.domega[2] * t[1],
                base.domega[2] * t[0] - base.domega[0] * t[2],
                base.domega[0] * t[1] - base.domega[1] * t[0],
            ];
            let s0 = rotate(&base.sigma0, &d);
            let dw = rotate(&base.domega, &d);
            let w = rotate(&base.omega, &d);
            let half = [0.5 * rel[0], 0.5 * rel[1], 0.5 * rel[2]];
            let s0_rel = rotate(&base.sigma0, &half);
            for i in 0..3 {
                let e0 = s0[i] - base.sigma0[i] + k[i] + dw_t[i] + s0_rel[i] - base.sigma0[i];
                let e1 =
                    dw[i] - base.domega[i] - s * base.domega[i] - 0.5 * (w2 * rel[i] + wd * w[i]);
                let e2 = w[i] - base.omega[i] - 0.5 * s * base.omega[i];
                acc[0][i] += e0 * e0;
                acc[1][i] += e1 * e1;
                acc[2][i] += e2 * e2;
            }
            // A after the rotation: {δ}A − A{δ}, linear in δ.
            for (c, v) in acc_field.iter_mut().enumerate() {
                let mut dv = -s * base.field.0[c];
                for axis in 0..3 {
                    dv += d[axis] * rotation_derivative(&base.field, axis).0[c];
                }
                *v += dv * dv;
            }
        }
        for (q, (sd, name)) in [
            (&e.sd_sigma0, "σ0"),
            (&e.sd_domega, "Ω′"),
            (&e.sd_omega, "Ω"),
        ]
        .iter()
        .enumerate()
        {
            for i in 0..3 {
                let mc = (acc[q][i] / n as f64).sqrt();
                assert!(
                    (sd[i] / mc - 1.0).abs() < 0.03,
                    "{name}[{i}]: {} vs {mc}",
                    sd[i]
                );
            }
        }
        for c in 0..6 {
            let mc = (acc_field[c] / n as f64).sqrt();
            let sd = e.sd_field.0[c];
            assert!((sd / mc - 1.0).abs() < 0.03, "A[{c}]: {sd} vs {mc}");
        }
    }

    /// A rotation of the frame by δ changes `A` as a rotated matrix does: `R A Rᵀ − A` to
    /// first order.
    #[test]
    fn rotation_derivative_is_the_first_order_change_of_a_rotated_matrix() {
        let a = Sym3([1.0, -2.0, 0.5, 0.3, -0.7, 1.1]);
        for axis in 0..3 {
            let h: f64 = 1e-6;
            let (c, s) = (h.cos(), h.sin());
            let mut r = [[0.0; 3]; 3];
            let (i, j) = ((axis + 1) % 3, (axis + 2) % 3);
            r[axis][axis] = 1.0;
            r[i][i] = c;
            r[j][j] = c;
            r[i][j] = -s;
            r[j][i] = s;
            // R A Rᵀ with R the rotation by h about `axis`.
            let rar = a.rotate(&r);
            let d = rotation_derivative(&a, axis);
            for k in 0..6 {
                let fd = (rar.0[k] - a.0[k]) / h;
                assert!(
                    (fd - d.0[k]).abs() < 1e-5,
                    "axis {axis} component {k}: {fd} vs {}",
                    d.0[k]
                );
            }
        }
    }

    #[test]
    fn zero_uncertainty_changes_nothing_and_validity_is_checked() {
        let fu = FrameUncertainty::<f64>::default();
        assert!(fu.is_zero());
        assert!(fu.is_valid());
        let bad = FrameUncertainty {
            rotation: -1e-3,
            translation: 0.0,
            size: 0.0,
            relative_rotation: 0.0,
        };
        assert!(!bad.is_valid());
        let nan = FrameUncertainty {
            rotation: 0.0,
            translation: f64::NAN,
            size: 0.0,
            relative_rotation: 0.0,
        };
        assert!(!nan.is_valid());
    }
}
