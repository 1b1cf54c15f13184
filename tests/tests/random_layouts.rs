//! The property test: branch and sign on nine-channel layouts the estimator was not
//! tuned on. Layouts drawn at random (nine channels anywhere within the arm, any axes, kept when model F
//! accepts them and the design is conditioned within `nine::CONDITION_MAX`), ideal parts,
//! Gaussian noise as declared; a torque-free tumble (|Ω| ≈ 2.2 rad/s) and a slow manoeuvre
//! (|Ω| about 0.4–1.1 rad/s). Per draw: rows silently wrong (Ω more than 5 reported deviations
//! off, no flag), rows more than 1 rad/s off, and the raw σ0, Ω′, Ω RMS over the truth-started
//! maximum likelihood; the fused (default) Ω over the maximum likelihood's per-sample Ω.
//! Seeds are printed per row: a row reproduces with `nine::make_random`.

use e2e_tests::nine::{self, Params, Score};
use e2e_tests::report::{self, Parts};

/// One draw's figures.
struct Draw {
    layout: u64,
    params: Params,
    condition: f64,
    slow: bool,
    ml_omega: f64,
    raw: Score,
    fused: Score,
    ratio: [f64; 3],
    fused_ratio: f64,
}

fn draw(p: Params) -> Draw {
    let case = nine::make_random(p, p.seed, p.manoeuvre);
    let (raw, fused) = (case.forward(true), case.forward(false));
    let (raw, fused) = (Score::of(&raw, &case.truth), Score::of(&fused, &case.truth));
    let ml = nine::rms_of(&case.ml_errors());
    let rms = raw.rms();
    Draw {
        layout: p.seed,
        params: p,
        condition: nine::design_condition(&case.loaded),
        slow: p.manoeuvre,
        ml_omega: ml[2],
        ratio: core::array::from_fn(|i| rms[i] / ml[i]),
        fused_ratio: fused.rms()[2] / ml[2],
        raw,
        fused,
    }
}

fn table(params: &[Params]) -> Vec<Draw> {
    let draws: Vec<Draw> = std::thread::scope(|s| {
        let handles: Vec<_> = params
            .chunks(params.len().div_ceil(4).max(1))
            .map(|chunk| s.spawn(move || chunk.iter().map(|p| draw(*p)).collect::<Vec<_>>()))
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().expect("draw"))
            .collect()
    });
    println!("| layout seed | rate | noise | arm | design condition | motion | ML's Ω RMS (rad/s) | silent raw / fused | > 1 rad/s off raw | flagged raw | σ0 / ML | Ω′ / ML | Ω / ML | fused Ω / ML |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for d in &draws {
        println!(
            "| {} | {} Hz | {:.1e} | {:.3} | {:.1} | {} | {:.3} | {:.3} % / {:.3} % | {:.2} % | {:.1} % | {:.2} | {:.2} | {:.2} | {:.2} |",
            d.layout,
            d.params.rate_hz,
            d.params.noise,
            d.params.arm,
            d.condition,
            if d.slow { "slow manoeuvre" } else { "tumble" },
            d.ml_omega,
            d.raw.pct(d.raw.silent),
            d.fused.pct(d.fused.silent),
            d.raw.pct(d.raw.off),
            d.raw.pct(d.raw.flagged),
            d.ratio[0],
            d.ratio[1],
            d.ratio[2],
            d.fused_ratio,
        );
    }
    let within = draws
        .iter()
        .filter(|d| d.ratio.iter().all(|r| *r <= 1.10))
        .count();
    println!(
        "{within} of {} draws within 1.10 × the maximum likelihood in σ0, Ω′ and Ω (raw)",
        draws.len()
    );
    draws
}

/// The parameters of draw `seed`: rate, noise, arm and motion drawn from the ranges
/// (rates from `rates`; noise 1e-4–1e-2 m/s² and arms 0.05–0.2 m log-uniform; either motion).
fn params(seed: u64, rates: &[f64], seconds: f64) -> Params {
    let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f64 / (1u64 << 53) as f64
    };
    let rate_hz = rates[(next() * rates.len() as f64) as usize % rates.len()];
    let noise = 10f64.powf(-4.0 + 2.0 * next());
    let arm = 0.05 * 4f64.powf(next());
    Params {
        rate_hz,
        noise,
        arm,
        seconds,
        seed,
        manoeuvre: next() < 0.5,
    }
}

