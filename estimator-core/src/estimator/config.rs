//! The configuration and its precomputation (paper eq. 10–11 per frame): validated as a whole;
//! on error the configuration in force stays untouched.

use super::frames::{FRAME_QUATERNIONS, NUM_FRAMES};
use super::Config;
use crate::arrangement::{Arrangement, ChannelMask, Model};
use crate::design::check_structural;
use crate::error::ConfigError;
use crate::integrity::{Protection, DEFAULT_MISSED};
use crate::linalg::{dot, quat_to_mat, Sym3};
use crate::real::Real;

/// Options of the estimator.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Per-sample output without the rate filter (continuity is still used for branch and sign).
    pub raw: bool,
    /// Approximate Ω at the first sample (settles sign and starting branch).
    pub initial_omega: Option<[f64; 3]>,
    /// Gravity-gradient tensor Γ (body frame), known; default 0.
    pub gamma: Sym3<f64>,
    /// Density of the white angular jerk that drives the branch and sign filter's Ω′
    /// (rad²/s⁵; `internals::tracker`): how fast Ω′ may wander, a property of the motion and not
    /// of the sample rate (its variance over a step Δ is this times Δ). Default
    /// [`DEFAULT_JERK_DENSITY`].
    pub jerk_density: f64,
    /// The probability that an output's error exceeds its protection level at a row
    /// ([`crate::integrity`]); default [`DEFAULT_MISSED`].
    pub missed: f64,
    /// Alert limits of σ0 (m/s²), Ω′ (rad/s²) and Ω (rad/s): a protection level above its
    /// limit (or none where a limit is finite) sets [`crate::Flags::INTEGRITY_ALERT`]. Default
    /// infinite: no alert.
    pub alert_limits: [f64; 3],
    /// Whether the protection levels are computed where the channel set allows them (default
    /// true). Off, no row carries one (and a finite alert limit alerts): for a unit whose
    /// processor cannot afford model F's per-set gains (≈ 8 000 instructions per set on a
    /// Cortex-M4F at N = 12, `docs/validation.md`).
    pub protection: bool,
}

/// The default white-jerk density (rad²/s⁵): Ω′ wanders by ≈ 10 rad/s² RMS in a second, which
/// holds the scenarios' tumbles and manoeuvres (jerk up to ≈ 30 rad/s³) and hand-held motion
/// while the filter still averages Ω′ over tens of milliseconds.
pub const DEFAULT_JERK_DENSITY: f64 = 100.0;

impl Default for Options {
    fn default() -> Self {
        Options {
            raw: false,
            initial_omega: None,
            gamma: Sym3::zero(),
            jerk_density: DEFAULT_JERK_DENSITY,
            missed: DEFAULT_MISSED,
            alert_limits: [f64::INFINITY; 3],
            protection: true,
        }
    }
}

impl<T: Real, const CAP: usize> Config<T, CAP> {
    /// [`Config::configure`] in the `preferred` model, or in model F where the channels of
    /// `mask` do not carry model G; returns the model built. On error `self` is
    /// unchanged and the error is the preferred model's.
    pub(super) fn configure_preferring(
        &mut self,
        arr: &Arrangement<CAP>,
        preferred: Model,
        mask: ChannelMask,
        options: Options,
    ) -> Result<Model, ConfigError> {
        match self.configure(arr, preferred, mask, options) {
            Ok(()) => Ok(preferred),
            Err(e) if preferred == Model::General => self
                .configure(arr, Model::FreeFloat, mask, options)
                .map(|()| Model::FreeFloat)
                .map_err(|_| e),
            Err(e) => Err(e),
        }
    }

    /// Validates and precomputes a configuration; on error `self` is unchanged.
    pub(super) fn configure(
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
        if !(options.jerk_density.is_finite() && options.jerk_density > 0.0) {
            return Err(ConfigError::NotPositive {
                what: "jerk density",
            });
        }
        if !(options.missed > 0.0 && options.missed < 1.0) {
            return Err(ConfigError::NotProbability {
                what: "missed probability",
            });
        }
        if !options.alert_limits.iter().all(|v| *v > 0.0) {
            return Err(ConfigError::NotPositive {
                what: "alert limit",
            });
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
        self.frame_uncertainty = arr.frame_uncertainty().cast();
        self.widen = !self.frame_uncertainty.is_zero();
        self.model = model;
        self.mask = mask;
        self.frames = frames;
        self.options = options;
        self.integrity = options
            .protection
            .then(|| Protection::build(arr, mask, model, options.missed))
            .flatten();
        self.set_gamma(&options.gamma);
        Ok(())
    }

    /// Γ in the body frame, in every frame `V`, and (model F) its offset `W (scale · s·Γ R)`
    /// (a channel reads `scale · s·(σ0 + … + Γ R) + bias`; `W` carries the `1 / scale`).
    pub(super) fn set_gamma(&mut self, gamma: &Sym3<f64>) {
        self.gamma = gamma.cast();
        for f in 0..NUM_FRAMES {
            let v = quat_to_mat(FRAME_QUATERNIONS[f]);
            self.gamma_frame[f] = gamma.rotate(&v).cast();
        }
        self.gamma_offset = [T::ZERO; CAP];
        if self.model == Model::FreeFloat {
            let pr = &self.proj[0];
            let mut c = [0.0f64; CAP];
            for (i, ch) in self.arr.channels().iter().enumerate() {
                if self.mask.contains(i) {
                    c[i] = ch.scale * dot(&ch.axis, &gamma.mul_vec(&ch.position));
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
}
