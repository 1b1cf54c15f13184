//! `ballisto sim`: runs a scenario — the parts read through their buses by the bench reader at
//! the scenario's rate — and writes `arrangement.toml`, `samples.csv` and `truth.csv`
//! (docs/formats.md); with `--estimate` also `estimates.csv`, the errors against the truth and a
//! plot.

use std::error::Error;
use std::io::Write;
use std::path::{Path, PathBuf};

use ballisto_config::arrangement_file::LoadedArrangement;
use hal_sim::recorder::Recorder;
use hal_sim::scenario::Scenario;

use crate::compare::{compare, Comparison};
use crate::estimate::{estimate_files, EstimateJob, Precision};
use crate::samples_csv;
use crate::truth_csv::TruthFiles;

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
    /// Run the firmware's tasks instead of the bench reader: its samples and its estimates
    /// (implies the comparison and the plot), with this alignment of free-running parts.
    pub firmware: Option<ballisto_fw::config::Alignment>,
    /// With `firmware`: identify in flight first (paper §6). A first boot on an
    /// erased calibration store gets the scenario's reference gyro by telecommand
    /// (TC[200,8–11]: window, reference points, report, commit; its telemetry in
    /// `telemetry-identify.bin`), or, in a scenario without one, a torque-free tumble's
    /// inertia (TC[200,8] source 2, the same window); the unit is reset, boots with the stored
    /// calibration and runs the scenario again: that second boot is what the other files hold.
    /// Where the scenario's temperature changes, windows spread over the run
    /// (`in_flight::Plan::for_scenario`), the last one's solution committed with the
    /// coefficients the unit's thermal track decides.
    pub identify: bool,
    /// With `firmware` (not `identify`): telecommand frames sent on the unit's command link,
    /// each chunk at its scenario time (s), e.g. what `ballisto tc` wrote.
    pub uplink: Vec<(f64, Vec<u8>)>,
    /// With `firmware`: a calibrated arrangement file over the scenario's channels that the
    /// unit's calibration store holds (committed on the ground): the unit boots on it (with
    /// `identify`, its first boot does).
    pub calibration: Option<&'a Path>,
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
    /// Per bus, sample sets only: name, bytes, busy time (s).
    pub buses: Vec<(String, u64, f64)>,
    /// Files written.
    pub files: Vec<PathBuf>,
    /// With `--estimate`: errors against the truth.
    pub errors: Option<Comparison>,
    /// With `--estimate`: rows flagged, per flag bit.
    pub flag_counts: [u64; 16],
    /// With `--firmware`: what the firmware counted and measured.
    pub firmware: Option<hal_sim::firmware_host::FirmwareReport>,
    /// With `--identify`: the first boot's identification reports, events and verifications,
    /// decoded from its telemetry (one line each); with `--calibration`: the stored
    /// calibration the unit booted on.
    pub identification: Vec<String>,
}

/// Every file a run may write in its output directory (which ones: the scenario and the
/// options decide).
pub const OUTPUTS: [&str; 9] = [
    "arrangement.toml",
    "samples.csv",
    "reference.csv",
    "truth.csv",
    "truth_geometry.toml",
    "estimates.csv",
    "estimates.png",
    "telemetry.bin",
    "telemetry-identify.bin",
];

