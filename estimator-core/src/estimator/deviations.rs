//! Standard deviations of the estimate (estimator.md, "Outputs"): `cov(a)` of the `a` solve,
//! first-order propagation to σ0, Ω′ and Ω through it (model F and model G without constant
//! covariances), and Ω's variances from the constant covariance of A (model G).

use super::{Branch, Config};
use crate::arrangement::Model;
use crate::linalg::{dot, mat_t_vec, mat_vec, norm2, omega_jacobian, scale, sub, Sym3, Vec3};
use crate::real::Real;
use crate::tracker::MAX_CANDIDATES;

/// Reciprocal condition (`det(JᵀJ)` over the cube of its mean eigenvalue) of the `a` solve
/// below which an estimate is flagged ill-conditioned: the Jacobian's condition number is then
/// several hundred (noise, and rounding in f32, amplified accordingly).
pub(super) const ILL_RCOND: f64 = 1e-5;

impl<T: Real, const CAP: usize> Config<T, CAP> {
    /// `cov(a) = (JᵀJ)⁻¹` with `J` rows `2 ε M_k a` (whitened equations: unit noise), and
    /// whether `JᵀJ` is nearly singular. Regularised so that `a = 0` (no rotation) gives large
    /// but finite variances. `jtj`: `JᵀJ` if the solver already formed it.
    #[inline(never)]
    pub(super) fn a_covariance(
        &self,
        f: usize,
        a: &Vec3<T>,
        jtj: Option<&Sym3<T>>,
    ) -> (Sym3<T>, bool) {
        let pr = &self.proj[f];
        let jtj = match jtj {
            Some(j) => *j,
            None => {
                let mut jtj = Sym3::<T>::zero();
                for mk in pr.mq.iter().take(pr.m) {
                    jtj.add_outer(&scale(T::of(2.0), &mk.mul_vec(a)));
                }
                jtj
            }
        };
        let third = jtj.trace() / T::of(3.0);
        let det = jtj.det();
        let ill = !(det > T::of(ILL_RCOND) * third * third * third);
        let reg = T::of(1e-6) * third + T::of(1e-12);
        let mut jr = jtj;
        for i in 0..3 {
            jr.0[i] += reg;
        }
        let big = T::of(1e12);
        let cov = jr
            .inverse(T::ZERO)
            .unwrap_or(Sym3([big, big, big, T::ZERO, T::ZERO, T::ZERO]));
        (cov, ill)
    }

    /// Model F: the mean per-component variance of a branch's Ω′ through its `cov(a)`
    /// (`var(x_c) = var0_c + 4 (T′_c a)ᵀ cov(a) (T′_c a)`, c = Ω′'s three), what the branch
    /// and sign filter takes with the branch's Ω′.
    pub(super) fn domega_variance(&self, f: usize, b: &Branch<T>) -> T {
        let pr = &self.proj[f];
        let mut acc = T::ZERO;
        for c in 3..6 {
            let g = pr.tq_body[c].mul_vec(&b.a);
            acc += pr.var0_body[c] + T::of(4.0) * b.cov_a.quad(&g);
        }
        (acc / T::of(3.0)).max(T::ZERO)
    }

