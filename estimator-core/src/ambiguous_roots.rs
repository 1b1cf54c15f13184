//! The roots a sample offers the path ([`crate::path_choice`]) where the two-way decision
//! ([`crate::two_way::combine`]) flags it branch ambiguous, and the estimate taken from the root
//! the path chooses (host tools, issue 15).
//!
//! **Why every root.** Offered only the two passes' estimates (stop 30), the path could not take
//! a root that neither pass held: in a manoeuvre with the 5 cm arm (1 kHz, 2e-3 m/s²) both
//! fixed-lag passes held the wrong root in some crossing zones, and the raw σ0 stayed 1.37× the
//! truth-started maximum likelihood; the per-sample oracle over every root is that maximum
//! likelihood exactly (`tests/examples/two_way.rs`, "oracle all"). Offered every root, with the
//! signs the passes hold, where the margins do not decide — and the decision's estimate
//! elsewhere — that case is 1.02× and the 1e-2 m/s² manoeuvre 1.06× (1.13×). Over the branch-lock
//! sweep (72 families × 4 seeds) the flags and silent rows are unchanged in every family and the
//! raw Ω RMS is better in 19 (up to −52 %) and worse in 22 (up to +20 %: at 4 kHz, 1e-2 m/s²,
//! 0.2 m, seed 4's first two seconds, where the path, not yet anchored by a long record, takes
//! a mirror root through the first ambiguous stretch). Offered only the roots one of the passes
//! holds, the 5 cm manoeuvre stayed at 1.37×; offered every root everywhere, the path overrode
//! settled decisions and was farther from the truth than the decision at most such rows in nine
//! of twelve cases probed.
//!
//! **What changes.** Only the estimate of such a sample: its flags and branch margin stay the
//! decision's (flag 16 exactly where the margin is under 16), so a row the path takes is
//! flagged, or not, as it was. A root neither pass holds is output as the estimator solved it (its deviations widened
//! near the crossing, [`crate::estimator`]'s crossing widening), raw even where the passes'
//! outputs are filtered: no filter has followed it.

use crate::estimate::{Estimate, Flags};
use crate::frame_uncertainty::FrameUncertainty;
use crate::linalg::Vec3;
use crate::path_choice::MAX_OPTIONS;
use crate::real::Real;
use crate::smoother::StepRecord;
use crate::tracker::MAX_CANDIDATES;

/// One sample's roots as the forward pass solved them (Ω with the + sign), with each root's
/// crossing widening (the diagonal of what was added to its Ω variance).
#[derive(Clone, Copy, Debug, Default)]
pub struct Roots<T> {
    roots: [Estimate<T>; MAX_CANDIDATES],
    widening: [Vec3<T>; MAX_CANDIDATES],
    n: u8,
}

impl<T: Real> Roots<T> {
    /// The roots of the sample `record` holds (filled by `Estimator::update_with`); none if the
    /// sample could not be used.
    pub fn of(record: &StepRecord<T>) -> Self {
        let n = if record.valid {
            usize::from(record.n_candidates).min(MAX_CANDIDATES)
        } else {
            0
        };
        let mut out = Roots {
            n: n as u8,
            ..Self::default()
        };
        out.roots[..n].copy_from_slice(&record.candidates[..n]);
        out.widening[..n].copy_from_slice(&record.widening[..n]);
        out
    }

    /// Number of roots.
    pub fn len(&self) -> usize {
        usize::from(self.n)
    }

    /// True without a root.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The options of an ambiguous sample, written into `out` (returns their number): every
    /// root with each sign that one of the passes holds (Ω not opposite to both passes': the
    /// sign is the passes' to decide, [`crate::two_way::combine`]), as the path's measurement —
    /// Ω's variance widened by the root's crossing term once more (measured on the probe's
    /// twelve cases: without it the 4 kHz manoeuvre with the 5 cm arm at 1e-2 m/s², seed 4,
    /// went from 1.07 to 1.09× the maximum likelihood, a 1 kHz tumble from 1.60 to 1.66×) —
    /// and which root and sign each is. Fewer than two roots: no option (nothing to choose).
    pub fn options(
        &self,
        forward: &Estimate<T>,
        backward: &Estimate<T>,
        out: &mut [RootOption<T>; MAX_OPTIONS],
    ) -> usize {
        if self.len() < 2 {
            return 0;
        }
        let mut m = 0;
        let roots = self.roots.iter().zip(self.widening.iter()).take(self.len());
        for (i, (root, wd)) in roots.enumerate() {
            for sign in [1i8, -1] {
                let mut e = signed(root, sign);
                if !(along(&e, forward) > T::ZERO || along(&e, backward) > T::ZERO) {
                    continue;
                }
                e.sd_omega =
                    core::array::from_fn(|k| (e.sd_omega[k] * e.sd_omega[k] + wd[k]).sqrt());
                out[m] = RootOption {
                    measurement: e,
                    root: i as u8,
                    sign,
                };
                m += 1;
            }
        }
        m
    }

