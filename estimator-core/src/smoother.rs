//! Fixed-lag smoothing of the branch and sign decisions: the output for sample `k` is decided
//! at sample `k + LAG` by following the best hypothesis back through the tracker's Viterbi
//! pointers. Continuity in both directions: the first samples of a record, where the sign has
//! no history yet, get the sign that the following samples settle.
//!
//! For host tools (files); the firmware outputs the forward decision at once (flagged while
//! unsettled). Memory is `O(LAG)`, not proportional to the record.

use crate::estimate::{Estimate, Flags};
use crate::estimator::{variance, LockMonitor};
use crate::frame_uncertainty::FrameUncertainty;
use crate::real::Real;
use crate::tracker::{State, COST_CAP, MAX_CANDIDATES, MAX_STATES, SIGN_MARGIN};

/// Everything about one sample that a later decision may need.
#[derive(Clone, Copy, Debug)]
pub struct StepRecord<T> {
    /// Time of the sample.
    pub t: f64,
    /// False if the sample could not be used (the forward estimate is a prediction).
    pub valid: bool,
    /// Whether the estimator runs raw (no filtered Ω).
    pub raw: bool,
    /// Candidate branches (Ω with the + sign, algebraic).
    pub candidates: [Estimate<T>; MAX_CANDIDATES],
    /// Number of candidates.
    pub n_candidates: u8,
    /// Per candidate, the diagonal of its deviations' widening near a branch crossing (model
    /// F; zero elsewhere), for the filtered output.
    pub widening: [crate::linalg::Vec3<T>; MAX_CANDIDATES],
    /// The forward path's bound on its rate filter's drift from crossings after this sample
    /// (model F; zero elsewhere).
    pub crossing_bias: crate::linalg::Vec3<T>,
    /// The tracker's hypotheses after this sample.
    pub states: [State<T>; MAX_STATES],
    /// Number of hypotheses.
    pub n_states: u8,
    /// The forward choice.
    pub best: u8,
    /// The forward estimate (as output without smoothing).
    pub forward: Estimate<T>,
    /// The forward path checked its choice with the lock monitor (model F, m = 3): the
    /// smoother checks its own output path the same way.
    pub monitored: bool,
}

impl<T: Real> Default for StepRecord<T> {
    fn default() -> Self {
        StepRecord {
            t: 0.0,
            valid: false,
            raw: true,
            candidates: [Estimate::default(); MAX_CANDIDATES],
            n_candidates: 0,
            widening: [[T::ZERO; 3]; MAX_CANDIDATES],
            crossing_bias: [T::ZERO; 3],
            states: [State::default(); MAX_STATES],
            n_states: 0,
            best: 0,
            forward: Estimate::default(),
            monitored: false,
        }
    }
}

impl<T: Real> StepRecord<T> {
    /// Marks the record as a prediction-only sample.
    pub fn invalidate(&mut self, t: f64, forward: Estimate<T>) {
        self.t = t;
        self.valid = false;
        self.n_states = 0;
        self.n_candidates = 0;
        self.forward = forward;
        self.monitored = false;
    }
}

/// A fixed-lag smoother over [`StepRecord`]s.
pub struct Smoother<T, const LAG: usize> {
    ring: [StepRecord<T>; LAG],
    /// Per slot of `ring`, the back-pointers (`State::from`) of its states and how many there
    /// are (0 for an invalid record), copied at commit: the chains are followed over these
    /// few bytes instead of the ≈ 3 KB records (measured: the largest cost of `ballisto
    /// estimate`'s estimation thread when read from the records).
    links: [([u8; MAX_STATES], u8); LAG],
    head: usize,
    len: usize,
    gamma_free_float: Option<crate::linalg::Sym3<T>>,
    frame_uncertainty: FrameUncertainty<T>,
    /// The lock monitor over the output path (records that ask for it).
    lock: LockMonitor<T>,
    /// Time of the last output the monitor took.
    lock_t: Option<f64>,
}

