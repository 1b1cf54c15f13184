//! The per-sample solve of one frame: `y = W p` (paper eq. 11 reduced by the SVD, whitening
//! folded in), the `a` solve of the `m` null-space equations (Kelvin's decomposition in model G,
//! the closed form for m = 3, Gauss–Newton for m > 3, the least-squares fallback), and
//! `x = y_lin − ε [aᵀ T_j a]` for each branch.

use super::{Branch, Config, Sample, Scratch};
use crate::arrangement::ChannelMask;
use crate::linalg::{norm2, Sym3, Vec3};
use crate::quadratic::{
    canonical_sign, closed_form, gauss_newton, rank_one_factor, refine, residual2, MAX_ROOTS,
};
use crate::real::Real;
use crate::tracker::MAX_CANDIDATES;

/// Most predictions used as Gauss–Newton starts (m > 3); with redundancy the global optimum
/// is unique and the cheapest hypotheses' predictions find it.
pub(super) const MAX_STARTS: usize = 2;

/// Gauss–Newton iterations per start (m > 3).
pub(super) const GN_ITERATIONS: usize = 6;

/// Where [`Config::refined_roots`] puts the roots it finds, their residuals and `JᵀJ`, and
/// which roots it refined.
struct Found<'a, T> {
    roots: &'a mut [Vec3<T>; MAX_CANDIDATES],
    fit: &'a mut [T; MAX_CANDIDATES],
    jtj: &'a mut [Sym3<T>; MAX_CANDIDATES],
    refined: &'a mut [bool; MAX_CANDIDATES],
}

impl<T: Real, const CAP: usize> Config<T, CAP> {
    /// The candidate branches in frame `f`; returns their number and whether the fallback
    /// (least squares without an exact real solution) was used.
    pub(super) fn solve_frame(
        &self,
        f: usize,
        sample: &Sample<'_, T>,
        eps: T,
        scratch: &mut Scratch<T, CAP>,
        out: &mut [Branch<T>; MAX_CANDIDATES],
    ) -> (usize, bool, T) {
        let Sample { p, dt, tracker } = *sample;
        let pr = &self.proj[f];
        let (k, m) = (pr.k, pr.m);
        let n = self.arr.len();
        // y = W p (paper eq. 11 reduced by the SVD), minus the channels' biases and the
        // known-Γ term of model F.
        let y = &mut scratch.y;
        let rows = k + m;
        project(&pr.wt, p, n, rows, y);
        if pr.has_bias_offset {
            for (yr, o) in y.iter_mut().zip(pr.bias_offset.iter()).take(rows) {
                *yr -= *o;
            }
        }
        if self.gamma_offset_nonzero {
            for (yr, g) in y.iter_mut().zip(self.gamma_offset.iter()).take(rows) {
                *yr -= *g;
            }
        }
        let pe = &mut scratch.pe;
        let forms = &pr.mq[..m];
        let roots = &mut scratch.roots;
        // Roots from `refine` carry their residual and JᵀJ in `scratch`.
        let mut refined = [false; MAX_CANDIDATES];
        let mut nr = 0;
        let mut eps = eps;
        if pr.has_lin_o {
            // Model G: the null-space equations are linear in the off-diagonals of A (frame V);
            // Kelvin's decomposition gives a and ε. One branch (±a), no iteration.
            if let Some((a, e)) = kelvin_root(pr, &y[k..k + m]) {
                eps = e;
                roots[0] = a;
                nr = 1;
            }
        }
        for e in 0..m {
            pe[e] = eps * y[k + e];
        }
        let rhs = &pe[..m];
        if nr > 0 {
            // Solved above.
        } else if m == 3 {
            let m3 = [pr.mq[0], pr.mq[1], pr.mq[2]];
            let p3 = [pe[0], pe[1], pe[2]];
            let mut cf = [[T::ZERO; 3]; MAX_ROOTS];
            nr = closed_form(&m3, &p3, &mut cf);
            roots[..nr].copy_from_slice(&cf[..nr]);
        } else {
            let found = Found {
                roots: &mut *roots,
                fit: &mut scratch.fit,
                jtj: &mut scratch.jtj,
                refined: &mut refined,
            };
            nr = self.refined_roots(f, sample, &pe[..m], &mut scratch.starts, found);
        }
        let mut fallback = false;
        if nr == 0 {
            // No real solution (noise at low rate): least squares from the prediction or a
            // start of the right size.
            fallback = true;
            roots[0] = self.fallback_root(f, forms, rhs, tracker.predicted_omega(dt));
            nr = 1;
        }
        for (i, (b, a)) in out.iter_mut().zip(roots.iter()).take(nr).enumerate() {
            b.a = *a;
            linear_unknowns(pr, y, eps, a, &mut b.x);
            if refined[i] {
                b.fit = scratch.fit[i];
                let Sym3(j) = &scratch.jtj[i];
                b.jtj = Some(Sym3([j[0], j[1], j[2], j[3], j[4], j[5]]));
            } else {
                b.fit = residual2(forms, rhs, a);
                b.jtj = None;
            }
            b.ill = false;
        }
        (nr, fallback, eps)
    }

