//! The last sample sets, kept so that a change of the channels in use starts from a warm rate
//! filter.
//!
//! A change of channel mask (a part isolated by the fault monitor and taken out, or re-admitted,
//! or gone missing) restarts the estimator's history: branch and sign tracking and the rate
//! filter start again from one sample's algebraic Ω and its variance, and the filter needs a
//! few tenths of a second to reach the deviation it had. The estimate after an exclusion is then
//! worse than that of the same readings never having had the part, for no reason but the
//! restart. Worse, a slow fault (a drift) is isolated seconds after its onset, and the
//! estimates it has already bent cannot seed the new filter.
//!
//! So the owner of the estimator keeps the last [`Recent`] sets (as read: every channel, the
//! part now out included) and, right after the new configuration is put in force, replays them
//! through it ([`Recent::replay`]): the estimator forgets them under the new mask, which ignores
//! the faulty part's readings, and meets the current set with the history the run without that
//! part would have had over the replayed span. The replayed estimates are discarded; nothing is
//! emitted for them twice.
//!
//! The same in the firmware (its `Estimation`) and in `ballisto estimate` (one estimator).
//! Measured (docs/validation.md, "Fault detection"; ideal parts, 20 runs per fault kind): the RMS Ω error
//! while the part is out, against the same readings without the part, went from 1.03–1.34 to
//! 1.00–1.02 on the mixed layout (1.34: a 3 σ/s drift isolated late) and from 1.01–1.12 to
//! 0.98–1.01 on the N = 18 layout. Only a change that takes channels out is replayed by the
//! owners: the history of a part coming back may hold what took it out.

use crate::arrangement::ChannelMask;
use crate::real::Real;

/// Sets replayed after a change of the channels in use: 0.16 s at 100 Hz, about the time the
/// rate filter takes to settle from a restart on the mixed layout (docs/validation.md, "Fault detection").
pub const REPLAY_SETS: usize = 16;

/// Whether a change of the channels in use from `before` to `after` is replayed: only one that
/// takes channels out. The history of a part coming back may be what took it out (a stuck part
/// returns as soon as it moves again; replayed, `tetra-orbit-faults` in model F took the wrong
/// sign), so a re-admission restarts from the set at hand.
pub fn replays(before: ChannelMask, after: ChannelMask) -> bool {
    after.0 & !before.0 == 0
}

/// The last `K` sample sets of up to `CAP` channels: their times (s) and readings.
#[derive(Clone)]
pub struct Recent<T, const CAP: usize, const K: usize> {
    t: [f64; K],
    p: [[T; CAP]; K],
    /// Channels per set (those of the first set pushed since the last clear).
    n: usize,
    /// Index of the oldest set, and how many are held.
    head: usize,
    len: usize,
}

impl<T: Real, const CAP: usize, const K: usize> Default for Recent<T, CAP, K> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real, const CAP: usize, const K: usize> Recent<T, CAP, K> {
    /// Empty.
    pub const fn new() -> Self {
        Recent {
            t: [0.0; K],
            p: [[T::ZERO; CAP]; K],
            n: 0,
            head: 0,
            len: 0,
        }
    }

    /// Forgets every set (a new arrangement: the channels are no longer those of the sets held).
    pub fn clear(&mut self) {
        self.head = 0;
        self.len = 0;
        self.n = 0;
    }

    /// How many sets are held (at most `K`).
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether no set is held.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The time (s) of the oldest set held.
    pub fn first_t(&self) -> Option<f64> {
        (self.len > 0).then(|| self.t[self.head])
    }

    /// The time (s) of the first set the estimator sees after a change made at `now`: the
    /// oldest held if the change is replayed, else `now` (the rate hint is for that instant).
    pub fn first_seen(&self, replay: bool, now: f64) -> f64 {
        self.first_t().filter(|_| replay).unwrap_or(now)
    }

    /// Keeps the set `p` read at `t` (s), forgetting the oldest if `K` are held. The channels
    /// beyond `CAP` are dropped; a set of another channel count than those held (a new
    /// arrangement not cleared) starts the history again.
    pub fn push(&mut self, t: f64, p: &[T]) {
        if K == 0 {
            return;
        }
        let n = p.len().min(CAP);
        if self.len > 0 && n != self.n {
            self.clear();
        }
        self.n = n;
        let slot = if self.len < K {
            self.len += 1;
            (self.head + self.len - 1) % K
        } else {
            let s = self.head;
            self.head = (self.head + 1) % K;
            s
        };
        self.t[slot] = t;
        self.p[slot][..n].copy_from_slice(&p[..n]);
    }

    /// Feeds every set held, oldest first, to `update` (the estimator's per-sample step, with
    /// the configuration now in force; its outputs are the caller's to discard).
    pub fn replay(&self, mut update: impl FnMut(f64, &[T])) {
        for i in 0..self.len {
            let s = (self.head + i) % K;
            update(self.t[s], &self.p[s][..self.n]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;
    use std::vec::Vec;

    #[test]
    fn only_a_change_that_takes_channels_out_is_replayed() {
        let all = ChannelMask::all(6);
        assert!(replays(all, all.without(2)));
        assert!(replays(all, all));
        assert!(!replays(all.without(2), all));
        assert!(!replays(all.without(2), all.without(3)));
    }

    #[test]
    fn keeps_the_last_k_sets_in_order() {
        let mut r = Recent::<f64, 4, 3>::new();
        assert!(r.is_empty());
        for k in 0..5 {
            r.push(f64::from(k), &[f64::from(k), 10.0 + f64::from(k)]);
        }
        assert_eq!(r.len(), 3);
        assert_eq!(r.first_t(), Some(2.0));
        let mut seen = Vec::new();
        r.replay(|t, p| seen.push((t, p.to_vec())));
        assert_eq!(
            seen,
            [
                (2.0, std::vec![2.0, 12.0]),
                (3.0, std::vec![3.0, 13.0]),
                (4.0, std::vec![4.0, 14.0])
            ]
        );
    }

    #[test]
    fn another_channel_count_starts_again_and_clear_forgets() {
        let mut r = Recent::<f32, 4, 3>::new();
        r.push(0.0, &[1.0, 2.0]);
        r.push(0.1, &[1.0, 2.0]);
        r.push(0.2, &[1.0, 2.0, 3.0]);
        assert_eq!(r.len(), 1);
        let mut n = 0;
        r.replay(|t, p| {
            assert_eq!((t, p), (0.2, &[1.0f32, 2.0, 3.0][..]));
            n += 1;
        });
        assert_eq!(n, 1);
        assert_eq!(
            (r.first_seen(true, 0.5), r.first_seen(false, 0.5)),
            (0.2, 0.5)
        );
        r.clear();
        assert_eq!((r.len(), r.first_t()), (0, None));
        assert_eq!(r.first_seen(true, 0.5), 0.5);
        r.replay(|_, _| panic!("nothing to replay"));
    }
}