impl<T: Real, const LAG: usize> Default for Smoother<T, LAG> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real, const LAG: usize> Smoother<T, LAG> {
    /// An empty smoother.
    pub fn new() -> Self {
        Smoother {
            ring: core::array::from_fn(|_| StepRecord::default()),
            links: [([u8::MAX; MAX_STATES], 0); LAG],
            head: 0,
            len: 0,
            gamma_free_float: None,
            frame_uncertainty: FrameUncertainty::default(),
            lock: LockMonitor::default(),
            lock_t: None,
        }
    }

    /// In model F the output `A` is `Γ + {Ω}²`: give Γ so that a smoothed sign or filtered Ω
    /// rebuilds it consistently (`None` in model G).
    pub fn set_free_float_gamma(&mut self, gamma: Option<crate::linalg::Sym3<T>>) {
        self.gamma_free_float = gamma;
    }

    /// The arrangement's frame uncertainty, added to the deviations of every output as the
    /// estimator adds it to its own ([`crate::Estimator::frame_uncertainty`]).
    pub fn set_frame_uncertainty(&mut self, frame: FrameUncertainty<T>) {
        self.frame_uncertainty = frame;
    }

    /// Forgets every record (a new record follows); the settings stay.
    pub fn reset(&mut self) {
        self.head = 0;
        self.len = 0;
        self.lock.reset();
        self.lock_t = None;
    }

    /// When the window is full, decides and returns the oldest sample and frees its slot.
    /// Call before [`Smoother::slot`] for every new sample.
    pub fn make_room(&mut self) -> Option<(f64, Estimate<T>)> {
        if LAG == 0 || self.len < LAG {
            return None;
        }
        let out = self.emit_oldest();
        self.head = (self.head + 1) % LAG;
        self.len -= 1;
        Some(out)
    }

    /// The free slot for the next record: fill it with [`crate::Estimator::update_with`], then
    /// call [`Smoother::commit`].
    pub fn slot(&mut self) -> &mut StepRecord<T> {
        let idx = (self.head + self.len) % LAG.max(1);
        &mut self.ring[idx]
    }

    /// Commits the slot filled last.
    pub fn commit(&mut self) {
        if LAG > 0 {
            let idx = (self.head + self.len) % LAG;
            let r = &self.ring[idx];
            let n = if r.valid {
                (r.n_states as usize).min(MAX_STATES)
            } else {
                0
            };
            let (from, count) = &mut self.links[idx];
            for (f, st) in from.iter_mut().zip(r.states.iter()).take(n) {
                *f = st.from;
            }
            *count = n as u8;
        }
        self.len = (self.len + 1).min(LAG);
    }

    /// Emits the remaining samples at the end of a record, oldest first.
    pub fn drain(&mut self, mut emit: impl FnMut(f64, Estimate<T>)) {
        while self.len > 0 {
            let out = self.emit_oldest();
            emit(out.0, out.1);
            self.head = (self.head + 1) % LAG.max(1);
            self.len -= 1;
        }
    }

    fn at(&self, i: usize) -> &StepRecord<T> {
        &self.ring[(self.head + i) % LAG.max(1)]
    }

    /// For every state `s` of record `from`: its ancestor state index at record 0 (`None` if
    /// the chain breaks at an invalid sample). One backward pass over the records for all
    /// states (measured: following each state's chain on its own made this the largest cost
    /// of `ballisto estimate` after number formatting).
    fn ancestors(&self, from: usize, out: &mut [Option<usize>; MAX_STATES]) {
        let n = (self.at(from).n_states as usize).min(MAX_STATES);
        for (s, a) in out.iter_mut().enumerate() {
            *a = (s < n).then_some(s);
        }
        for i in (1..=from).rev() {
            let (links, count) = &self.links[(self.head + i) % LAG.max(1)];
            for a in out.iter_mut().take(n) {
                if let Some(s) = *a {
                    *a = if s >= usize::from(*count) {
                        None
                    } else {
                        let f = links[s];
                        (f != u8::MAX).then_some(f as usize)
                    };
                }
            }
        }
    }