    /// The estimate of an ambiguous sample whose path took `option` (one of
    /// [`Roots::options`]'s): the decision's own (`decided`) where it holds that root with that
    /// sign, else the pass that does, else the root as solved with the arrangement's `frame`
    /// uncertainty (as the estimator adds it to its outputs); always with the decision's branch
    /// margin and its branch and sign flags (the other flags of the estimate taken are kept).
    pub fn take(
        &self,
        option: &RootOption<T>,
        decided: &Estimate<T>,
        forward: &Estimate<T>,
        backward: &Estimate<T>,
        frame: &FrameUncertainty<T>,
    ) -> Estimate<T> {
        let Some(root) = self.roots[..self.len()].get(usize::from(option.root)) else {
            return *decided;
        };
        let mut chosen = signed(root, option.sign);
        let holds = |e: &Estimate<T>| Self::holds_signed(&chosen, e);
        let mut out = if holds(decided) {
            return *decided;
        } else if holds(forward) {
            *forward
        } else if holds(backward) {
            *backward
        } else {
            frame.widen(&mut chosen);
            chosen
        };
        // Branch and sign are the decision's (flag 16 exactly when its margin is under 16);
        // what the solve says of the root (fallback, ill-conditioned, …) is added.
        let decision = Flags::BRANCH_AMBIGUOUS | Flags::SIGN_UNRESOLVED;
        out.flags = Flags((out.flags.0 & !decision) | decided.flags.0);
        out.branch_margin = decided.branch_margin;
        out
    }
}

impl<T: Real> Roots<T> {
    /// `e` holds the root `signed` (Ω with its sign): the same `a`, Ω on the same side.
    fn holds_signed(signed: &Estimate<T>, e: &Estimate<T>) -> bool {
        same_root(&e.a, &signed.a) && along(signed, e) > T::ZERO
    }
}

/// A root with a sign, offered to the path at an ambiguous sample.
#[derive(Clone, Copy, Debug, Default)]
pub struct RootOption<T> {
    /// What the path takes as its measurement (Ω, Ω′ and their deviations).
    pub measurement: Estimate<T>,
    root: u8,
    sign: i8,
}

/// The root with Ω of the given sign (σ0, Ω′ and the field do not depend on it).
fn signed<T: Real>(root: &Estimate<T>, sign: i8) -> Estimate<T> {
    if sign < 0 {
        crate::two_way::reversed(root)
    } else {
        *root
    }
}

/// `Ω_a · Ω_b`.
fn along<T: Real>(a: &Estimate<T>, b: &Estimate<T>) -> T {
    (0..3).fold(T::ZERO, |s, k| s + a.omega[k] * b.omega[k])
}

/// Two solutions `a` of the quadratic forms are the same root (`a` and `−a` solve them alike):
/// equal to a part in a thousand. The passes solve a sample from different starts, so their
/// roots agree to the solver's tolerance, not bit for bit.
fn same_root<T: Real>(x: &Vec3<T>, y: &Vec3<T>) -> bool {
    let d2 = |s: T| {
        (0..3).fold(T::ZERO, |acc, k| {
            acc + (x[k] - s * y[k]) * (x[k] - s * y[k])
        })
    };
    let scale = (0..3).fold(T::ZERO, |acc, k| acc + x[k] * x[k] + y[k] * y[k]);
    let tol = T::of(1e-6) * scale;
    d2(T::ONE) <= tol || d2(-T::ONE) <= tol
}

#[cfg(test)]
mod tests {
    use super::*;

    fn root(a: [f64; 3], sd: f64) -> Estimate<f64> {
        Estimate {
            a,
            omega: a,
            sd_omega: [sd; 3],
            ..Default::default()
        }
    }

