//! Branch and sign tracking by kinematic consistency (estimator.md, "Branch choice" and "The sign
//! of Ω").
//!
//! Each sample offers a few candidate branches (solutions of the quadratic forms); each branch
//! has its own Ω′ (the linear solve depends on `a`) and an Ω known only up to sign. A signed
//! candidate is a *state*. Along the true branch `dΩ/dt = Ω′`; along a mirror branch it
//! generally is not. Every state carries its own rate filter — Ω predicted by integrating the
//! branch's Ω′ (trapezoidal rule), corrected by the branch's algebraic Ω — and a cumulative cost,
//! the negative log-likelihood of its innovations (a Viterbi recursion over hypotheses):
//!
//! `cost_j(t) = fit_j + min_i [cost_i(t−Δ) + min(|ν_ij|²/S_ij + 3 ln S_ij, STEP_CAP)]`,
//! `ν_ij = Ω_j − (Ω̂_i + ½(Ω′_i + Ω′_j) Δ)`, `S_ij = P_i + q + R_j`.
//!
//! A step cut by the cap from the best hypothesis also starts a fresh one at the candidate
//! (its own Ω and variance, the same cost: `restart` below), so a branch whose history was lost can
//! be picked up again with a filter of its own.
//!
//! Because the filter integrates Ω′ over its whole memory, the innovations of a wrong sign or a
//! mirror branch grow with time instead of being drowned in per-sample noise. Costs are
//! normalised so the best state costs 0; a hypothesis [`COST_CAP`] behind the best is dropped. The output is the cheapest state; the sign
//! is reported unresolved while a state with the same branch and opposite sign is within
//! [`SIGN_MARGIN`].

use crate::linalg::{dot, norm2, scale, sub, Vec3};
use crate::real::Real;

/// Most candidate branches per sample.
pub const MAX_CANDIDATES: usize = 4;
/// Most states (signed candidates).
pub const MAX_STATES: usize = 8;
/// Cap of a state's cost above the best (the memory of the tracker).
pub const COST_CAP: f64 = 200.0;
/// Cap of one step's cost (robustness against a single bad sample).
pub const STEP_CAP: f64 = 60.0;
/// Most hypotheses (histories) kept per output (candidate and sign).
pub const HISTORIES_PER_OUTPUT: usize = 2;
/// Memory of the learnt model error, s (the time constant of its running mean above 100 Hz).
pub const MODEL_ERROR_MEMORY_S: f64 = 1.0;
/// Memory of the learnt model error, samples (what sets it at 100 Hz and below).
pub const MODEL_ERROR_MEMORY_SAMPLES: f64 = 100.0;
/// Cost margin that settles the sign / the branch (≈ 4 σ).
pub const SIGN_MARGIN: f64 = 16.0;

/// A candidate branch at one sample (Ω up to sign).
#[derive(Clone, Copy, Debug, Default)]
pub struct Candidate<T> {
    /// Ω (body frame), either sign.
    pub omega: Vec3<T>,
    /// Variance of one component of this branch's Ω (from its `a` solve).
    pub omega_var: T,
    /// Ω′ of this branch (body frame).
    pub domega: Vec3<T>,
    /// Misfit of this branch to the sample (whitened χ²).
    pub fit: T,
}

/// A signed hypothesis with its own rate filter.
#[derive(Clone, Copy, Debug, Default)]
pub struct State<T> {
    /// Filtered Ω of this hypothesis.
    pub omega: Vec3<T>,
    /// Variance of one component of `omega`.
    pub var: T,
    /// Ω′ of the branch at this sample.
    pub domega: Vec3<T>,
    /// Cumulative cost above the best state.
    pub cost: T,
    /// Candidate index at this sample.
    pub candidate: u8,
    /// +1 or −1: the sign applied to the candidate's Ω.
    pub sign: i8,
    /// Index of the predecessor state at the previous sample (`u8::MAX`: none).
    pub from: u8,
}

