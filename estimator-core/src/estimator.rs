//! The estimator: configuration (precomputation) and the per-sample solve.
//!
//! Per sample (no SVD, no allocation): `y = W p` (one matrix–vector product), the `a` solve
//! from the `m` null-space equations, `x = G⁺(p − ε q(a))` as `y_lin − ε [aᵀ T_j a]` for each
//! branch, branch and sign tracking, first-order standard deviations of the chosen branch, and
//! (unless raw) the rate filter.

use crate::arrangement::{Arrangement, ChannelMask, Model};
use crate::design::{check_structural, Projection};
use crate::error::ConfigError;
use crate::estimate::{Estimate, Flags};
use crate::linalg::{copy3, dot, mat_t_vec, mat_vec, norm2, quat_to_mat, scale, Mat3, Sym3, Vec3};
use crate::quadratic::{
    canonical_sign, closed_form, gauss_newton, rank_one_factor, refine, residual2, MAX_ROOTS,
};
use crate::real::Real;
use crate::smoother::StepRecord;
use crate::svd::MAX_COLS;
use crate::tracker::{Candidate, Tracker, MAX_CANDIDATES};

/// Number of precomputed frames `V` for model G.
pub const NUM_FRAMES: usize = 4;

/// The frames `V` of model G as quaternions `[w, x, y, z]`: chosen (numerical search over the
/// sphere) so that every rate direction has all three components at least 0.185·|Ω| in one of
/// them, which keeps every off-diagonal of `A` large (estimator.md: "Choose V from the
/// predicted A so that the off-diagonals are large").
pub const FRAME_QUATERNIONS: [[f64; 4]; NUM_FRAMES] = [
    [1.0, 0.0, 0.0, 0.0],
    [
        0.8178638641141279,
        -0.5425542429903757,
        0.1674932673596002,
        0.09316436324396377,
    ],
    [
        0.24923937382434666,
        -0.8844306211486356,
        -0.14682476352409543,
        -0.36620308535890217,
    ],
    [
        -0.6856432616288827,
        -0.614718901601607,
        -0.37747774290860625,
        0.09759376724589237,
    ],
];

/// Frame score `min_i |(V Ω̂)_i|` above which the current frame is kept without a search.
const FRAME_KEEP_SCORE: f64 = 0.25;

/// Options of the estimator.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Per-sample output without the rate filter (continuity is still used for branch and sign).
    pub raw: bool,
    /// Approximate Ω at the first sample (settles sign and starting branch).
    pub initial_omega: Option<[f64; 3]>,
    /// Gravity-gradient tensor Γ (body frame), known; default 0.
    pub gamma: Sym3<f64>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            raw: false,
            initial_omega: None,
            gamma: Sym3::zero(),
        }
    }
}

/// Reciprocal condition (`det(JᵀJ)` over the cube of its mean eigenvalue) of the `a` solve
/// below which an estimate is flagged ill-conditioned: the Jacobian's condition number is then
/// several hundred (noise, and rounding in f32, amplified accordingly).
const ILL_RCOND: f64 = 1e-5;

/// Most predictions used as Gauss–Newton starts (m > 3); with redundancy the global optimum
/// is unique and the cheapest hypotheses' predictions find it.
const MAX_STARTS: usize = 2;

/// Gauss–Newton iterations per start (m > 3).
const GN_ITERATIONS: usize = 6;

/// One branch at one sample, in frame coordinates.
#[derive(Clone, Copy, Debug, Default)]
struct Branch<T> {
    a: Vec3<T>,
    x: [T; MAX_COLS],
    fit: T,
    /// `JᵀJ` of the `a` solve when the solver formed it (else computed for `cov_a`).
    jtj: Option<Sym3<T>>,
    /// `cov(a)` and whether its solve is ill-conditioned (filled after the solve).
    cov_a: Sym3<T>,
    ill: bool,
    /// Model G: standard deviations of Ω (body frame), from the constant covariance of A.
    omega_sd: Vec3<T>,
}

/// The estimator for up to `CAP` channels.
pub struct Estimator<T: Real, const CAP: usize = 32> {
    cfg: Config<T, CAP>,
    /// Frame in use.
    frame: usize,
    tracker: Tracker<T>,
    last_t: Option<f64>,
    /// Two estimate slots, written in place: `out[last]` is the last estimate from a usable
    /// sample (valid when `has_last`); the other slot receives the next output (a new estimate,
    /// which then becomes the last, or the prediction for an unusable sample, which does not).
    out: [Estimate<T>; 2],
    /// The slot of `out` holding the last estimate (`false`: 0, `true`: 1; a `bool` so that
    /// indexing needs no bounds check).
    last: bool,
    has_last: bool,
    domega_var: T,
    work: Work<T, CAP>,
}

/// The configuration and everything precomputed from it (paper eq. 10–11): read-only in the
/// sample loop.
struct Config<T: Real, const CAP: usize> {
    arr: Arrangement<CAP>,
    model: Model,
    mask: ChannelMask,
    proj: [Projection<T, CAP>; NUM_FRAMES],
    usable: [bool; NUM_FRAMES],
    frames: usize,
    gamma: Sym3<T>,
    gamma_frame: [Sym3<T>; NUM_FRAMES],
    gamma_offset: [T; CAP],
    gamma_offset_nonzero: bool,
    options: Options,
}

/// Per-sample working storage, kept in the estimator so that the sample loop neither zeroes
/// nor copies it (every slot is written before it is read).
struct Work<T: Real, const CAP: usize> {
    branches: [Branch<T>; MAX_CANDIDATES],
    trial: [Branch<T>; MAX_CANDIDATES],
    cands: [Candidate<T>; MAX_CANDIDATES],
    scratch: Scratch<T, CAP>,
    /// The readings with excluded channels zeroed.
    masked: [T; CAP],
}

/// What one frame's solve reads: the readings, the time step and the tracker's predictions.
#[derive(Clone, Copy)]
struct Sample<'a, T> {
    p: &'a [T],
    dt: T,
    tracker: &'a Tracker<T>,
}

/// Working vectors of one frame's solve.
struct Scratch<T: Real, const CAP: usize> {
    /// `y = W p`.
    y: [T; CAP],
    /// `ε P`, the right-hand sides of the quadratic forms.
    pe: [T; CAP],
    /// The roots of the `a` solve and the Gauss–Newton starts.
    roots: [Vec3<T>; MAX_CANDIDATES],
    starts: [Vec3<T>; MAX_STARTS + MAX_ROOTS + 2],
    /// Residual and `JᵀJ` of each root found by [`refine`].
    fit: [T; MAX_CANDIDATES],
    jtj: [Sym3<T>; MAX_CANDIDATES],
}

