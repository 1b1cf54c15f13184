//! Identification of each channel's geometry from a known field (paper §6), in a form that runs
//! at sample rate on the target and is solved on command.
//!
//! With the field known — the rate `Ω` and angular acceleration `Ω′` of a reference (a primary
//! IMU on the bus), and `σ(0) = 0` at the centre of mass of a freely moving body (paper §3,
//! after eq. 3) — every channel reads (paper eq. 4 with the parts' scale and bias, eq. 5)
//!
//! ```text
//! p = c s·(L R) + b,   L = Γ + {Ω}² + {Ω′}
//! ```
//!
//! with `R` its seismic point from the centre of mass, `s` its axis, `c` its scale and `b` its
//! bias. That is `p = zᵀ vec(L) + b` with `z = vec(c s Rᵀ)`: linear in the ten numbers
//! `k = (vec L, 1)` of the field. So the least squares of a channel over a window,
//! `Σ (p − qᵀk)²` with `q = (z, b)`, is a quadratic form in `q` whose coefficients are the
//! sums `Σ k kᵀ` (one 10×10 matrix, the same for every channel), `Σ p k` and `Σ p²`
//! ([`FieldSums`]): 55 + 11 N multiply-adds per sample set, and no sample kept. The solve
//! ([`identify`]) then iterates Gauss–Newton on each channel's parameters (two axis tilts,
//! position, bias — the paper's eq. 9 with the bias added, as its §6 allows — and the scale
//! where it can be told apart)
//! over those sums exactly, as often as it needs, without a second pass over the data — the
//! linearisation of eq. 9 is only the step, not the model.
//!
//! In free fall a channel's scale is not separable from its distance to the centre of mass
//! (`c s·(L R)` is a product): any scale explains the record exactly with its lever arm scaled
//! to match, so the record carries no information on it (the Fisher bound is infinite;
//! `tests/identify.rs`, `in_free_flight_the_scale_is_one_product_with_the_lever_arm`). The
//! scale is held at the arrangement's value (the ground calibration's) and named, always
//! ([`ALWAYS_HELD`]); the estimate needs only the product.
//! What else the window did not excite is decided, not assumed: a parameter whose deviation exceeds
//! half its tolerance ([`Tolerance`]) is held at its nominal value, the worst first, and named
//! ([`ChannelFit::held`]). The positions come out relative to the centre of mass; their common
//! translation — which no accelerometer record separates from where the centre of mass is —
//! is held by convention (the mean mounting error is zero), and where the centre of mass is
//! is what is left: reported as paper eq. 12's ρ, the instrument origin seen from the centre of
//! mass ([`Identified::rho`], paper §8), the sign `ballisto com` writes.
//!
//! Without a reference, in a torque-free tumble with the inertia given, the motion is fitted
//! with the geometry ([`identify_tumble`]): Euler's equations carry the start rate to every
//! sample, and the search is over that rate alone.
//!
//! The channel's model, its parameters and tolerances ([`model`]) and the frame's uncertainty
//! of the result ([`crate::frame_uncertainty::motions`]) are the ones `ballisto calibrate`'s
//! ground fit uses too. That fit stays on the host: with the field unknown (static poses,
//! self-calibration) every channel's parameters are tied to every other's through the field
//! of each sample, a joint problem of `7N` parameters (84 × 84 for twelve channels, in
//! nalgebra, with allocation), where the field known here leaves one 7 × 7 problem per channel.
//!
//! A constant specific force at the centre of mass (drag, thrust) would be taken as bias: the
//! identification is for free flight, where it is far below the parts' noise (1e-6 m/s²).

pub(crate) mod cholesky;
mod fit;
pub mod model;
mod result;
mod search;
mod solve;
mod sums;
mod tumble;

pub use fit::ALWAYS_HELD;
pub use model::{reading_gradient, tilt_basis, too_few_determined, Param, Tolerance, PARAMS};
pub use result::{ChannelFit, Identified, IdentifyError};
pub use solve::identify;
pub use sums::{field_terms, FieldSums, TERMS};
pub use tumble::{identify_tumble, Body, Sets, TumbleError, TumbleFit, RESIDUAL_LIMIT};
