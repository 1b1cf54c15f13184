//! One track's Kalman filter of (Ω, Ω′) on the white-jerk model: prediction, the update by
//! model F's readings (iterated extended) or by model G's nearest root, a track's start.

use super::*;
use crate::linalg::{dot, mat_vec, norm2, scale, sub, Mat3, Sym3, Vec3};
use crate::real::Real;

/// The two signs of a candidate's Ω.
pub(super) const SIGNS: [i8; 2] = [1, -1];

pub(super) fn sign_of<T: Real>(sign: i8) -> T {
    T::of(f64::from(sign))
}

/// Predicts a track over `dt` with the white-jerk noise `qs` (`[Ω Ω, Ω Ω′, Ω′ Ω′]`, times I).
#[inline(always)]
pub(super) fn predict<T: Real>(t: &mut State<T>, dt: T, qs: [T; 3]) {
    t.omega = propagate(t, dt);
    for r in 0..3 {
        for c in 0..3 {
            t.p_ww[r][c] += dt * (t.p_wd[r][c] + t.p_wd[c][r] + dt * t.p_dd[r][c]);
            t.p_wd[r][c] += dt * t.p_dd[r][c];
        }
        t.p_ww[r][r] += qs[0];
        t.p_wd[r][r] += qs[1];
        t.p_dd[r][r] += qs[2];
    }
}

/// One Kalman update by three measurements: `u = P_ΩΩ Hᵀ_Ω + P_ΩΩ′ Hᵀ_Ω′` and
/// `v = P_Ω′Ω Hᵀ_Ω + P_Ω′Ω′ Hᵀ_Ω′` (the two halves of `P Hᵀ`), the innovation covariance `s`
/// and the innovation `nu`. Returns the normalised innovation and `ln det S`; beyond `gate` the
/// update is weighted down to the gate's.
#[inline(always)]
pub(super) fn update3<T: Real>(
    t: &mut State<T>,
    (u, v): (&Mat3<T>, &Mat3<T>),
    s: &Mat3<T>,
    nu: &Vec3<T>,
    gate: T,
) -> (T, T) {
    let (cof, det) = Sym3::from_mat(s).cofactors();
    let det = det.max(det_floor(s));
    let s_inv = cof.scaled(T::ONE / det).to_mat();
    let w = mat_vec(&s_inv, nu);
    let nis = dot(nu, &w).max(T::ZERO);
    let ln_det = det.ln_approx();
    // Beyond the gate the update is weighted down to the gate's (a Huber-weighted update:
    // one wild sample pulls little, while a noise larger than declared — real parts — is
    // still followed instead of coasting away from the readings).
    let weight = if nis > gate { gate / nis } else { T::ONE };
    let w = scale(weight, &w);
    let s_inv = s_inv.map(|row| row.map(|x| x * weight));
    let (dw, dd) = (mat_vec(u, &w), mat_vec(v, &w));
    if !dw.iter().chain(dd.iter()).all(|x| x.is_finite()) {
        return (T::of(f64::MAX), ln_det);
    }
    for c in 0..3 {
        t.omega[c] += dw[c];
        t.domega[c] += dd[c];
    }
    // P⁺ = P − (P Hᵀ) S⁻¹ (P Hᵀ)ᵀ, block by block.
    let (us, vs) = (mul(u, &s_inv), mul(v, &s_inv));
    for r in 0..3 {
        for c in 0..3 {
            let (mut ww, mut wd, mut dd) = (T::ZERO, T::ZERO, T::ZERO);
            for k in 0..3 {
                ww += us[r][k] * u[c][k];
                wd += us[r][k] * v[c][k];
                dd += vs[r][k] * v[c][k];
            }
            t.p_ww[r][c] -= ww;
            t.p_wd[r][c] -= wd;
            t.p_dd[r][c] -= dd;
        }
    }
    // Rounding can leave the difference a little asymmetric or, for a nearly exact
    // measurement, with a diagonal at or below zero (which lets the filter diverge):
    // symmetrised, its diagonal kept positive.
    for p in [&mut t.p_ww, &mut t.p_dd] {
        for r in 0..3 {
            for c in (r + 1)..3 {
                let m = T::of(0.5) * (p[r][c] + p[c][r]);
                p[r][c] = m;
                p[c][r] = m;
            }
            p[r][r] = p[r][r].max(T::of(1e-30));
        }
    }
    (nis, ln_det)
}

