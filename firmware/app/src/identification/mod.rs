//! Identification in flight (paper §6): each channel's geometry from the field a
//! reference rate gives (estimation → identification).
//!
//! A window is started by TC[200,8]. Every sample set of the window (its channel vector, as the
//! estimator got it) waits in a short queue until the reference points (TC[200,9], Ω on the
//! unit's time) cover its instant; then Ω and Ω′ there ([`reference`]) make the field's terms
//! and the set goes into estimator-core's sums (`identify::FieldSums`: 55 + 11 N multiply-adds,
//! no set kept). TC[200,10] solves the sums (`identify::identify`); the application keeps the
//! solution under a number and TC[200,11] names that number to commit it. All of it but the
//! copy of each set runs in the identification task, below the estimate ([`task`]). The
//! field: `σ(0) = 0` at the centre of mass (free flight) and the reference's Ω and Ω′; the
//! gravity gradient (≈ 4e-6 s⁻² in low orbit, 4e-7 m/s² on a 0.1 m arm) is left out. Across
//! windows at different temperatures each channel's bias is tracked against its part's
//! temperature ([`thermal`]), and a commit takes the temperature coefficient it decides.

mod reference;
mod task;
mod thermal;
mod tumble;
mod window;

pub use reference::{Push, ReferenceTrack};
pub use task::{Identifier, Order, Solved, ORDERS, SET_QUEUE};
pub use thermal::ThermalTracking;
pub use tumble::{longest_window_ms, TUMBLE_FLOATS};
pub use window::Identification;

/// Why a window gives no solution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Unsolved {
    /// No window was started.
    NoWindow,
    /// With a reference: the solve failed.
    Identify(estimator_core::identify::IdentifyError),
    /// In a tumble: the search or the solve failed, or the motion does not determine a
    /// parameter.
    Tumble(estimator_core::identify::TumbleError),
}

/// Sample sets that can wait for the reference to cover them. At sample rates where that is
/// less than three reference periods, only every d-th set is taken (the window then averages
/// fewer sets; nothing else changes).
pub const PENDING: usize = 48;

/// What the window has seen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    /// Sets the reference did not cover (before its first points, in a gap, or pushed out of
    /// the queue waiting for it).
    pub not_covered: u32,
    /// Sets with a reading missing.
    pub incomplete: u32,
    /// Reference points taken.
    pub points: u32,
    /// Reference points that restarted the track (after the first).
    pub restarts: u32,
}
