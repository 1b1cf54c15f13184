//! `ballisto estimate`: the estimator over a samples file, streaming rows to the estimates file
//! (the firmware's per-sample code, one row per sample as it arrives).

use std::error::Error;
use std::path::Path;

use ballisto_config::arrangement_file::{load_arrangement, LoadedArrangement, HOST_CAP};
use estimator_core::exclusion::MissingRuns;
use estimator_core::fault_monitor::{
    FaultMonitor, NoParityTest, Settings, StuckCheck, Suspicion, TrustedRate, Verdict,
};
use estimator_core::parity::Parity;
use estimator_core::recent::{replays, Recent, REPLAY_SETS};
use estimator_core::{ChannelMask, Estimate, Estimator, Flags, Model, Options, Real};

use crate::estimates_csv::ThreadedWriter;
use crate::plausibility;
use crate::samples_csv::SamplesReader;

/// The sample-loop scalar of a host run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precision {
    /// `f32`, as on the target.
    F32,
    /// `f64`.
    F64,
}

/// What `ballisto estimate` does.
#[derive(Clone, Debug)]
pub struct EstimateJob<'a> {
    /// Arrangement file.
    pub arrangement: &'a Path,
    /// Samples file.
    pub samples: &'a Path,
    /// Estimates file to write.
    pub out: &'a Path,
    /// Model (overrides the file's).
    pub model: Option<Model>,
    /// Options (hint, raw).
    pub options: Options,
    /// Scalar type.
    pub precision: Precision,
}

/// Counts of a run.
#[derive(Clone, Debug, Default)]
pub struct Summary {
    /// Rows written.
    pub rows: u64,
    /// Rows with each flag bit set (bit index → count).
    pub flag_counts: [u64; 16],
    /// The model used.
    pub model: Option<Model>,
    /// Channels.
    pub channels: usize,
    /// Why the model differs from the file's, if it does (said once, after the run).
    pub model_note: Option<String>,
    /// What looks implausible in the inputs, naming the likely cause.
    pub warnings: Vec<String>,
}

/// Runs the estimator over a samples file, streaming rows to the estimates file. Rows written
/// before an error stay in the output (flushed); the error names file and line.
pub fn estimate_files(job: &EstimateJob) -> Result<Summary, Box<dyn Error>> {
    crate::output::check_distinct(&[job.out], &[job.arrangement, job.samples])?;
    let loaded = load_arrangement(job.arrangement)?;
    let (model, model_note) =
        ballisto_config::model_choice::recommend(job.model, &loaded, job.arrangement)?;
    let summary = match job.precision {
        Precision::F64 => run_typed::<f64>(job, &loaded, model),
        Precision::F32 => run_typed::<f32>(job, &loaded, model),
    }?;
    Ok(Summary {
        model_note,
        ..summary
    })
}

/// The estimator as the host tools run it: the per-sample code of the firmware
/// ([`Estimator`]), with the fault isolation the firmware runs about it, and two looks ahead
/// the firmware cannot have (docs/branch-lock.md): without a hint, the record's first
/// [`RUN_IN_S`] are run backwards first (time reversed: the same readings, Ω negated) and the
/// forward run starts at that run's settled rate; and rows whose sign is unresolved are held
/// until a later row settles it, then take the sign that continues that row's Ω backwards.
pub struct HostEstimator<T: Real> {
    est: Estimator<T, HOST_CAP>,
    /// Fault isolation from the measurements, run as the firmware runs it; `None`
    /// when off.
    faults: Option<Faults<T>>,
    /// Rows held for their sign, oldest first.
    held: std::collections::VecDeque<HeldRow<T>>,
    /// The record's first samples while they are gathered for the backward run-in (`None`
    /// once it has run, or with a hint).
    run_in: Option<Vec<(f64, Vec<T>)>>,
}

/// Seconds of record run backwards to start the forward run (without a hint).
pub const RUN_IN_S: f64 = 2.0;

