//! A channel's bias against its temperature across identification windows: how
//! identification in flight tracks the bias coefficient through an orbit's thermal cycle.
//!
//! Every window solved in flight (paper §6, [`crate::identify`]) gives each channel's bias `b̂`
//! with its standard deviation, for the readings as the estimator got them (brought to `t_ref`
//! by the coefficients in use, [`super::Thermal`]), over a window whose parts stood at a mean
//! temperature `T̄`. If the coefficient in use is off by `δ`, the bias found is
//! `b(t_ref) + δ·(T̄ − t_ref)`: a straight line in `T̄`. The track keeps, per channel, the sums of
//! the weighted least squares of that line (weights `1/sd²`; six numbers, no window kept) and
//! gives the line's bias at a chosen `t_ref` and slope, with standard deviations scaled up by
//! the scatter about the line where it exceeds what the windows' own deviations explain.
//!
//! The scale's coefficient is not tracked: in free flight a channel's scale is one product
//! with its lever arm (`identify`, `ALWAYS_HELD`), and the part of the lever arm that would
//! move with temperature is not told apart from the structure's own expansion (≈ 2e-5 /°C for
//! aluminium, the order of a datasheet's scale coefficient).

use super::{plausible, MIN_SPAN_C};

/// The fewest windows from which a channel's line is taken: two give a line that explains
/// them exactly, a third is the first check of it.
pub const MIN_WINDOWS: u16 = 3;

/// One channel's weighted sums, with temperatures and biases taken from the first window's
/// (`t0`, `b0`) so that the sums do not cancel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Sums {
    windows: u16,
    t0: f64,
    b0: f64,
    w: f64,
    wt: f64,
    wtt: f64,
    wb: f64,
    wtb: f64,
    wbb: f64,
    lo: f64,
    hi: f64,
}

/// The line a channel's windows give: `bias + bias_tc·(T − t_ref)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    /// The temperature `bias` refers to (°C).
    pub t_ref: f64,
    /// The bias at `t_ref` (m/s²).
    pub bias: f64,
    /// Its standard deviation (m/s²).
    pub bias_sd: f64,
    /// The slope (m/s² per °C): the coefficient in use is off by this much.
    pub bias_tc: f64,
    /// Its standard deviation (m/s² per °C).
    pub bias_tc_sd: f64,
    /// Windows behind the line.
    pub windows: u16,
    /// Their mean temperatures' span (°C).
    pub span: f64,
    /// The scatter about the line over what the windows' deviations explain (χ² per degree
    /// of freedom; NaN with two windows). Where above 1 the deviations above are scaled by its
    /// square root.
    pub scatter: f64,
}

impl Line {
    /// Whether the windows decide the line: at least [`MIN_WINDOWS`] over at least
    /// [`MIN_SPAN_C`] (the ground calibration's span).
    pub fn determined(&self) -> bool {
        self.windows >= MIN_WINDOWS && self.span >= MIN_SPAN_C
    }
}

/// The sums of `N` channels.
#[derive(Clone, Debug)]
pub struct Track<const N: usize> {
    sums: [Sums; N],
}

impl<const N: usize> Default for Track<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Track<N> {
    /// No window.
    pub const fn new() -> Self {
        Track {
            sums: [Sums {
                windows: 0,
                t0: 0.0,
                b0: 0.0,
                w: 0.0,
                wt: 0.0,
                wtt: 0.0,
                wb: 0.0,
                wtb: 0.0,
                wbb: 0.0,
                lo: 0.0,
                hi: 0.0,
            }; N],
        }
    }

    /// Forgets every window.
    pub fn clear(&mut self) {
        *self = Self::new();
    }

    /// A window's bias `bias` (m/s², standard deviation `sd`) for channel `channel` at the
    /// window's mean temperature `t` (°C). Returns whether it was taken: not for a channel
    /// beyond `N`, a temperature not [`plausible`], a bias not finite or a deviation not
    /// positive and finite.
    pub fn add(&mut self, channel: usize, t: f64, bias: f64, sd: f64) -> bool {
        let Some(s) = self.sums.get_mut(channel) else {
            return false;
        };
        if !(plausible(t) && bias.is_finite() && sd.is_finite() && sd > 0.0) {
            return false;
        }
        if s.windows == 0 {
            *s = Sums {
                t0: t,
                b0: bias,
                lo: t,
                hi: t,
                ..Sums::default()
            };
        }
        let w = 1.0 / (sd * sd);
        let (x, y) = (t - s.t0, bias - s.b0);
        s.windows = s.windows.saturating_add(1);
        s.w += w;
        s.wt += w * x;
        s.wtt += w * x * x;
        s.wb += w * y;
        s.wtb += w * x * y;
        s.wbb += w * y * y;
        s.lo = s.lo.min(t);
        s.hi = s.hi.max(t);
        true
    }

    /// Windows taken for channel `channel`.
    pub fn windows(&self, channel: usize) -> u16 {
        self.sums.get(channel).map_or(0, |s| s.windows)
    }

