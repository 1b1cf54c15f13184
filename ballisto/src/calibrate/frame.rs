//! How well a calibrated arrangement's frame is tied to the body: the common translation,
//! rotation and size of the identified geometry's error ([`estimator_core::FrameUncertainty`]).
//!
//! The identification's error `e` (calibrated − true, all channels' parameters,
//! tolerance-scaled) has the covariance [`super::fit`] computes: the data's along identified
//! directions, one tolerance along what is held (gauges included: the common translation,
//! and without a reference the common rotation and size, are held at the nominal values,
//! which are only as good as the mounting). The frame's error is the least-squares fit of the
//! frame motions to `e` — translation, rotation, size, and the rotation of the axes relative to
//! the lever arms (what a self-calibration sees only weakly; estimator-core's module doc) —
//! `φ = (GᵀG)⁻¹Gᵀ e` with `G` the scaled generators, so `cov(φ) = L cov(e) Lᵀ`. Each is
//! reported by its largest axis.

use nalgebra::{DMatrix, DVector, Vector3};

use estimator_core::FrameUncertainty;

use super::fit::{tilt_basis, Geometry, Tolerance};

/// Columns of the generators: translation x, y, z; rotation x, y, z; size; rotation of the
/// axes relative to the lever arms x, y, z.
const MOTIONS: usize = 10;

/// The frame uncertainty of the geometry `geo` whose error has the tolerance-scaled
/// covariance `cov` (7 parameters per channel, [`super::fit::PARAMETERS`] order).
pub fn uncertainty(geo: &[Geometry], cov: &DMatrix<f64>, tol: &Tolerance) -> FrameUncertainty<f64> {
    let g = generators(geo, tol);
    let gtg = g.transpose() * &g;
    let Some(inv) = gtg.try_inverse() else {
        // Fewer channels than frame motions to tell apart: claim nothing rather than a
        // number the geometry cannot support.
        return FrameUncertainty {
            rotation: f64::INFINITY,
            translation: f64::INFINITY,
            size: f64::INFINITY,
            relative_rotation: f64::INFINITY,
        };
    };
    let l = inv * g.transpose();
    let c = &l * cov * l.transpose();
    let largest = |r: std::ops::Range<usize>| r.map(|k| c[(k, k)]).fold(0.0f64, f64::max).sqrt();
    FrameUncertainty {
        translation: largest(0..3),
        rotation: largest(3..6),
        size: largest(6..7),
        relative_rotation: largest(7..10),
    }
}

/// The deviation of the size of `geo` when it is held at the drawing's: one tolerance along
/// the size's generator, as for a gauge ([`uncertainty`]).
pub fn held_size(geo: &[Geometry], tol: &Tolerance) -> f64 {
    1.0 / generators(geo, tol).column(6).norm()
}

/// The common rotation and the rotation of the axes against the lever arms (rad, rotation
/// vectors) that best explain the change from the geometry `nominal` to `geo` (the frame
/// motions fitted to the tolerance-scaled parameter changes, as in [`uncertainty`]); `None`
/// with too few channels to tell the motions apart.
pub fn rotation(
    nominal: &[Geometry],
    geo: &[Geometry],
    tol: &Tolerance,
) -> Option<(Vector3<f64>, Vector3<f64>)> {
    let g = generators(nominal, tol);
    let mut e = DVector::zeros(7 * nominal.len());
    for (i, (n0, c)) in nominal.iter().zip(geo.iter()).enumerate() {
        let (u1, u2) = tilt_basis(&n0.axis);
        let da = c.axis - n0.axis;
        let dp = c.position - n0.position;
        let change = [
            c.scale - n0.scale,
            u1.dot(&da),
            u2.dot(&da),
            c.bias - n0.bias,
            dp.x,
            dp.y,
            dp.z,
        ];
        for (j, v) in change.iter().enumerate() {
            e[7 * i + j] = v / tol.of(j);
        }
    }
    let phi = (g.transpose() * &g).try_inverse()? * g.transpose() * e;
    Some((
        Vector3::new(phi[3], phi[4], phi[5]),
        Vector3::new(phi[7], phi[8], phi[9]),
    ))
}

