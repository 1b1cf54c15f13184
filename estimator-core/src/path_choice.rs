//! Which pass each sample takes in the two-way decision (host tools, issue 15): the path through
//! the forward and backward passes' estimates that is most consistent with a smooth motion,
//! decided over a whole block of samples.
//!
//! **Why.** Where two branches of the quadratic forms cross or touch (model F, m = 3), each pass
//! may leave the crossing on the wrong root and take 0.1–0.4 s to come back; the truth is then
//! on the other pass (docs/branch-lock.md: choosing per sample the pass nearer the truth gives the
//! maximum-likelihood accuracy). Each pass's branch margin sits at the tracker's step cap after a
//! crossing whichever root it holds, so the larger margin is a coin toss there: at 1 kHz the raw
//! Ω RMS of a manoeuvre stayed 1.2–1.6× the truth-started maximum likelihood.
//!
//! **How.** Along the true path `dΩ/dt = Ω′` with Ω′ varying smoothly; a path that jumps to the
//! other root at a crossing does not continue the slope it came in with. A beam of
//! [`PATH_WIDTH`] hypotheses, each a Kalman filter of the state (Ω, Ω′) — constant Ω′ driven by
//! white jerk, the same isotropic 2×2 covariance for the three axes — takes at every sample one
//! of the estimates the sample offers: its Ω (variance: the mean of its `sd_omega²`) and then
//! its Ω′ (the mean of its `sd_domega²`) as measurements; a hypothesis' cost is the negative
//! log-likelihood of its innovations, `|ν|²/S + 3 ln S` for each. The cheapest hypotheses
//! survive, at most [`PER_OPTION`] per option of the sample; at the end of the block the
//! cheapest one's history gives each sample's option (a Viterbi decision over the whole block,
//! not a per-sample one).
//!
//! **The jerk density** is `JERK_PER_SAMPLE × rate` (Ω′ may wander by √0.3 rad/s² per
//! sample): measured on the nine-channel family (the `two_way` probe (removed; in the git history under `tests/examples/`), raw Ω against the
//! maximum likelihood), a rate-independent density lost lock at one end or the other (1 000
//! rad²/s⁵: 16× at 100 Hz; 10: 1.7× at 4 kHz, 1 kHz manoeuvre); per sample, 0.1–0.3 × rate
//! held every case tried from 50 Hz to 4 kHz, while 1 × rate took the 1 kHz tumble to 1.38×.
//!
//! `ballisto estimate` offers every root of the sample, with the signs the passes hold, where
//! the two-way decision flags it branch ambiguous (the passes' margins do not decide), and the
//! two-way estimate elsewhere (issue 15): the flags and margins stay the two-way
//! decision's, and only the estimate taken in ambiguous samples changes. Offered only the two
//! passes' estimates there, the path could not take a root that neither pass held.
//! Allocation-free: the caller keeps one [`Links`] per sample of the block.

use crate::estimate::Estimate;
use crate::real::Real;

/// Hypotheses kept by the beam. Measured on the nine-channel family
/// (the `two_way` probe (removed; in the git history under `tests/examples/`)): 16, at most [`PER_OPTION`] per option of a sample.
pub const PATH_WIDTH: usize = 16;

/// Hypotheses kept per option of a sample (the beam stays spread over the roots).
pub const PER_OPTION: usize = 2;

/// Options of one sample at most: every root of the quadratic forms with either sign.
pub const MAX_OPTIONS: usize = 2 * crate::tracker::MAX_CANDIDATES;

/// Variance (rad²/s⁴) by which Ω′ may wander per sample (the white jerk density is this times
/// the sample rate; see the module's documentation).
pub const JERK_PER_SAMPLE: f64 = 0.3;

/// One hypothesis: the filtered Ω and Ω′, their per-axis covariance, and its cost.
#[derive(Clone, Copy, Debug, Default)]
pub struct PathState {
    omega: [f64; 3],
    domega: [f64; 3],
    p_ww: f64,
    p_wd: f64,
    p_dd: f64,
    cost: f64,
}

