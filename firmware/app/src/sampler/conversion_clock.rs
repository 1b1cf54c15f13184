//! The conversion clock of a free-running part: when did its n-th sample happen, on the
//! firmware's time base?
//!
//! A part on its own oscillator converts at `c_n = c_0 + n·T`, with `T` off nominal by the
//! oscillator's error (hundreds of ppm to a few per cent) and each instant jittered. The
//! firmware sees only counts: reading the FIFO level between the instants `a` and `b` of one
//! transfer tells that conversion `n` (the total so far) happened before `b`, and conversion
//! `n + 1` after `a`. So `c_n ∈ (a − T, b]`. The tracker keeps an interval for the time of the
//! latest conversion, carried forward by the period estimate (widened by its uncertainty and a
//! jitter margin) and cut by every new observation. The sampler reads each part at the
//! predicted time of a conversion (see [`ConversionClock::probe_after`]), so every reading
//! halves the interval: the phase is found within a few sample sets and then tracked within
//! about the jitter margin. A long baseline between two sharp intervals measures the period
//! (the sharpest interval so far, within a factor of two, anchors it). The bounds are not
//! intersected: the margin covers most of the jitter, not all of it, and an intersection of
//! two slightly wrong bounds can leave none.
//!
//! Times are `f64` seconds since boot: the arithmetic is a handful of operations per part and
//! sample set.

/// Observations between two sharp intervals before the period is measured from them.
const BASELINE: u64 = 64;
/// An interval narrower than this fraction of the period is sharp enough to anchor the period
/// measurement.
const SHARP: f64 = 0.1;

/// Tracker of one part's conversion instants.
#[derive(Clone, Copy, Debug)]
pub struct ConversionClock {
    /// Period estimate (s) and its relative uncertainty (a bound).
    period: f64,
    tolerance: f64,
    /// Allowance for the jitter of each conversion instant and of the read instants (s).
    margin: f64,
    /// Index of the latest observed conversion and the interval holding its time.
    n: u64,
    lo: f64,
    hi: f64,
    locked: bool,
    /// A sharp interval (index, centre, half-width) from which the period is measured.
    anchor: Option<(u64, f64, f64)>,
    /// Observations that contradicted the track (phase lost and found again).
    resyncs: u32,
}

impl ConversionClock {
    /// A tracker for a nominal `period` (s), oscillator `tolerance` (relative) and jitter
    /// `margin` (s).
    pub fn new(period: f64, tolerance: f64, margin: f64) -> Self {
        ConversionClock {
            period,
            tolerance,
            margin,
            n: 0,
            lo: 0.0,
            hi: 0.0,
            locked: false,
            anchor: None,
            resyncs: 0,
        }
    }

    /// Forgets the phase (the count was lost: FIFO overrun or restart); keeps the period.
    pub fn unlock(&mut self) {
        self.locked = false;
        self.anchor = None;
    }

    /// True once an observation has been made since the last [`ConversionClock::unlock`].
    pub fn is_locked(&self) -> bool {
        self.locked
    }

    /// The period estimate (s).
    pub fn period(&self) -> f64 {
        self.period
    }

    /// Half-width of the interval of the latest conversion's time (s).
    pub fn uncertainty(&self) -> f64 {
        0.5 * (self.hi - self.lo)
    }

    /// How many observations contradicted the track.
    pub fn resyncs(&self) -> u32 {
        self.resyncs
    }

    /// The interval for conversion `i`, carried from the latest observed conversion.
    fn interval(&self, i: u64) -> (f64, f64) {
        let d = i as f64 - self.n as f64;
        let spread = d.abs() * self.period * self.tolerance;
        (
            self.lo + d * self.period - spread,
            self.hi + d * self.period + spread,
        )
    }

    /// Estimated time of conversion `i` (s): the centre of its interval.
    pub fn time_of(&self, i: u64) -> f64 {
        let (lo, hi) = self.interval(i);
        0.5 * (lo + hi)
    }

    /// The time by which conversion `i` has surely happened (s): the upper end of its
    /// interval.
    pub fn surely_by(&self, i: u64) -> f64 {
        self.interval(i).1
    }

    /// The instant at which reading the count tells the most: the predicted time of the first
    /// conversion after `t`; `t` itself when the phase is unknown.
    pub fn probe_after(&self, t: f64) -> f64 {
        if !self.locked {
            return t;
        }
        let c = self.time_of(self.n);
        let ahead = libm::floor((t - c) / self.period) + 1.0;
        if !(ahead >= 0.0) {
            return t;
        }
        self.time_of(self.n + ahead as u64).max(t)
    }

