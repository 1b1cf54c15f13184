//! `ballisto estimate`: the estimator over a samples file, streaming rows to the estimates file
//! (the firmware's per-sample code, one row per sample as it arrives).

use std::error::Error;
use std::path::Path;

use ballisto_config::arrangement_file::{load_arrangement, LoadedArrangement, HOST_CAP};
use estimator_core::supervisor::Supervisor;
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
    /// A progress bar on stderr (drawn only on a terminal).
    pub progress: bool,
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

/// Runs the estimator over a samples file, streaming rows to the estimates file, put in place
/// once complete: after an error (naming file and line) the previous file stays as it was.
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
    run_in: Option<Vec<Gathered<T>>>,
}

/// A sample gathered for the run-in: time, readings, and their variances if the record has
/// them.
type Gathered<T> = (f64, Vec<T>, Option<Vec<T>>);

/// Seconds of record run backwards to start the forward run (without a hint).
pub const RUN_IN_S: f64 = 2.0;

/// A row held for its sign: time, estimate, the channels it used and the model it was made in.
type HeldRow<T> = (f64, Estimate<T>, ChannelMask, Model);

/// Most seconds a row is held for its sign; older rows go out as they are (flagged): a
/// steady spin without a hint never settles it.
pub const SIGN_HOLD_S: f64 = 10.0;

/// The fault supervisor of a host run (estimator-core's, as the firmware runs it), and
/// what it needs on the ground: the sample rate from the record's first two times.
struct Faults<T: Real> {
    supervisor: Box<Supervisor<T, HOST_CAP>>,
    first_t: Option<f64>,
    /// The configured model (the estimator's, unless the channels in use do not carry it).
    preferred: Model,
}

impl<T: Real> Faults<T> {
    /// The supervisor over the parts of `loaded`, with the arrangement file's ranges.
    fn new(loaded: &LoadedArrangement, model: Model) -> Self {
        let arr = &loaded.arrangement;
        let part: Vec<u8> = (0..arr.len()).map(|i| arr.part(i)).collect();
        Faults {
            supervisor: Box::new(Supervisor::new(&part, &loaded.ranges, None)),
            first_t: None,
            preferred: model,
        }
    }

    /// The rate from the first two samples' times; once known, the monitor's tests for the
    /// channels of the parts not missing.
    fn learn_rate(&mut self, t: f64, est: &Estimator<T, HOST_CAP>) {
        if self.supervisor.rate_known() {
            return;
        }
        match self.first_t {
            Some(t0) if t > t0 => {
                let tested = self.mask(self.supervisor.missing());
                self.supervisor.set_rate(1.0 / (t - t0), est, tested);
            }
            _ => self.first_t = Some(t),
        }
    }

    /// Every channel but those of the parts in `parts` (bit per part).
    fn mask(&self, parts: u32) -> ChannelMask {
        self.supervisor.without_parts(parts)
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
            faults: Some(Faults::new(loaded, model)),
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
        emit: impl FnMut(f64, &Estimate<T>, ChannelMask, Model),
    ) {
        self.push_with_variance(t, p, None, emit);
    }

