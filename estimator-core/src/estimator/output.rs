//! The estimate of the chosen branch (paper section 7: `A = ε{a}² + diag(d)` rotated out of the
//! frame, Ω from `ΩΩᵀ = (A − Γ) − ½ tr(A − Γ) I`), its deviations and flags; the rate filter's
//! Ω put in its place.

use super::{Branch, Config};
use crate::arrangement::Model;
use crate::estimate::{Estimate, Flags};
use crate::linalg::{mat_t_vec, Mat3, Sym3, Vec3};
use crate::quadratic::rank_one_factor;
use crate::real::Real;

impl<T: Real, const CAP: usize> Config<T, CAP> {
    /// Replaces the algebraic Ω of `est` by a hypothesis' filtered Ω and its deviation; in
    /// model F also `A = Γ + {Ω}²` and its deviations.
    pub(super) fn apply_filtered(&self, est: &mut Estimate<T>, filtered: (Vec3<T>, Vec3<T>)) {
        let (w, v) = filtered;
        est.omega = w;
        est.sd_omega = v.map(|x| x.max(T::ZERO).sqrt());
        let var = (v[0] + v[1] + v[2]) / T::of(3.0);
        if self.model == Model::FreeFloat {
            est.field = self.gamma.add_scaled(T::ONE, &Sym3::skew_squared(&w));
            est.sd_field = crate::linalg::skew_squared_sd_isotropic(&w, var);
        }
    }