    /// First-order standard deviations of σ0, Ω′ and Ω (body frame) through `cov(a)`:
    /// `cov(x) = cov0 + H cov(a) Hᵀ` with `H = ∂x/∂a = −2 ε T_j a`.
    /// Ω's deviation only `with_omega` (zero otherwise).
    pub(super) fn deviations_linearised(
        &self,
        f: usize,
        eps: T,
        b: &Branch<T>,
        omega: &Vec3<T>,
        with_omega: bool,
    ) -> (Vec3<T>, Vec3<T>, Vec3<T>) {
        let pr = &self.proj[f];
        let v = &pr.frame;
        let k = pr.k;
        let cov_a = b.cov_a;
        // σ0 and Ω′ in the body frame: x_c = (Vᵀ y)_c − ε aᵀ T′_c a, so
        // var(x_c) = var0_c + 4 (T′_c a)ᵀ cov(a) (T′_c a) (T′_c: `tq_body`).
        let mut sd6 = [T::ZERO; 6];
        for (c, sd) in sd6.iter_mut().enumerate() {
            let g = pr.tq_body[c].mul_vec(&b.a);
            *sd = (pr.var0_body[c] + T::of(4.0) * cov_a.quad(&g))
                .max(T::ZERO)
                .sqrt();
        }
        let sd_sigma0 = [sd6[0], sd6[1], sd6[2]];
        let sd_domega = [sd6[3], sd6[4], sd6[5]];
        // Standard deviations in the body frame: diag(Vᵀ C V)_k = v_kᵀ C v_k, v_k = column k of V.
        let vcols = [
            [v[0][0], v[1][0], v[2][0]],
            [v[0][1], v[1][1], v[2][1]],
            [v[0][2], v[1][2], v[2][2]],
        ];
        let sd = |c: &Sym3<T>| {
            [
                c.quad(&vcols[0]).max(T::ZERO).sqrt(),
                c.quad(&vcols[1]).max(T::ZERO).sqrt(),
                c.quad(&vcols[2]).max(T::ZERO).sqrt(),
            ]
        };
        let sd_omega = match self.model {
            _ if !with_omega => [T::ZERO; 3],
            Model::FreeFloat => sd(&cov_a),
            Model::General => {
                let wv = mat_vec(v, omega);
                let w2 = norm2(&wv);
                if w2 > T::ZERO {
                    // ∂Ω/∂(a, d) from dΩ = (dM Ω − Ω (Ωᵀ dM Ω)/(2|Ω|²))/|Ω|².
                    let mut jac = [[T::ZERO; 6]; 3];
                    let aw = dot(&b.a, &wv);
                    for i in 0..3 {
                        // da_i: dM = ε(e_i aᵀ + a e_iᵀ).
                        let mut dmw = scale(eps * wv[i], &b.a);
                        dmw[i] += eps * aw;
                        let q = T::of(2.0) * eps * wv[i] * aw;
                        for r in 0..3 {
                            jac[r][i] = (dmw[r] - wv[r] * q / (T::of(2.0) * w2)) / w2;
                        }
                        // dd_i: dM = e_i e_iᵀ − ½ I.
                        let mut dmw = scale(-T::of(0.5), &wv);
                        dmw[i] += wv[i];
                        let q = wv[i] * wv[i] - T::of(0.5) * w2;
                        for r in 0..3 {
                            jac[r][3 + i] = (dmw[r] - wv[r] * q / (T::of(2.0) * w2)) / w2;
                        }
                    }
                    // Joint covariance of (a, d): d = y_d − ε aᵀT a, so cov(d, a) = H_d cov(a)
                    // with H_d rows −2 ε T_j a (j = 6, 7, 8), and
                    // cov(d) = cov0_d + H_d cov(a) H_dᵀ.
                    let ca = cov_a.to_mat();
                    let mut h = [[T::ZERO; 3]; 3];
                    for (r, hr) in h.iter_mut().enumerate().take(k.saturating_sub(6)) {
                        *hr = scale(-T::of(2.0) * eps, &pr.tq[6 + r].mul_vec(&b.a));
                    }
                    let mut cd = pr.cov0[2].to_mat();
                    for r in 0..3 {
                        let hc = mat_t_vec(&ca, &h[r]);
                        for c in 0..3 {
                            cd[r][c] += dot(&hc, &h[c]);
                        }
                    }
                    let mut c6 = [[T::ZERO; 6]; 6];
                    for r in 0..3 {
                        let cda = mat_t_vec(&ca, &h[r]);
                        for c in 0..3 {
                            c6[r][c] = ca[r][c];
                            c6[3 + r][3 + c] = cd[r][c];
                            c6[3 + r][c] = cda[c];
                            c6[c][3 + r] = cda[c];
                        }
                    }
                    // cov(Ω) = J C Jᵀ.
                    let mut jc = [[T::ZERO; 6]; 3];
                    for r in 0..3 {
                        for i in 0..6 {
                            let mut acc = T::ZERO;
                            for j in 0..6 {
                                acc += jac[r][j] * c6[j][i];
                            }
                            jc[r][i] = acc;
                        }
                    }
                    let mut cw = [[T::ZERO; 3]; 3];
                    for r in 0..3 {
                        for s in r..3 {
                            let mut acc = T::ZERO;
                            for i in 0..6 {
                                acc += jc[r][i] * jac[s][i];
                            }
                            cw[r][s] = acc;
                            cw[s][r] = acc;
                        }
                    }
                    sd(&Sym3::from_mat(&cw))
                } else {
                    [T::of(1e6); 3]
                }
            }
        };
        (sd_sigma0, sd_domega, sd_omega)
    }
}

