//! The fault matrix as a test: every fault kind of hal-sim in one part of a layout with
//! redundancy (N = 18, model G, ideal parts), 20 runs each, through the firmware on the
//! simulated buses with its fault monitor (`tests/examples/fault_matrix.rs` prints the table).

use ballisto_link::decode::Report;
use ballisto_link::EventId;
use e2e_tests::csv::read_columns;
use e2e_tests::faults::{fault_matrix, omega_error, INTERMITTENT};

/// Kinds the parity space must isolate in every run or all but one (a 10 σ bias in a part
/// whose removal leaves little redundancy can take longer than its 3 s).
const ISOLATED: [&str; 8] = [
    "stuck",
    "bias jump 0.1 m/s²",
    "bias jump 10 σ",
    "noise burst ×30",
    "saturation",
    "dead",
    "corrupt 5 %",
    "timeout",
];

#[test]
fn faults_are_isolated_and_the_estimate_without_the_part_is_as_good_as_never_having_it() {
    the_matrix_holds(e2e_tests::faults::layout);
}

/// The same layout estimated in model F: the monitor's parity space is model G's whatever the
/// model (model F's field is one of model G's), so a free-float instrument with redundancy
/// isolates as model G does (before, model F ran no parity test: only the stuck and range
/// checks).
#[test]
fn in_model_f_the_same_faults_are_isolated() {
    the_matrix_holds(e2e_tests::faults::layout_free_float);
}

/// The N = 18 matrix's assertions for a layout (20 runs per kind).
fn the_matrix_holds(layout: fn(u64) -> hal_sim::scenario::Scenario) {
    let runs = 20;
    let (clean, rows) = fault_matrix(runs, layout);
    // Fault-free: no part ever taken out, no row silently wrong, no NaN, nothing lost.
    assert_eq!(
        clean.wrong_excluded, 0,
        "healthy parts out in fault-free runs"
    );
    assert_eq!(clean.silent_clean, 0, "fault-free rows silently wrong");
    assert_eq!((clean.nan, clean.lost), (0, 0));
    assert!(clean.clean_rows > 20_000);
    false_alarms_within_the_goal(&clean);
    protection_holds("none", &clean.protection);
    for (name, t) in &rows {
        protection_holds(name, &t.protection);
        held_across_its_gaps(name, t);
        isolated_in_time_where_the_layout_surely_can(name, t);
        println!(
            "{name}: isolated {} of {runs}, healthy part out on {} rows, silent {} / {} while active, {} after, Ω error ratio {:?}",
            t.isolated.len(),
            t.wrong_excluded,
            t.silent_active,
            t.active,
            t.silent_after,
            t.error_ratio()
        );
        // Never a healthy part blamed; never NaN; no telemetry lost; every reference (the
        // run without the fault and without the part) a yardstick.
        assert_eq!(t.wrong_excluded, 0, "{name}: a healthy part out");
        assert_eq!(t.wrong_references, 0, "{name}: a reference wrong");
        assert_eq!((t.nan, t.lost), (0, 0), "{name}");
        // After the fault: at most the bar of 0.1 % silently wrong rows (a 3 σ bias that
        // was seen but not isolated can leave a handful), none after an isolated kind.
        assert!(
            t.silent_after * 1000 <= t.after,
            "{name}: silent after {}",
            t.silent_after
        );
        if ISOLATED.contains(name) {
            assert_eq!(t.silent_after, 0, "{name}: silently wrong after the fault");
            assert!(
                t.isolated.len() + 1 >= runs as usize,
                "{name}: isolated {}",
                t.isolated.len()
            );
            // At most 0.2 % while active (the bar is 0.1 %): between a 10 σ bias
            // jump's onset and its isolation the per-sample solve follows the fault at 8–10 of
            // its deviations while the monitor's window has not concluded and the estimator's
            // own residual gate flickers (10 of 6 000 rows, 0.17 %, with the branch and sign
            // filter of issue 46; the lock monitor it replaced flagged all but 3 of them). The
            // bound on such rows is the integrity bound; until then this is the figure.
            assert!(
                t.silent_active * 500 <= t.active,
                "{name}: silent while active {} of {}",
                t.silent_active,
                t.active
            );
            // The goal: the estimate with the part out within 1.2 × that of the same
            // run without the fault and without the part. With the last sets replayed through
            // the new configuration (`estimator_core::recent`) within 1.05 (measured 0.98–1.01;
            // restarted cold, 1.01–1.12).
            let ratio = t.error_ratio().expect("rows with the part out");
            assert!(ratio <= 1.05, "{name}: Ω error ratio {ratio:.2}");
        }
        // Every fault is seen within 1 s in most runs (a 3 σ bias or a 3 σ/s drift in some
        // parts only later: the table in `docs/validation.md`); a drift of 1 σ/s is one σ
        // after a second, which no test can see: reported, not asserted.
        if *name == "drift 1 σ per s" {
            continue;
        }
        assert!(
            t.detected.len() * 2 >= runs as usize,
            "{name}: detected {}",
            t.detected.len()
        );
    }
}

