//! The fault matrix: fault-free runs and runs of every fault kind in a drawn part, and what
//! they showed, kind by kind.

use hal_sim::scenario::Scenario;

use crate::faults::*;

/// One row of the fault matrix: what the runs of one fault kind (or of none) showed.
#[derive(Debug, Default)]
pub struct Tally {
    /// Runs.
    pub runs: usize,
    /// Runs whose fault was seen within 1 s of its onset, and those latencies (s).
    pub detected: Vec<f64>,
    /// Runs whose faulty part went out of the solve while the fault was active, and when (s
    /// after the onset).
    pub isolated: Vec<f64>,
    /// For a bias or a drift (`None` for other kinds): the runs whose fault the layout can
    /// attribute to its part within [`ISOLATE_WITHIN_S`] ([`attributable`]) at even odds and
    /// with 99 % probability, and of each those isolated within that time.
    pub attributable: Option<[(usize, usize); 2]>,
    /// Rows with a healthy part out of the solve, of `rows`.
    pub wrong_excluded: usize,
    /// Rows from 1 s on.
    pub rows: usize,
    /// Rows before any fault, and those flagged 64 (false alarms).
    pub clean_rows: usize,
    /// Of `clean_rows`, flagged 64.
    pub flagged_clean: usize,
    /// Of `clean_rows`, silently wrong.
    pub silent_clean: usize,
    /// Rows while the fault was active; flagged 64; silently wrong.
    pub active: usize,
    /// Of `active`, flagged 64.
    pub flagged_active: usize,
    /// Of `active`, silently wrong.
    pub silent_active: usize,
    /// Of `active`, rows with the faulty part out.
    pub out_active: usize,
    /// Rows while active from the part's first exclusion on, and of them with the part out.
    pub since_isolation: usize,
    /// See `since_isolation`.
    pub out_since_isolation: usize,
    /// Rows while active from the part's second exclusion on, and of them with the part out.
    pub since_second: usize,
    /// See `since_second`.
    pub out_since_second: usize,
    /// Rows after the fault, and of them silently wrong.
    pub after: usize,
    /// Of `after`, silently wrong.
    pub silent_after: usize,
    /// Squared Ω errors summed over the rows with the faulty part out, and over the same
    /// rows of the run without the fault and without the part.
    pub err_out: f64,
    /// See `err_out`.
    pub err_ref: f64,
    /// Runs whose reference was itself wrong ([`reference_wrong`]): left out of `err_out` and
    /// `err_ref`.
    pub wrong_references: usize,
    /// Estimates not finite.
    pub nan: usize,
    /// Telemetry packets lost.
    pub lost: u32,
    /// The protection levels over every row from 1 s on.
    pub protection: Protection,
}

impl Tally {
    fn add(&mut self, r: &FaultRun) {
        self.runs += 1;
        self.wrong_excluded += r.wrong_excluded;
        self.rows += r.clean_rows + r.active_rows + r.after_rows;
        self.clean_rows += r.clean_rows;
        self.flagged_clean += r.flagged_clean;
        self.silent_clean += r.silent_clean;
        if let Some(l) = r.latency.filter(|l| *l <= 1.0) {
            self.detected.push(l);
        }
        self.active += r.active_rows;
        self.flagged_active += r.flagged_active;
        self.silent_active += r.silent_active;
        self.out_active += r.excluded_active;
        self.since_isolation += r.since_isolation;
        self.out_since_isolation += r.out_since_isolation;
        self.since_second += r.since_second;
        self.out_since_second += r.out_since_second;
        self.after += r.after_rows;
        self.silent_after += r.silent_after;
        self.nan += r.nan;
        self.lost += r.lost;
        self.protection.merge(&r.protection);
    }

    /// The RMS Ω error while the faulty part was out over that of the run without the part.
    pub fn error_ratio(&self) -> Option<f64> {
        (self.err_ref > 0.0).then(|| (self.err_out / self.err_ref).sqrt())
    }
}

/// The fault matrix: `runs` fault-free runs, then `runs` of every kind of [`kinds`], each in
/// one part drawn at random for [`FAULT_S`] from a time drawn in 3–7 s (the draws are the
/// same for the same `runs`), sized by that part's own noise (in the mixed layout a LIS3DH's
/// σ is 13 times an ADXL355's).
pub fn fault_matrix(runs: u64, layout: fn(u64) -> Scenario) -> (Tally, Vec<(&'static str, Tally)>) {
    let mut next = draws(0x9E37_79B9_7F4A_7C15u64);
    let mut clean = Tally::default();
    for seed in 0..runs {
        clean.add(&fault_run(&layout(1000 + seed), None));
    }
    let mut rows = Vec::new();
    for (k, name) in kinds(1.0, 1.0)
        .into_iter()
        .map(|(name, _)| name)
        .enumerate()
    {
        let mut tally = Tally::default();
        for seed in 0..runs {
            let mut sc = layout(2000 + seed);
            let (part, spec) = drawn_fault(&sc, k, &mut next);
            let start = 3.0 + 4.0 * next();
            let bursts = if name.starts_with(INTERMITTENT) {
                // Three bursts from 2–4 s: the window spans their pattern, and the run goes
                // on for FAULT_S after the last.
                let bursts = burst_times(name, 2.0 + 0.5 * (start - 3.0), &mut next);
                sc.duration = sc.duration.max(bursts[BURSTS - 1].1 + FAULT_S);
                bursts
            } else {
                vec![(start, start + FAULT_S)]
            };
            inject(&mut sc, part, &spec, &bursts);
            let window = (bursts[0].0, bursts[bursts.len() - 1].1);
            let r = fault_run(&sc, Some((part, window.0, window.1)));
            if spec.bias.is_some() || spec.rate.is_some() {
                let bias = spec.bias.unwrap_or_default();
                let rate = spec.rate.unwrap_or_default();
                let counts = tally.attributable.get_or_insert([(0, 0); 2]);
                for ((runs, isolated), power) in counts.iter_mut().zip([EVEN_ODDS, SURELY]) {
                    if attributable(&sc, part, bias, rate, power) == Some(true) {
                        *runs += 1;
                        *isolated +=
                            usize::from(r.excluded_after.is_some_and(|l| l <= ISOLATE_WITHIN_S));
                    }
                }
            }
            if let Some(l) = r.excluded_after {
                tally.isolated.push(l);
                let out = r.excluded_errors.iter().map(|(_, e)| e).sum::<f64>();
                let rows = errors_without_part(&sc, part, &r.excluded_errors);
                let reference = rows.iter().map(|r| r.0).sum::<f64>();
                if reference_wrong(&rows) {
                    tally.wrong_references += 1;
                } else {
                    tally.err_out += out;
                    tally.err_ref += reference;
                }
            }
            tally.add(&r);
        }
        rows.push((name, tally));
    }
    (clean, rows)
}