/// The least determinant an innovation covariance `s` is given (a nearly singular one is
/// regularised: its inverse stays finite).
#[inline(always)]
pub(super) fn det_floor<T: Real>(s: &Mat3<T>) -> T {
    T::of(1e-12) * (s[0][0] * s[1][1] * s[2][2]).abs() + T::of(1e-30)
}

/// `a + b` (`a` full, `b` symmetric).
#[inline(always)]
pub(super) fn add_sym<T: Real>(a: &Mat3<T>, b: &Sym3<T>) -> Mat3<T> {
    let b = b.to_mat();
    let mut m = *a;
    for r in 0..3 {
        for c in 0..3 {
            m[r][c] += b[r][c];
        }
    }
    m
}

/// `a b`.
#[inline(always)]
pub(super) fn mul<T: Real>(a: &Mat3<T>, b: &Mat3<T>) -> Mat3<T> {
    let mut m = [[T::ZERO; 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            m[r][c] = a[r][0] * b[0][c] + a[r][1] * b[1][c] + a[r][2] * b[2][c];
        }
    }
    m
}

/// `a hᵀ + b` (`h` given by its rows).
#[inline(always)]
pub(super) fn mul_t_add<T: Real>(a: &Mat3<T>, h: &Mat3<T>, b: &Mat3<T>) -> Mat3<T> {
    let mut m = *b;
    for r in 0..3 {
        for c in 0..3 {
            m[r][c] += a[r][0] * h[c][0] + a[r][1] * h[c][1] + a[r][2] * h[c][2];
        }
    }
    m
}

/// `bᵀ` (a full matrix's transpose).
#[inline(always)]
pub(super) fn transpose<T: Real>(b: &Mat3<T>) -> Mat3<T> {
    [
        [b[0][0], b[1][0], b[2][0]],
        [b[0][1], b[1][1], b[2][1]],
        [b[0][2], b[1][2], b[2][2]],
    ]
}

