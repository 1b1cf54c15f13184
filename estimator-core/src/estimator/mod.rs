//! The estimator: configuration (precomputation) and the per-sample solve.
//!
//! Per sample (no SVD, no allocation): `y = W p` (one matrix–vector product), the `a` solve
//! from the `m` null-space equations, `x = G⁺(p − ε q(a))` as `y_lin − ε [aᵀ T_j a]` for each
//! branch, branch and sign tracking, first-order standard deviations of the chosen branch, and
//! (unless raw) the rate filter.

//! One concept per file:
//! - [`config`]: the options, validation and precomputation of a configuration;
//! - [`frames`]: the frames `V` of model G and the choice among them;
//! - [`solve`]: one frame's per-sample solve (`W p`, the `a` solve, the branches);
//! - [`deviations`]: `cov(a)` and the standard deviations;
//! - [`output`]: the estimate of the chosen branch.
//!
//! Branch and sign are the tracker's (`internals::tracker`: one multiple-hypothesis (Ω, Ω′)
//! filter). This file holds the state (configuration, working storage, tracker, output slots)
//! and the per-sample sequence that ties them together.

mod config;
mod deviations;
mod frames;
mod output;
mod solve;

pub use config::{Options, DEFAULT_JERK_DENSITY};
pub use frames::{FRAME_QUATERNIONS, NUM_FRAMES};

use crate::arrangement::{Arrangement, ChannelMask, Model};
use crate::design::Projection;
use crate::error::ConfigError;
use crate::estimate::{Estimate, Flags};
use crate::frame_uncertainty::FrameUncertainty;
use crate::integrity::Protection;
use crate::linalg::{norm2, Sym3, Vec3};
use crate::real::Real;
use crate::svd::MAX_COLS;
use crate::tracker::{Candidate, Measured, Readings, Tracker, MAX_CANDIDATES};

use crate::quadratic::MAX_ROOTS;
use deviations::{omega_variances, widen_near_crossings, KELVIN_MIN_SCORE};
use frames::frame_score;
use output::CommonFlags;
use solve::{readings_usable, MAX_STARTS};

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
    /// The slot of `out` holding the last estimate (0 or 1).
    last: usize,
    has_last: bool,
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
    /// Model F: the known Γ's part of `y = W p`, `W (scale · s·Γ R)` (frame 0; the
    /// `1 / scale` is in `W`), taken off `y`.
    gamma_offset: [T; CAP],
    gamma_offset_nonzero: bool,
    /// The calibrated frame's common errors, added to the reported deviations.
    frame_uncertainty: FrameUncertainty<T>,
    /// Whether the frame uncertainty is other than zero.
    widen: bool,
    options: Options,
    /// The protection levels' gains (with redundancy; model F's linearised per row).
    integrity: Option<Protection<T, CAP>>,
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

impl<T: Real, const CAP: usize> Config<T, CAP> {
    /// The tracker's candidates of one sample from its `branches` in `frame` (`eps`: the
    /// frame's scaling): Ω with its covariance, Ω′ in body axes with its variance, the fit.
    #[inline]
    fn candidates(
        &self,
        frame: usize,
        eps: T,
        branches: &mut [Branch<T>],
        cands: &mut [Candidate<T>; MAX_CANDIDATES],
    ) {
        for (c, b) in cands.iter_mut().zip(branches.iter_mut()) {
            let omega = self.omega_of(frame, eps, b);
            let (omega_cov, domega_var) = match &self.proj[frame].general_cov {
                Some(gc) => {
                    // Model G: A is linear in p, its covariance a constant; Ω's follows from it.
                    let var = omega_variances(&gc.field, &omega);
                    b.omega_sd = [var[0].sqrt(), var[1].sqrt(), var[2].sqrt()];
                    b.ill = frame_score(&b.a) < T::of(KELVIN_MIN_SCORE);
                    let z = T::ZERO;
                    let sd = &gc.sd_domega;
                    let domega_var = (sd[0] * sd[0] + sd[1] * sd[1] + sd[2] * sd[2]) / T::of(3.0);
                    // Isotropic, at the largest: near Ω = 0 the first-order variances of Ω from
                    // ΩΩᵀ are not valid component by component (a spin-up from rest: 17 rows
                    // of the firmware's output silently wrong with the diagonal, none with its
                    // mean; 1 of `ballisto estimate`'s with the mean, none with the largest).
                    let m = var[0].max(var[1]).max(var[2]);
                    (Sym3([m, m, m, z, z, z]), domega_var)
                }
                None => (b.cov_a, self.domega_variance(frame, b)),
            };
            *c = Candidate {
                omega,
                omega_cov,
                domega: self.proj[frame].to_body(&[b.x[3], b.x[4], b.x[5]]),
                domega_var,
                fit: b.fit,
            };
        }
    }
}

