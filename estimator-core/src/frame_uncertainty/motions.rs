//! The frame's error fitted to a geometry's parameter errors: one computation for every
//! identification (`ballisto calibrate`'s joint fit, the in-flight one's
//! [`crate::identify::Identified::frame_uncertainty`]).
//!
//! The identification's error `e` (identified − true, every channel's parameters in
//! [`Param`] order, each divided by its tolerance) has a covariance the identification knows:
//! the data's along what it determined, one tolerance along what it held (the gauges included:
//! what no record decides is held at the drawing's values, which are only as good as the
//! mounting). The frame's error is the least-squares fit of the frame motions ([`MOTIONS`]:
//! translation, rotation, size, and the rotation of the axes relative to the lever arms) to
//! `e`, `φ = (GᵀG)⁻¹Gᵀ e` with `G` the tolerance-scaled generators, so `cov(φ) = L cov(e) Lᵀ`
//! with `L = (GᵀG)⁻¹Gᵀ`. Each motion is reported by its largest axis.
//!
//! Written without allocation: `GᵀG` and `Gᵀ cov G` are 10 × 10, summed over the channel
//! pairs' 7 × 7 blocks of the covariance.

use super::FrameUncertainty;
use crate::arrangement::Channel;
use crate::identify::cholesky::{cholesky, cholesky_solve};
use crate::identify::{tilt_basis, Param, Tolerance, PARAMS};
use crate::linalg::{cross, dot, Vec3};
use crate::real::Real;

/// Frame motions: translation x, y, z; rotation x, y, z; size; rotation of the axes relative
/// to the lever arms x, y, z.
pub const MOTIONS: usize = 10;

/// One channel's rows of the generators (tolerance-scaled, [`Param`] order): a translation
/// moves its position; a rotation `δ` moves the position by `δ × R` and tilts the axis by
/// `δ × s`; a size change moves the position by `R`; a relative rotation `d` tilts the axis
/// by `½ d × s` and moves the position by `−½ d × R`. Scale and bias are not moved by the frame.
#[inline(never)]
pub fn channel_motions(c: &Channel, tol: &Tolerance) -> [[f64; MOTIONS]; PARAMS] {
    // Scaled as they are built (positions in position tolerances, tilt directions in axis
    // tolerances): a division per entry afterwards was 0.8 KB of the flight image.
    let (tp, ta) = (1.0 / tol.position, 1.0 / tol.axis);
    let (u1, u2) = tilt_basis(&c.axis);
    let tilts = [u1.map(|v| v * ta), u2.map(|v| v * ta)];
    let r = c.position.map(|v| v * tp);
    let mut g = [[0.0; MOTIONS]; PARAMS];
    let pos = Param::PositionX as usize;
    for k in 0..3 {
        let mut e = [0.0; 3];
        e[k] = 1.0;
        g[pos + k][k] = tp;
        let tilt = cross(&e, &c.axis);
        let moved = cross(&e, &r);
        for (t, u) in tilts.iter().enumerate() {
            g[1 + t][3 + k] = dot(u, &tilt);
            g[1 + t][7 + k] = 0.5 * g[1 + t][3 + k];
        }
        for j in 0..3 {
            g[pos + j][3 + k] = moved[j];
            g[pos + j][7 + k] = -0.5 * moved[j];
        }
        g[pos + k][6] = r[k];
    }
    g
}

/// `acc += aᵀ b` for two channels' rows (PARAMS × MOTIONS each).
#[inline(never)]
fn add_product(
    acc: &mut [[f64; MOTIONS]; MOTIONS],
    a: &[[f64; MOTIONS]; PARAMS],
    b: &[[f64; MOTIONS]; PARAMS],
) {
    for (k, row) in acc.iter_mut().enumerate() {
        for (l, v) in row.iter_mut().enumerate() {
            *v += (0..PARAMS).map(|p| a[p][k] * b[p][l]).sum::<f64>();
        }
    }
}