impl<T: Real, const CAP: usize> Work<T, CAP> {
    fn new() -> Self {
        Work {
            branches: [Branch::default(); MAX_CANDIDATES],
            trial: [Branch::default(); MAX_CANDIDATES],
            cands: [Candidate::default(); MAX_CANDIDATES],
            masked: [T::ZERO; CAP],
            scratch: Scratch {
                y: [T::ZERO; CAP],
                pe: [T::ZERO; CAP],
                roots: [[T::ZERO; 3]; MAX_CANDIDATES],
                starts: [[T::ZERO; 3]; MAX_STARTS + MAX_ROOTS + 2],
                fit: [T::ZERO; MAX_CANDIDATES],
                jtj: [Sym3::zero(); MAX_CANDIDATES],
            },
        }
    }
}

impl<T: Real, const CAP: usize> Estimator<T, CAP> {
    /// Builds an estimator: validates the arrangement for the model and precomputes every
    /// frame (paper eq. 10–11).
    pub fn new(
        arr: &Arrangement<CAP>,
        model: Model,
        options: Options,
    ) -> Result<Self, ConfigError> {
        let mut e = Estimator {
            cfg: Config {
                arr: Arrangement::new(),
                model,
                mask: ChannelMask::all(0),
                proj: core::array::from_fn(|_| Projection::empty()),
                usable: [false; NUM_FRAMES],
                frames: 0,
                gamma: Sym3::zero(),
                gamma_frame: [Sym3::zero(); NUM_FRAMES],
                gamma_offset: [T::ZERO; CAP],
                gamma_offset_nonzero: false,
                options: Options::default(),
            },
            frame: 0,
            tracker: Tracker::new(),
            last_t: None,
            out: [Estimate::default(); 2],
            last: false,
            has_last: false,
            domega_var: T::ZERO,
            work: Work::new(),
        };
        e.configure(arr, model, ChannelMask::all(arr.len()), options)?;
        Ok(e)
    }

    /// Reconfigures (new arrangement, model, channel mask or options). On error the previous
    /// configuration stays in force, untouched.
    pub fn configure(
        &mut self,
        arr: &Arrangement<CAP>,
        model: Model,
        mask: ChannelMask,
        options: Options,
    ) -> Result<(), ConfigError> {
        self.cfg.configure(arr, model, mask, options)?;
        self.frame = 0;
        self.reset();
        Ok(())
    }

    /// Excludes or includes channels (new precomputation); on error nothing changes.
    pub fn set_mask(&mut self, mask: ChannelMask) -> Result<(), ConfigError> {
        let arr = self.cfg.arr.clone();
        self.configure(&arr, self.cfg.model, mask, self.cfg.options)
    }

    /// Sets the known gravity-gradient tensor Γ (body frame). Cheap (no SVD).
    pub fn set_gamma(&mut self, gamma: &Sym3<f64>) -> Result<(), ConfigError> {
        if !gamma.0.iter().all(|v| v.is_finite()) {
            return Err(ConfigError::NotFinite {
                what: "gravity gradient Γ",
            });
        }
        self.cfg.options.gamma = *gamma;
        self.cfg.set_gamma(gamma);
        Ok(())
    }

    /// Sets (or clears) the rate hint and restarts branch and sign tracking.
    pub fn set_hint(&mut self, omega: Option<[f64; 3]>) -> Result<(), ConfigError> {
        if let Some(w) = omega {
            if !w.iter().all(|v| v.is_finite()) {
                return Err(ConfigError::NotFinite { what: "rate hint" });
            }
        }
        self.cfg.options.initial_omega = omega;
        self.reset();
        Ok(())
    }

    /// Forgets the history (tracker, filter, time).
    pub fn reset(&mut self) {
        self.tracker.reset();
        self.last_t = None;
        self.has_last = false;
        self.domega_var = T::ZERO;
    }

    /// The model in use.
    pub fn model(&self) -> Model {
        self.cfg.model
    }

    /// The arrangement in use.
    pub fn arrangement(&self) -> &Arrangement<CAP> {
        &self.cfg.arr
    }

    /// The channel mask in use.
    pub fn mask(&self) -> ChannelMask {
        self.cfg.mask
    }

    /// Equilibrated condition number of the design matrix of frame `f` (None if unusable).
    pub fn condition(&self, f: usize) -> Option<f64> {
        (f < self.cfg.frames && self.cfg.usable[f]).then(|| self.cfg.proj[f].condition)
    }

    /// Variance per step of the rate model error learnt by the tracker (trapezoidal integration
    /// of Ω′: jerk, sampling), rad²/s² — a health figure for telemetry.
    pub fn rate_model_variance(&self) -> T {
        self.tracker.model_variance()
    }

    /// Degrees of freedom of the residual (`N − 12` in model G, `N − 9` in model F).
    pub fn dof(&self) -> usize {
        self.cfg.proj[0].m.saturating_sub(3)
    }

    /// One sample set: `p[i]` is channel `i`'s specific force (m/s²) at time `t` (s).
    /// Never panics; never returns NaN (a non-finite reading gives the prediction, flagged).
    pub fn update(&mut self, t: f64, p: &[T]) -> &Estimate<T> {
        self.update_with(t, p, None)
    }