/// The files a run will write and about how large each will be (bytes), from the number of
/// values per row and the bytes a value takes in each file (measured on `tetra-orbit` and
/// `tetra-orbit-thermal`: a reading about 20, a temperature 5, a truth value 21, an estimate
/// 19; the firmware's telemetry about 190 per sample set).
pub fn expected_sizes(job: &SimJob) -> Vec<(&'static str, u64)> {
    let sc = job.scenario;
    let rows = sc.samples() as u64;
    let channels = sc
        .arrangement()
        .expanded_channels("scenario")
        .map_or(0, |c| c.len()) as u64;
    let temps = if sc.temperature.is_some() {
        channels
    } else {
        0
    };
    let firmware = job.firmware.is_some();
    let mut sizes = vec![
        ("samples.csv", rows * (12 + channels * 20 + temps * 5)),
        ("truth.csv", rows * truth_row_bytes(sc)),
    ];
    if let Some(r) = &sc.reference {
        let every = r.rate.map_or(1.0, |hz| (sc.rate / hz).round().max(1.0)) as u64;
        sizes.push(("reference.csv", rows.div_ceil(every) * (12 + 3 * 20)));
    }
    if firmware || job.estimate {
        // The gravity gradient's columns with model G only (12 channels or more).
        let general = sc.model.as_deref() != Some("free-float") && channels >= 12;
        let gamma = if general {
            crate::estimates_csv::GAMMA_COLUMNS.len()
        } else {
            0
        };
        let columns = (crate::estimates_csv::COLUMNS.len()
            + crate::estimates_csv::EXTRA_COLUMNS.len()
            + gamma) as u64;
        sizes.push(("estimates.csv", rows * columns * 19));
    }
    if firmware {
        let boots = if job.identify { 2 } else { 1 };
        sizes.push(("telemetry.bin", boots * rows * 190));
    }
    sizes
}

/// About how many bytes a truth row takes: 26 values of about 21 bytes, but a `0` where the
/// environment makes a column zero (no gravity gradient outside an orbit; no specific force in
/// deep space without drag or burns).
fn truth_row_bytes(sc: &Scenario) -> u64 {
    let env = &sc.environment;
    let mut zeros = 0;
    if env.kind != "orbit" {
        zeros += 6;
    }
    if env.kind == "space" && env.drag.is_none() && env.burns.is_empty() {
        zeros += 3;
    }
    (26 - zeros) * 21 + zeros * 2
}

/// The files [`run_sim_keeping_the_plot`] keeps: what a person reads; the records (the CSV
/// files, the telemetry) are what a long run's size is.
pub const KEPT_WITH_THE_PLOT: [&str; 3] =
    ["arrangement.toml", "truth_geometry.toml", "estimates.png"];

/// Runs a scenario as [`run_sim`] does, with the records in a scratch directory inside
/// `job.out` (removed at the end, and on SIGINT/SIGTERM/SIGHUP): only
/// [`KEPT_WITH_THE_PLOT`] are put in `job.out`, for a person who wants the plot and the
/// summary of a long run without its gigabytes. Needs `job.estimate` or `job.firmware`.
pub fn run_sim_keeping_the_plot(job: &SimJob) -> Result<SimReport, Box<dyn Error>> {
    if !(job.estimate || job.firmware.is_some()) {
        return Err(
            "only the plot is kept, and without --estimate or --firmware there is none".into(),
        );
    }
    std::fs::create_dir_all(job.out)
        .map_err(|e| format!("{}: cannot create the directory: {e}", job.out.display()))?;
    let scratch = crate::output::Scratch::new(job.out)?;
    let inner = SimJob {
        out: scratch.path(),
        uplink: job.uplink.clone(),
        ..*job
    };
    let mut report = run_sim(&inner)?;
    let mut kept = Vec::new();
    for name in KEPT_WITH_THE_PLOT {
        let from = scratch.path().join(name);
        if from.exists() {
            let to = job.out.join(name);
            std::fs::rename(&from, &to)
                .map_err(|e| format!("{}: cannot put in place: {e}", to.display()))?;
            kept.push(to);
        }
    }
    report.files = kept;
    Ok(report)
}

