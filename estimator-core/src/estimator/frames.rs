//! The frames `V` of model G (estimator.md: "Choose V from the predicted A so that the
//! off-diagonals are large"): the precomputed set, the frame chosen from the predicted rate,
//! and ε from the predicted field (paper Appendix, A1).

use super::Config;
use crate::linalg::{norm2, Vec3};
use crate::real::Real;

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

impl<T: Real, const CAP: usize> Config<T, CAP> {
    /// Frame whose axes see every component of `w` largest (with hysteresis).
    pub(super) fn choose_frame(&self, current_frame: usize, w: &Vec3<T>) -> usize {
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
    pub(super) fn epsilon(&self, f: usize, w: &Vec3<T>) -> T {
        let wv = self.proj[f].to_frame(w);
        let g = &self.gamma_frame[f].0;
        let prod = (wv[0] * wv[1] + g[3]) * (wv[0] * wv[2] + g[4]) * (wv[1] * wv[2] + g[5]);
        if prod < T::ZERO {
            -T::ONE
        } else {
            T::ONE
        }
    }

    /// `a` in frame `f` that reproduces the field of rate `w` (body): `a = V w` when `Γ` is
    /// negligible (model G with `d ≈ Γ` terms absorbed by the solve), `a = w` in model F.
    pub(super) fn a_from_omega(&self, f: usize, w: &Vec3<T>) -> Vec3<T> {
        self.proj[f].to_frame(w)
    }
}

/// `min_i |w_i| / |w|`: how well a frame separates the off-diagonals of `{w}²`.
pub(super) fn frame_score<T: Real>(w: &Vec3<T>) -> T {
    let n = norm2(w).sqrt();
    if !(n > T::ZERO) {
        return T::ZERO;
    }
    w[0].abs().min(w[1].abs()).min(w[2].abs()) / n
}