impl PathState {
    /// The cumulative cost (negative log-likelihood of the innovations).
    pub fn cost(&self) -> f64 {
        self.cost
    }

    /// The same state at another cost (probes).
    pub fn with_cost(s: &Self, cost: f64) -> Self {
        PathState { cost, ..*s }
    }

    /// A state at an estimate (its Ω and Ω′ with their variances), at cost 0.
    pub fn at<T: Real>(e: &Estimate<T>) -> Self {
        PathState {
            omega: e.omega.map(|v| v.to_f64()),
            domega: e.domega.map(|v| v.to_f64()),
            p_ww: omega_var(e),
            p_wd: 0.0,
            p_dd: domega_var(e),
            cost: 0.0,
        }
    }

    /// Predicted by `dt` (constant Ω′, white jerk of density `jerk`, rad²/s⁵) and updated by
    /// `e`'s Ω and then its Ω′; the innovations' negative log-likelihood is added to the cost.
    pub fn step<T: Real>(&self, dt: f64, jerk: f64, e: &Estimate<T>) -> Self {
        let mut w = [0.0; 3];
        for (k, v) in w.iter_mut().enumerate() {
            *v = self.omega[k] + self.domega[k] * dt;
        }
        let p_ww =
            self.p_ww + 2.0 * dt * self.p_wd + dt * dt * self.p_dd + jerk * dt * dt * dt / 3.0;
        let p_wd = self.p_wd + dt * self.p_dd + jerk * dt * dt / 2.0;
        let p_dd = self.p_dd + jerk * dt;
        // Ω.
        let s = p_ww + omega_var(e);
        let nu: [f64; 3] = core::array::from_fn(|k| e.omega[k].to_f64() - w[k]);
        let mut cost = self.cost + innovation_cost(&nu, s);
        let (kw, kd) = (p_ww / s, p_wd / s);
        let mut d = self.domega;
        for k in 0..3 {
            w[k] += kw * nu[k];
            d[k] += kd * nu[k];
        }
        let (p_ww, p_wd, p_dd) = ((1.0 - kw) * p_ww, (1.0 - kw) * p_wd, p_dd - kd * p_wd);
        // Ω′.
        let s = p_dd + domega_var(e);
        let nu: [f64; 3] = core::array::from_fn(|k| e.domega[k].to_f64() - d[k]);
        cost += innovation_cost(&nu, s);
        let (gw, gd) = (p_wd / s, p_dd / s);
        for k in 0..3 {
            w[k] += gw * nu[k];
            d[k] += gd * nu[k];
        }
        PathState {
            omega: w,
            domega: d,
            p_ww: p_ww - gw * p_wd,
            p_wd: p_wd - gw * p_dd,
            p_dd: p_dd - gd * p_dd,
            cost,
        }
    }
}

/// `|ν|²/S + 3 ln S` for a 3-vector innovation of per-axis variance `s` (floored so that a
/// degenerate variance cannot give an infinite or NaN cost).
fn innovation_cost(nu: &[f64; 3], s: f64) -> f64 {
    let s = s.max(1e-30);
    (nu[0] * nu[0] + nu[1] * nu[1] + nu[2] * nu[2]) / s + 3.0 * s.ln_approx()
}

/// Mean per-axis variance of an estimate's Ω.
fn omega_var<T: Real>(e: &Estimate<T>) -> f64 {
    mean_square(&e.sd_omega)
}

/// Mean per-axis variance of an estimate's Ω′.
fn domega_var<T: Real>(e: &Estimate<T>) -> f64 {
    mean_square(&e.sd_domega)
}

/// The mean of the squares of three deviations.
fn mean_square<T: Real>(sd: &[T; 3]) -> f64 {
    sd.iter().map(|s| s.to_f64() * s.to_f64()).sum::<f64>() / 3.0
}