/// Model F (m = 3): the extended Kalman filter's update of a predicted track by the readings,
/// linearised at its prediction; returns the normalised innovations (whose log-determinants
/// are added to the cost as well). First the null-space equations (`H = [G, 0]`, `G` the rows
/// `2 (Mₖ Ω̂)ᵀ`, unit noise), then the Ω′ rows at the updated Ω (`H = [J, I]`, `J` the rows
/// `2 (Tⱼ Ω̂)ᵀ`, noise `var0`). Updates beyond `gate` are weighted down to it.
#[inline(always)]
pub(super) fn update_by_readings<T: Real>(t: &mut State<T>, r: &Readings<T>, gate: T) -> T {
    let zero = [[T::ZERO; 3]; 3];
    let prior = t.omega;
    let v_t = transpose(&t.p_wd);
    // Iterated (Gauss–Newton) linearisation: where the prior is wide against the forms'
    // curvature (at a start, in a weakly observed direction) one linearisation at the
    // prediction leaves the update biased and its covariance overconfident (a slow manoeuvre
    // on a random layout: 0.1 % of the filtered rows silently wrong with one, none with it).
    let mut lin = prior;
    let (mut u, mut v, mut s, mut nu) = (zero, zero, zero, [T::ZERO; 3]);
    for _ in 0..IEKF_ITERATIONS {
        let mut g = zero;
        let d = sub(&prior, &lin);
        for (k, (m, pe)) in r.forms.iter().zip(r.pe.iter()).enumerate() {
            g[k] = scale(T::of(2.0), &m.mul_vec(&lin));
            nu[k] = *pe - T::of(0.5) * dot(&lin, &g[k]) - dot(&g[k], &d);
        }
        u = mul_t_add(&t.p_ww, &g, &zero);
        v = mul_t_add(&v_t, &g, &zero);
        s = mul(&g, &u);
        for (k, row) in s.iter_mut().enumerate() {
            row[k] += T::ONE;
        }
        let (cof, det) = Sym3::from_mat(&s).cofactors();
        let det = det.max(det_floor(&s));
        let step = mat_vec(&u, &cof.mul_vec(&nu));
        let next = [
            prior[0] + step[0] / det,
            prior[1] + step[1] / det,
            prior[2] + step[2] / det,
        ];
        let moved = norm2(&sub(&next, &lin));
        lin = next;
        if !(moved > T::of(0.01) * (t.p_ww[0][0] + t.p_ww[1][1] + t.p_ww[2][2])) {
            break;
        }
    }
    let (nis_m, ln_m) = update3(t, (&u, &v), &s, &nu, gate);
    t.cost += ln_m;
    let mut j = zero;
    let mut nu = r.y;
    for k in 0..3 {
        let tw = r.t[k].mul_vec(&t.omega);
        nu[k] -= t.domega[k] + dot(&t.omega, &tw);
        j[k] = scale(T::of(2.0), &tw);
    }
    let u = mul_t_add(&t.p_ww, &j, &t.p_wd);
    let v = mul_t_add(&transpose(&t.p_wd), &j, &t.p_dd);
    let mut s = mul(&j, &u);
    for rr in 0..3 {
        for c in 0..3 {
            s[rr][c] += v[rr][c];
        }
        s[rr][rr] += r.var0[rr];
    }
    let (nis_d, ln_d) = update3(t, (&u, &v), &s, &nu, gate);
    t.cost += ln_d;
    nis_m + nis_d
}

/// Model G (and model F with m > 3): the update of a predicted track by the signed root nearest
/// it (its Ω, then its Ω′, with their variances); returns the normalised innovations (whose
/// log-determinants are added to the cost as well). Updates beyond `gate` are weighted down
/// to it.
#[inline(always)]
pub(super) fn update_by_root<T: Real>(t: &mut State<T>, cands: &[Candidate<T>], gate: T) -> T {
    let mut best: Option<(T, usize, Vec3<T>)> = None;
    let s_of = |c: &Candidate<T>| add_sym(&t.p_ww, &c.omega_cov);
    for (ci, c) in cands.iter().enumerate() {
        let sc = s_of(c);
        let (cof, det) = Sym3::from_mat(&sc).cofactors();
        let inv = cof.scaled(T::ONE / det.max(T::of(1e-30)));
        for sign in SIGNS {
            let nu = sub(&scale(sign_of(sign), &c.omega), &t.omega);
            let nis = inv.quad(&nu);
            if best.as_ref().is_none_or(|b| nis < b.0) {
                best = Some((nis, ci, nu));
            }
        }
    }
    let Some((_, ci, nu)) = best else {
        return T::ZERO;
    };
    let c = &cands[ci];
    let s = s_of(c);
    let (u, v) = (t.p_ww, transpose(&t.p_wd));
    let (nis_w, ln_w) = update3(t, (&u, &v), &s, &nu, gate);
    t.cost += ln_w;
    let (u, v) = (t.p_wd, t.p_dd);
    let mut s = t.p_dd;
    for k in 0..3 {
        s[k][k] += c.domega_var.max(T::of(1e-30));
    }
    let nu = sub(&c.domega, &t.domega);
    let (nis_d, ln_d) = update3(t, (&u, &v), &s, &nu, gate);
    t.cost += ln_d;
    nis_w + nis_d
}