/// The sign of each output of a candidate: `Ω`, then `−Ω`.
const SIGNS: [i8; 2] = [1, -1];

impl<T: Real> State<T> {
    /// Copies `src` field by field. Measured: with a whole-struct assignment instead, the
    /// per-sample estimate takes ~90 instructions more on the Cortex-M4F (`cargo qemu-bench`,
    /// flashed profile, mean: model F 4 030 vs 3 939, over the 4 000 budget; G 3 785 vs 3 694).
    #[inline(always)]
    fn set(&mut self, src: &State<T>) {
        let State {
            omega,
            var,
            domega,
            cost,
            candidate,
            sign,
            from,
        } = *src;
        let [w0, w1, w2] = omega;
        let [d0, d1, d2] = domega;
        self.omega[0] = w0;
        self.omega[1] = w1;
        self.omega[2] = w2;
        self.var = var;
        self.domega[0] = d0;
        self.domega[1] = d1;
        self.domega[2] = d2;
        self.cost = cost;
        self.candidate = candidate;
        self.sign = sign;
        self.from = from;
    }
}

/// The result of one tracker step.
#[derive(Clone, Copy, Debug)]
pub struct Choice<T> {
    /// Index of the chosen state.
    pub state: usize,
    /// Index of the chosen candidate.
    pub candidate: usize,
    /// Signed algebraic Ω of the chosen state (the candidate's Ω with the state's sign).
    pub omega: Vec3<T>,
    /// Filtered Ω of the chosen state and its per-component variance.
    pub filtered: (Vec3<T>, T),
    /// The sign is not settled.
    pub sign_unresolved: bool,
    /// Another branch is nearly as good.
    pub branch_ambiguous: bool,
    /// Cost of the cheapest hypothesis on another branch above the chosen one (twice the
    /// negative log-likelihood ratio); [`COST_CAP`] when none is left in the tracker's memory.
    /// Below [`SIGN_MARGIN`] the branch is ambiguous.
    pub branch_margin: T,
}

/// The multi-hypothesis branch and sign tracker.
#[derive(Clone, Debug)]
pub struct Tracker<T> {
    /// Two state buffers: the current one and the one the next step writes.
    buf: [[State<T>; MAX_STATES]; 2],
    cur: usize,
    n: usize,
    best: usize,
    /// Running variance of the trapezoidal model error per step (jerk, sampling), learnt from
    /// the chosen hypothesis' innovations.
    model_var: T,
    /// Working storage of [`Tracker::step`] (not zeroed per step; written before read): the
    /// kept histories of one output and each new state's model-error sample.
    top: [[(State<T>, T); HISTORIES_PER_OUTPUT]; 2],
    innov: [T; MAX_STATES],
}

impl<T: Real> Default for Tracker<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real> Tracker<T> {
    /// A tracker with no history.
    pub fn new() -> Self {
        Tracker {
            buf: [[State::default(); MAX_STATES]; 2],
            cur: 0,
            n: 0,
            best: 0,
            model_var: T::ZERO,
            top: [[(State::default(), T::ZERO); HISTORIES_PER_OUTPUT]; 2],
            innov: [T::ZERO; MAX_STATES],
        }
    }

