//! The fault supervisor: what keeps faulty and silent parts out of the solve, and the
//! estimate honest meanwhile. The firmware's estimation and `ballisto estimate` both run it,
//! so that the unit and the ground flag and exclude the same sets for the same readings.
//!
//! Per sample set, around the estimator's per-sample step:
//! 1. [`Supervisor::observe`]: the readings' news — which parts answered ([`MissingRuns`]:
//!    a part silent for `EXCLUDE_AFTER` sets is wanted out, one good again for
//!    `INCLUDE_AFTER` sets back in), each part's own signal ([`StuckCheck`]: stuck, or at its
//!    range limit), and the [`FaultMonitor`]'s window on the parity space of every channel
//!    tested (the isolated part's too, so that it is re-admitted once consistent).
//! 2. [`Supervisor::change`]: the parts wanted out, if they differ from those out now (and the
//!    solve did not already refuse that set). The caller makes the channel mask of them (with
//!    its own channels out by command), puts it in force in the estimator (the model it can
//!    carry: [`crate::Estimator::set_mask_in`]), and says how that went:
//!    [`Supervisor::taken`] (which returns the rate hint the estimator restarts from) or
//!    [`Supervisor::refuse`] (too few channels left: the part stays in, the sets flagged).
//! 3. [`Supervisor::before_update`]: after a change that takes channels out, the last
//!    [`REPLAY_SETS`] sets replayed through the new configuration, so that its rate filter
//!    meets this set warm ([`crate::recent`]).
//! 4. [`Supervisor::after_update`]: the estimate's flag 64 ([`Flags::RESIDUAL_HIGH`]) where a
//!    fault may still be in the solve — seen and not isolated, isolated and not left out, or,
//!    with no parity space, the readings inconsistent with the known field or model F's own
//!    residual ([`NoParityTest`]); a suspicion held through sets without a test
//!    ([`Suspicion`]); the last rate it trusts ([`TrustedRate`]) for the next change's hint.
//!
//! The parity space is model G's whatever the model estimated in (model F's field is one of
//! model G's, so its readings lie in it too); it is rebuilt — one SVD, outside the per-sample
//! solve — when the channels tested change ([`Supervisor::rebuild`], or
//! [`Supervisor::install`] with one built elsewhere, as the firmware's builder task does).

use crate::arrangement::ChannelMask;
use crate::estimate::{Estimate, Flags};
use crate::estimator::Estimator;
use crate::exclusion::MissingRuns;
use crate::fault_monitor::{
    FaultMonitor, NoParityTest, Settings, StuckCheck, Suspicion, TrustedRate, Verdict,
};
use crate::parity::{Parity, NO_PART};
use crate::real::Real;
use crate::recent::{replays, Recent, REPLAY_SETS};

/// Most parts the supervisor tells apart (a part is a bit of a `u32` set).
pub const MAX_PARTS: usize = 32;

/// A parity space, or none (too few channels: N ≤ 12).
pub type Checks<T, const CAP: usize> = Option<Parity<T, CAP>>;

/// The parts wanted out of the solve (bit per part).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Change {
    /// Out because they stopped answering.
    pub missing: u32,
    /// Out because the monitor isolated them, or their own signal is stuck or at its limit.
    pub isolated: u32,
}

impl Change {
    /// Every part wanted out.
    pub fn out(&self) -> u32 {
        self.missing | self.isolated
    }
}

/// What a change put in force brings: the rate hint the estimator restarts from (the last
/// trusted rate carried to the first set it will see, where an isolated part leaves or
/// returns; else the last rate), and whether the parts out for silence changed (the channels
/// tested then change: the parity space is rebuilt).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Taken {
    /// The hint for the estimator's restart.
    pub hint: Option<[f64; 3]>,
    /// The parts out for silence changed.
    pub missing_changed: bool,
}