    /// As [`Estimator::update`], and also fills `record` with every candidate branch and every
    /// hypothesis of the tracker, for a fixed-lag smoother ([`crate::smoother::Smoother`]).
    #[inline(never)]
    pub fn update_with(
        &mut self,
        t: f64,
        p: &[T],
        record: Option<&mut StepRecord<T>>,
    ) -> &Estimate<T> {
        let cfg = &self.cfg;
        let n = cfg.arr.len();
        let input_ok = readings_usable(p, n, cfg.mask) && t.is_finite();
        let dt = match self.last_t {
            Some(t0) if t > t0 && (t - t0).is_finite() => t - t0,
            _ => 0.0,
        };
        let dt_t = T::of(dt);
        if !input_ok {
            return self.hold(t, dt_t, record);
        }
        let excluded = cfg.mask.count(n) < n;
        let Work {
            branches,
            trial,
            cands,
            scratch,
            masked,
        } = &mut self.work;
        // Excluded channels' readings may be anything (a dead part gives NaN): zero them, as
        // `W` has zero weight there and 0 × NaN would poison the solve.
        let p: &[T] = if excluded {
            for (i, (m, v)) in masked.iter_mut().zip(p.iter()).enumerate().take(n) {
                *m = if cfg.mask.contains(i) { *v } else { T::ZERO };
            }
            &masked[..n]
        } else {
            p
        };
        let tracker = &self.tracker;
        let sample = Sample {
            p,
            dt: dt_t,
            tracker,
        };

        // Candidate branches.
        let mut fallback = false;
        let mut nb = 0;
        let mut eps = T::ONE;
        let mut frame = self.frame;
        let pred = tracker.predicted_omega(dt_t);
        let hint: Option<Vec3<T>> = cfg
            .options
            .initial_omega
            .map(|w| [T::of(w[0]), T::of(w[1]), T::of(w[2])]);
        let steer = pred.or(if tracker.has_history() { None } else { hint });
        match (cfg.model, steer) {
            (Model::General, Some(w)) if norm2(&w) > T::ZERO => {
                frame = cfg.choose_frame(frame, &w);
                let e0 = cfg.epsilon(frame, &w);
                let (k, fb, e) = cfg.solve_frame(frame, &sample, e0, scratch, branches);
                nb = k;
                fallback = fb;
                eps = e;
            }
            (Model::General, _) => {
                // No prediction: try every frame, keep the best-conditioned decomposition.
                let mut best_score = -T::ONE;
                for f in 0..cfg.frames {
                    if !cfg.usable[f] {
                        continue;
                    }
                    let (k, fb, e) = cfg.solve_frame(f, &sample, T::ONE, scratch, trial);
                    let mut score = if fb { -T::of(0.5) } else { T::ZERO };
                    for b in trial.iter().take(k) {
                        score = score.max(frame_score(&b.a) - if fb { T::ONE } else { T::ZERO });
                    }
                    if score > best_score {
                        best_score = score;
                        frame = f;
                        branches[..k].copy_from_slice(&trial[..k]);
                        nb = k;
                        fallback = fb;
                        eps = e;
                    }
                }
            }
            (Model::FreeFloat, _) => {
                frame = 0;
                let (k, fb, _) = cfg.solve_frame(0, &sample, T::ONE, scratch, branches);
                nb = k;
                fallback = fb;
            }
        }
        self.frame = frame;
        for (c, b) in cands.iter_mut().zip(branches.iter_mut()).take(nb) {
            let omega = cfg.omega_of(frame, eps, b);
            let omega_var = match &cfg.proj[frame].general_cov {
                Some(gc) => {
                    // Model G: A is linear in p, its covariance a constant; Ω's follows from it.
                    let var = omega_variances(&gc.field, &omega);
                    b.omega_sd = [var[0].sqrt(), var[1].sqrt(), var[2].sqrt()];
                    b.ill = frame_score(&b.a) < T::of(KELVIN_MIN_SCORE);
                    (var[0] + var[1] + var[2]) / T::of(3.0)
                }
                None => {
                    let (cov_a, ill) = cfg.a_covariance(frame, &b.a, b.jtj.as_ref());
                    b.cov_a = cov_a;
                    b.ill = ill;
                    cov_a.trace() / T::of(3.0)
                }
            };
            *c = Candidate {
                omega,
                omega_var,
                domega: cfg.proj[frame].to_body(&[b.x[3], b.x[4], b.x[5]]),
                fit: b.fit,
            };
        }
        let hint_var = hint.map(|h| (h, T::of(0.0625) * norm2(&h) + T::of(0.01)));
        // Several histories per output only where mirror branches exist and can merge.
        let histories = if cfg.model == Model::FreeFloat && cfg.proj[0].m == 3 {
            2
        } else {
            1
        };
        let Some(choice) =
            self.tracker
                .step(&cands[..nb], dt_t, self.domega_var, hint_var, histories)
        else {
            return self.hold(t, dt_t, record);
        };
        let common = CommonFlags {
            fallback,
            excluded,
            branches: nb as u8,
        };
        let b = &branches[choice.candidate];
        let (lo, hi) = self.out.split_at_mut(1);
        let (prev, est) = if !self.last {
            (&lo[0], &mut hi[0])
        } else {
            (&hi[0], &mut lo[0])
        };
        let prev = self.has_last.then_some(prev);
        cfg.finish(frame, eps, b, &choice.omega, !cfg.options.raw, prev, est);
        common.apply(est, choice.sign_unresolved, choice.branch_ambiguous);
        let sd = &est.sd_domega;
        self.domega_var = (sd[0].sq() + sd[1].sq() + sd[2].sq()) / T::of(3.0);
        if !cfg.options.raw {
            cfg.apply_filtered(est, choice.filtered);
        }
        if let Some(rec) = record {
            rec.t = t;
            rec.valid = true;
            rec.raw = cfg.options.raw;
            rec.n_candidates = nb as u8;
            for (ci, b) in branches.iter().enumerate().take(nb) {
                let e = &mut rec.candidates[ci];
                cfg.finish(frame, eps, b, &cands[ci].omega, false, prev, e);
                common.apply(e, false, false);
            }
            let states = self.tracker.states();
            rec.n_states = states.len() as u8;
            rec.states[..states.len()].copy_from_slice(states);
            rec.best = choice.state as u8;
            rec.forward = *est;
        }
        self.last_t = Some(t);
        self.last = !self.last;
        self.has_last = true;
        &self.out[usize::from(self.last)]
    }

    /// Replaces the algebraic Ω of `est` by a hypothesis' filtered Ω (∫Ω′ fused with the
    /// algebraic Ω) and its deviation; in model F also `A = Γ + {Ω}²`.
    pub fn apply_filtered(&self, est: &mut Estimate<T>, filtered: (Vec3<T>, T)) {
        self.cfg.apply_filtered(est, filtered);
    }

    /// Output when a sample cannot be used: the last estimate propagated by Ω′ over `dt`,
    /// flagged; recorded as invalid for the smoother.
    fn hold(&mut self, t: f64, dt: T, record: Option<&mut StepRecord<T>>) -> &Estimate<T> {
        let last = self.out[usize::from(self.last)];
        let est = &mut self.out[usize::from(!self.last)];
        *est = if self.has_last {
            last
        } else {
            Estimate::default()
        };
        est.omega = [
            est.omega[0] + est.domega[0] * dt,
            est.omega[1] + est.domega[1] * dt,
            est.omega[2] + est.domega[2] * dt,
        ];
        est.flags = Flags(est.flags.0 | Flags::INPUT_INVALID);
        if !self.has_last {
            est.flags = Flags(est.flags.0 | Flags::SIGN_UNRESOLVED);
        }
        if let Some(rec) = record {
            rec.invalidate(t, *est);
        }
        &self.out[usize::from(!self.last)]
    }
}

