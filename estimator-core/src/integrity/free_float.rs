//! Protection levels of model F (free float, `A = Γ + {Ω}²` with `Γ` known): the argument of
//! model G ([`super`]) on the model linearised at the row's estimate. A channel reads
//! `s·σ0 + (R × s)·Ω′ + s·{Ω}²R` (+ `s·Γ R`, known), and `s·{Ω}²R = (s·Ω)(Ω·R) − |Ω|²(s·R)` has
//! the gradient `(Ω·R) s + (s·Ω) R − 2 (s·R) Ω` in Ω: nine unknowns, `ν = N − 9` parity
//! degrees of freedom, a design `H = [H₆ | H_Ω]` whose last three columns move with Ω.
//!
//! So the gains are computed at every row, in the estimator's precision, by blocks: `H₆` (σ0,
//! Ω′) is the channel set's, so `G₆ = (H₆ᵀH₆)⁻¹` and each row's `G₆ a_r` are computed at
//! configuration; per row only `B = H₆ᵀH_Ω`, `C = H_ΩᵀH_Ω`, `E = G₆ B` and the Schur complement
//! `S = C − Bᵀ E` (3 × 3) are, and each reading's gain `k_r = (HᵀH)⁻¹ h_r` follows as
//! `k_Ω = S⁻¹ (b_r − Eᵀ a_r)`, `k₆ = G₆ a_r − E k_Ω` (`h_r = [a_r, b_r]`). A part's slope for
//! an output `x` is bounded by the Frobenius norm of `K_{x,S} R_S`, whose square is
//! `tr(K_{x,S} P_SS⁻¹ K_{x,S}ᵀ)` (`R_S R_Sᵀ = P_SS⁻¹`): at most √3 above the largest singular
//! value. Measured under QEMU (Cortex-M4F, N = 12, f32): the Cholesky of the whole 9 × 9
//! normal matrix per row cost 18 000 instructions; these blocks a fraction of it
//! (`docs/validation.md`).
//!
//! The linearisation holds where the fault's effect is small against Ω's own scale: a fault
//! that carries the estimate to another root (the mirror, or another branch) is covered as in
//! model G, by the `2|Ω|` the level adds while the sign or the branch is in doubt. With Ω
//! zero (`S` singular: Ω's columns vanish) or where one part's fault can hide from the parity
//! space (`P_SS` singular), there is no level at that row.

use super::{Groups, UNBOUNDED};
use crate::arrangement::{Arrangement, ChannelMask};
use crate::estimate::Estimate;
use crate::identify::cholesky::{cholesky, cholesky_solve, invert_spd};
use crate::linalg::{cross, dot, Sym3, Vec3};
use crate::real::Real;

/// Unknowns of the linearised model F: σ0, Ω′ (the fixed block), δΩ.
const UNKNOWNS: usize = 9;
const FIXED: usize = 6;

/// What model F's levels need of the channel set.
#[derive(Clone, Debug)]
pub struct FreeFloatIntegrity<T, const CAP: usize> {
    /// Per row in the solve: `a_r = [s, R × s]/σ` (σ its noise).
    fixed: [[T; FIXED]; CAP],
    /// Per row: `G₆ a_r`.
    gain: [[T; FIXED]; CAP],
    /// Per row: `R` and `(s·R)/σ`.
    arm: [Vec3<T>; CAP],
    along: [T; CAP],
    /// `G₆ = (H₆ᵀH₆)⁻¹`.
    g6: [[T; FIXED]; FIXED],
    rows: usize,
    groups: Groups<CAP>,
    /// `√χ²_ν` at `1 − β/2`.
    parity_noise: T,
    /// The two-sided normal point at `β/2`.
    free: T,
}

