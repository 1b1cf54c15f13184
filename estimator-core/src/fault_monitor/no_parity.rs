//! The consistency tests where the monitor has no parity space: model G's known field and
//! model F's own residual, windowed.

use super::{window_limit, Settings, CAP_FACTOR};
use crate::estimate::Estimate;
use crate::real::Real;

/// Model G's consistency with a known gravity gradient ("redundancy is found where it
/// exists"): in orbit or on the ground Γ is known to far below the noise, so `A − Γ` must be
/// `{Ω}² = Ω Ωᵀ − |Ω|² I` — six components, three unknowns. With twelve channels model G has
/// no parity space, but this test has three degrees of freedom: the weighted least-squares fit
/// of Ω to `A − Γ` (Gauss–Newton from the estimate's Ω, weights `cov(A)⁻¹`, model G's constant
/// covariance) leaves `χ²₃` when the readings are consistent. It tests, it does not isolate.
#[derive(Clone, Debug)]
pub struct FieldCheck<T> {
    gamma: [T; 6],
    /// `cov(A)⁻¹`.
    weight: [[T; 6]; 6],
    lambda: T,
    total: T,
    limit: T,
}

impl<T: Real> FieldCheck<T> {
    /// The test for `cov(A)` (`Estimator::field_covariance`) and the known `gamma`, windowed as
    /// the fault monitor's; `None` if `cov(A)` is not positive definite.
    pub fn new(
        cov: &[[T; 6]; 6],
        gamma: &crate::linalg::Sym3<f64>,
        settings: Settings,
        rate_hz: f64,
    ) -> Option<Self> {
        let mut a = [[0.0f64; 6]; 6];
        for (ar, cr) in a.iter_mut().zip(cov.iter()) {
            for (x, c) in ar.iter_mut().zip(cr.iter()) {
                *x = c.to_f64();
            }
        }
        let inv = crate::identify::cholesky::invert_spd(&a)?;
        let mut weight = [[T::ZERO; 6]; 6];
        for (wr, ir) in weight.iter_mut().zip(inv.iter()) {
            for (w, x) in wr.iter_mut().zip(ir.iter()) {
                *w = T::of(*x);
            }
        }
        let tau = (settings.window_s * rate_hz).clamp(2.0, 1e7);
        Some(FieldCheck {
            gamma: gamma.0.map(T::of),
            weight,
            lambda: T::of(1.0 - 1.0 / tau),
            total: T::ZERO,
            limit: T::of(window_limit(3, tau, settings.false_alarm)),
        })
    }

    /// This estimate's `χ²₃` (0 if it has no finite field).
    pub fn chi2(&self, e: &Estimate<T>) -> T {
        let s: [T; 6] = core::array::from_fn(|i| e.field.0[i] - self.gamma[i]);
        let mut w = e.omega;
        let mut chi2 = T::ZERO;
        for it in 0..4 {
            let (r, j) = residual_and_jacobian(&s, &w);
            let wr: [T; 6] = core::array::from_fn(|a| {
                (0..6).fold(T::ZERO, |acc, b| acc + self.weight[a][b] * r[b])
            });
            chi2 = (0..6).fold(T::ZERO, |acc, a| acc + r[a] * wr[a]);
            if it == 3 {
                break;
            }
            // Normal equations Jᵀ W J δ = Jᵀ W r.
            let mut n = [T::ZERO; 6];
            let mut g = [T::ZERO; 3];
            let wj: [[T; 3]; 6] = core::array::from_fn(|a| {
                core::array::from_fn(|k| {
                    (0..6).fold(T::ZERO, |acc, b| acc + self.weight[a][b] * j[b][k])
                })
            });
            for (k, gk) in g.iter_mut().enumerate() {
                *gk = (0..6).fold(T::ZERO, |acc, a| acc + j[a][k] * wr[a]);
            }
            let idx = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)];
            for (slot, (p, q)) in n.iter_mut().zip(idx) {
                *slot = (0..6).fold(T::ZERO, |acc, a| acc + j[a][p] * wj[a][q]);
            }
            let Some(d) = crate::linalg::Sym3(n).solve(&g) else {
                break;
            };
            for k in 0..3 {
                w[k] += d[k];
            }
        }
        if chi2.is_finite() {
            chi2.max(T::ZERO)
        } else {
            T::ZERO
        }
    }

    /// The window's `χ²` over its limit (above 1: inconsistent).
    pub fn level(&self) -> T {
        self.total / self.limit
    }

    /// One estimate: whether the window's `χ²` is above its limit (the readings inconsistent
    /// with the known field: a fault, or a Γ that is not the one given).
    pub fn step(&mut self, e: &Estimate<T>) -> bool {
        let x = self.chi2(e);
        self.total = (self.lambda * self.total + x).min(T::of(CAP_FACTOR) * self.limit);
        self.total > self.limit
    }
}