/// The Cholesky factor of `GᵀG` and its order; `None` with too few channels to tell the
/// motions apart.
///
/// The order is handed to the factorisation and the solves as a run-time value
/// (`black_box`): with it a constant, the 10 × 10 solves unrolled to 2.3 KB of the STM32H743
/// image (measured), which had less than that to spare; as loops they take a few hundred
/// bytes, and run once per identification.
#[inline(never)]
fn normal_factor<C: AsRef<Channel>>(
    channels: &[C],
    tol: &Tolerance,
) -> Option<([[f64; MOTIONS]; MOTIONS], usize)> {
    let mut gtg = [[0.0; MOTIONS]; MOTIONS];
    for c in channels {
        let g = channel_motions(c.as_ref(), tol);
        add_product(&mut gtg, &g, &g);
    }
    let order = core::hint::black_box(MOTIONS);
    cholesky(&mut gtg, order).then_some((gtg, order))
}

/// The frame uncertainty of `channels` whose parameter errors have the tolerance-scaled
/// covariance `cov(p, r)` (indices `PARAMS · channel + parameter`, [`Param`] order): the
/// diagonal of `(GᵀG)⁻¹ Gᵀ cov G (GᵀG)⁻¹`. With fewer channels than frame motions to tell
/// apart it claims nothing (every deviation infinite) rather than a number the geometry
/// cannot support.
///
/// `cov` is called, not inlined, and the products are one function: unrolled at the flight
/// profile's speed level, the first version took 6.8 KB of the STM32H743 image (measured),
/// which had 3.9 KB to spare.
#[inline(never)]
pub fn from_covariance<C: AsRef<Channel>>(
    channels: &[C],
    cov: &dyn Fn(usize, usize) -> f64,
    tol: &Tolerance,
) -> FrameUncertainty<f64> {
    let Some((l, order)) = normal_factor(channels, tol) else {
        return FrameUncertainty {
            rotation: f64::INFINITY,
            translation: f64::INFINITY,
            size: f64::INFINITY,
            relative_rotation: f64::INFINITY,
        };
    };
    // B = Gᵀ cov G = Σ_i G_iᵀ W_i with W_i = Σ_j cov_ij G_j (the zeros of cov skipped: in
    // flight most of it is).
    let mut b = [[0.0; MOTIONS]; MOTIONS];
    for (i, ci) in channels.iter().enumerate() {
        let mut w = [[0.0; MOTIONS]; PARAMS];
        for (j, cj) in channels.iter().enumerate() {
            let gj = channel_motions(cj.as_ref(), tol);
            for (p, wp) in w.iter_mut().enumerate() {
                for (r, gjr) in gj.iter().enumerate() {
                    let c = cov(PARAMS * i + p, PARAMS * j + r);
                    if c != 0.0 {
                        for (x, g) in wp.iter_mut().zip(gjr.iter()) {
                            *x += c * g;
                        }
                    }
                }
            }
        }
        add_product(&mut b, &channel_motions(ci.as_ref(), tol), &w);
    }
    // var_a = yᵀ B y with y = (GᵀG)⁻¹ e_a.
    let mut var = [0.0f64; MOTIONS];
    for (a, v) in var.iter_mut().enumerate() {
        let mut e = [0.0; MOTIONS];
        e[a] = 1.0;
        let y = cholesky_solve(&l, order, &e);
        for (row, yk) in b.iter().zip(y.iter()) {
            for (x, yl) in row.iter().zip(y.iter()) {
                *v += yk * x * yl;
            }
        }
    }
    let largest =
        |r: core::ops::Range<usize>| Real::sqrt(r.map(|k| var[k]).fold(0.0f64, f64::max).max(0.0));
    FrameUncertainty {
        translation: largest(0..3),
        rotation: largest(3..6),
        size: largest(6..7),
        relative_rotation: largest(7..10),
    }
}

/// The deviation of the size of `channels` when it is held at the drawing's: one tolerance
/// along the size's generator, as for a gauge.
#[inline]
pub fn held_size(channels: &[Channel], tol: &Tolerance) -> f64 {
    let n2: f64 = channels
        .iter()
        .map(|c| {
            channel_motions(c, tol)
                .iter()
                .map(|row| row[6] * row[6])
                .sum::<f64>()
        })
        .sum();
    1.0 / Real::sqrt(n2)
}