/// One sample's links of the beam: per kept hypothesis, its predecessor at the previous sample
/// and the option it took there.
#[derive(Clone, Copy, Debug, Default)]
pub struct Links {
    from: [u8; PATH_WIDTH],
    option: [u8; PATH_WIDTH],
    n: u8,
}

/// The beam over one block of samples.
#[derive(Clone, Debug)]
pub struct PathChoice {
    states: [PathState; PATH_WIDTH],
    n: usize,
    jerk: f64,
}

impl PathChoice {
    /// A beam for samples at `rate_hz`, starting from `start` (the state on the chosen path at
    /// the sample before the block, [`PathChoice::follow`]) or, without one, from the first
    /// sample's estimates.
    pub fn new(rate_hz: f64, start: Option<PathState>) -> Self {
        Self::with_jerk(JERK_PER_SAMPLE * rate_hz.max(0.0), start)
    }

    /// [`PathChoice::new`] with a jerk density (rad²/s⁵) of the caller's (probes).
    pub fn with_jerk(jerk: f64, start: Option<PathState>) -> Self {
        let mut states = [PathState::default(); PATH_WIDTH];
        let n = match start {
            Some(s) => {
                states[0] = PathState { cost: 0.0, ..s };
                1
            }
            None => 0,
        };
        PathChoice { states, n, jerk }
    }

    /// One sample: `dt` since the previous one and the estimates it offers (the passes'
    /// outputs, or the sample's roots: at most [`MAX_OPTIONS`], the rest ignored; none: the
    /// sample is skipped, its links empty). Writes the sample's links.
    pub fn step<T: Real>(&mut self, dt: f64, options: &[Estimate<T>], links: &mut Links) {
        let options = &options[..options.len().min(MAX_OPTIONS)];
        if options.is_empty() {
            *links = Links::default();
            return;
        }
        let mut next = [(PathState::default(), 0u8, 0u8); PATH_WIDTH * MAX_OPTIONS];
        let mut m = 0;
        if self.n == 0 {
            for (o, e) in options.iter().enumerate() {
                next[m] = (PathState::at(e), 0, o as u8);
                m += 1;
            }
        }
        for (i, s) in self.states[..self.n].iter().enumerate() {
            for (o, e) in options.iter().enumerate() {
                next[m] = (s.step(dt, self.jerk, e), i as u8, o as u8);
                m += 1;
            }
        }
        let next = &mut next[..m];
        next.sort_unstable_by(|a, b| a.0.cost.total_cmp(&b.0.cost));
        let mut per_option = [0usize; MAX_OPTIONS];
        let mut kept = 0;
        for &(s, from, option) in next.iter() {
            if kept == PATH_WIDTH {
                break;
            }
            let o = usize::from(option);
            if per_option[o] == PER_OPTION {
                continue;
            }
            per_option[o] += 1;
            self.states[kept] = s;
            links.from[kept] = from;
            links.option[kept] = option;
            kept += 1;
        }
        self.n = kept;
        links.n = kept as u8;
        // Costs relative to the best (kept first), so they stay small over any block.
        let base = self.states[0].cost;
        for s in self.states[..kept].iter_mut() {
            s.cost = if s.cost.is_finite() {
                s.cost - base
            } else {
                f64::MAX
            };
        }
    }

    /// The cheapest hypothesis' history: `picks[k]` the option sample `k` of the block (whose
    /// links are `links`, oldest first) takes (0 for a sample skipped).
    pub fn decide(links: &[Links], picks: &mut [u8]) {
        let mut j = 0usize;
        for (l, p) in links.iter().zip(picks.iter_mut()).rev() {
            if l.n == 0 {
                *p = 0;
                continue;
            }
            let j_here = j.min(usize::from(l.n) - 1);
            *p = l.option[j_here];
            j = usize::from(l.from[j_here]);
        }
    }