impl<T: Real, const CAP: usize> Config<T, CAP> {
    /// A configuration with no channel (nothing precomputed).
    fn empty(model: Model) -> Self {
        Config {
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
            frame_uncertainty: FrameUncertainty::default(),
            widen: false,
            options: Options::default(),
            integrity: None,
        }
    }
}

/// A second configuration, set aside (double buffering): when exclusions switch the
/// estimator from model G to model F ([`Estimator::set_mask_keeping`]), model G's
/// configuration is kept here, and the return to it is a swap instead of a precomputation
/// (model G's four frames: 7.4 million instructions on the M4F, `cargo qemu-bench`; on the
/// QEMU board the return stalled the sample loop for 1.24 s, 124 sets dropped).
pub struct SpareConfig<T: Real, const CAP: usize> {
    cfg: Config<T, CAP>,
}

impl<T: Real, const CAP: usize> Default for SpareConfig<T, CAP> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real, const CAP: usize> SpareConfig<T, CAP> {
    /// An empty slot.
    pub fn new() -> Self {
        SpareConfig {
            cfg: Config::empty(Model::General),
        }
    }

    /// Forgets the configuration set aside (call it when the arrangement or the options
    /// change: it would bring back the old ones).
    pub fn clear(&mut self) {
        self.cfg.frames = 0;
    }

    /// The model and channels of the configuration set aside (`None` if there is none).
    pub fn holds(&self) -> Option<(Model, ChannelMask)> {
        (self.cfg.frames > 0).then_some((self.cfg.model, self.cfg.mask))
    }

