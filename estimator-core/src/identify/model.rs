//! A channel's model and its parameters, one for every identification — the firmware's from
//! the window's sums ([`super::identify`]), the tumble's ([`super::identify_tumble`]) and the
//! ground calibration's with the field unknown (`ballisto calibrate`): a channel reads
//!
//! ```text
//! h = c s·f(R) + b,   f(R) = σ(0) + M R,   M = Γ + {Ω}² + {Ω′}
//! ```
//!
//! (paper eq. 4 with the parts' scale `c` and bias `b`, eq. 5), and its seven parameters
//! ([`Param`]) are the scale, two tilts of the axis `s` (paper eq. 9's `δs`, perpendicular to
//! `s`: [`tilt_basis`]), the position `R` and the bias, with the tolerances ([`Tolerance`]) that
//! decide what a record determines.

use crate::linalg::{cross, dot, norm2, Vec3};
use crate::real::Real;

/// Parameters per channel.
pub const PARAMS: usize = 7;

/// A channel's parameters, in the order of [`super::ChannelFit::sd`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Param {
    /// Scale factor.
    Scale,
    /// Axis tilt towards the first direction perpendicular to the axis (rad).
    TiltA,
    /// Axis tilt towards the second (rad).
    TiltB,
    /// Position, x (m).
    PositionX,
    /// Position, y (m).
    PositionY,
    /// Position, z (m).
    PositionZ,
    /// Bias (m/s²).
    Bias,
}

impl Param {
    /// All, in order.
    pub const ALL: [Param; PARAMS] = [
        Param::Scale,
        Param::TiltA,
        Param::TiltB,
        Param::PositionX,
        Param::PositionY,
        Param::PositionZ,
        Param::Bias,
    ];

    /// Its bit in [`super::ChannelFit::held`].
    pub const fn bit(self) -> u8 {
        1 << self as u8
    }

    /// Its name in reports.
    pub const fn name(self) -> &'static str {
        match self {
            Param::Scale => "scale",
            Param::TiltA => "tilt a",
            Param::TiltB => "tilt b",
            Param::PositionX => "position x",
            Param::PositionY => "position y",
            Param::PositionZ => "position z",
            Param::Bias => "bias",
        }
    }
}

/// How far from nominal each parameter may be (the parts' datasheet and the mounting): a
/// parameter the window determines to worse than half of it is held at nominal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerance {
    /// Scale factor (relative).
    pub scale: f64,
    /// Axis tilt, rad.
    pub axis: f64,
    /// Position, m.
    pub position: f64,
    /// Bias, m/s².
    pub bias: f64,
}

impl Tolerance {
    /// The host calibration's tolerances (`ballisto calibrate`): scale 0.02, axis 10 mrad,
    /// position 1 mm, bias 0.5 m/s² (an ADXL355's ±25 mg offset is 0.25 m/s²).
    pub const DATASHEET: Tolerance = Tolerance {
        scale: 0.02,
        axis: 0.01,
        position: 1e-3,
        bias: 0.5,
    };

    /// The tolerance of parameter `p` (`0..PARAMS`, [`Param`] order).
    #[inline]
    pub fn of(&self, p: usize) -> f64 {
        match p {
            0 => self.scale,
            1 | 2 => self.axis,
            6 => self.bias,
            _ => self.position,
        }
    }
}

/// Whether a record that determined `determined` of the `asked` parameters (to half their
/// tolerance) is refused as not exciting enough: fewer than half. One rule for every
/// identification that decides on its own (`ballisto calibrate`'s joint fit, the tumble's); a
/// window with a reference is solved on command and reports what it held.
#[inline]
pub const fn too_few_determined(determined: usize, asked: usize) -> bool {
    2 * determined < asked
}

impl Default for Tolerance {
    /// [`Tolerance::DATASHEET`].
    fn default() -> Self {
        Tolerance::DATASHEET
    }
}

/// Two unit vectors perpendicular to the unit axis `s` and to each other, the directions of
/// its tilts a and b: the first along `s × e`, `e` the coordinate axis least aligned with `s`,
/// the second `s × first`.
#[inline]
pub fn tilt_basis(s: &Vec3<f64>) -> (Vec3<f64>, Vec3<f64>) {
    let a = [s[0].abs(), s[1].abs(), s[2].abs()];
    let e = if a[0] <= a[1] && a[0] <= a[2] {
        [1.0, 0.0, 0.0]
    } else if a[1] <= a[2] {
        [0.0, 1.0, 0.0]
    } else {
        [0.0, 0.0, 1.0]
    };
    let u = cross(s, &e);
    let n = Real::sqrt(norm2(&u));
    let u = [u[0] / n, u[1] / n, u[2] / n];
    (u, cross(s, &u))
}

