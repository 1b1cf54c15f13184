//! Instruction counts of one per-sample estimate (and of the precomputation) on a Cortex-M4F,
//! under QEMU mps2-an386 with `-icount shift=0`: one guest instruction advances virtual time
//! by 1 ns, so SysTick counts instructions deterministically. The instructions per SysTick
//! tick are calibrated here with a loop of known length.
//!
//! Run: `cargo qemu-bench` (README, "Layout"; figures in `docs/validation.md`). Prints whether the per-sample budget
//! ([`BUDGET`] instructions for N = 12) is met; built with `QEMU_BENCH_STRICT=1` it also exits non-zero
//! when it is not.
//!
//! On the host the same program runs the same estimates (no counter) so that it builds and is
//! linted with the workspace.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

mod scenario;

use core::fmt::Write;

use estimator_core::recent::{Recent, REPLAY_SETS};
use estimator_core::{ChannelMask, Estimator, FrameUncertainty, Model, Options};

/// Per-sample budget for N = 12 (instructions). Issue "One firmware" set 4 000; issue 46's
/// branch and sign filter — tracks of (Ω, Ω′) with their full covariance, an extended Kalman
/// update per track — costs more (mean G 5 422 / F 5 827, max 7 400 / 8 040; nine channels
/// 10 518 / 26 600), and the capability is kept over that budget: this is the bound the flashed
/// profile is held to until the filter is made cheaper. It is the estimate's without the
/// protection levels: model F's, linearised at every set's Ω, came after it and are kept over
/// it (reported beside the verdict, ≈ 8 000 instructions more at N = 12).
const BUDGET: u64 = 6_500;
/// The whole per-set path's budget, N = 12, mean.
const PATH_BUDGET: u64 = 10_000;
/// Samples per model in the per-sample measurement.
const SAMPLES: usize = match option_env!("QEMU_BENCH_SAMPLES") {
    Some(s) => parse_usize(s),
    None => 1_000,
};

/// `usize` from decimal digits at compile time (for `QEMU_BENCH_SAMPLES`, used when profiling).
const fn parse_usize(s: &str) -> usize {
    let b = s.as_bytes();
    let mut i = 0;
    let mut n = 0;
    while i < b.len() {
        n = n * 10 + (b[i] - b'0') as usize;
        i += 1;
    }
    n
}

/// A cycle/instruction counter and a console.
trait Platform: Write {
    /// A free-running down-counter (24 bit) or `None` on the host.
    fn ticks(&mut self) -> Option<u32>;
    /// Ticks since the start, the counter's wraps counted (`None` on the host): for spans
    /// longer than the 24-bit counter's 2²⁴ ticks (671 M instructions), which [`Self::ticks`]
    /// would report modulo that.
    fn long_ticks(&mut self) -> Option<u64>;
    /// Instructions per tick, measured with a loop of known length.
    fn calibrate(&mut self) -> f64;
    /// Fills the free stack below the caller's frame with a pattern (none on the host).
    fn paint_stack(&mut self) {}
    /// Bytes of the painted stack overwritten since [`Platform::paint_stack`] (`None` on the
    /// host).
    fn stack_used(&mut self) -> Option<usize> {
        None
    }
    /// Whether the core has a double-precision FPU (the Cortex-M7 of the STM32H743; not the
    /// M4F).
    fn double_precision_fpu(&mut self) -> bool {
        false
    }
}

fn elapsed(t0: u32, t1: u32) -> u64 {
    (t0.wrapping_sub(t1) & 0x00ff_ffff) as u64
}

/// Measures `f` in instructions (0 on the host).
fn measure<P: Platform, R>(p: &mut P, per_tick: f64, f: impl FnOnce() -> R) -> (R, u64) {
    let t0 = p.ticks();
    let r = f();
    let t1 = p.ticks();
    let n = match (t0, t1) {
        (Some(a), Some(b)) => (elapsed(a, b) as f64 * per_tick) as u64,
        _ => 0,
    };
    (r, n)
}

