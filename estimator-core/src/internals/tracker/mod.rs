//! Branch and sign: one multiple-hypothesis kinematic filter (estimator.md, "Branch choice" and
//! "The sign of Ω"; docs/branch-lock.md).
//!
//! Each sample's readings are met by several values of Ω (roots of the quadratic forms, either
//! sign); along the true one `dΩ/dt = Ω′`, along a mirror root or the wrong sign it is not. So
//! the filter keeps a few *tracks*, each a Kalman filter of the state (Ω, Ω′) on a white-jerk
//! model — `Ω̇ = Ω′`, `Ω̇′ = j`, `j` white with the density
//! [`Options::jerk_density`](crate::Options) (rad²/s⁵: a property of the motion, the same at
//! every sample rate) — with its full 6 × 6 covariance (blocks Ω–Ω, Ω–Ω′, Ω′–Ω′), and a cost:
//! twice its negative log-likelihood over time (a bank of filters scored by their likelihood,
//! the multiple-model filter of the accelerometer-only navigation literature that carries Ω as
//! a state; Nilsson & Skog 2016 review them).
//!
//! **Measurements.** In model F a track is updated by the readings themselves, linearised at
//! its own prediction (an extended Kalman filter): the `m` null-space equations
//! `pₖ = Ωᵀ Mₖ Ω + e` (whitened: unit noise) and the linear solve's Ω′ rows
//! `y = Ω′ + [Ωᵀ Tⱼ Ω]ⱼ + e` ([`Readings`]). Every track explains the same measurements, so
//! their costs compare; near a crossing, where the roots' first-order deviations do not hold,
//! the readings simply say little and the track holds to its own motion. In model G (one root,
//! either sign, A linear in the readings) a track takes the signed root nearest its prediction
//! with the root's variances. Each step's normalised innovation counts in full up to the gate
//! [`STEP_CAP`] and logarithmically beyond (a heavy-tailed likelihood: one wild sample does not
//! undo the evidence).
//!
//! **Tracks.** At the first sample a track starts at every root with either sign (and at the
//! hint, if one is given, updated by the sample's readings; the roots then pay their distance
//! from the hint). A track that
//! falls [`COST_CAP`] behind the best is dropped; two that meet are merged. When the best track
//! fails the gate — the readings are not where its motion says (a mirror root it followed has
//! left it, a fault, a wrong hint) — a track also starts at every signed root that no track is
//! near, [`STEP_CAP`] + [`SIGN_MARGIN`] behind the best: the lock test is the track's own
//! innovation, not a second monitor, and a lost history is found again by the evidence alone.
//!
//! **Output.** The cheapest track; its Ω is the filtered Ω, and the signed root nearest it is
//! the sample's (raw) Ω. `branch_margin` is the cost of the cheapest track nearest another root
//! (flag 16 below [`SIGN_MARGIN`]), and 0 where that root is more than [`SIGN_MARGIN`] (in χ²)
//! from the track (no root of the sample is the motion's) or the best track's innovation is
//! beyond twice that (the readings are not where its motion says: a fault, a lost lock); the sign is unresolved while a track nearest the same
//! root with the other sign is within [`SIGN_MARGIN`].

use crate::linalg::{norm2, scale, sub, Mat3, Sym3, Vec3};
use crate::real::Real;

mod filter;
use filter::*;

/// Most candidate branches per sample.
pub const MAX_CANDIDATES: usize = 4;
/// Most tracks kept.
pub const MAX_STATES: usize = 8;
/// Cap of a track's cost above the best (the memory of the filter).
pub const COST_CAP: f64 = 200.0;
/// The gate of one step's normalised innovation: beyond it the innovation counts only
/// logarithmically, and the best track failing it starts new tracks.
pub const STEP_CAP: f64 = 60.0;
/// Memory of the jerk density's adaptation, s.
pub const JERK_MEMORY_S: f64 = 1.0;
/// Most the jerk density may grow over the configured one.
pub const JERK_SCALE_MAX: f64 = 1e6;
/// Most linearisations of model F's null-space update (iterated extended Kalman filter).
pub const IEKF_ITERATIONS: usize = 3;
/// Cost margin that settles the sign / the branch (≈ 4 σ).
pub const SIGN_MARGIN: f64 = 16.0;