/// The fault supervisor of one estimator of up to `CAP` channels from up to `P` parts (at most
/// [`MAX_PARTS`]; see the module's doc).
pub struct Supervisor<T, const CAP: usize, const P: usize = MAX_PARTS> {
    /// Built once the sample rate is known (its windows are in sets).
    monitor: Option<FaultMonitor<T, CAP>>,
    rate_hz: Option<f64>,
    /// The first set's readings and variances while the rate is not known: the monitor's
    /// window starts with them once it is, as where the rate is known from the start.
    first: Option<([T; CAP], [T; CAP], u32)>,
    /// Each channel's part ([`NO_PART`] for none).
    part: [u8; CAP],
    n: usize,
    /// The test where there is no parity space.
    no_parity: NoParityTest<T>,
    stuck: StuckCheck<T, CAP>,
    /// Parts stuck or at their limit at the last set.
    stuck_parts: u32,
    runs: MissingRuns<P>,
    /// The parts out of the solve: for silence, and as isolated.
    missing: u32,
    isolated: u32,
    /// An isolated set the solve refused (not asked again while it stands).
    refused: Option<u32>,
    /// A part isolated was taken out at this set.
    newly_out: bool,
    last_omega: Option<[f64; 3]>,
    trusted: TrustedRate,
    suspicion: Suspicion,
    recent: Recent<T, CAP, REPLAY_SETS>,
    replay_due: bool,
}

impl<T: Real, const CAP: usize, const P: usize> Supervisor<T, CAP, P> {
    /// A supervisor for channels read from `part` (each channel's part, [`NO_PART`] for none)
    /// with full scales `range` (m/s², infinite for none), at `rate_hz` if known (else from
    /// [`Supervisor::set_rate`] on); no parity space until [`Supervisor::rebuild`].
    pub fn new(part: &[u8], range: &[f64], rate_hz: Option<f64>) -> Self {
        let mut parts = [NO_PART; CAP];
        let n = part.len().min(CAP);
        parts[..n].copy_from_slice(&part[..n]);
        Supervisor {
            monitor: rate_hz.map(|r| FaultMonitor::new(Settings::default(), r)),
            rate_hz,
            first: None,
            part: parts,
            n,
            no_parity: NoParityTest::None,
            stuck: StuckCheck::with_limits(&parts[..n], range),
            stuck_parts: 0,
            runs: MissingRuns::new(),
            missing: 0,
            isolated: 0,
            refused: None,
            newly_out: false,
            last_omega: None,
            trusted: TrustedRate::default(),
            suspicion: Suspicion::default(),
            recent: Recent::new(),
            replay_due: false,
        }
    }

    /// Each channel's part, as the parity space is built with.
    pub fn parts(&self) -> &[u8] {
        &self.part[..self.n]
    }

    /// Every channel but those of the parts in `parts` (bit per part): the channels the solve
    /// and the monitor use with those parts out.
    pub fn without_parts(&self, parts: u32) -> ChannelMask {
        let mut mask = ChannelMask::all(self.n);
        for (c, q) in self.parts().iter().enumerate() {
            if usize::from(*q) < MAX_PARTS && parts & (1 << q) != 0 {
                mask = mask.without(c);
            }
        }
        mask
    }

    /// Whether the sample rate is known (the monitor runs).
    pub fn rate_known(&self) -> bool {
        self.monitor.is_some()
    }

    /// The sample rate, once known (from the first two sets' times): the monitor is built
    /// with the parity space of the channels of `tested`, and its window starts with the
    /// first set. Ignored once the rate is known, or if it is not finite and positive.
    pub fn set_rate(&mut self, rate_hz: f64, estimator: &Estimator<T, CAP>, tested: ChannelMask) {
        if self.monitor.is_some() || !rate_hz.is_finite() || rate_hz <= 0.0 {
            return;
        }
        self.rate_hz = Some(rate_hz);
        self.monitor = Some(FaultMonitor::new(Settings::default(), rate_hz));
        self.rebuild(estimator, tested);
        if let (Some((p, var, stuck)), Some(m)) = (self.first.take(), &mut self.monitor) {
            m.set_variance(&var[..self.n]);
            m.step_with(&p[..self.n], stuck);
        }
    }

    /// The parity space of the channels of `tested` in the estimator's arrangement, or none
    /// where they have no redundancy (then the estimator's [`NoParityTest`]).
    pub fn rebuild(&mut self, estimator: &Estimator<T, CAP>, tested: ChannelMask) {
        let parity = Parity::build(estimator.arrangement(), tested, self.parts()).ok();
        self.install(estimator, parity);
    }