/// As [`measure`], for spans longer than the SysTick counter's wrap ([`Platform::long_ticks`]).
fn measure_long<P: Platform, R>(p: &mut P, per_tick: f64, f: impl FnOnce() -> R) -> (R, u64) {
    let t0 = p.long_ticks();
    let r = f();
    let t1 = p.long_ticks();
    let n = match (t0, t1) {
        (Some(a), Some(b)) => (b.saturating_sub(a) as f64 * per_tick) as u64,
        _ => 0,
    };
    (r, n)
}

/// A calibration as `ballisto calibrate` writes it: every channel's bias and scale, and the
/// frame's uncertainty (the parts below report `scale · f + bias`).
const CAL_BIAS: f64 = 0.05;
const CAL_SCALE: f64 = 1.004;

/// How an estimate is configured for a measurement.
#[derive(Clone, Copy)]
struct Setup {
    /// Bias, scale and the frame's uncertainty, as calibrated parts run.
    calibrated: bool,
    /// The protection levels computed where the channels allow them (`Options::protection`).
    protection: bool,
}

fn run_model<P: Platform, const CAP: usize>(
    p: &mut P,
    per_tick: f64,
    model: Model,
    channels: usize,
    setup: Setup,
) -> u64 {
    let Setup {
        calibrated,
        protection,
    } = setup;
    let mut arr = scenario::arrangement::<CAP>(channels);
    if calibrated {
        for i in 0..channels {
            let _ = arr.set_calibration(i, CAL_BIAS, CAL_SCALE);
        }
        let _ = arr.set_frame_uncertainty(FrameUncertainty {
            rotation: 1e-4,
            translation: 2e-4,
            size: 1e-4,
            relative_rotation: 1e-3,
        });
    }
    let (est, setup) = measure(p, per_tick, || {
        Estimator::<f32, CAP>::new(
            &arr,
            model,
            Options {
                protection,
                ..Options::default()
            },
        )
    });
    let mut est = match est {
        Ok(e) => e,
        Err(e) => {
            let _ = writeln!(p, "configuration failed: {e}");
            return u64::MAX;
        }
    };
    let mut p64 = [0.0f64; CAP];
    let mut p32 = [0.0f32; CAP];
    p.paint_stack();
    let (mut total, mut worst, mut count) = (0u64, 0u64, 0u64);
    let mut over = 0u64;
    let mut max_err = 0.0f64;
    // The last sets, as the firmware keeps them to replay after an exclusion.
    let mut recent = Recent::<f32, CAP, REPLAY_SETS>::new();
    let (gain, offset) = if calibrated {
        (CAL_SCALE, CAL_BIAS)
    } else {
        (1.0, 0.0)
    };
    for k in 0..SAMPLES {
        let t = k as f64 * scenario::DT;
        scenario::outputs(&arr, t, 0.002, &mut p64);
        for (a, b) in p32.iter_mut().zip(p64.iter()) {
            *a = (*b * gain + offset) as f32;
        }
        let (e, n) = measure(p, per_tick, || est.update(t, &p32[..channels]));
        recent.push(t, &p32[..channels]);
        // The first sample has no prediction and tries every frame: reported apart.
        if k > 0 {
            total += n;
            worst = worst.max(n);
            count += 1;
            if n > BUDGET {
                over += 1;
            }
        }
        if k > 50 {
            let w = scenario::field(t).2;
            let d = (0..3)
                .map(|i| (e.omega[i] as f64 - w[i]) * (e.omega[i] as f64 - w[i]))
                .sum::<f64>();
            max_err = max_err.max(libm::sqrt(d));
        }
    }
    let stack = p.stack_used();
    // Reconfiguration: exclude one channel (new SVD for the new mask), model F only (model G
    // needs all 12).
    let reconf = if model == Model::FreeFloat {
        measure(p, per_tick, || {
            est.set_mask(ChannelMask::all(channels).without(5))
        })
        .1
    } else {
        est.reset();
        0
    };
    // The replay that follows an exclusion in the firmware (`estimator_core::recent`): the
    // last sets through the configuration now in force, from a restarted history, in the
    // sample path at the change.
    let replay = measure(p, per_tick, || {
        recent.replay(|t, x| {
            est.update(t, x);
        })
    })
    .1;
    let mean = total / count.max(1);
    if let Some(bytes) = stack {
        let _ = writeln!(
            p,
            "model {:<10} stack high-water mark of the per-sample estimate: at most {bytes} bytes \
             below the caller (estimator state {} bytes, not on the stack in the firmware)",
            model.name(),
            core::mem::size_of::<Estimator<f32, CAP>>()
        );
    }
    let _ = writeln!(
        p,
        "model {:<10} N = {channels}{}{}: per-sample estimate mean {mean} instructions, max {worst}, \
         {over} of {count} over {BUDGET}; precomputation (all frames) {setup}; mask change {reconf}; \
         replay of the last {REPLAY_SETS} sets {replay}; max |Ω error| after 0.5 s {max_err:.4} rad/s",
        model.name(),
        if calibrated { ", calibrated" } else { "" },
        if protection { "" } else { ", no protection levels" }
    );
    mean
}