impl<T: Real, const CAP: usize> FreeFloatIntegrity<T, CAP> {
    /// What the levels of the channels of `mask` in `arr` need, at missed probability
    /// `missed`; `None` without redundancy (`N ≤ 9`), with a part of more than three channels,
    /// or where σ0 and Ω′ alone are not observable. Configuration time, f64.
    pub fn build(arr: &Arrangement<CAP>, mask: ChannelMask, missed: f64) -> Option<Self> {
        let mut idx = [0usize; CAP];
        let mut rows = 0;
        for i in (0..arr.len()).filter(|i| mask.contains(*i)) {
            idx[rows] = i;
            rows += 1;
        }
        if rows <= UNKNOWNS {
            return None;
        }
        let (parity_noise, free) = super::points(rows - UNKNOWNS, missed)?;
        let groups = Groups::of(arr, &idx[..rows])?;
        let mut fixed = [[0.0f64; FIXED]; CAP];
        let mut n6 = [[0.0f64; FIXED]; FIXED];
        for (r, &i) in idx[..rows].iter().enumerate() {
            let ch = &arr.channels()[i];
            let m = cross(&ch.position, &ch.axis);
            for k in 0..3 {
                fixed[r][k] = ch.axis[k] / ch.noise;
                fixed[r][3 + k] = m[k] / ch.noise;
            }
            for a in 0..FIXED {
                for b in 0..FIXED {
                    n6[a][b] += fixed[r][a] * fixed[r][b];
                }
            }
        }
        let g6 = invert_spd(&n6)?;
        let mut out = FreeFloatIntegrity {
            fixed: [[T::ZERO; FIXED]; CAP],
            gain: [[T::ZERO; FIXED]; CAP],
            arm: [[T::ZERO; 3]; CAP],
            along: [T::ZERO; CAP],
            g6: g6.map(|row| row.map(T::of)),
            rows,
            groups,
            parity_noise: T::of(parity_noise),
            free: T::of(free),
        };
        for (r, &i) in idx[..rows].iter().enumerate() {
            let ch = &arr.channels()[i];
            out.fixed[r] = fixed[r].map(T::of);
            out.gain[r] =
                core::array::from_fn(|a| T::of((0..FIXED).map(|b| g6[a][b] * fixed[r][b]).sum()));
            out.arm[r] = ch.position.map(T::of);
            out.along[r] = T::of(dot(&ch.axis, &ch.position) / ch.noise);
        }
        Some(out)
    }

    /// The levels `[σ0 (m/s²), Ω′ (rad/s²), Ω (rad/s)]` of estimate `e`, linearised at its Ω;
    /// `None` where the row gives none (Ω's columns vanish at rest, or a part's fault can hide).
    pub fn levels(&self, e: &Estimate<T>) -> Option<[T; 3]> {
        let (k, omega) = self.gains(&e.omega)?;
        let mut slope = [T::ZERO; 3];
        for g in 0..self.groups.parts {
            let s = self.groups.rows(g);
            // P_SS = I − h_a·k_b (symmetric), padded with the identity.
            let mut pss = Sym3([T::ONE, T::ONE, T::ONE, T::ZERO, T::ZERO, T::ZERO]);
            let at = |a: usize, b: usize| match (a, b) {
                (0, 0) => 0,
                (1, 1) => 1,
                (2, 2) => 2,
                (0, 1) | (1, 0) => 3,
                (0, 2) | (2, 0) => 4,
                _ => 5,
            };
            for a in 0..s.len() {
                for b in a..s.len() {
                    let (ra, rb) = (s[a], s[b]);
                    let mut hk = T::ZERO;
                    for c in 0..FIXED {
                        hk += self.fixed[ra][c] * k[rb][c];
                    }
                    for c in 0..3 {
                        hk += omega[ra][c] * k[rb][FIXED + c];
                    }
                    pss.0[at(a, b)] = (if a == b { T::ONE } else { T::ZERO }) - hk;
                }
            }
            // P_SS's eigenvalues lie in [0, 1]. A part whose fault can hide has one at zero; a
            // nearly dependent one has a small one and a large slope, which is a bound (an
            // absolute threshold on the determinant, 10⁻⁶, refused 29 % of the rows of random
            // layouts whose parts are checked poorly but surely). Its entries are rounded by
            // about ε each (`I − h·k`, gains of order one): `P_SS − 16 ε I` is inverted instead,
            // a slope that covers the rounding, and a part where that is not positive definite
            // has no bound at this row.
            let mut full = pss.to_mat();
            for (i, row) in full.iter_mut().enumerate() {
                row[i] -= T::of(16.0) * T::EPSILON;
            }
            let m = spd_inverse(&full)?; // tr(K_{x,S} M K_{x,S}ᵀ) per output x.
            let mut sq = [T::ZERO; 3];
            for c in 0..UNKNOWNS {
                let mut v = [T::ZERO; 3];
                for (j, &r) in s.iter().enumerate() {
                    v[j] = k[r][c];
                }
                sq[c / 3] += m.quad(&v);
            }
            for (sl, q) in slope.iter_mut().zip(sq) {
                if !(q >= T::ZERO) {
                    return None;
                }
                *sl = sl.max(q.sqrt());
            }
        }
        let chi = if e.chi2 > T::ZERO {
            e.chi2.sqrt()
        } else {
            T::ZERO
        };
        let c = chi + self.parity_noise;
        let level = |sd: &Vec3<T>, slope: T| {
            let v = self.free * dot(sd, sd).sqrt() + slope * c;
            if v.is_finite() {
                v.min(T::of(UNBOUNDED))
            } else {
                T::of(UNBOUNDED)
            }
        };
        Some([
            level(&e.sd_sigma0, slope[0]),
            level(&e.sd_domega, slope[1]),
            level(&e.sd_omega, slope[2]),
        ])
    }