    /// As [`Supervisor::rebuild`] with the parity space built elsewhere; returns the one it
    /// replaces. Nothing is installed before the rate is known.
    pub fn install(
        &mut self,
        estimator: &Estimator<T, CAP>,
        parity: Checks<T, CAP>,
    ) -> Checks<T, CAP> {
        let (Some(monitor), Some(rate)) = (&mut self.monitor, self.rate_hz) else {
            return parity;
        };
        self.no_parity =
            NoParityTest::for_estimator(estimator, parity.is_some(), Settings::default(), rate);
        monitor.replace_parity(parity)
    }

    /// The parity space in force kept, the model's test made anew for the estimator's new
    /// configuration: the same channels tested, no SVD.
    pub fn refit(&mut self, estimator: &Estimator<T, CAP>) {
        let checks = match &mut self.monitor {
            Some(m) => m.replace_parity(None),
            None => None,
        };
        self.install(estimator, checks);
    }

    /// One set's readings `p` (NaN where a part had no value; a part with every channel NaN
    /// did not answer) and, if known, each channel's noise variance over its declared one:
    /// the monitor's verdict on them.
    pub fn observe(&mut self, p: &[T], variance: Option<&[T]>) -> Verdict {
        self.newly_out = false;
        let (mut present, mut seen) = (0u32, 0u32);
        for (c, q) in self.part[..self.n].iter().enumerate() {
            if usize::from(*q) < P.min(MAX_PARTS) {
                seen |= 1 << q;
                if p.get(c).is_some_and(|v| !v.to_f64().is_nan()) {
                    present |= 1 << q;
                }
            }
        }
        let mut bits = seen;
        while bits != 0 {
            let q = bits.trailing_zeros() as usize;
            self.runs.observe(q, present & (1 << q) != 0);
            bits &= bits - 1;
        }
        self.stuck_parts = self.stuck.step(p);
        let Some(m) = &mut self.monitor else {
            if self.first.is_none() {
                let mut first = ([T::ZERO; CAP], [T::ONE; CAP], self.stuck_parts);
                for (slot, x) in first.0.iter_mut().zip(p) {
                    *slot = *x;
                }
                for (slot, x) in first.1.iter_mut().zip(variance.unwrap_or(&[])) {
                    *slot = *x;
                }
                self.first = Some(first);
            }
            return Verdict::NoTest;
        };
        if let Some(v) = variance {
            m.set_variance(v);
        }
        m.step_with(p, self.stuck_parts)
    }

    /// The parts isolated at the last set (bit per part): by the parity space, or by their own
    /// signal.
    pub fn isolated_now(&self) -> u32 {
        let monitor = self.monitor.as_ref().and_then(|m| m.isolated());
        let by_parity = monitor
            .filter(|p| usize::from(*p) < P.min(MAX_PARTS))
            .map_or(0, |p| 1 << p);
        by_parity | self.stuck_parts
    }

    /// The parts wanted out, if they are not those out now (and not a set of isolated parts
    /// the solve refused).
    pub fn change(&self) -> Option<Change> {
        let missing = self.runs.wanted(self.missing);
        let isolated = self.isolated_now();
        let same = missing == self.missing
            && (isolated == self.isolated || self.refused == Some(isolated));
        (!same).then_some(Change { missing, isolated })
    }

    /// `change` is in force at the set read at `now` (s), the estimator's channels `before`
    /// it and `after`: where they differ the estimator restarted, and where the change takes
    /// channels out ([`replays`]) the last sets are replayed before this one.
    pub fn taken(
        &mut self,
        change: Change,
        before: ChannelMask,
        after: ChannelMask,
        now: f64,
    ) -> Taken {
        let replay = replays(before, after);
        let from = self.recent.first_seen(replay, now);
        let hint = if change.isolated != self.isolated {
            self.trusted.hint_at(from).or(self.last_omega)
        } else {
            self.last_omega
        };
        let missing_changed = change.missing != self.missing;
        self.newly_out |= change.isolated & !self.isolated != 0;
        self.missing = change.missing;
        self.isolated = change.isolated;
        self.replay_due = replay;
        Taken {
            hint,
            missing_changed,
        }
    }