impl<T: Real, const CAP: usize> Config<T, CAP> {
    /// Validates and precomputes a configuration; on error `self` is unchanged.
    fn configure(
        &mut self,
        arr: &Arrangement<CAP>,
        model: Model,
        mask: ChannelMask,
        options: Options,
    ) -> Result<(), ConfigError> {
        if let Some(w) = options.initial_omega {
            if !w.iter().all(|v| v.is_finite()) {
                return Err(ConfigError::NotFinite {
                    what: "initial omega",
                });
            }
        }
        if !options.gamma.0.iter().all(|v| v.is_finite()) {
            return Err(ConfigError::NotFinite {
                what: "gravity gradient Γ",
            });
        }
        for i in 0..64 {
            if mask.contains(i) && i >= arr.len() {
                return Err(ConfigError::NoSuchChannel { channel: i });
            }
        }
        check_structural(arr, mask, model)?;
        let frames = match model {
            Model::General => NUM_FRAMES,
            Model::FreeFloat => 1,
        };
        // Frame 0 (body axes) decides errors; nothing is changed before it succeeds.
        self.proj[0].build(arr, mask, model, &quat_to_mat(FRAME_QUATERNIONS[0]), 0)?;
        self.usable = [false; NUM_FRAMES];
        self.usable[0] = true;
        for f in 1..frames {
            self.usable[f] = self.proj[f]
                .build(
                    arr,
                    mask,
                    model,
                    &quat_to_mat(FRAME_QUATERNIONS[f]),
                    f as u8,
                )
                .is_ok();
        }
        self.arr = arr.clone();
        self.model = model;
        self.mask = mask;
        self.frames = frames;
        self.options = options;
        self.set_gamma(&options.gamma);
        Ok(())
    }

    /// Γ in the body frame, in every frame `V`, and (model F) its offset `W (s·Γ R)`.
    fn set_gamma(&mut self, gamma: &Sym3<f64>) {
        self.gamma = gamma.cast();
        for f in 0..NUM_FRAMES {
            let v = quat_to_mat(FRAME_QUATERNIONS[f]);
            self.gamma_frame[f] = gamma.rotate(&v).cast();
        }
        // Model F: p_i − s_i·Γ R_i enters the linear solve; precompute W (s·Γ R).
        self.gamma_offset = [T::ZERO; CAP];
        if self.model == Model::FreeFloat {
            let pr = &self.proj[0];
            let mut c = [0.0f64; CAP];
            for (i, ch) in self.arr.channels().iter().enumerate() {
                if self.mask.contains(i) {
                    c[i] = dot(&ch.axis, &gamma.mul_vec(&ch.position));
                }
            }
            for r in 0..pr.k + pr.m {
                let mut acc = 0.0;
                for (i, ci) in c.iter().enumerate().take(self.arr.len()) {
                    acc += pr.wt[i][r].to_f64() * ci;
                }
                self.gamma_offset[r] = T::of(acc);
            }
        }
        self.gamma_offset_nonzero = self.gamma_offset.iter().any(|g| *g != T::ZERO);
    }

    /// Replaces the algebraic Ω of `est` by a hypothesis' filtered Ω and its deviation; in
    /// model F also `A = Γ + {Ω}²` and its deviations.
    fn apply_filtered(&self, est: &mut Estimate<T>, filtered: (Vec3<T>, T)) {
        let (w, var) = filtered;
        est.omega = w;
        let sd = var.max(T::ZERO).sqrt();
        est.sd_omega = [sd, sd, sd];
        if self.model == Model::FreeFloat {
            est.field = self.gamma.add_scaled(T::ONE, &Sym3::skew_squared(&w));
            est.sd_field = crate::linalg::skew_squared_sd_isotropic(&w, var);
        }
    }

    /// Frame whose axes see every component of `w` largest (with hysteresis).
    fn choose_frame(&self, current_frame: usize, w: &Vec3<T>) -> usize {
        let score = |f: usize| frame_score(&self.proj[f].to_frame(w));
        let current = if self.usable[current_frame] {
            score(current_frame)
        } else {
            -T::ONE
        };
        // Good enough (the worst-case score over all directions with these frames is 0.185):
        // keep the frame, no search.
        if current >= T::of(FRAME_KEEP_SCORE) {
            return current_frame;
        }
        let mut best = current_frame;
        let mut best_score = current;
        for f in 0..self.frames {
            if self.usable[f] {
                let s = score(f);
                if s > best_score {
                    best_score = s;
                    best = f;
                }
            }
        }
        if best != current_frame && best_score > T::of(1.15) * current {
            best
        } else if self.usable[current_frame] {
            current_frame
        } else {
            best
        }
    }

    /// ε from the predicted `A` in frame `f`: the sign of `A₁₂ A₁₃ A₂₃` (Appendix, A1).
    fn epsilon(&self, f: usize, w: &Vec3<T>) -> T {
        let wv = self.proj[f].to_frame(w);
        let g = &self.gamma_frame[f].0;
        let prod = (wv[0] * wv[1] + g[3]) * (wv[0] * wv[2] + g[4]) * (wv[1] * wv[2] + g[5]);
        if prod < T::ZERO {
            -T::ONE
        } else {
            T::ONE
        }
    }

