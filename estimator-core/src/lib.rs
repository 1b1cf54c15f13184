//! # estimator-core
//!
//! The mathematics of the ballistometer (J.P.B. Vreeburg, *Identification of the geometry of
//! accelerometers in an arrangement*, NLR-TP-2000-585): from N single-axis accelerometer
//! outputs, the specific force σ(0) at the instrument origin, the angular acceleration Ω′, the
//! angular rate Ω and the field matrix `A = Γ + {Ω}²` — no gyro.
//!
//! `no_std`, no allocation, no panics on any input; generic over the scalar ([`Real`]): `f32`
//! on the target, `f64` on the host. Precomputation (SVD per channel mask and frame) is done in
//! `f64` whatever the sample-loop scalar.
//!
//! The public interface:
//! - [`arrangement`]: channels (position, axis, noise), the models, channel masks.
//! - [`estimator`]: configuration (precomputation) and the per-sample solve.
//! - [`estimate`]: the outputs and their status flags.
//! - [`exclusion`]: when a part that stops answering leaves the solve and when it returns.
//! - [`recent`]: the last sample sets, replayed into the estimator after a change of channels.
//! - [`fault_monitor`]: the consistency of the readings (parity space, known field, own signal).
//! - [`supervisor`]: the one fault supervisor (isolation, exclusion, replay) the firmware and
//!   the ground both run.
//! - [`identify`]: each channel's geometry from a known field (paper §6), at sample rate.
//! - [`thermal`]: a reading at one temperature turned into the one at the calibration's
//!   temperature.
//! - [`integrity`]: the protection level of each output (the error a fault of one part could
//!   cause).
//! - [`frame_uncertainty`]: the common errors of a calibrated frame, added to the reported
//!   deviations.
//! - [`error`], [`linalg`] (the small fixed-size vectors and matrices of the interface),
//!   [`real`] (the scalar).
//!
//! A tetrahedron of four tri-axial parts (12 channels) spinning at 1 rad/s about z, on the
//! ground (σ0 = 1 g up), estimated in model G:
//!
//! ```
//! use estimator_core::{Arrangement, Estimator, Model, Options};
//!
//! let places = [[0.1, 0.1, 0.1], [-0.1, -0.1, 0.1], [-0.1, 0.1, -0.1], [0.1, -0.1, -0.1]];
//! let mut array = Arrangement::<12>::new();
//! for r in places {
//!     for axis in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] {
//!         array.push(r, axis, 1e-3)?; // position (m), sensitive axis, noise (m/s² RMS)
//!     }
//! }
//! let options = Options { initial_omega: Some([0.0, 0.0, 1.0]), ..Options::default() };
//! let mut estimator = Estimator::<f64, 12>::new(&array, Model::General, options)?;
//! // What each channel reads (paper eq. 4): s·σ0 + s·{Ω}²R, with Ω′ = 0 and Γ = 0.
//! let (w, sigma0) = (1.0, [0.0, 0.0, estimator_core::G0]);
//! let mut readings = [0.0; 12];
//! for (k, c) in array.channels().iter().enumerate() {
//!     let centripetal = [-w * w * c.position[0], -w * w * c.position[1], 0.0];
//!     readings[k] = (0..3).map(|i| c.axis[i] * (sigma0[i] + centripetal[i])).sum();
//! }
//! for n in 0..100 {
//!     let estimate = estimator.update(f64::from(n) * 0.01, &readings);
//!     assert!((estimate.omega[2] - w).abs() < 1e-6 && (estimate.sigma0[2] - sigma0[2]).abs() < 1e-9);
//! }
//! # Ok::<(), estimator_core::ConfigError>(())
//! ```
//!
//! Inside (crate-private; reachable by tests and benches through the hidden `internals`):
//! `svd` (configuration-time SVD), `design` (the precomputed matrices of paper eq. (10)–(11)
//! per mask and frame), `quadratic` (the quadratic forms for `a`: closed form for m = 3,
//! Kelvin's decomposition, Gauss–Newton), `tracker` (branch and sign tracking by kinematic
//! consistency, a rate filter per hypothesis).
// Unit tests link std (the test harness); the library never does.
#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]
#![deny(unsafe_op_in_unsafe_fn)]
// `!(x > y)` is how this crate rejects NaN along with the out-of-range values: intentional.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Matrix code indexes rows and columns by number; iterator chains would hide the algebra.
#![allow(clippy::needless_range_loop)]

pub mod arrangement;
pub mod error;
pub mod estimate;
pub mod estimator;
pub mod exclusion;
pub mod fault_monitor;
pub mod frame_uncertainty;
pub mod identify;
pub mod integrity;
pub mod linalg;
pub mod parity;
pub mod real;
pub mod recent;
pub mod supervisor;
pub mod thermal;

#[doc(hidden)]
pub mod internals;
pub(crate) use internals::{design, quadratic, svd, tracker};

pub use arrangement::{Arrangement, Channel, ChannelMask, Model};

/// Standard gravity, m/s² (the unit of the parts' ranges and of "g"); the one definition the
/// workspace uses.
pub const G0: f64 = 9.806_65;
pub use error::{ConfigError, Unknown};
pub use estimate::{Estimate, Flags};
pub use estimator::{Estimator, Options, SpareConfig};
pub use frame_uncertainty::FrameUncertainty;
pub use linalg::{Sym3, Vec3};
pub use real::Real;
