//! Issue 16: `identify_tumble` beyond the one recording of its test — other tumbles (initial
//! rates) and other noise seeds of `orbit-identify`'s datasheet parts, torque removed. Prints,
//! per variant, the start's and the result's Ω0 error, the Ω RMS over the record against ideal
//! parts, and the silently wrong rows (or the refusal).
//!
//! `cargo run --release -p e2e-tests --example tumble_variants` (`END=41` for a window of 1–41 s
//! instead of 1–21 s)

use e2e_tests::recorded::{ideal, record};
use estimator_core::identify::{identify_tumble, Body, Sets, Tolerance};
use estimator_core::{Arrangement, Estimator, Model, Options, Sym3};
use hal_sim::arrangement_file::HOST_CAP;
use hal_sim::scenario::Scenario;

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

/// Ω RMS and silently wrong rows of the estimator on a geometry.
fn run(
    arr: &Arrangement<HOST_CAP>,
    sets: &[(f64, Vec<f64>)],
    omega: &[[f64; 3]],
) -> (f64, usize, Vec<[f64; 3]>) {
    let mut est = Estimator::<f64, HOST_CAP>::new(
        arr,
        Model::General,
        Options {
            initial_omega: Some(omega[0]),
            ..Options::default()
        },
    )
    .unwrap();
    let (mut e2, mut silent, mut rates) = (0.0, 0, Vec::new());
    for ((t, p), w) in sets.iter().zip(omega) {
        let e = est.update(*t, p);
        e2 += (0..3).map(|i| (e.omega[i] - w[i]).powi(2)).sum::<f64>();
        silent += usize::from(
            e.flags.0 == 0 && (0..3).any(|i| (e.omega[i] - w[i]).abs() > 5.0 * e.sd_omega[i]),
        );
        rates.push(e.omega);
    }
    ((e2 / (3 * sets.len()) as f64).sqrt(), silent, rates)
}

fn main() {
    for (omega0, seed) in [
        ([0.3, 1.7, -0.6], 11),
        ([1.2, -0.4, 0.9], 12),
        ([-0.8, 0.5, 1.5], 13),
        ([2.0, 0.2, 0.3], 14),
        ([0.1, 0.1, 2.0], 15),
        ([0.2, 1.5, 0.2], 16),
    ] {
        let mut sc = Scenario::load("orbit-identify").unwrap();
        sc.body.torque = None;
        sc.body.omega0 = Some(omega0);
        sc.seed = seed;
        let j = sc.body.inertia.unwrap();
        let body = Body {
            inertia: Sym3([j[0], j[1], j[2], 0.0, 0.0, 0.0]),
            gamma: Sym3([0.0; 6]),
        };
        let nominal = sc
            .arrangement()
            .load("arrangement.toml")
            .unwrap()
            .arrangement;
        let (sets, truth) = record(&sc);
        let omega: Vec<[f64; 3]> = truth.iter().map(|t| t.omega).collect();
        let (ideal_sets, ideal_truth) = record(&ideal(&sc));
        let ideal_omega: Vec<[f64; 3]> = ideal_truth.iter().map(|t| t.omega).collect();
        let (reference, _, _) = run(&nominal, &ideal_sets, &ideal_omega);
        let (before, _, est) = run(&nominal, &sets, &omega);
        let k0 = sets.iter().position(|(t, _)| *t >= 1.0).unwrap();
        let k1 = sets
            .iter()
            .position(|(t, _)| {
                *t >= std::env::var("END")
                    .ok()
                    .and_then(|v| v.parse().ok())
                    .unwrap_or(21.0)
            })
            .unwrap();
        let off = |w: &[f64; 3]| {
            (0..3)
                .map(|i| (w[i] - omega[k0][i]).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        let r = identify_tumble(
            &Window(&sets[k0..k1], &est[k0..k1]),
            &body,
            &est[k0],
            &nominal,
            &Tolerance::DATASHEET,
        );
        match r {
            Ok(fit) => {
                let (after, silent, _) = run(&fit.identified.arrangement().unwrap(), &sets, &omega);
                println!(
                    "Ω0 {omega0:?} seed {seed}: start {:.2e} off, found {:.2e}; Ω RMS nominal {before:.2e}, identified {after:.2e}, ideal {reference:.2e} ({:.2}×); silent {silent} of {}",
                    off(&est[k0]),
                    off(&fit.omega0),
                    after / reference,
                    sets.len()
                );
            }
            Err(e) => println!(
                "Ω0 {omega0:?} seed {seed}: start {:.2e} off; Ω RMS nominal {before:.2e}; refused {e:?}",
                off(&est[k0])
            ),
        }
    }
}