    /// m > 3: the roots by Gauss–Newton from the best start (the prediction, else the hint,
    /// else the linear `S = a aᵀ` solve), and from the others only where its residual fails
    /// the χ² gate; each root with its residual and `JᵀJ` (`found`). Returns their number.
    fn refined_roots(
        &self,
        f: usize,
        sample: &Sample<'_, T>,
        pe: &[T],
        starts: &mut [Vec3<T>; MAX_STARTS + MAX_ROOTS + 2],
        found: Found<'_, T>,
    ) -> usize {
        let Sample { dt, tracker, .. } = *sample;
        let pr = &self.proj[f];
        let m = pr.m;
        let forms = &pr.mq[..m];
        let rhs = pe;
        let mut nr = 0;
        // One Gauss–Newton run from the best start (the prediction, else the hint, else the
        // linear S = a aᵀ solve) normally suffices: with redundancy the optimum is unique.
        // Only if its residual fails the χ² gate are the other hypotheses' predictions and
        // the linear solve tried as well.
        let mut ns = 0;
        // The chosen hypothesis' prediction first; the others' only if it fails the gate.
        let best_pred = tracker.predicted_omega(dt);
        if let Some(w) = &best_pred {
            starts[ns] = self.a_from_omega(f, w);
            ns += 1;
        }
        if !tracker.has_history() {
            if let Some(h) = self.options.initial_omega {
                starts[ns] = self.a_from_omega(f, &[T::of(h[0]), T::of(h[1]), T::of(h[2])]);
                ns += 1;
            }
        }
        let lin_start = || {
            if !pr.has_lin_s {
                return None;
            }
            let mut s6 = [T::ZERO; 6];
            for (c, s) in s6.iter_mut().enumerate() {
                let mut acc = T::ZERO;
                for e in 0..m {
                    acc += pr.lin_s[c][e] * pe[e];
                }
                *s = acc;
            }
            Some(rank_one_factor(&Sym3(s6))).filter(|a| norm2(a) > T::ZERO)
        };
        // The linear start only when there is no prediction (it is added below otherwise,
        // if the prediction's solution fails the gate).
        let mut lin_tried = ns == 0;
        if ns == 0 {
            if let Some(a0) = lin_start() {
                starts[ns] = a0;
                ns += 1;
            }
        }
        if ns == 0 {
            // No prediction and no linear start: closed form on the first three equations.
            let m3 = [pr.mq[0], pr.mq[1], pr.mq[2]];
            let p3 = [pe[0], pe[1], pe[2]];
            let mut cf = [[T::ZERO; 3]; MAX_ROOTS];
            let nc = closed_form(&m3, &p3, &mut cf);
            for a in cf.iter().take(nc) {
                starts[ns] = *a;
                ns += 1;
            }
        }
        let mut i = 0;
        while i < ns {
            let sol = refine(forms, rhs, &starts[i], GN_ITERATIONS);
            let (mut a, res) = (sol.a, sol.fit);
            canonical_sign(&mut a);
            let dup = found.roots[..nr].iter().any(|b| {
                norm2(&crate::linalg::sub(&a, b)) <= T::of(1e-6) * norm2(&a).max(T::EPSILON)
            });
            if !dup && nr < MAX_CANDIDATES && crate::linalg::all_finite(&a) {
                found.roots[nr] = a;
                found.fit[nr] = res;
                found.jtj[nr] = sol.jtj;
                found.refined[nr] = true;
                nr += 1;
            }
            if i == 0 && res <= pr.chi2_gate {
                break;
            }
            if i == 0 {
                if let Some(w0) = best_pred {
                    let mut preds = [[T::ZERO; 3]; MAX_CANDIDATES];
                    let np = tracker.predictions(dt, &mut preds);
                    let mut added = 0;
                    for w in preds.iter().take(np) {
                        if *w != w0 && added + 1 < MAX_STARTS {
                            starts[ns] = self.a_from_omega(f, w);
                            ns += 1;
                            added += 1;
                        }
                    }
                }
            }
            if !lin_tried && i + 1 == ns {
                lin_tried = true;
                if let Some(a0) = lin_start() {
                    starts[ns] = a0;
                    ns += 1;
                }
            }
            i += 1;
        }
        nr
    }

