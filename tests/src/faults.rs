//! Faults through the firmware on a layout with redundancy: the layout, one run
//! with at most one fault in one part, and what the run showed against the truth.

use ballisto_fw::config::{Alignment, AppConfig, MAX_CHANNELS};
use estimator_core::Flags;
use hal_sim::firmware_host::{firmware_config, run_firmware};
use hal_sim::scenario::{FaultSpec, Scenario};

pub use crate::fault_matrix::{fault_matrix, Tally};

/// Flags that warn (everything but the informational "channels excluded", 8).
pub const WARNING: u16 = !Flags::CHANNELS_EXCLUDED;

/// `tetra-orbit` (four ADXL355 on a tetrahedron, ideal parts: noise and clock offsets only)
/// with two more ADXL355s on its SPI bus: N = 18, model G, 6 degrees of freedom in the
/// whitened residual; `duration` s at 100 Hz, no faults yet.
pub fn redundant_layout(seed: u64, duration: f64) -> Scenario {
    let mut sc = Scenario::load("tetra-orbit").unwrap();
    sc.duration = duration;
    sc.seed = seed;
    sc.faults.clear();
    let template = sc.parts[0].clone();
    for (i, (position, cs)) in [([0.12, 0.0, -0.05], 4), ([-0.05, 0.11, 0.08], 5)]
        .into_iter()
        .enumerate()
    {
        let mut p = template.clone();
        p.name = format!("u{}", 4 + i);
        p.position = position;
        p.cs = Some(cs);
        p.orientation = None;
        sc.parts.push(p);
    }
    sc
}

/// `ground-spin-mixed` (two ADXL355 on SPI, two LIS3DH on I²C with their own clocks, a
/// turntable spin-up on the ground) doubled: two more ADXL355 on the SPI bus and two more
/// LIS3DH on a second I²C bus, N = 24, model G: 12 degrees of freedom, parts of two noise
/// levels (the LIS3DH's is ten times the ADXL355's) and free-running clocks; `duration` s at
/// 100 Hz, no faults yet.
pub fn mixed_layout(seed: u64, duration: f64) -> Scenario {
    let mut sc = Scenario::load("ground-spin-mixed").unwrap();
    sc.duration = duration;
    sc.seed = seed;
    sc.faults.clear();
    let mut bus = sc.buses[1].clone();
    bus.name = "i2c2".to_string();
    sc.buses.push(bus);
    let (a, l) = (sc.parts[0].clone(), sc.parts[2].clone());
    for (i, position) in [[0.02, 0.13, -0.09], [-0.12, -0.03, 0.02]]
        .into_iter()
        .enumerate()
    {
        let mut p = a.clone();
        p.name = format!("a{}", 2 + i);
        p.position = position;
        p.cs = Some(2 + i);
        p.orientation = None;
        sc.parts.push(p);
    }
    for (i, position) in [[0.1, 0.08, 0.11], [-0.03, 0.12, -0.11]]
        .into_iter()
        .enumerate()
    {
        let mut p = l.clone();
        p.name = format!("l{}", 2 + i);
        p.position = position;
        p.bus = "i2c2".to_string();
        p.address = Some(0x18 + i as u8);
        sc.parts.push(p);
    }
    sc
}

/// The Ω error of an estimate (the norm) against the truth, and whether it is silently wrong:
/// above `ballisto::compare::SILENT_SD` reported deviations (the norm of the three) with no
/// [`WARNING`] flag.
pub fn omega_error(omega: [f64; 3], truth: [f64; 3], sd: [f64; 3], flags: u16) -> (f64, bool) {
    let norm = |v: [f64; 3]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let err = norm(core::array::from_fn(|k| omega[k] - truth[k]));
    let silent = err > ballisto::compare::SILENT_SD * norm(sd) && flags & WARNING == 0;
    (err, silent)
}

/// [`omega_error`] of one of the firmware's estimates (f32) against the true Ω.
pub fn firmware_omega_error(e: &estimator_core::Estimate<f32>, truth: [f64; 3]) -> (f64, bool) {
    omega_error(
        e.omega.map(f64::from),
        truth,
        e.sd_omega.map(f64::from),
        e.flags.0,
    )
}

