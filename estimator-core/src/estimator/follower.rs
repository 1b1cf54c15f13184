//! The root taken where mirror branches cross (model F, m = 3; issue 15): a kinematic filter
//! of (Ω, Ω′) that follows the motion's slope through the crossing.
//!
//! **Why.** Where two roots of the quadratic forms cross, the tracker's hypotheses test only Ω,
//! predicted by integrating each sample's own Ω′ — at 1 kHz a noisy one (≈ 0.9 rad/s² RMS) —
//! so a hypothesis that leaves the crossing on the mirror root, which does not continue the
//! slope the motion came in with, looks nearly as good as the true one, and the tracker took
//! 0.1–0.4 s to leave it: the forward path's raw Ω was 1.03–2.07 × the truth-started maximum
//! likelihood (docs/branch-lock.md). A filter that carries Ω′ as a state, driven by a white jerk,
//! sees it at once: the mirror root's Ω does not continue the filtered slope, and its Ω′ jumps.
//!
//! **How.** The state (Ω, Ω′) with one isotropic 2×2 covariance for the three axes, predicted
//! with a constant Ω′ and a jerk of [`JERK_PER_SAMPLE`] rad²/s⁴ per sample, then updated by a
//! root's Ω and by its Ω′ (the output's variance): a Kalman filter on a white-jerk model.
//! At each sample every root with either sign is scored by the negative log-likelihood of those
//! two innovations, `|ν|²/S + 3 ln S` each, and the cheapest is taken: a beam of one, which the
//! causal beam of the `two_way` probe (removed; in the git history under `tests/examples/`) (`LAGS=0`, `BEAM=1`) showed to be as good as 16
//! hypotheses (1 kHz, 2e-3 m/s², 0.12 m: 1.01 × ML in a tumble and a manoeuvre). A root's Ω
//! variance is its first-order one plus **twice** its crossing widening ([`super::crossing`]):
//! near a double root the root's error is biased by up to the half separation, alike from
//! sample to sample, which a variance counted once does not cover (at 1 kHz, 1e-2 m/s², 0.12 m,
//! manoeuvre, seed 1: 1.13 × ML in σ0 with it once, 1.01 twice, 1.92 without).
//!
//! **When.** At every sample where mirror roots can cross (the path check in full): its memory
//! of the slope is what decides at a crossing, so it runs throughout, started from the
//! tracker's choice where that is settled and not the least-squares fallback, and kept out of
//! the output for a warm-up of [`WARM_UP_S`]. It is stopped — and started again at the
//! tracker's next such choice — when its own innovation is beyond [`STEP_CAP`] (it lost the
//! motion: a wild sample, a fault) or when the tracker holds no hypothesis on the root it takes
//! (ruled out beyond the tracker's memory). The tracker keeps the flags, the margins and the filtered output; where the two
//! take different roots the output is the follower's, reported branch ambiguous with a margin
//! of 0 (sign unresolved where only the sign differs).

use super::Branch;
use crate::linalg::Vec3;
use crate::real::Real;
use crate::tracker::{Candidate, Choice, State, STEP_CAP};

/// Variance (rad²/s⁴) by which the follower's Ω′ may wander per sample (its white jerk density
/// is this times the sample rate). Measured with the forward path's raw accuracy
/// (the `forward_accuracy` probe (removed; in the git history under `tests/examples/`), the sixteen cases of `tests/tests/branch_lock.rs`,
/// seeds 1–4, ideal parts apart from the jitter, declared Gaussian noise): 0.1 held seed 1 at
/// 1.01 × ML in every case; 0.3 (the path choice's) left the 1 kHz, 1e-2 m/s² manoeuvre at
/// 1.14 and 1 kHz seed-4 tumbles at 1.8; 0.03 1.22 on the former.
pub const JERK_PER_SAMPLE: f64 = 0.1;

/// The follower's warm-up (s): after a start it follows without taking the output, and a
/// disagreement with the tracker starts it again at the tracker's choice. A start in a
/// crossing zone, where the roots are within the noise of each other, can put it on the mirror
/// root: 1 kHz, 1e-4 m/s², 0.2 m, manoeuvre, seed 4, whose record starts in one, was 3.13 × ML
/// in Ω started at the first sample, 2.33 started only from a settled choice among real roots,
/// 1.16 with the warm-up as well (the tracker alone: 1.15). At least [`WARM_UP_SAMPLES`]
/// samples.
pub const WARM_UP_S: f64 = 0.1;
/// The follower's warm-up in samples, at least (low rates).
pub const WARM_UP_SAMPLES: u8 = 5;

/// How many times a root's crossing widening is counted in its Ω variance (see the module).
const WIDENING_COUNT: f64 = 2.0;