/// The identification task's work (below the estimate since issue 49) on the same
/// motion: a set into the window's queue (every set), a reference point (every fifth set: 20
/// Hz at 100 Hz) with the sets it covers moved into the sums, and the solve on command.
/// Counted, not budgeted: it runs in a task of lower priority than the estimate's (the sums
/// are `f64`: soft-float on this M4F; the STM32H743 has a double-precision FPU); what the
/// sample path pays for it is the set's copy into the task's queue ([`run_per_set`]).
fn run_identification<P: Platform>(p: &mut P, per_tick: f64) {
    use ballisto_fw::identification::Identification;
    use ballisto_link::identification::ReferencePoint;
    let arr = scenario::arrangement::<24>(12);
    let mut id = Identification::new();
    id.start(0, 50, 3_600_000, &arr, 100.0, None);
    let mut p64 = [0.0f64; 12];
    let mut p32 = [0.0f32; 12];
    let (mut set_total, mut set_worst) = (0u64, 0u64);
    let (mut point_total, mut point_worst, mut points) = (0u64, 0u64, 0u64);
    for k in 0..SAMPLES {
        let t = k as f64 * scenario::DT;
        scenario::outputs(&arr, t, 0.002, &mut p64);
        // In free fall (σ0 = 0 at the origin, here the centre of mass), as the identification
        // takes the field.
        let s0 = scenario::field(t).0;
        for ((a, b), ch) in p32.iter_mut().zip(p64.iter()).zip(arr.channels()) {
            *a = (*b - estimator_core::linalg::dot(&ch.axis, &s0)) as f32;
        }
        let tn = (t * 1e9) as u64;
        let w = scenario::field(t).2.map(|v| v as f32);
        let (_, n) = measure(p, per_tick, || id.on_set(tn, &p32, &w));
        set_total += n;
        set_worst = set_worst.max(n);
        if k % 5 == 0 {
            let w = scenario::field(t).2;
            let point = ReferencePoint {
                t: tn,
                omega: w.map(|v| v as f32),
            };
            let (_, n) = measure(p, per_tick, || id.on_points(core::iter::once(point)));
            if k >= 10 {
                point_total += n;
                point_worst = point_worst.max(n);
                points += 1;
            }
        }
    }
    let (solved, solve) = measure(p, per_tick, || id.solve(0).map(|(_, _, s)| s.sets));
    let sets = SAMPLES as u64;
    let _ = writeln!(
        p,
        "identification task (N = 12, reference at 20 Hz): per set queued mean {} instructions, max \
         {set_worst}; per reference point (its 5 sets into the sums) mean {}, max \
         {point_worst}: {} per set; solve {solve} ({} sets{})",
        set_total / sets.max(1),
        point_total / points.max(1),
        (set_total + point_total) / sets.max(1),
        solved.unwrap_or(0),
        if solved.is_ok() { "" } else { ": FAILED" }
    );
}