    /// The candidate branches in frame `f`; returns their number and whether the fallback
    /// (least squares without an exact real solution) was used.
    fn solve_frame(
        &self,
        f: usize,
        sample: &Sample<'_, T>,
        eps: T,
        scratch: &mut Scratch<T, CAP>,
        out: &mut [Branch<T>; MAX_CANDIDATES],
    ) -> (usize, bool, T) {
        let Sample { p, dt, tracker } = *sample;
        let pr = &self.proj[f];
        let (k, m) = (pr.k, pr.m);
        let n = self.arr.len();
        // y = W p (paper eq. 11 reduced by the SVD), minus the known-Γ term of model F.
        let y = &mut scratch.y;
        let rows = k + m;
        project(&pr.wt, p, n, rows, y);
        if self.gamma_offset_nonzero {
            for (yr, g) in y.iter_mut().zip(self.gamma_offset.iter()).take(rows) {
                *yr -= *g;
            }
        }
        let pe = &mut scratch.pe;
        let forms = &pr.mq[..m];
        let roots = &mut scratch.roots;
        // Roots from `refine` carry their residual and JᵀJ in `scratch`.
        let mut refined = [false; MAX_CANDIDATES];
        let mut nr = 0;
        let mut eps = eps;
        if pr.has_lin_o {
            // Model G: the null-space equations are linear in the off-diagonals of A (frame V);
            // Kelvin's decomposition gives a and ε. One branch (±a), no iteration.
            let mut o = [T::ZERO; 3];
            for (c, oc) in o.iter_mut().enumerate() {
                let mut acc = T::ZERO;
                for e in 0..m {
                    acc += pr.lin_o[c][e] * y[k + e];
                }
                *oc = acc;
            }
            if let Some((a, e)) = crate::quadratic::kelvin(&o) {
                eps = e;
                roots[0] = a;
                nr = 1;
            }
        }
        for e in 0..m {
            pe[e] = eps * y[k + e];
        }
        let rhs = &pe[..m];
        if nr > 0 {
            // Solved above.
        } else if m == 3 {
            let m3 = [pr.mq[0], pr.mq[1], pr.mq[2]];
            let p3 = [pe[0], pe[1], pe[2]];
            let mut cf = [[T::ZERO; 3]; MAX_ROOTS];
            nr = closed_form(&m3, &p3, &mut cf);
            roots[..nr].copy_from_slice(&cf[..nr]);
        } else {
            // One Gauss–Newton run from the best start (the prediction, else the hint, else the
            // linear S = a aᵀ solve) normally suffices: with redundancy the optimum is unique.
            // Only if its residual fails the χ² gate are the other hypotheses' predictions and
            // the linear solve tried as well.
            let starts = &mut scratch.starts;
            let mut ns = 0;
            // The chosen hypothesis' prediction first; the others' only if it fails the gate.
            let best_pred = tracker.predicted_omega(dt);
            if let Some(w) = &best_pred {
                starts[ns] = self.a_from_omega(f, w);
                ns += 1;
            }
            if !tracker.has_history() {
                if let Some(h) = self.options.initial_omega {
                    starts[ns] = self.a_from_omega(f, &[T::of(h[0]), T::of(h[1]), T::of(h[2])]);
                    ns += 1;
                }
            }
            let lin_start = || {
                if !pr.has_lin_s {
                    return None;
                }
                let mut s6 = [T::ZERO; 6];
                for (c, s) in s6.iter_mut().enumerate() {
                    let mut acc = T::ZERO;
                    for e in 0..m {
                        acc += pr.lin_s[c][e] * pe[e];
                    }
                    *s = acc;
                }
                Some(rank_one_factor(&Sym3(s6))).filter(|a| norm2(a) > T::ZERO)
            };
            // The linear start only when there is no prediction (it is added below otherwise,
            // if the prediction's solution fails the gate).
            let mut lin_tried = ns == 0;
            if ns == 0 {
                if let Some(a0) = lin_start() {
                    starts[ns] = a0;
                    ns += 1;
                }
            }
            if ns == 0 {
                // No prediction and no linear start: closed form on the first three equations.
                let m3 = [pr.mq[0], pr.mq[1], pr.mq[2]];
                let p3 = [pe[0], pe[1], pe[2]];
                let mut cf = [[T::ZERO; 3]; MAX_ROOTS];
                let nc = closed_form(&m3, &p3, &mut cf);
                for a in cf.iter().take(nc) {
                    starts[ns] = *a;
                    ns += 1;
                }
            }
            let mut i = 0;
            while i < ns {
                let sol = refine(forms, rhs, &starts[i], GN_ITERATIONS);
                let (mut a, res) = (sol.a, sol.fit);
                canonical_sign(&mut a);
                let dup = roots[..nr].iter().any(|b| {
                    norm2(&crate::linalg::sub(&a, b)) <= T::of(1e-6) * norm2(&a).max(T::EPSILON)
                });
                if !dup && nr < MAX_CANDIDATES && a.iter().all(|v| v.is_finite()) {
                    roots[nr] = a;
                    scratch.fit[nr] = res;
                    scratch.jtj[nr] = sol.jtj;
                    refined[nr] = true;
                    nr += 1;
                }
                if i == 0 && res <= pr.chi2_gate {
                    break;
                }
                if i == 0 {
                    if let Some(w0) = best_pred {
                        let mut preds = [[T::ZERO; 3]; MAX_CANDIDATES];
                        let np = tracker.predictions(dt, &mut preds);
                        let mut added = 0;
                        for w in preds.iter().take(np) {
                            if *w != w0 && added + 1 < MAX_STARTS {
                                starts[ns] = self.a_from_omega(f, w);
                                ns += 1;
                                added += 1;
                            }
                        }
                    }
                }
                if !lin_tried && i + 1 == ns {
                    lin_tried = true;
                    if let Some(a0) = lin_start() {
                        starts[ns] = a0;
                        ns += 1;
                    }
                }
                i += 1;
            }
        }
        let mut fallback = false;
        if nr == 0 {
            // No real solution (noise at low rate): least squares from the prediction or a
            // start of the right size.
            fallback = true;
            let start = match tracker.predicted_omega(dt) {
                Some(w) if norm2(&w) > T::ZERO => self.a_from_omega(f, &w),
                _ => {
                    let mut big = T::ZERO;
                    let mut mnorm = T::ZERO;
                    for e in 0..m {
                        big = big.max(rhs[e].abs());
                        mnorm = mnorm.max(forms[e].0.iter().fold(T::ZERO, |a, v| a.max(v.abs())));
                    }
                    let r = if mnorm > T::ZERO {
                        (big / mnorm).sqrt()
                    } else {
                        T::ZERO
                    };
                    let c = r * T::of(0.577_350_269_189_625_8);
                    [c, c, c]
                }
            };
            let (mut a, _) = gauss_newton(forms, rhs, &start, 2 * GN_ITERATIONS);
            if !a.iter().all(|v| v.is_finite()) {
                a = [T::ZERO; 3];
            }
            roots[0] = a;
            nr = 1;
        }
        for (i, (b, a)) in out.iter_mut().zip(roots.iter()).take(nr).enumerate() {
            let o = crate::linalg::outer6(a);
            copy3(&mut b.a, a);
            for j in 0..k {
                b.x[j] = y[j] - eps * pr.tq[j].quad_outer(&o);
            }
            if refined[i] {
                b.fit = scratch.fit[i];
                let Sym3(j) = &scratch.jtj[i];
                b.jtj = Some(Sym3([j[0], j[1], j[2], j[3], j[4], j[5]]));
            } else {
                b.fit = residual2(forms, rhs, a);
                b.jtj = None;
            }
            b.ill = false;
        }
        (nr, fallback, eps)
    }

    /// `a` in frame `f` that reproduces the field of rate `w` (body): `a = V w` when `Γ` is
    /// negligible (model G with `d ≈ Γ` terms absorbed by the solve), `a = w` in model F.
    fn a_from_omega(&self, f: usize, w: &Vec3<T>) -> Vec3<T> {
        self.proj[f].to_frame(w)
    }