/// A row held for its sign: time, estimate, the channels it used and the model it was made in.
type HeldRow<T> = (f64, Estimate<T>, ChannelMask, Model);

/// Most seconds a row is held for its sign; older rows go out as they are (flagged): a
/// steady spin without a hint never settles it.
pub const SIGN_HOLD_S: f64 = 10.0;

/// What the estimator used for one sample, and what the monitor saw of it.
#[derive(Clone, Copy, Debug)]
struct RowUse {
    /// The channels in the solve.
    mask: ChannelMask,
    /// The model in force (model F instead of model G where exclusions leave it unobservable).
    model: Model,
    /// Flag 64 on the row: the monitor saw a fault it could not isolate, or isolated a part
    /// the solve could not leave out.
    residual_high: bool,
    /// The monitor's verdict (before the known-field test and the held suspicion).
    verdict: Verdict,
    /// A part isolated was taken out of the solve at this sample.
    newly_out: bool,
}

/// The fault monitor of a host run and what it decided.
struct Faults<T: Real> {
    /// Built at the second sample, when the rate is known.
    monitor: Option<FaultMonitor<T, HOST_CAP>>,
    /// Each channel's part (sensors of the arrangement file, `name.x/y/z`).
    part: Vec<u8>,
    arrangement: estimator_core::Arrangement<HOST_CAP>,
    /// Every channel of the arrangement.
    all: ChannelMask,
    first_t: Option<f64>,
    /// The configured model (the estimator's, unless the channels in use do not carry it).
    preferred: Model,
    /// Every model has the own-signal check (stuck, or at the arrangement file's `range`).
    stuck: StuckCheck<T, HOST_CAP>,
    /// Runs of missing and good samples per part (as the firmware's `Estimation`).
    runs: MissingRuns<32>,
    /// The parts out of the estimator's solve (bit per part): missing too long, and
    /// isolated by the monitor; and an isolated set it refused.
    missing: u32,
    isolated: u32,
    refused: Option<u32>,
    trusted: TrustedRate,
    /// A fault suspected and not isolated, held through samples without a test.
    suspicion: Suspicion,
    last_omega: Option<[f64; 3]>,
    /// The sample rate, once known (the monitor's windows).
    rate: Option<f64>,
    /// The test where there is no parity space (model G's known field, or model F's own
    /// residual), once the rate is known.
    no_parity: NoParityTest<T>,
    /// The last samples, replayed through the estimator's new configuration when the
    /// channels in use change (as the firmware's `Estimation`), and whether that is due.
    recent: Box<Recent<T, HOST_CAP, REPLAY_SETS>>,
    replay_due: bool,
}

impl<T: Real> Faults<T> {
    /// The monitor over the parts of `loaded` (the parity space in model G only).
    fn new(loaded: &LoadedArrangement, model: Model) -> Option<Self> {
        let arr = &loaded.arrangement;
        let part: Vec<u8> = (0..arr.len()).map(|i| arr.part(i)).collect();
        Some(Faults {
            monitor: None,
            stuck: StuckCheck::with_limits(&part, &loaded.ranges),
            part,
            arrangement: loaded.arrangement.clone(),
            all: ChannelMask::all(loaded.names.len()),
            first_t: None,
            preferred: model,
            runs: MissingRuns::new(),
            missing: 0,
            isolated: 0,
            refused: None,
            trusted: TrustedRate::default(),
            suspicion: Suspicion::default(),
            last_omega: None,
            rate: None,
            no_parity: NoParityTest::None,
            recent: Box::new(Recent::new()),
            replay_due: false,
        })
    }

