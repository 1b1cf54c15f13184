//! One channel's fit: Gauss–Newton on its parameters over the window's sums (paper eq. 9 with
//! scale and bias), what the window did not determine held at nominal.

use super::cholesky::{cholesky, cholesky_solve, inverse_diagonal};
use super::model::{tilt_basis, Param, Tolerance, PARAMS};
use super::result::ChannelFit;
use super::sums::TERMS;
use crate::arrangement::Channel;
use crate::linalg::{norm2, Vec3};
use crate::real::Real;

/// A channel's parameters: scale, axis (the nominal axis tilted by `tilt` along the nominal
/// tilt directions, so that a held tilt stays exactly nominal), position from the centre of
/// mass, bias.
#[derive(Clone, Copy, Debug)]
pub(super) struct State {
    scale: f64,
    nominal_axis: Vec3<f64>,
    basis: (Vec3<f64>, Vec3<f64>),
    tilt: [f64; 2],
    position: Vec3<f64>,
    bias: f64,
}

impl State {
    #[inline]
    pub(super) fn new(scale: f64, axis: Vec3<f64>, position: Vec3<f64>, bias: f64) -> Self {
        State {
            scale,
            nominal_axis: axis,
            basis: tilt_basis(&axis),
            tilt: [0.0; 2],
            position,
            bias,
        }
    }

    /// The unit axis and its length before normalising.
    #[inline]
    fn axis(&self) -> (Vec3<f64>, f64) {
        let (t1, t2) = &self.basis;
        let v: Vec3<f64> = core::array::from_fn(|k| {
            self.nominal_axis[k] + self.tilt[0] * t1[k] + self.tilt[1] * t2[k]
        });
        let n = Real::sqrt(norm2(&v));
        ([v[0] / n, v[1] / n, v[2] / n], n)
    }

    /// `q = (vec(c s Rᵀ), b)`: the reading is `qᵀ k`.
    #[inline]
    fn q(&self) -> [f64; TERMS] {
        let (s, _) = self.axis();
        let mut q = [0.0; TERMS];
        for j in 0..3 {
            for l in 0..3 {
                q[3 * j + l] = self.scale * s[j] * self.position[l];
            }
        }
        q[9] = self.bias;
        q
    }

    /// `∂q/∂θ` (TERMS × PARAMS), θ = (scale, tilts, position, bias) (paper eq. 9 with scale
    /// and bias).
    #[inline]
    fn jacobian(&self) -> [[f64; PARAMS]; TERMS] {
        let (s, n) = self.axis();
        // ∂(v/|v|)/∂tilt = (t − s (s·t)) / |v|.
        let d = |t: &Vec3<f64>| -> Vec3<f64> {
            let st = s[0] * t[0] + s[1] * t[1] + s[2] * t[2];
            core::array::from_fn(|k| (t[k] - s[k] * st) / n)
        };
        let (d1, d2) = (d(&self.basis.0), d(&self.basis.1));
        let (c, r) = (self.scale, &self.position);
        let mut j = [[0.0; PARAMS]; TERMS];
        for a in 0..3 {
            for l in 0..3 {
                let row = &mut j[3 * a + l];
                row[0] = s[a] * r[l];
                row[1] = c * d1[a] * r[l];
                row[2] = c * d2[a] * r[l];
                row[3 + l] = c * s[a];
            }
        }
        j[9][6] = 1.0;
        j
    }

    /// The parameters after the step `d`.
    #[inline]
    fn step(&self, d: &[f64; PARAMS]) -> State {
        State {
            scale: self.scale + d[0],
            tilt: [self.tilt[0] + d[1], self.tilt[1] + d[2]],
            position: [
                self.position[0] + d[3],
                self.position[1] + d[4],
                self.position[2] + d[5],
            ],
            bias: self.bias + d[6],
            ..*self
        }
    }
}