/// The goal: flag 64 on at most 0.1 % of the fault-free rows (the per-sample point
/// at 99.99 % leaves the budget to the readings' systematic misfit and the monitor's window;
/// at 99.9 % the per-sample test alone flagged 0.118 % of the N = 18 layout's rows).
fn false_alarms_within_the_goal(clean: &e2e_tests::faults::Tally) {
    assert!(
        clean.flagged_clean * 1000 <= clean.clean_rows,
        "false alarms: {} of {} rows",
        clean.flagged_clean,
        clean.clean_rows
    );
}

/// The goal for a bias or a drift: isolated within 2 s in every run whose fault the
/// layout can attribute to its part by then with 99 % probability (`e2e_tests::faults::
/// attributable`: what a test over the whole 2 s would see). At even odds, the boundary of
/// what any test can do, the share is reported (`docs/validation.md`).
fn isolated_in_time_where_the_layout_surely_can(name: &str, t: &e2e_tests::faults::Tally) {
    if let Some([_, (runs, isolated)]) = t.attributable {
        assert_eq!(
            isolated, runs,
            "{name}: isolated within 2 s in {isolated} of the {runs} runs surely attributable"
        );
    }
}

/// The goal for an intermittent fault: its part out on at least 99 % of the rows from
/// its second exclusion on, across the gaps between its bursts (a regular pattern and one whose
/// period is drawn per run, each gap within ±20 % of it). The first gap is not asserted: no
/// test can tell it from the end of a fault, and the part is re-admitted in it
/// (`estimator_core::fault_monitor`: the hold comes from the gap measured).
fn held_across_its_gaps(name: &str, t: &e2e_tests::faults::Tally) {
    if !name.starts_with(INTERMITTENT) {
        return;
    }
    assert!(t.since_second > 0, "{name}: never excluded twice");
    assert!(
        t.out_since_second * 100 >= 99 * t.since_second,
        "{name}: part out on {} of {} rows from its second exclusion on",
        t.out_since_second,
        t.since_second
    );
}

/// The goal for the protection levels: each output's error above its level on at most
/// 0.1 % of the rows that have one (the missed probability is 10⁻³), faults included; both
/// models have them on every row with all parts in, model F's linearised at each row's Ω
/// (`estimator_core::integrity`).
fn protection_holds(name: &str, p: &e2e_tests::faults::Protection) {
    println!(
        "{name}: error above PL σ0 / Ω′ / Ω {:?} of {} rows ({} without, {} with the sign unresolved), mean PL {:?}",
        p.above,
        p.bounded,
        p.unbounded,
        p.sign_unresolved,
        p.mean()
    );
    for q in 0..3 {
        assert!(
            p.above[q] * 1000 <= p.bounded,
            "{name}: output {q} above its protection level on {} of {} rows",
            p.above[q],
            p.bounded
        );
    }
}