    /// Notes which parts have a value in this sample (a part without one has every channel
    /// NaN: an empty field in the samples file, as the firmware writes a part it could not
    /// read).
    fn observe_parts(&mut self, p: &[T]) {
        let mut present = 0u32;
        let mut seen = 0u32;
        for (c, q) in self.part.iter().enumerate() {
            if *q < 32 {
                seen |= 1 << q;
                if p.get(c).is_some_and(|v| !v.to_f64().is_nan()) {
                    present |= 1 << q;
                }
            }
        }
        for q in 0..32 {
            if seen & (1 << q) != 0 {
                self.runs.observe(q, present & (1 << q) != 0);
            }
        }
    }

    /// The monitor's tests for the channels of the parts not missing, as the firmware's
    /// `Isolation::rebuild`: the parity space, or else estimator-core's [`NoParityTest`];
    /// none before the rate is known.
    fn rebuild(&mut self, est: &Estimator<T, HOST_CAP>) {
        let tested = self.mask(self.missing);
        let (Some(m), Some(rate)) = (&mut self.monitor, self.rate) else {
            return;
        };
        // Model G's parity space whatever the model estimated in (model F's field is one of
        // model G's), as the firmware's.
        let parity = Parity::build(&self.arrangement, tested, &self.part).ok();
        self.no_parity =
            NoParityTest::for_estimator(est, parity.is_some(), Settings::default(), rate);
        m.set_parity(parity);
    }

    /// One sample's readings: the monitor's verdict and the parts to keep out of the solve
    /// from this sample on (bit per part: isolated by the parity space, or stuck); `est` the
    /// estimator's estimator (the monitor is built at the second sample, when the rate is
    /// known).
    fn step(&mut self, t: f64, p: &[T], est: &Estimator<T, HOST_CAP>) -> (Verdict, u32) {
        self.observe_parts(p);
        let stuck = self.stuck.step(p);
        if self.monitor.is_none() {
            match self.first_t {
                Some(t0) if t > t0 => {
                    let rate = 1.0 / (t - t0);
                    self.rate = Some(rate);
                    self.monitor = Some(FaultMonitor::new(Settings::default(), rate));
                    self.rebuild(est);
                }
                _ => self.first_t = Some(t),
            }
        }
        let Some(m) = &mut self.monitor else {
            return (Verdict::NoTest, stuck);
        };
        let verdict = m.step_with(p, stuck);
        let isolated = m.isolated().filter(|p| *p < 32).map_or(0, |p| 1u32 << p);
        (verdict, isolated | stuck)
    }

    /// Every channel but those of the parts in `parts` (bit per part).
    fn mask(&self, parts: u32) -> ChannelMask {
        let mut mask = self.all;
        for (c, p) in self.part.iter().enumerate() {
            if *p < 32 && parts & (1 << p) != 0 {
                mask = mask.without(c);
            }
        }
        mask
    }
}

impl<T: Real> HostEstimator<T> {
    /// Builds the estimator; errors name what is wrong with the arrangement.
    pub fn new(
        loaded: &LoadedArrangement,
        model: Model,
        options: Options,
    ) -> Result<Self, estimator_core::ConfigError> {
        Ok(HostEstimator {
            est: Estimator::<T, HOST_CAP>::new(&loaded.arrangement, model, options)?,
            faults: Faults::new(loaded, model),
            held: Default::default(),
            run_in: options.initial_omega.is_none().then(Vec::new),
        })
    }

    /// Switches fault isolation off (on by default in model G): for a record whose geometry is
    /// being identified (`ballisto calibrate`), every sample is inconsistent with the nominal
    /// one.
    pub fn without_fault_isolation(mut self) -> Self {
        self.faults = None;
        self
    }

    /// One sample; `emit` receives the rows decided, oldest first (delayed while their sign is
    /// unresolved, up to [`SIGN_HOLD_S`]).
    pub fn push(&mut self, t: f64, p: &[T], mut emit: impl FnMut(f64, &Estimate<T>)) {
        self.push_masked(t, p, |t, e, _, _| emit(t, e));
    }