/// Frame score of `a` below which Kelvin's decomposition is flagged ill-conditioned.
pub(super) const KELVIN_MIN_SCORE: f64 = 0.02;

/// Variances of Ω (body frame) from the covariance of A (`[xx, yy, zz, xy, xz, yz]`), by
/// `dΩ = (dM Ω − Ω (Ωᵀ dM Ω)/(2|Ω|²)) / |Ω|²` with `dM = dA − ½ tr(dA) I` (first order of
/// `ΩΩᵀ = A − ½ tr A I`). Large but finite at Ω = 0.
pub(super) fn omega_variances<T: Real>(c: &[[T; 6]; 6], w: &Vec3<T>) -> Vec3<T> {
    let Some(jac) = omega_jacobian(w) else {
        return [T::of(1e12); 3];
    };
    // jᵀ C j with C symmetric: the diagonal once, the upper triangle twice.
    let mut var = [T::ZERO; 3];
    for r in 0..3 {
        let j = &jac[r];
        let mut acc = T::ZERO;
        for i in 0..6 {
            let mut inner = T::of(0.5) * c[i][i] * j[i];
            for l in (i + 1)..6 {
                inner += c[i][l] * j[l];
            }
            acc += j[i] * inner;
        }
        var[r] = (T::of(2.0) * acc).max(T::ZERO);
    }
    var
}

/// The 99.9 % point of `h / s` at a crossing: `2 × 3.29` (see [`widen_near_crossings`]).
pub(super) const CROSSING_RHO: f64 = 6.6;