/// What issue 46 asks of the draws: no more than 0.1 % of rows silently wrong on either
/// output, the raw σ0, Ω′ and Ω within 1.10 × the truth-started maximum likelihood on at least
/// 95 % of the draws, and on slow manoeuvres the filtered Ω within 0.25 × the maximum
/// likelihood's per-sample Ω.
fn holds(case: &str, draws: &[Draw]) {
    let rows: usize = draws.iter().map(|d| d.raw.rows).sum();
    let silent_raw: usize = draws.iter().map(|d| d.raw.silent).sum();
    let silent_fused: usize = draws.iter().map(|d| d.fused.silent).sum();
    println!(
        "silently wrong: raw {silent_raw}, filtered {silent_fused} of {rows} rows; worst draws by Ω / ML: {:?}",
        {
            let mut w: Vec<(u64, f64)> = draws.iter().map(|d| (d.layout, d.ratio[2])).collect();
            w.sort_by(|a, b| b.1.total_cmp(&a.1));
            w.truncate(3);
            w
        }
    );
    let mut held = report::row(
        case,
        Parts::Ideal,
        "rows silently wrong, raw / filtered",
        format!("{silent_raw} / {silent_fused} of {rows}"),
        "≤ 0.1 % each",
        silent_raw * 1000 <= rows && silent_fused * 1000 <= rows,
    );
    let within = draws
        .iter()
        .filter(|d| d.ratio.iter().all(|r| *r <= 1.10))
        .count();
    held &= report::row(
        case,
        Parts::Ideal,
        "draws with raw σ0, Ω′, Ω within 1.10 × ML",
        format!("{within} of {}", draws.len()),
        "≥ 95 %",
        within * 100 >= 95 * draws.len(),
    );
    let slow: Vec<&Draw> = draws.iter().filter(|d| d.slow).collect();
    let worst = slow
        .iter()
        .max_by(|a, b| a.fused_ratio.total_cmp(&b.fused_ratio));
    if let Some(w) = worst {
        held &= report::row(
            case,
            Parts::Ideal,
            "slow manoeuvres: worst filtered Ω / per-sample ML",
            format!(
                "{:.2} (draw {}; {} slow)",
                w.fused_ratio,
                w.layout,
                slow.len()
            ),
            "≤ 0.25 each",
            w.fused_ratio <= 0.25,
        );
    }
    assert!(held, "a bar of the draws is missed: the rows above");
}

/// Eight fresh draws (seeds 4701–4708, none used while the filter was developed), 50 Hz–1 kHz,
/// 10 s each.
#[test]
fn random_nine_channel_layouts() {
    let params: Vec<Params> = (4701..=4708u64)
        .map(|s| params(s, &[50.0, 100.0, 250.0, 1000.0], 10.0))
        .collect();
    for p in &params {
        println!(
            "draw {}: {} Hz, noise {:.1e} m/s², arm {:.3} m, {}",
            p.seed,
            p.rate_hz,
            p.noise,
            p.arm,
            if p.manoeuvre {
                "slow manoeuvre"
            } else {
                "tumble"
            }
        );
    }
    holds(
        "8 random nine-channel layouts, 50 Hz–1 kHz, 10 s",
        &table(&params),
    );
}

/// Thirty-two fresh draws (seeds 4801–4832), 50 Hz–4 kHz, 20 s each: `scripts/validate.sh`.
#[test]
#[ignore = "thirty-two random layouts with the ML reference (minutes): scripts/validate.sh"]
fn random_nine_channel_layouts_full() {
    println!("Random nine-channel layouts (model F, m = 3), ideal parts, declared Gaussian noise:");
    let params: Vec<Params> = (4801..=4832u64)
        .map(|s| params(s, &[50.0, 100.0, 250.0, 1000.0, 4000.0], 20.0))
        .collect();
    holds(
        "32 random nine-channel layouts, 50 Hz–4 kHz, 20 s",
        &table(&params),
    );
}

/// The draws the filter was developed on (seeds 4601–4608, 1 kHz, 2e-3 m/s², 0.12 m, 20 s).
#[test]
#[ignore = "eight random layouts × two motions with the ML reference (minutes): scripts/validate.sh"]
fn random_nine_channel_layouts_development_set() {
    println!(
        "Random nine-channel layouts (model F, m = 3), 1 kHz, 2e-3 m/s², arm 0.12 m, 20 s, ideal parts:"
    );
    let params: Vec<Params> = (4601..=4608u64)
        .flat_map(|layout| {
            [false, true].map(|slow| Params {
                rate_hz: 1000.0,
                noise: 2e-3,
                arm: 0.12,
                seconds: 20.0,
                seed: layout,
                manoeuvre: slow,
            })
        })
        .collect();
    table(&params);
}