    /// Adds a hypothesis at both signs of every candidate of the last step (`cands`, as given
    /// to it) that no hypothesis holds yet (the same output, Ω within their deviations), each
    /// as a restart would start it (see [`restart`]): its own Ω and variance, [`STEP_CAP`]
    /// behind the best (and its fit's excess over the best's), into a free slot or in place of
    /// the costliest hypothesis if cheaper. For a tracker none of whose hypotheses is a
    /// consistent path (the estimator's lock monitor says when): restarts are otherwise made
    /// only along the best hypothesis' prediction, so a sign that every hypothesis lost would
    /// never be tried again. Out of line, outside [`Tracker::step`]: the per-sample path pays
    /// nothing for it.
    #[inline(never)]
    pub fn reopen(&mut self, cands: &[Candidate<T>]) {
        let (next, mut nn, best) = (&mut self.buf[self.cur], self.n, self.best);
        if nn == 0 {
            return;
        }
        let best_fit = cands
            .get(usize::from(next[best].candidate))
            .map_or(T::ZERO, |c| c.fit);
        for (ci, c) in cands.iter().enumerate().take(MAX_CANDIDATES) {
            let r = c.omega_var.max(T::of(1e-30));
            let cost = T::of(STEP_CAP) + (c.fit - best_fit).max(T::ZERO);
            for sign in SIGNS {
                let omega = scale(T::of(f64::from(sign)), &c.omega);
                let held = next[..nn].iter().any(|s| {
                    usize::from(s.candidate) == ci && s.sign == sign && same_history(s, &omega, r)
                });
                if held {
                    continue;
                }
                let slot = if nn < MAX_STATES {
                    nn += 1;
                    nn - 1
                } else {
                    let costliest =
                        (0..nn)
                            .filter(|&j| j != best)
                            .fold(None, |w: Option<usize>, j| match w {
                                Some(w) if next[w].cost >= next[j].cost => Some(w),
                                _ => Some(j),
                            });
                    match costliest {
                        Some(w) if cost < next[w].cost => w,
                        _ => continue,
                    }
                };
                next[slot].set(&State {
                    omega,
                    var: r,
                    domega: c.domega,
                    cost,
                    candidate: ci as u8,
                    sign,
                    from: next[best].from,
                });
            }
        }
        self.n = nn;
    }

    /// Forgets the history.
    pub fn reset(&mut self) {
        self.n = 0;
        self.model_var = T::ZERO;
    }

    /// True once a step has been taken.
    pub fn has_history(&self) -> bool {
        self.n > 0
    }

    /// The states after the last step.
    pub fn states(&self) -> &[State<T>] {
        &self.buf[self.cur][..self.n]
    }

    /// The chosen state's filtered Ω propagated by `dt` (the prediction), if any.
    pub fn predicted_omega(&self, dt: T) -> Option<Vec3<T>> {
        (self.n > 0).then(|| propagate(&self.buf[self.cur][self.best], dt))
    }

    /// Every distinct predicted Ω (one per surviving branch, sign dropped), cheapest first, for
    /// starting the `a` search (m > 3).
    pub fn predictions(&self, dt: T, out: &mut [Vec3<T>; MAX_CANDIDATES]) -> usize {
        let states = &self.buf[self.cur];
        let mut order = [0usize; MAX_STATES];
        for (i, o) in order.iter_mut().enumerate().take(self.n) {
            *o = i;
        }
        for i in 1..self.n {
            let mut j = i;
            while j > 0 && states[order[j]].cost < states[order[j - 1]].cost {
                order.swap(j, j - 1);
                j -= 1;
            }
        }
        let mut k = 0;
        for &i in order.iter().take(self.n) {
            let s = &states[i];
            if s.cost > T::of(COST_CAP * 0.5) {
                continue;
            }
            let p = propagate(s, dt);
            let tol = T::of(1e-4) * norm2(&p).max(T::of(1e-12));
            let dup = out[..k]
                .iter()
                .any(|q| norm2(&sub(&p, q)) < tol || norm2(&crate::linalg::add(&p, q)) < tol);
            if !dup && k < MAX_CANDIDATES {
                out[k] = p;
                k += 1;
            }
        }
        k
    }

    /// Variance of the trapezoidal model error learnt so far.
    pub fn model_variance(&self) -> T {
        self.model_var
    }