/// Model F's own residual, windowed (issue 17: "run the consistency test in the model that
/// has the degrees of freedom"): with 10–12 channels model F has no parity space (model G's
/// needs 13) and no known-field test (that is model G's), but its per-sample `χ²` has `N − 9`
/// degrees of freedom ([`Estimate::chi2`], [`Estimate::dof`]). Summed over the monitor's window
/// against the same false-alarm rate, a bias too small for the per-sample 99.99 % point shows.
/// It tests, it does not isolate.
#[derive(Clone, Debug)]
pub struct ResidualCheck<T> {
    lambda: T,
    total: T,
    limit: T,
}

impl<T: Real> ResidualCheck<T> {
    /// The test for `dof` degrees of freedom (`Estimator::dof`); `None` for 0.
    pub fn new(dof: usize, settings: Settings, rate_hz: f64) -> Option<Self> {
        if dof == 0 {
            return None;
        }
        let tau = (settings.window_s * rate_hz).clamp(2.0, 1e7);
        Some(ResidualCheck {
            lambda: T::of(1.0 - 1.0 / tau),
            total: T::ZERO,
            limit: T::of(window_limit(dof, tau, settings.false_alarm)),
        })
    }

    /// The window's `χ²` over its limit (above 1: inconsistent).
    pub fn level(&self) -> T {
        self.total / self.limit
    }

    /// One estimate: whether the window's `χ²` is above its limit. A prediction (no readings
    /// used) or a non-finite `χ²` adds nothing.
    pub fn step(&mut self, e: &Estimate<T>) -> bool {
        let x = if e.flags.has(crate::Flags::INPUT_INVALID) || !e.chi2.is_finite() {
            T::ZERO
        } else {
            e.chi2.max(T::ZERO)
        };
        self.total = (self.lambda * self.total + x).min(T::of(CAP_FACTOR) * self.limit);
        self.total > self.limit
    }
}

/// The test where the fault monitor has no parity space (N ≤ 12): model G's
/// known-field test ([`FieldCheck`]), else model F's own residual windowed ([`ResidualCheck`],
/// 10–12 channels), else none (nine channels in model F: no degree of freedom). Chosen once
/// per channel set, as the monitor's parity space is rebuilt; the firmware's `Isolation` and
/// `ballisto estimate` both run it, after each estimate.
#[derive(Clone, Debug)]
pub enum NoParityTest<T> {
    /// A parity space, or no degree of freedom: no test here.
    None,
    /// Model G's consistency with the known Γ.
    Field(FieldCheck<T>),
    /// Model F's own `χ²` with `N − 9` degrees of freedom, windowed.
    Residual(ResidualCheck<T>),
}

impl<T: Real> NoParityTest<T> {
    /// The test for `estimator`'s configuration where `has_parity` is false (the monitor's
    /// parity space could not be built over the channels tested), windowed over `settings`
    /// at `rate_hz`.
    pub fn for_estimator<const CAP: usize>(
        estimator: &crate::Estimator<T, CAP>,
        has_parity: bool,
        settings: Settings,
        rate_hz: f64,
    ) -> Self {
        if has_parity {
            return NoParityTest::None;
        }
        if let Some(cov) = estimator.field_covariance() {
            if let Some(f) = FieldCheck::new(&cov, &estimator.known_gamma(), settings, rate_hz) {
                return NoParityTest::Field(f);
            }
        }
        match estimator.model() {
            crate::Model::FreeFloat => ResidualCheck::new(estimator.dof(), settings, rate_hz)
                .map_or(NoParityTest::None, NoParityTest::Residual),
            crate::Model::General => NoParityTest::None,
        }
    }

    /// After an estimate: whether the window is inconsistent; `None` where there is no test
    /// (a parity space instead, no degree of freedom, or an estimate it cannot use).
    pub fn step(&mut self, e: &Estimate<T>) -> Option<bool> {
        if !e.is_finite() {
            return None;
        }
        match self {
            NoParityTest::None => None,
            NoParityTest::Field(f) => Some(f.step(e)),
            NoParityTest::Residual(r) => Some(r.step(e)),
        }
    }

    /// The window's `χ²` over its limit; `None` without a test.
    pub fn level(&self) -> Option<T> {
        match self {
            NoParityTest::None => None,
            NoParityTest::Field(f) => Some(f.level()),
            NoParityTest::Residual(r) => Some(r.level()),
        }
    }
}

/// `r = S − ({Ω}²)` and `∂{Ω}²/∂Ω` (components `[xx, yy, zz, xy, xz, yz]`).
fn residual_and_jacobian<T: Real>(s: &[T; 6], w: &[T; 3]) -> ([T; 6], [[T; 3]; 6]) {
    let [x, y, z] = *w;
    let two = T::of(2.0);
    let f = [
        -(y * y + z * z),
        -(x * x + z * z),
        -(x * x + y * y),
        x * y,
        x * z,
        y * z,
    ];
    let zero = T::ZERO;
    let j = [
        [zero, -two * y, -two * z],
        [-two * x, zero, -two * z],
        [-two * x, -two * y, zero],
        [y, x, zero],
        [z, zero, x],
        [zero, z, y],
    ];
    (core::array::from_fn(|i| s[i] - f[i]), j)
}
