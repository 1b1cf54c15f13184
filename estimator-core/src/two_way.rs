//! Two-way decision of branch and sign (host tools): the estimator run forward, and run again
//! over the time-reversed record, decides each sample from the direction with more evidence.
//!
//! **Why it works.** Reversing time leaves every reading unchanged: the specific force at each
//! channel is a second derivative of position (σ(0), Ω′ and `{Ω}²` keep their values) while the
//! reversed motion's rate is `−Ω` (paper eq. 2: `Ω′` is even under reversal, `Ω` odd). So the
//! same estimator, fed the readings last to first at `t' = T − t`, estimates the reversed motion,
//! and [`reversed`] maps its output back.
//!
//! **What it repairs.** After two branches of the quadratic forms cross (m = 3), the forward
//! tracker needs 0.1–0.4 s of kinematic evidence to leave the root it followed through the
//! crossing; the samples just after a crossing are just before it for the backward pass, whose
//! choice is settled there. Each pass's [`Estimate::branch_margin`] is its evidence (twice the
//! negative log-likelihood ratio of the best other branch), so the sample takes the direction
//! with the larger margin. Measured on the nine-channel family (docs/branch-lock.md): at 1 kHz,
//! 2e-3 m/s², 0.12 m the raw Ω RMS over a 20 s tumble fell from 1.78× the truth-started
//! maximum likelihood (forward) to 1.01×. Where the margins are no guide (after a crossing both
//! passes sit at the tracker's step cap, whichever root they hold) the sample is flagged.
//!
//! **Never silently wrong.** The combined margin is the two passes' evidence added where they
//! agree and set against each other where they do not (approximating each pass's margin as the
//! cost difference between the two choices, the two-filter sum gives `m_f + m_b` and
//! `|m_f − m_b|`), so that two confident passes on different branches give a small margin and the
//! row is flagged [`Flags::BRANCH_AMBIGUOUS`]. Where a pass's lock monitor found its path
//! through the sample inconsistent (margin 0), the other pass agreeing does not clear it: two
//! passes can sit on the same mirror root (measured: 1 kHz, 1e-2 m/s², 5 cm tumble, seed 1,
//! 353 silently wrong rows when agreement cleared it).

use crate::estimate::{Estimate, Flags};
use crate::real::Real;
use crate::tracker::{COST_CAP, SIGN_MARGIN};

/// Two estimates agree when every component of Ω is within this many combined deviations.
const AGREE_SD: f64 = 5.0;

/// The forward-time estimate of a sample from the reversed pass's estimate: Ω changes sign;
/// σ0, Ω′, the field `A = Γ + {Ω}²` and every deviation keep theirs.
pub fn reversed<T: Real>(e: &Estimate<T>) -> Estimate<T> {
    let mut out = *e;
    out.omega = e.omega.map(|v| -v);
    out
}

/// True if the two estimates of Ω are within [`AGREE_SD`] combined deviations in every
/// component.
fn agree<T: Real>(a: &Estimate<T>, b: &Estimate<T>) -> bool {
    (0..3).all(|i| {
        let d = (a.omega[i] - b.omega[i]).abs();
        let s = (a.sd_omega[i] * a.sd_omega[i] + b.sd_omega[i] * b.sd_omega[i]).sqrt();
        !(d > T::of(AGREE_SD) * s)
    })
}

/// True if the lock monitor flagged the estimate (branch ambiguous with margin 0; the module
/// `estimator::lock_monitor`).
fn inconsistent<T: Real>(e: &Estimate<T>) -> bool {
    e.flags.has(Flags::BRANCH_AMBIGUOUS) && !(e.branch_margin > T::ZERO)
}

/// True if the two passes disagree in sign only: within [`AGREE_SD`] once one is reversed.
fn opposite_signs<T: Real>(forward: &Estimate<T>, backward: &Estimate<T>) -> bool {
    !agree(forward, backward) && agree(forward, &reversed(backward))
}

