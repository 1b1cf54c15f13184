//! `ballisto estimate`: the estimator over a samples file, streaming rows to the estimates file
//! (host tools decide branch and sign with a fixed lag).

use std::error::Error;
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

use estimator_core::smoother::Smoother;
use estimator_core::{Estimate, Estimator, Flags, Model, Options, Real};
use hal_sim::arrangement_file::{load_arrangement, LoadedArrangement, HOST_CAP};

use crate::estimates_csv::ThreadedWriter;
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
}

/// Runs the estimator over a samples file, streaming rows to the estimates file. Rows written
/// before an error stay in the output (flushed); the error names file and line.
pub fn estimate_files(job: &EstimateJob) -> Result<Summary, Box<dyn Error>> {
    let loaded = load_arrangement(job.arrangement)?;
    let (model, note) = crate::model_choice::recommend(job.model, &loaded);
    if let Some(note) = note {
        eprintln!("ballisto estimate: {}: {note}", job.arrangement.display());
    }
    match job.precision {
        Precision::F64 => run_typed::<f64>(job, &loaded, model),
        Precision::F32 => run_typed::<f32>(job, &loaded, model),
    }
}

/// Samples by which host tools delay each output so that the branch and sign decisions see the
/// samples that follow (fixed-lag smoothing); at 100 Hz, 1.28 s.
pub const HOST_LAG: usize = 128;

/// The estimator as the host tools run it: the same per-sample code as the firmware, followed
/// by fixed-lag smoothing of branch and sign decisions ([`estimator_core::smoother`]).
pub struct HostEstimator<T: Real> {
    est: Estimator<T, HOST_CAP>,
    smoother: Box<Smoother<T, HOST_LAG>>,
}

impl<T: Real> HostEstimator<T> {
    /// Builds the estimator; errors name what is wrong with the arrangement.
    pub fn new(
        loaded: &LoadedArrangement,
        model: Model,
        options: Options,
    ) -> Result<Self, estimator_core::ConfigError> {
        let est = Estimator::<T, HOST_CAP>::new(&loaded.arrangement, model, options)?;
        let mut smoother = Box::new(Smoother::new());
        if model == Model::FreeFloat {
            smoother.set_free_float_gamma(Some(options.gamma.cast()));
        }
        smoother.set_frame_uncertainty(est.frame_uncertainty());
        Ok(HostEstimator { est, smoother })
    }

    /// One sample; `emit` receives the decided outputs (delayed by [`HOST_LAG`] samples).
    pub fn push(&mut self, t: f64, p: &[T], mut emit: impl FnMut(f64, &Estimate<T>)) {
        if let Some((t0, e)) = self.smoother.make_room() {
            emit(t0, &e);
        }
        self.est.update_with(t, p, Some(self.smoother.slot()));
        self.smoother.commit();
    }

    /// End of the record: emits what is still held.
    pub fn finish(&mut self, mut emit: impl FnMut(f64, &Estimate<T>)) {
        self.smoother.drain(|t, e| emit(t, &e));
    }
}

fn run_typed<T: Real + Send + 'static>(
    job: &EstimateJob,
    loaded: &LoadedArrangement,
    model: Model,
) -> Result<Summary, Box<dyn Error>> {
    let mut est = HostEstimator::<T>::new(loaded, model, job.options)
        .map_err(|e| format!("{}: {e}", job.arrangement.display()))?;
    let mut reader = SamplesReader::open(job.samples, &loaded.names)?;
    let out =
        File::create(job.out).map_err(|e| format!("{}: cannot create: {e}", job.out.display()))?;
    let mut w = ThreadedWriter::<T>::new(
        BufWriter::with_capacity(1 << 16, out),
        model == Model::General,
    );
    let mut row = vec![0.0f64; loaded.names.len()];
    let mut p = vec![T::ZERO; loaded.names.len()];
    let mut summary = Summary {
        model: Some(model),
        channels: loaded.names.len(),
        ..Default::default()
    };
    let mut io_err: Option<std::io::Error> = None;
    let mut emit = |t: f64, e: &Estimate<T>| {
        if io_err.is_some() {
            return;
        }
        if let Err(err) = w.push(t, e) {
            io_err = Some(err);
        }
        summary.rows += 1;
        count_flags(&mut summary.flag_counts, e.flags);
    };
    let result = loop {
        match reader.next_row(&mut row) {
            Ok(Some(t)) => {
                for (pi, ri) in p.iter_mut().zip(row.iter()) {
                    *pi = T::of(*ri);
                }
                est.push(t, &p, &mut emit);
            }
            Ok(None) => break Ok(()),
            Err(e) => break Err(e),
        }
    };
    // Rows accepted before an error are still estimated and written.
    est.finish(&mut emit);
    let written = w.finish();
    if let Some(e) = io_err.or(written.err()) {
        return Err(format!("{}: write failed: {e}", job.out.display()).into());
    }
    result?;
    Ok(summary)
}

/// Names of the flag bits, for summaries and `--help`.
pub const FLAG_NAMES: [(u16, &str); 7] = [
    (Flags::SIGN_UNRESOLVED, "sign unresolved"),
    (Flags::FALLBACK, "no real solution for a / fallback used"),
    (Flags::ILL_CONDITIONED, "ill-conditioned"),
    (Flags::CHANNELS_EXCLUDED, "channel(s) excluded"),
    (Flags::BRANCH_AMBIGUOUS, "branch ambiguous"),
    (Flags::INPUT_INVALID, "input invalid (prediction output)"),
    (Flags::RESIDUAL_HIGH, "residual high (fault suspected)"),
];

/// Adds one row's flags to the counts per flag bit.
pub fn count_flags(counts: &mut [u64; 16], flags: Flags) {
    for (bit, c) in counts.iter_mut().enumerate() {
        if flags.has(1 << bit) {
            *c += 1;
        }
    }
}