    fn roots(rs: &[Estimate<f64>], widening: f64) -> Roots<f64> {
        let mut out = Roots::default();
        for (i, r) in rs.iter().enumerate() {
            out.roots[i] = *r;
            out.widening[i] = [widening; 3];
        }
        out.n = rs.len() as u8;
        out
    }

    /// Options: each root with the signs the passes hold, Ω's variance widened once more; a
    /// single root offers nothing.
    #[test]
    fn options_are_the_roots_with_the_passes_signs() {
        let r = roots(
            &[root([1.0, 0.0, 0.0], 0.1), root([0.0, 2.0, 0.0], 0.1)],
            0.03,
        );
        let f = root([1.0, 0.1, 0.0], 0.05);
        let mut out = [RootOption::default(); MAX_OPTIONS];
        // Both passes on the + side of root 0, and at right angles to root 1 (Ω · Ω = 0.2 > 0
        // for its + sign only).
        let n = r.options(&f, &f, &mut out);
        assert_eq!(n, 2);
        assert_eq!((out[0].root, out[0].sign), (0, 1));
        assert_eq!((out[1].root, out[1].sign), (1, 1));
        assert!((out[0].measurement.sd_omega[0] - (0.01f64 + 0.03).sqrt()).abs() < 1e-12);
        // Passes of opposite signs: both signs of each root.
        let b = root([-1.0, -0.1, 0.0], 0.05);
        assert_eq!(r.options(&f, &b, &mut out), 4);
        let one = roots(&[root([1.0, 0.0, 0.0], 0.1)], 0.0);
        assert_eq!(one.options(&f, &b, &mut out), 0);
    }

    /// The estimate taken: the decision's where it holds the root, the other pass's where that
    /// one does, else the root itself — with the decision's flags and margin in every case.
    #[test]
    fn the_root_taken_keeps_the_decisions_flags_and_margin() {
        let r0 = root([1.0, 0.0, 0.0], 0.1);
        let r1 = root([0.0, 2.0, 0.0], 0.1);
        let r2 = root([0.5, 0.5, 3.0], 0.1);
        let r = roots(&[r0, r1, r2], 0.0);
        let mut fwd = r0;
        fwd.omega = [1.01, 0.0, 0.0]; // filtered
        fwd.sd_omega = [0.02; 3];
        let mut bwd = r1;
        bwd.a = [0.0, 2.0 + 1e-9, 0.0]; // solved from another start
        let mut decided = fwd;
        decided.flags = Flags(Flags::BRANCH_AMBIGUOUS);
        decided.branch_margin = 3.0;
        let mut out = [RootOption::default(); MAX_OPTIONS];
        let n = r.options(&fwd, &bwd, &mut out);
        let frame = FrameUncertainty::default();
        let pick = |root: u8, sign: i8| {
            *out[..n]
                .iter()
                .find(|o| o.root == root && o.sign == sign)
                .unwrap()
        };
        assert_eq!(
            r.take(&pick(0, 1), &decided, &fwd, &bwd, &frame).omega,
            decided.omega
        );
        let other = r.take(&pick(1, 1), &decided, &fwd, &bwd, &frame);
        assert_eq!(other.omega, bwd.omega);
        assert!(other.flags.has(Flags::BRANCH_AMBIGUOUS));
        assert_eq!(other.branch_margin, 3.0);
        // The decision not ambiguous (passes agreeing within the noise), the pass taken flagged
        // of its own: the decision's flag and margin, not the pass's.
        let mut settled = decided;
        settled.flags = Flags(0);
        settled.branch_margin = 40.0;
        let mut flagged_bwd = bwd;
        flagged_bwd.flags = Flags(Flags::BRANCH_AMBIGUOUS | Flags::FALLBACK);
        let quiet = r.take(&pick(1, 1), &settled, &fwd, &flagged_bwd, &frame);
        assert_eq!(quiet.flags, Flags(Flags::FALLBACK));
        assert_eq!(quiet.branch_margin, 40.0);
        let neither = r.take(&pick(2, 1), &decided, &fwd, &bwd, &frame);
        assert_eq!(neither.omega, r2.omega);
        assert!(neither.flags.has(Flags::BRANCH_AMBIGUOUS));
        assert_eq!(neither.branch_margin, 3.0);
    }
}