/// The root the follower takes at a sample.
#[derive(Clone, Copy, Debug)]
pub(super) struct Pick<T> {
    /// Index of the candidate.
    pub candidate: usize,
    /// The sign applied to the candidate's Ω: +1 or −1.
    pub sign: i8,
    /// `|ν|² / S` of the root's Ω against the prediction (3 degrees of freedom).
    pub nis: T,
}

/// The (Ω, Ω′) filter (see the module's documentation).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Follower<T> {
    active: bool,
    /// Time since the start (s), up to [`WARM_UP_S`]; samples since the start, up to
    /// [`WARM_UP_SAMPLES`].
    age: T,
    samples: u8,
    omega: Vec3<T>,
    domega: Vec3<T>,
    p_ww: T,
    p_wd: T,
    p_dd: T,
}

impl<T: Real> Follower<T> {
    /// Whether the follower is running (from its start at the tracker's choice to a stop).
    pub fn active(&self) -> bool {
        self.active
    }

    /// Stops following (the tracker's choice is the output's again).
    pub fn stop(&mut self) {
        self.active = false;
    }

    /// Starts at a hypothesis: its Ω and Ω′ with their per-component variances.
    pub fn start(&mut self, (omega, omega_var): (Vec3<T>, T), (domega, domega_var): (Vec3<T>, T)) {
        *self = Follower {
            active: true,
            age: T::ZERO,
            samples: 0,
            omega,
            domega,
            p_ww: omega_var,
            p_wd: T::ZERO,
            p_dd: domega_var,
        };
    }

    /// One sample: predicted by `dt`, every candidate with either sign scored, the cheapest
    /// taken in. `widening(i)` is the mean per-component variance that the crossing adds to
    /// candidate `i`'s Ω; `domega_var` the per-component variance of Ω′. `None` without a
    /// candidate.
    pub fn step(
        &mut self,
        cands: &[Candidate<T>],
        widening: impl Fn(usize) -> T,
        dt: T,
        domega_var: T,
    ) -> Option<Pick<T>> {
        let jerk = T::of(JERK_PER_SAMPLE);
        let dt2 = dt * dt;
        let p_ww =
            self.p_ww + T::of(2.0) * dt * self.p_wd + dt2 * self.p_dd + jerk * dt2 / T::of(3.0);
        let p_wd = self.p_wd + dt * self.p_dd + T::of(0.5) * jerk * dt;
        let p_dd = self.p_dd + jerk;
        let mut w = self.omega;
        for k in 0..3 {
            w[k] += self.domega[k] * dt;
        }
        // Each candidate's innovation variances and gain, then both signs.
        let r_d = p_dd + domega_var;
        let variances = |c: &Candidate<T>, ci: usize| {
            let s = (p_ww + c.omega_var + T::of(WIDENING_COUNT) * widening(ci)).max(T::of(1e-30));
            // Ω′'s innovation variance after the Ω update is `s_d = r_d − p_wd²/s = num / s`:
            // one logarithm (`ln s + ln s_d = ln num`) and one division per candidate.
            let num = (s * r_d - p_wd * p_wd).max(T::of(1e-30) * s);
            let inv = T::ONE / (s * num);
            (s, num * inv, s * s * inv, num)
        };
        let (mut best_cost, mut best_ci, mut best_sign) = (T::ZERO, usize::MAX, T::ONE);
        for (ci, c) in cands.iter().enumerate() {
            let (_, inv_s, inv_sd, num) = variances(c, ci);
            let kd = p_wd * inv_s;
            let base = T::of(3.0) * num.ln_approx();
            for sg in [T::ONE, -T::ONE] {
                let (mut nu2, mut mu2) = (T::ZERO, T::ZERO);
                for k in 0..3 {
                    let nu = sg * c.omega[k] - w[k];
                    let mu = c.domega[k] - self.domega[k] - kd * nu;
                    nu2 += nu * nu;
                    mu2 += mu * mu;
                }
                let cost = base + nu2 * inv_s + mu2 * inv_sd;
                if best_ci == usize::MAX || cost < best_cost {
                    (best_cost, best_ci, best_sign) = (cost, ci, sg);
                }
            }
        }
        let c = cands.get(best_ci)?;
        let (s, inv_s, _, _) = variances(c, best_ci);
        // Ω, then Ω′ (the filter's update).
        let (kw, kd) = (p_ww * inv_s, p_wd * inv_s);
        let mut d = self.domega;
        let mut nu2 = T::ZERO;
        for k in 0..3 {
            let nu = best_sign * c.omega[k] - w[k];
            nu2 += nu * nu;
            w[k] += kw * nu;
            d[k] += kd * nu;
        }
        let (p_ww, p_wd, p_dd) = ((T::ONE - kw) * p_ww, (T::ONE - kw) * p_wd, p_dd - kd * p_wd);
        let s_d = (p_dd + domega_var).max(T::of(1e-30));
        let (gw, gd) = (p_wd / s_d, p_dd / s_d);
        for k in 0..3 {
            let mu = c.domega[k] - d[k];
            w[k] += gw * mu;
            d[k] += gd * mu;
        }
        self.omega = w;
        self.domega = d;
        self.p_ww = p_ww - gw * p_wd;
        self.p_wd = p_wd - gw * p_dd;
        self.p_dd = p_dd - gd * p_dd;
        Some(Pick {
            candidate: best_ci,
            sign: if best_sign > T::ZERO { 1 } else { -1 },
            nis: nu2 / s,
        })
    }
}