/// The identification task's solve without a reference (TC[200,8] source 2): a
/// torque-free tumble (inertia 1, 1.8, 2.5; Ω0 (0.3, 1.7, −0.6) rad/s, Euler's equations by
/// RK4 at 10 ms) in free flight, 12 channels with their declared noise, a 60 s window kept as
/// means of 4 sets (1 500) with a start rate 0.05 rad/s off; the search and the solve counted
/// (tens of G instructions: [`measure_long`]). On a double-precision FPU only: QEMU did not
/// finish it in the M4F's soft f64 in 20 minutes.
fn run_tumble<P: Platform>(p: &mut P, per_tick: f64) {
    use ballisto_fw::identification::Identification;
    if !p.double_precision_fpu() {
        let _ = writeln!(
            p,
            "identification without a reference: not counted without a double-precision FPU"
        );
        return;
    }
    let arr = scenario::arrangement::<24>(12);
    let noise = arr.channels()[0].noise;
    let inertia = [1.0f64, 1.8, 2.5];
    let euler = |w: &[f64; 3]| {
        let h = [inertia[0] * w[0], inertia[1] * w[1], inertia[2] * w[2]];
        let c = estimator_core::linalg::cross(&h, w);
        [c[0] / inertia[0], c[1] / inertia[1], c[2] / inertia[2]]
    };
    let mut id = Identification::new();
    let j = [1.0f32, 1.8, 2.5, 0.0, 0.0, 0.0];
    id.start(0, 40, 60_000, &arr, 100.0, Some(j));
    let mut w = [0.3f64, 1.7, -0.6];
    let mut p32 = [0.0f32; 12];
    let dt = scenario::DT;
    for k in 0..6000usize {
        let t = k as f64 * dt;
        let dw = euler(&w);
        let a = estimator_core::Sym3::skew_squared(&w);
        for (i, (ch, o)) in arr.channels().iter().zip(p32.iter_mut()).enumerate() {
            let r = &ch.position;
            let v = estimator_core::linalg::dot(&ch.axis, &a.mul_vec(r))
                + estimator_core::linalg::dot(&estimator_core::linalg::cross(r, &ch.axis), &dw);
            *o = (v + noise * scenario::gaussian(i, t)) as f32;
        }
        let off = if k == 0 { 0.05 } else { 0.0 };
        let rate = [(w[0] + off) as f32, w[1] as f32, w[2] as f32];
        id.on_set((t * 1e9) as u64, &p32, &rate);
        // RK4.
        let step = |v: &[f64; 3], d: &[f64; 3], h: f64| {
            [v[0] + h * d[0], v[1] + h * d[1], v[2] + h * d[2]]
        };
        let k1 = euler(&w);
        let k2 = euler(&step(&w, &k1, dt / 2.0));
        let k3 = euler(&step(&w, &k2, dt / 2.0));
        let k4 = euler(&step(&w, &k3, dt));
        for c in 0..3 {
            w[c] += dt / 6.0 * (k1[c] + 2.0 * k2[c] + 2.0 * k3[c] + k4[c]);
        }
    }
    let (solved, n) = measure_long(p, per_tick, || id.solve(0).map(|(_, _, s)| s.sets));
    let _ = writeln!(
        p,
        "identification without a reference (N = 12, 60 s of a torque-free tumble in 1 500 means): \
         search and solve {n} instructions{}",
        match solved {
            Ok(_) => "",
            Err(_) => ": REFUSED",
        }
    );
}