    /// Unsigned Ω (body) of a branch: model F `Ω = a`; model G from `ΩΩᵀ = (A − Γ) − ½ tr(A − Γ) I`.
    #[inline(never)]
    fn omega_of(&self, f: usize, eps: T, b: &Branch<T>) -> Vec3<T> {
        match self.model {
            Model::FreeFloat => b.a,
            Model::General => {
                let v = &self.proj[f].frame;
                mat_t_vec(v, &rank_one_factor(&self.centripetal(f, eps, b)))
            }
        }
    }

    /// `(A − Γ) − ½ tr(A − Γ) I` in frame `f` (= ΩΩᵀ for a rigid body).
    fn centripetal(&self, f: usize, eps: T, b: &Branch<T>) -> Sym3<T> {
        let c = field_in_frame(eps, b).add_scaled(-T::ONE, &self.gamma_frame[f]);
        let h = T::of(0.5) * c.trace();
        let mut m = c;
        m.0[0] -= h;
        m.0[1] -= h;
        m.0[2] -= h;
        m
    }

    /// `cov(a) = (JᵀJ)⁻¹` with `J` rows `2 ε M_k a` (whitened equations: unit noise), and
    /// whether `JᵀJ` is nearly singular. Regularised so that `a = 0` (no rotation) gives large
    /// but finite variances. `jtj`: `JᵀJ` if the solver already formed it.
    #[inline(never)]
    fn a_covariance(&self, f: usize, a: &Vec3<T>, jtj: Option<&Sym3<T>>) -> (Sym3<T>, bool) {
        let pr = &self.proj[f];
        let jtj = match jtj {
            Some(j) => *j,
            None => {
                let mut jtj = Sym3::<T>::zero();
                for mk in pr.mq.iter().take(pr.m) {
                    jtj.add_outer(&scale(T::of(2.0), &mk.mul_vec(a)));
                }
                jtj
            }
        };
        let third = jtj.trace() / T::of(3.0);
        let det = jtj.det();
        let ill = !(det > T::of(ILL_RCOND) * third * third * third);
        let reg = T::of(1e-6) * third + T::of(1e-12);
        let mut jr = jtj;
        for i in 0..3 {
            jr.0[i] += reg;
        }
        let big = T::of(1e12);
        let cov = jr
            .inverse(T::ZERO)
            .unwrap_or(Sym3([big, big, big, T::ZERO, T::ZERO, T::ZERO]));
        (cov, ill)
    }

    /// First-order standard deviations of σ0, Ω′ and Ω (body frame) through `cov(a)`:
    /// `cov(x) = cov0 + H cov(a) Hᵀ` with `H = ∂x/∂a = −2 ε T_j a`.
    /// Ω's deviation only `with_omega` (zero otherwise).
    fn deviations_linearised(
        &self,
        f: usize,
        eps: T,
        b: &Branch<T>,
        omega: &Vec3<T>,
        with_omega: bool,
    ) -> (Vec3<T>, Vec3<T>, Vec3<T>) {
        let pr = &self.proj[f];
        let v = &pr.frame;
        let k = pr.k;
        let cov_a = b.cov_a;
        // σ0 and Ω′ in the body frame: x_c = (Vᵀ y)_c − ε aᵀ T′_c a, so
        // var(x_c) = var0_c + 4 (T′_c a)ᵀ cov(a) (T′_c a) (T′_c: `tq_body`).
        let mut sd6 = [T::ZERO; 6];
        for (c, sd) in sd6.iter_mut().enumerate() {
            let g = pr.tq_body[c].mul_vec(&b.a);
            *sd = (pr.var0_body[c] + T::of(4.0) * cov_a.quad(&g))
                .max(T::ZERO)
                .sqrt();
        }
        let sd_sigma0 = [sd6[0], sd6[1], sd6[2]];
        let sd_domega = [sd6[3], sd6[4], sd6[5]];
        // Standard deviations in the body frame: diag(Vᵀ C V)_k = v_kᵀ C v_k, v_k = column k of V.
        let vcols = [
            [v[0][0], v[1][0], v[2][0]],
            [v[0][1], v[1][1], v[2][1]],
            [v[0][2], v[1][2], v[2][2]],
        ];
        let sd = |c: &Sym3<T>| {
            [
                c.quad(&vcols[0]).max(T::ZERO).sqrt(),
                c.quad(&vcols[1]).max(T::ZERO).sqrt(),
                c.quad(&vcols[2]).max(T::ZERO).sqrt(),
            ]
        };
        let sd_omega = match self.model {
            _ if !with_omega => [T::ZERO; 3],
            Model::FreeFloat => sd(&cov_a),
            Model::General => {
                let wv = mat_vec(v, omega);
                let w2 = norm2(&wv);
                if w2 > T::ZERO {
                    // ∂Ω/∂(a, d) from dΩ = (dM Ω − Ω (Ωᵀ dM Ω)/(2|Ω|²))/|Ω|².
                    let mut jac = [[T::ZERO; 6]; 3];
                    let aw = dot(&b.a, &wv);
                    for i in 0..3 {
                        // da_i: dM = ε(e_i aᵀ + a e_iᵀ).
                        let mut dmw = scale(eps * wv[i], &b.a);
                        dmw[i] += eps * aw;
                        let q = T::of(2.0) * eps * wv[i] * aw;
                        for r in 0..3 {
                            jac[r][i] = (dmw[r] - wv[r] * q / (T::of(2.0) * w2)) / w2;
                        }
                        // dd_i: dM = e_i e_iᵀ − ½ I.
                        let mut dmw = scale(-T::of(0.5), &wv);
                        dmw[i] += wv[i];
                        let q = wv[i] * wv[i] - T::of(0.5) * w2;
                        for r in 0..3 {
                            jac[r][3 + i] = (dmw[r] - wv[r] * q / (T::of(2.0) * w2)) / w2;
                        }
                    }
                    // Joint covariance of (a, d): d = y_d − ε aᵀT a, so cov(d, a) = H_d cov(a)
                    // with H_d rows −2 ε T_j a (j = 6, 7, 8), and
                    // cov(d) = cov0_d + H_d cov(a) H_dᵀ.
                    let ca = cov_a.to_mat();
                    let mut h = [[T::ZERO; 3]; 3];
                    for (r, hr) in h.iter_mut().enumerate().take(k.saturating_sub(6)) {
                        *hr = scale(-T::of(2.0) * eps, &pr.tq[6 + r].mul_vec(&b.a));
                    }
                    let mut cd = pr.cov0[2].to_mat();
                    for r in 0..3 {
                        let hc = mat_t_vec(&ca, &h[r]);
                        for c in 0..3 {
                            cd[r][c] += dot(&hc, &h[c]);
                        }
                    }
                    let mut c6 = [[T::ZERO; 6]; 6];
                    for r in 0..3 {
                        let cda = mat_t_vec(&ca, &h[r]);
                        for c in 0..3 {
                            c6[r][c] = ca[r][c];
                            c6[3 + r][3 + c] = cd[r][c];
                            c6[3 + r][c] = cda[c];
                            c6[c][3 + r] = cda[c];
                        }
                    }
                    // cov(Ω) = J C Jᵀ.
                    let mut jc = [[T::ZERO; 6]; 3];
                    for r in 0..3 {
                        for i in 0..6 {
                            let mut acc = T::ZERO;
                            for j in 0..6 {
                                acc += jac[r][j] * c6[j][i];
                            }
                            jc[r][i] = acc;
                        }
                    }
                    let mut cw = [[T::ZERO; 3]; 3];
                    for r in 0..3 {
                        for s in r..3 {
                            let mut acc = T::ZERO;
                            for i in 0..6 {
                                acc += jc[r][i] * jac[s][i];
                            }
                            cw[r][s] = acc;
                            cw[s][r] = acc;
                        }
                    }
                    sd(&Sym3::from_mat(&cw))
                } else {
                    [T::of(1e6); 3]
                }
            }
        };
        (sd_sigma0, sd_domega, sd_omega)
    }