/// One sample's decision from its forward estimate and its backward one (already
/// [`reversed`]): the estimate of the direction with the larger branch margin, with the
/// combined margin and [`Flags::BRANCH_AMBIGUOUS`] set exactly when it is below the sign
/// margin. A sample the estimator could not use ([`Flags::INPUT_INVALID`]) keeps the forward
/// output. The sign is unresolved only if the chosen direction's is and the two do not agree,
/// or if the two hold opposite signs, each settled.
pub fn combine<T: Real>(forward: &Estimate<T>, backward: &Estimate<T>) -> Estimate<T> {
    if forward.flags.has(Flags::INPUT_INVALID) || backward.flags.has(Flags::INPUT_INVALID) {
        return *forward;
    }
    let agreed = agree(forward, backward);
    if opposite_signs(forward, backward) {
        // The passes hold opposite signs (the branch margins do not weigh the sign). A pass
        // whose sign is settled wins over one whose is not (the first samples of a record
        // without a rate hint); two settled ones keep the forward pass's, whose sign descends
        // from the record's start, and say so.
        let unresolved = |e: &Estimate<T>| e.flags.has(Flags::SIGN_UNRESOLVED);
        if unresolved(forward) && !unresolved(backward) {
            return *backward;
        }
        let mut out = *forward;
        out.flags = Flags(out.flags.0 | Flags::SIGN_UNRESOLVED);
        return out;
    }
    let (mf, mb) = (forward.branch_margin, backward.branch_margin);
    let mut out = if mb > mf { *backward } else { *forward };
    let margin = if agreed && (inconsistent(forward) || inconsistent(backward)) {
        // A pass's lock monitor found the path through this sample kinematically
        // inconsistent: the other pass agreeing is no evidence against that (both may sit on
        // the same mirror root).
        T::ZERO
    } else if agreed {
        (mf + mb).min(T::of(COST_CAP))
    } else {
        (mf - mb).abs()
    };
    out.branch_margin = margin;
    let mut bits = out.flags.0 & !Flags::BRANCH_AMBIGUOUS;
    if margin < T::of(SIGN_MARGIN) {
        bits |= Flags::BRANCH_AMBIGUOUS;
    }
    let resolved_by_either =
        !forward.flags.has(Flags::SIGN_UNRESOLVED) || !backward.flags.has(Flags::SIGN_UNRESOLVED);
    if agreed && resolved_by_either {
        bits &= !Flags::SIGN_UNRESOLVED;
    }
    out.flags = Flags(bits);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn est(omega: [f64; 3], sd: f64, margin: f64, flags: u16) -> Estimate<f64> {
        Estimate {
            omega,
            sd_omega: [sd; 3],
            branch_margin: margin,
            flags: Flags(flags),
            ..Default::default()
        }
    }

    #[test]
    fn reversal_negates_only_the_rate() {
        let mut e = est([1.0, -2.0, 3.0], 0.1, 40.0, 0);
        e.domega = [0.5, 0.6, 0.7];
        e.sigma0 = [9.0, 8.0, 7.0];
        let r = reversed(&e);
        assert_eq!(r.omega, [-1.0, 2.0, -3.0]);
        assert_eq!(r.domega, e.domega);
        assert_eq!(r.sigma0, e.sigma0);
        assert_eq!(r.sd_omega, e.sd_omega);
    }

    #[test]
    fn agreeing_passes_add_their_evidence() {
        let f = est([1.0, 0.0, 0.0], 0.1, 10.0, Flags::BRANCH_AMBIGUOUS);
        let b = est([1.05, 0.0, 0.0], 0.1, 9.0, Flags::BRANCH_AMBIGUOUS);
        let c = combine(&f, &b);
        assert_eq!(c.branch_margin, 19.0);
        assert!(!c.flags.has(Flags::BRANCH_AMBIGUOUS));
        assert_eq!(c.omega, f.omega, "the larger margin's estimate");
        let capped = combine(&est([1.0; 3], 0.1, 150.0, 0), &est([1.0; 3], 0.1, 150.0, 0));
        assert_eq!(capped.branch_margin, COST_CAP);
    }

    #[test]
    fn a_lock_monitor_verdict_stands_against_agreement() {
        let f = est([1.0, 0.0, 0.0], 0.1, 0.0, Flags::BRANCH_AMBIGUOUS);
        let b = est([1.0, 0.0, 0.0], 0.1, 200.0, 0);
        let c = combine(&f, &b);
        assert_eq!(c.branch_margin, 0.0);
        assert!(c.flags.has(Flags::BRANCH_AMBIGUOUS));
        let c = combine(&b, &f);
        assert!(c.flags.has(Flags::BRANCH_AMBIGUOUS));
    }

    #[test]
    fn disagreeing_passes_set_their_evidence_against_each_other() {
        let f = est([1.0, 0.0, 0.0], 0.1, 60.0, 0);
        let b = est([0.3, 1.2, 0.0], 0.1, 50.0, 0);
        let c = combine(&f, &b);
        assert_eq!(c.omega, f.omega);
        assert_eq!(c.branch_margin, 10.0);
        assert!(c.flags.has(Flags::BRANCH_AMBIGUOUS));
        let c = combine(&f, &est([0.3, 1.2, 0.0], 0.1, 90.0, 0));
        assert_eq!(
            c.omega,
            [0.3, 1.2, 0.0],
            "the backward pass has more evidence"
        );
        assert_eq!(c.branch_margin, 30.0);
        assert!(!c.flags.has(Flags::BRANCH_AMBIGUOUS));
    }

    #[test]
    fn the_sign_is_resolved_by_either_pass_that_agrees() {
        let f = est([1.0; 3], 0.1, 30.0, Flags::SIGN_UNRESOLVED);
        let b = est([1.0; 3], 0.1, 20.0, 0);
        assert!(!combine(&f, &b).flags.has(Flags::SIGN_UNRESOLVED));
        let both = est([1.0; 3], 0.1, 20.0, Flags::SIGN_UNRESOLVED);
        assert!(combine(&f, &both).flags.has(Flags::SIGN_UNRESOLVED));
    }

    #[test]
    fn opposite_signs_are_flagged_and_the_forward_sign_kept() {
        let f = est([1.0, 0.5, 0.0], 0.1, 0.0, Flags::BRANCH_AMBIGUOUS);
        let b = est([-1.0, -0.5, 0.0], 0.1, 200.0, 0);
        let c = combine(&f, &b);
        assert_eq!(c.omega, f.omega);
        assert!(c.flags.has(Flags::SIGN_UNRESOLVED));
    }

    #[test]
    fn a_settled_sign_wins_over_an_unsettled_one() {
        let f = est([1.0, 0.5, 0.0], 0.1, 30.0, Flags::SIGN_UNRESOLVED);
        let b = est([-1.0, -0.5, 0.0], 0.1, 20.0, 0);
        let c = combine(&f, &b);
        assert_eq!(c.omega, b.omega);
        assert!(!c.flags.has(Flags::SIGN_UNRESOLVED));
    }

    #[test]
    fn an_unusable_sample_keeps_the_forward_prediction() {
        let f = est([1.0; 3], 0.1, 5.0, Flags::INPUT_INVALID);
        let b = est([2.0; 3], 0.1, 90.0, Flags::INPUT_INVALID);
        let c = combine(&f, &b);
        assert_eq!(c.omega, f.omega);
        assert_eq!(c.flags, f.flags);
    }
}