/// The whole per-set path of the flashed application, N = 12 (the built-in `tetra`
/// board) in `model`: `Estimation::process` (the channel vector, the fault monitor's tests,
/// the exclusion bookkeeping, the last sets kept for a replay, the estimate) and, while an
/// identification window is open, the set's copy into the identification task's queue — the
/// code the application task runs per set before its reports, compiled where the application
/// is. The task's own work (every fifth set a reference point, 20 Hz, with the sets it covers
/// moved into the sums) runs outside the count, as it does below the estimate on the board.
/// Every channel has temperature coefficients and the sets carry the parts'
/// temperatures as the sampler reads them — one part's new one every sixth set at 100 Hz — so
/// the count holds the corrections' update and their application, and, with the window open,
/// the window's temperature sums at each new read (`identification::ThermalTracking`).
/// Readings: the benchmark's motion with the configuration's declared noise (Gaussian).
/// Returns the mean.
fn run_per_set<P: Platform>(p: &mut P, per_tick: f64, model: Model, identifying: bool) -> u64 {
    use ballisto_fw::estimation::Estimation;
    use ballisto_fw::identification::Identification;
    use ballisto_fw::sampler::SampleSet;
    use ballisto_link::identification::ReferencePoint;
    let mut cfg = ballisto_fw::config::tetra();
    cfg.model = model;
    for c in 0..cfg.arrangement.len() {
        let th = estimator_core::thermal::Thermal::new(20.0, 1.5e-3, -1e-4).ok();
        let _ = cfg.arrangement.set_thermal(c, th);
    }
    let Ok(mut estimation) = Estimation::new(&cfg) else {
        let _ = writeln!(p, "per-set path: configuration refused");
        return 0;
    };
    use ballisto_fw::identification::{Identifier, Order};
    let identifier = Identifier::new();
    let mut id = Identification::new();
    let mut thermal = ballisto_fw::identification::ThermalTracking::new();
    if identifying {
        id.start(0, 50, 3_600_000, &cfg.arrangement, 100.0, None);
    }
    let noise = cfg.arrangement.channels()[0].noise;
    let mut out = [0.0f64; 24];
    let n = cfg.arrangement.len();
    let (mut total, mut worst, mut worst_k) = (0u64, 0u64, 0usize);
    for k in 0..SAMPLES {
        let t = k as f64 * scenario::DT;
        scenario::outputs(&cfg.arrangement, t, noise, &mut out[..n]);
        let mut parts = [None; ballisto_fw::config::MAX_PARTS];
        for (i, part) in cfg.sampling.parts() {
            let mut v = [0.0f32; 3];
            for (x, c) in v.iter_mut().zip(part.channels.iter()) {
                if let Some(c) = c {
                    *x = out[usize::from(*c)] as f32;
                }
            }
            parts[i] = Some(v);
        }
        let tn = (t * 1e9) as u64;
        let mut set = SampleSet::new(k as u32, tn, parts);
        // Part (k / 6) mod 4 read anew every sixth set, warming by 0.01 °C a read.
        for (i, temp) in set.temperatures.iter_mut().take(4).enumerate() {
            let reads = (k / 6 + 4 - i) / 4;
            *temp = 20.0 + 0.01 * reads as f32;
        }
        set.temperature_reads = (k / 6 + 1) as u32;
        let point = ReferencePoint {
            t: tn,
            omega: scenario::field(t).2.map(|v| v as f32),
        };
        let (_, n) = measure(p, per_tick, || {
            let new_read =
                estimation.observe_temperatures(set.temperature_reads, &set.temperatures);
            if identifying && new_read {
                thermal.observe(estimation.temperatures());
            }
            let e = estimation.process(&set);
            if identifying {
                identifier.post_set(set.t, estimation.readings(), e.estimate.omega);
            }
            e.estimate.flags
        });
        // The identification task, uncounted.
        if identifying && k % 5 == 0 {
            identifier.post(Order::Points(core::iter::once(point).collect()));
        }
        identifier.run_now(&mut id);
        // After the rate filter's start (as the estimate's own count).
        if k >= 10 {
            total += n;
            if n > worst {
                (worst, worst_k) = (n, k);
            }
        }
    }
    let mean = total / (SAMPLES as u64 - 10).max(1);
    let _ = writeln!(
        p,
        "{:<16} N = 12: whole per-set path (estimate, fault monitor{}) mean {mean} \
         instructions, max {worst} (set {worst_k})",
        model_name(model),
        if identifying {
            ", identification open"
        } else {
            ""
        }
    );
    mean
}

fn model_name(model: Model) -> &'static str {
    match model {
        Model::General => "model general",
        _ => "model free-float",
    }
}

