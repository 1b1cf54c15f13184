//! Branch and sign tracking by kinematic consistency (estimator.md, "Branch choice" and "The sign
//! of Ω").
//!
//! Each sample offers a few candidate branches (solutions of the quadratic forms); each branch
//! has its own Ω′ (the linear solve depends on `a`) and an Ω known only up to sign. A signed
//! candidate is a *state*. Along the true branch `Ω(t+Δ) − Ω(t) = ∫Ω′`; along a mirror branch
//! it generally is not. The tracker keeps every state alive with a cumulative cost (a Viterbi
//! recursion over the short history):
//!
//! `cost_j(t) = fit_j + min_i [cost_i(t−Δ) + min(c_ij, STEP_CAP)]`,
//! `c_ij = |Ω_j − Ω_i − ½(Ω′_i + Ω′_j) Δ|² / s²`,
//!
//! normalised so the best state costs 0 and capped at [`COST_CAP`] (a rejected hypothesis can
//! come back after `COST_CAP` of contrary evidence — the "window"). The output is the cheapest
//! state; the sign is reported unresolved while the state with the same branch and opposite
//! sign is within [`SIGN_MARGIN`].

use crate::linalg::{norm2, scale, sub, Vec3};
use crate::real::Real;

/// Most candidate branches per sample.
pub const MAX_CANDIDATES: usize = 6;
/// Most states (signed candidates).
pub const MAX_STATES: usize = 2 * MAX_CANDIDATES;
/// Cap of a state's cost above the best (the memory of the tracker).
pub const COST_CAP: f64 = 200.0;
/// Cap of one step's kinematic cost (robustness against a single bad sample).
pub const STEP_CAP: f64 = 60.0;
/// Cost margin that settles the sign / the branch (≈ 4 σ).
pub const SIGN_MARGIN: f64 = 16.0;

/// A candidate branch at one sample (Ω up to sign).
#[derive(Clone, Copy, Debug, Default)]
pub struct Candidate<T> {
    /// Ω (body frame), either sign.
    pub omega: Vec3<T>,
    /// Ω′ of this branch (body frame).
    pub domega: Vec3<T>,
    /// Misfit of this branch to the sample (whitened χ²).
    pub fit: T,
}

#[derive(Clone, Copy, Debug, Default)]
struct State<T> {
    omega: Vec3<T>,
    domega: Vec3<T>,
    cost: T,
    candidate: u8,
}

/// The result of one tracker step.
#[derive(Clone, Copy, Debug)]
pub struct Choice<T> {
    /// Index of the chosen candidate.
    pub candidate: usize,
    /// Signed Ω of the chosen state.
    pub omega: Vec3<T>,
    /// The sign is not settled.
    pub sign_unresolved: bool,
    /// Another branch is nearly as good.
    pub branch_ambiguous: bool,
}