    /// The solve cannot leave `change`'s isolated parts out (too few channels for either
    /// model): they stay in, and every set they are isolated in is flagged.
    pub fn refuse(&mut self, change: Change) {
        self.refused = Some(change.isolated);
    }

    /// The parts out of the solve for silence (bit per part).
    pub fn missing(&self) -> u32 {
        self.missing
    }

    /// The parts out of the solve as isolated (bit per part).
    pub fn isolated(&self) -> u32 {
        self.isolated
    }

    /// Before the estimator's step on `p` at `t` (s): the last sets replayed through
    /// `update` (the estimator's step, outputs discarded) if a change calls for it, and this
    /// set kept for the next.
    pub fn before_update(&mut self, t: f64, p: &[T], update: impl FnMut(f64, &[T])) {
        if core::mem::take(&mut self.replay_due) {
            self.recent.replay(update);
        }
        self.recent.push(t, p);
    }

    /// After the estimator's step at `t` (s): `estimate` flagged where a fault may be in the
    /// solve; returns the verdict to report (`verdict`: [`Supervisor::observe`]'s, with the
    /// known-field test's and a held suspicion's).
    pub fn after_update(
        &mut self,
        t: f64,
        estimate: &mut Estimate<T>,
        verdict: Verdict,
    ) -> Verdict {
        if estimate.is_finite() && !estimate.flags.has(Flags::INPUT_INVALID) {
            self.last_omega = Some(estimate.omega.map(|v| v.to_f64()));
        }
        let verdict = verdict.with_field(self.no_parity.step(estimate));
        let verdict = self.suspicion.hold(verdict, self.newly_out);
        // A part isolated that the solve could not leave out.
        let isolated = self.isolated_now();
        let kept = self.refused == Some(isolated) && isolated & !self.isolated != 0;
        if kept || verdict == Verdict::NotIsolated {
            estimate.flags.0 |= Flags::RESIDUAL_HIGH;
        }
        self.trusted.observe(t, estimate, verdict);
        verdict
    }

    /// The last rate estimated (the hint across a change of channels or a pause).
    pub fn last_omega(&self) -> Option<[f64; 3]> {
        self.last_omega
    }

    /// A rate given from outside (a hint commanded): taken as the last rate.
    pub fn set_last_omega(&mut self, omega: [f64; 3]) {
        self.last_omega = Some(omega);
    }

    /// Whether the monitor has a parity space.
    pub fn has_parity(&self) -> bool {
        self.monitor.as_ref().is_some_and(|m| m.has_parity())
    }

    /// The test run where there is no parity space.
    pub fn no_parity(&self) -> &NoParityTest<T> {
        &self.no_parity
    }

    /// The window's χ² over its limit (or the mean test's over its own, if higher): the
    /// monitor's, or the no-parity test's where it has no parity space; 0 before the rate is
    /// known.
    pub fn level(&self) -> T {
        self.no_parity
            .level()
            .or_else(|| self.monitor.as_ref().map(|m| m.level()))
            .unwrap_or(T::ZERO)
    }