/// What one run showed, from 1 s on (the start-up excluded).
#[derive(Debug, Default)]
pub struct FaultRun {
    /// Time from the fault's start to the first row that shows it (flag 64, or the part
    /// missing or excluded), if any while it is active.
    pub latency: Option<f64>,
    /// Rows before the fault (all rows of a run without one).
    pub clean_rows: usize,
    /// Of [`Self::clean_rows`], those flagged 64 (false alarms).
    pub flagged_clean: usize,
    /// Of [`Self::clean_rows`], those silently wrong (Ω error above 5 reported deviations, no
    /// warning flag).
    pub silent_clean: usize,
    /// Rows while the fault is active.
    pub active_rows: usize,
    /// Of [`Self::active_rows`], those flagged 64.
    pub flagged_active: usize,
    /// Of [`Self::active_rows`], those silently wrong: Ω error above 5 reported deviations,
    /// no warning flag.
    pub silent_active: usize,
    /// Rows after the fault.
    pub after_rows: usize,
    /// Of [`Self::after_rows`], those silently wrong.
    pub silent_after: usize,
    /// Estimates with a value that is not finite.
    pub nan: usize,
    /// Telemetry packets the firmware could not send.
    pub lost: u32,
    /// Time from the fault's start to the first row with the faulty part out of the solve
    /// (isolated from the measurements, or missing on the bus), if any while it is active.
    pub excluded_after: Option<f64>,
    /// Rows (from 1 s on) with a healthy part out of the solve (and answering on its bus).
    pub wrong_excluded: usize,
    /// Of [`Self::active_rows`], those with the faulty part out of the solve.
    pub excluded_active: usize,
    /// Rows while the fault is active from the first with the part out, and of them those
    /// with the part out (the goal: all).
    pub since_isolation: usize,
    /// See [`Self::since_isolation`].
    pub out_since_isolation: usize,
    /// Times the part went out of the solve while the fault was active.
    pub exclusions: usize,
    /// Rows while active from the part's second exclusion on (an intermittent fault's
    /// pattern known), and of them with the part out.
    pub since_second: usize,
    /// See [`Self::since_second`].
    pub out_since_second: usize,
    /// Rows after the fault with the faulty part still out of the solve.
    pub excluded_after_end: usize,
    /// The rows while the fault is active with the faulty part out of the solve: their times
    /// (s) and squared Ω errors (rad²/s²).
    pub excluded_errors: Vec<(f64, f64)>,
    /// Integrity, over every row from 1 s on.
    pub protection: Protection,
}

/// What the protection levels said over a run's rows (`estimator_core::integrity`).
#[derive(Clone, Copy, Debug, Default)]
pub struct Protection {
    /// Rows with protection levels.
    pub bounded: usize,
    /// Rows without (no bound: model F, or a channel set without redundancy).
    pub unbounded: usize,
    /// Of [`Self::bounded`], rows whose σ0, Ω′ and Ω error (norm) is above its level.
    pub above: [usize; 3],
    /// Of [`Self::bounded`], rows with the sign of Ω unresolved (flag 1): their Ω error is
    /// counted against the level all the same.
    pub sign_unresolved: usize,
    /// Sum of each level over the bounded rows (their mean: [`Self::mean`]).
    pub level_sum: [f64; 3],
}