/// A predicted track's update: by the readings (model F, m = 3) or by the signed root nearest
/// it; returns the normalised innovation.
#[inline(always)]
pub(super) fn update<T: Real>(
    t: &mut State<T>,
    readings: Option<&Readings<T>>,
    cands: &[Candidate<T>],
    gate: T,
) -> T {
    match readings {
        Some(r) => update_by_readings(t, r, gate),
        None => update_by_root(t, cands, gate),
    }
}

/// Labels a track with the signed root nearest its Ω.
#[inline(always)]
pub(super) fn label<T: Real>(t: &mut State<T>, cands: &[Candidate<T>]) {
    let mut best = T::of(f64::MAX);
    for (ci, c) in cands.iter().enumerate() {
        let (dm, dp) = (
            norm2(&sub(&t.omega, &c.omega)),
            norm2(&crate::linalg::add(&t.omega, &c.omega)),
        );
        if dm < best {
            best = dm;
            (t.candidate, t.sign) = (ci as u8, 1);
        }
        if dp < best {
            best = dp;
            (t.candidate, t.sign) = (ci as u8, -1);
        }
    }
}

/// The cost of a normalised innovation `nis` (twice the negative log-likelihood): itself up to
/// the gate `cap`, logarithmic beyond (a heavy-tailed likelihood).
#[inline(always)]
pub(super) fn robust<T: Real>(nis: T, cap: T) -> T {
    if nis > cap {
        cap * (T::ONE + (nis / cap).ln_approx())
    } else {
        nis
    }
}

/// A new track at the `sign` of candidate `c`: its own Ω and Ω′ (model F: from the readings at
/// that Ω) with their variances.
#[inline(always)]
pub(super) fn start<T: Real>(
    c: &Candidate<T>,
    readings: Option<&Readings<T>>,
    ci: usize,
    sign: i8,
    cost: T,
) -> State<T> {
    let omega = scale(sign_of(sign), &c.omega);
    let mut st = State {
        omega,
        domega: c.domega,
        cost,
        candidate: ci as u8,
        sign,
        p_ww: c.omega_cov.to_mat(),
        ..State::default()
    };
    // A root's first-order covariance can be huge (a nearly singular solve: up to 10¹²); a
    // track's Ω is known to its own size at least: the covariance is scaled down to that.
    let largest = st.p_ww[0][0].max(st.p_ww[1][1]).max(st.p_ww[2][2]);
    let bound = norm2(&omega) + T::ONE;
    if largest > bound {
        let f = bound / largest;
        for row in st.p_ww.iter_mut() {
            for x in row.iter_mut() {
                *x *= f;
            }
        }
    }
    for k in 0..3 {
        st.p_ww[k][k] = st.p_ww[k][k].max(T::of(1e-30));
    }
    match readings {
        Some(r) => {
            // Ω′ from the Ω′ rows at this Ω: `Ω′ = y − [ΩᵀTⱼΩ]ⱼ`, so its error is `−J δΩ`
            // plus the rows' noise (`J` the rows `2 (Tⱼ Ω)ᵀ`): correlated with Ω's.
            let mut j = [[T::ZERO; 3]; 3];
            for k in 0..3 {
                let tw = r.t[k].mul_vec(&omega);
                st.domega[k] = r.y[k] - dot(&omega, &tw);
                j[k] = scale(T::of(2.0), &tw);
            }
            let pj = mul_t_add(&st.p_ww, &j, &[[T::ZERO; 3]; 3]);
            st.p_dd = mul(&j, &pj);
            for k in 0..3 {
                st.p_dd[k][k] += r.var0[k];
                for l in 0..3 {
                    st.p_wd[k][l] = -pj[k][l];
                }
            }
        }
        None => {
            for k in 0..3 {
                st.p_dd[k][k] = c.domega_var.max(T::of(1e-30));
            }
        }
    }
    st
}

pub(super) fn propagate<T: Real>(s: &State<T>, dt: T) -> Vec3<T> {
    [
        s.omega[0] + s.domega[0] * dt,
        s.omega[1] + s.domega[1] * dt,
        s.omega[2] + s.domega[2] * dt,
    ]
}