    /// Row `r`'s Ω columns at `w`: `((w·R) s + (s·w) R − 2 (s·R) w)/σ`.
    #[inline]
    fn omega_column(&self, r: usize, w: &Vec3<T>) -> Vec3<T> {
        let s = [self.fixed[r][0], self.fixed[r][1], self.fixed[r][2]];
        let (wr, sw) = (dot(w, &self.arm[r]), dot(&s, w));
        let two_sr = T::of(2.0) * self.along[r];
        core::array::from_fn(|k| wr * s[k] + sw * self.arm[r][k] - two_sr * w[k])
    }

    /// Each reading's gain `k_r = (HᵀH)⁻¹ h_r` at `w` (module doc: by blocks) and its Ω
    /// columns; `None` where Ω is not observable to first order (at rest).
    #[allow(clippy::type_complexity)]
    fn gains(&self, w: &Vec3<T>) -> Option<([[T; UNKNOWNS]; CAP], [Vec3<T>; CAP])> {
        let n = self.rows;
        let mut b = [[T::ZERO; 3]; FIXED];
        let mut c = Sym3::zero();
        let mut omega = [[T::ZERO; 3]; CAP];
        for r in 0..n {
            let h = self.omega_column(r, w);
            omega[r] = h;
            for a in 0..FIXED {
                for (bj, hj) in b[a].iter_mut().zip(h) {
                    *bj += self.fixed[r][a] * hj;
                }
            }
            c.0[0] += h[0] * h[0];
            c.0[1] += h[1] * h[1];
            c.0[2] += h[2] * h[2];
            c.0[3] += h[0] * h[1];
            c.0[4] += h[0] * h[2];
            c.0[5] += h[1] * h[2];
        }
        // E = G₆ B, S = C − Bᵀ E.
        let mut e = [[T::ZERO; 3]; FIXED];
        for (a, ea) in e.iter_mut().enumerate() {
            for (j, x) in ea.iter_mut().enumerate() {
                for (g, br) in self.g6[a].iter().zip(b.iter()) {
                    *x += *g * br[j];
                }
            }
        }
        let mut schur = c;
        for (slot, (i, j)) in [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)]
            .into_iter()
            .enumerate()
        {
            for a in 0..FIXED {
                schur.0[slot] -= b[a][i] * e[a][j];
            }
        }
        // Ω observable to first order: S's determinant against C's scale (at rest both
        // vanish; in f32 the subtraction leaves ~10⁻⁴ of C).
        let scale = (c.0[0] + c.0[1] + c.0[2]) * T::of(1.0 / 3.0);
        let tiny = T::of(1e-12) * scale * scale * scale;
        if !(scale > T::ZERO) {
            return None;
        }
        let s_inv = schur.inverse(tiny)?;
        let mut k = [[T::ZERO; UNKNOWNS]; CAP];
        for r in 0..n {
            let mut u = omega[r];
            for a in 0..FIXED {
                for (j, uj) in u.iter_mut().enumerate() {
                    *uj -= e[a][j] * self.fixed[r][a];
                }
            }
            let kw = s_inv.mul_vec(&u);
            for a in 0..FIXED {
                k[r][a] = self.gain[r][a] - (e[a][0] * kw[0] + e[a][1] * kw[1] + e[a][2] * kw[2]);
            }
            k[r][FIXED..].copy_from_slice(&kw);
        }
        Some((k, omega))
    }
}

