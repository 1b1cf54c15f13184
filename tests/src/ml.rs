//! A slow f64 multi-start maximum-likelihood reference, written independently of
//! estimator-core (nalgebra, dense matrices, no precomputed forms).
//!
//! - Model G: the likelihood is Gaussian in (σ0, Ω′, A) — 12 unknowns entering linearly — so its
//!   maximum is the weighted linear least-squares solution; Ω follows from A exactly as the
//!   product does (`ΩΩᵀ = A − ½ tr A I`, top eigenpair).
//! - Model F: (σ0, Ω′) are eliminated linearly; the remaining cost in Ω has several local minima,
//!   found by Levenberg–Marquardt from 52 starting points (13 directions × 4 magnitudes). The
//!   global minimum is the ML estimate. When several minima fit equally (m = 3: every branch
//!   fits exactly) the reference takes the one nearest the truth — an oracle no real-time
//!   estimator has — and the sign of Ω (unobservable in one sample) is always taken nearest
//!   the truth.

use ballisto_config::arrangement_file::LoadedArrangement;
use estimator_core::Model;
use nalgebra::{DMatrix, DVector, Matrix3, SymmetricEigen, Vector3};

/// One reference estimate.
#[derive(Clone, Copy, Debug)]
pub struct MlEstimate {
    /// σ0.
    pub sigma0: [f64; 3],
    /// Ω′.
    pub domega: [f64; 3],
    /// Ω.
    pub omega: [f64; 3],
    /// A as `[xx, yy, zz, xy, xz, yz]`.
    pub field: [f64; 6],
}

/// The reference estimator for one arrangement and model.
pub struct MlReference {
    model: Model,
    w: Vec<f64>,
    qs: Vec<Matrix3<f64>>,
    pinv: DMatrix<f64>,
    null_t: DMatrix<f64>,
}

fn skew2(w: &Vector3<f64>) -> Matrix3<f64> {
    w * w.transpose() - Matrix3::identity() * w.norm_squared()
}

impl MlReference {
    /// Builds the reference (dense SVD of the whitened design matrix).
    pub fn new(loaded: &LoadedArrangement, model: Model) -> Self {
        let ch = loaded.arrangement.channels();
        let n = ch.len();
        let k = match model {
            Model::General => 12,
            Model::FreeFloat => 6,
        };
        let mut g = DMatrix::<f64>::zeros(n, k);
        let mut w = Vec::with_capacity(n);
        let mut qs = Vec::with_capacity(n);
        for (i, c) in ch.iter().enumerate() {
            let s = Vector3::from(c.axis);
            let r = Vector3::from(c.position);
            let rxs = r.cross(&s);
            let wi = 1.0 / c.noise;
            w.push(wi);
            let mut row = vec![s.x, s.y, s.z, rxs.x, rxs.y, rxs.z];
            if model == Model::General {
                row.extend_from_slice(&[
                    s.x * r.x,
                    s.y * r.y,
                    s.z * r.z,
                    s.x * r.y + s.y * r.x,
                    s.x * r.z + s.z * r.x,
                    s.y * r.z + s.z * r.y,
                ]);
            }
            for (j, v) in row.iter().enumerate() {
                g[(i, j)] = v * wi;
            }
            // s·{Ω}² R = Ωᵀ Q Ω, Q = ½(s Rᵀ + R sᵀ) − (s·R) I, whitened.
            let q = (s * r.transpose() + r * s.transpose()) * 0.5 - Matrix3::identity() * s.dot(&r);
            qs.push(q * wi);
        }
        let svd = g.clone().svd(true, true);
        let pinv = svd.pseudo_inverse(1e-12).expect("pseudo-inverse");
        // Left null space: complete U to an orthonormal basis via the full SVD of G (n×n U).
        let full = nalgebra::linalg::SVD::new(
            {
                let mut ext = DMatrix::<f64>::zeros(n, n);
                ext.view_mut((0, 0), (n, k)).copy_from(&g);
                ext
            },
            true,
            false,
        );
        let u = full.u.expect("U");
        // Columns of U whose singular value is zero span the left null space.
        let mut idx: Vec<usize> = (0..n).collect();
        idx.sort_by(|&a, &b| {
            full.singular_values[b]
                .partial_cmp(&full.singular_values[a])
                .unwrap()
        });
        let null_cols: Vec<usize> = idx[k..].to_vec();
        let mut null_t = DMatrix::<f64>::zeros(n - k, n);
        for (row, &c) in null_cols.iter().enumerate() {
            for i in 0..n {
                null_t[(row, i)] = u[(i, c)];
            }
        }
        MlReference {
            model,
            w,
            qs,
            pinv,
            null_t,
        }
    }

