//! Issue 16, identification without a reference (source 2): the `orbit-identify` scenario's
//! parts (4 × ADXL355 with datasheet errors: bias up to 0.2 m/s², scale ±1 %, cross-axis,
//! 0.5 mm, 5 mrad) in a torque-free tumble, the inertia given. From the estimator's rate with
//! the nominal geometry (0.39 rad/s off at the window's start) `identify_tumble` fits the start
//! rate and the geometry jointly; the estimate with the identified geometry is then within
//! 1.2 × that of ideal parts (every datasheet error removed) over the whole record. A body that
//! does not move as the given inertia says is refused, not returned.

use ballisto_config::arrangement_file::HOST_CAP;
use e2e_tests::recorded;
use e2e_tests::report::{self, Parts};
use estimator_core::identify::{identify_tumble, Body, Sets, Tolerance, TumbleError};
use estimator_core::{Arrangement, Estimator, Model, Options, Sym3};
use hal_sim::scenario::Scenario;

/// A recorded scenario: readings per set and the true rate.
struct Record {
    sets: Vec<(f64, Vec<f64>)>,
    omega: Vec<[f64; 3]>,
}

/// The sets of a time window of a record, and the estimator's rates at them.
struct Window<'a>(&'a [(f64, Vec<f64>)], &'a [[f64; 3]]);

impl Sets for Window<'_> {
    fn for_each(&self, f: &mut dyn FnMut(f64, &[f64])) {
        for (t, p) in self.0 {
            f(*t, p);
        }
    }

    fn rates(&self, f: &mut dyn FnMut(f64, &[f64; 3])) {
        for ((t, _), w) in self.0.iter().zip(self.1) {
            f(*t, w);
        }
    }
}

fn record(sc: &Scenario) -> Record {
    let (sets, truth) = recorded::record(sc);
    Record {
        sets,
        omega: truth.iter().map(|t| t.omega).collect(),
    }
}

/// The estimator on a geometry (model G, started at the record's true rate).
fn estimator(arr: &Arrangement<HOST_CAP>, rec: &Record) -> Estimator<f64, HOST_CAP> {
    Estimator::new(
        arr,
        Model::General,
        Options {
            initial_omega: Some(rec.omega[0]),
            ..Options::default()
        },
    )
    .unwrap()
}

/// The estimator's rates over a record with a geometry.
fn rates(arr: &Arrangement<HOST_CAP>, rec: &Record) -> Vec<[f64; 3]> {
    let mut est = estimator(arr, rec);
    rec.sets
        .iter()
        .map(|(t, p)| est.update(*t, p).omega)
        .collect()
}

/// Rows of a record whose Ω is more than 5 reported deviations off in a component with no
/// flag, with a geometry.
fn silent(arr: &Arrangement<HOST_CAP>, rec: &Record) -> usize {
    let mut est = estimator(arr, rec);
    rec.sets
        .iter()
        .zip(&rec.omega)
        .filter(|((t, p), w)| {
            let e = est.update(*t, p);
            e.flags.0 == 0 && (0..3).any(|i| (e.omega[i] - w[i]).abs() > 5.0 * e.sd_omega[i])
        })
        .count()
}

fn rms(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let s: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| (0..3).map(|i| (x[i] - y[i]).powi(2)).sum::<f64>())
        .sum();
    (s / (3 * a.len()) as f64).sqrt()
}

/// A scenario's body in free flight: its principal moments, no gravity gradient.
fn body(sc: &Scenario) -> Body {
    let j = sc.body.inertia.unwrap();
    Body {
        inertia: Sym3([j[0], j[1], j[2], 0.0, 0.0, 0.0]),
        gamma: Sym3([0.0; 6]),
    }
}

/// `orbit-identify` with its torque removed, its nominal geometry and its record.
fn setup() -> (Scenario, Arrangement<HOST_CAP>, Record) {
    let mut sc = Scenario::load("orbit-identify").unwrap();
    sc.body.torque = None;
    let nominal = sc.arrangement().load("arrangement.toml").unwrap();
    let rec = record(&sc);
    (sc, nominal.arrangement, rec)
}