/// One channel's least squares over the window's sums.
pub(super) struct Problem<'a> {
    pub(super) gram: &'a [[f64; TERMS]; TERMS],
    pub(super) cross: &'a [f64; TERMS],
    pub(super) square: f64,
    pub(super) sets: f64,
    pub(super) tolerance: &'a Tolerance,
}

/// Iterations of one Gauss–Newton before it is declared unsettled.
const MAX_ITERATIONS: usize = 40;
/// A step below this share of every tolerance has settled.
const SETTLED: f64 = 1e-4;
/// A parameter whose deviation exceeds this share of its tolerance is held.
const HOLD_AT: f64 = 0.5;
/// The ridge added to the scaled normal matrix, relative to its largest diagonal.
const RIDGE: f64 = 1e-10;
/// Held always: in free fall a channel reads `c s·(L R)`, so its scale `c` and its distance
/// from the centre of mass are one product (`(αc, R/α)` reads the same in any field). The
/// scale stays at the arrangement's (the ground calibration's) value; the product, which is
/// what the estimate needs, is identified.
pub const ALWAYS_HELD: u8 = Param::Scale.bit();

impl Problem<'_> {
    /// `Σ (p − qᵀk)²`.
    #[inline]
    fn cost(&self, q: &[f64; TERMS]) -> f64 {
        let mut qmq = 0.0;
        for i in 0..TERMS {
            qmq += q[i] * dot_row(&self.gram[i], q);
        }
        (self.square - 2.0 * dot_row(self.cross, q) + qmq).max(0.0)
    }

    /// The tolerance-scaled normal matrix `D JᵀMJ D` and right-hand side `D Jᵀ(g − Mq)`.
    #[inline]
    fn normal(&self, st: &State) -> ([[f64; PARAMS]; PARAMS], [f64; PARAMS]) {
        let (j, q) = (st.jacobian(), st.q());
        let mut mj = [[0.0; PARAMS]; TERMS];
        let mut resid = [0.0; TERMS];
        for t in 0..TERMS {
            for p in 0..PARAMS {
                mj[t][p] = (0..TERMS).map(|u| self.gram[t][u] * j[u][p]).sum();
            }
            resid[t] = self.cross[t] - dot_row(&self.gram[t], &q);
        }
        let mut h = [[0.0; PARAMS]; PARAMS];
        let mut b = [0.0; PARAMS];
        for p in 0..PARAMS {
            let dp = self.tolerance.of(p);
            for r in 0..PARAMS {
                let s: f64 = (0..TERMS).map(|t| j[t][p] * mj[t][r]).sum();
                h[p][r] = dp * s * self.tolerance.of(r);
            }
            b[p] = dp * (0..TERMS).map(|t| j[t][p] * resid[t]).sum::<f64>();
        }
        // A ridge of 10⁻¹⁰ of the largest diagonal: a direction the window does not see
        // (a lever arm along the only spin axis) gets a deviation far above its tolerance and
        // is held, instead of failing the factorisation; the seen ones do not notice it.
        let top = (0..PARAMS).map(|p| h[p][p]).fold(0.0f64, f64::max);
        for (p, row) in h.iter_mut().enumerate() {
            row[p] += RIDGE * top;
        }
        (h, b)
    }

    /// Gauss–Newton from `start` on the parameters not in `held`; `None` if it does not settle.
    #[inline(never)]
    fn settle(&self, start: State, held: u8) -> Option<State> {
        let mut st = start;
        for _ in 0..MAX_ITERATIONS {
            let (h, b) = self.normal(&st);
            let (mut a, idx, n) = compact(&h, held);
            let mut rhs = [0.0; PARAMS];
            for (k, &p) in idx[..n].iter().enumerate() {
                rhs[k] = b[p];
            }
            if !cholesky(&mut a, n) {
                return None;
            }
            let x = cholesky_solve(&a, n, &rhs);
            let mut d = [0.0; PARAMS];
            let mut largest = 0.0f64;
            for (k, &p) in idx[..n].iter().enumerate() {
                d[p] = x[k] * self.tolerance.of(p);
                largest = largest.max(x[k].abs());
            }
            if !largest.is_finite() {
                return None;
            }
            st = st.step(&d);
            if largest < SETTLED {
                return Some(st);
            }
        }
        None
    }

    /// The channel's fit: Gauss–Newton, then what the window did not determine held at
    /// nominal (the worst first) and Gauss–Newton again, until every
    /// free parameter is determined to half its tolerance; a Gauss–Newton that does not settle
    /// holds the least informed free parameter and runs again. `None` if the normal matrix at
    /// the solution is not positive definite with nothing left to hold.
    #[inline(never)]
    pub(super) fn fit(&self, nominal: State, noise: f64) -> Option<ChannelFit> {
        let mut held = ALWAYS_HELD;
        let (at_nominal, _) = self.normal(&nominal);
        loop {
            // What the window cannot determine is decided first, at the nominal point with the
            // declared noise: a Gauss–Newton along a direction only the ridge holds creeps
            // (0.9 of the step left per iteration in a torque-free tumble) and never settles.
            if let Some(p) = self.worst(&at_nominal, held, noise).1 {
                held |= 1 << p;
                continue;
            }
            if held == (1 << PARAMS) - 1 {
                // Everything held: the nominal channel.
                return Some(self.report(&nominal, [0.0; PARAMS], held, noise));
            }
            let Some(st) = self.settle(nominal, held) else {
                // Not settling: the least informed free parameter is held and the rest solved
                // again (measured: on drawn torque-free tumbles a channel whose Gauss–Newton
                // wandered along a direction the window barely sees refused the whole
                // solution; holding instead identified 16 of 24 tumbles, 11 before).
                held |= 1 << least_informed(&at_nominal, held)?;
                continue;
            };
            // At the solution, with the residual's deviation where it exceeds the noise.
            let sigma = self.sigma(&st, noise, PARAMS - held.count_ones() as usize);
            match self.worst(&self.normal(&st).0, held, sigma) {
                (Some(sd), None) => return Some(self.report(&st, sd, held, noise)),
                (_, Some(p)) => held |= 1 << p,
                (None, None) => return None,
            }
        }
    }

    /// The deviations of the parameters not in `held` from the scaled normal matrix `h` with
    /// the residual deviation `sigma` (`None` if `h` is not positive definite), and the worst
    /// of those beyond half its tolerance (or, not positive definite, the least informed).
    #[inline]
    fn worst(
        &self,
        h: &[[f64; PARAMS]; PARAMS],
        held: u8,
        sigma: f64,
    ) -> (Option<[f64; PARAMS]>, Option<usize>) {
        let (mut a, idx, n) = compact(h, held);
        if n == 0 {
            return (Some([0.0; PARAMS]), None);
        }
        if !cholesky(&mut a, n) {
            return (None, least_informed(h, held));
        }
        let mut worst: Option<(usize, f64)> = None;
        let mut sd = [0.0; PARAMS];
        for (k, &p) in idx[..n].iter().enumerate() {
            let rel = sigma * Real::sqrt(inverse_diagonal(&a, n, k).max(0.0));
            sd[p] = rel * self.tolerance.of(p);
            if rel > HOLD_AT && worst.is_none_or(|(_, w)| rel > w) {
                worst = Some((p, rel));
            }
        }
        (Some(sd), worst.map(|(p, _)| p))
    }

    /// The residual's deviation, not below the channel's declared noise.
    #[inline]
    fn sigma(&self, st: &State, noise: f64, free: usize) -> f64 {
        let dof = (self.sets - free as f64).max(1.0);
        Real::sqrt(self.cost(&st.q()) / dof).max(noise)
    }

    #[inline]
    fn report(&self, st: &State, mut sd: [f64; PARAMS], held: u8, noise: f64) -> ChannelFit {
        for (p, s) in sd.iter_mut().enumerate() {
            if held & (1 << p) != 0 {
                *s = self.tolerance.of(p);
            }
        }
        ChannelFit {
            channel: Channel {
                position: st.position,
                axis: st.axis().0,
                noise,
                bias: st.bias,
                scale: st.scale,
            },
            sd,
            held,
            residual_rms: Real::sqrt(self.cost(&st.q()) / self.sets.max(1.0)),
        }
    }
}