    /// No real solution (noise at low rate): least squares from the `predicted` rate, or from
    /// a start of the right size.
    fn fallback_root(
        &self,
        f: usize,
        forms: &[Sym3<T>],
        rhs: &[T],
        predicted: Option<crate::linalg::Vec3<T>>,
    ) -> crate::linalg::Vec3<T> {
        let m = forms.len();
        let start = match predicted {
            Some(w) if norm2(&w) > T::ZERO => self.a_from_omega(f, &w),
            _ => {
                let mut big = T::ZERO;
                let mut mnorm = T::ZERO;
                for e in 0..m {
                    big = big.max(rhs[e].abs());
                    mnorm = mnorm.max(forms[e].0.iter().fold(T::ZERO, |a, v| a.max(v.abs())));
                }
                let r = if mnorm > T::ZERO {
                    (big / mnorm).sqrt()
                } else {
                    T::ZERO
                };
                let c = r * T::of(0.577_350_269_189_625_8);
                [c, c, c]
            }
        };
        let (mut a, _) = gauss_newton(forms, rhs, &start, 2 * GN_ITERATIONS);
        if !a.iter().all(|v| v.is_finite()) {
            a = [T::ZERO; 3];
        }
        a
    }
}

/// True if `p` has `n` readings and every included one is finite. One test for the common
/// case (`x·0` is ±0 for finite `x`, NaN otherwise); the mask is consulted only if it fails
/// (a non-finite reading of an excluded channel is allowed).
pub(super) fn readings_usable<T: Real>(p: &[T], n: usize, mask: ChannelMask) -> bool {
    let Some(p) = p.get(..n) else {
        return false;
    };
    crate::linalg::all_finite(p)
        || p.iter()
            .enumerate()
            .all(|(i, v)| v.is_finite() || !mask.contains(i))
}

/// Rows of `W p` accumulated together in [`project`] (in registers on the target).
pub(super) const PROJECT_CHUNK: usize = 12;

/// `y = W p` for the first `rows` rows, `W` stored by channel (`wt[i]` = column `i`): up to
/// [`PROJECT_CHUNK`] rows at a time, each reading loaded once per chunk and its coefficients
/// contiguous (rows past `rows` are zero in `wt` and discarded).
pub(super) fn project<T: Real, const CAP: usize>(
    wt: &[[T; CAP]; CAP],
    p: &[T],
    n: usize,
    rows: usize,
    y: &mut [T; CAP],
) {
    let n = n.min(p.len());
    let (p, wt) = (&p[..n], &wt[..n]);
    let rows = rows.min(CAP);
    let mut r0 = 0;
    while r0 + PROJECT_CHUNK <= CAP && r0 < rows {
        let mut acc = [T::ZERO; PROJECT_CHUNK];
        for (col, &pi) in wt.iter().zip(p.iter()) {
            let c = &col[r0..r0 + PROJECT_CHUNK];
            for (a, w) in acc.iter_mut().zip(c.iter()) {
                *a += *w * pi;
            }
        }
        let end = (r0 + PROJECT_CHUNK).min(rows);
        y[r0..end].copy_from_slice(&acc[..end - r0]);
        r0 += PROJECT_CHUNK;
    }
    for (r, yr) in y.iter_mut().enumerate().take(rows).skip(r0) {
        let mut acc = T::ZERO;
        for (col, &pi) in wt.iter().zip(p.iter()) {
            acc += col[r] * pi;
        }
        *yr = acc;
    }
}