    /// The decision for the oldest record, its output path checked by the lock monitor where
    /// the record asks for it: a path that does not integrate its own Ω′ is flagged
    /// branch-ambiguous with margin 0, as the forward path flags its own.
    fn emit_oldest(&mut self) -> (f64, Estimate<T>) {
        let (t, mut est, chosen) = self.decide_oldest();
        let oldest = self.at(0);
        let Some(chosen) = chosen.filter(|_| oldest.monitored) else {
            return (t, est);
        };
        let st = &oldest.states[chosen];
        let root = &oldest.candidates[st.candidate as usize];
        let omega = crate::linalg::scale(T::of(f64::from(st.sign)), &root.omega);
        let (domega, sd_omega, sd_domega) = (root.domega, root.sd_omega, root.sd_domega);
        let dt = T::of(self.lock_t.map_or(0.0, |t0| t - t0));
        self.lock_t = Some(t);
        if self.lock.update(
            (&omega, &domega),
            (variance(&sd_omega), variance(&sd_domega)),
            dt,
            false,
        ) {
            crate::estimator::mark_inconsistent(&mut est);
        }
        (t, est)
    }

    /// The decision for the oldest record. A record of an unusable sample gives the
    /// estimator's held output (its deviations already widened by the frame uncertainty);
    /// a usable one's estimate (from the candidates, or its forward one if it holds no
    /// hypothesis) is the solve's and is widened here.
    /// Also returns the chosen state, if any.
    fn decide_oldest(&self) -> (f64, Estimate<T>, Option<usize>) {
        let oldest = self.at(0);
        if !oldest.valid {
            return (oldest.t, oldest.forward, None);
        }
        let (t, mut est, chosen) = if oldest.n_states == 0 {
            (oldest.t, oldest.forward, None)
        } else {
            let (t, est, chosen) = self.decide_valid();
            (t, est, Some(chosen))
        };
        if !self.frame_uncertainty.is_zero() {
            self.frame_uncertainty.widen(&mut est);
        }
        (t, est, chosen)
    }

    fn decide_valid(&self) -> (f64, Estimate<T>, usize) {
        let oldest = self.at(0);
        // The newest record whose chain reaches the oldest without a break, and where each of
        // its states' chains leads at the oldest record (one backward pass for all of them).
        let mut anc = [None; MAX_STATES];
        let mut last = self.len - 1;
        while last > 0 {
            if self.at(last).valid {
                self.ancestors(last, &mut anc);
                if anc[0].is_some() {
                    break;
                }
            }
            last -= 1;
        }
        let newest = self.at(last);
        let (choice, chosen_cost) = if last == 0 {
            (oldest.best as usize, T::ZERO)
        } else {
            match anc[newest.best as usize] {
                Some(a) => (a, newest.states[newest.best as usize].cost),
                None => (oldest.best as usize, T::ZERO),
            }
        };
        // Margins of the alternatives (opposite sign, other branch) at the newest record.
        let margin = T::of(SIGN_MARGIN);
        let mut sign_unresolved = false;
        // The cheapest alternative on another branch (at the oldest record) above the choice.
        let mut branch_margin = T::of(COST_CAP);
        if last == 0 {
            sign_unresolved = oldest.forward.flags.has(Flags::SIGN_UNRESOLVED);
            branch_margin = oldest.forward.branch_margin;
        } else {
            for j in 0..newest.n_states as usize {
                if let Some(a) = anc[j] {
                    let above = newest.states[j].cost - chosen_cost;
                    let (sa, sc) = (&oldest.states[a], &oldest.states[choice]);
                    if sa.candidate != sc.candidate {
                        branch_margin = branch_margin.min(above.max(T::ZERO));
                    } else if above < margin && sa.sign != sc.sign {
                        sign_unresolved = true;
                    }
                }
            }
        }
        let branch_ambiguous = branch_margin < margin;
        let st = &oldest.states[choice];
        let mut est = oldest.candidates[st.candidate as usize];
        let sign = T::of(st.sign as f64);
        let mut flags = est.flags.0 & !(Flags::SIGN_UNRESOLVED | Flags::BRANCH_AMBIGUOUS);
        if sign_unresolved {
            flags |= Flags::SIGN_UNRESOLVED;
        }
        if branch_ambiguous {
            flags |= Flags::BRANCH_AMBIGUOUS;
        }
        est.flags = Flags(flags);
        est.branch_margin = branch_margin;
        if oldest.raw {
            for v in est.omega.iter_mut() {
                *v *= sign;
            }
        } else {
            est.omega = st.omega;
            let sd = st.var.max(T::ZERO).sqrt();
            est.sd_omega = [sd, sd, sd];
            let w = &oldest.widening[st.candidate as usize];
            crate::estimator::widen_smoothed(&mut est, &oldest.crossing_bias, w);
            if let Some(g) = self.gamma_free_float {
                est.field = g.add_scaled(T::ONE, &crate::linalg::Sym3::skew_squared(&st.omega));
                let v = st.var.max(T::ZERO);
                let iso = crate::linalg::Sym3([v, v, v, T::ZERO, T::ZERO, T::ZERO]);
                est.sd_field = crate::linalg::skew_squared_sd(&st.omega, &iso);
            }
        }
        (oldest.t, est, choice)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::{cross, dot, norm2, sub, Sym3, Vec3};
    use crate::{Arrangement, Estimator, Model, Options};

    const DT: f64 = 0.01;

    /// A changing rate and its derivative.
    fn rate(t: f64) -> (Vec3<f64>, Vec3<f64>) {
        (
            [1.0 + 0.5 * t.sin(), 0.8 * (0.7 * t).cos(), -0.6 + 0.3 * t],
            [0.5 * t.cos(), -0.56 * (0.7 * t).sin(), 0.3],
        )
    }

    /// Four tri-axial parts on a tetrahedron (N = 12, model G).
    fn tetra() -> Arrangement<16> {
        let mut arr = Arrangement::new();
        let c = 0.15 / 3f64.sqrt();
        for r in [[c, c, c], [c, -c, -c], [-c, c, -c], [-c, -c, c]] {
            for axis in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] {
                arr.push(r, axis, 0.003).unwrap();
            }
        }
        arr
    }