/// One sample of the follower beside the tracker (model F, m = 3): the output's root is the
/// follower's where the two disagree — reported branch ambiguous with a margin of 0 (sign
/// unresolved, the margin kept, where only the sign differs), the filtered Ω and the chosen
/// state (the record's `best`, whence the host's smoother traces back) the tracker's cheapest
/// hypothesis on that root — and the tracker's `choice` unchanged elsewhere. Starts,
/// steps and stops the follower (see the module's documentation).
#[inline(never)]
pub(super) fn follow<T: Real>(
    follower: &mut Follower<T>,
    choice: &mut Choice<T>,
    (cands, branches): (&[Candidate<T>], &[Branch<T>]),
    (dt, domega_var): (T, T),
    states: &[State<T>],
    fallback: bool,
) {
    let start_at_choice = |f: &mut Follower<T>| {
        f.start(
            choice.filtered,
            (cands[choice.candidate].domega, domega_var),
        )
    };
    if !follower.active() {
        // Started only from a settled choice among real roots: a tracker still deciding, or
        // the least-squares fallback (no real root: its margin says nothing), would hand the
        // follower a root it may have to leave (see [`WARM_UP_S`]).
        if !(fallback || choice.branch_ambiguous || choice.sign_unresolved) {
            start_at_choice(follower);
        }
        return;
    }
    let third = T::of(1.0 / 3.0);
    let widening = |i: usize| {
        branches.get(i).map_or(T::ZERO, |b| {
            (b.widening[0] + b.widening[1] + b.widening[2]) * third
        })
    };
    let Some(pick) = follower.step(cands, widening, dt, domega_var) else {
        follower.stop();
        return;
    };
    let tracker_sign = states.get(choice.state).map_or(1, |s| s.sign);
    let same_branch = pick.candidate == choice.candidate;
    let agrees = same_branch && pick.sign == tracker_sign;
    let warm = follower.age >= T::of(WARM_UP_S) && follower.samples >= WARM_UP_SAMPLES;
    if !warm {
        follower.age += dt;
        follower.samples = follower.samples.saturating_add(1);
    }
    if !agrees && !warm {
        // Still warming up: taken back to the tracker's choice, the warm-up started again.
        start_at_choice(follower);
        return;
    }
    if pick.nis > T::of(STEP_CAP) {
        follower.stop();
        return;
    }
    if agrees {
        return;
    }
    // The tracker's cheapest hypothesis on the follower's root; none: ruled out beyond the
    // tracker's memory.
    let held = states
        .iter()
        .enumerate()
        .filter(|(_, s)| usize::from(s.candidate) == pick.candidate && s.sign == pick.sign)
        .min_by(|(_, a), (_, b)| {
            a.cost
                .partial_cmp(&b.cost)
                .unwrap_or(core::cmp::Ordering::Equal)
        });
    let Some((held_index, held)) = held else {
        follower.stop();
        return;
    };
    let c = &cands[pick.candidate];
    let sg = T::of(f64::from(pick.sign));
    choice.candidate = pick.candidate;
    choice.omega = core::array::from_fn(|k| sg * c.omega[k]);
    choice.filtered = (held.omega, held.var);
    choice.state = held_index;
    if same_branch {
        // The same branch: its margin over the other branches stands.
        choice.sign_unresolved = true;
    } else {
        choice.branch_ambiguous = true;
        choice.branch_margin = T::ZERO;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const RATE: f64 = 1000.0;
    const SD: f64 = 0.004;
    const SD_D: f64 = 0.9;

    /// A deterministic noise in [−1, 1].
    fn noise(k: usize, axis: usize) -> f64 {
        let x = ((k * 3 + axis) as f64 * 12.9898).sin() * 43_758.545;
        2.0 * (x - x.floor()) - 1.0
    }

    /// The truth and, from `tc`, a mirror root that leaves it at 2 rad/s per s while its own
    /// Ω′ says the opposite (as after a crossing): candidates `[mirror, truth]`, noisy.
    fn candidates(k: usize, tc: f64) -> [Candidate<f64>; 2] {
        let t = k as f64 / RATE;
        let w = [1.0 + 0.5 * t, -0.4, 2.0 - 0.3 * t];
        let d = [0.5, 0.0, -0.3];
        let off = 2.0 * (t - tc).max(0.0);
        let mirror_w = [w[0] + off, w[1] - off, w[2]];
        let mirror_d = [d[0] - 2.0, d[1] + 2.0, d[2]];
        let cand = |w: [f64; 3], d: [f64; 3], j: usize| Candidate {
            omega: core::array::from_fn(|i| w[i] + SD * noise(k + 11 * j, i)),
            omega_var: SD * SD,
            domega: core::array::from_fn(|i| d[i] + SD_D * noise(k + 29 * j, i)),
            fit: 0.0,
        };
        [cand(mirror_w, mirror_d, 1), cand(w, d, 0)]
    }

    /// After the roots part, the follower takes the one that continues the slope it came in
    /// with, although the mirror is offered first and is within the noise of the truth at the
    /// first samples.
    #[test]
    fn takes_the_root_that_continues_the_slope() {
        let (tc, n) = (0.3, 600);
        let mut f = Follower::<f64>::default();
        let first = candidates(0, tc);
        f.start((first[1].omega, SD * SD), (first[1].domega, SD_D * SD_D));
        let mut wrong = Vec::new();
        for k in 1..n {
            let c = candidates(k, tc);
            let pick = f.step(&c, |_| 0.0, 1.0 / RATE, SD_D * SD_D).unwrap();
            let t = k as f64 / RATE;
            if t > tc + 0.01 && (pick.candidate, pick.sign) != (1, 1) {
                wrong.push(k);
            }
            assert!(
                pick.nis < STEP_CAP,
                "sample {k}: the follower lost the motion"
            );
        }
        assert!(wrong.is_empty(), "mirror or other sign taken at {wrong:?}");
    }

    /// Beside a tracker that leaves a crossing on the mirror (its hypothesis on the truth 30
    /// behind): the follower is started from a settled choice among real roots only, takes
    /// nothing during its warm-up, and after the crossing puts the truth in the output — branch
    /// ambiguous, margin 0, the filtered Ω the tracker's hypothesis on that root.
    #[test]
    fn overrides_the_tracker_after_its_warm_up_and_says_so() {
        let tc = 0.2;
        let branches = [Branch::default(); 2];
        let mut f = Follower::<f64>::default();
        for k in 0..400 {
            let c = candidates(k, tc);
            let t = k as f64 / RATE;
            let settled = k >= 3;
            // Before the crossing the tracker holds the truth; after it, the mirror.
            let held = usize::from(t < tc);
            // The tracker's best hypothesis first (on the root it holds), the other root's 30
            // behind.
            let hyp = |candidate: usize, cost: f64| State {
                candidate: candidate as u8,
                sign: 1,
                cost,
                omega: [7.0 + candidate as f64; 3],
                var: 2.0 + candidate as f64,
                ..State::default()
            };
            let states = [hyp(held, 0.0), hyp(1 - held, 30.0)];
            let mut choice = Choice {
                state: 0,
                candidate: held,
                omega: c[held].omega,
                filtered: (c[held].omega, SD * SD),
                sign_unresolved: false,
                branch_ambiguous: !settled,
                branch_margin: if settled { 40.0 } else { 3.0 },
            };
            let before = choice;
            let dt = if k == 0 { 0.0 } else { 1.0 / RATE };
            follow(
                &mut f,
                &mut choice,
                (&c, &branches),
                (dt, SD_D * SD_D),
                &states,
                k == 3,
            );
            if k <= 3 {
                // Not settled, or the fallback: not started.
                assert!(!f.active(), "sample {k}");
            }
            let warm = t >= 0.004 + WARM_UP_S + 0.002;
            if !warm || held == 1 {
                assert_eq!(choice.candidate, before.candidate, "sample {k}");
                assert_eq!(choice.branch_margin, before.branch_margin, "sample {k}");
            } else if t > tc + 0.01 {
                assert_eq!(choice.candidate, 1, "sample {k}: the truth");
                assert!(choice.branch_ambiguous && choice.branch_margin == 0.0);
                let hyp = states.iter().find(|s| s.candidate == 1).unwrap();
                assert_eq!(choice.filtered, (hyp.omega, hyp.var));
            }
        }
    }
}