    /// How many times part `part` was re-admitted after an isolation.
    pub fn readmissions(&self, part: u8) -> u8 {
        self.monitor.as_ref().map_or(0, |m| m.readmissions(part))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arrangement::{Arrangement, Model};
    use crate::exclusion::{EXCLUDE_AFTER, INCLUDE_AFTER};
    use crate::fault_monitor::STUCK_SETS;
    use crate::Options;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Six tri-axial parts (N = 18, a parity space of 6 degrees of freedom), at rest on the
    /// ground: every channel reads g along its axis plus noise.
    fn six_parts() -> (Arrangement<18>, [u8; 18]) {
        let places = [
            [0.1, 0.1, 0.1],
            [-0.1, -0.1, 0.1],
            [-0.1, 0.1, -0.1],
            [0.1, -0.1, -0.1],
            [0.12, 0.0, -0.05],
            [-0.05, 0.11, 0.08],
        ];
        let mut arr = Arrangement::<18>::new();
        let mut part = [0u8; 18];
        for (i, r) in places.iter().enumerate() {
            for (k, axis) in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
                .into_iter()
                .enumerate()
            {
                arr.push(*r, axis, 1e-3).unwrap();
                part[3 * i + k] = i as u8;
            }
        }
        arr.set_parts(&part);
        (arr, part)
    }

    fn reading(rng: &mut ChaCha8Rng) -> [f64; 18] {
        core::array::from_fn(
            |c| if c % 3 == 2 { 9.81 } else { 0.0 } + rng.gen_range(-1.7e-3..1.7e-3),
        )
    }

    #[test]
    fn a_silent_part_is_wanted_out_then_back_and_a_part_the_solve_cannot_spare_is_flagged() {
        let (arr, part) = six_parts();
        let est = Estimator::<f64, 18>::new(&arr, Model::General, Options::default()).unwrap();
        let mut sup = Supervisor::<f64, 18>::new(&part, &[f64::INFINITY; 18], Some(100.0));
        sup.rebuild(&est, ChannelMask::all(18));
        assert!(sup.has_parity());
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut wanted = None;
        for k in 0..EXCLUDE_AFTER {
            let mut p = reading(&mut rng);
            p[3..6].fill(f64::NAN);
            sup.observe(&p, None);
            wanted = sup.change();
            assert_eq!(wanted.is_some(), k + 1 == EXCLUDE_AFTER, "set {k}");
        }
        let change = wanted.unwrap();
        assert_eq!(
            change,
            Change {
                missing: 0b10,
                isolated: 0
            }
        );
        let all = ChannelMask::all(18);
        let taken = sup.taken(change, all, sup.without_parts(0b10), 0.05);
        assert!(taken.missing_changed);
        assert_eq!(sup.missing(), 0b10);
        for k in 0..INCLUDE_AFTER {
            sup.observe(&reading(&mut rng), None);
            let back = sup.change();
            assert_eq!(back.is_some(), k + 1 == INCLUDE_AFTER, "set {k}");
            if let Some(c) = back {
                assert_eq!(c.out(), 0);
                sup.taken(c, sup.without_parts(0b10), all, 1.0);
            }
        }
        assert_eq!(sup.missing(), 0);
        // Part 2 stuck: wanted out once its own check says so; refused (as where too few
        // channels would be left), it is not asked again, and every set carries flag 64.
        let stuck = reading(&mut rng);
        let mut est = est;
        for k in 0..2 * STUCK_SETS {
            let mut p = reading(&mut rng);
            p[6..9].copy_from_slice(&stuck[6..9]);
            let verdict = sup.observe(&p, None);
            if let Some(c) = sup.change() {
                assert_eq!(c.isolated, 0b100, "set {k}");
                sup.refuse(c);
            }
            let mut e = *est.update(f64::from(k) * 0.01, &p);
            sup.after_update(f64::from(k) * 0.01, &mut e, verdict);
            let out = sup.isolated_now() != 0;
            assert_eq!(e.flags.has(Flags::RESIDUAL_HIGH), out, "set {k}");
            // Stuck once its value has repeated STUCK_SETS times after the first.
            assert_eq!(out, k >= STUCK_SETS, "set {k}");
        }
        assert_eq!(sup.isolated(), 0);
    }

    #[test]
    fn a_rate_learned_at_the_second_set_gives_the_window_of_a_rate_known_from_the_start() {
        let (arr, part) = six_parts();
        let est = Estimator::<f64, 18>::new(&arr, Model::General, Options::default()).unwrap();
        let mut known = Supervisor::<f64, 18>::new(&part, &[f64::INFINITY; 18], Some(100.0));
        known.rebuild(&est, ChannelMask::all(18));
        let mut learned = Supervisor::<f64, 18>::new(&part, &[f64::INFINITY; 18], None);
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        for k in 0..300 {
            let mut p = reading(&mut rng);
            if k > 100 {
                p[4] += 0.02; // a bias the window sees build up
            }
            let variance = [0.6; 18];
            if k == 1 {
                learned.set_rate(100.0, &est, ChannelMask::all(18));
            }
            let a = known.observe(&p, Some(&variance));
            let b = learned.observe(&p, Some(&variance));
            if k >= 1 {
                assert_eq!(a, b, "set {k}");
                assert_eq!(
                    known.level().to_bits(),
                    learned.level().to_bits(),
                    "set {k}"
                );
            }
        }
        assert_ne!(known.isolated_now(), 0, "the bias is isolated");
    }
}