/// Model F: widens each branch's `cov(a)` (`Ω = a`) along the separation to its nearest other
/// branch, where the two are within a few first-order deviations of each other: a crossing.
///
/// Where two branches cross, the forms have a double root; noise splits it into two roots
/// `±h` about their mean, with `h ~ √e` for a perturbation `e` of the forms (or into a complex
/// pair: the least-squares fallback). The Jacobian at a split root then gives a deviation `s`
/// along the separation with `h / s ≈ 2 |e| / σ_e`: at a crossing the observed half separation
/// is only a few first-order deviations (`h / s` ≤ [`CROSSING_RHO`] with 99.9 %), the truth may
/// be anywhere between the two roots, and the first-order covariance is invalid. Each root's
/// `cov(a)` is widened by `w(ρ) (d/2)(d/2)ᵀ`, with `d` the difference to the nearest other root
/// (either sign), `ρ = h / s` and `w = 1 / (1 + (ρ / CROSSING_RHO)⁸)`: 1/2 at the 99.9 % point,
/// 3.6 % at ρ = 10, nothing beyond ρ = 37. Through `cov(a)` it reaches the branch and sign
/// filter's measurement variances of Ω and Ω′ (near a crossing the filter holds to its own
/// motion) and the reported deviations of Ω, σ0 and Ω′ (without it, at 1 kHz the chosen root
/// was more than 5 first-order deviations off on 1.1 % of the nine-channel family's rows).
///
/// A root's own mirror `−a` counts as another root: at Ω = 0 the forms' double root splits
/// into `±h` as at any crossing, and a still body's readings — noise and whatever bias a
/// calibration left — put Ω a few rad/s from zero with a first-order deviation a fifth of
/// that. Without it, on the MIMU4444 board at rest (calibrated, 62.5 Hz, 19 mm) 0.8 % of the
/// rows were more than 5 deviations off without a flag and the filtered Ω 1.6 rad/s RMS;
/// with it, at most 0.01 % and 0.8 rad/s (the filter holds to its own motion there).
pub(super) fn widen_near_crossings<T: Real>(branches: &mut [Branch<T>]) {
    let n = branches.len().min(MAX_CANDIDATES);
    // The nearest other root of each, either sign (its own mirror first): squared distance
    // and difference.
    let mut near = [(T::of(1e30), [T::ZERO; 3]); MAX_CANDIDATES];
    for (b, nb) in branches.iter().zip(near.iter_mut()).take(n) {
        let d = scale(T::of(2.0), &b.a);
        *nb = (norm2(&d), d);
    }
    for i in 0..n {
        for j in (i + 1)..n {
            let (ai, aj) = (&branches[i].a, &branches[j].a);
            let dm = sub(ai, aj);
            let dp = [ai[0] + aj[0], ai[1] + aj[1], ai[2] + aj[2]];
            let (m2, p2) = (norm2(&dm), norm2(&dp));
            let nd = if m2 <= p2 { (m2, dm) } else { (p2, dp) };
            if nd.0 < near[i].0 {
                near[i] = nd;
            }
            if nd.0 < near[j].0 {
                near[j] = nd;
            }
        }
    }
    let k2 = CROSSING_RHO * CROSSING_RHO;
    let k8 = T::of(k2 * k2 * k2 * k2);
    for (b, (d2, d)) in branches.iter_mut().zip(near.iter()).take(n) {
        // ρ² = h² / s² with h² = |d|² / 4 and s² = dᵀ cov d / |d|².
        let q = b.cov_a.quad(d).max(T::of(1e-30));
        let rho2 = T::of(0.25) * *d2 * *d2 / q;
        let r4 = rho2 * rho2;
        let w = k8 / (k8 + r4 * r4);
        if w > T::of(1e-6) {
            b.cov_a.add_outer_scaled(T::of(0.25) * w, d);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A branch at `a` with the isotropic `cov(a)` of deviation `sd`.
    fn branch(a: Vec3<f64>, sd: f64) -> Branch<f64> {
        let v = sd * sd;
        Branch {
            a,
            cov_a: Sym3([v, v, v, 0.0, 0.0, 0.0]),
            ..Default::default()
        }
    }

    #[test]
    fn a_root_near_zero_is_widened_towards_its_mirror() {
        // |a| = 2 at deviation 0.3: ρ = 6.7, at the crossing's 99.9 % point: half the
        // half-separation squared is added along a.
        let mut b = [branch([2.0, 0.0, 0.0], 0.3)];
        widen_near_crossings(&mut b);
        let along = b[0].cov_a.0[0];
        assert!(
            along > 0.09 + 0.4 * 4.0 && along < 0.09 + 0.6 * 4.0,
            "{along}"
        );
        // Across a, nothing.
        assert_eq!(b[0].cov_a.0[1], 0.09);
        assert_eq!(b[0].cov_a.0[2], 0.09);
    }

    #[test]
    fn a_root_many_deviations_from_zero_is_left_alone() {
        // ρ = 2 / 0.01 = 200: far beyond any crossing.
        let mut b = [branch([2.0, 0.0, 0.0], 0.01)];
        widen_near_crossings(&mut b);
        assert!((b[0].cov_a.0[0] - 1e-4).abs() < 1e-12);
    }

    #[test]
    fn two_roots_close_to_each_other_widen_along_their_difference() {
        let mut b = [branch([5.0, 0.0, 0.0], 0.3), branch([5.0, 1.0, 0.0], 0.3)];
        widen_near_crossings(&mut b);
        // Separation 1 along y, ρ = 0.5 / 0.3: fully widened, by (d/2)² = 0.25.
        for x in &b {
            assert!((x.cov_a.0[1] - (0.09 + 0.25)).abs() < 1e-3, "{:?}", x.cov_a);
            assert!((x.cov_a.0[0] - 0.09).abs() < 1e-9);
        }
    }
}