/// Runs a scenario (see the module doc).
pub fn run_sim(job: &SimJob) -> Result<SimReport, Box<dyn Error>> {
    let sc = job.scenario;
    std::fs::create_dir_all(job.out)
        .map_err(|e| format!("{}: cannot create the directory: {e}", job.out.display()))?;
    let path = |name: &str| job.out.join(name);
    let arrangement = sc.arrangement();
    // Every file written beside its final path and put in place once complete
    // (`crate::output`).
    crate::output::write(&path("arrangement.toml"), arrangement.to_toml().as_bytes())?;
    let loaded = arrangement
        .load("arrangement.toml")
        .map_err(|e| format!("the scenario's arrangement: {e}"))?;
    let (samples_out, mut samples) = crate::output::create(&path("samples.csv"))?;
    let (reference_out, reference) = match hal_sim::reference::ReferenceSensor::of(sc) {
        Some(sensor) => {
            let (out, w) = crate::output::create(&path("reference.csv"))?;
            (Some(out), Some((w, sensor)))
        }
        None => (None, None),
    };
    let (truth_out, truth_w) = crate::output::create(&path("truth.csv"))?;
    let mut truth = TruthFiles::new(truth_w, reference)?;
    // With a scenario that models temperature, the parts' temperatures as the firmware or the
    // bench reader read them are in the record (`temp_<channel>`, docs/formats.md
    // "Temperature").
    let temperatures = sc.temperature.is_some();
    let temp_columns: Vec<String> = if temperatures {
        loaded.names.iter().map(|n| format!(",temp_{n}")).collect()
    } else {
        Vec::new()
    };
    // The firmware's record carries each reading's noise variance as the sampler gave it
    // (`var_<channel>`, docs/formats.md "Variance"): `ballisto estimate` then runs the fault
    // supervisor on the unit's own input.
    let var_columns: Vec<String> = if job.firmware.is_some() {
        loaded.names.iter().map(|n| format!(",var_{n}")).collect()
    } else {
        Vec::new()
    };
    writeln!(
        samples,
        "t,{}{}{}",
        loaded.names.join(","),
        temp_columns.concat(),
        var_columns.concat()
    )?;
    let mut report = match job.firmware {
        Some(alignment) => record_firmware(
            job,
            &loaded,
            alignment,
            temperatures,
            &mut samples,
            &mut truth,
        )?,
        None => record_bench(job, &loaded, temperatures, &mut samples, &mut truth)?,
    };
    samples.flush()?;
    truth.flush()?;
    for out in [Some(samples_out), Some(truth_out), reference_out]
        .into_iter()
        .flatten()
    {
        out.commit()?;
    }
    report.files = vec![
        path("arrangement.toml"),
        path("samples.csv"),
        path("truth.csv"),
    ];
    if sc.reference.is_some() {
        report.files.push(path("reference.csv"));
    }
    if sc.has_part_errors() {
        let file = path("truth_geometry.toml");
        crate::output::write(&file, sc.truth_geometry().to_toml().as_bytes())?;
        report.files.push(file);
    }
    let est = path("estimates.csv");
    if job.firmware.is_none() && job.estimate {
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
            progress: false,
        })?;
        report.flag_counts = summary.flag_counts;
    }
    if job.firmware.is_some() || job.estimate {
        report.errors = Some(compare(&path("truth.csv"), &est)?);
        report.files.push(est.clone());
        let png = path("estimates.png");
        let (plot, _) = crate::output::Pending::new(&png)?;
        crate::plot::plot_files(&crate::plot::PlotJob {
            truth: &path("truth.csv"),
            estimates: &est,
            samples: temperatures.then(|| path("samples.csv")).as_deref(),
            heading: &plot_heading(job),
            png: plot.path(),
        })?;
        plot.commit()?;
        report.files.push(png);
    }
    if job.firmware.is_some() {
        report.files.push(path("telemetry.bin"));
    }
    if job.identify {
        report.files.push(path("telemetry-identify.bin"));
    }
    Ok(report)
}

/// What a run's plot shows, for its heading: the scenario (its description), the kind of
/// parts (their noise, whether they carry mounting and sensor errors and temperature
/// coefficients), the rate and length, and whose estimates.
fn plot_heading(job: &SimJob) -> Vec<String> {
    let sc = job.scenario;
    let mut types: Vec<&str> = sc.parts.iter().map(|p| p.part.label()).collect();
    types.dedup();
    let noise = if sc.parts.iter().any(|p| p.noise_density == Some(0.0)) {
        "noise-free"
    } else if sc.parts.iter().any(|p| p.noise_density.is_some()) {
        "the scenario's noise"
    } else {
        "datasheet noise"
    };
    let errors = if sc.has_part_errors() {
        "with mounting and sensor errors (truth_geometry.toml)"
    } else {
        "mounted as designed, no sensor errors"
    };
    let thermal = if sc
        .parts
        .iter()
        .any(|p| p.bias_tc.is_some() || p.scale_tc.is_some())
    {
        ", temperature coefficients"
    } else {
        ""
    };
    let whose = match (job.firmware.is_some(), job.identify) {
        (true, true) => "the firmware (f32), after identifying in flight",
        (true, false) => "the firmware (f32)",
        _ => "ballisto estimate (f64)",
    };
    vec![
        sc.description.clone(),
        format!(
            "{} × {}: {noise}, {errors}{thermal}  ·  {} Hz, {} s  ·  estimates of {whose}",
            sc.parts.len(),
            types.join(" + "),
            sc.rate,
            sc.duration
        ),
    ]
}

