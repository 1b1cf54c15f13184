//! How well a calibrated arrangement's frame is tied to the body: estimator-core's frame
//! motions fitted to the identification's parameter errors
//! ([`estimator_core::frame_uncertainty::motions`], the same computation as the in-flight
//! identification's), for the ground fit's geometry and covariance.
//!
//! The covariance [`super::fit`] computes is the data's along identified directions and one
//! tolerance along what is held (gauges included: the common translation, and without a
//! reference the common rotation and size, are held at the nominal values, which are only as
//! good as the mounting).

use nalgebra::{DMatrix, Vector3};

use estimator_core::frame_uncertainty::motions;
use estimator_core::{Channel, FrameUncertainty};

use super::fit::{Geometry, Tolerance};

fn channels(geo: &[Geometry]) -> Vec<Channel> {
    geo.iter().map(Geometry::channel).collect()
}

/// The frame uncertainty of the geometry `geo` whose error has the tolerance-scaled
/// covariance `cov` (7 parameters per channel, [`super::fit::PARAMETERS`] order).
pub fn uncertainty(geo: &[Geometry], cov: &DMatrix<f64>, tol: &Tolerance) -> FrameUncertainty<f64> {
    motions::from_covariance(&channels(geo), &|p, r| cov[(p, r)], tol)
}

/// The deviation of the size of `geo` when it is held at the drawing's.
pub fn held_size(geo: &[Geometry], tol: &Tolerance) -> f64 {
    motions::held_size(&channels(geo), tol)
}

/// The common rotation and the rotation of the axes against the lever arms (rad, rotation
/// vectors) that best explain the change from the geometry `nominal` to `geo`; `None` with
/// too few channels to tell the motions apart.
pub fn rotation(
    nominal: &[Geometry],
    geo: &[Geometry],
    tol: &Tolerance,
) -> Option<(Vector3<f64>, Vector3<f64>)> {
    motions::rotation(&channels(nominal), &channels(geo), tol).map(|(r, d)| (r.into(), d.into()))
}