/// The window from `from`, `seconds` long, and the estimator's rates from the nominal geometry.
fn window(
    rec: &Record,
    nominal: &Arrangement<HOST_CAP>,
    from: f64,
    seconds: f64,
) -> (usize, usize, Vec<[f64; 3]>) {
    let k0 = rec.sets.iter().position(|(t, _)| *t >= from).unwrap();
    let k1 = rec
        .sets
        .iter()
        .position(|(t, _)| *t >= from + seconds)
        .unwrap_or(rec.sets.len());
    (k0, k1, rates(nominal, rec)[k0..k1].to_vec())
}

#[test]
fn a_torque_free_tumble_identifies_the_geometry_without_a_reference() {
    let (sc, nominal, rec) = setup();
    let body = body(&sc);
    let (k0, k1, est) = window(&rec, &nominal, 1.0, 20.0);
    let off = |w: &[f64; 3]| rms(&[*w], &[rec.omega[k0]]) * 3f64.sqrt();
    let fit = identify_tumble(
        &Window(&rec.sets[k0..k1], &est),
        &body,
        &est[0],
        &nominal,
        &Tolerance::DATASHEET,
    )
    .expect("a 20 s tumble determines the motion");
    let identified = fit
        .identified
        .arrangement(&fit.identified.frame_uncertainty())
        .unwrap();
    let (before, after) = (
        rms(&rates(&nominal, &rec), &rec.omega),
        rms(&rates(&identified, &rec), &rec.omega),
    );
    let ideal_sc = sc.with_ideal_parts();
    let ideal_rec = record(&ideal_sc);
    let reference = rms(&rates(&nominal, &ideal_rec), &ideal_rec.omega);
    let held: Vec<u8> = fit.identified.channels().iter().map(|f| f.held).collect();
    println!(
        "tumble without a reference, 20 s: start {:.3e} rad/s off, found {:.3e} off (sd {:.1e} \
         {:.1e} {:.1e}) after {} \
         evaluations (cost {:.1} for {} channels); Ω RMS nominal geometry {before:.3e}, \
         identified {after:.3e}, ideal parts {reference:.3e} ({:.2}×); held {held:?}",
        off(&est[0]),
        off(&fit.omega0),
        fit.omega0_sd[0],
        fit.omega0_sd[1],
        fit.omega0_sd[2],
        fit.evaluations,
        fit.cost,
        nominal.len(),
        after / reference
    );
    assert!(off(&est[0]) > 0.1, "the start is far off");
    assert!(off(&fit.omega0) < 1e-3);
    // The start rate's deviations describe its error (within 5 of them per component).
    for k in 0..3 {
        assert!((fit.omega0[k] - rec.omega[k0][k]).abs() < 5.0 * fit.omega0_sd[k]);
    }
    let case = "orbit-identify, torque-free tumble, 20 s, no reference (host)";
    assert!(
        report::row(
            case,
            Parts::Datasheet,
            "RMS error Ω over ideal parts",
            format!("{:.2}", after / reference),
            "≤ 1.2",
            after <= 1.2 * reference
        ),
        "{after} against {reference}"
    );
    let quiet = silent(&identified, &rec);
    println!("{quiet} of {} rows silently wrong", rec.sets.len());
    assert!(report::silent(
        case,
        Parts::Datasheet,
        quiet,
        rec.sets.len(),
        1000
    ));
    // Torque-free: at least one parameter held per channel besides the scale, and named.
    assert!(fit
        .identified
        .channels()
        .iter()
        .all(|f| f.held.count_ones() >= 2));
    // A held parameter's deviation is its tolerance (docs/telemetry.md, TM[200,129]): the start
    // rate's spread is the free parameters'.
    let tolerance = estimator_core::identify::Tolerance::DATASHEET;
    for f in fit.identified.channels() {
        for (k, p) in estimator_core::identify::Param::ALL.iter().enumerate() {
            if f.is_held(*p) {
                assert_eq!(f.sd[k], tolerance.of(k), "held {p:?}: {:?}", f.sd);
            }
        }
    }
    // Other windows, shorter ones included: each either finds the start rate or is refused
    // (from the estimator's rates with the nominal geometry, the search can end in a local
    // minimum: then no geometry fits and the solve says so).
    for (from, seconds) in [(15.0, 20.0), (35.0, 20.0), (1.0, 10.0), (30.0, 5.0)] {
        let (k0, k1, est) = window(&rec, &nominal, from, seconds);
        let sets = Window(&rec.sets[k0..k1], &est);
        let off = |w: &[f64; 3]| rms(&[*w], &[rec.omega[k0]]) * 3f64.sqrt();
        match identify_tumble(&sets, &body, &est[0], &nominal, &Tolerance::DATASHEET) {
            Ok(fit) => {
                let arr = fit
                    .identified
                    .arrangement(&fit.identified.frame_uncertainty())
                    .unwrap();
                let after = rms(&rates(&arr, &rec), &rec.omega);
                let quiet = silent(&arr, &rec);
                println!(
                    "window {from} s + {seconds} s: start {:.3e} off, found {:.3e} off; Ω RMS \
                     {:.2}× ideal parts; {quiet} of {} rows silently wrong",
                    off(&est[0]),
                    off(&fit.omega0),
                    after / reference,
                    rec.sets.len()
                );
                assert!(
                    quiet * 1000 <= rec.sets.len(),
                    "window {from} s + {seconds} s"
                );
                // Found the motion (the start was 0.38–0.45 rad/s off); a short window
                // determines the geometry less well (held parameters stay nominal).
                assert!(off(&fit.omega0) < 1e-2, "window {from} s + {seconds} s");
            }
            Err(e) => println!("window {from} s + {seconds} s: refused ({e:?})"),
        }
    }
}

