//! A window without a reference (TC[200,8] source 2): the sets of a torque-free tumble kept,
//! each with the estimator's rate, and solved by estimator-core's `identify_tumble` (the start
//! rate searched, Euler's equations carrying it to every kept set, each channel's geometry
//! solved at every trial; paper §6).
//!
//! Every evaluation of the search runs over all kept sets, so they are kept, not summed. A
//! window needs all of its length, not a sample of it (measured on 12 drawn tumbles: a set
//! every 100 ms of 20 s, or every 250 ms of 60 s, identified 2–3 where the whole 60 s record
//! identified 8), so the unit keeps the **means** of consecutive sets over `period_ms`, in at
//! most [`TUMBLE_FLOATS`] numbers (128 KiB); a window that would not fit is refused when it is
//! started, naming the longest that does ([`longest_window_ms`]). A mean of `k` sets has the
//! noise of one over `√k`, which the search is told. The search takes a mean for the motion at
//! its mid-time: the motion's curvature moves it by `f″T²/24` over a mean of `T` s — at
//! 2 rad/s and 40 ms about 3·10⁻⁴ m/s², a third of an ADXL355's noise over that mean, and four
//! times that at 80 ms, so the period is short (40 ms: `ballisto sim --firmware --identify`).
//! Measured: on `orbit-identify`'s tumble means of 4 sets give the raw sets' geometry within a
//! tenth of a tolerance; on board, 6 drawn tumbles nothing was tuned on are identified at
//! 0.98–1.08 × ideal parts or refused by name (the README gives the figures).

use estimator_core::identify::{
    identify_tumble, Body, Identified, IdentifyError, Sets, Tolerance, TumbleError,
};
use estimator_core::{Arrangement, Sym3};

use crate::config::MAX_CHANNELS;
use crate::time::Nanos;

/// Numbers the kept sets may take: per set its time (s from the window's start), the
/// estimator's Ω (3) and the channels — 1 724 means of 15 channels, 69 s in means of 40 ms at
/// 100 Hz.
pub const TUMBLE_FLOATS: usize = 32 * 1024;

/// Sets in a mean of `period_ms` at `rate_hz` (at least one; the telecommand's acceptance
/// bounds the period, the configuration the rate).
fn sets_per_mean(period_ms: u16, rate_hz: f32) -> u32 {
    libm::roundf(f32::from(period_ms) * 1e-3 * rate_hz).clamp(1.0, 65_535.0) as u32
}

/// The longest tumble window, ms, whose means of `period_ms` over `channels` channels sampled
/// at `rate_hz` fit the room.
pub fn longest_window_ms(channels: usize, period_ms: u16, rate_hz: f32) -> u32 {
    let means = (TUMBLE_FLOATS / (4 + channels.min(MAX_CHANNELS))) as f32;
    let sets = means * sets_per_mean(period_ms, rate_hz) as f32;
    libm::floorf(sets / rate_hz.max(1e-3) * 1e3).min(u32::MAX as f32) as u32
}

/// The kept sets of a tumble window.
pub struct Tumble {
    /// The body's inertia (`[xx, yy, zz, xy, xz, yz]`), while a tumble window is open.
    inertia: Option<[f32; 6]>,
    kept: heapless::Vec<f32, TUMBLE_FLOATS>,
    channels: usize,
    /// Sets per mean.
    averaged: u32,
    /// The mean being summed: its sets, their times' sum (ns from the window's start), the
    /// first set's rate, the channels' sums.
    sum: (u32, u64, [f32; 3], [f32; MAX_CHANNELS]),
}

impl Tumble {
    /// No window.
    pub const fn new() -> Self {
        Tumble {
            inertia: None,
            kept: heapless::Vec::new(),
            channels: 0,
            // Set by `start`; zero keeps a board's static window all zeros (in .bss, not
            // 128 KiB of flash).
            averaged: 0,
            sum: (0, 0, [0.0; 3], [0.0; MAX_CHANNELS]),
        }
    }

    /// A new window over `channels` channels sampled at `rate_hz`, a tumble's if `inertia` is
    /// given: each kept set the mean of `period_ms` of sets (at least one).
    pub fn start(
        &mut self,
        inertia: Option<[f32; 6]>,
        channels: usize,
        period_ms: u16,
        rate_hz: f32,
    ) {
        self.inertia = inertia;
        self.kept.clear();
        self.channels = channels.min(MAX_CHANNELS);
        self.averaged = sets_per_mean(period_ms, rate_hz);
        self.sum = (0, 0, [0.0; 3], [0.0; MAX_CHANNELS]);
    }

    /// Whether the window is a tumble's.
    pub fn active(&self) -> bool {
        self.inertia.is_some()
    }

    /// Adds a set `since` ns into the window: its channels `p` (all finite) and the
    /// estimator's rate `omega`; `false` if a mean it completed found no room (those sets are
    /// not covered).
    pub fn add(&mut self, since: Nanos, p: &[f32], omega: &[f32; 3]) -> bool {
        let n = self.channels;
        let (count, t, w, sums) = &mut self.sum;
        if *count == 0 {
            *w = *omega;
            *t = 0;
            sums.fill(0.0);
        }
        *count += 1;
        *t += since;
        for (s, v) in sums.iter_mut().zip(p.iter().take(n)) {
            *s += v;
        }
        if *count < self.averaged {
            return true;
        }
        let k = *count;
        *count = 0;
        if self.kept.len() + 4 + n > TUMBLE_FLOATS {
            return false;
        }
        // Room was checked above.
        let _ = self.kept.push((*t / u64::from(k)) as f32 / 1e9);
        let k = k as f32;
        let _ = self.kept.extend_from_slice(w);
        for s in sums.iter().take(n) {
            let _ = self.kept.push(s / k);
        }
        true
    }