    /// The full estimate of the chosen branch, with first-order standard deviations, written
    /// to `out`. With `rate_filtered` the parts the rate filter replaces
    /// ([`Config::apply_filtered`]: Ω's deviation, model F's field) are left out. `prev` is
    /// the last estimate, output (flagged) if this one were not finite.
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn finish(
        &self,
        f: usize,
        eps: T,
        b: &Branch<T>,
        omega: &Vec3<T>,
        rate_filtered: bool,
        prev: Option<&Estimate<T>>,
        out: &mut Estimate<T>,
    ) {
        let pr = &self.proj[f];
        let v = &pr.frame;
        let m = pr.m;
        out.sigma0 = pr.to_body(&[b.x[0], b.x[1], b.x[2]]);
        out.domega = pr.to_body(&[b.x[3], b.x[4], b.x[5]]);
        out.omega = *omega;
        match self.model {
            Model::General => {
                out.field = field_in_frame(eps, b).rotate(&transpose(v));
                out.d = [b.x[6], b.x[7], b.x[8]];
            }
            Model::FreeFloat => {
                if !rate_filtered {
                    out.field = self.gamma.add_scaled(T::ONE, &Sym3::skew_squared(&b.a));
                }
                out.d = [T::ZERO; 3];
            }
        }
        let mut flags = 0u16;
        if b.ill {
            flags |= Flags::ILL_CONDITIONED;
        }
        match &pr.general_cov {
            Some(gc) => {
                out.sd_sigma0 = gc.sd_sigma0;
                out.sd_domega = gc.sd_domega;
                out.sd_omega = b.omega_sd;
                out.sd_field = gc.sd_field;
            }
            None => {
                let (s0, sdw, sw) = self.deviations_linearised(f, eps, b, omega, !rate_filtered);
                out.sd_sigma0 = s0;
                out.sd_domega = sdw;
                out.sd_omega = sw;
                out.sd_field = match self.model {
                    // Model F: A = Γ + {Ω}², Ω = a with cov(a) (body frame: V = I).
                    Model::FreeFloat if !rate_filtered => {
                        crate::linalg::skew_squared_sd(omega, &b.cov_a)
                    }
                    Model::FreeFloat => out.sd_field,
                    // Model G without the constant covariance (degenerate frame): not available.
                    Model::General => Sym3([T::of(1e12); 6]),
                };
            }
        }
        let chi2 = b.fit;
        let dof = m.saturating_sub(3);
        if dof > 0 && chi2 > pr.chi2_gate {
            flags |= Flags::RESIDUAL_HIGH;
        }
        out.a = b.a;
        out.frame = f as u8;
        out.epsilon = if eps < T::ZERO { -1 } else { 1 };
        out.flags = Flags(flags);
        out.chi2 = chi2;
        out.dof = dof as u8;
        out.branches = 0;
        if !out.is_finite() {
            // Defensive: never emit NaN. Keep the previous estimate, flagged.
            *out = prev.copied().unwrap_or_default();
            out.flags = Flags(out.flags.0 | Flags::ILL_CONDITIONED | Flags::FALLBACK);
        }
    }
}

/// Flags shared by every branch of one sample.
#[derive(Clone, Copy)]
struct CommonFlags {
    fallback: bool,
    excluded: bool,
    branches: u8,
}

impl CommonFlags {
    fn apply<T: Real>(&self, est: &mut Estimate<T>, sign_unresolved: bool, branch_ambiguous: bool) {
        est.branches = self.branches;
        let mut flags = est.flags.0;
        for (on, bit) in [
            (sign_unresolved, Flags::SIGN_UNRESOLVED),
            (branch_ambiguous, Flags::BRANCH_AMBIGUOUS),
            (self.fallback, Flags::FALLBACK),
            (self.excluded, Flags::CHANNELS_EXCLUDED),
        ] {
            if on {
                flags |= bit;
            }
        }
        est.flags = Flags(flags);
    }
}

/// Model G's field in the branch's frame: `A_V = ε{a}² + diag(d)` (paper section 7).
fn field_in_frame<T: Real>(eps: T, b: &Branch<T>) -> Sym3<T> {
    let mut a = Sym3::skew_squared(&b.a).scaled(eps);
    a.0[0] += b.x[6];
    a.0[1] += b.x[7];
    a.0[2] += b.x[8];
    a
}

/// Frame score of `a` below which Kelvin's decomposition is flagged ill-conditioned.
const KELVIN_MIN_SCORE: f64 = 0.02;

