//! The protection levels hold on layouts they were not developed on: random arrays of 4–8
//! tri-axial parts (random places within a random arm, random mountings, random noise), both
//! models wherever they have redundancy, random motions (rates 0.3–3 rad/s, a steady Ω′), and
//! a fault of random size (0–30 σ of one reading, random direction) on a random part at every
//! row — the per-row bound's worst case. In f64 and in the unit's f32. Each output's error is
//! above its level on at most 0.1 % of the rows (the missed probability, 10⁻³), and in f64
//! every solved row of a configuration with redundancy has a level (in f32 the rows without
//! one are counted and printed, and each carries flag 512). Seeds 9100–9131 showed that an absolute threshold on a part's
//! `P_SS` refused 29 % of model F's rows, seeds 9200–9231 that a precision threshold still
//! refused 1.4 % in f32 (it now inverts `P_SS − 16 ε I`: `integrity/free_float.rs`); seeds
//! 9300–9331, run here, were not used in developing the levels.

use estimator_core::linalg::{cross, dot, Vec3};
use estimator_core::{Arrangement, Estimator, Flags, Model, Options, Real};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const ROWS: usize = 2_000;

/// A random rotation (columns: the part's axes in the body frame), from a random quaternion.
fn rotation(rng: &mut ChaCha8Rng) -> [[f64; 3]; 3] {
    estimator_core::linalg::quat_to_mat(core::array::from_fn(|_| rng.gen_range(-1.0..1.0)))
}

/// One draw: the layout, the motion, the model.
struct Draw {
    arr: Arrangement<24>,
    noise: Vec<f64>,
    parts: usize,
    sigma0: Vec3<f64>,
    omega0: Vec3<f64>,
    domega: Vec3<f64>,
}

fn draw(seed: u64) -> Draw {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let parts = rng.gen_range(4..=8usize);
    let arm = rng.gen_range(0.05..0.3);
    let mut arr = Arrangement::<24>::new();
    let mut noise = Vec::new();
    let mut part = Vec::new();
    for p in 0..parts {
        let at: Vec3<f64> = core::array::from_fn(|_| rng.gen_range(-arm..arm));
        let m = rotation(&mut rng);
        let sigma = 10f64.powf(rng.gen_range(-4.0..-2.5));
        // The part's axes: the rotation's columns.
        for axis in (0..3).map(|k| m.map(|row| row[k])) {
            arr.push(at, axis, sigma).unwrap();
            noise.push(sigma);
            part.push(p as u8);
        }
    }
    arr.set_parts(&part);
    let dir: Vec3<f64> = core::array::from_fn(|_| rng.gen_range(-1.0..1.0));
    let n = dot(&dir, &dir).sqrt();
    let rate = rng.gen_range(0.3..3.0);
    Draw {
        arr,
        noise,
        parts,
        // On the ground or in free fall.
        sigma0: if rng.gen_bool(0.5) {
            [0.0, 0.0, 9.80665]
        } else {
            [0.0; 3]
        },
        omega0: dir.map(|v| rate * v / n),
        domega: core::array::from_fn(|_| rng.gen_range(-0.2..0.2)),
    }
}

fn distance(a: &Vec3<f64>, b: &Vec3<f64>) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

/// Rows, rows above each level, rows without a level.
#[derive(Default, Debug)]
struct Tally {
    rows: usize,
    above: [usize; 3],
    without: usize,
}

fn run<T: Real>(d: &Draw, model: Model, seed: u64, tally: &mut Tally) {
    let n = d.arr.len();
    let options = Options {
        raw: true,
        initial_omega: Some(d.omega0),
        ..Options::default()
    };
    let Ok(mut est) = Estimator::<T, 24>::new(&d.arr, model, options) else {
        return; // a draw the model cannot configure (degenerate): nothing to bound
    };
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed);
    for k in 0..ROWS {
        let t = k as f64 * 0.01;
        let w: Vec3<f64> = core::array::from_fn(|i| d.omega0[i] + d.domega[i] * t);
        let mut p = [T::ZERO; 24];
        let part = rng.gen_range(0..d.parts);
        let size = rng.gen_range(0.0..30.0);
        for (i, ch) in d.arr.channels().iter().enumerate() {
            let r = ch.position;
            let wr = cross(&w, &r);
            let f: Vec3<f64> =
                core::array::from_fn(|j| d.sigma0[j] + cross(&d.domega, &r)[j] + cross(&w, &wr)[j]);
            let (u1, u2): (f64, f64) = (rng.gen_range(1e-12..1.0), rng.gen());
            let gauss = (-2.0 * u1.ln()).sqrt() * (core::f64::consts::TAU * u2).cos();
            let mut x = dot(&ch.axis, &f) + d.noise[i] * gauss;
            if i / 3 == part {
                x += size * d.noise[i] * rng.gen_range(-1.0..1.0);
            }
            p[i] = T::of(x);
        }
        let e = *est.update(t, &p[..n]);
        tally.rows += 1;
        // Every row is solved here: one without a level says so.
        assert_eq!(
            e.flags.has(Flags::NO_PROTECTION_LEVEL),
            e.protection.is_none(),
            "flag 512 and the level at row {k}"
        );
        let Some(pl) = e.protection else {
            tally.without += 1;
            continue;
        };
        let out = [e.sigma0, e.domega, e.omega].map(|v| v.map(|x| x.to_f64()));
        for (q, truth) in [d.sigma0, d.domega, w].iter().enumerate() {
            tally.above[q] += usize::from(distance(&out[q], truth) > pl[q].to_f64());
        }
    }
}

#[test]
fn levels_hold_on_random_layouts_in_both_models_and_precisions() {
    let mut tallies: [[Tally; 2]; 2] = Default::default();
    for seed in 9300..9332u64 {
        let d = draw(seed);
        for (m, model) in [Model::General, Model::FreeFloat].into_iter().enumerate() {
            let redundant = match model {
                Model::General => d.arr.len() > 12,
                Model::FreeFloat => d.arr.len() > 9,
            };
            if !redundant {
                continue;
            }
            run::<f64>(&d, model, seed, &mut tallies[m][0]);
            run::<f32>(&d, model, seed, &mut tallies[m][1]);
        }
    }
    for (m, name) in ["model G", "model F"].iter().enumerate() {
        for (k, precision) in ["f64", "f32"].iter().enumerate() {
            let t = &tallies[m][k];
            println!("{name} {precision}: {t:?}");
            assert!(t.rows > 20_000, "{name} {precision}: {} rows", t.rows);
            for q in 0..3 {
                assert!(
                    t.above[q] * 1000 <= t.rows - t.without,
                    "{name} {precision}: output {q} above its level on {} of {} rows",
                    t.above[q],
                    t.rows - t.without
                );
            }
            // In f64 every solved row has a level. In f32 a part checked poorly enough that
            // rounding could hide its fault leaves its row without one (said, not bounded):
            // reported, 1.3 % of model F's rows on these seeds.
            println!(
                "{name} {precision}: {:.2} % of the rows without a level",
                100.0 * t.without as f64 / t.rows as f64
            );
            if *precision == "f64" {
                assert_eq!(t.without, 0, "{name} f64: rows without a level");
            }
        }
    }
}