/// The gradient of a channel's reading `h = c s·f + b` over its parameters ([`Param`] order)
/// at the specific force `f = σ(0) + M R` its seismic point sees (paper eq. 4; the
/// linearisation of eq. 9 with scale and bias): `scale` `c`, unit axis `s`, `tilt` the change
/// of the unit axis per unit of tilt a and b (at zero tilt, [`tilt_basis`]), `m` the field's
/// gradient `M` (row-major).
#[inline]
pub fn reading_gradient(
    scale: f64,
    axis: &Vec3<f64>,
    tilt: &(Vec3<f64>, Vec3<f64>),
    m: &[[f64; 3]; 3],
    f: &Vec3<f64>,
) -> [f64; PARAMS] {
    // ∂h/∂R = Mᵀ (c s).
    let arm: Vec3<f64> = core::array::from_fn(|l| (0..3).map(|a| m[a][l] * scale * axis[a]).sum());
    [
        dot(axis, f),
        scale * dot(&tilt.0, f),
        scale * dot(&tilt.1, f),
        arm[0],
        arm[1],
        arm[2],
        1.0,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether the three are orthonormal.
    fn orthonormal(s: &Vec3<f64>, t1: &Vec3<f64>, t2: &Vec3<f64>) -> bool {
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        close(dot(s, t1), 0.0)
            && close(dot(s, t2), 0.0)
            && close(dot(t1, t2), 0.0)
            && close(norm2(t1), 1.0)
            && close(norm2(t2), 1.0)
    }

    #[test]
    fn tilt_basis_is_orthonormal() {
        for s in [[1.0, 0.0, 0.0], [0.0, 0.6, 0.8], [0.577, 0.577, 0.5774]] {
            let n = Real::sqrt(norm2(&s));
            let s = [s[0] / n, s[1] / n, s[2] / n];
            let (t1, t2) = tilt_basis(&s);
            assert!(orthonormal(&s, &t1, &t2));
        }
    }

    /// The gradient is the reading's first-order change: each parameter moved by a small
    /// step changes `h` by the gradient times the step (the axis renormalised after a tilt).
    #[test]
    fn the_reading_gradient_is_the_first_order_change() {
        let s = {
            let v = [0.3, -0.5, 0.81];
            let n = Real::sqrt(norm2(&v));
            [v[0] / n, v[1] / n, v[2] / n]
        };
        let m = [[-1.2, 0.4, 0.9], [-0.1, -2.0, 0.3], [0.7, -0.6, -0.5]];
        let sigma0 = [0.2, -0.1, 0.05];
        let (c, r, b) = (1.01, [0.04, -0.03, 0.07], 0.02);
        let h = |c: f64, s: &Vec3<f64>, r: &Vec3<f64>, b: f64| -> f64 {
            let f: Vec3<f64> =
                core::array::from_fn(|k| sigma0[k] + (0..3).map(|l| m[k][l] * r[l]).sum::<f64>());
            c * dot(s, &f) + b
        };
        let f: Vec3<f64> =
            core::array::from_fn(|k| sigma0[k] + (0..3).map(|l| m[k][l] * r[l]).sum::<f64>());
        let basis = tilt_basis(&s);
        let g = reading_gradient(c, &s, &basis, &m, &f);
        let e = 1e-6;
        let base = h(c, &s, &r, b);
        let tilted = |t: &Vec3<f64>| -> Vec3<f64> {
            let v: Vec3<f64> = core::array::from_fn(|k| s[k] + e * t[k]);
            let n = Real::sqrt(norm2(&v));
            [v[0] / n, v[1] / n, v[2] / n]
        };
        let moved = |k: usize| -> Vec3<f64> {
            core::array::from_fn(|l| r[l] + if l == k { e } else { 0.0 })
        };
        let numeric = [
            h(c + e, &s, &r, b),
            h(c, &tilted(&basis.0), &r, b),
            h(c, &tilted(&basis.1), &r, b),
            h(c, &s, &moved(0), b),
            h(c, &s, &moved(1), b),
            h(c, &s, &moved(2), b),
            h(c, &s, &r, b + e),
        ];
        for p in 0..PARAMS {
            let d = (numeric[p] - base) / e;
            assert!(
                (d - g[p]).abs() < 1e-5,
                "{}: {d} vs {}",
                Param::ALL[p].name(),
                g[p]
            );
        }
    }
}