#[test]
fn a_wrong_inertia_is_refused_not_returned() {
    let (sc, nominal, rec) = setup();
    let j = sc.body.inertia.unwrap();
    // A window of one stage: a refusal runs the search's whole budget (every start, every
    // offset), the longer the window the longer (20 s: twice the time, refused alike).
    let (k0, k1, est) = window(&rec, &nominal, 1.0, 4.0);
    // The principal moments given in the wrong order: no start rate fits the readings.
    let swapped = Body {
        inertia: Sym3([j[2], j[1], j[0], 0.0, 0.0, 0.0]),
        gamma: Sym3([0.0; 6]),
    };
    let sets = Window(&rec.sets[k0..k1], &est);
    match identify_tumble(&sets, &swapped, &est[0], &nominal, &Tolerance::DATASHEET) {
        Err(TumbleError::NotDetermined { channel, ratio }) => {
            println!("swapped inertia refused: channel {channel} residual {ratio:.1}× its noise");
            assert!(ratio > estimator_core::identify::RESIDUAL_LIMIT);
        }
        // The best start found leaves a channel whose solve does not settle: refused too.
        Err(TumbleError::Identify(e)) => println!("swapped inertia refused: {e:?}"),
        Ok(fit) => panic!(
            "accepted: Ω0 {:?} against {:?}, cost {}",
            fit.omega0, rec.omega[k0], fit.cost
        ),
        Err(e) => panic!("refused for another reason: {e:?}"),
    }
    let indefinite = Body {
        inertia: Sym3([1.0, -1.0, 1.0, 0.0, 0.0, 0.0]),
        gamma: Sym3([0.0; 6]),
    };
    assert_eq!(
        identify_tumble(&sets, &indefinite, &est[0], &nominal, &Tolerance::DATASHEET).err(),
        Some(TumbleError::Inertia)
    );
}