    /// As [`Self::push_masked`], with each reading's noise variance over its channel's
    /// declared one (the firmware's sampler's, from a record's `var_<channel>` columns) for
    /// the fault monitor, as the unit's monitor had it.
    pub fn push_with_variance(
        &mut self,
        t: f64,
        p: &[T],
        variance: Option<&[T]>,
        mut emit: impl FnMut(f64, &Estimate<T>, ChannelMask, Model),
    ) {
        if let Some(buf) = &mut self.run_in {
            buf.push((t, p.to_vec(), variance.map(<[T]>::to_vec)));
            if t - buf[0].0 < RUN_IN_S {
                return;
            }
            self.start_after_run_in(&mut emit);
            return;
        }
        self.decide(t, p, variance, &mut emit);
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
            for (t, p, _) in buf.iter().rev() {
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
        for (t, p, v) in &buf {
            self.decide(*t, p, v.as_deref(), &mut *emit);
        }
    }

    /// One sample through the estimator, its row emitted or held for its sign.
    fn decide(
        &mut self,
        t: f64,
        p: &[T],
        variance: Option<&[T]>,
        mut emit: impl FnMut(f64, &Estimate<T>, ChannelMask, Model),
    ) {
        let (out, mask, model) = self.estimate(t, p, variance);
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

    /// The estimate of one sample, with the channels it used and its model: the supervisor's
    /// steps about the estimator's, as in the firmware's `Estimation::process`.
    fn estimate(
        &mut self,
        t: f64,
        p: &[T],
        variance: Option<&[T]>,
    ) -> (Estimate<T>, ChannelMask, Model) {
        let Some(f) = &mut self.faults else {
            let out = *self.est.update(t, p);
            return (out, self.est.mask(), self.est.model());
        };
        f.learn_rate(t, &self.est);
        let verdict = f.supervisor.observe(p, variance);
        f.update_exclusions(t, &mut self.est);
        let est = &mut self.est;
        f.supervisor.before_update(t, p, |t, p| {
            est.update(t, p);
        });
        let mut out = *self.est.update(t, p);
        f.supervisor.after_update(t, &mut out, verdict);
        (out, self.est.mask(), self.est.model())
    }
}

impl<T: Real> Faults<T> {
    /// Takes out the parts the supervisor wants out and includes recovered ones (as the
    /// firmware's `Estimation::update_exclusions`): in model F where the channels left do not
    /// carry model G, restarting from the hint the supervisor gives.
    fn update_exclusions(&mut self, t: f64, est: &mut Estimator<T, HOST_CAP>) {
        let Some(change) = self.supervisor.change() else {
            return;
        };
        let mask = self.mask(change.out());
        let model_before = est.model();
        let before = est.mask();
        let restarted = mask != before;
        if restarted && est.set_mask_in(mask, self.preferred).is_err() {
            // Too few channels left for either model: the mask stays (the rows flagged).
            self.supervisor.refuse(change);
            return;
        }
        let taken = self.supervisor.taken(change, before, mask, t);
        if restarted && est.set_hint(taken.hint).is_err() {
            let _ = est.set_hint(None);
        }
        if taken.missing_changed || est.model() != model_before {
            let tested = self.mask(self.supervisor.missing());
            self.supervisor.rebuild(est, tested);
        }
    }
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
    let (mut var_row, mut var) = (vec![1.0f64; p.len()], vec![T::ONE; p.len()]);
    let with_variance = reader.has_variance();
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
    let mut noise = plausibility::NoiseTrack::new(loaded.names.len());
    let bar = crate::progress::reading(job.progress, job.samples, "estimate");
    let mut read = 0u64;
    let result = loop {
        if read.is_multiple_of(4096) {
            bar.set_position(reader.bytes_read());
        }
        read += 1;
        match reader.next_row(&mut row) {
            Ok(Some(t)) => {
                if let Err(e) = reader.temperatures(&mut temps) {
                    break Err(e);
                }
                // A record without variance columns has none to read or convert per row.
                if with_variance {
                    if let Err(e) = reader.variances(&mut var_row) {
                        break Err(e);
                    }
                    for (vi, ri) in var.iter_mut().zip(&var_row) {
                        *vi = T::of(*ri);
                    }
                }
                correct_for_temperature(loaded, &temps, &mut row, &mut uncorrected);
                noise.push(&row);
                for (pi, ri) in p.iter_mut().zip(row.iter()) {
                    *pi = T::of(*ri);
                }
                if reader.row_absurd() {
                    absurd_rows.borrow_mut().push_back(t);
                }
                let variance = with_variance.then_some(&var[..]);
                est.push_with_variance(t, &p, variance, &mut emit);
            }
            Ok(None) => break Ok(()),
            Err(e) => break Err(e),
        }
    };
    bar.finish_and_clear();
    if let Err(e) = result {
        // The pending output is dropped: a previous file of that name stays as it was.
        return Err(e.into());
    }
    est.finish_masked(&mut emit);
    let written = w.finish();
    if let Some(e) = io_err.or(written.err()) {
        return Err(format!("{}: write failed: {e}", job.out.display()).into());
    }
    if summary.rows == 0 {
        return Err(format!(
            "{}: no sample rows after the header: nothing written",
            job.samples.display()
        )
        .into());
    }
    pending.commit()?;
    summary.warnings.extend(input_warnings(
        job,
        loaded,
        &reader,
        &uncorrected,
        (!with_variance).then_some(&noise),
        &mut sigma0,
    ));
    Ok(summary)
}

/// The warnings on a run's inputs: the arrangement's, absurd readings, channels not
/// compensated for temperature, readings quieter than their declared noise (`noise`, where the
/// arrangement declares it: not with per-row variances) and a median |σ0| of another unit.
fn input_warnings<R: std::io::Read>(
    job: &EstimateJob,
    loaded: &LoadedArrangement,
    reader: &SamplesReader<R>,
    uncorrected: &[u64],
    noise: Option<&plausibility::NoiseTrack>,
    sigma0: &mut [f32],
) -> Vec<String> {
    let mut warnings = Vec::new();
    let file = job.arrangement.display().to_string();
    warnings.extend(plausibility::arrangement(loaded, &file));
    warnings.extend(reader.absurd_warnings(&loaded.names));
    for (c, n) in uncorrected.iter().enumerate().filter(|(_, n)| **n > 0) {
        let name = &loaded.names[c];
        warnings.push(if reader.has_temperature(c) {
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
    if let Some(noise) = noise {
        let declared = loaded.noises();
        warnings.extend(
            noise
                .warning(&declared)
                .map(|w| format!("{}: {w}", job.samples.display())),
        );
    }
    if !sigma0.is_empty() {
        let mid = sigma0.len() / 2;
        let median = f64::from(*sigma0.select_nth_unstable_by(mid, f32::total_cmp).1);
        warnings.extend(
            plausibility::specific_force(median).map(|w| format!("{}: {w}", job.samples.display())),
        );
    }
    warnings
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
pub const FLAG_NAMES: [(u16, &str); 10] = [
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
    (
        Flags::NO_PROTECTION_LEVEL,
        "no protection level (where the configuration gives them)",
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