/// One estimator: `ballisto estimate` on the samples the firmware read runs the
/// same monitor and takes the same parts out at the same rows (the `excluded` column of both
/// estimates files), writes the same protection levels (issue 48: empty on the same rows, else
/// equal to f32's precision), and writes no silently wrong row.
#[test]
fn ballisto_estimate_takes_out_the_part_the_firmware_takes_out_at_the_same_rows() {
    use hal_sim::scenario::FaultSpec;
    let mut sc = e2e_tests::faults::layout(4000);
    let part = 2;
    sc.faults.push(FaultSpec {
        part: sc.parts[part].name.clone(),
        kind: "stuck".to_string(),
        start: 4.0,
        end: Some(7.0),
        bias: None,
        rate: None,
        density: None,
        probability: None,
        stall: None,
    });
    let dir = std::env::temp_dir().join(format!("ballisto-faults-{}", std::process::id()));
    let out = e2e_tests::faults::firmware_then_host(&sc, &dir);
    let names = [
        "t",
        "excluded",
        "flags",
        "pl_sigma0",
        "pl_domega",
        "pl_omega",
    ];
    let host = read_columns(&out, &names);
    let firmware = read_columns(&dir.join("estimates.csv"), &names);
    let truth_path = dir.join("truth.csv");
    let truth = read_columns(&truth_path, &["t"]);
    assert_eq!(host.len(), firmware.len());
    let (silent, _, _) = silent_and_flagged(&out, &truth_path);
    // The telemetry says what was isolated and excluded, and when: the part isolated once,
    // excluded, included again after the fault; a suspicion may open and close around it.
    let stream =
        ballisto::decode::decode_stream(&std::fs::read(dir.join("telemetry.bin")).unwrap());
    assert!(stream.problems.is_empty(), "{:?}", stream.problems);
    let events: Vec<(EventId, u32, u32)> = stream
        .packets
        .iter()
        .filter_map(|p| match &p.report {
            Report::Event(e) if e.id != EventId::Boot => Some((e.id, e.a, e.b)),
            _ => None,
        })
        .collect();
    println!("events: {events:?}");
    let kinds: Vec<EventId> = events
        .iter()
        .map(|e| e.0)
        .filter(|k| *k != EventId::FaultSuspected)
        .collect();
    assert_eq!(
        kinds,
        [
            EventId::PartIsolated,
            EventId::PartsExcluded,
            EventId::PartsIncluded
        ]
    );
    let isolated = events.iter().find(|e| e.0 == EventId::PartIsolated);
    assert_eq!(isolated.map(|e| (e.1, e.2)), Some((2, 0b111 << 6)));
    assert!(events.len() <= 5, "{} events", events.len());
    // The part's three channels (`u2.x/y/z` are channels 6–8 of the arrangement file).
    let bits = 0b111u64 << (3 * part);
    let (mut out_rows, mut differ, mut bounded) = (0, 0, 0);
    for ((h, f), tr) in host.iter().zip(&firmware).zip(&truth) {
        assert_eq!(h[0], tr[0]);
        for q in 3..6 {
            let (a, b) = (h[q], f[q]);
            assert_eq!(
                a.is_nan(),
                b.is_nan(),
                "t {}: a level on one side only",
                h[0]
            );
            // Equal where the flags are (the host settles the sign of the first rows by its
            // backward run-in; the firmware's level covers −Ω there).
            assert!(
                a.is_nan() || h[2] != f[2] || (a - b).abs() <= 1e-4 * a.abs(),
                "t {}: level {q} host {a} firmware {b}",
                h[0]
            );
            bounded += usize::from(!a.is_nan());
        }
        let excluded = h[1] as u64;
        differ += usize::from(excluded != f[1] as u64);
        assert_eq!(excluded & !bits, 0, "t {}: a healthy part out", h[0]);
        if excluded == bits {
            out_rows += 1;
            assert!(h[2] as u16 & estimator_core::Flags::CHANNELS_EXCLUDED != 0);
            assert!(h[0] > 4.0, "out before the fault, t {}", h[0]);
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    println!(
        "rows out: {out_rows}, rows where host and firmware differ: {differ}, silent: {silent}, levels {bounded}"
    );
    // Levels on every row but the predictions (the part stuck is no missing reading).
    assert!(
        bounded >= 3 * (host.len() - 10),
        "levels on {bounded} of 3 × {}",
        host.len()
    );
    // Isolated within a second of the onset and held to its end (3 s at 100 Hz).
    assert!(out_rows >= 200, "rows with the part out: {out_rows}");
    assert_eq!(
        differ, 0,
        "the host's exclusions differ from the firmware's"
    );
    assert_eq!(silent, 0);
}

/// Rows from 1 s on of an estimates file against its truth: (silently wrong, flagged 64, rows).
fn silent_and_flagged(
    estimates: &std::path::Path,
    truth: &std::path::Path,
) -> (usize, usize, usize) {
    let e = read_columns(
        estimates,
        &[
            "t",
            "flags",
            "omega_x",
            "omega_y",
            "omega_z",
            "sd_omega_x",
            "sd_omega_y",
            "sd_omega_z",
        ],
    );
    let tr = read_columns(truth, &["t", "omega_x", "omega_y", "omega_z"]);
    let (mut silent, mut flagged, mut rows) = (0, 0, 0);
    for (a, b) in e.iter().zip(&tr) {
        if a[0] < 1.0 {
            continue;
        }
        rows += 1;
        let flags = a[1] as u16;
        let at = |v: &[f64], i: usize| [v[i], v[i + 1], v[i + 2]];
        let (_, wrong) = omega_error(at(a, 2), at(b, 1), at(a, 5), flags);
        silent += usize::from(wrong);
        flagged += usize::from(flags & estimator_core::Flags::RESIDUAL_HIGH != 0);
    }
    (silent, flagged, rows)
}

/// Twelve channels in model G have no parity space; model G's known-field test (Γ known in
/// orbit: three degrees of freedom) flags what the faults of `tetra-orbit-faults` do to the
/// estimate, through the firmware and through `ballisto estimate` on its samples, and nothing
/// on the clean `tetra-orbit`. A part out (the stuck one, the dead one) leaves nine channels:
/// both take them in model F at the same rows, and a suspicion stands through that spell
/// without a test. The same scenarios configured in model F: its own residual windowed
/// (`ResidualCheck`, three degrees of freedom) flags the bias that the per-sample χ² lets
/// through (194 silently wrong firmware rows without the window).
#[test]
fn twelve_channels_are_never_silently_wrong_under_the_named_faults() {
    for (name, faulty, free_float) in [
        ("tetra-orbit-faults", true, false),
        ("tetra-orbit", false, false),
        ("tetra-orbit-faults", true, true),
        ("tetra-orbit", false, true),
    ] {
        let mut sc = hal_sim::scenario::Scenario::load(name).unwrap();
        if free_float {
            sc.model = Some("free-float".to_string());
        }
        let dir = std::env::temp_dir().join(format!(
            "ballisto-field-{}-{name}-{free_float}",
            std::process::id()
        ));
        let host = e2e_tests::faults::firmware_then_host(&sc, &dir);
        let truth = dir.join("truth.csv");
        let fw = silent_and_flagged(&dir.join("estimates.csv"), &truth);
        let h = silent_and_flagged(&host, &truth);
        // One estimator: the same channels out at the same rows (the stuck part isolated, the
        // dead one missing; each time in model F, whose rows leave the gamma columns empty).
        let names = ["excluded", "gamma_xx"];
        let (fe, he) = (
            read_columns(&dir.join("estimates.csv"), &names),
            read_columns(&host, &names),
        );
        let _ = std::fs::remove_dir_all(&dir);
        let out_rows = fe.iter().filter(|r| r[0] != 0.0).count();
        let differ = fe.iter().zip(&he).filter(|(a, b)| a[0] != b[0]).count();
        let model_f = |rows: &[Vec<f64>]| rows.iter().filter(|r| r[1].is_nan()).count();
        let name = if free_float {
            format!("{name} (model F)")
        } else {
            name.to_string()
        };
        println!(
            "{name}: (silent, flagged 64, rows) firmware {fw:?}, ballisto estimate {h:?}; rows \
             with a part out {out_rows}, in model F: firmware {}, host {}; excluded differs on \
             {differ}",
            model_f(&fe),
            model_f(&he)
        );
        assert_eq!(
            differ, 0,
            "{name}: the host's exclusions differ from the firmware's"
        );
        let in_f = if free_float { fe.len() } else { out_rows };
        assert_eq!(
            model_f(&fe),
            in_f,
            "{name}: model F exactly while a part is out"
        );
        assert_eq!(model_f(&he), in_f, "{name}");
        assert_eq!((fw.0, h.0), (0, 0), "{name}: silently wrong rows");
        if faulty {
            assert!(fw.1 > 500 && h.1 > 500, "{name}: the faults are flagged");
        } else if free_float {
            // Model F's per-sample χ² above its 99.9 % point: about 2 of 1 901 rows expected;
            // the window adds none.
            assert!(fw.1 <= 8 && h.1 <= 8, "{name}: false alarms");
        } else {
            assert_eq!((fw.1, h.1), (0, 0), "{name}: false alarms");
        }
    }
}

/// A passing known-field test clears a suspicion (`Verdict::with_field`): `ground-spin-mixed`
/// (twelve channels in model G on the ground, a spin-up from rest) trips it at start-up only —
/// taken for no test, the held suspicion flagged 1 994 of its 2 001 firmware rows.
#[test]
fn a_start_up_suspicion_on_twelve_channels_ends_when_the_field_test_passes() {
    let sc = hal_sim::scenario::Scenario::load("ground-spin-mixed").unwrap();
    let dir = std::env::temp_dir().join(format!("ballisto-gsm-{}", std::process::id()));
    let host = e2e_tests::faults::firmware_then_host(&sc, &dir);
    let names = ["t", "flags"];
    let last_flagged = |path: &std::path::Path| {
        read_columns(path, &names)
            .iter()
            .filter(|r| r[1] as u16 & estimator_core::Flags::RESIDUAL_HIGH != 0)
            .map(|r| r[0])
            .fold(0.0, f64::max)
    };
    let (fw, h) = (
        last_flagged(&dir.join("estimates.csv")),
        last_flagged(&host),
    );
    let _ = std::fs::remove_dir_all(&dir);
    println!("last row flagged 64: firmware {fw} s, ballisto estimate {h} s");
    assert!(fw < 3.0 && h < 3.0, "flag 64 after the start-up");
}

/// The 24-channel mixed layout (`e2e_tests::faults::mixed_layout`: LIS3DH on their own clocks,
/// a spin-up from rest on the ground). Since model G keeps a second history per output while
/// its path check fails (docs/validation.md, "Fault detection"), the wrong sign taken near rest is given
/// up: no fault-free row is silently wrong and at most 0.5 % of the rows after a fault (20 runs:
/// 0 %; before, 8–17 %), and where the part was taken out the estimate is within the issue's
/// 1.2 × that of the run without it (references that are themselves wrong left apart; since
/// the replay of the last sets, within 1.05). With
/// the interpolated values' own variance declared to the monitor no healthy part is taken out
/// (without it, up to 0.6 % of the rows after small or noisy faults). Not yet good
/// enough, and so not asserted: small biases silently wrong while active (the table in `docs/validation.md`).
#[test]
fn the_mixed_layout_is_not_silently_wrong_after_a_fault() {
    let (clean, rows) = fault_matrix(10, e2e_tests::faults::mixed);
    assert_eq!((clean.nan, clean.lost), (0, 0));
    false_alarms_within_the_goal(&clean);
    protection_holds("none", &clean.protection);
    assert_eq!(clean.silent_clean, 0, "fault-free rows silently wrong");
    assert_eq!(
        clean.wrong_excluded, 0,
        "healthy parts out in fault-free runs"
    );
    for (name, t) in &rows {
        println!(
            "{name}: silent {} / {} while active, {} / {} after, Ω error ratio {:?} ({} references wrong)",
            t.silent_active,
            t.active,
            t.silent_after,
            t.after,
            t.error_ratio(),
            t.wrong_references
        );
        assert_eq!((t.nan, t.lost), (0, 0), "{name}");
        assert_eq!(t.wrong_excluded, 0, "{name}: a healthy part out");
        // A slow drift is seen late in this layout, or within a 1 s of its onset in none of
        // the runs (the open goal: a test on the residual's mean): reported, not
        // asserted.
        if !name.starts_with("drift") {
            assert!(!t.detected.is_empty(), "{name}: never seen");
        }
        protection_holds(name, &t.protection);
        held_across_its_gaps(name, t);
        isolated_in_time_where_the_layout_surely_can(name, t);
        assert!(
            t.silent_after * 200 <= t.after,
            "{name}: silent after {} of {}",
            t.silent_after,
            t.after
        );
        // The goal is 1.2 ×; with the last sets replayed through the new
        // configuration (`estimator_core::recent`) within 1.05 (measured 0.99–1.02; restarted
        // cold, 1.05–1.11).
        if let Some(ratio) = t.error_ratio() {
            assert!(ratio <= 1.05, "{name}: Ω error ratio {ratio:.2}");
        }
    }
}

/// Range limits (issue 17: saturation "from its own signal"): a bias of 40 m/s² on one axis of
/// a ±2 g ADXL355 drives that axis onto its rail (20.08 m/s²) while its other two still move, so
/// only the range limit can name the part from its own signal. With redundancy (N = 18) the
/// part is out of the solve from the first clipped set, in the firmware and in `ballisto
/// estimate` alike (the arrangement file's `range`); with twelve channels in model G (no
/// parity space) it is named at once by a `part-isolated` event and taken out all the same, the
/// estimate made in model F on the nine channels left until it returns (`model-switched`
/// events). Never a silently wrong row.
#[test]
fn one_axis_on_its_rail_names_its_part_at_the_first_clipped_set() {
    use hal_sim::scenario::{FaultSpec, Scenario};
    let part = 2;
    let onset = 4.0;
    let fault = |sc: &Scenario| FaultSpec {
        part: sc.parts[part].name.clone(),
        kind: "bias-jump".to_string(),
        start: onset,
        end: Some(onset + 3.0),
        bias: Some([0.0, 0.0, 40.0]),
        rate: None,
        density: None,
        probability: None,
        stall: None,
    };
    let bits = 0b111u64 << (3 * part);
    for redundant in [true, false] {
        let mut sc = if redundant {
            e2e_tests::faults::layout(4100)
        } else {
            Scenario::load("tetra-orbit").unwrap()
        };
        sc.faults.push(fault(&sc));
        let dir =
            std::env::temp_dir().join(format!("ballisto-range-{}-{redundant}", std::process::id()));
        let host = e2e_tests::faults::firmware_then_host(&sc, &dir);
        let names = ["t", "excluded", "flags"];
        let h = read_columns(&host, &names);
        let f = read_columns(&dir.join("estimates.csv"), &names);
        let truth = dir.join("truth.csv");
        let (silent_fw, _, _) = silent_and_flagged(&dir.join("estimates.csv"), &truth);
        let (silent_host, _, _) = silent_and_flagged(&host, &truth);
        let stream =
            ballisto::decode::decode_stream(&std::fs::read(dir.join("telemetry.bin")).unwrap());
        let _ = std::fs::remove_dir_all(&dir);
        let named: Vec<(f64, u32)> = stream
            .packets
            .iter()
            .filter_map(|p| match &p.report {
                Report::Event(e) if e.id == EventId::PartIsolated => Some((p.t, e.a)),
                _ => None,
            })
            .collect();
        // On-board time runs from boot, before the first set: the first motion report's time
        // less the first row's is the offset.
        let boot = stream
            .packets
            .iter()
            .find(|p| matches!(p.report, Report::Motion(_)))
            .map_or(0.0, |p| p.t)
            - f[0][0];
        let first = |rows: &[Vec<f64>], bit: &dyn Fn(&[f64]) -> bool| {
            rows.iter()
                .find(|r| r[0] >= onset - 0.5 && bit(r))
                .map(|r| r[0])
        };
        let out = |r: &[f64]| r[1] as u64 == bits;
        let (first_h, first_f) = (first(&h, &out), first(&f, &out));
        let switches: Vec<(f64, u32, u32)> = stream
            .packets
            .iter()
            .filter_map(|p| match &p.report {
                Report::Event(e) if e.id == EventId::ModelSwitched => Some((p.t - boot, e.a, e.b)),
                _ => None,
            })
            .collect();
        println!(
            "N = {}: part named {named:?} (on-board time, boot {boot:.3} s before the first \
             set); first row out: host {first_h:?}, firmware {first_f:?}; model switched \
             {switches:?}; silent host {silent_host}, firmware {silent_fw}",
            if redundant { 18 } else { 12 }
        );
        assert_eq!(named.first().map(|e| e.1), Some(part as u32));
        let at = named[0].0 - boot;
        assert!(
            (onset..onset + 0.005).contains(&at),
            "named at {at} s (onset {onset} s)"
        );
        for first in [first_h, first_f] {
            let t = first.expect("the part out");
            assert!((onset..onset + 0.005).contains(&t), "from {t} s");
        }
        // The same rows out in both, and only this part ever.
        let differ = h.iter().zip(&f).filter(|(a, b)| a[1] != b[1]).count();
        assert_eq!(differ, 0, "rows where host and firmware differ");
        let rows_out = f.iter().filter(|r| out(r)).count();
        assert!(rows_out >= 300, "rows out {rows_out}");
        assert!(f.iter().all(|r| r[1] as u64 & !bits == 0));
        if redundant {
            assert!(switches.is_empty(), "model switched with 15 channels left");
        } else {
            // Nine channels do not carry model G: model F from the first clipped set to the
            // part's return, each switch reported.
            let (g, f) = (0, 1);
            assert_eq!(switches.len(), 2, "{switches:?}");
            assert_eq!((switches[0].1, switches[0].2), (g, f));
            assert!((onset..onset + 0.005).contains(&switches[0].0));
            assert_eq!((switches[1].1, switches[1].2), (f, g));
            assert!(switches[1].0 > onset + 3.0);
        }
        assert_eq!((silent_fw, silent_host), (0, 0), "silently wrong rows");
    }
}

/// A part that stands in for the faulty one is not taken out in its place. Noise bursts (×30,
/// 0.3 s) in u2 of the N = 18 layout, whose removal u5's nearly matches (a fresh seed of the
/// matrix's drawn-period intermittent kind, 8014): as the tests decay after the first burst,
/// u5's removal explained a little more of the excess than u2's, and u5 was taken out for
/// 245 rows. Isolation now needs every other part's removal to leave a test above its limit.
#[test]
fn a_part_that_stands_in_for_the_faulty_one_is_not_taken_out_in_its_place() {
    use e2e_tests::faults::{fault_run, inject, kinds, layout, JITTERED};
    let mut sc = layout(8014);
    let part = 2;
    let faulty = &sc.parts[part];
    let (_, spec) = kinds(
        sc.channel_noise(faulty),
        faulty.noise_density.unwrap_or(0.0),
    )
    .into_iter()
    .find(|(name, _)| *name == JITTERED)
    .unwrap();
    let bursts = [(2.689, 2.989), (8.989, 9.289), (17.217, 17.517)];
    inject(&mut sc, part, &spec, &bursts);
    sc.duration = 20.5;
    let r = fault_run(&sc, Some((part, bursts[0].0, bursts[2].1)));
    assert_eq!(r.wrong_excluded, 0, "rows with a healthy part out");
    assert_eq!((r.nan, r.lost), (0, 0));
}

/// What the layout itself can attribute (`e2e_tests::faults::attributable`, the yardstick of the
/// matrix's "isolated ≤ 2 s" column): in the N = 18 layout parts u2 and u5 stand in for each
/// other for the matrix's fault direction `(1, −1, ½)` — a 3 σ bias or a 3 σ/s drift on either
/// is not attributable within 2 s by any test on the residual, on every other part it is —
/// and a 10 σ bias on any part is.
#[test]
fn parts_that_can_stand_in_for_each_other_are_not_attributable() {
    use e2e_tests::faults::{attributable, EVEN_ODDS};
    let sc = e2e_tests::faults::layout(2000);
    let sigma = sc.channel_noise(&sc.parts[0]);
    let pattern = |b: f64| [b, -b, 0.5 * b];
    let twins = [2, 5];
    for p in 0..sc.parts.len() {
        let small = pattern(3.0 * sigma);
        let expected = Some(!twins.contains(&p));
        assert_eq!(
            attributable(&sc, p, small, [0.0; 3], EVEN_ODDS),
            expected,
            "3 σ bias, u{p}"
        );
        assert_eq!(
            attributable(&sc, p, [0.0; 3], small, EVEN_ODDS),
            expected,
            "3 σ/s drift, u{p}"
        );
        let large = pattern(10.0 * sigma);
        assert_eq!(
            attributable(&sc, p, large, [0.0; 3], EVEN_ODDS),
            Some(true),
            "10 σ, u{p}"
        );
    }
    // No parity space without the two extra parts: nothing can be attributed.
    let mut four = sc.clone();
    four.parts.truncate(4);
    assert_eq!(
        attributable(&four, 0, pattern(1.0), [0.0; 3], EVEN_ODDS),
        None
    );
}