    /// Builds a configuration in this slot — the precomputation of
    /// [`Estimator::configure_preferring`] — without touching any estimator, so that it can run
    /// while the estimator in force goes on estimating (issue 17: the firmware builds it in a
    /// lower-priority task); [`Estimator::swap_in`] then puts it in force. Returns the model
    /// built (model F where `mask` does not carry the `preferred` model G). On error the slot
    /// keeps what it held.
    pub fn build(
        &mut self,
        arr: &Arrangement<CAP>,
        preferred: Model,
        mask: ChannelMask,
        options: Options,
    ) -> Result<Model, ConfigError> {
        self.cfg.configure_preferring(arr, preferred, mask, options)
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
            cfg: Config::empty(model),
            frame: 0,
            tracker: Tracker::new(T::of(options.jerk_density)),
            last_t: None,
            out: [Estimate::default(); 2],
            last: 0,
            has_last: false,
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

    /// Takes the channels of `mask` in the `preferred` model if they carry it, and otherwise in
    /// model F (issue 17: where exclusions leave model G unobservable — fewer than 12 channels,
    /// or a design of rank below 12 — model F, whose `A = Γ + {Ω}²` needs 9 and the known Γ of
    /// the options, still estimates). Returns the model now in force; on error (neither model
    /// can use the channels) nothing changes and the error is the preferred model's. Like
    /// [`Estimator::set_mask`] it restarts the history: set the hint after it.
    pub fn set_mask_in(
        &mut self,
        mask: ChannelMask,
        preferred: Model,
    ) -> Result<Model, ConfigError> {
        let arr = self.cfg.arr.clone();
        self.configure_preferring(&arr, preferred, mask, self.cfg.options)
    }

    /// [`Estimator::configure`] in the `preferred` model, or in model F where the channels of
    /// `mask` do not carry model G (as [`Estimator::set_mask_in`], with a new arrangement and
    /// options); returns the model now in force. On error nothing changes.
    pub fn configure_preferring(
        &mut self,
        arr: &Arrangement<CAP>,
        preferred: Model,
        mask: ChannelMask,
        options: Options,
    ) -> Result<Model, ConfigError> {
        let model = self
            .cfg
            .configure_preferring(arr, preferred, mask, options)?;
        self.frame = 0;
        self.reset();
        Ok(model)
    }

    /// As [`Estimator::set_mask_in`], with `spare` as the second buffer: the configuration in
    /// force is set aside there before the new one is built (one swap, no copy), so that a
    /// switch from model G to model F keeps model G's; and where `spare` already holds the
    /// `preferred` model for `mask` while another model is in force, that configuration is
    /// swapped back in without a precomputation. History restarts as with `set_mask_in`; on
    /// error nothing changes.
    pub fn set_mask_keeping(
        &mut self,
        mask: ChannelMask,
        preferred: Model,
        spare: &mut SpareConfig<T, CAP>,
    ) -> Result<Model, ConfigError> {
        let back = self.cfg.model != preferred && spare.holds() == Some((preferred, mask));
        core::mem::swap(&mut self.cfg, &mut spare.cfg);
        let model = if back {
            preferred
        } else {
            let (arr, options) = (&spare.cfg.arr, spare.cfg.options);
            match self.cfg.configure_preferring(arr, preferred, mask, options) {
                Ok(model) => model,
                Err(e) => {
                    core::mem::swap(&mut self.cfg, &mut spare.cfg);
                    return Err(e);
                }
            }
        };
        self.frame = 0;
        self.reset();
        Ok(model)
    }

    /// Puts the configuration of `spare` in force and sets the one in force aside there (one
    /// swap of the two buffers, no precomputation), restarting the history as a mask change
    /// does; returns the model now in force. `None`, and nothing changes, if `spare` holds no
    /// configuration.
    pub fn swap_in(&mut self, spare: &mut SpareConfig<T, CAP>) -> Option<Model> {
        spare.holds()?;
        core::mem::swap(&mut self.cfg, &mut spare.cfg);
        self.frame = 0;
        self.reset();
        Some(self.cfg.model)
    }

    /// The options in force (those of the last configuration).
    pub fn options(&self) -> Options {
        self.cfg.options
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
        self.tracker.set_jerk(T::of(self.cfg.options.jerk_density));
        self.last_t = None;
        self.has_last = false;
    }

    /// The model in use.
    pub fn model(&self) -> Model {
        self.cfg.model
    }

    /// The arrangement in use.
    pub fn arrangement(&self) -> &Arrangement<CAP> {
        &self.cfg.arr
    }

    /// The frame uncertainty in force, in the sample-loop scalar (zero unless the
    /// arrangement sets one).
    pub fn frame_uncertainty(&self) -> FrameUncertainty<T> {
        self.cfg.frame_uncertainty
    }

    /// The channel mask in use.
    pub fn mask(&self) -> ChannelMask {
        self.cfg.mask
    }

    /// Equilibrated condition number of the design matrix of frame `f` (None if unusable).
    pub fn condition(&self, f: usize) -> Option<f64> {
        (f < self.cfg.frames && self.cfg.usable[f]).then(|| self.cfg.proj[f].condition)
    }

    /// Model G: the covariance of A's components (body frame, `[xx, yy, zz, xy, xz, yz]`, s⁻⁴;
    /// a constant of the arrangement and mask); `None` in model F.
    pub fn field_covariance(&self) -> Option<[[T; 6]; 6]> {
        self.cfg.proj[0].general_cov.as_ref().map(|g| g.field)
    }

    /// The gravity-gradient tensor Γ the options give (body frame; model F's known field).
    pub fn known_gamma(&self) -> Sym3<f64> {
        self.cfg.options.gamma
    }

    /// Degrees of freedom of the residual (`N − 12` in model G, `N − 9` in model F).
    pub fn dof(&self) -> usize {
        self.cfg.proj[0].m.saturating_sub(3)
    }

    /// One sample set: `p[i]` is channel `i`'s specific force (m/s²) at time `t` (s).
    /// Never panics; never returns NaN (a non-finite reading gives the prediction, flagged).
    ///
    /// The returned deviations include the arrangement's frame uncertainty
    /// ([`Arrangement::set_frame_uncertainty`]).
    pub fn update(&mut self, t: f64, p: &[T]) -> &Estimate<T> {
        let (slot, solved) = self.solve_sample(t, p);
        // In place: a new estimate is widened once; a held one is the last output, widened
        // already.
        let est = &mut self.out[slot];
        if self.cfg.widen && solved {
            self.cfg.frame_uncertainty.widen(est);
        }
        self.cfg.protect(est, solved);
        &self.out[slot]
    }

    /// The solve of one sample; returns the slot of `out` holding its estimate and whether
    /// it is a new one (false: the last one held, for an unusable sample).
    #[inline(never)]
    fn solve_sample(&mut self, t: f64, p: &[T]) -> (usize, bool) {
        let cfg = &self.cfg;
        let n = cfg.arr.len();
        let input_ok = readings_usable(p, n, cfg.mask) && t.is_finite();
        let dt = match self.last_t {
            Some(t0) if t > t0 && (t - t0).is_finite() => t - t0,
            _ => 0.0,
        };
        let dt_t = T::of(dt);
        if !input_ok {
            return (self.hold(dt_t), false);
        }
        let excluded = !cfg.mask.holds_all(n);
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
        if cfg.proj[frame].general_cov.is_none() {
            for b in branches.iter_mut().take(nb) {
                (b.cov_a, b.ill) = cfg.a_covariance(frame, &b.a, b.jtj.as_ref());
            }
            if cfg.model == Model::FreeFloat {
                widen_near_crossings(&mut branches[..nb]);
            }
        }
        cfg.candidates(frame, eps, &mut branches[..nb], cands);
        let hint_var = hint.map(|h| (h, T::of(0.0625) * norm2(&h) + T::of(0.01)));
        // Model F with m = 3 (several roots, crossing): the readings each track is updated by
        // (`Ω = a`): the null-space equations and the linear solve's Ω′ rows (their values
        // from any root: `y = Ω′ + [aᵀTⱼa]`). With m > 3 the root is unique: as in model G.
        let pr = &cfg.proj[frame];
        let measured = match cfg.model {
            Model::FreeFloat if nb > 0 && pr.m == 3 => {
                let (b, c) = (&branches[0], &cands[0]);
                let t = [pr.tq_body[3], pr.tq_body[4], pr.tq_body[5]];
                let mut y = c.domega;
                for (yj, tj) in y.iter_mut().zip(t.iter()) {
                    *yj += tj.quad(&b.a);
                }
                Measured::Readings(Readings {
                    forms: [pr.mq[0], pr.mq[1], pr.mq[2]],
                    pe: [scratch.pe[0], scratch.pe[1], scratch.pe[2]],
                    y,
                    t,
                    var0: [pr.var0_body[3], pr.var0_body[4], pr.var0_body[5]],
                })
            }
            _ => Measured::Roots,
        };
        let Some(choice) = self.tracker.step(&cands[..nb], measured, dt_t, hint_var) else {
            return (self.hold(dt_t), false);
        };
        let common = CommonFlags {
            fallback,
            excluded,
            branches: nb as u8,
        };
        let b = &branches[choice.candidate];
        let (lo, hi) = self.out.split_at_mut(1);
        let (prev, est) = if self.last == 0 {
            (&lo[0], &mut hi[0])
        } else {
            (&hi[0], &mut lo[0])
        };
        let prev = self.has_last.then_some(prev);
        cfg.finish(frame, eps, b, &choice.omega, !cfg.options.raw, prev, est);
        common.apply(est, choice.sign_unresolved, choice.branch_ambiguous);
        est.branch_margin = choice.branch_margin;
        if !cfg.options.raw {
            cfg.apply_filtered(est, choice.filtered);
        }
        self.last_t = Some(t);
        self.last = 1 - self.last;
        self.has_last = true;
        (self.last, true)
    }

    /// Output when a sample cannot be used: the last estimate propagated by Ω′ over `dt`,
    /// flagged.
    fn hold(&mut self, dt: T) -> usize {
        let last = self.out[self.last];
        let est = &mut self.out[1 - self.last];
        *est = if self.has_last {
            last
        } else {
            // Nothing known: no other branch in the tracker's memory either (a margin of 0
            // would contradict the absent branch flag).
            Estimate {
                branch_margin: T::of(crate::tracker::COST_CAP),
                ..Estimate::default()
            }
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
        1 - self.last
    }
}