    /// One step: `cands` are this sample's branches; `dt` the time since the previous step;
    /// `domega_var` the variance of one component of Ω′; `hint` an approximate Ω with its
    /// variance (used only without history); `histories` how many histories to keep per output
    /// (1 ..= [`HISTORIES_PER_OUTPUT`]: 2 where branches can merge, i.e. m = 3 in model F).
    ///
    /// For every output (candidate and sign) the two cheapest continuations of distinct
    /// histories survive (two continuations are the same history when their filtered Ω agree
    /// to within their deviation), so hypotheses outlive samples where branches merge or only
    /// the least-squares fallback exists; at most [`MAX_STATES`] overall, the cheapest.
    #[inline(never)]
    pub fn step(
        &mut self,
        cands: &[Candidate<T>],
        dt: T,
        domega_var: T,
        hint: Option<(Vec3<T>, T)>,
        histories: usize,
    ) -> Option<Choice<T>> {
        let histories = histories.clamp(1, HISTORIES_PER_OUTPUT);
        let nc = cands.len().min(MAX_CANDIDATES);
        if nc == 0 {
            return None;
        }
        let cap = T::of(COST_CAP);
        let step_cap = T::of(STEP_CAP);
        let half_dt = T::of(0.5) * dt;
        let q = half_dt * half_dt * T::of(2.0) * domega_var + self.model_var;
        let three = T::of(3.0);
        let top = &mut self.top;
        let innov = &mut self.innov;
        let (lo, hi) = self.buf.split_at_mut(1);
        let (prev, next) = if self.cur == 0 {
            (&lo[0], &mut hi[0])
        } else {
            (&hi[0], &mut lo[0])
        };
        let np = self.n;
        let self_best = self.best;
        let mut nn = 0usize;
        let model_var = self.model_var;
        for (ci, c) in cands.iter().enumerate().take(nc) {
            let r = c.omega_var.max(T::of(1e-30));
            // The two outputs of this candidate: Ω with either sign.
            let zs = [c.omega, scale(-T::ONE, &c.omega)];
            // The cheapest distinct histories of each output, `top[sign][..nt[sign]]`:
            // (state, model-error sample).
            let mut nt = [0usize; 2];
            // The best predecessor's prediction, innovation variance and cost before the
            // innovation term, kept for the restart test below.
            let (mut best_pred, mut best_sv, mut best_base) = ([T::ZERO; 3], T::ONE, T::ZERO);
            if np == 0 {
                for (si, z) in zs.iter().enumerate() {
                    let mut cost = c.fit;
                    if let Some((h, var)) = hint {
                        cost += (norm2(&sub(z, &h)) / var.max(T::of(1e-30))).min(cap);
                    }
                    top[si][0] = (
                        State {
                            omega: *z,
                            var: r,
                            domega: c.domega,
                            cost,
                            candidate: ci as u8,
                            sign: SIGNS[si],
                            from: u8::MAX,
                        },
                        T::ZERO,
                    );
                    nt[si] = 1;
                }
            }
            for (i, s) in prev.iter().enumerate().take(np) {
                // Shared by both signs: the prediction, its variance, the gain, the log term.
                let mut pred = [T::ZERO; 3];
                for k in 0..3 {
                    pred[k] = s.omega[k] + half_dt * (s.domega[k] + c.domega[k]);
                }
                let pvar = s.var + q;
                let sv = pvar + r;
                let inv_sv = T::ONE / sv;
                let base = s.cost + c.fit + three * sv.ln_approx();
                if i == self_best {
                    (best_pred, best_sv, best_base) = (pred, sv, base);
                }
                let gain = pvar * inv_sv;
                for (si, z) in zs.iter().enumerate() {
                    let nu = sub(z, &pred);
                    let nu2 = norm2(&nu);
                    let cost = base + (nu2 * inv_sv).min(step_cap);
                    let kept = &mut top[si];
                    let n = &mut nt[si];
                    if *n == histories && cost >= kept[*n - 1].0.cost {
                        continue;
                    }
                    let st = State {
                        omega: [
                            pred[0] + gain * nu[0],
                            pred[1] + gain * nu[1],
                            pred[2] + gain * nu[2],
                        ],
                        var: (T::ONE - gain) * pvar,
                        domega: c.domega,
                        cost,
                        candidate: ci as u8,
                        sign: SIGNS[si],
                        from: i as u8,
                    };
                    // Innovation variance not explained by the filter, the measurement and the
                    // Ω′ noise: an unbiased sample of the model error (the learnt part of q is
                    // not subtracted, so the running mean converges to it).
                    let entry = (st, nu2 / three - (sv - model_var));
                    // Same history as a kept one? Keep the cheaper.
                    if let Some(j) = (0..*n).find(|&j| same_history(&kept[j].0, &st.omega, st.var))
                    {
                        if cost < kept[j].0.cost {
                            kept[j] = entry;
                        }
                    } else if *n < histories {
                        kept[*n] = entry;
                        *n += 1;
                    } else {
                        kept[*n - 1] = entry;
                    }
                    if *n == 2 && kept[1].0.cost < kept[0].0.cost {
                        kept.swap(0, 1);
                    }
                }
            }
            if np > 0 {
                // The restart test, from the best hypothesis (see `restart`): only the output
                // that points along the prediction can restart, and only beyond the cap.
                let along = dot(&c.omega, &best_pred);
                let nu2 = norm2(&c.omega) + norm2(&best_pred) - T::of(2.0) * along.abs();
                if nu2 > step_cap * best_sv {
                    let si = if along >= T::ZERO { 0 } else { 1 };
                    let cost = best_base + step_cap;
                    restart(
                        (c, ci),
                        (si, self_best, cost),
                        &mut top[si],
                        &mut nt[si],
                        histories,
                    );
                }
            }
            for (si, kept) in top.iter().enumerate() {
                for (st, ex) in kept.iter().take(nt[si]) {
                    if !st.cost.is_finite() {
                        continue;
                    }
                    let slot = if nn < MAX_STATES {
                        nn += 1;
                        nn - 1
                    } else {
                        let mut worst = 0;
                        for j in 1..nn {
                            if next[j].cost > next[worst].cost {
                                worst = j;
                            }
                        }
                        if st.cost >= next[worst].cost {
                            continue;
                        }
                        worst
                    };
                    next[slot].set(st);
                    innov[slot] = *ex;
                }
            }
        }
        if nn == 0 {
            return None;
        }
        let mut best = 0;
        for j in 1..nn {
            if next[j].cost < next[best].cost {
                best = j;
            }
        }
        // Normalise; drop hypotheses that fell COST_CAP behind (dead); the margin of the
        // cheapest surviving hypothesis on another branch.
        let base = next[best].cost;
        let best_candidate = next[best].candidate;
        let mut branch_margin = cap;
        let mut kept = 0;
        for j in 0..nn {
            next[j].cost -= base;
            if next[j].cost < cap || j == best {
                if next[j].candidate != best_candidate {
                    branch_margin = branch_margin.min(next[j].cost);
                }
                if j != kept {
                    let src = next[j];
                    next[kept].set(&src);
                    innov[kept] = innov[j];
                }
                if j == best {
                    best = kept;
                }
                kept += 1;
            }
        }
        let nn = kept;
        // Learn the model error along the chosen hypothesis (bounded influence per sample).
        if np > 0 {
            // Per-sample samples may be negative (no clamp: clamping would bias the mean up);
            // bounded influence above; the running mean is kept non-negative.
            let e = innov[best].min(T::of(25.0) * (q + next[best].var));
            // A running mean over at least MODEL_ERROR_MEMORY_SAMPLES innovations and at least
            // MODEL_ERROR_MEMORY_S: with a memory of samples alone a 1–4 kHz tracker followed
            // its innovations' noise and learnt a mirror branch's inconsistency as model error
            // within 25 ms (docs/branch-lock.md).
            let alpha =
                (dt / T::of(MODEL_ERROR_MEMORY_S)).min(T::ONE / T::of(MODEL_ERROR_MEMORY_SAMPLES));
            self.model_var = (self.model_var + alpha * (e - self.model_var)).max(T::ZERO);
        }
        let margin = T::of(SIGN_MARGIN);
        let b = next[best];
        let mut sign_unresolved = false;
        for (j, s) in next.iter().enumerate().take(nn) {
            if j != best && s.cost < margin && s.candidate == b.candidate && s.sign != b.sign {
                sign_unresolved = true;
            }
        }
        let branch_ambiguous = branch_margin < margin;
        self.cur ^= 1;
        self.n = nn;
        self.best = best;
        let omega = cands[b.candidate as usize].omega;
        Some(Choice {
            state: best,
            candidate: b.candidate as usize,
            omega: if b.sign > 0 {
                omega
            } else {
                scale(-T::ONE, &omega)
            },
            filtered: (b.omega, b.var),
            sign_unresolved,
            branch_ambiguous,
            branch_margin,
        })
    }
}