    /// Noise-free readings (paper eq. 4 with Γ = 0).
    fn readings(arr: &Arrangement<16>, t: f64) -> Vec<f64> {
        let (w, dw) = rate(t);
        let sigma0 = [0.1, -0.2, 0.05];
        let field = Sym3::skew_squared(&w);
        arr.channels()
            .iter()
            .map(|c| {
                let (s, r) = (&c.axis, &c.position);
                dot(s, &sigma0) + dot(&cross(r, s), &dw) + dot(s, &field.mul_vec(r))
            })
            .collect()
    }

    /// The first sample's sign cannot be known from that sample alone: the forward decision
    /// flags it unresolved. The fixed-lag smoother gives every output, the first included, the
    /// sign the following samples settle, unflagged, in order and none lost.
    #[test]
    fn look_ahead_settles_the_sign_of_the_first_samples() {
        let arr = tetra();
        let mut est = Estimator::<f64, 16>::new(&arr, Model::General, Options::default()).unwrap();
        let mut sm = Box::new(Smoother::<f64, 32>::new());
        let mut out = Vec::new();
        let mut first_forward_unresolved = None;
        let n = 200;
        for k in 0..n {
            let t = k as f64 * DT;
            if let Some(e) = sm.make_room() {
                out.push(e);
            }
            let e = est.update_with(t, &readings(&arr, t), Some(sm.slot()));
            first_forward_unresolved.get_or_insert(e.flags.has(Flags::SIGN_UNRESOLVED));
            sm.commit();
        }
        sm.drain(|t, e| out.push((t, e)));
        assert_eq!(first_forward_unresolved, Some(true));
        assert_eq!(out.len(), n);
        for (k, (t, e)) in out.iter().enumerate() {
            assert!((t - k as f64 * DT).abs() < 1e-12, "output {k} at {t}");
            let w = rate(*t).0;
            let err = norm2(&sub(&e.omega, &w)).sqrt();
            assert!(err < 1e-3, "t = {t}: Ω {:?} vs {w:?}", e.omega);
            assert!(!e.flags.has(Flags::SIGN_UNRESOLVED), "t = {t}");
        }
    }
}