    /// Channel `channel`'s line with its bias at `t_ref` (°C; `None`: at the windows' weighted
    /// mean temperature, where bias and slope are uncorrelated). `None` with fewer than two
    /// windows or no temperature span between them.
    pub fn line(&self, channel: usize, t_ref: Option<f64>) -> Option<Line> {
        let s = self.sums.get(channel)?;
        if s.windows < 2 || !(s.w > 0.0) {
            return None;
        }
        // Centred sums (weighted mean of the shifted temperatures and biases).
        let (xm, ym) = (s.wt / s.w, s.wb / s.w);
        let sxx = s.wtt - s.wt * xm;
        let sxy = s.wtb - s.wt * ym;
        let syy = s.wbb - s.wb * ym;
        if !(sxx > 0.0) || s.hi - s.lo <= 0.0 {
            return None;
        }
        let slope = sxy / sxx;
        let chi2 = (syy - slope * sxy).max(0.0);
        let scatter = if s.windows > 2 {
            chi2 / f64::from(s.windows - 2)
        } else {
            f64::NAN
        };
        let k2 = if scatter > 1.0 { scatter } else { 1.0 };
        let t_mean = s.t0 + xm;
        let t_ref = t_ref.unwrap_or(t_mean);
        let dt = t_ref - t_mean;
        Some(Line {
            t_ref,
            bias: s.b0 + ym + slope * dt,
            bias_sd: libm::sqrt(k2 * (1.0 / s.w + dt * dt / sxx)),
            bias_tc: slope,
            bias_tc_sd: libm::sqrt(k2 / sxx),
            windows: s.windows,
            span: s.hi - s.lo,
            scatter,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Windows on a known line with deviations drawn at their stated size give the line
    /// back within a few of the deviations it states.
    #[test]
    fn windows_on_a_line_give_it_back() {
        let (b_ref, slope, t_ref) = (0.0812, 1.3e-3, 25.0);
        let mut track = Track::<2>::new();
        // A deterministic spread of ±1 sd (sum zero).
        let wobble = [0.7, -1.1, 0.4, 1.2, -0.9, -0.3];
        let sd = 2e-5;
        for (k, w) in wobble.iter().enumerate() {
            let t = 4.0 + 6.5 * k as f64;
            let b = b_ref + slope * (t - t_ref) + w * sd;
            assert!(track.add(0, t, b, sd));
        }
        let line = track.line(0, Some(t_ref)).unwrap();
        assert!(line.determined());
        assert_eq!(line.windows, 6);
        assert!((line.span - 32.5).abs() < 1e-12);
        assert!((line.bias - b_ref).abs() < 3.0 * line.bias_sd, "{line:?}");
        assert!(
            (line.bias_tc - slope).abs() < 3.0 * line.bias_tc_sd,
            "{line:?}"
        );
        assert!(line.bias_tc_sd < 2e-6 && line.scatter < 2.0, "{line:?}");
        // At the weighted mean temperature by default.
        let mid = track.line(0, None).unwrap();
        assert!((mid.t_ref - 20.25).abs() < 1e-9);
        assert!(mid.bias_sd <= line.bias_sd);
        // Channel 1 saw nothing; one window is no line.
        assert!(track.line(1, None).is_none());
        assert!(track.add(1, 10.0, 0.1, sd));
        assert!(track.line(1, None).is_none());
    }

    /// Scatter beyond the windows' deviations widens the line's; a narrow span or two windows
    /// do not decide it; refused inputs leave the sums alone.
    #[test]
    fn what_the_windows_cannot_decide_is_said() {
        let mut track = Track::<1>::new();
        let sd = 1e-5;
        for (t, w) in [(10.0, 30.0), (20.0, -30.0), (30.0, 30.0), (40.0, -30.0)] {
            assert!(track.add(0, t, 0.05 + w * sd, sd));
        }
        let line = track.line(0, Some(25.0)).unwrap();
        assert!(line.scatter > 100.0, "{line:?}");
        // The deviations alone would give sd/√500 per °C for this spread of temperatures.
        let unscaled = sd / 500f64.sqrt();
        assert!(line.bias_tc_sd > 20.0 * unscaled, "{line:?}");
        let mut two = Track::<1>::new();
        two.add(0, 10.0, 0.05, sd);
        two.add(0, 40.0, 0.06, sd);
        let l = two.line(0, None).unwrap();
        assert!(!l.determined() && l.scatter.is_nan());
        let mut narrow = Track::<1>::new();
        for t in [20.0, 23.0, 26.0, 29.0] {
            narrow.add(0, t, 0.05, sd);
        }
        assert!(!narrow.line(0, None).unwrap().determined());
        let before = narrow.clone().line(0, None);
        assert!(!narrow.add(0, f64::NAN, 0.05, sd));
        assert!(!narrow.add(0, 300.0, 0.05, sd));
        assert!(!narrow.add(0, 20.0, f64::INFINITY, sd));
        assert!(!narrow.add(0, 20.0, 0.05, 0.0));
        assert!(!narrow.add(1, 20.0, 0.05, sd));
        assert_eq!(narrow.line(0, None), before);
        narrow.clear();
        assert_eq!(narrow.windows(0), 0);
    }
}