/// The bench reader's record (with `temperatures`, the `temp_<channel>` columns after the
/// channels).
fn record_bench(
    job: &SimJob,
    loaded: &LoadedArrangement,
    temperatures: bool,
    samples: &mut impl Write,
    truth: &mut TruthFiles<impl Write>,
) -> Result<SimReport, Box<dyn Error>> {
    let sc = job.scenario;
    let mut rec = Recorder::new(sc)?;
    // Column of each part axis in estimator channel order (the arrangement's order).
    let columns: Vec<Vec<(usize, usize)>> = sc
        .parts
        .iter()
        .map(|p| {
            Scenario::part_axes(p)
                .into_iter()
                .filter_map(|j| loaded.channel(&p.name, j).map(|c| (j, c)))
                .collect()
        })
        .collect();
    let n = sc.samples();
    let bar = progress_bar(job.progress, n as u64);
    let channels = loaded.names.len();
    let mut row: Vec<Option<f64>> = vec![None; if temperatures { 2 * channels } else { channels }];
    for k in 0..n {
        let (t, set) = rec.sample_set(k);
        row.iter_mut().for_each(|v| *v = None);
        for (reading, cols) in set.iter().zip(columns.iter()) {
            if let Ok(a) = reading {
                for &(j, c) in cols {
                    row[c] = Some(a[j]);
                }
            }
        }
        if let Some(temps) = rec.temperatures(k) {
            for (temp, cols) in temps.iter().zip(columns.iter()) {
                for &(_, c) in cols {
                    row[channels + c] = *temp;
                }
            }
        }
        samples_csv::write_row(samples, t, row.iter().copied())?;
        truth.row(k, &rec.truth(t))?;
        if k % 1024 == 0 {
            bar.set_position(k as u64);
        }
    }
    bar.finish_and_clear();
    Ok(SimReport {
        samples: n,
        channels: loaded.names.len(),
        parts: sc
            .parts
            .iter()
            .enumerate()
            .map(|(i, p)| PartCount {
                name: p.name.clone(),
                reads: rec.reader().reads[i],
                errors: rec.reader().errors[i],
            })
            .collect(),
        buses: rec.sampling_usage(),
        files: Vec::new(),
        errors: None,
        flag_counts: [0; 16],
        firmware: None,
        identification: Vec::new(),
    })
}

/// The channels of the parts in `parts` (the simulator commands no exclusion).
fn excluded_channels(
    config: &ballisto_fw::config::AppConfig,
    parts: ballisto_link::PartSet,
) -> u64 {
    let mut bits = 0u64;
    for (i, p) in config.sampling.parts() {
        if parts.contains(i) {
            for c in p.channels.iter().flatten() {
                bits |= 1 << c;
            }
        }
    }
    bits
}

