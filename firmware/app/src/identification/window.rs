//! The window: sample sets waiting for the reference, the sums, the solve. Run by the
//! identification task ([`super::Identifier::run`]), below the estimate.

use ballisto_link::identification::{IdentificationSummary, ReferencePoint};
use estimator_core::identify::Tolerance;
use estimator_core::identify::{field_terms, identify, FieldSums};
use estimator_core::{Arrangement, Sym3};
use heapless::Deque;

use super::reference::{Push, ReferenceTrack};
use super::tumble::Tumble;
use super::{Counters, Solved, Unsolved, PENDING};
use crate::config::MAX_CHANNELS;
use crate::time::Nanos;

/// A reference interval longer than this many stated periods is a gap.
const GAP_PERIODS: u64 = 3;

/// The identification's state.
pub struct Identification {
    /// The open window: its start and end, and which sets it takes (every `decimation`-th).
    window: Option<(Nanos, Nanos, u32)>,
    /// The arrangement in force when the window was started: the one its sets were read with.
    arrangement: Arrangement<MAX_CHANNELS>,
    seen: u32,
    track: ReferenceTrack,
    pending: Deque<(Nanos, [f32; MAX_CHANNELS]), PENDING>,
    sums: FieldSums<MAX_CHANNELS>,
    /// Without a reference: the kept sets of a tumble.
    tumble: Tumble,
    counters: Counters,
    next_solution: u16,
}

impl Default for Identification {
    fn default() -> Self {
        Self::new()
    }
}

impl Identification {
    /// No window.
    pub const fn new() -> Self {
        Identification {
            window: None,
            arrangement: Arrangement::new(),
            seen: 0,
            track: ReferenceTrack::new(0),
            pending: Deque::new(),
            sums: FieldSums::new(),
            tumble: Tumble::new(),
            counters: Counters {
                not_covered: 0,
                incomplete: 0,
                points: 0,
                restarts: 0,
            },
            next_solution: 1,
        }
    }

    /// Starts a window of `window_ms` from `now` over the channels of `arrangement` sampled
    /// at `rate_hz`: with the reference sent every `period_ms`, or, with the body's `inertia`,
    /// a torque-free tumble whose sets are kept as means over `period_ms`. What was
    /// accumulated is dropped (a reported solution stays committable).
    #[inline(never)]
    pub fn start(
        &mut self,
        now: Nanos,
        period_ms: u16,
        window_ms: u32,
        arrangement: &Arrangement<MAX_CHANNELS>,
        rate_hz: f32,
        inertia: Option<[f32; 6]>,
    ) {
        let period = u64::from(period_ms) * 1_000_000;
        let decimation = if inertia.is_some() {
            // Every set joins a mean.
            1
        } else {
            // Sets the queue must hold: three periods' worth.
            let needed = libm::ceilf(3.0 * f32::from(period_ms) * 1e-3 * rate_hz);
            libm::ceilf(needed / PENDING as f32).max(1.0) as u32
        };
        self.tumble
            .start(inertia, arrangement.len(), period_ms, rate_hz);
        self.window = Some((now, now + u64::from(window_ms) * 1_000_000, decimation));
        self.arrangement.clone_from(arrangement);
        let channels = arrangement.len();
        self.seen = 0;
        self.track = ReferenceTrack::new(GAP_PERIODS * period);
        self.pending.clear();
        self.sums.clear(channels);
        self.counters = Counters::default();
    }