/// RMS errors of σ0 (at `origin` of the true geometry: `σ0 + (A + {Ω′}) origin`, paper eq. 4),
/// Ω′ and Ω of the estimator on `arr` over `sets` after 2 s, started at the true rate; and the
/// rows whose σ0 or Ω is more than 5 reported deviations off with no flag.
fn errors(
    arr: &Arrangement<HOST_CAP>,
    sets: &[(f64, Vec<f64>)],
    truth: &[hal_sim::motion::Truth],
    origin: [f64; 3],
) -> ([f64; 3], usize) {
    let mut est = Estimator::<f64, HOST_CAP>::new(
        arr,
        Model::General,
        Options {
            initial_omega: Some(truth[0].omega),
            ..Options::default()
        },
    )
    .unwrap();
    let (mut sum, mut n, mut silent) = ([0.0; 3], 0usize, 0usize);
    for ((t, p), tr) in sets.iter().zip(truth) {
        let e = est.update(*t, p);
        if *t < 2.0 {
            continue;
        }
        let at = tr.field.mul_vec(&origin);
        let dw = tr.domega;
        let s0 = [
            tr.sigma0[0] + at[0] + dw[1] * origin[2] - dw[2] * origin[1],
            tr.sigma0[1] + at[1] + dw[2] * origin[0] - dw[0] * origin[2],
            tr.sigma0[2] + at[2] + dw[0] * origin[1] - dw[1] * origin[0],
        ];
        let mut off = false;
        for k in 0..3 {
            sum[0] += (e.sigma0[k] - s0[k]).powi(2);
            sum[1] += (e.domega[k] - dw[k]).powi(2);
            sum[2] += (e.omega[k] - tr.omega[k]).powi(2);
            off |= (e.omega[k] - tr.omega[k]).abs() > 5.0 * e.sd_omega[k];
        }
        silent += usize::from(off && e.flags.0 == 0);
        n += 3;
    }
    (sum.map(|s| (s / n as f64).sqrt()), silent)
}

/// A drawn case (`e2e_tests::drawn`) in a torque-free tumble without a reference: the scenario,
/// its nominal arrangement, the record and its truth, the estimator's rates on the nominal
/// geometry, the body.
#[allow(clippy::type_complexity)]
fn drawn_tumble(
    seed: u64,
    parts: usize,
) -> (
    Scenario,
    Arrangement<HOST_CAP>,
    Vec<(f64, Vec<f64>)>,
    Vec<hal_sim::motion::Truth>,
    Vec<[f64; 3]>,
    Body,
) {
    let mut sc = e2e_tests::drawn::drawn_case(seed, parts, 20.0);
    sc.body.torque = None;
    sc.reference = None;
    let nominal = sc
        .arrangement()
        .load("arrangement.toml")
        .unwrap()
        .arrangement;
    let (sets, truth) = recorded::record(&sc);
    let mut est =
        Estimator::<f64, HOST_CAP>::new(&nominal, Model::General, Options::default()).unwrap();
    let rates: Vec<[f64; 3]> = sets.iter().map(|(t, p)| est.update(*t, p).omega).collect();
    let body = body(&sc);
    (sc, nominal, sets, truth, rates, body)
}