/// Where a candidate's output is beyond the cap from the best hypothesis of the previous step,
/// also the hypothesis that restarts there. Such a sample is either a wild one in the continued
/// history (which [`Tracker::step`] keeps: robust) or a branch that history's filter was never
/// on: continued, its filter memory would hold the hypothesis off its own branch for good (at
/// 1 kHz the nine-channel tumble lost the true branch that way: docs/branch-lock.md). The
/// restart starts at the candidate with its own variance, at the continuation's capped cost;
/// only from the best hypothesis (from any other it would cost more and start the same), and
/// not for an output pointing against the prediction (the other sign: no rate turns over in
/// one step). Out of line, after the continuations: the per-sample path stays as it was. Its
/// insertion repeats the one inlined in [`Tracker::step`] on purpose: one loop over both
/// (continuation, then restart) cost +170 instructions per sample on the Cortex-M4F; this, with
/// the test reusing the best predecessor's prediction and the model error's time-based memory,
/// +44 (`cargo qemu-bench`, flashed profile: 3 744 / 3 925 against 3 700 / 3 881).
#[inline(never)]
fn restart<T: Real>(
    (c, ci): (&Candidate<T>, usize),
    (si, from, cost): (usize, usize, T),
    kept: &mut [(State<T>, T); HISTORIES_PER_OUTPUT],
    n: &mut usize,
    histories: usize,
) {
    let st = State {
        omega: scale(T::of(SIGNS[si] as f64), &c.omega),
        var: c.omega_var.max(T::of(1e-30)),
        domega: c.domega,
        cost,
        candidate: ci as u8,
        sign: SIGNS[si],
        from: from as u8,
    };
    let same = kept[..*n]
        .iter()
        .position(|k| same_history(&k.0, &st.omega, st.var));
    match same {
        Some(j) if cost < kept[j].0.cost => kept[j] = (st, T::ZERO),
        Some(_) => {}
        None if *n < histories => {
            kept[*n] = (st, T::ZERO);
            *n += 1;
        }
        None if cost < kept[*n - 1].0.cost => kept[*n - 1] = (st, T::ZERO),
        None => {}
    }
    if *n == 2 && kept[1].0.cost < kept[0].0.cost {
        kept.swap(0, 1);
    }
}