/// Model G's root: the null-space equations are linear in the off-diagonals of A (frame V);
/// Kelvin's decomposition of them gives `a` and ε (`y_null`: the null-space rows of `y`).
fn kelvin_root<T: Real, const CAP: usize>(
    pr: &crate::internals::design::Projection<T, CAP>,
    y_null: &[T],
) -> Option<(crate::linalg::Vec3<T>, T)> {
    let mut o = [T::ZERO; 3];
    for (c, oc) in o.iter_mut().enumerate() {
        let mut acc = T::ZERO;
        for (l, ye) in pr.lin_o[c].iter().zip(y_null) {
            acc += *l * *ye;
        }
        *oc = acc;
    }
    crate::quadratic::kelvin(&o)
}

/// The linear unknowns of a branch `a`: `x = y − ε G⁺ q(a)` (paper eq. 11), `aᵀ T_j a` per
/// unknown.
#[inline]
fn linear_unknowns<T: Real, const CAP: usize>(
    pr: &crate::internals::design::Projection<T, CAP>,
    y: &[T; CAP],
    eps: T,
    a: &crate::linalg::Vec3<T>,
    x: &mut [T; 9],
) {
    // x = y − ε G⁺ q(a) (paper eq. 11): `aᵀ T_j a` per linear unknown.
    if pr.tq_diag_known {
        // Model G: only the off-diagonals are read (`design::tq_structured`): 27
        // multiply-adds fewer per root than the full forms, and model G's estimate
        // 64 instructions cheaper on the M4F (`cargo qemu-bench`).
        let two_eps = eps + eps;
        let o = [a[0] * a[1], a[0] * a[2], a[1] * a[2]];
        let sq = [a[0] * a[0], a[1] * a[1], a[2] * a[2]];
        let a2 = sq[0] + sq[1] + sq[2];
        for j in 0..pr.k {
            let t = &pr.tq[j].0;
            x[j] = y[j] - two_eps * (t[3] * o[0] + t[4] * o[1] + t[5] * o[2]);
        }
        for c in 0..3 {
            x[6 + c] -= eps * (sq[c] - a2);
        }
    } else {
        let o = crate::linalg::outer6(a);
        for j in 0..pr.k {
            x[j] = y[j] - eps * pr.tq[j].quad_outer(&o);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn readings_usable_only_when_every_included_reading_is_finite() {
        let all = ChannelMask::all(4);
        assert!(readings_usable(&[1.0f32, -0.0, 3.0, 1e30], 4, all));
        assert!(!readings_usable(&[1.0f32, 2.0, 3.0], 4, all), "too few");
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let p = [1.0f32, bad, 3.0, 4.0];
            assert!(!readings_usable(&p, 4, all));
            // Channel 1 excluded: its reading does not matter.
            assert!(readings_usable(&p, 4, all.without(1)));
            assert!(!readings_usable(&p, 4, all.without(2)));
        }
        // Readings past n are not looked at.
        assert!(readings_usable(
            &[1.0f32, 2.0, f32::NAN],
            2,
            ChannelMask::all(2)
        ));
    }

    /// `project` equals the plain product for every row count (chunks and remainder).
    #[test]
    fn project_equals_the_plain_product() {
        const CAP: usize = 32;
        let mut wt = [[0.0f64; CAP]; CAP];
        for (i, col) in wt.iter_mut().enumerate() {
            for (r, w) in col.iter_mut().enumerate() {
                *w = ((i * 7 + r * 13) % 17) as f64 - 8.0 + 0.1 * r as f64;
            }
        }
        let p: Vec<f64> = (0..CAP).map(|i| 0.3 * i as f64 - 2.0).collect();
        for n in [1, 5, 12, 20, 32] {
            for rows in [1, 4, 11, 12, 13, 24, 25, 32] {
                // Rows past `rows` must not leak into y: fill y with a marker.
                let mut y = [7.5f64; CAP];
                project(&wt, &p, n, rows, &mut y);
                for r in 0..CAP {
                    let want = if r < rows {
                        (0..n).map(|i| wt[i][r] * p[i]).sum::<f64>()
                    } else {
                        7.5
                    };
                    assert!((y[r] - want).abs() < 1e-9, "n {n} rows {rows} r {r}");
                }
            }
        }
    }
}