/// The inverse of a symmetric positive definite 3 × 3 matrix in the estimator's precision;
/// `None` unless its Cholesky factor exists.
fn spd_inverse<T: Real>(a: &[[T; 3]; 3]) -> Option<Sym3<T>> {
    let mut l = *a;
    if !cholesky(&mut l, 3) {
        return None;
    }
    let col = |c: usize| {
        let mut e = [T::ZERO; 3];
        e[c] = T::ONE;
        cholesky_solve(&l, 3, &e)
    };
    let (x, y, z) = (col(0), col(1), col(2));
    Some(Sym3([x[0], y[1], z[2], x[1], x[2], y[2]]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Estimator, Model};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    // The layout, readings and options of model G's tests: six tri-axial parts (N = 18,
    // ν = 9 in model F), noise 1 mg; noise-free readings of a rigid body (Γ = 0).
    use super::super::tests::{dist, layout, raw as options, readings};

    /// A fault on one part moves σ0, Ω′ and Ω by no more than the slope (linearised at the
    /// fault-free Ω) times `√χ²` (noise-free: `χ²` is `|P b|²`), up to the model's curvature
    /// at 30 σ; and the bound is not loose (a Frobenius norm: at most √3 above the exact
    /// gain).
    #[test]
    fn a_fault_of_one_part_moves_each_output_by_at_most_its_slope_times_the_residual() {
        let arr = layout();
        let ff = FreeFloatIntegrity::<f64, 24>::build(&arr, ChannelMask::all(18), 1e-3).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let (s0, dw, w) = ([1e-4, -2e-4, 5e-5], [0.5, 0.2, -1.0], [1.0, -0.5, 2.0]);
        let clean = readings(&arr, s0, dw, w);
        let mut est = Estimator::<f64, 24>::new(&arr, Model::FreeFloat, options()).unwrap();
        let base = *est.update(0.0, &clean);
        assert!(base.chi2 < 1e-12, "noise-free χ² {}", base.chi2);
        // The slopes at the fault-free Ω: levels with no deviation and no residual, over the
        // parity noise.
        let mut only = base;
        only.chi2 = 0.0;
        only.sd_sigma0 = [0.0; 3];
        only.sd_domega = [0.0; 3];
        only.sd_omega = [0.0; 3];
        let slope = ff.levels(&only).unwrap().map(|l| l / ff.parity_noise);
        let mut worst = [0.0f64; 3];
        for k in 0..600 {
            let part = k % 6;
            let mut p = clean;
            let size = 1e-3 * rng.gen_range(3.0..30.0);
            let dir: [f64; 3] = core::array::from_fn(|_| rng.gen_range(-1.0..1.0));
            let n = dir.iter().map(|x| x * x).sum::<f64>().sqrt();
            for a in 0..3 {
                p[3 * part + a] += size * dir[a] / n;
            }
            let mut est = Estimator::<f64, 24>::new(&arr, Model::FreeFloat, options()).unwrap();
            let e = *est.update(0.0, &p);
            let chi = e.chi2.sqrt();
            let moved = [
                dist(&e.sigma0, &base.sigma0),
                dist(&e.domega, &base.domega),
                dist(&e.omega, &base.omega),
            ];
            for q in 0..3 {
                let ratio = moved[q] / (slope[q] * chi);
                assert!(ratio <= 1.02, "output {q}, part {part}: {ratio}");
                worst[q] = worst[q].max(ratio);
            }
        }
        println!("model F, largest share of the bound reached: {worst:?}");
        assert!(
            worst.iter().all(|w| *w > 0.5),
            "worst share of the bound {worst:?}"
        );
    }

    /// With noise and a fault of random size (0–30 σ) on a random part, in f64 and in the
    /// unit's f32, each output's error is below its level on at least 99.9 % of rows, and
    /// every solved row has a level.
    #[test]
    fn errors_stay_below_the_levels_with_a_fault_of_any_size_in_f64_and_f32() {
        fn run<T: Real>(seed: u64) -> ([usize; 3], usize, [f64; 3]) {
            let arr = layout();
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let mut est = Estimator::<T, 24>::new(&arr, Model::FreeFloat, options()).unwrap();
            let (s0, dw, w0) = ([1e-4, -2e-4, 5e-5], [0.02, 0.01, -0.01], [1.0, -0.5, 2.0]);
            let rows = 10_000;
            let mut above = [0usize; 3];
            let mut mean = [0.0f64; 3];
            for k in 0..rows {
                let t = k as f64 * 0.01;
                let w = [0, 1, 2].map(|i| w0[i] + dw[i] * t);
                let mut p = readings(&arr, s0, dw, w);
                for x in p.iter_mut() {
                    let (u1, u2): (f64, f64) = (rng.gen_range(1e-12..1.0), rng.gen());
                    *x += 1e-3 * (-2.0 * u1.ln()).sqrt() * (2.0 * core::f64::consts::PI * u2).cos();
                }
                let part = rng.gen_range(0..6);
                let size = 1e-3 * rng.gen_range(0.0..30.0);
                for a in 0..3 {
                    p[3 * part + a] += size * rng.gen_range(-1.0..1.0);
                }
                let pt: [T; 18] = p.map(T::of);
                let e = *est.update(t, &pt);
                let pl = e.protection.expect("a level on every solved row");
                let out = [e.sigma0, e.domega, e.omega];
                let truth = [s0, dw, w];
                for q in 0..3 {
                    let o = out[q].map(|v| v.to_f64());
                    above[q] += usize::from(dist(&o, &truth[q]) > pl[q].to_f64());
                    mean[q] += pl[q].to_f64() / rows as f64;
                }
            }
            (above, rows, mean)
        }
        for (name, (above, rows, mean)) in [("f64", run::<f64>(12)), ("f32", run::<f32>(12))] {
            println!(
                "model F {name}: above the level {above:?} of {rows} rows, mean level {mean:?}"
            );
            for q in 0..3 {
                assert!(
                    above[q] * 1000 <= rows,
                    "{name}: output {q} above its level on {} of {rows} rows (mean level {:?})",
                    above[q],
                    mean
                );
            }
        }
    }

    /// At rest (Ω exactly zero) Ω's columns vanish: no level. Near it, the level is a bound
    /// with Ω's share as large as Ω's deviation (the rows of random layouts check the flag
    /// that a row without a level carries: `tests/protection_levels.rs`).
    #[test]
    fn at_rest_there_is_no_level() {
        let arr = layout();
        let ff = FreeFloatIntegrity::<f64, 24>::build(&arr, ChannelMask::all(18), 1e-3).unwrap();
        let e = Estimate::<f64>::default();
        assert!(ff.levels(&e).is_none());
        let near = Estimate {
            omega: [1e-7, 0.0, 0.0],
            ..e
        };
        assert!(ff.levels(&near).is_some());
    }
}
