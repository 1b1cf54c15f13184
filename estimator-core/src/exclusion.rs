//! Parts that stop answering: when a part is taken out of the solve and when it is
//! put back — the bookkeeping the firmware and `ballisto estimate` share, so that both leave
//! the same parts out at the same samples.
//!
//! A part whose readings are all missing (no value on the bus, an empty field in a samples
//! file) for [`EXCLUDE_AFTER`] sets in a row is wanted out; an excluded part with
//! [`INCLUDE_AFTER`] good sets in a row is wanted back. Until then a missing reading gives the
//! estimator's flagged prediction. Which channels the solve then uses, and in which model, is
//! [`crate::Estimator::set_mask_in`]'s.

/// Sets in a row without a value after which a part is wanted out of the solve.
pub const EXCLUDE_AFTER: u16 = 5;
/// Good sets in a row after which an excluded part is wanted back.
pub const INCLUDE_AFTER: u16 = 100;

/// Runs of missing and of good sets per part (`P` parts at most; a part index is a bit of a
/// `u32` set, so `P ≤ 32`).
#[derive(Clone, Debug)]
pub struct MissingRuns<const P: usize> {
    missing: [u16; P],
    good: [u16; P],
}

impl<const P: usize> Default for MissingRuns<P> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const P: usize> MissingRuns<P> {
    /// No part seen yet.
    pub const fn new() -> Self {
        MissingRuns {
            missing: [0; P],
            good: [0; P],
        }
    }

    /// One set's news of part `part`: whether it had a value. Parts beyond `P` are ignored.
    pub fn observe(&mut self, part: usize, present: bool) {
        let (Some(m), Some(g)) = (self.missing.get_mut(part), self.good.get_mut(part)) else {
            return;
        };
        if present {
            *m = 0;
            *g = g.saturating_add(1);
        } else {
            *g = 0;
            *m = m.saturating_add(1);
        }
    }

    /// The parts wanted out (bit per part), from those out now (`current`): a part missing for
    /// [`EXCLUDE_AFTER`] sets joins, one good for [`INCLUDE_AFTER`] sets leaves.
    pub fn wanted(&self, current: u32) -> u32 {
        let mut wanted = current;
        for i in 0..P.min(32) {
            if self.missing[i] >= EXCLUDE_AFTER {
                wanted |= 1 << i;
            } else if self.good[i] >= INCLUDE_AFTER {
                wanted &= !(1 << i);
            }
        }
        wanted
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_part_is_wanted_out_after_its_missing_run_and_back_after_its_good_run() {
        let mut runs = MissingRuns::<4>::new();
        let mut out = 0;
        for k in 0..EXCLUDE_AFTER {
            assert_eq!(runs.wanted(out), 0, "set {k}");
            runs.observe(2, false);
            runs.observe(1, true);
        }
        out = runs.wanted(out);
        assert_eq!(out, 0b100);
        // Back only after a whole good run; one missing set starts it again.
        for _ in 0..INCLUDE_AFTER - 1 {
            runs.observe(2, true);
        }
        runs.observe(2, false);
        assert_eq!(runs.wanted(out), 0b100);
        for _ in 0..INCLUDE_AFTER {
            runs.observe(2, true);
        }
        assert_eq!(runs.wanted(out), 0);
        // Beyond the capacity: ignored, not a panic.
        runs.observe(7, false);
    }
}