    /// Sets the protection levels of `est` (with redundancy and a `solved` sample, else none;
    /// model F's where its linearisation at the row's Ω gives one) and [`Flags::INTEGRITY_ALERT`] where one is above its alert limit or missing
    /// under a finite one.
    pub(super) fn protect(&self, est: &mut Estimate<T>, solved: bool) {
        // A prediction (a sample without its readings) has no bound: the motion since the
        // last estimate is not measured.
        est.protection = self
            .integrity
            .as_ref()
            .filter(|_| solved)
            .and_then(|i| i.levels(est));
        if self.integrity.is_some() && solved && est.protection.is_none() {
            est.flags.0 |= Flags::NO_PROTECTION_LEVEL;
        } else {
            est.flags.0 &= !Flags::NO_PROTECTION_LEVEL;
        }
        // Ω may be −Ω while its sign is unresolved, or another root while the branch is
        // ambiguous (a gross fault not yet isolated can carry the filter to the mirror root:
        // the mixed layout, a stuck part, 2 rows of 30 000): the level covers the mirror,
        // `2|Ω|` away (another root it bounds only as far as it lies within that).
        if let Some(pl) = &mut est.protection {
            if est.flags.has(Flags::SIGN_UNRESOLVED) || est.flags.has(Flags::BRANCH_AMBIGUOUS) {
                let w = &est.omega;
                pl[2] += T::of(2.0) * (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
            }
        }
        let limits = &self.options.alert_limits;
        let alert = match &est.protection {
            Some(pl) => pl.iter().zip(limits).any(|(p, l)| p.to_f64() > *l),
            None => limits.iter().any(|l| l.is_finite()),
        };
        if alert {
            est.flags.0 |= Flags::INTEGRITY_ALERT;
        } else {
            est.flags.0 &= !Flags::INTEGRITY_ALERT;
        }
    }

    /// Unsigned Ω (body) of a branch: model F `Ω = a`; model G from `ΩΩᵀ = (A − Γ) − ½ tr(A − Γ) I`.
    #[inline(never)]
    pub(super) fn omega_of(&self, f: usize, eps: T, b: &Branch<T>) -> Vec3<T> {
        match self.model {
            Model::FreeFloat => b.a,
            Model::General => {
                let v = &self.proj[f].frame;
                mat_t_vec(v, &rank_one_factor(&self.centripetal(f, eps, b)))
            }
        }
    }

    /// `(A − Γ) − ½ tr(A − Γ) I` in frame `f` (= ΩΩᵀ for a rigid body).
    pub(super) fn centripetal(&self, f: usize, eps: T, b: &Branch<T>) -> Sym3<T> {
        let c = field_in_frame(eps, b).add_scaled(-T::ONE, &self.gamma_frame[f]);
        let h = T::of(0.5) * c.trace();
        let mut m = c;
        m.0[0] -= h;
        m.0[1] -= h;
        m.0[2] -= h;
        m
    }

    /// The full estimate of the chosen branch, with first-order standard deviations, written
    /// to `out`. With `rate_filtered` the parts the rate filter replaces
    /// ([`Config::apply_filtered`]: Ω's deviation, model F's field) are left out. `prev` is
    /// the last estimate, output (flagged) if this one were not finite.
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    pub(super) fn finish(
        &self,
        f: usize,
        eps: T,
        b: &Branch<T>,
        omega: &Vec3<T>,
        rate_filtered: bool,
        prev: Option<&Estimate<T>>,
        out: &mut Estimate<T>,
    ) {
        let pr = &self.proj[f];
        let v = &pr.frame;
        let m = pr.m;
        out.sigma0 = pr.to_body(&[b.x[0], b.x[1], b.x[2]]);
        out.domega = pr.to_body(&[b.x[3], b.x[4], b.x[5]]);
        out.omega = *omega;
        match self.model {
            Model::General => {
                out.field = field_in_frame(eps, b).rotate(&transpose(v));
                out.d = [b.x[6], b.x[7], b.x[8]];
            }
            Model::FreeFloat => {
                if !rate_filtered {
                    out.field = self.gamma.add_scaled(T::ONE, &Sym3::skew_squared(&b.a));
                }
                out.d = [T::ZERO; 3];
            }
        }
        let mut flags = 0u16;
        if b.ill {
            flags |= Flags::ILL_CONDITIONED;
        }
        match &pr.general_cov {
            Some(gc) => {
                out.sd_sigma0 = gc.sd_sigma0;
                out.sd_domega = gc.sd_domega;
                out.sd_omega = b.omega_sd;
                out.sd_field = gc.sd_field;
            }
            None => {
                let (s0, sdw, sw) = self.deviations_linearised(f, eps, b, omega, !rate_filtered);
                out.sd_sigma0 = s0;
                out.sd_domega = sdw;
                out.sd_omega = sw;
                out.sd_field = match self.model {
                    // Model F: A = Γ + {Ω}², Ω = a with cov(a) (body frame: V = I).
                    Model::FreeFloat if !rate_filtered => {
                        crate::linalg::skew_squared_sd(omega, &b.cov_a)
                    }
                    Model::FreeFloat => out.sd_field,
                    // Model G without the constant covariance (degenerate frame): not available.
                    Model::General => Sym3([T::of(1e12); 6]),
                };
            }
        }
        let chi2 = b.fit;
        let dof = m.saturating_sub(3);
        if dof > 0 && chi2 > pr.fault_gate {
            flags |= Flags::RESIDUAL_HIGH;
        }
        out.a = b.a;
        out.frame = f as u8;
        out.epsilon = if eps < T::ZERO { -1 } else { 1 };
        out.flags = Flags(flags);
        out.chi2 = chi2;
        out.dof = dof as u8;
        out.branches = 0;
        if !out.is_finite() {
            // Defensive: never emit NaN. Keep the previous estimate, flagged.
            *out = prev.copied().unwrap_or_default();
            out.flags = Flags(out.flags.0 | Flags::ILL_CONDITIONED | Flags::FALLBACK);
        }
    }
}

/// Flags shared by every branch of one sample.
#[derive(Clone, Copy)]
pub(super) struct CommonFlags {
    pub(super) fallback: bool,
    pub(super) excluded: bool,
    pub(super) branches: u8,
}

impl CommonFlags {
    pub(super) fn apply<T: Real>(
        &self,
        est: &mut Estimate<T>,
        sign_unresolved: bool,
        branch_ambiguous: bool,
    ) {
        est.branches = self.branches;
        let mut flags = est.flags.0;
        for (on, bit) in [
            (sign_unresolved, Flags::SIGN_UNRESOLVED),
            (branch_ambiguous, Flags::BRANCH_AMBIGUOUS),
            (self.fallback, Flags::FALLBACK),
            (self.excluded, Flags::CHANNELS_EXCLUDED),
        ] {
            if on {
                flags |= bit;
            }
        }
        est.flags = Flags(flags);
    }
}

/// Model G's field in the branch's frame: `A_V = ε{a}² + diag(d)` (paper section 7).
pub(super) fn field_in_frame<T: Real>(eps: T, b: &Branch<T>) -> Sym3<T> {
    let mut a = Sym3::skew_squared(&b.a).scaled(eps);
    a.0[0] += b.x[6];
    a.0[1] += b.x[7];
    a.0[2] += b.x[8];
    a
}

pub(super) fn transpose<T: Real>(m: &Mat3<T>) -> Mat3<T> {
    [
        [m[0][0], m[1][0], m[2][0]],
        [m[0][1], m[1][1], m[2][1]],
        [m[0][2], m[1][2], m[2][2]],
    ]
}