/// Without a reference, on drawn cases (4 or 5 ADXL355 at random places with datasheet errors
/// drawn, random torque-free tumbles; seeds 4911–4934, which the search's starts and the hold of
/// a channel that does not settle were chosen on): the whole 60 s record
/// at 100 Hz, as `ballisto calibrate --inertia` takes it. Each is either identified — σ0 (at
/// the identified origin), Ω′ and Ω then within 1.5 × ideal parts, no row silently wrong — or
/// refused by name (the channel no start rate explains, the channel and parameter the motion
/// does not determine, the channel whose solve does not settle).
#[test]
#[ignore = "a long sweep: scripts/validate.sh runs it and reports its figures"]
fn drawn_torque_free_tumbles_are_identified_or_refused_by_name() {
    let mut identified = 0;
    let mut failures = Vec::new();
    for (seed, parts) in (4911..=4934).map(|s: u64| (s, 4 + (s as usize + 1) % 2)) {
        let (sc, nominal, sets, truth, rates, body) = drawn_tumble(seed, parts);
        let ideal_sc = sc.with_ideal_parts();
        let (ideal_sets, ideal_truth) = recorded::record(&ideal_sc);
        let (reference, _) = errors(&nominal, &ideal_sets, &ideal_truth, [0.0; 3]);
        match identify_tumble(
            &Window(&sets, &rates),
            &body,
            &rates[0],
            &nominal,
            &Tolerance::DATASHEET,
        ) {
            Ok(fit) => {
                let arr = fit
                    .identified
                    .arrangement(&fit.identified.frame_uncertainty())
                    .unwrap();
                let rho = sc.body.origin_offset.unwrap_or([0.0; 3]);
                let origin: [f64; 3] = core::array::from_fn(|k| fit.identified.rho[k] - rho[k]);
                let (after, silent) = errors(&arr, &sets, &truth, origin);
                let r: Vec<f64> = (0..3).map(|k| after[k] / reference[k]).collect();
                println!(
                    "case {seed} ({parts} parts): identified after {} evaluations; σ0 {:.2} ×, \
                     Ω′ {:.2} ×, Ω {:.2} × ideal; {silent} rows silently wrong",
                    fit.evaluations, r[0], r[1], r[2]
                );
                identified += 1;
                let case = format!("drawn tumble {seed}: {parts} × ADXL355, no reference (host)");
                let held = report::over_ideal(&case, Parts::Datasheet, &[r[0], r[1], r[2]], 1.5);
                if !(held & report::silent(&case, Parts::Datasheet, silent, sets.len(), 1000)) {
                    failures.push((seed, r, silent));
                }
            }
            // Each refusal names a channel (and what of it the motion does not determine).
            Err(e @ TumbleError::NotDetermined { .. })
            | Err(e @ TumbleError::MotionUncertain { .. })
            | Err(e @ TumbleError::NotExcited { .. })
            | Err(e @ TumbleError::Ambiguous { .. })
            | Err(e @ TumbleError::Identify(_)) => {
                println!("case {seed} ({parts} parts): refused: {e:?}");
                report::refused(
                    &format!("drawn tumble {seed}: {parts} × ADXL355, no reference (host)"),
                    Parts::Datasheet,
                    refusal_name(&e),
                );
            }
            Err(e) => panic!("case {seed}: refused for a reason naming nothing: {e:?}"),
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
    assert!(
        identified >= 16,
        "{identified} of 24 drawn tumbles identified"
    );
}

/// A window that determines less than half of the geometry a tumble can is refused by name,
/// not returned as the nominal geometry under another name: drawn case 4920, a set every
/// 100 ms of 20 s (where, before the rule, every channel's tilts and position were held and
/// only the biases identified, Ω then 330 × the ideal parts' error).
#[test]
fn a_window_that_determines_little_is_refused_by_name() {
    let (_, nominal, sets, _, rates, body) = drawn_tumble(4920, 5);
    let kept: Vec<usize> = (100..2100).step_by(10).collect();
    let window: Vec<(f64, Vec<f64>)> = kept.iter().map(|&k| sets[k].clone()).collect();
    let window_rates: Vec<[f64; 3]> = kept.iter().map(|&k| rates[k]).collect();
    let refused = identify_tumble(
        &Window(&window, &window_rates),
        &body,
        &window_rates[0],
        &nominal,
        &Tolerance::DATASHEET,
    );
    println!("{refused:?}");
    assert!(
        matches!(refused, Err(TumbleError::NotExcited { .. })),
        "{:?}",
        refused.map(|f| f
            .identified
            .channels()
            .iter()
            .map(|c| c.held)
            .collect::<Vec<_>>())
    );
}

/// Means of consecutive sets, told as such (`Sets::averaged`), give the raw sets' solution:
/// `orbit-identify`'s tumble, 20 s from 1 s, raw and as means of 4 sets. Both identified; the
/// means' channels carry the nominal (per-set) noise and residuals of the same size, every
/// parameter is within a tenth of its tolerance of the raw solution's, and its deviation within
/// 25 % of it (or both held).
#[test]
fn means_of_sets_give_the_raw_sets_solution() {
    struct Means<'a>(Window<'a>, u32);
    impl Sets for Means<'_> {
        fn for_each(&self, f: &mut dyn FnMut(f64, &[f64])) {
            self.0.for_each(f)
        }
        fn rates(&self, f: &mut dyn FnMut(f64, &[f64; 3])) {
            self.0.rates(f)
        }
        fn averaged(&self) -> u32 {
            self.1
        }
    }
    let (sc, nominal, rec) = setup();
    let body = body(&sc);
    let (k0, k1, est) = window(&rec, &nominal, 1.0, 20.0);
    let raw = &rec.sets[k0..k1];
    let k = 4;
    let means: Vec<(f64, Vec<f64>)> = raw
        .chunks_exact(k)
        .map(|c| {
            let t = c.iter().map(|s| s.0).sum::<f64>() / k as f64;
            let p = (0..nominal.len())
                .map(|i| c.iter().map(|s| s.1[i]).sum::<f64>() / k as f64)
                .collect();
            (t, p)
        })
        .collect();
    let mean_rates: Vec<[f64; 3]> = est.chunks_exact(k).map(|c| c[0]).collect();
    let solve = |sets: &dyn Sets| {
        identify_tumble(sets, &body, &est[0], &nominal, &Tolerance::DATASHEET)
            .expect("identified")
            .identified
    };
    let a = solve(&Window(raw, &est));
    let b = solve(&Means(Window(&means, &mean_rates), k as u32));
    let tol = Tolerance::DATASHEET;
    for (i, ((x, y), c)) in a
        .channels()
        .iter()
        .zip(b.channels())
        .zip(nominal.channels())
        .enumerate()
    {
        assert!(
            (y.channel.noise - c.noise).abs() < 1e-12 * c.noise,
            "channel {i}"
        );
        let r = y.residual_rms / x.residual_rms;
        assert!((0.8..1.25).contains(&r), "channel {i}: residual {r}");
        let d = |u: &[f64; 3], v: &[f64; 3]| {
            ((u[0] - v[0]).powi(2) + (u[1] - v[1]).powi(2) + (u[2] - v[2]).powi(2)).sqrt()
        };
        assert!(
            d(&x.channel.position, &y.channel.position) < 0.1 * tol.position,
            "channel {i}"
        );
        assert!(
            d(&x.channel.axis, &y.channel.axis) < 0.1 * tol.axis,
            "channel {i}"
        );
        assert!(
            (x.channel.bias - y.channel.bias).abs() < 0.1 * tol.bias,
            "channel {i}"
        );
        assert_eq!(x.held, y.held, "channel {i}");
        for p in 0..x.sd.len() {
            let r = y.sd[p] / x.sd[p];
            assert!(
                (0.8..1.25).contains(&r),
                "channel {i} parameter {p}: sd {r}"
            );
        }
    }
}

/// A refusal's kind and what it names, for the report.
fn refusal_name(e: &TumbleError) -> String {
    match e {
        TumbleError::NotDetermined { channel, ratio } => {
            format!("not determined: channel {channel}, residual {ratio:.1} × its noise")
        }
        TumbleError::MotionUncertain { channel, param, .. } => {
            format!("motion uncertain: channel {channel}, {param:?}")
        }
        TumbleError::NotExcited { channel, param } => {
            format!("not excited: channel {channel}, {param:?}")
        }
        TumbleError::Ambiguous { .. } => "two start rates fit".to_string(),
        other => format!("{other:?}"),
    }
}