/// Whether a hypothesis at `omega` with variance `var` continues the same history as `s`:
/// their filtered Ω agree to within half their combined deviation.
#[inline(always)]
fn same_history<T: Real>(s: &State<T>, omega: &Vec3<T>, var: T) -> bool {
    norm2(&sub(&s.omega, omega)) <= T::of(0.25) * (s.var + var)
}

fn propagate<T: Real>(s: &State<T>, dt: T) -> Vec3<T> {
    [
        s.omega[0] + s.domega[0] * dt,
        s.omega[1] + s.domega[1] * dt,
        s.omega[2] + s.domega[2] * dt,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f64 = 0.01;

    /// A rate that changes in every component, and its derivative.
    fn truth(t: f64) -> (Vec3<f64>, Vec3<f64>) {
        (
            [1.0 + 0.5 * t.sin(), 0.8 * (0.7 * t).cos(), 0.3 + 0.2 * t],
            [0.5 * t.cos(), -0.56 * (0.7 * t).sin(), 0.2],
        )
    }

    fn cand(omega: Vec3<f64>, domega: Vec3<f64>) -> Candidate<f64> {
        Candidate {
            omega,
            omega_var: 1e-4,
            domega,
            fit: 0.0,
        }
    }

    fn dist(a: &Vec3<f64>, b: &Vec3<f64>) -> f64 {
        norm2(&sub(a, b)).sqrt()
    }

    /// A mirror branch: the true Ω′ (the linear solve gives nearly the same Ω′ on both) with an
    /// Ω that does not integrate it. The tracker must follow the branch along which
    /// dΩ/dt = Ω′, whatever the candidates' order, and settle the sign it makes consistent.
    #[test]
    fn follows_the_kinematically_consistent_branch_and_settles_its_sign() {
        let mut tr = Tracker::<f64>::new();
        let mut last = None;
        for k in 0..400 {
            let t = k as f64 * DT;
            let (w, dw) = truth(t);
            let mirror = [w[1], -w[0], 0.5 * w[2]];
            let true_first = k % 2 == 0;
            let cands = if true_first {
                [cand(w, dw), cand(mirror, dw)]
            } else {
                [cand(mirror, dw), cand(w, dw)]
            };
            let c = tr.step(&cands, DT, 1e-6, None, 1).expect("a choice");
            last = Some((c, true_first, w));
        }
        let (c, true_first, w) = last.unwrap();
        assert_eq!(c.candidate, if true_first { 0 } else { 1 });
        assert!(
            c.branch_margin >= SIGN_MARGIN && !c.branch_ambiguous,
            "{}",
            c.branch_margin
        );
        assert!(!c.sign_unresolved, "Ω′ ≠ 0 tells the signs apart");
        assert!(dist(&c.omega, &w) < 1e-6, "{:?} vs {w:?}", c.omega);
        assert!(dist(&c.filtered.0, &w) < 1e-2, "{:?}", c.filtered.0);
    }

    /// Two branches that both integrate their Ω′ (a copy of the truth shifted by a constant):
    /// no record can tell them apart, so the margin stays below [`SIGN_MARGIN`] and the branch
    /// is flagged ambiguous at every step; the margin is the cost of the other branch's best
    /// hypothesis, never negative.
    #[test]
    fn equally_consistent_branches_are_ambiguous_with_their_margin() {
        let mut tr = Tracker::<f64>::new();
        let hint = truth(0.0).0;
        for k in 0..400 {
            let t = k as f64 * DT;
            let (w, dw) = truth(t);
            let shifted = [w[0] + 0.5, w[1] - 0.3, w[2] + 0.2];
            let h = (k == 0).then_some((hint, 1.0));
            let c = tr
                .step(&[cand(w, dw), cand(shifted, dw)], DT, 1e-6, h, 1)
                .unwrap();
            assert!(
                c.branch_margin >= 0.0 && c.branch_margin < SIGN_MARGIN,
                "step {k}"
            );
            assert!(c.branch_ambiguous, "step {k}");
        }
    }

    /// In a steady spin (Ω′ = 0) nothing distinguishes Ω from −Ω: the sign is reported
    /// unresolved however long the record; a hint at the first sample settles it.
    #[test]
    fn sign_is_unresolved_in_a_steady_spin_until_a_hint_settles_it() {
        let w = [0.0, 0.3, 2.0];
        let mut tr = Tracker::<f64>::new();
        for _ in 0..300 {
            let c = tr.step(&[cand(w, [0.0; 3])], DT, 1e-6, None, 1).unwrap();
            assert!(c.sign_unresolved);
        }
        let hint = [0.1, 0.2, 1.8];
        let hint_var = 0.0625 * norm2(&hint) + 0.01;
        let mut tr = Tracker::<f64>::new();
        for k in 0..300 {
            let h = (k == 0).then_some((hint, hint_var));
            let c = tr.step(&[cand(w, [0.0; 3])], DT, 1e-6, h, 1).unwrap();
            assert!(!c.sign_unresolved, "step {k}");
            assert!(dist(&c.omega, &w) < 1e-9, "step {k}: {:?}", c.omega);
        }
    }

    /// Where two branches merge (model F, m = 3: the closed form offers one root for both) and
    /// separate again, the tracker stays on the true one — with the mirror offered first and
    /// nearest the prediction at the first samples after. (It passes with one history per
    /// output too: here the true history is the cheaper one at the merge. The case the second
    /// history exists for is covered end to end by the 9-channel cases of `tests/`.)
    #[test]
    fn stays_on_the_true_branch_after_a_merge() {
        let t0 = 2.0;
        let mut tr = Tracker::<f64>::new();
        let hint = truth(0.0).0;
        for k in 0..500 {
            let t = k as f64 * DT;
            let (w, dw) = truth(t);
            let s = (t - t0) * (t - t0);
            let mirror = [w[0] + 0.8 * s, w[1] - 0.5 * s, w[2] + 0.3 * s];
            let merged = (t - t0).abs() < 0.05;
            let h = (k == 0).then_some((hint, 0.01));
            let c = if merged {
                tr.step(&[cand(w, dw)], DT, 1e-6, h, 2)
            } else {
                tr.step(&[cand(mirror, dw), cand(w, dw)], DT, 1e-6, h, 2)
            }
            .unwrap();
            if t > t0 + 0.5 {
                assert_eq!(c.candidate, 1, "t = {t}: on the mirror branch");
                assert!(dist(&c.omega, &w) < 1e-9);
                assert!(!c.sign_unresolved && !c.branch_ambiguous, "t = {t}");
            }
        }
    }

    /// A tracker whose every hypothesis holds the wrong sign (here: started by a wrong hint)
    /// never starts the other sign by itself — restarts are made only along the prediction —
    /// although the sign it holds does not integrate Ω′. Re-opened, it starts both signs of
    /// every candidate and the evidence moves it to the consistent one within 0.5 s.
    #[test]
    fn reopened_it_finds_the_sign_no_hypothesis_held() {
        for reopen in [false, true] {
            let mut tr = Tracker::<f64>::new();
            let wrong = scale(-1.0, &truth(0.0).0);
            let mut on_truth_after = None;
            for k in 0..300 {
                let t = k as f64 * DT;
                let (w, dw) = truth(t);
                let h = (k == 0).then_some((wrong, 0.01));
                let cands = [cand(w, dw)];
                let c = tr.step(&cands, DT, 1e-6, h, 2).unwrap();
                if reopen && k == 100 {
                    tr.reopen(&cands);
                }
                let right = dist(&c.omega, &w) < 1e-9;
                if k < 100 {
                    assert!(!right, "step {k}: the wrong hint's sign is held");
                }
                if right && on_truth_after.is_none() {
                    on_truth_after = Some(k);
                }
                if !right {
                    on_truth_after = None;
                }
            }
            match (reopen, on_truth_after) {
                (false, found) => assert_eq!(found, None, "never re-opened"),
                (true, Some(k)) => assert!(k < 150, "on the consistent sign from step {k}"),
                (true, None) => panic!("re-opened, the consistent sign was not found"),
            }
        }
    }

    /// The cost of a hypothesis is capped: a single wild sample on the true branch costs at
    /// most `STEP_CAP` and does not hand the output to the mirror for good.
    #[test]
    fn one_wild_sample_does_not_lose_lock() {
        let mut tr = Tracker::<f64>::new();
        let hint = truth(0.0).0;
        for k in 0..400 {
            let t = k as f64 * DT;
            let (w, dw) = truth(t);
            let mirror = [w[1], -w[0], 0.5 * w[2]];
            let shown = if k == 200 {
                [w[0] + 3.0, w[1], w[2]]
            } else {
                w
            };
            let h = (k == 0).then_some((hint, 0.01));
            let c = tr
                .step(&[cand(shown, dw), cand(mirror, dw)], DT, 1e-6, h, 1)
                .unwrap();
            if k > 210 {
                assert_eq!(c.candidate, 0, "step {k}");
            }
        }
    }
}