    /// End of the record: emits the rows still held, as they are.
    pub fn finish(&mut self, mut emit: impl FnMut(f64, &Estimate<T>)) {
        self.finish_masked(|t, e, _, _| emit(t, e));
    }

    /// As [`Self::finish`], with the channels and the model of each row.
    pub fn finish_masked(&mut self, mut emit: impl FnMut(f64, &Estimate<T>, ChannelMask, Model)) {
        self.start_after_run_in(&mut emit);
        for (t, e, m, model) in self.held.drain(..) {
            emit(t, &e, m, model);
        }
    }

    /// As [`Self::push`]; `emit` also receives the channels the row's estimate used and the
    /// model it was made in (model F instead of model G while exclusions leave model G
    /// unobservable).
    pub fn push_masked(
        &mut self,
        t: f64,
        p: &[T],
        mut emit: impl FnMut(f64, &Estimate<T>, ChannelMask, Model),
    ) {
        if let Some(buf) = &mut self.run_in {
            buf.push((t, p.to_vec()));
            if t - buf[0].0 < RUN_IN_S {
                return;
            }
            self.start_after_run_in(&mut emit);
            return;
        }
        self.decide(t, p, &mut emit);
    }

    /// The backward run-in over the gathered first samples (a fresh estimator on the same
    /// configuration, times reversed, Ω negated), its settled rate as the forward run's hint,
    /// then the gathered samples forward. Nothing if the run-in has been made.
    fn start_after_run_in(&mut self, emit: &mut impl FnMut(f64, &Estimate<T>, ChannelMask, Model)) {
        let Some(buf) = self.run_in.take() else {
            return;
        };
        let Some(t_end) = buf.last().map(|s| s.0) else {
            return;
        };
        let (arr, model, options) = (self.est.arrangement(), self.est.model(), self.est.options());
        if let Ok(mut back) = Estimator::<T, HOST_CAP>::new(arr, model, options) {
            let mut last = None;
            for (t, p) in buf.iter().rev() {
                last = Some(*back.update(t_end - t, p));
            }
            let unsettled = Flags::SIGN_UNRESOLVED
                | Flags::BRANCH_AMBIGUOUS
                | Flags::INPUT_INVALID
                | Flags::FALLBACK;
            if let Some(e) = last.filter(|e| e.flags.0 & unsettled == 0 && e.is_finite()) {
                let _ = self.est.set_hint(Some(e.omega.map(|v| -v.to_f64())));
            }
        }
        for (t, p) in &buf {
            self.decide(*t, p, &mut *emit);
        }
    }

    /// One sample through the estimator, its row emitted or held for its sign.
    fn decide(
        &mut self,
        t: f64,
        p: &[T],
        mut emit: impl FnMut(f64, &Estimate<T>, ChannelMask, Model),
    ) {
        let (out, mask, model) = self.estimate(t, p);
        let settled =
            !out.flags.has(Flags::SIGN_UNRESOLVED) && !out.flags.has(Flags::INPUT_INVALID);
        if !settled {
            self.held.push_back((t, out, mask, model));
            while self.held.front().is_some_and(|h| t - h.0 > SIGN_HOLD_S) {
                if let Some((t, e, m, model)) = self.held.pop_front() {
                    emit(t, &e, m, model);
                }
            }
            return;
        }
        // This row settles the sign: the held rows take the sign that continues it backwards
        // (Ω moves by Ω′Δ between samples, the other sign is 2|Ω| away).
        let mut next = out.omega;
        for (_, e, _, _) in self.held.iter_mut().rev() {
            if e.flags.has(Flags::SIGN_UNRESOLVED) && !e.flags.has(Flags::INPUT_INVALID) {
                let keep: T = (0..3)
                    .map(|i| (e.omega[i] - next[i]) * (e.omega[i] - next[i]))
                    .fold(T::ZERO, |a, b| a + b);
                let flip: T = (0..3)
                    .map(|i| (e.omega[i] + next[i]) * (e.omega[i] + next[i]))
                    .fold(T::ZERO, |a, b| a + b);
                if flip < keep {
                    e.omega = e.omega.map(|v| -v);
                }
                e.flags.0 &= !Flags::SIGN_UNRESOLVED;
            }
            next = e.omega;
        }
        for (t, e, m, model) in self.held.drain(..) {
            emit(t, &e, m, model);
        }
        emit(t, &out, mask, model);
    }

