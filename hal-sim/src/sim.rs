//! `ballisto sim`: runs a scenario — the parts read through their buses by the bench reader at
//! the scenario's rate — and writes `arrangement.toml`, `samples.csv` and `truth.csv`
//! (interfaces.md); with `--estimate` also `estimates.csv`, the errors against the truth and a
//! plot.

use std::error::Error;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::bench::BenchReader;
use crate::compare::{compare, Comparison};
use crate::rig::Rig;
use crate::run::{estimate_files, write_truth_header, write_truth_row, EstimateJob, Precision};
use crate::scenario::Scenario;

/// What to run.
pub struct SimJob<'a> {
    /// The scenario.
    pub scenario: &'a Scenario,
    /// Output directory (created if missing).
    pub out: &'a Path,
    /// Also run the estimator, compare and plot.
    pub estimate: bool,
    /// Show a progress bar (on a terminal, for long runs).
    pub progress: bool,
}

/// Reads and failures of one part.
#[derive(Clone, Debug)]
pub struct PartCount {
    /// Part name.
    pub name: String,
    /// Reads.
    pub reads: u64,
    /// Failed reads (empty fields in samples.csv).
    pub errors: u64,
}

/// What a run produced.
#[derive(Clone, Debug)]
pub struct SimReport {
    /// Sample sets written.
    pub samples: usize,
    /// Channels.
    pub channels: usize,
    /// Per part.
    pub parts: Vec<PartCount>,
    /// Per bus: name, bytes, busy time (s).
    pub buses: Vec<(String, u64, f64)>,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// With `--estimate`: errors against the truth.
    pub errors: Option<Comparison>,
    /// With `--estimate`: rows flagged, per flag bit.
    pub flag_counts: [u64; 16],
}

/// Runs a scenario (see the module doc).
pub fn run_sim(job: &SimJob) -> Result<SimReport, Box<dyn Error>> {
    let sc = job.scenario;
    std::fs::create_dir_all(job.out)
        .map_err(|e| format!("{}: cannot create the directory: {e}", job.out.display()))?;
    let path = |name: &str| job.out.join(name);
    let arrangement = sc.arrangement();
    std::fs::write(path("arrangement.toml"), arrangement.to_toml())
        .map_err(|e| format!("{}: {e}", path("arrangement.toml").display()))?;
    let loaded = arrangement
        .load("arrangement.toml")
        .map_err(|e| format!("the scenario's arrangement: {e}"))?;

    let rig = Rig::build(sc)?;
    let mut reader = BenchReader::start(sc, &rig.ports)?;
    // Column of each part axis in estimator channel order (the arrangement's order).
    let columns: Vec<Vec<(usize, usize)>> = sc
        .parts
        .iter()
        .map(|p| {
            Scenario::part_axes(p)
                .into_iter()
                .filter_map(|j| {
                    let name = format!("{}.{}", p.name, ["x", "y", "z"][j]);
                    loaded.names.iter().position(|n| *n == name).map(|c| (j, c))
                })
                .collect()
        })
        .collect();
    let create = |name: &str| -> Result<BufWriter<File>, String> {
        File::create(path(name))
            .map(|f| BufWriter::with_capacity(1 << 16, f))
            .map_err(|e| format!("{}: cannot create: {e}", path(name).display()))
    };
    let mut samples = create("samples.csv")?;
    let mut truth = create("truth.csv")?;
    writeln!(samples, "t,{}", loaded.names.join(","))?;
    write_truth_header(&mut truth)?;

    let n = sc.samples();
    let bar = progress_bar(job.progress, n as u64);
    let any_sync = sc.parts.iter().any(|p| sc.sync(p));
    let mut row: Vec<Option<f64>> = vec![None; loaded.names.len()];
    for k in 0..n {
        let t = k as f64 / sc.rate;
        rig.clock.advance_to(t);
        if any_sync {
            rig.sync.pulse(t);
        }
        row.iter_mut().for_each(|v| *v = None);
        for (i, cols) in columns.iter().enumerate() {
            if let Ok(a) = reader.read(i) {
                for &(j, c) in cols {
                    row[c] = Some(a[j]);
                }
            }
        }
        write!(samples, "{t}")?;
        for v in &row {
            match v {
                Some(v) => write!(samples, ",{v}")?,
                None => write!(samples, ",")?,
            }
        }
        writeln!(samples)?;
        let tr = rig.truth.borrow_mut().truth_at(t);
        write_truth_row(&mut truth, &tr)?;
        if k % 1024 == 0 {
            bar.set_position(k as u64);
        }
    }
    bar.finish_and_clear();
    samples.flush()?;
    truth.flush()?;
    let mut report = SimReport {
        samples: n,
        channels: loaded.names.len(),
        parts: sc
            .parts
            .iter()
            .enumerate()
            .map(|(i, p)| PartCount {
                name: p.name.clone(),
                reads: reader.reads[i],
                errors: reader.errors[i],
            })
            .collect(),
        buses: rig.bus_usage(),
        files: vec![
            path("arrangement.toml"),
            path("samples.csv"),
            path("truth.csv"),
        ],
        errors: None,
        flag_counts: [0; 16],
    };
    if job.estimate {
        let est = path("estimates.csv");
        let summary = estimate_files(&EstimateJob {
            arrangement: &path("arrangement.toml"),
            samples: &path("samples.csv"),
            out: &est,
            model: None,
            options: estimator_core::Options {
                initial_omega: sc.initial_omega,
                ..Default::default()
            },
            precision: Precision::F64,
        })?;
        report.flag_counts = summary.flag_counts;
        report.errors = Some(compare(&path("truth.csv"), &est)?);
        report.files.push(est.clone());
        let png = path("estimates.png");
        crate::plot::plot_files(&path("truth.csv"), &est, &png)?;
        report.files.push(png);
    }
    Ok(report)
}

fn progress_bar(show: bool, n: u64) -> indicatif::ProgressBar {
    // Long runs only: 100 000 sample sets take a few seconds.
    if !show || n < 100_000 {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(n);
    if let Ok(style) =
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} sample sets ({eta} left)")
    {
        bar.set_style(style);
    }
    bar
}
