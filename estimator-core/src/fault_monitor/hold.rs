//! What outlives a window: a suspicion held through sets without a test, and the last rate
//! the monitor trusted.

use super::Verdict;
use crate::estimate::{Estimate, Flags};
use crate::real::Real;

/// A suspicion outlives a spell without a test. Where exclusions leave no redundancy (model G
/// switched to model F on the nine channels left) the monitor has no test and says
/// [`Verdict::NoTest`]; a fault it suspected and could not isolate may still be in the
/// channels in use, and nothing can tell. So a suspicion stands until a test clears it, or
/// until a part is taken out that explains it (isolated by the monitor, or by its own signal:
/// a stuck part whose exclusion itself leaves no test). Measured on `tetra-orbit-faults` (a
/// bias on one part, then another part dead): dropping it left 194 rows silently wrong through
/// the firmware, 0.06–0.14 rad/s off.
#[derive(Clone, Copy, Debug, Default)]
pub struct Suspicion {
    held: bool,
}

impl Suspicion {
    /// The verdict to act on: [`Verdict::NoTest`] while a suspicion stands is
    /// [`Verdict::NotIsolated`]; any test's verdict replaces it; `explained`: a part was taken
    /// out of the solve at this sample as isolated (the suspicion is dropped).
    pub fn hold(&mut self, verdict: Verdict, explained: bool) -> Verdict {
        let verdict = if verdict == Verdict::NoTest && self.held && !explained {
            Verdict::NotIsolated
        } else {
            verdict
        };
        self.held = verdict == Verdict::NotIsolated;
        verdict
    }
}

/// The rate hint across an exclusion or a re-admission: the last estimate with no warning flag
/// from readings the monitor found consistent, carried forward by its Ω′. (The estimates
/// between a fault's onset and its isolation may have taken the wrong sign, and the estimator
/// restarts its branch and sign tracking on the new channel set from this hint; a fault is
/// isolated 0.1–2 s after its onset, and in a slew Ω moves by rad/s meanwhile.)
#[derive(Clone, Copy, Debug, Default)]
pub struct TrustedRate {
    last: Option<(f64, [f64; 3], [f64; 3])>,
}

impl TrustedRate {
    /// Takes `e` (at `t`, s) if the monitor's `verdict` and its flags say it can be trusted.
    pub fn observe<T: Real>(&mut self, t: f64, e: &Estimate<T>, verdict: Verdict) {
        if verdict != Verdict::NotIsolated
            && e.is_finite()
            && e.flags.0 & !Flags::CHANNELS_EXCLUDED == 0
        {
            self.last = Some((t, e.omega.map(|v| v.to_f64()), e.domega.map(|v| v.to_f64())));
        }
    }

    /// The trusted Ω carried to `t` (s) by its Ω′, if there is one (back in time too: the
    /// hint for the first of the sets replayed after an exclusion, `crate::recent`).
    pub fn hint_at(&self, t: f64) -> Option<[f64; 3]> {
        let (t0, omega, domega) = self.last?;
        let age = t - t0;
        Some(core::array::from_fn(|k| omega[k] + domega[k] * age))
    }
}