    /// Between the instants `a` and `b` (s) the part had made `n` conversions in total.
    pub fn observe(&mut self, a: f64, b: f64, n: u64) {
        let (lo_obs, hi_obs) = (a - self.period - self.margin, b + self.margin);
        if self.locked && n >= self.n {
            let (lo, hi) = self.interval(n);
            let (lo, hi) = (lo.max(lo_obs), hi.min(hi_obs));
            if lo <= hi {
                self.n = n;
                self.lo = lo;
                self.hi = hi;
                self.measure_period();
                return;
            }
            self.resyncs = self.resyncs.saturating_add(1);
            self.anchor = None;
        }
        self.n = n;
        self.lo = lo_obs;
        self.hi = hi_obs;
        self.locked = true;
    }

    /// Anchors a sharp interval; later, a sharp interval `BASELINE` conversions on measures
    /// the period (the two interval widths bound its error).
    fn measure_period(&mut self) {
        let half = self.uncertainty();
        if half > SHARP * self.period {
            return;
        }
        let mid = 0.5 * (self.lo + self.hi);
        let Some((n0, mid0, half0)) = self.anchor else {
            self.anchor = Some((self.n, mid, half));
            return;
        };
        if self.n >= n0 + BASELINE {
            let span = (self.n - n0) as f64;
            let period = (mid - mid0) / span;
            let tolerance = (half + half0) / span / period;
            if period > 0.0 && tolerance < self.tolerance {
                self.period = period;
                self.tolerance = tolerance;
            }
        }
        // A much sharper interval anchors the later measurements instead (the first sharp
        // one comes while the phase is still being found, up to a tenth of a period wide,
        // and would bound the period's error by that width over the whole baseline).
        if half < 0.5 * half0 {
            self.anchor = Some((self.n, mid, half));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A part converting at `c0 + n·T` (true period off nominal), read at the probe instants.
    fn track(ppm: f64, sets: usize) -> (ConversionClock, f64) {
        let nominal = 1.0 / 400.0;
        let true_period = nominal / (1.0 + ppm * 1e-6);
        let c0 = 0.000_731;
        let count = |t: f64| libm::floor((t - c0) / true_period).max(0.0) as u64;
        let mut clock = ConversionClock::new(nominal, 0.01, 5e-6);
        let mut worst = 0.0f64;
        for k in 1..=sets {
            let t = k as f64 * 0.01;
            let r = clock.probe_after(t);
            let (a, b) = (r, r + 50e-6);
            // The count is taken somewhere inside the transfer.
            let n = count(a + 20e-6);
            clock.observe(a, b, n);
            if k > 100 {
                let truth = c0 + n as f64 * true_period;
                worst = worst.max((clock.time_of(n) - truth).abs());
            }
        }
        (clock, worst)
    }

    #[test]
    fn phase_is_found_and_held_within_the_read_window() {
        for ppm in [0.0, 150.0, -80.0, 5000.0] {
            let (clock, worst) = track(ppm, 3000);
            assert!(worst < 60e-6, "{ppm} ppm: worst {worst:e} s");
            assert_eq!(clock.resyncs(), 0, "{ppm} ppm");
        }
    }

    #[test]
    fn period_is_measured() {
        let (clock, _) = track(5000.0, 3000);
        let true_period = 1.0 / 400.0 / 1.005;
        let err = (clock.period() - true_period).abs() / true_period;
        assert!(err < 1e-4, "relative period error {err:e}");
    }

    /// The period's bound holds and narrows with the baseline: a sharper interval re-anchors
    /// the measurement (here the first sharp ones come from slow transfers, 0.24 ms, then the
    /// reads speed up to 50 µs).
    #[test]
    fn the_period_bound_holds_and_narrows() {
        for ppm in [0.0, 150.0, -80.0, 5000.0] {
            let nominal = 1.0 / 400.0;
            let true_period = nominal / (1.0 + ppm * 1e-6);
            let c0 = 0.000_731;
            let count = |t: f64| libm::floor((t - c0) / true_period).max(0.0) as u64;
            let mut clock = ConversionClock::new(nominal, 0.01, 5e-6);
            for k in 1..=3000 {
                let t = k as f64 * 0.01;
                let transfer = if k <= 50 { 240e-6 } else { 50e-6 };
                let a = clock.probe_after(t) - 0.5 * transfer;
                let n = count(a + 0.6 * transfer);
                clock.observe(a, a + transfer, n);
            }
            let err = (clock.period - true_period).abs() / true_period;
            assert!(
                err <= clock.tolerance,
                "{ppm} ppm: error {err:e} beyond the bound {:e}",
                clock.tolerance
            );
            assert!(
                clock.tolerance < 3e-6,
                "{ppm} ppm: bound {:e}",
                clock.tolerance
            );
        }
    }

    #[test]
    fn a_contradiction_resyncs() {
        let mut clock = ConversionClock::new(0.0025, 1e-3, 5e-6);
        clock.observe(0.010, 0.010_05, 4);
        // Ten conversions later in count but far too early in time.
        clock.observe(0.011, 0.011_05, 14);
        assert_eq!(clock.resyncs(), 1);
        assert!(clock.is_locked());
    }
}