/// The fault monitor alone (the whole per-set path with it: [`run_per_set`]): the parity space's
/// detection and isolation per set at the 24-channel capacity (8 tri-axial parts, 12 degrees
/// of freedom), and model G's known-field test where 12 channels have no parity space, on the
/// same motion with the declared (Gaussian) noise.
fn run_fault_monitor<P: Platform>(p: &mut P, per_tick: f64) {
    use estimator_core::fault_monitor::{FaultMonitor, FieldCheck, Settings};
    use estimator_core::parity::Parity;
    let arr = scenario::arrangement::<24>(24);
    let part: [u8; 24] = core::array::from_fn(|c| (c / 3) as u8);
    let mut monitor = FaultMonitor::<f32, 24>::new(Settings::default(), 1.0 / scenario::DT);
    // The parity space's build (one SVD in f64; the firmware makes it when the parts tested
    // change, still in the sample path after the estimator's new configuration is swapped in):
    // at 24 channels and with two parts out (18).
    let (parity, all) = measure(p, per_tick, || {
        Parity::build(&arr, ChannelMask::all(24), &part).ok()
    });
    let eighteen = ChannelMask::all(18);
    let (_, fewer) = measure(p, per_tick, || {
        Parity::<f32, 24>::build(&arr, eighteen, &part).ok()
    });
    let _ = writeln!(
        p,
        "parity space build: N = 24 {all} instructions, N = 18 {fewer}"
    );
    monitor.set_parity(parity);
    // `SAMPLES` sets from set `from` with `bias` on channel 0: mean and worst instructions,
    // and the sets found clean.
    let mut run = |from: usize, bias: f64| {
        let mut p64 = [0.0f64; 24];
        let (mut total, mut worst, mut clean) = (0u64, 0u64, 0usize);
        for k in from..from + SAMPLES {
            scenario::outputs(&arr, k as f64 * scenario::DT, 0.002, &mut p64);
            p64[0] += bias;
            let p32 = p64.map(|v| v as f32);
            let (v, n) = measure(p, per_tick, || monitor.step(&p32));
            total += n;
            worst = worst.max(n);
            clean += usize::from(v == estimator_core::fault_monitor::Verdict::Clean);
        }
        (total / SAMPLES as u64, worst, clean)
    };
    let (mean, worst, clean) = run(0, 0.0);
    // Under a fault the tests evaluate each part's residual without it (isolation): a bias of
    // 0.1 m/s² (50 σ) on one channel.
    let (fault_mean, fault_worst, fault_clean) = run(SAMPLES, 0.1);
    let _ = writeln!(
        p,
        "fault monitor (N = 24, 8 parts): per set mean {mean} instructions, max {worst}; {clean} \
         of {SAMPLES} sets clean"
    );
    let _ = writeln!(
        p,
        "fault monitor (N = 24, 8 parts), a 50 σ bias on one channel: per set mean {fault_mean} \
         instructions, max {fault_worst}; {} of {SAMPLES} sets flagged",
        SAMPLES - fault_clean
    );
    let arr12 = scenario::arrangement::<24>(12);
    let Ok(mut est) = Estimator::<f32, 24>::new(&arr12, Model::General, Options::default()) else {
        return;
    };
    let Some(mut check) = est.field_covariance().and_then(|c| {
        FieldCheck::new(
            &c,
            &est.known_gamma(),
            Settings::default(),
            1.0 / scenario::DT,
        )
    }) else {
        return;
    };
    let mut p12 = [0.0f64; 12];
    let (mut total, mut worst, mut alarms) = (0u64, 0u64, 0usize);
    for k in 0..SAMPLES {
        let t = k as f64 * scenario::DT;
        scenario::outputs(&arr12, t, 0.002, &mut p12);
        let e = *est.update(t, &p12.map(|v| v as f32));
        let (a, n) = measure(p, per_tick, || check.step(&e));
        total += n;
        worst = worst.max(n);
        alarms += usize::from(a);
    }
    let _ = writeln!(
        p,
        "known-field test (model G, N = 12): per set mean {} instructions, max {worst}; {alarms} \
         of {SAMPLES} sets in alarm",
        total / SAMPLES as u64
    );
}