/// The free parameter (not in `held`) with the least information (the smallest diagonal of
/// the scaled normal matrix `h`).
#[inline]
fn least_informed(h: &[[f64; PARAMS]; PARAMS], held: u8) -> Option<usize> {
    (0..PARAMS)
        .filter(|p| held & (1 << p) == 0)
        .min_by(|&p, &r| h[p][p].total_cmp(&h[r][r]))
}

#[inline]
fn dot_row(a: &[f64; TERMS], b: &[f64; TERMS]) -> f64 {
    a.iter().zip(b.iter()).map(|(x, y)| x * y).sum()
}

/// The rows and columns of `h` not in `held`, packed to the top left; their indices; how many.
#[inline]
fn compact(
    h: &[[f64; PARAMS]; PARAMS],
    held: u8,
) -> ([[f64; PARAMS]; PARAMS], [usize; PARAMS], usize) {
    let mut idx = [0usize; PARAMS];
    let mut n = 0;
    for p in 0..PARAMS {
        if held & (1 << p) == 0 {
            idx[n] = p;
            n += 1;
        }
    }
    let mut a = [[0.0; PARAMS]; PARAMS];
    for r in 0..n {
        for c in 0..n {
            a[r][c] = h[idx[r]][idx[c]];
        }
    }
    (a, idx, n)
}