    /// A sample set's channel vector (NaN where a part had no value) at `t`, and the
    /// estimator's rate then.
    #[inline(never)]
    pub fn on_set(&mut self, t: Nanos, p: &[f32], omega: &[f32; 3]) {
        let Some((start, end, decimation)) = self.window else {
            return;
        };
        if t < start || t > end {
            return;
        }
        self.seen = self.seen.wrapping_add(1);
        if !self.seen.is_multiple_of(decimation) {
            return;
        }
        if p.iter().any(|v| !v.is_finite()) {
            // In a tumble the mean under way is dropped too (its noise would not be the one
            // the search is told).
            self.counters.incomplete += 1 + self.tumble.drop_mean();
            return;
        }
        if self.tumble.active() {
            if !omega.iter().all(|v| v.is_finite()) {
                // The mean under way cannot be completed with its sets' spacing.
                self.counters.incomplete += 1 + self.tumble.drop_mean();
            } else if !self.tumble.add(t - start, p, omega) {
                self.counters.not_covered += self.tumble.averaged();
            }
            return;
        }
        let mut v = [0.0; MAX_CHANNELS];
        let n = p.len().min(MAX_CHANNELS);
        v[..n].copy_from_slice(&p[..n]);
        if self.pending.is_full() {
            self.pending.pop_front();
            self.counters.not_covered += 1;
        }
        // Room was made above.
        let _ = self.pending.push_back((t, v));
    }

    /// Reference points (in time order, as acceptance checked).
    #[inline(never)]
    pub fn on_points(&mut self, points: impl Iterator<Item = ReferencePoint>) {
        // A tumble's window takes no reference.
        if self.window.is_none() || self.tumble.active() {
            return;
        }
        for p in points {
            self.counters.points += 1;
            if self.track.push(&p) == Push::Restarted && self.counters.points > 1 {
                self.counters.restarts += 1;
            }
            self.drain();
        }
    }

    /// Moves the sets the track now covers into the sums; drops those it never will.
    #[inline(never)]
    fn drain(&mut self) {
        let channels = self.sums.channels();
        let Some((t0, t2)) = self.track.span() else {
            // A restarted track covers nothing before its first point.
            if let Some(first) = self.track.first() {
                while self.pending.front().is_some_and(|(t, _)| *t < first) {
                    self.pending.pop_front();
                    self.counters.not_covered += 1;
                }
            }
            return;
        };
        let gamma = Sym3([0.0; 6]);
        while let Some((t, p)) = self.pending.front() {
            if *t > t2 {
                break;
            }
            if let (true, Some((w, dw))) = (*t >= t0, self.track.field_at(*t)) {
                let k = field_terms(&w, &dw, &gamma);
                if !self.sums.add(&k, &p[..channels]) {
                    self.counters.incomplete += 1;
                }
            } else {
                self.counters.not_covered += 1;
            }
            self.pending.pop_front();
        }
    }

    /// Solves the window for the arrangement in force at its start (paper §6) and numbers the
    /// solution; `lost` sets never reached the window (the queue to this task was full) and are
    /// counted as not covered.
    #[inline(never)]
    pub fn solve(&mut self, lost: u32) -> Solved {
        if self.window.is_none() {
            return Err(Unsolved::NoWindow);
        }
        let arrangement = &self.arrangement;
        let id = if self.tumble.active() {
            self.tumble.solve(arrangement).map_err(Unsolved::Tumble)?
        } else {
            identify(&self.sums, arrangement, &Tolerance::DATASHEET).map_err(Unsolved::Identify)?
        };
        let number = self.next_solution;
        self.next_solution = self.next_solution.wrapping_add(1).max(1);
        let frame = id.frame_uncertainty();
        let c = self.counters;
        let summary = IdentificationSummary {
            solution: number,
            channels: arrangement.len() as u8,
            // A tumble's kept sets are means: the sample sets behind them.
            sets: if self.tumble.active() {
                id.sets.saturating_mul(self.tumble.averaged())
            } else {
                id.sets
            },
            not_covered: c.not_covered + self.pending.len() as u32 + lost,
            incomplete: c.incomplete,
            points: c.points,
            restarts: c.restarts,
            rho: id.rho.map(|v| v as f32),
            rho_sd: id.rho_sd.map(|v| v as f32),
            frame: [
                frame.rotation as f32,
                frame.translation as f32,
                frame.size as f32,
            ],
        };
        Ok((id, frame, summary))
    }

    /// The window's counters.
    pub fn counters(&self) -> Counters {
        self.counters
    }
}