/// A candidate branch at one sample (Ω up to sign).
#[derive(Clone, Copy, Debug, Default)]
pub struct Candidate<T> {
    /// Ω (body frame), either sign.
    pub omega: Vec3<T>,
    /// Covariance of this branch's Ω (body frame; from its `a` solve).
    pub omega_cov: Sym3<T>,
    /// Ω′ of this branch (body frame).
    pub domega: Vec3<T>,
    /// Variance of one component of this branch's Ω′.
    pub domega_var: T,
    /// Misfit of this branch to the sample (whitened χ²).
    pub fit: T,
}

impl<T: Real> Candidate<T> {
    /// Mean variance of one component of Ω.
    fn omega_var(&self) -> T {
        self.omega_cov.trace() / T::of(3.0)
    }
}

/// Model F with m = 3: what a track's extended Kalman filter measures at one sample (body
/// frame, `Ω = a`): the three null-space equations `pₖ = Ωᵀ Mₖ Ω` (unit noise) and the linear
/// solve's Ω′ rows `y = Ω′ + [Ωᵀ Tⱼ Ω]ⱼ` (noise variances `var0`).
#[derive(Clone, Copy, Debug)]
pub struct Readings<T> {
    /// The forms `Mₖ`.
    pub forms: [Sym3<T>; 3],
    /// Their right-hand sides `pₖ`.
    pub pe: [T; 3],
    /// The Ω′ rows' values.
    pub y: Vec3<T>,
    /// `Tⱼ` of each Ω′ row.
    pub t: [Sym3<T>; 3],
    /// Variances of the Ω′ rows' noise.
    pub var0: Vec3<T>,
}

/// What a step measures: model F's readings, or model G's roots alone.
#[derive(Clone, Copy, Debug)]
pub enum Measured<T> {
    /// Model F with m = 3: each track is updated by the readings (extended Kalman filter).
    Readings(Readings<T>),
    /// Model G, and model F with m > 3 (one root): each track takes the signed root nearest
    /// its prediction.
    Roots,
}

/// A track: its (Ω, Ω′) filter, cost and the signed root nearest it.
#[derive(Clone, Copy, Debug, Default)]
pub struct State<T> {
    /// Filtered Ω.
    pub omega: Vec3<T>,
    /// Filtered Ω′.
    pub domega: Vec3<T>,
    /// Covariance of Ω.
    pub p_ww: Mat3<T>,
    /// Covariance of Ω with Ω′ (`E[δΩ δΩ′ᵀ]`).
    pub p_wd: Mat3<T>,
    /// Covariance of Ω′.
    pub p_dd: Mat3<T>,
    /// Bound on the bias a crossing left in Ω (per component; see [`Tracker::step`]'s output).
    pub bias: Vec3<T>,
    /// Cumulative cost above the best track.
    pub cost: T,
    /// The candidate nearest the track at this sample.
    pub candidate: u8,
    /// +1 or −1: the sign of that candidate's Ω nearest the track.
    pub sign: i8,
}

impl<T: Real> State<T> {
    /// Mean variance of one component of Ω.
    pub fn omega_var(&self) -> T {
        (self.p_ww[0][0] + self.p_ww[1][1] + self.p_ww[2][2]) / T::of(3.0)
    }
}

/// The result of one step.
#[derive(Clone, Copy, Debug)]
pub struct Choice<T> {
    /// Index of the chosen candidate.
    pub candidate: usize,
    /// Signed algebraic Ω of the chosen candidate (the root nearest the best track).
    pub omega: Vec3<T>,
    /// Filtered Ω of the best track and the variances of its components.
    pub filtered: (Vec3<T>, Vec3<T>),
    /// The sign is not settled.
    pub sign_unresolved: bool,
    /// Another branch is nearly as good.
    pub branch_ambiguous: bool,
    /// Cost of the cheapest track nearest another root above the best (twice the negative
    /// log-likelihood ratio); [`COST_CAP`] when none is left in memory. Below [`SIGN_MARGIN`]
    /// the branch is ambiguous.
    pub branch_margin: T,
}

/// The multiple-track branch and sign filter.
#[derive(Clone, Debug)]
pub struct Tracker<T> {
    tracks: [State<T>; MAX_STATES],
    n: usize,
    best: usize,
    /// White-jerk density (rad²/s⁵): the configured one, the least.
    jerk: T,
    /// The factor on it learnt from the best track's innovations (≥ 1).
    jerk_scale: T,
    /// Candidates at the last step.
    last_nc: usize,
}

