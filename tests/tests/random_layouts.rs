//! Issue 46's measure: branch and sign on nine-channel layouts the estimator was not tuned on.
//! Layouts drawn at random (nine channels anywhere within the arm, any axes, kept when model F
//! accepts them: the rank check), 1 kHz, 2e-3 m/s² (Gaussian, as declared), arm 0.12 m, ideal
//! parts, 20 s; a torque-free tumble (|Ω| ≈ 2.2 rad/s) and a slow manoeuvre (|Ω| about
//! 0.4–1.1 rad/s). Per draw: rows silently wrong (Ω more than 5 reported deviations off, no
//! flag) and more than 1 rad/s off on each path, and the raw σ0, Ω′, Ω RMS of `ballisto
//! estimate --raw` over the truth-started maximum likelihood — the figures issue 46 asks to
//! bound (≤ 0.1 % silent; ≤ 1.10 × ML on 95 % of draws).
//!
//! Not asserted yet: the estimator does not meet them (issue 46 is open); `scripts/validate.sh`
//! prints the table into `docs/validation.md`. Layout seeds 4601–4608 (printed per row: a row
//! reproduces with `nine::make_random`).

use e2e_tests::nine::{self, Params, Score};

/// Layout seeds of the draws.
const LAYOUTS: std::ops::RangeInclusive<u64> = 4601..=4608;

#[test]
#[ignore = "eight random layouts × two motions with the ML reference (minutes): scripts/validate.sh"]
fn random_nine_channel_layouts_full() {
    println!(
        "Random nine-channel layouts (model F, m = 3), 1 kHz, 2e-3 m/s², arm 0.12 m, 20 s, ideal parts:"
    );
    println!("| layout seed | design condition | motion | ML's Ω RMS (rad/s) | silent fwd / two-way (raw) | silent filtered fwd / two-way | > 1 rad/s off fwd / two-way | flagged two-way | σ0 / ML | Ω′ / ML | Ω / ML |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let mut within = 0;
    let mut draws = 0;
    for layout in LAYOUTS {
        for slow in [false, true] {
            let p = Params {
                rate_hz: 1000.0,
                noise: 2e-3,
                arm: 0.12,
                seconds: 20.0,
                seed: layout,
                manoeuvre: slow,
            };
            let case = nine::make_random(p, layout, slow);
            let (fwd, two) = (case.forward(true), case.smoothed(true));
            let (ffwd, ftwo) = (case.forward(false), case.smoothed(false));
            let score = |rows: &[estimator_core::Estimate<f64>]| Score::of(rows, &case.truth);
            let (f, t, ff, ft) = (score(&fwd), score(&two), score(&ffwd), score(&ftwo));
            let ml = nine::rms_of(&case.ml_errors());
            let rms = t.rms();
            let ratio: [f64; 3] = core::array::from_fn(|i| rms[i] / ml[i]);
            draws += 1;
            if ratio.iter().all(|r| *r <= 1.10) {
                within += 1;
            }
            println!(
                "| {layout} | {:.1} | {} | {:.3} | {:.3} % / {:.3} % | {:.3} % / {:.3} % | {:.2} % / {:.2} % | {:.1} % | {:.2} | {:.2} | {:.2} |",
                nine::design_condition(&case.loaded),
                if slow { "slow manoeuvre" } else { "tumble" },
                ml[2],
                f.pct(f.silent),
                t.pct(t.silent),
                ff.pct(ff.silent),
                ft.pct(ft.silent),
                f.pct(f.off),
                t.pct(t.off),
                t.pct(t.flagged),
                ratio[0],
                ratio[1],
                ratio[2]
            );
        }
    }
    println!("{within} of {draws} draws within 1.10 × the maximum likelihood in σ0, Ω′ and Ω (two-way, raw)");
}