fn run<P: Platform>(p: &mut P) -> i32 {
    let per_tick = p.calibrate();
    let _ = writeln!(
        p,
        "qemu-bench: {per_tick:.3} instructions per SysTick tick (calibrated)"
    );
    // `QEMU_BENCH_ONLY=general|free-float` (compile time) runs one model in the budget's
    // configuration, for profiling.
    let only = option_env!("QEMU_BENCH_ONLY");
    // The budget's configuration (issue 13: N = 12, uncalibrated), then as calibrated parts
    // run (bias, scale and the frame's uncertainty): reported beside it, not in the verdict.
    let mut means = [[0u64; 2]; 2];
    let configurations = if only.is_some() { 1 } else { 2 };
    for (calibrated, m) in [false, true]
        .into_iter()
        .zip(means.iter_mut())
        .take(configurations)
    {
        // The budget is the estimate's: model G has no protection level at N = 12 (no
        // redundancy); model F's (three degrees of freedom) cost their own, reported below.
        let setup = Setup {
            calibrated,
            protection: false,
        };
        m[0] = match only {
            Some("free-float") => 0,
            _ => run_model::<P, 12>(p, per_tick, Model::General, 12, setup),
        };
        m[1] = match only {
            Some("general") => 0,
            _ => run_model::<P, 12>(p, per_tick, Model::FreeFloat, 12, setup),
        };
    }
    if only.is_none() {
        // Model F with its protection levels (gains linearised at every set's Ω): kept over
        // the budget, which was set before they existed; reported, not in the verdict.
        let setup = Setup {
            calibrated: false,
            protection: true,
        };
        run_model::<P, 12>(p, per_tick, Model::FreeFloat, 12, setup);
    }
    let mut path = [0u64; 2];
    if only.is_none() {
        // The paper's layout, nine channels in model F (m = 3): where mirror roots cross, the
        // closed-form roots, the path check and the follower run on every sample.
        // Reported, not budgeted: the budget is N = 12's.
        let plain = Setup {
            calibrated: false,
            protection: true,
        };
        run_model::<P, 12>(p, per_tick, Model::FreeFloat, 9, plain);
        // With redundancy (24 channels, 8 tri-axial parts, model G): the protection levels
        // run on every set. Reported, not budgeted.
        run_model::<P, 24>(p, per_tick, Model::General, 24, plain);
        run_identification(p, per_tick);
        run_tumble(p, per_tick);
        run_fault_monitor(p, per_tick);
        for model in [Model::General, Model::FreeFloat] {
            run_per_set(p, per_tick, model, false);
        }
        path = [
            run_per_set(p, per_tick, Model::General, true),
            run_per_set(p, per_tick, Model::FreeFloat, true),
        ];
    }
    let measured = p.ticks().is_some();
    let over = measured && (means[0][0] > BUDGET || means[0][1] > BUDGET);
    if measured && (means[1][0] > BUDGET || means[1][1] > BUDGET) {
        let _ = writeln!(
            p,
            "calibrated configuration over {BUDGET} instructions (model G {} / F {}): not in \
             the verdict",
            means[1][0], means[1][1]
        );
    }
    let verdict = if !measured {
        "not measured on the host"
    } else if over {
        "EXCEEDED"
    } else {
        "met"
    };
    let _ = writeln!(
        p,
        "budget {BUDGET} instructions per estimate (N = 12): {verdict}"
    );
    if measured && only.is_none() {
        let met = if path.iter().all(|m| *m <= PATH_BUDGET) {
            "met"
        } else {
            "EXCEEDED (not in the exit status: reported)"
        };
        let _ = writeln!(
            p,
            "budget {PATH_BUDGET} instructions per set, whole path (N = 12, mean, model G {} / \
             F {}): {met}",
            path[0], path[1]
        );
    }
    if over && option_env!("QEMU_BENCH_STRICT") == Some("1") {
        1
    } else {
        0
    }
}

#[cfg(target_os = "none")]
mod target;

#[cfg(not(target_os = "none"))]
struct Host(String);

#[cfg(not(target_os = "none"))]
impl Write for Host {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        self.0.push_str(s);
        Ok(())
    }
}

#[cfg(not(target_os = "none"))]
impl Platform for Host {
    fn ticks(&mut self) -> Option<u32> {
        None
    }
    fn long_ticks(&mut self) -> Option<u64> {
        None
    }
    fn calibrate(&mut self) -> f64 {
        0.0
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    let mut h = Host(String::new());
    let code = run(&mut h);
    print!("{}", h.0);
    std::process::exit(code);
}