/// The firmware's record: its sample sets (with `temperatures`, the parts' temperatures where
/// they changed), the truth at their instants, its estimates.
fn record_firmware(
    job: &SimJob,
    loaded: &LoadedArrangement,
    alignment: ballisto_fw::config::Alignment,
    temperatures: bool,
    samples: &mut impl Write,
    truth: &mut TruthFiles<impl Write>,
) -> Result<SimReport, Box<dyn Error>> {
    use hal_sim::firmware_host::{firmware_config, run_firmware_with, SimTime};
    let sc = job.scenario;
    let config = firmware_config(sc, loaded, alignment)?;
    let path = job.out.join("estimates.csv");
    let (estimates_out, mut estimates) = crate::output::create(&path)?;
    crate::estimates_csv::write_header(&mut estimates)?;
    let n = sc.samples();
    let bar = progress_bar(job.progress, n as u64);
    let channels = loaded.names.len();
    let columns = if temperatures { 3 } else { 2 };
    let mut row: Vec<Option<f64>> = vec![None; columns * channels];
    let mut flag_counts = [0u64; 16];
    let mut last_temperature = [f32::NAN; ballisto_fw::config::MAX_PARTS];
    let mut failure: Option<std::io::Error> = None;
    let mut emit = |set: &ballisto_fw::sampler::SampleSet,
                    m: &ballisto_fw::estimation::SetEstimate,
                    tr: &hal_sim::motion::Truth| {
        let t = SimTime::seconds(set.t);
        firmware_row(&mut row, &config, set, temperatures, &mut last_temperature);
        crate::estimate::count_flags(&mut flag_counts, m.estimate.flags);
        let r = samples_csv::write_row(samples, t, row.iter().copied())
            .and_then(|_| truth.row(set.k as usize, tr))
            .and_then(|_| {
                crate::estimates_csv::write_row(
                    &mut estimates,
                    t,
                    &m.estimate,
                    m.model == estimator_core::Model::General,
                    excluded_channels(&config, m.excluded),
                )
            });
        if let Err(e) = r {
            failure.get_or_insert(e);
        }
        if set.k.is_multiple_of(1024) {
            bar.set_position(u64::from(set.k));
        }
    };
    let tm_path = job.out.join("telemetry.bin");
    let (downlink_out, mut downlink) = crate::output::create(&tm_path)?;
    let mut identification = Vec::new();
    let fw = if job.identify {
        use hal_sim::in_flight::{identify_and_reboot, uplink, uplink_tumble, Plan};
        let plans = Plan::for_scenario(sc);
        let up = if sc.reference.is_some() {
            uplink(sc, &plans)?
        } else {
            // Without a reference: a torque-free tumble over the same windows, means of 40 ms
            // kept.
            uplink_tumble(sc, &plans, 40)
                .map_err(|e| format!("{e}; and no [reference] sensor to identify with"))?
        };
        let calibration = match job.calibration {
            Some(path) => {
                let c = stored_calibration(path, loaded)?;
                identification.push(format!(
                    "booted on the stored calibration {} (first boot)",
                    path.display()
                ));
                Some(c)
            }
            None => None,
        };
        let first_path = job.out.join("telemetry-identify.bin");
        let mut first = Vec::new();
        let (_, second, id) = identify_and_reboot(
            sc,
            &config,
            calibration.as_ref(),
            &up,
            &mut first,
            &mut downlink,
            &mut emit,
        )?;
        crate::output::write(&first_path, &first)?;
        identification.extend(identification_lines(&first));
        identification.push(format!(
            "second boot: calibration {:?} id={} crc={:#010x}",
            id.source, id.id, id.crc
        ));
        second
    } else if let Some(path) = job.calibration {
        let calibration = stored_calibration(path, loaded)?;
        let (report, id) = hal_sim::in_flight::boot_on_stored(
            sc,
            &config,
            &calibration,
            &job.uplink,
            &mut downlink,
            &mut emit,
        )
        .map_err(|e| format!("{}: {e}", path.display()))?;
        identification.push(format!(
            "booted on the stored calibration {:?} id={} crc={:#010x} ({})",
            id.source,
            id.id,
            id.crc,
            path.display()
        ));
        report
    } else {
        run_firmware_with(sc, &config, n as u32, &job.uplink, &mut downlink, &mut emit)
            .map_err(|e| format!("{}: {e}", tm_path.display()))?
    };
    bar.finish_and_clear();
    if let Some(e) = failure {
        return Err(e.into());
    }
    crate::output::finish(estimates_out, estimates)?;
    crate::output::finish(downlink_out, downlink)?;
    Ok(SimReport {
        samples: fw.estimates as usize,
        channels: loaded.names.len(),
        parts: sc
            .parts
            .iter()
            .zip(fw.parts.iter())
            .map(|(p, h)| PartCount {
                name: p.name.clone(),
                reads: u64::from(h.reads),
                errors: u64::from(h.bus_errors + h.implausible),
            })
            .collect(),
        buses: fw.buses.clone(),
        files: Vec::new(),
        errors: None,
        flag_counts,
        firmware: Some(fw),
        identification,
    })
}