impl Protection {
    /// Counts one row: estimate `e` against truth `tr`.
    pub fn add(&mut self, e: &estimator_core::Estimate<f32>, tr: &hal_sim::motion::Truth) {
        let Some(pl) = e.protection else {
            self.unbounded += 1;
            return;
        };
        self.bounded += 1;
        self.sign_unresolved += usize::from(e.flags.has(Flags::SIGN_UNRESOLVED));
        let err = |v: [f32; 3], t: [f64; 3]| {
            (0..3)
                .map(|k| (f64::from(v[k]) - t[k]).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        let errors = [
            err(e.sigma0, tr.sigma0),
            err(e.domega, tr.domega),
            err(e.omega, tr.omega),
        ];
        for q in 0..3 {
            self.above[q] += usize::from(errors[q] > f64::from(pl[q]));
            self.level_sum[q] += f64::from(pl[q]);
        }
    }

    /// Adds another run's counts.
    pub fn merge(&mut self, o: &Protection) {
        self.bounded += o.bounded;
        self.unbounded += o.unbounded;
        self.sign_unresolved += o.sign_unresolved;
        for q in 0..3 {
            self.above[q] += o.above[q];
            self.level_sum[q] += o.level_sum[q];
        }
    }

    /// The share (%) of bounded rows above each level.
    pub fn above_pct(&self) -> [f64; 3] {
        self.above
            .map(|a| 100.0 * a as f64 / self.bounded.max(1) as f64)
    }

    /// The mean level of each output over the bounded rows.
    pub fn mean(&self) -> [f64; 3] {
        self.level_sum.map(|s| s / self.bounded.max(1) as f64)
    }
}

/// Runs `sc` through the firmware; `fault`: the faulty part's index, and the fault's start
/// and end (s).
pub fn fault_run(sc: &Scenario, fault: Option<(usize, f64, f64)>) -> FaultRun {
    let loaded = sc.arrangement().load("arrangement.toml").unwrap();
    let config = firmware_config(sc, &loaded, Alignment::Interpolate).unwrap();
    let mut r = FaultRun::default();
    let part_bit = fault.map_or(0, |(p, _, _)| 1u8 << p);
    let (start, end) = fault.map_or((f64::INFINITY, f64::INFINITY), |f| (f.1, f.2));
    let mut out_before = false;
    let report = run_firmware(sc, &config, sc.samples() as u32, &mut |_, m, tr| {
        // The set's instant in simulated time, as the fault's start and end (the report's `t`
        // is on-board time, from boot: 50 ms earlier in these scenarios).
        let t = tr.t;
        let e = &m.estimate;
        let vals = e.omega.iter().chain(&e.sigma0).chain(&e.domega);
        if vals.clone().any(|v| !v.is_finite()) {
            r.nan += 1;
        }
        let (err, silent) = firmware_omega_error(e, tr.omega);
        let residual = e.flags.has(Flags::RESIDUAL_HIGH);
        let seen = residual || (m.missing.0 | m.excluded.0) & part_bit != 0;
        let out = m.excluded.0 & part_bit != 0;
        let was_out = core::mem::replace(&mut out_before, out);
        if t < 1.0 {
            return;
        }
        r.protection.add(e, tr);
        r.wrong_excluded += usize::from(m.excluded.0 & !part_bit & !m.missing.0 != 0);
        if t < start {
            r.clean_rows += 1;
            r.flagged_clean += usize::from(residual);
            r.silent_clean += usize::from(silent);
        } else if t < end {
            r.active_rows += 1;
            r.flagged_active += usize::from(residual);
            r.silent_active += usize::from(silent);
            if seen && r.latency.is_none() {
                r.latency = Some(t - start);
            }
            if out {
                r.excluded_active += 1;
                r.excluded_errors.push((t, err * err));
                if r.excluded_after.is_none() {
                    r.excluded_after = Some(t - start);
                }
            }
            if r.excluded_after.is_some() {
                r.since_isolation += 1;
                r.out_since_isolation += usize::from(out);
            }
            r.exclusions += usize::from(out && !was_out);
            if r.exclusions >= 2 {
                r.since_second += 1;
                r.out_since_second += usize::from(out);
            }
        } else {
            r.after_rows += 1;
            r.silent_after += usize::from(silent);
            r.excluded_after_end += usize::from(out);
        }
    })
    .expect("the firmware ran");
    r.lost = report.housekeeping.tm_lost;
    r
}

/// The reference for the estimate after an exclusion: `sc` run without faults and without
/// part `part`'s channels in the solve (the part still sampled, so that every other part's
/// readings are those of the run with the fault: [`without_channels_of`]), at the rows whose
/// times are `at` (s; matched to the nearest set): per row its squared Ω error and its own
/// squared reported deviation (the norm of the three).
///
/// The part stays on its bus in the reference (left off it, the other parts' samples would fall
/// at other instants with other noise, and the ratio of the two runs' errors would compare two
/// noise draws: the mixed layout, 10 σ bias, seed 2008, 1.80 against such a reference, 1.09
/// against this one, whose errors match the fault run's to the digit from 0.3 s after the
/// exclusion on).
pub fn errors_without_part(sc: &Scenario, part: usize, at: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut reference = sc.clone();
    reference.faults.clear();
    let loaded = reference.arrangement().load("arrangement.toml").unwrap();
    let config = firmware_config(&reference, &loaded, Alignment::Interpolate).unwrap();
    let config = without_channels_of(&config, part);
    let mut by_time = Vec::new();
    run_firmware(
        &reference,
        &config,
        reference.samples() as u32,
        &mut |_, m, tr| {
            let e = &m.estimate;
            let err2: f64 = (0..3)
                .map(|k| (f64::from(e.omega[k]) - tr.omega[k]).powi(2))
                .sum();
            let sd2: f64 = e.sd_omega.iter().map(|s| f64::from(*s).powi(2)).sum();
            by_time.push((tr.t, (err2, sd2)));
        },
    )
    .expect("the firmware ran");
    at.iter()
        .filter_map(|(t, _)| {
            let k = by_time.partition_point(|(u, _)| u < t);
            [k.checked_sub(1), Some(k)]
                .into_iter()
                .flatten()
                .filter_map(|i| by_time.get(i))
                .min_by(|a, b| (a.0 - t).abs().total_cmp(&(b.0 - t).abs()))
                .map(|(_, e)| *e)
        })
        .collect()
}

/// Whether a reference ([`errors_without_part`]) is itself wrong on its rows: its RMS Ω error
/// above [`ballisto::compare::SILENT_SD`] times its RMS reported deviation (a start from rest
/// that took the wrong sign: the fault matrix, `docs/validation.md`). Such a run
/// is no yardstick; the matrix counts it apart.
pub fn reference_wrong(rows: &[(f64, f64)]) -> bool {
    let err: f64 = rows.iter().map(|r| r.0).sum();
    let sd: f64 = rows.iter().map(|r| r.1).sum();
    err > ballisto::compare::SILENT_SD.powi(2) * sd
}

/// `config` with part `part` still sampled (the buses' timing and every other part's samples
/// as with it) but none of its channels in the arrangement: the estimate without the part on
/// the very readings a run that takes it out works with.
pub fn without_channels_of(config: &AppConfig, part: usize) -> AppConfig {
    let mut out = config.clone();
    let dropped: Vec<u8> = config.sampling.parts[part]
        .map(|p| p.channels.iter().flatten().copied().collect())
        .unwrap_or_default();
    let mut arrangement = estimator_core::Arrangement::new();
    let mut new_index = [None; MAX_CHANNELS];
    for (i, c) in config.arrangement.channels().iter().enumerate() {
        if !dropped.contains(&(i as u8)) {
            new_index[i] = Some(arrangement.push(c.position, c.axis, c.noise).unwrap() as u8);
        }
    }
    out.arrangement = arrangement;
    for p in out.sampling.parts.iter_mut().flatten() {
        p.channels = p
            .channels
            .map(|c| c.and_then(|c| new_index[usize::from(c)]));
    }
    out.validate().expect("a part's channels dropped");
    out
}

/// Seconds of each run.
pub const DURATION: f64 = 12.0;
/// Each fault lasts this long (s), starting uniformly in 3–7 s.
pub const FAULT_S: f64 = 3.0;

/// Within this time of its onset a fault must be isolated (the goal for a drift).
pub const ISOLATE_WITHIN_S: f64 = 2.0;

/// Whether the layout itself can attribute a fault of `bias + rate · t` (m/s², per axis x, y, z
/// of part `part`) to that part within [`ISOLATE_WITHIN_S`] of its onset with probability
/// `power`: for every other part `q`, the fault's noncentrality in the residual without `q`,
/// `Σ |P⁽q⁾ b(t)|²` over the sets of that time, reaches what a `χ²` test with that residual's
/// degrees of freedom at the monitor's false-alarm probability (10⁻⁶) needs to see it with that
/// probability ([`needed_noncentrality`]; [`EVEN_ODDS`] or [`SURELY`]). Below it, `q` can stand
/// in for `part` (it explains the fault as well) and no test on the residual tells the two
/// apart in that time: the monitor rightly says "not isolated". In the N = 18 layout parts 2
/// and 5 are such a pair for the matrix's fault direction `(1, −1, ½)`: without the other, 1 %
/// of either's parity energy is left. `None`: the part cannot be isolated at all (no parity
/// space, or its removal leaves no test).
pub fn attributable(
    sc: &Scenario,
    part: usize,
    bias: [f64; 3],
    rate: [f64; 3],
    power: f64,
) -> Option<bool> {
    let loaded = sc.arrangement().load("arrangement.toml").ok()?;
    let arr = &loaded.arrangement;
    let parts = ballisto_config::arrangement_file::parts_of(&loaded.names);
    let mask = estimator_core::ChannelMask::all(arr.len());
    let parity = estimator_core::parity::Parity::<
        f64,
        { ballisto_config::arrangement_file::HOST_CAP },
    >::build(arr, mask, &parts)
    .ok()?;
    let name = &sc.parts.get(part)?.name;
    let channels: Vec<Option<usize>> = (0..3).map(|k| loaded.channel(name, k)).collect();
    let number = usize::from(parts[channels.iter().flatten().next().copied()?]);
    parity.part_dof(number)?;
    let sets = (ISOLATE_WITHIN_S * sc.rate).round() as usize;
    let mut noncentrality = vec![0.0f64; parity.parts()];
    for k in 1..=sets {
        let t = k as f64 / sc.rate;
        let mut x: Vec<f64> = arr.channels().iter().map(|c| c.bias).collect();
        for (axis, ch) in channels.iter().enumerate() {
            if let Some(i) = ch {
                x[*i] += bias[axis] + rate[axis] * t;
            }
        }
        let sample = parity.evaluate(&x)?;
        for (n, w) in noncentrality.iter_mut().zip(sample.without.iter()) {
            *n += w;
        }
    }
    Some((0..parity.parts()).filter(|q| *q != number).all(|q| {
        parity
            .part_dof(q)
            .is_none_or(|dof| noncentrality[q] >= needed_noncentrality(dof as f64, power))
    }))
}

/// [`attributable`] at even odds: the boundary of what any test can do.
pub const EVEN_ODDS: f64 = 0.5;
/// [`attributable`] with 99 % probability: a fault any good test should isolate in time.
pub const SURELY: f64 = 0.99;

/// The noncentrality at which `χ²` with `dof` degrees of freedom exceeds its point at the
/// monitor's false-alarm probability (10⁻⁶) with probability `power` (Patnaik: the
/// noncentral `χ²_ν(λ)` as `c χ²_f`, `c = (ν + 2λ)/(ν + λ)`, `f = (ν + λ)²/(ν + 2λ)`; the
/// quantiles by Wilson–Hilferty; λ by bisection).
pub fn needed_noncentrality(dof: f64, power: f64) -> f64 {
    use estimator_core::fault_monitor::{chi2_quantile, upper_normal_quantile};
    let point = chi2_quantile(dof, upper_normal_quantile(1e-6));
    let z = if power >= 0.5 {
        -upper_normal_quantile(1.0 - power)
    } else {
        upper_normal_quantile(power)
    };
    let sees = |l: f64| {
        let c = (dof + 2.0 * l) / (dof + l);
        let f = (dof + l).powi(2) / (dof + 2.0 * l);
        point / c <= chi2_quantile(f, z)
    };
    let (mut lo, mut hi) = (0.0, 1e6);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if sees(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

/// The matrix's layout for `seed` (the tetrahedron and two more ADXL355, N = 18).
pub fn layout(seed: u64) -> Scenario {
    redundant_layout(seed, DURATION)
}

/// [`layout`] estimated in model F (Γ known: the orbit's), the configured model of a
/// free-float instrument (N = 18, 9 degrees of freedom in model F, 6 in the monitor's parity
/// space, which is model G's).
pub fn layout_free_float(seed: u64) -> Scenario {
    let mut sc = layout(seed);
    sc.model = Some("free-float".to_string());
    sc
}

/// The mixed layout for `seed` (N = 24, [`mixed_layout`]).
pub fn mixed(seed: u64) -> Scenario {
    mixed_layout(seed, DURATION)
}

/// A fault of `kind` with no part, start or parameters yet.
fn fault(kind: &str) -> FaultSpec {
    FaultSpec {
        part: String::new(),
        kind: kind.to_string(),
        start: 0.0,
        end: None,
        bias: None,
        rate: None,
        density: None,
        probability: None,
        stall: None,
    }
}

/// The matrix's bias jump of size `b` (m/s²): `(b, −b, b/2)` on the part's x, y, z.
pub fn bias_jump(b: f64) -> FaultSpec {
    FaultSpec {
        bias: Some([b, -b, 0.5 * b]),
        ..fault("bias-jump")
    }
}

/// A drift of `rate` (m/s² per s) on the part's x and y, half of it on z: `(r, −r, r/2)`.
fn drift(name: &'static str, rate: f64) -> (&'static str, FaultSpec) {
    (
        name,
        FaultSpec {
            rate: Some([rate, -rate, 0.5 * rate]),
            ..fault("drift")
        },
    )
}

/// The name prefix of the intermittent kinds: [`BURSTS`] bursts of [`BURST_S`], every
/// [`BURST_PERIOD_S`] (gaps longer than a re-admission takes after one burst, 2.9 s: the
/// monitor must hold the part out across them from its second burst on), or ([`JITTERED`]) at
/// a period drawn in [`JITTERED_PERIOD_S`] per run, each gap within ±[`JITTER`] of it.
pub const INTERMITTENT: &str = "intermittent";
/// Bursts of the intermittent kinds.
pub const BURSTS: usize = 3;
/// Length of one burst, s.
pub const BURST_S: f64 = 0.3;
/// Bursts of the regular kind start this far apart, s.
pub const BURST_PERIOD_S: f64 = 3.8;
/// The intermittent kind with a drawn, jittered period.
pub const JITTERED: &str = "intermittent noise bursts ×30 (0.3 s every 5–10 s ± 20 %)";
/// The range of [`JITTERED`]'s period, s.
pub const JITTERED_PERIOD_S: (f64, f64) = (5.0, 10.0);
/// Each of [`JITTERED`]'s gaps is its period times 1 ± up to this.
pub const JITTER: f64 = 0.2;

/// The bursts (start, end; s) of an intermittent kind `name` whose first starts at `s0`;
/// `draw` gives numbers uniform in [0, 1).
pub(crate) fn burst_times(name: &str, s0: f64, draw: &mut impl FnMut() -> f64) -> Vec<(f64, f64)> {
    let (period, jitter) = if name == JITTERED {
        let (lo, hi) = JITTERED_PERIOD_S;
        (lo + (hi - lo) * draw(), JITTER)
    } else {
        (BURST_PERIOD_S, 0.0)
    };
    let mut t = s0;
    let mut out = Vec::new();
    for b in 0..BURSTS {
        if b > 0 {
            t += period * (1.0 + jitter * (2.0 * draw() - 1.0));
        }
        out.push((t, t + BURST_S));
    }
    out
}

/// Uniform draws in [0, 1) from `seed` (xorshift64): the same sequence for the same seed.
pub fn draws(seed: u64) -> impl FnMut() -> f64 {
    let mut x = seed;
    move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Fault kind `k` of [`kinds`] in a part of `sc` drawn by `next`, sized by that part's own
/// noise: (the part, the fault).
pub fn drawn_fault(sc: &Scenario, k: usize, next: &mut impl FnMut() -> f64) -> (usize, FaultSpec) {
    let part = (next() * sc.parts.len() as f64) as usize % sc.parts.len();
    let faulty = &sc.parts[part];
    let (_, spec) = kinds(
        sc.channel_noise(faulty),
        faulty.noise_density.unwrap_or(0.0),
    )
    .swap_remove(k);
    (part, spec)
}

/// Adds fault `spec` to part `part` of `sc` over each of `windows` (start, end; s).
pub fn inject(sc: &mut Scenario, part: usize, spec: &FaultSpec, windows: &[(f64, f64)]) {
    for (start, end) in windows {
        let mut f = spec.clone();
        f.part = sc.parts[part].name.clone();
        f.start = *start;
        f.end = Some(*end);
        sc.faults.push(f);
    }
}

/// The fault kinds of hal-sim, as scenario faults on `part` from `start` (drift and bias at
/// several sizes; noise bursts also intermittent), in the faulty part's own terms: `sigma` its
/// per-sample noise (m/s²), `density` its noise density (m/s²/√Hz; a burst is 30 × that).
pub fn kinds(sigma: f64, density: f64) -> Vec<(&'static str, FaultSpec)> {
    let f = fault;
    let bias = bias_jump;
    vec![
        ("stuck", f("stuck")),
        ("bias jump 0.1 m/s²", bias(0.1)),
        ("bias jump 10 σ", bias(10.0 * sigma)),
        ("bias jump 3 σ", bias(3.0 * sigma)),
        drift("drift 1 σ per s", sigma),
        drift("drift 3 σ per s", 3.0 * sigma),
        drift("drift 10 σ per s", 10.0 * sigma),
        (
            "noise burst ×30",
            FaultSpec {
                density: Some(30.0 * density),
                ..f("noise-burst")
            },
        ),
        (
            "intermittent noise bursts ×30 (0.3 s every 3.8 s)",
            FaultSpec {
                density: Some(30.0 * density),
                ..f("noise-burst")
            },
        ),
        ("saturation", f("saturation")),
        ("dead", f("dead")),
        (
            "corrupt 5 %",
            FaultSpec {
                probability: Some(0.05),
                ..f("corrupt")
            },
        ),
        (
            "timeout",
            FaultSpec {
                stall: Some(1e-3),
                ..f("timeout")
            },
        ),
        // Last: the kinds before it draw their parts and times as they did without it.
        (
            JITTERED,
            FaultSpec {
                density: Some(30.0 * density),
                ..f("noise-burst")
            },
        ),
    ]
}

/// `sc` through the firmware on the simulated buses (`ballisto sim --firmware` into `dir`), then
/// `ballisto estimate` (f32, as on board) on the samples the firmware read; returns the path of
/// the host's estimates file (the firmware's is `dir/estimates.csv`).
pub fn firmware_then_host(
    sc: &hal_sim::scenario::Scenario,
    dir: &std::path::Path,
) -> std::path::PathBuf {
    use ballisto::estimate::{estimate_files, EstimateJob, Precision};
    use ballisto::sim::{run_sim, SimJob};
    run_sim(&SimJob {
        scenario: sc,
        out: dir,
        estimate: false,
        progress: false,
        firmware: Some(ballisto_fw::config::Alignment::Interpolate),
        identify: false,
        uplink: Vec::new(),
        calibration: None,
    })
    .unwrap();
    let host = dir.join("host.csv");
    estimate_files(&EstimateJob {
        arrangement: &dir.join("arrangement.toml"),
        samples: &dir.join("samples.csv"),
        out: &host,
        model: None,
        options: estimator_core::Options {
            initial_omega: sc.initial_omega,
            ..Default::default()
        },
        precision: Precision::F32,
        progress: false,
    })
    .unwrap();
    host
}
