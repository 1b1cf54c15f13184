//! One fault supervisor: the unit (the firmware on the simulated buses) and the ground
//! (`ballisto estimate` on the samples the firmware read) run estimator-core's `Supervisor`,
//! so every fault kind of hal-sim, in a part drawn per run, on layouts that decide by a
//! parity space (N = 18 and the mixed N = 24), by model G's known field (N = 12) or in
//! model F, gives the same parts out and the same rows flagged 64 on both.

use e2e_tests::csv::read_columns;
use e2e_tests::faults::{drawn_fault, draws, firmware_then_host, inject, kinds};
use e2e_tests::report::{row, Parts};
use estimator_core::Flags;
use hal_sim::scenario::Scenario;

/// Rows of the two estimates files where the parts out differ, and where flag 64 does.
fn differences(sc: &Scenario, tag: &str) -> (usize, usize, usize) {
    let dir = std::env::temp_dir().join(format!("ballisto-one-{tag}-{}", std::process::id()));
    let host = firmware_then_host(sc, &dir);
    let names = ["t", "excluded", "flags"];
    let ground = read_columns(&host, &names);
    let unit = read_columns(&dir.join("estimates.csv"), &names);
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(ground.len(), unit.len(), "{tag}: rows");
    let (mut excluded, mut flagged) = (0, 0);
    for (g, u) in ground.iter().zip(&unit) {
        assert_eq!(g[0], u[0], "{tag}: times");
        let high = |row: &[f64]| row[2] as u16 & Flags::RESIDUAL_HIGH != 0;
        if g[1] != u[1] || high(g) != high(u) {
            println!(
                "{tag}: t {} ground out {} flags {}, unit out {} flags {}",
                g[0], g[1], g[2], u[1], u[2]
            );
        }
        excluded += usize::from(g[1] != u[1]);
        flagged += usize::from(high(g) != high(u));
    }
    (excluded, flagged, ground.len())
}

/// Every kind of [`kinds`] in a part drawn per kind, from a time drawn in 3–6 s, for 3 s.
fn every_kind_agrees(name: &str, layout: fn(u64) -> Scenario) {
    let mut next = draws(0x2545_F491_4F6C_DD1Du64);
    let mut report = Vec::new();
    for (k, (kind, _)) in kinds(1.0, 1.0).into_iter().enumerate() {
        let mut sc = layout(7000 + k as u64);
        let (part, spec) = drawn_fault(&sc, k, &mut next);
        let start = 3.0 + 3.0 * next();
        inject(&mut sc, part, &spec, &[(start, start + 3.0)]);
        let (excluded, flagged, rows) = differences(&sc, &format!("{name}-{k}"));
        println!("{name}: {kind} in part {part}: rows {rows}, parts out differ {excluded}, flag 64 differs {flagged}");
        report.push((kind, excluded, flagged, rows));
    }
    let runs = report.len();
    let rows: usize = report.iter().map(|r| r.3).sum();
    let differ: Vec<_> = report.iter().filter(|r| r.1 + r.2 > 0).collect();
    let held = row(
        &format!("{name}, every fault kind in a drawn part"),
        Parts::Ideal,
        "rows where the unit and the ground differ in parts out / flag 64",
        format!(
            "{} / {} of {rows} ({runs} runs)",
            report.iter().map(|r| r.1).sum::<usize>(),
            report.iter().map(|r| r.2).sum::<usize>()
        ),
        "0",
        differ.is_empty(),
    );
    assert!(held, "{name}: the unit and the ground differ: {differ:?}");
}

#[test]
fn eighteen_channels_in_model_g() {
    every_kind_agrees("N = 18, model G", e2e_tests::faults::layout);
}

#[test]
fn eighteen_channels_in_model_f() {
    every_kind_agrees("N = 18, model F", e2e_tests::faults::layout_free_float);
}

#[test]
fn the_mixed_layout() {
    every_kind_agrees("mixed N = 24", e2e_tests::faults::mixed);
}

#[test]
fn twelve_channels_on_the_known_field() {
    every_kind_agrees("tetra-orbit N = 12", |seed| {
        let mut sc = Scenario::load("tetra-orbit").unwrap();
        sc.duration = e2e_tests::faults::DURATION;
        sc.seed = seed;
        sc.faults.clear();
        sc
    });
}