    /// The estimate of one sample, with the channels it used and its model.
    fn estimate(&mut self, t: f64, p: &[T]) -> (Estimate<T>, ChannelMask, Model) {
        let used = self.isolate(t, p);
        if let Some(f) = &mut self.faults {
            // A new channel set in force: the last samples through it first (their estimates
            // dropped), so that the rate filter meets this one warm (as the firmware).
            if std::mem::take(&mut f.replay_due) {
                let est = &mut self.est;
                f.recent.replay(|t, p| {
                    est.update(t, p);
                });
            }
            f.recent.push(t, p);
        }
        let mut out = *self.est.update(t, p);
        if let Some(f) = &mut self.faults {
            // With no parity space, model G's known-field test or model F's own residual on
            // the estimate flags the row (as the firmware's).
            let field = f.no_parity.step(&out);
            let verdict = used.verdict.with_field(field);
            // In model F on the channels left by an exclusion there is no test: a suspicion
            // stands until a test clears it or an isolated part is taken out (as in the
            // firmware).
            let verdict = f.suspicion.hold(verdict, used.newly_out);
            let residual_high = used.residual_high || verdict == Verdict::NotIsolated;
            let verdict = if residual_high {
                out.flags.0 |= Flags::RESIDUAL_HIGH;
                Verdict::NotIsolated
            } else {
                Verdict::Clean
            };
            f.trusted.observe(t, &out, verdict);
            if out.is_finite() && !out.flags.has(Flags::INPUT_INVALID) {
                f.last_omega = Some(out.omega.map(|v| v.to_f64()));
            }
        }
        (out, used.mask, used.model)
    }

    /// The fault monitor's step and the parts missing too long (as the firmware's
    /// `Estimation::process`): the estimator takes the channel mask they decide — in model F
    /// where the channels left do not carry model G — restarting from the trusted rate when
    /// an isolated part leaves or re-enters, from the last rate when a missing one does;
    /// returns what the row used and whether it gets flag 64.
    fn isolate(&mut self, t: f64, p: &[T]) -> RowUse {
        let Some(f) = &mut self.faults else {
            return RowUse {
                mask: self.est.mask(),
                model: self.est.model(),
                residual_high: false,
                verdict: Verdict::NoTest,
                newly_out: false,
            };
        };
        let (verdict, isolated) = f.step(t, p, &self.est);
        let isolated_before = f.isolated;
        let wanted = f.runs.wanted(f.missing);
        if wanted != f.missing || (isolated != f.isolated && f.refused != Some(isolated)) {
            // Replayed as in the firmware (only a change that takes channels out); the hint is
            // for the first sample the estimator will see.
            let mask = f.mask(wanted | isolated);
            let replay = replays(self.est.mask(), mask);
            let from = f.recent.first_seen(replay, t);
            let hint = if isolated != f.isolated {
                f.trusted.hint_at(from).or(f.last_omega)
            } else {
                f.last_omega
            };
            let model_before = self.est.model();
            if let Some(restarted) = set_mask(&mut self.est, mask, f.preferred, hint) {
                let stale = wanted != f.missing || self.est.model() != model_before;
                f.missing = wanted;
                f.isolated = isolated;
                f.replay_due = restarted && replay;
                if stale {
                    f.rebuild(&self.est);
                }
            } else {
                f.refused = Some(isolated);
            }
        }
        // A part isolated that the solve could not leave out (too few channels): flag 64.
        let kept = isolated & !f.isolated != 0;
        RowUse {
            mask: self.est.mask(),
            model: self.est.model(),
            residual_high: kept,
            verdict,
            newly_out: f.isolated & !isolated_before != 0,
        }
    }
}