impl<T: Real> Default for Tracker<T> {
    fn default() -> Self {
        Self::new(T::of(crate::estimator::DEFAULT_JERK_DENSITY))
    }
}

impl<T: Real> Tracker<T> {
    /// A filter with no history and the white-jerk density `jerk` (rad²/s⁵).
    pub fn new(jerk: T) -> Self {
        Tracker {
            tracks: [State::default(); MAX_STATES],
            n: 0,
            best: 0,
            jerk,
            jerk_scale: T::ONE,
            last_nc: 0,
        }
    }

    /// Sets the white-jerk density (rad²/s⁵) and forgets the history.
    pub fn set_jerk(&mut self, jerk: T) {
        self.jerk = jerk;
        self.reset();
    }

    /// Forgets the history.
    pub fn reset(&mut self) {
        self.n = 0;
        self.jerk_scale = T::ONE;
        self.last_nc = 0;
    }

    /// The white-jerk density in use (rad²/s⁵): the configured one times what the innovations
    /// asked for.
    pub fn jerk_density(&self) -> T {
        self.jerk * self.jerk_scale
    }

    /// True once a step has been taken.
    pub fn has_history(&self) -> bool {
        self.n > 0
    }

    /// The tracks after the last step.
    pub fn states(&self) -> &[State<T>] {
        &self.tracks[..self.n]
    }

    /// The best track's Ω predicted by `dt`, if any.
    pub fn predicted_omega(&self, dt: T) -> Option<Vec3<T>> {
        (self.n > 0).then(|| propagate(&self.tracks[self.best], dt))
    }

