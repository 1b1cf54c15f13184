//! The search for a tumble's start rate: Nelder–Mead on the cost, in stages over the window,
//! from several starts whose distinct ends are the candidates.

use super::Sets;
use crate::linalg::Vec3;

/// The shortest stage of the search, s (a 5 s window of the `orbit-identify` tumble left Ω0
/// too loose to determine the geometry; 10 s did).
pub(super) const MIN_STAGE_S: f64 = 5.0;

/// Nelder–Mead iterations per round, at most.
pub(super) const ITERATIONS: usize = 200;

/// The three rounds' initial simplex steps, as fractions of `|Ω0|`.
pub(super) const STEPS: [f64; 3] = [0.05, 0.01, 0.002];

/// The continuation's stages over the window of `sets`: its first quarter, half, then all of
/// it, as many as keep every stage at least [`MIN_STAGE_S`] long; the last is the whole window
/// (infinite). Returns the spans and how many are used.
pub(super) fn stage_spans<S: Sets + ?Sized>(sets: &S) -> ([f64; 3], usize) {
    let (mut t_first, mut t_last) = (f64::NAN, f64::NAN);
    sets.for_each(&mut |t, _| {
        if t_first.is_nan() {
            t_first = t;
        }
        t_last = t;
    });
    let total = t_last - t_first;
    let mut spans = [f64::INFINITY; 3];
    let mut stages = 1;
    while stages < spans.len() && total / (1u32 << stages) as f64 >= MIN_STAGE_S {
        stages += 1;
    }
    for (k, span) in spans.iter_mut().take(stages).enumerate() {
        *span = total / (1u32 << (stages - 1 - k)) as f64;
    }
    spans[stages - 1] = f64::INFINITY;
    (spans, stages)
}

/// The candidates worth going on with, moved to the front: one of each pair the same motion
/// (`same`), then those at the noise (whitened cost within `at_noise`) if any is, else the
/// cheapest alone (`best` if none has a cost). Returns how many.
pub(super) fn distinct_candidates(
    candidates: &mut [(Vec3<f64>, f64); 4],
    same: &dyn Fn(&Vec3<f64>, &Vec3<f64>) -> bool,
    at_noise: f64,
    best: Vec3<f64>,
) -> usize {
    let mut kept = 0;
    for i in 0..candidates.len() {
        if !(0..kept).any(|j| same(&candidates[j].0, &candidates[i].0)) {
            candidates[kept] = candidates[i];
            kept += 1;
        }
    }
    // If any candidate is at the noise, only those go on.
    if candidates[..kept].iter().any(|c| c.1 <= at_noise) {
        let mut n = 0;
        for i in 0..kept {
            if candidates[i].1 <= at_noise {
                candidates[n] = candidates[i];
                n += 1;
            }
        }
        kept = n;
    } else {
        // Else the cheapest alone.
        let cheapest = candidates[..kept]
            .iter()
            .copied()
            .fold((best, f64::INFINITY), |a, c| if c.1 < a.1 { c } else { a });
        candidates[0] = cheapest;
        kept = 1;
    }
    kept
}

/// Nelder–Mead over three variables from `x0` with an initial simplex of `step` along each
/// axis, at most [`ITERATIONS`] iterations (fewer once the simplex has shrunk to 10⁻⁶ of
/// `step`); returns the best vertex.
pub(super) fn nelder_mead(
    f: &mut dyn FnMut(&Vec3<f64>) -> f64,
    x0: Vec3<f64>,
    step: f64,
) -> Vec3<f64> {
    let mut pts = [(x0, 0.0); 4];
    for (i, p) in pts.iter_mut().enumerate() {
        if i > 0 {
            p.0[i - 1] += step;
        }
        p.1 = f(&p.0);
    }
    let order = |pts: &mut [(Vec3<f64>, f64); 4]| {
        // Insertion sort by cost, infinities last (four vertices).
        for i in 1..4 {
            let mut k = i;
            while k > 0 && pts[k].1 < pts[k - 1].1 {
                pts.swap(k, k - 1);
                k -= 1;
            }
        }
    };
    for _ in 0..ITERATIONS {
        order(&mut pts);
        // Settled: the simplex has shrunk to 10⁻⁶ of its first size.
        let spread = pts[1..]
            .iter()
            .flat_map(|p| (0..3).map(move |k| (p.0[k] - pts[0].0[k]).abs()))
            .fold(0.0, f64::max);
        if spread < 1e-6 * step {
            break;
        }
        let c: Vec3<f64> =
            core::array::from_fn(|k| (pts[0].0[k] + pts[1].0[k] + pts[2].0[k]) / 3.0);
        let along = |s: f64, worst: &Vec3<f64>| -> Vec3<f64> {
            core::array::from_fn(|k| c[k] + s * (worst[k] - c[k]))
        };
        let worst = pts[3].0;
        let xr = along(-1.0, &worst);
        let fr = f(&xr);
        if fr < pts[0].1 {
            let xe = along(-2.0, &worst);
            let fe = f(&xe);
            pts[3] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < pts[2].1 {
            pts[3] = (xr, fr);
        } else {
            let xc = along(0.5, &worst);
            let fc = f(&xc);
            if fc < pts[3].1 {
                pts[3] = (xc, fc);
            } else {
                let b = pts[0].0;
                for p in pts.iter_mut().skip(1) {
                    p.0 = core::array::from_fn(|k| b[k] + 0.5 * (p.0[k] - b[k]));
                    p.1 = f(&p.0);
                }
            }
        }
    }
    order(&mut pts);
    pts[0].0
}