/// Takes `mask` in the `preferred` model, or in model F where the channels do not carry it (if
/// mask and model are not the ones in force: [`Estimator::set_mask_in`]), and restarts branch
/// and sign from `hint`; `None` if the estimator refuses the mask (too few channels left for
/// either model), else whether it restarted.
fn set_mask<T: Real>(
    est: &mut Estimator<T, HOST_CAP>,
    mask: ChannelMask,
    preferred: Model,
    hint: Option<[f64; 3]>,
) -> Option<bool> {
    if est.mask() == mask && est.model() == preferred {
        return Some(false);
    }
    est.set_mask_in(mask, preferred).ok()?;
    if est.set_hint(hint).is_err() {
        let _ = est.set_hint(None);
    }
    Some(true)
}

fn run_typed<T: Real + Send + 'static>(
    job: &EstimateJob,
    loaded: &LoadedArrangement,
    model: Model,
) -> Result<Summary, Box<dyn Error>> {
    let mut est = HostEstimator::<T>::new(loaded, model, job.options)
        .map_err(|e| format!("{}: {e}", job.arrangement.display()))?;
    let mut reader = SamplesReader::open(job.samples, &loaded.names)?.with_ranges(&loaded.ranges);
    // Written beside the final path, put in place once complete (`crate::output`).
    let (pending, out) = crate::output::create(job.out)?;
    let mut w = ThreadedWriter::<T>::new(out);
    let mut row = vec![0.0f64; loaded.names.len()];
    let mut p = vec![T::ZERO; loaded.names.len()];
    let mut summary = Summary {
        model: Some(model),
        channels: loaded.names.len(),
        ..Default::default()
    };
    let mut io_err: Option<std::io::Error> = None;
    let all = ChannelMask::all(loaded.names.len());
    // The times of rows with an absurd reading, not yet emitted (the estimator emits in order).
    let absurd_rows = std::cell::RefCell::new(std::collections::VecDeque::<f64>::new());
    // |σ0| of every row, for the median ([`plausibility::specific_force`]).
    let mut sigma0 = Vec::new();
    let mut emit = |t: f64, e: &Estimate<T>, mask: ChannelMask, row_model: Model| {
        if io_err.is_some() {
            return;
        }
        let mut e = *e;
        let mut absurd = absurd_rows.borrow_mut();
        while absurd.front().is_some_and(|&a| a < t) {
            absurd.pop_front();
        }
        if absurd.front() == Some(&t) {
            absurd.pop_front();
            e.flags.0 |= Flags::INPUT_ABSURD;
        }
        let gamma = row_model == Model::General;
        if let Err(err) = w.push(t, &e, all.0 & !mask.0, gamma) {
            io_err = Some(err);
        }
        summary.rows += 1;
        count_flags(&mut summary.flag_counts, e.flags);
        let s = e
            .sigma0
            .iter()
            .map(|v| v.to_f64().powi(2))
            .sum::<f64>()
            .sqrt();
        if s.is_finite() && !e.flags.has(Flags::INPUT_INVALID) {
            sigma0.push(s as f32);
        }
    };
    // Temperature compensation (`estimator_core::thermal`): each channel with coefficients, at
    // the last temperature its column gave; uncorrected rows counted for a warning.
    let mut temps = vec![f64::NAN; loaded.names.len()];
    let mut uncorrected = vec![0u64; loaded.names.len()];
    let result = loop {
        match reader.next_row(&mut row) {
            Ok(Some(t)) => {
                if let Err(e) = reader.temperatures(&mut temps) {
                    break Err(e);
                }
                correct_for_temperature(loaded, &temps, &mut row, &mut uncorrected);
                for (pi, ri) in p.iter_mut().zip(row.iter()) {
                    *pi = T::of(*ri);
                }
                if reader.row_absurd() {
                    absurd_rows.borrow_mut().push_back(t);
                }
                est.push_masked(t, &p, &mut emit);
            }
            Ok(None) => break Ok(()),
            Err(e) => break Err(e),
        }
    };
    // Rows accepted before an error are still estimated and written.
    est.finish_masked(&mut emit);
    let written = w.finish();
    if let Some(e) = io_err.or(written.err()) {
        return Err(format!("{}: write failed: {e}", job.out.display()).into());
    }
    if summary.rows == 0 {
        // The pending output is dropped: a previous file of that name stays as it was.
        result?;
        return Err(format!(
            "{}: no sample rows after the header: nothing written",
            job.samples.display()
        )
        .into());
    }
    // The rows accepted before an input error are a whole output: in place, then the error.
    pending.commit()?;
    result?;
    let file = job.arrangement.display().to_string();
    summary
        .warnings
        .extend(plausibility::arrangement(loaded, &file));
    summary
        .warnings
        .extend(reader.absurd_warnings(&loaded.names));
    for (c, n) in uncorrected.iter().enumerate().filter(|(_, n)| **n > 0) {
        let name = &loaded.names[c];
        summary.warnings.push(if reader.has_temperature(c) {
            format!(
                "{}: channel \"{name}\" has temperature coefficients but no temperature before its first temp_{name} value: {n} rows not compensated",
                job.samples.display()
            )
        } else {
            format!(
                "{}: channel \"{name}\" has temperature coefficients but no temp_{name} column: not compensated",
                job.samples.display()
            )
        });
    }
    if !sigma0.is_empty() {
        let mid = sigma0.len() / 2;
        let median = f64::from(*sigma0.select_nth_unstable_by(mid, f32::total_cmp).1);
        summary.warnings.extend(
            plausibility::specific_force(median).map(|w| format!("{}: {w}", job.samples.display())),
        );
    }
    Ok(summary)
}