    /// Every distinct predicted Ω (one per track, sign dropped), cheapest first, for
    /// starting the `a` search (m > 3).
    pub fn predictions(&self, dt: T, out: &mut [Vec3<T>; MAX_CANDIDATES]) -> usize {
        let states = &self.tracks;
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

    /// One step: `cands` are this sample's branches and `measured` what the tracks are updated
    /// by; `dt` the time since the previous step; `hint` an approximate Ω with its variance
    /// (used only without history). `None` without a candidate.
    #[inline(never)]
    pub fn step(
        &mut self,
        cands: &[Candidate<T>],
        measured: Measured<T>,
        dt: T,
        hint: Option<(Vec3<T>, T)>,
    ) -> Option<Choice<T>> {
        let nc = cands.len().min(MAX_CANDIDATES);
        if nc == 0 {
            return None;
        }
        let cands = &cands[..nc];
        let gate = T::of(STEP_CAP);
        let readings = match measured {
            Measured::Readings(r) => Some(r),
            Measured::Roots => None,
        };
        let mut lost = false;
        let mut initiate = false;
        if self.n == 0 {
            // A hint is a prior: a track of its own, updated by this sample's readings.
            if let Some((h, var)) = hint {
                let c = Candidate {
                    omega: h,
                    omega_cov: Sym3([var, var, var, T::ZERO, T::ZERO, T::ZERO]),
                    domega: [T::ZERO; 3],
                    domega_var: T::of(1e6),
                    fit: T::ZERO,
                };
                let mut tr = start(&c, readings.as_ref(), 0, 1, T::ZERO);
                let nis = update(&mut tr, readings.as_ref(), cands, gate);
                tr.cost += robust(nis, gate);
                self.push(tr);
            }
            for (ci, c) in cands.iter().enumerate() {
                for sign in SIGNS {
                    let mut cost = c.fit;
                    if let Some((h, var)) = hint {
                        let z = scale(sign_of(sign), &c.omega);
                        cost += (norm2(&sub(&z, &h)) / var.max(T::of(1e-30))).min(T::of(COST_CAP));
                    }
                    self.push(start(c, readings.as_ref(), ci, sign, cost));
                }
            }
        } else {
            // The white-jerk model over `dt`: Q = q [[Δ³/3, Δ²/2], [Δ²/2, Δ]].
            let q = self.jerk * self.jerk_scale * dt;
            let qs = [q * dt * dt / T::of(3.0), T::of(0.5) * q * dt, q];
            let mut best_nis = T::ZERO;
            for k in 0..self.n {
                let tr = &mut self.tracks[k];
                predict(tr, dt, qs);
                let prior = [tr.p_ww[0][0], tr.p_ww[1][1], tr.p_ww[2][2]];
                let nis = update(tr, readings.as_ref(), cands, gate);
                // A bias in the prior goes through the update as the prior's weight in it
                // (`1 − K H = P⁺ / P⁻` per component).
                for c in 0..3 {
                    tr.bias[c] *= (tr.p_ww[c][c] / prior[c].max(T::of(1e-30))).min(T::ONE);
                }
                tr.cost += robust(nis, gate);
                if k == self.best {
                    best_nis = nis;
                    // The lock test: the best track's own innovation beyond the gate starts
                    // new tracks; beyond the margin per 3 of its 6 degrees of freedom (the
                    // 99.99 % point) the sample is in doubt: the readings are not where its
                    // motion says.
                    initiate = nis > gate;
                    lost = nis > T::of(2.0 * SIGN_MARGIN);
                }
            }
            self.adapt(best_nis, dt);
        }
        // Roots are born in pairs where a complex pair turns real (a crossing unfolding): a
        // new root starts a track too, or a track that left the crossing on its mirror would
        // never meet the true one (the issue-15 family at 50 Hz, 1e-4 m/s², 0.2 m: 8 s on the
        // mirror, unflagged).
        let born = nc > self.last_nc;
        self.last_nc = nc;
        if initiate || born {
            let best_cost = self.tracks[..self.n]
                .iter()
                .fold(T::of(f64::MAX), |b, t| b.min(t.cost));
            // A track at every signed root that no track is near (within the gate); where
            // roots were just born, at every one that is no track's nearest (the two roots of
            // an unfolding crossing are within each other's noise).
            let cost = best_cost + gate + T::of(SIGN_MARGIN);
            let n = self.n;
            if born {
                // Each track's nearest signed root, once (`settle` labels them again after
                // the merges).
                for t in self.tracks[..n].iter_mut() {
                    label(t, cands);
                }
            }
            for (ci, c) in cands.iter().enumerate() {
                for sign in SIGNS {
                    let z = scale(sign_of(sign), &c.omega);
                    let var = c.omega_var().max(T::of(1e-30));
                    let near = self.tracks[..n].iter().any(|t| {
                        if born {
                            (usize::from(t.candidate), t.sign) == (ci, sign)
                        } else {
                            norm2(&sub(&t.omega, &z)) <= gate * (t.omega_var() + var)
                        }
                    });
                    if !near {
                        self.push(start(c, readings.as_ref(), ci, sign, cost));
                    }
                }
            }
        }
        self.settle(cands, lost)
    }

    /// Covariance matching of the jerk: the best track's normalised innovation per degree of
    /// freedom averages 1 when the model holds; persistently above it (a motion with more
    /// jerk than configured, or readings noisier than declared — real parts) the jerk density
    /// grows, with a memory of [`JERK_MEMORY_S`], and falls back towards the configured one
    /// (its floor) when the innovations are within the model. Without it a hand-held
    /// recording (62.5 Hz, |Ω| to 40 rad/s) left the readings behind: Ω off by hundreds of
    /// rad/s; a configured density of 10⁶ instead held it, but loosens the branch choice of
    /// slow motions.
    fn adapt(&mut self, nis: T, dt: T) {
        let per_dof = nis / T::of(6.0);
        let alpha = (dt / T::of(JERK_MEMORY_S)).min(T::of(0.1));
        let g = alpha * (per_dof.min(T::of(20.0)) - T::ONE);
        self.jerk_scale = (self.jerk_scale * (T::ONE + g.max(-T::of(0.5))))
            .max(T::ONE)
            .min(T::of(JERK_SCALE_MAX));
    }

    /// Adds a track, in place of the costliest if all places are taken and it is cheaper.
    fn push(&mut self, t: State<T>) {
        if !t.cost.is_finite() {
            return;
        }
        if self.n < MAX_STATES {
            self.tracks[self.n] = t;
            self.n += 1;
            return;
        }
        let mut worst = 0;
        for j in 1..self.n {
            if self.tracks[j].cost > self.tracks[worst].cost {
                worst = j;
            }
        }
        if t.cost < self.tracks[worst].cost {
            self.tracks[worst] = t;
        }
    }

    /// After the updates: merges tracks that met, normalises the costs, drops tracks
    /// [`COST_CAP`] behind, labels each with its nearest signed root, and makes the choice
    /// (`lost`: the best track's innovation was beyond the doubt threshold: margin 0).
    fn settle(&mut self, cands: &[Candidate<T>], lost: bool) -> Option<Choice<T>> {
        // Merge: of two tracks within half their combined deviation, the cheaper stays.
        let mut i = 0;
        while i < self.n {
            let mut j = i + 1;
            while j < self.n {
                let (a, b) = (&self.tracks[i], &self.tracks[j]);
                if norm2(&sub(&a.omega, &b.omega)) <= T::of(0.25) * (a.omega_var() + b.omega_var())
                {
                    if b.cost < a.cost {
                        self.tracks[i] = self.tracks[j];
                    }
                    self.n -= 1;
                    self.tracks[j] = self.tracks[self.n];
                } else {
                    j += 1;
                }
            }
            i += 1;
        }
        let mut best = 0;
        for j in 1..self.n {
            if self.tracks[j].cost < self.tracks[best].cost {
                best = j;
            }
        }
        let base = self.tracks[best].cost;
        let mut kept = 0;
        for j in 0..self.n {
            let mut t = self.tracks[j];
            t.cost -= base;
            let finite = t.omega.iter().chain(t.domega.iter()).all(|v| v.is_finite());
            if !finite || (!(t.cost < T::of(COST_CAP)) && j != best) {
                continue;
            }
            label(&mut t, cands);
            if j == best {
                best = kept;
            }
            self.tracks[kept] = t;
            kept += 1;
        }
        self.n = kept;
        self.best = best;
        if kept == 0 {
            return None;
        }
        let b = self.tracks[best];
        let margin = T::of(SIGN_MARGIN);
        let mut branch_margin = T::of(COST_CAP);
        let mut sign_unresolved = false;
        for (j, t) in self.tracks[..kept].iter().enumerate() {
            if j == best {
                continue;
            }
            if t.candidate != b.candidate {
                branch_margin = branch_margin.min(t.cost);
            } else if t.sign != b.sign && t.cost < margin {
                sign_unresolved = true;
            }
        }
        let c = &cands[usize::from(b.candidate)];
        let omega = scale(sign_of(b.sign), &c.omega);
        // The nearest root is not where the best track is (beyond the margin's χ², in the two
        // covariances): the sample's root is not the motion's, and nothing here can say which
        // is (margin 0).
        let (cof, det) = Sym3::from_mat(&add_sym(&b.p_ww, &c.omega_cov)).cofactors();
        let d = sub(&omega, &b.omega);
        if lost || !(cof.quad(&d) <= margin * det) {
            branch_margin = T::ZERO;
        }
        // Another signed root the track also explains (within the margin's χ²): the roots
        // of a crossing, and the truth may be anywhere between them; a track linearised at one
        // of them takes itself for precise, and keeps the bias after the roots part (a
        // nine-channel layout after an exclusion: 0.12 rad/s off at 7 reported deviations for
        // 0.3 s). The best track's bias bound takes half the way to the farthest such root,
        // goes through each update as the prior does, and the filtered Ω's variances carry it.
        let mut spread = [T::ZERO; 3];
        for (ci, o) in cands.iter().enumerate() {
            for sign in SIGNS {
                if ci == usize::from(b.candidate) && sign == b.sign {
                    continue;
                }
                let z = scale(sign_of(sign), &o.omega);
                let d = sub(&z, &b.omega);
                let (cof, det) = Sym3::from_mat(&add_sym(&b.p_ww, &o.omega_cov)).cofactors();
                if cof.quad(&d) <= margin * det {
                    for k in 0..3 {
                        spread[k] = spread[k].max(T::of(0.25) * d[k] * d[k]);
                    }
                }
            }
        }
        let bias = &mut self.tracks[best].bias;
        let mut var = [b.p_ww[0][0], b.p_ww[1][1], b.p_ww[2][2]];
        for k in 0..3 {
            bias[k] = bias[k].max(spread[k].sqrt());
            var[k] += bias[k] * bias[k];
        }
        Some(Choice {
            candidate: usize::from(b.candidate),
            omega,
            filtered: (b.omega, var),
            sign_unresolved,
            branch_ambiguous: branch_margin < margin,
            branch_margin,
        })
    }
}

#[cfg(test)]
mod tests;