/// The common rotation and the rotation of the axes against the lever arms (rad, rotation
/// vectors) that best explain the change from `nominal` to `changed` (the frame motions
/// fitted to the tolerance-scaled parameter changes); `None` with too few channels to tell
/// the motions apart.
#[inline]
pub fn rotation(
    nominal: &[Channel],
    changed: &[Channel],
    tol: &Tolerance,
) -> Option<(Vec3<f64>, Vec3<f64>)> {
    let (l, order) = normal_factor(nominal, tol)?;
    let mut gte = [0.0f64; MOTIONS];
    for (n0, c) in nominal.iter().zip(changed.iter()) {
        let (u1, u2) = tilt_basis(&n0.axis);
        let da: Vec3<f64> = core::array::from_fn(|k| c.axis[k] - n0.axis[k]);
        let change = [
            c.scale - n0.scale,
            dot(&u1, &da),
            dot(&u2, &da),
            c.position[0] - n0.position[0],
            c.position[1] - n0.position[1],
            c.position[2] - n0.position[2],
            c.bias - n0.bias,
        ];
        let g = channel_motions(n0, tol);
        for (m, v) in gte.iter_mut().enumerate() {
            *v += (0..PARAMS)
                .map(|p| g[p][m] * change[p] / tol.of(p))
                .sum::<f64>();
        }
    }
    let phi = cholesky_solve(&l, order, &gte);
    Some(([phi[3], phi[4], phi[5]], [phi[7], phi[8], phi[9]]))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetra() -> [Channel; 12] {
        let c = 0.05;
        let corners = [[c, c, c], [c, -c, -c], [-c, c, -c], [-c, -c, c]];
        core::array::from_fn(|i| {
            let mut axis = [0.0; 3];
            axis[i % 3] = 1.0;
            Channel {
                position: corners[i / 3],
                axis,
                noise: 1e-3,
                bias: 0.0,
                scale: 1.0,
            }
        })
    }

    /// With every parameter known only to its tolerance (nothing identified), the common
    /// translation of N positions is known to `tol / √N`. About x, the axes' rotation is
    /// known to `1 / √I_a` from the axes that tilt with it (two of three: `I_a = 2N/3 /
    /// tol_axis²`) and the lever arms' to `1 / √I_p` from the positions it moves (`I_p =
    /// Σ (R_y² + R_z²) / tol_position²`); the frame's rotation is their mean, the relative
    /// rotation their difference. With the data determining everything exactly, nothing is
    /// left; a turned geometry is found turned, with no relative rotation.
    #[test]
    fn priors_average_over_the_channels_and_exact_data_leave_nothing() {
        let geo = tetra();
        let tol = Tolerance::DATASHEET;
        let n = geo.len();
        let prior = from_covariance(&geo, &|p, r| if p == r { 1.0 } else { 0.0 }, &tol);
        let t = tol.position / (n as f64).sqrt();
        assert!(
            (prior.translation / t - 1.0).abs() < 1e-9,
            "{prior:?} vs {t}"
        );
        let arms: f64 = geo
            .iter()
            .map(|g| g.position[1] * g.position[1] + g.position[2] * g.position[2])
            .sum();
        let var = tol.axis * tol.axis / (2.0 * n as f64 / 3.0) + tol.position * tol.position / arms;
        let mean = 0.5 * var.sqrt();
        assert!(
            (prior.rotation / mean - 1.0).abs() < 1e-9,
            "{prior:?} vs {mean}"
        );
        assert!(
            (prior.relative_rotation / var.sqrt() - 1.0).abs() < 1e-9,
            "{prior:?}"
        );
        assert!(prior.size > 0.0);
        let exact = from_covariance(&geo, &|_, _| 0.0, &tol);
        assert_eq!(exact, FrameUncertainty::default());
        // A small turn: R(δ) x ≈ x + δ × x + ½ δ × (δ × x).
        let d = [2e-3, -1e-3, 3e-3];
        let turn = |x: &Vec3<f64>| -> Vec3<f64> {
            let a = cross(&d, x);
            let b = cross(&d, &a);
            core::array::from_fn(|k| x[k] + a[k] + 0.5 * b[k])
        };
        let turned = geo.map(|g| Channel {
            axis: turn(&g.axis),
            position: turn(&g.position),
            ..g
        });
        let (found, relative) = rotation(&geo, &turned, &tol).unwrap();
        assert!(relative.iter().all(|v| v.abs() < 1e-6), "{relative:?}");
        assert!(
            (0..3).all(|k| (found[k] - d[k]).abs() < 1e-5),
            "{found:?} vs {d:?}"
        );
        assert!(from_covariance(&geo[..2], &|_, _| 1.0, &tol)
            .translation
            .is_infinite());
    }
}