    /// The ML estimate for one sample; `truth_omega` only breaks exact ties and fixes the sign.
    pub fn estimate(&self, p: &[f64], truth_omega: &[f64; 3]) -> MlEstimate {
        let n = p.len();
        let pw = DVector::from_iterator(n, p.iter().zip(self.w.iter()).map(|(a, b)| a * b));
        let truth = Vector3::from(*truth_omega);
        match self.model {
            Model::General => {
                let x = &self.pinv * &pw;
                let a = Matrix3::new(x[6], x[9], x[10], x[9], x[7], x[11], x[10], x[11], x[8]);
                let m = a - Matrix3::identity() * (0.5 * a.trace());
                let eig = SymmetricEigen::new(m);
                let (mut best, mut lam) = (0, f64::NEG_INFINITY);
                for i in 0..3 {
                    if eig.eigenvalues[i] > lam {
                        lam = eig.eigenvalues[i];
                        best = i;
                    }
                }
                let mut omega = eig.eigenvectors.column(best) * lam.max(0.0).sqrt();
                if (omega - truth).norm() > (-omega - truth).norm() {
                    omega = -omega;
                }
                MlEstimate {
                    sigma0: [x[0], x[1], x[2]],
                    domega: [x[3], x[4], x[5]],
                    omega: [omega.x, omega.y, omega.z],
                    field: [x[6], x[7], x[8], x[9], x[10], x[11]],
                }
            }
            Model::FreeFloat => {
                let pn = &self.null_t * &pw;
                let cost_and_jac = |om: &Vector3<f64>| {
                    let m = self.null_t.nrows();
                    let mut r = DVector::<f64>::zeros(m);
                    let mut j = DMatrix::<f64>::zeros(m, 3);
                    for e in 0..m {
                        let mut me = Matrix3::<f64>::zeros();
                        for (i, q) in self.qs.iter().enumerate() {
                            me += q * self.null_t[(e, i)];
                        }
                        let mo = me * om;
                        r[e] = pn[e] - om.dot(&mo);
                        for c in 0..3 {
                            j[(e, c)] = -2.0 * mo[c];
                        }
                    }
                    (r, j)
                };
                let dirs: [[f64; 3]; 13] = [
                    [1.0, 0.0, 0.0],
                    [0.0, 1.0, 0.0],
                    [0.0, 0.0, 1.0],
                    [1.0, 1.0, 0.0],
                    [1.0, -1.0, 0.0],
                    [1.0, 0.0, 1.0],
                    [1.0, 0.0, -1.0],
                    [0.0, 1.0, 1.0],
                    [0.0, 1.0, -1.0],
                    [1.0, 1.0, 1.0],
                    [1.0, 1.0, -1.0],
                    [1.0, -1.0, 1.0],
                    [-1.0, 1.0, 1.0],
                ];
                let mut minima: Vec<(f64, Vector3<f64>)> = Vec::new();
                for d in dirs {
                    for mag in [0.5, 1.5, 3.0, 6.0] {
                        let mut om = Vector3::from(d).normalize() * mag;
                        let (mut r, mut j) = cost_and_jac(&om);
                        let mut cost = r.norm_squared();
                        let mut mu = 1e-3;
                        for _ in 0..100 {
                            let jtj = j.transpose() * &j;
                            let jtr = j.transpose() * &r;
                            let mut damped = jtj.clone();
                            for i in 0..3 {
                                damped[(i, i)] += mu * jtj[(i, i)].max(1e-12);
                            }
                            let Some(step) = damped.lu().solve(&(-jtr)) else {
                                break;
                            };
                            let trial = om + Vector3::new(step[0], step[1], step[2]);
                            let (r2, j2) = cost_and_jac(&trial);
                            let c2 = r2.norm_squared();
                            if c2 < cost {
                                let done = cost - c2 < 1e-15 * (1.0 + cost);
                                om = trial;
                                r = r2;
                                j = j2;
                                cost = c2;
                                mu = (mu * 0.3).max(1e-12);
                                if done {
                                    break;
                                }
                            } else {
                                mu *= 10.0;
                                if mu > 1e8 {
                                    break;
                                }
                            }
                        }
                        minima.push((cost, om));
                    }
                }
                let best_cost = minima.iter().map(|m| m.0).fold(f64::INFINITY, f64::min);
                // Ties: within 1e-6 of the best cost (χ² units) — in practice m = 3 exact fits.
                let mut omega = minima
                    .iter()
                    .filter(|m| m.0 <= best_cost + 1e-6)
                    .map(|m| {
                        if (m.1 - truth).norm() <= (-m.1 - truth).norm() {
                            m.1
                        } else {
                            -m.1
                        }
                    })
                    .min_by(|a, b| (a - truth).norm().partial_cmp(&(b - truth).norm()).unwrap())
                    .unwrap();
                if !omega.iter().all(|v| v.is_finite()) {
                    omega = Vector3::zeros();
                }
                let q = DVector::from_iterator(n, self.qs.iter().map(|q| omega.dot(&(q * omega))));
                let x = &self.pinv * (pw - q);
                let a = skew2(&omega);
                MlEstimate {
                    sigma0: [x[0], x[1], x[2]],
                    domega: [x[3], x[4], x[5]],
                    omega: [omega.x, omega.y, omega.z],
                    field: [
                        a[(0, 0)],
                        a[(1, 1)],
                        a[(2, 2)],
                        a[(0, 1)],
                        a[(0, 2)],
                        a[(1, 2)],
                    ],
                }
            }
        }
    }
}