    /// The state on a decided path after its samples: `taken` the estimates the path took,
    /// oldest first, with their times, continuing `start` (a time and the state there; as for
    /// [`PathChoice::new`]). The next block's beam starts from it so that the path is
    /// continuous across blocks.
    pub fn follow<'a, T: Real + 'a>(
        rate_hz: f64,
        start: Option<(f64, PathState)>,
        taken: impl IntoIterator<Item = (f64, &'a Estimate<T>)>,
    ) -> Option<(f64, PathState)> {
        let jerk = JERK_PER_SAMPLE * rate_hz.max(0.0);
        let mut cur = start;
        for (t, e) in taken {
            cur = Some(match cur {
                Some((t0, s)) => (t, s.step(t - t0, jerk, e)),
                None => (t, PathState::at(e)),
            });
        }
        cur
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sample's estimate: Ω, Ω′ and their deviation.
    fn est(omega: [f64; 3], domega: [f64; 3], sd: f64, sd_d: f64) -> Estimate<f64> {
        Estimate {
            omega,
            domega,
            sd_omega: [sd; 3],
            sd_domega: [sd_d; 3],
            ..Estimate::default()
        }
    }

    /// A deterministic noise in [−1, 1] (no RNG crate in a `no_std` library's tests).
    fn noise(k: usize, axis: usize) -> f64 {
        let x = ((k * 3 + axis) as f64 * 12.9898).sin() * 43_758.545;
        2.0 * (x - x.floor()) - 1.0
    }

    /// The situation after a branch crossing at `tc`: the forward pass holds the true root
    /// before it and a mirror root after it (Ω drifting off at 2 rad/s per s while its Ω′ is
    /// the truth's less that: a slope its own Ω′ does not explain), the backward pass the
    /// reverse. The margins cannot tell them apart; the path takes the truth on every sample
    /// but the few next to the crossing, where the two are within the noise.
    #[test]
    fn the_path_takes_the_pass_that_continues_the_motion() {
        let (rate, tc, n) = (1000.0, 0.5, 1000usize);
        let truth = |t: f64| {
            (
                [2.0 * t.sin(), 1.0 + 0.5 * t, -t * t],
                [2.0 * t.cos(), 0.5, -2.0 * t],
            )
        };
        let mirror = |t: f64| {
            let (w, d) = truth(t);
            let off = 2.0 * (t - tc);
            (
                [w[0] + off, w[1] - off, w[2]],
                [d[0] - 2.0, d[1] + 2.0, d[2]],
            )
        };
        let (sd, sd_d) = (0.004, 0.9);
        let mut beam = PathChoice::new(rate, None);
        let mut links = vec![Links::default(); n];
        let mut truth_is_backward = vec![false; n];
        for k in 0..n {
            let t = k as f64 / rate;
            let noisy = |(w, d): ([f64; 3], [f64; 3])| {
                est(
                    core::array::from_fn(|i| w[i] + sd * noise(k, i)),
                    core::array::from_fn(|i| d[i] + sd_d * noise(k + 7, i)),
                    sd,
                    sd_d,
                )
            };
            let (f, b) = if t < tc {
                (noisy(truth(t)), noisy(mirror(t)))
            } else {
                (noisy(mirror(t)), noisy(truth(t)))
            };
            truth_is_backward[k] = t >= tc;
            beam.step(
                if k == 0 { 0.0 } else { 1.0 / rate },
                &[f, b],
                &mut links[k],
            );
        }
        let mut picks = vec![0u8; n];
        PathChoice::decide(&links, &mut picks);
        let wrong: Vec<usize> = (0..n)
            .filter(|&k| (picks[k] == 1) != truth_is_backward[k])
            .collect();
        // Within 5 ms of the crossing the two roots are within 0.02 rad/s: either will do.
        assert!(
            wrong.iter().all(|&k| (k as f64 / rate - tc).abs() < 0.005),
            "wrong pass at samples {wrong:?}"
        );
    }

    /// Without a choice every sample takes its one option, and degenerate deviations (zero)
    /// give finite costs: the decision is still made; a sample without an option is skipped
    /// and the path goes on through it.
    #[test]
    fn without_a_choice_the_one_option_is_taken() {
        let mut beam = PathChoice::new(100.0, None);
        let mut links = vec![Links::default(); 50];
        for (k, l) in links.iter_mut().enumerate() {
            let e = est([1.0, 0.0, k as f64 * 0.01], [0.0, 0.0, 1.0], 0.0, 0.0);
            if k == 20 {
                beam.step::<f64>(0.01, &[], l);
            } else {
                beam.step(0.01, &[e], l);
            }
        }
        assert!(beam.states[..beam.n].iter().all(|s| s.cost.is_finite()));
        let mut picks = vec![7u8; 50];
        PathChoice::decide(&links, &mut picks);
        assert!(picks.iter().all(|p| *p == 0));
    }

    /// Among four roots at a sample, the path takes the one that continues the motion it came
    /// in with (100 samples where the truth was the only option), not a mirror that leaves it,
    /// a far root that is consistent with itself, or the opposite sign.
    #[test]
    fn among_every_root_the_path_takes_the_one_that_continues_the_motion() {
        let (rate, n) = (1000.0, 600usize);
        let (sd, sd_d) = (0.01, 0.9);
        let mut beam = PathChoice::new(rate, None);
        let mut links = vec![Links::default(); n];
        for (k, l) in links.iter_mut().enumerate() {
            let t = k as f64 / rate;
            // The truth: Ω = (1 + t, 0.5, 0), Ω′ = (1, 0, 0); from 0.1 s three other roots: a
            // mirror drifting away at a slope its own Ω′ does not explain (as after a
            // crossing), a far root at rest, and the truth's opposite sign.
            let w = [1.0 + t, 0.5, 0.0];
            let d = [1.0, 0.0, 0.0];
            let at = |w: [f64; 3], d: [f64; 3], j: usize| {
                est(
                    core::array::from_fn(|i| w[i] + sd * noise(k + 13 * j, i)),
                    core::array::from_fn(|i| d[i] + sd_d * noise(k + 29 * j, i)),
                    sd,
                    sd_d,
                )
            };
            let options = [
                at([w[0] - 3.0 * (t - 0.1), w[1], w[2]], [0.5, 0.0, 0.0], 1),
                at(w, d, 0),
                at([-2.0, 3.0, 1.0], [0.0; 3], 2),
                at(w.map(|v| -v), d, 3),
            ];
            let dt = if k == 0 { 0.0 } else { 1.0 / rate };
            if k < 100 {
                beam.step(dt, &options[1..2], l);
            } else {
                beam.step(dt, &options, l);
            }
        }
        let mut picks = vec![0u8; n];
        PathChoice::decide(&links, &mut picks);
        // Before 0.1 s the truth was the only option (index 0); within 10 ms after it the
        // drifting mirror is within 0.03 rad/s of the truth.
        let wrong: Vec<(usize, u8)> = (0..n)
            .filter(|&k| !(100..110).contains(&k) && picks[k] != u8::from(k >= 100))
            .map(|k| (k, picks[k]))
            .collect();
        assert!(wrong.is_empty(), "wrong root at (sample, option) {wrong:?}");
    }

    /// The state carried across blocks is the filter along the decided path.
    #[test]
    fn following_a_path_continues_its_state() {
        let rows: Vec<(f64, Estimate<f64>)> = (0..200)
            .map(|k| {
                let t = k as f64 * 0.001;
                (t, est([t, 0.0, 0.0], [1.0, 0.0, 0.0], 1e-3, 0.1))
            })
            .collect();
        let (t, s) = PathChoice::follow(1000.0, None, rows.iter().map(|(t, e)| (*t, e))).unwrap();
        assert_eq!(t, rows[199].0);
        assert!((s.omega[0] - rows[199].0).abs() < 1e-3, "{:?}", s.omega);
        assert!((s.domega[0] - 1.0).abs() < 0.05, "{:?}", s.domega);
    }
}