/// The multi-hypothesis branch and sign tracker.
#[derive(Clone, Debug)]
pub struct Tracker<T> {
    states: [State<T>; MAX_STATES],
    n: usize,
    best: usize,
    /// Running mean of the chosen path's squared kinematic residual per component (model error
    /// of the trapezoidal rule: jerk, sampling).
    model_var: T,
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
            states: [State::default(); MAX_STATES],
            n: 0,
            best: 0,
            model_var: T::ZERO,
        }
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

    /// The chosen state's Ω and Ω′ propagated by `dt` (the prediction), if any.
    pub fn predicted_omega(&self, dt: T) -> Option<Vec3<T>> {
        (self.n > 0).then(|| {
            let s = &self.states[self.best];
            [
                s.omega[0] + s.domega[0] * dt,
                s.omega[1] + s.domega[1] * dt,
                s.omega[2] + s.domega[2] * dt,
            ]
        })
    }

    /// Every distinct predicted Ω (one per surviving branch, sign dropped), cheapest first, for
    /// starting the `a` search (m > 3).
    pub fn predictions(&self, dt: T, out: &mut [Vec3<T>; MAX_CANDIDATES]) -> usize {
        let mut k = 0;
        let mut order = [0usize; MAX_STATES];
        for (i, o) in order.iter_mut().enumerate().take(self.n) {
            *o = i;
        }
        // Insertion sort by cost (n ≤ 12).
        for i in 1..self.n {
            let mut j = i;
            while j > 0 && self.states[order[j]].cost < self.states[order[j - 1]].cost {
                order.swap(j, j - 1);
                j -= 1;
            }
        }
        for &i in order.iter().take(self.n) {
            let s = &self.states[i];
            if s.cost > T::of(COST_CAP * 0.5) {
                continue;
            }
            let p = [
                s.omega[0] + s.domega[0] * dt,
                s.omega[1] + s.domega[1] * dt,
                s.omega[2] + s.domega[2] * dt,
            ];
            let dup = out[..k].iter().any(|q| {
                let tol = T::of(1e-4) * norm2(&p).max(T::of(1e-12));
                norm2(&sub(&p, q)) < tol || norm2(&crate::linalg::add(&p, q)) < tol
            });
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
    /// `step_var` the variance `s²` of one component of the kinematic residual from noise;
    /// `hint` an approximate Ω with its variance (used only without history).
    pub fn step(
        &mut self,
        cands: &[Candidate<T>],
        dt: T,
        step_var: T,
        hint: Option<(Vec3<T>, T)>,
    ) -> Option<Choice<T>> {
        let nc = cands.len().min(MAX_CANDIDATES);
        if nc == 0 {
            return None;
        }
        let cap = T::of(COST_CAP);
        let step_cap = T::of(STEP_CAP);
        let s2 = (step_var + self.model_var).max(T::of(1e-30));
        let inv_s2 = T::ONE / s2;
        let half_dt = T::of(0.5) * dt;
        let mut next = [State::<T>::default(); MAX_STATES];
        let mut from = [usize::MAX; MAX_STATES];
        let mut nn = 0;
        for (ci, c) in cands.iter().enumerate().take(nc) {
            for sign in [T::ONE, -T::ONE] {
                let omega = scale(sign, &c.omega);
                let mut cost = c.fit;
                if self.n > 0 {
                    let mut best = cap * T::of(4.0);
                    let mut arg = usize::MAX;
                    for (i, s) in self.states.iter().enumerate().take(self.n) {
                        let mut r = [T::ZERO; 3];
                        for k in 0..3 {
                            r[k] = omega[k] - s.omega[k] - half_dt * (s.domega[k] + c.domega[k]);
                        }
                        let trans = (norm2(&r) * inv_s2).min(step_cap);
                        let total = s.cost + trans;
                        if total < best {
                            best = total;
                            arg = i;
                        }
                    }
                    cost += best;
                    from[nn] = arg;
                } else if let Some((h, var)) = hint {
                    let d = norm2(&sub(&omega, &h)) / var.max(T::of(1e-30));
                    cost += d.min(cap);
                }
                next[nn] = State {
                    omega,
                    domega: c.domega,
                    cost,
                    candidate: ci as u8,
                };
                nn += 1;
            }
        }
        // Normalise and cap.
        let mut best = 0;
        for j in 1..nn {
            if next[j].cost < next[best].cost {
                best = j;
            }
        }
        let base = next[best].cost;
        for s in next.iter_mut().take(nn) {
            s.cost = (s.cost - base).min(cap);
            if !s.cost.is_finite() {
                s.cost = cap;
            }
        }
        // Learn the model error along the chosen path.
        if self.n > 0 && from[best] != usize::MAX {
            let p = &self.states[from[best]];
            let c = &next[best];
            let mut r2 = T::ZERO;
            for k in 0..3 {
                r2 += (c.omega[k] - p.omega[k] - half_dt * (p.domega[k] + c.domega[k])).sq();
            }
            let excess = (r2 / T::of(3.0) - step_var).max(T::ZERO);
            // Bounded influence of one sample: at most 25 s² per update.
            let excess = excess.min(T::of(25.0) * s2);
            self.model_var += T::of(0.02) * (excess - self.model_var);
        }
        let margin = T::of(SIGN_MARGIN);
        let mirror = best ^ 1; // states are pushed in (+, −) pairs per candidate
        let sign_unresolved = next[mirror].cost < margin;
        let branch_ambiguous = (0..nn).any(|j| j / 2 != best / 2 && next[j].cost < margin);
        self.states = next;
        self.n = nn;
        self.best = best;
        Some(Choice {
            candidate: next[best].candidate as usize,
            omega: next[best].omega,
            sign_unresolved,
            branch_ambiguous,
        })
    }
}