/// Each channel of `row` with temperature coefficients and a temperature in `temps` corrected to
/// its reading at `t_ref` (`estimator_core::thermal::Thermal::at_reference`); a channel with
/// coefficients and no temperature yet is counted in `uncorrected`.
fn correct_for_temperature(
    loaded: &LoadedArrangement,
    temps: &[f64],
    row: &mut [f64],
    uncorrected: &mut [u64],
) {
    let channels = loaded.arrangement.channels();
    for c in 0..channels.len() {
        let Some(th) = loaded.arrangement.thermal(c) else {
            continue;
        };
        if temps[c].is_nan() {
            uncorrected[c] += 1;
        } else {
            row[c] = th.at_reference(row[c], temps[c], channels[c].bias);
        }
    }
}

/// Names of the flag bits, for summaries and `--help`.
pub const FLAG_NAMES: [(u16, &str); 9] = [
    (Flags::SIGN_UNRESOLVED, "sign unresolved"),
    (Flags::FALLBACK, "no real solution for a / fallback used"),
    (Flags::ILL_CONDITIONED, "ill-conditioned"),
    (Flags::CHANNELS_EXCLUDED, "channel(s) excluded"),
    (Flags::BRANCH_AMBIGUOUS, "branch ambiguous"),
    (Flags::INPUT_INVALID, "input invalid (prediction output)"),
    (Flags::RESIDUAL_HIGH, "residual high (fault suspected)"),
    (
        Flags::INPUT_ABSURD,
        "reading absurd (beyond the part's range; read as missing)",
    ),
    (
        Flags::INTEGRITY_ALERT,
        "integrity alert (a protection level above its alert limit)",
    ),
];

/// Adds one row's flags to the counts per flag bit.
pub fn count_flags(counts: &mut [u64; 16], flags: Flags) {
    for (bit, c) in counts.iter_mut().enumerate() {
        if flags.has(1 << bit) {
            *c += 1;
        }
    }
}