/// Variances of Ω (body frame) from the covariance of A (`[xx, yy, zz, xy, xz, yz]`), by
/// `dΩ = (dM Ω − Ω (Ωᵀ dM Ω)/(2|Ω|²)) / |Ω|²` with `dM = dA − ½ tr(dA) I` (first order of
/// `ΩΩᵀ = A − ½ tr A I`). Large but finite at Ω = 0.
fn omega_variances<T: Real>(c: &[[T; 6]; 6], w: &Vec3<T>) -> Vec3<T> {
    let w2 = norm2(w);
    if !(w2 > T::ZERO) {
        return [T::of(1e12); 3];
    }
    let half = T::of(0.5);
    let two = T::of(2.0);
    // Columns of ∂Ω/∂A for the six components.
    let mut jac = [[T::ZERO; 6]; 3];
    let dmw: [(Vec3<T>, T); 6] = [
        (
            [half * w[0], -half * w[1], -half * w[2]],
            w[0] * w[0] - half * w2,
        ),
        (
            [-half * w[0], half * w[1], -half * w[2]],
            w[1] * w[1] - half * w2,
        ),
        (
            [-half * w[0], -half * w[1], half * w[2]],
            w[2] * w[2] - half * w2,
        ),
        ([w[1], w[0], T::ZERO], two * w[0] * w[1]),
        ([w[2], T::ZERO, w[0]], two * w[0] * w[2]),
        ([T::ZERO, w[2], w[1]], two * w[1] * w[2]),
    ];
    let inv = T::ONE / w2;
    for (col, (d, q)) in dmw.iter().enumerate() {
        let k = *q * half * inv;
        for r in 0..3 {
            jac[r][col] = (d[r] - w[r] * k) * inv;
        }
    }
    // jᵀ C j with C symmetric: the diagonal once, the upper triangle twice.
    let mut var = [T::ZERO; 3];
    for r in 0..3 {
        let j = &jac[r];
        let mut acc = T::ZERO;
        for i in 0..6 {
            let mut inner = T::of(0.5) * c[i][i] * j[i];
            for l in (i + 1)..6 {
                inner += c[i][l] * j[l];
            }
            acc += j[i] * inner;
        }
        var[r] = (T::of(2.0) * acc).max(T::ZERO);
    }
    var
}

/// True if `p` has `n` readings and every included one is finite. One test for the common
/// case (`x·0` is ±0 for finite `x`, NaN otherwise); the mask is consulted only if it fails
/// (a non-finite reading of an excluded channel is allowed).
fn readings_usable<T: Real>(p: &[T], n: usize, mask: ChannelMask) -> bool {
    let Some(p) = p.get(..n) else {
        return false;
    };
    let mut acc = T::ZERO;
    for v in p {
        acc += *v * T::ZERO;
    }
    acc == T::ZERO
        || p.iter()
            .enumerate()
            .all(|(i, v)| v.is_finite() || !mask.contains(i))
}

/// Rows of `W p` accumulated together in [`project`] (in registers on the target).
const PROJECT_CHUNK: usize = 12;

/// `y = W p` for the first `rows` rows, `W` stored by channel (`wt[i]` = column `i`): up to
/// [`PROJECT_CHUNK`] rows at a time, each reading loaded once per chunk and its coefficients
/// contiguous (rows past `rows` are zero in `wt` and discarded).
fn project<T: Real, const CAP: usize>(
    wt: &[[T; CAP]; CAP],
    p: &[T],
    n: usize,
    rows: usize,
    y: &mut [T; CAP],
) {
    let n = n.min(p.len());
    let (p, wt) = (&p[..n], &wt[..n]);
    let rows = rows.min(CAP);
    let mut r0 = 0;
    while r0 + PROJECT_CHUNK <= CAP && r0 < rows {
        let mut acc = [T::ZERO; PROJECT_CHUNK];
        for (col, &pi) in wt.iter().zip(p.iter()) {
            let c = &col[r0..r0 + PROJECT_CHUNK];
            for (a, w) in acc.iter_mut().zip(c.iter()) {
                *a += *w * pi;
            }
        }
        let end = (r0 + PROJECT_CHUNK).min(rows);
        y[r0..end].copy_from_slice(&acc[..end - r0]);
        r0 += PROJECT_CHUNK;
    }
    for (r, yr) in y.iter_mut().enumerate().take(rows).skip(r0) {
        let mut acc = T::ZERO;
        for (col, &pi) in wt.iter().zip(p.iter()) {
            acc += col[r] * pi;
        }
        *yr = acc;
    }
}

/// `min_i |w_i| / |w|`: how well a frame separates the off-diagonals of `{w}²`.
fn frame_score<T: Real>(w: &Vec3<T>) -> T {
    let n = norm2(w).sqrt();
    if !(n > T::ZERO) {
        return T::ZERO;
    }
    w[0].abs().min(w[1].abs()).min(w[2].abs()) / n
}

fn transpose<T: Real>(m: &Mat3<T>) -> Mat3<T> {
    [
        [m[0][0], m[1][0], m[2][0]],
        [m[0][1], m[1][1], m[2][1]],
        [m[0][2], m[1][2], m[2][2]],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn readings_usable_only_when_every_included_reading_is_finite() {
        let all = ChannelMask::all(4);
        assert!(readings_usable(&[1.0f32, -0.0, 3.0, 1e30], 4, all));
        assert!(!readings_usable(&[1.0f32, 2.0, 3.0], 4, all), "too few");
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let p = [1.0f32, bad, 3.0, 4.0];
            assert!(!readings_usable(&p, 4, all));
            // Channel 1 excluded: its reading does not matter.
            assert!(readings_usable(&p, 4, all.without(1)));
            assert!(!readings_usable(&p, 4, all.without(2)));
        }
        // Readings past n are not looked at.
        assert!(readings_usable(
            &[1.0f32, 2.0, f32::NAN],
            2,
            ChannelMask::all(2)
        ));
    }

    #[test]
    fn estimate_finiteness_sees_every_component() {
        let e = Estimate::<f32>::default();
        assert!(e.is_finite());
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let mut x = e;
            x.sd_field.0[5] = bad;
            assert!(!x.is_finite());
            let mut x = e;
            x.sigma0[0] = bad;
            assert!(!x.is_finite());
            let mut x = e;
            x.chi2 = bad;
            assert!(!x.is_finite());
        }
    }

    /// `project` equals the plain product for every row count (chunks and remainder).
    #[test]
    fn project_equals_the_plain_product() {
        const CAP: usize = 32;
        let mut wt = [[0.0f64; CAP]; CAP];
        for (i, col) in wt.iter_mut().enumerate() {
            for (r, w) in col.iter_mut().enumerate() {
                *w = ((i * 7 + r * 13) % 17) as f64 - 8.0 + 0.1 * r as f64;
            }
        }
        let p: Vec<f64> = (0..CAP).map(|i| 0.3 * i as f64 - 2.0).collect();
        for n in [1, 5, 12, 20, 32] {
            for rows in [1, 4, 11, 12, 13, 24, 25, 32] {
                // Rows past `rows` must not leak into y: fill y with a marker.
                let mut y = [7.5f64; CAP];
                project(&wt, &p, n, rows, &mut y);
                for r in 0..CAP {
                    let want = if r < rows {
                        (0..n).map(|i| wt[i][r] * p[i]).sum::<f64>()
                    } else {
                        7.5
                    };
                    assert!((y[r] - want).abs() < 1e-9, "n {n} rows {rows} r {r}");
                }
            }
        }
    }
}