#[cfg(test)]
mod tests {
    use super::super::model::reading_gradient;
    use super::*;

    /// The sums' form of the Jacobian is the channel model's gradient
    /// ([`reading_gradient`]) rearranged: for any field `L` with σ(0) = 0,
    /// `∂h/∂θ = Σ_t (∂q_t/∂θ) k_t` with `k = (vec L, 1)`, and the tilted axis's derivative
    /// `(t − s (s·t)) / |v|`.
    #[test]
    fn the_sums_jacobian_is_the_models_gradient() {
        let mut st = State::new(1.02, [0.0, 0.6, 0.8], [0.05, -0.02, 0.03], 0.1);
        st = st.step(&[0.0, 3e-3, -2e-3, 0.0, 0.0, 0.0, 0.0]);
        let l = [[-1.1, 0.3, 0.8], [-0.2, -1.9, 0.4], [0.6, -0.7, -0.4]];
        let mut k = [0.0; TERMS];
        for a in 0..3 {
            for c in 0..3 {
                k[3 * a + c] = l[a][c];
            }
        }
        k[9] = 1.0;
        let jq = st.jacobian();
        let (s, n) = st.axis();
        let d = |t: &Vec3<f64>| -> Vec3<f64> {
            let st = s[0] * t[0] + s[1] * t[1] + s[2] * t[2];
            core::array::from_fn(|k| (t[k] - s[k] * st) / n)
        };
        let tilt = (d(&st.basis.0), d(&st.basis.1));
        let f: Vec3<f64> = core::array::from_fn(|a| (0..3).map(|c| l[a][c] * st.position[c]).sum());
        let g = reading_gradient(st.scale, &s, &tilt, &l, &f);
        for p in 0..PARAMS {
            let from_sums: f64 = (0..TERMS).map(|t| jq[t][p] * k[t]).sum();
            assert!(
                (from_sums - g[p]).abs() < 1e-12,
                "{p}: {from_sums} vs {}",
                g[p]
            );
        }
    }
}