/// The frame motions as parameter changes of every channel (rows: 7 per channel,
/// tolerance-scaled): a translation moves every position; a rotation `δ` moves a position
/// by `δ × R` and tilts an axis by `δ × s`; a size change moves each position by `R`; a
/// relative rotation `d` tilts the axes by `½ d × s` and moves the positions by `−½ d × R`.
fn generators(geo: &[Geometry], tol: &Tolerance) -> DMatrix<f64> {
    let mut g = DMatrix::zeros(7 * geo.len(), MOTIONS);
    for (i, ch) in geo.iter().enumerate() {
        let (u1, u2) = tilt_basis(&ch.axis);
        let row = 7 * i;
        for k in 0..3 {
            let e = Vector3::ith(k, 1.0);
            // Translation.
            g[(row + 4 + k, k)] = 1.0;
            // Rotation about e.
            let tilt = e.cross(&ch.axis);
            let moved = e.cross(&ch.position);
            g[(row + 1, 3 + k)] = u1.dot(&tilt);
            g[(row + 2, 3 + k)] = u2.dot(&tilt);
            for j in 0..3 {
                g[(row + 4 + j, 3 + k)] = moved[j];
            }
            // Size.
            g[(row + 4 + k, 6)] = ch.position[k];
            // The axes turned by ½ about e against the lever arms by −½ (their relative
            // rotation; the mean is the rotation above).
            g[(row + 1, 7 + k)] = 0.5 * u1.dot(&tilt);
            g[(row + 2, 7 + k)] = 0.5 * u2.dot(&tilt);
            for j in 0..3 {
                g[(row + 4 + j, 7 + k)] = -0.5 * moved[j];
            }
        }
        for j in 0..7 {
            for m in 0..MOTIONS {
                g[(row + j, m)] /= tol.of(j);
            }
        }
    }
    g
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetra() -> Vec<Geometry> {
        let c = 0.05;
        let mut geo = Vec::new();
        for r in [[c, c, c], [c, -c, -c], [-c, c, -c], [-c, -c, c]] {
            for k in 0..3 {
                geo.push(Geometry {
                    position: Vector3::from(r),
                    axis: Vector3::ith(k, 1.0),
                    scale: 1.0,
                    bias: 0.0,
                    noise: 1e-3,
                });
            }
        }
        geo
    }

    /// With every parameter known only to its tolerance (nothing identified), the common
    /// translation of N positions is known to `tol / √N`. About x, the axes' rotation is
    /// known to `1 / √I_a` from the axes that tilt with it (two of three: `I_a = 2N/3 /
    /// tol_axis²`) and the lever arms' to `1 / √I_p` from the positions it moves (`I_p =
    /// Σ (R_y² + R_z²) / tol_position²`); the frame's rotation is their mean, the relative
    /// rotation their difference. With the data determining everything exactly, nothing is
    /// left.
    #[test]
    fn priors_average_over_the_channels_and_exact_data_leave_nothing() {
        let geo = tetra();
        let tol = Tolerance::default();
        let n = geo.len();
        let prior = uncertainty(&geo, &DMatrix::identity(7 * n, 7 * n), &tol);
        let t = tol.position / (n as f64).sqrt();
        assert!(
            (prior.translation / t - 1.0).abs() < 1e-9,
            "{prior:?} vs {t}"
        );
        let arms: f64 = geo
            .iter()
            .map(|g| g.position.y.powi(2) + g.position.z.powi(2))
            .sum();
        let var = tol.axis.powi(2) / (2.0 * n as f64 / 3.0) + tol.position.powi(2) / arms;
        let mean = 0.5 * var.sqrt();
        assert!(
            (prior.rotation / mean - 1.0).abs() < 1e-9,
            "{prior:?} vs {mean}"
        );
        let relative = var.sqrt();
        assert!(
            (prior.relative_rotation / relative - 1.0).abs() < 1e-9,
            "{prior:?} vs {relative}"
        );
        assert!(prior.size > 0.0);
        let turn = nalgebra::Rotation3::new(Vector3::new(2e-3, -1e-3, 3e-3));
        let turned: Vec<Geometry> = geo
            .iter()
            .map(|g| Geometry {
                axis: turn * g.axis,
                position: turn * g.position,
                ..*g
            })
            .collect();
        let (found, relative) = rotation(&geo, &turned, &tol).unwrap();
        assert!(relative.norm() < 1e-6, "{relative}");
        assert!(
            (found - turn.scaled_axis()).norm() < 1e-5,
            "{found} vs {}",
            turn.scaled_axis()
        );
        let exact = uncertainty(&geo, &DMatrix::zeros(7 * n, 7 * n), &tol);
        assert_eq!(exact.rotation, 0.0);
        assert_eq!(exact.translation, 0.0);
        assert_eq!(exact.size, 0.0);
        assert_eq!(exact.relative_rotation, 0.0);
    }
}