/// One set's row of the firmware's samples file: each channel's reading, then (with
/// `temperatures`) its part's temperature where it changed since `last_temperature`, then its
/// variance where it is not one sample's (interpolated or extrapolated).
fn firmware_row(
    row: &mut [Option<f64>],
    config: &ballisto_fw::config::AppConfig,
    set: &ballisto_fw::sampler::SampleSet,
    temperatures: bool,
    last_temperature: &mut [f32; ballisto_fw::config::MAX_PARTS],
) {
    use hal_sim::firmware_host::for_each_channel;
    let channels = config.arrangement.len();
    let var_at = if temperatures { 2 * channels } else { channels };
    row.iter_mut().for_each(|v| *v = None);
    for_each_channel(&config.sampling, set, |c, x| row[c] = Some(f64::from(x)));
    // A reading's variance where it is not one sample's (interpolated or extrapolated).
    for (part, &v) in config.sampling.parts.iter().zip(&set.variance) {
        if v != 1.0 {
            for c in part.iter().flat_map(|p| p.channels.iter().flatten()) {
                if row[usize::from(*c)].is_some() {
                    row[var_at + usize::from(*c)] = Some(f64::from(v));
                }
            }
        }
    }
    if temperatures {
        // A part's temperature where it changed (the column holds the last one).
        for (i, (&t, part)) in set
            .temperatures
            .iter()
            .zip(&config.sampling.parts)
            .enumerate()
        {
            if t.is_nan() || t.to_bits() == last_temperature[i].to_bits() {
                continue;
            }
            last_temperature[i] = t;
            for c in part.iter().flat_map(|p| p.channels.iter().flatten()) {
                row[channels + usize::from(*c)] = Some(f64::from(t));
            }
        }
    }
}

/// The first boot's identification as log lines (its summary, channels, tracks, the commit
/// and any refusal; on scenario time), and what was damaged in its stream.
fn identification_lines(first: &[u8]) -> Vec<String> {
    use ballisto_link::decode::Report;
    let stream = crate::decode::decode_stream(first);
    let mut lines = Vec::new();
    for p in &stream.packets {
        let wanted = match &p.report {
            Report::IdentificationSummary(_)
            | Report::IdentifiedChannel(_)
            | Report::ThermalTrack(_) => true,
            Report::Event(e) => e.id == ballisto_link::EventId::CalibrationStored,
            Report::Verification(v) => v.failure.is_some(),
            _ => false,
        };
        if wanted {
            // On-board time → scenario time (the unit powers up 50 ms before it starts).
            lines.extend(crate::decode::log_line(p, hal_sim::rig::POWER_ON));
        }
    }
    lines.extend(stream.problems);
    lines
}

/// The calibrated arrangement of `path` as the unit stores it; its channels must be the
/// scenario's, in its order.
fn stored_calibration(
    path: &Path,
    scenario: &LoadedArrangement,
) -> Result<estimator_core::Arrangement<{ ballisto_fw::config::MAX_CHANNELS }>, Box<dyn Error>> {
    let loaded = ballisto_config::arrangement_file::load_arrangement(path)?;
    if loaded.names != scenario.names {
        return Err(format!(
            "{}: its channels ({}) are not the scenario's ({})",
            path.display(),
            loaded.names.join(","),
            scenario.names.join(",")
        )
        .into());
    }
    ballisto_config::firmware_config::firmware_arrangement(&loaded)
        .map_err(|e| format!("{}: {e}", path.display()).into())
}

fn progress_bar(show: bool, n: u64) -> indicatif::ProgressBar {
    // Long runs only: 100 000 sample sets take a few seconds.
    crate::progress::bar(
        show && n >= 100_000,
        n,
        "{bar:40} {pos}/{len} sample sets ({eta} left)",
    )
}