    /// Drops the mean being summed (a set that could not join it: an incomplete one);
    /// returns how many sets it had.
    pub fn drop_mean(&mut self) -> u32 {
        core::mem::take(&mut self.sum.0)
    }

    /// Sets per kept mean.
    pub fn averaged(&self) -> u32 {
        self.averaged.max(1)
    }

    /// Solves the kept sets for `nominal` (the arrangement they were read with).
    #[inline(never)]
    pub fn solve(
        &self,
        nominal: &Arrangement<MAX_CHANNELS>,
    ) -> Result<Identified<MAX_CHANNELS>, TumbleError> {
        let inertia = self.inertia.ok_or(TumbleError::Inertia)?;
        let sets = Kept {
            data: &self.kept,
            channels: self.channels,
            averaged: self.averaged(),
        };
        // The search starts from the first kept set's rate (and the rates of all of them).
        let Some(w) = self.kept.get(1..4) else {
            return Err(TumbleError::Identify(IdentifyError::TooFewSets { have: 0 }));
        };
        let start = [w[0], w[1], w[2]].map(f64::from);
        let body = Body {
            inertia: Sym3(inertia.map(f64::from)),
            gamma: Sym3([0.0; 6]),
        };
        let fit = identify_tumble(&sets, &body, &start, nominal, &Tolerance::DATASHEET)?;
        Ok(fit.identified)
    }
}

impl Default for Tumble {
    fn default() -> Self {
        Self::new()
    }
}

/// The kept sets as estimator-core's search reads them.
struct Kept<'a> {
    data: &'a [f32],
    channels: usize,
    averaged: u32,
}

impl Sets for Kept<'_> {
    fn for_each(&self, f: &mut dyn FnMut(f64, &[f64])) {
        let mut p = [0.0f64; MAX_CHANNELS];
        for set in self.data.chunks_exact(4 + self.channels) {
            for (v, x) in p.iter_mut().zip(&set[4..]) {
                *v = f64::from(*x);
            }
            f(f64::from(set[0]), &p[..self.channels]);
        }
    }

    fn rates(&self, f: &mut dyn FnMut(f64, &[f64; 3])) {
        for set in self.data.chunks_exact(4 + self.channels) {
            f(f64::from(set[0]), &[set[1], set[2], set[3]].map(f64::from));
        }
    }

    fn averaged(&self) -> u32 {
        self.averaged
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::{vec, vec::Vec};

    /// Kept sets as the search reads them: each one's time and channels.
    type Read = Vec<(f64, Vec<f64>)>;

    /// The kept sets, as the search reads them, and their rates.
    fn kept(t: &Tumble) -> (Read, Vec<[f64; 3]>) {
        let sets = Kept {
            data: &t.kept,
            channels: t.channels,
            averaged: t.averaged(),
        };
        let (mut p, mut w) = (Vec::new(), Vec::new());
        sets.for_each(&mut |t, v| p.push((t, v.to_vec())));
        sets.rates(&mut |_, r| w.push(*r));
        (p, w)
    }

    #[test]
    fn each_kept_set_is_the_mean_of_a_period_of_sets() {
        let mut t = Tumble::new();
        // 20 ms at 100 Hz: means of 2 sets.
        t.start(Some([1.0, 2.0, 3.0, 0.0, 0.0, 0.0]), 3, 20, 100.0);
        assert_eq!(t.averaged(), 2);
        for k in 0..5u64 {
            let x = k as f32;
            assert!(t.add(k * 10_000_000, &[x, 2.0 * x, -x], &[x, 0.0, 1.0]));
        }
        let (p, w) = kept(&t);
        // Two complete means; the fifth set waits for its partner.
        assert_eq!(p.len(), 2);
        assert!((p[0].0 - 0.005).abs() < 1e-9 && (p[1].0 - 0.025).abs() < 1e-9);
        assert_eq!(p[1].1, vec![2.5, 5.0, -2.5]);
        // The rate of each mean's first set.
        assert_eq!(w[1], [2.0, 0.0, 1.0]);
    }

    #[test]
    fn the_longest_window_fits_and_no_more() {
        let mut t = Tumble::new();
        // 12 channels, means of 40 ms at 100 Hz: 2 048 means of 4 sets, 81.92 s.
        let longest = longest_window_ms(12, 40, 100.0);
        assert_eq!(longest, 81_920);
        t.start(Some([1.0, 2.0, 3.0, 0.0, 0.0, 0.0]), 12, 40, 100.0);
        let p = [1.0f32; 12];
        let sets = u64::from(longest) / 10;
        assert!((0..sets).all(|k| t.add(k * 10_000_000, &p, &[0.0; 3])));
        // The next mean finds no room.
        assert!((0..4).any(|_| !t.add(0, &p, &[0.0; 3])));
    }

    #[test]
    fn a_dropped_mean_starts_again() {
        let mut t = Tumble::new();
        t.start(Some([1.0, 2.0, 3.0, 0.0, 0.0, 0.0]), 2, 30, 100.0);
        assert_eq!(t.averaged(), 3);
        t.add(0, &[9.0, 9.0], &[0.0; 3]);
        t.add(10_000_000, &[9.0, 9.0], &[0.0; 3]);
        assert_eq!(t.drop_mean(), 2);
        for k in 2..5u64 {
            t.add(k * 10_000_000, &[1.0, 2.0], &[0.0; 3]);
        }
        let (p, _) = kept(&t);
        assert_eq!(p.len(), 1);
        assert_eq!(p[0].1, vec![1.0, 2.0]);
        assert!((p[0].0 - 0.03).abs() < 1e-9);
    }
}
