//! Accuracy of the truth: conservation laws and the analytic (Jacobi elliptic) solution of
//! torque-free rotation, and the environments (orbit gravity gradient, ground, origin offset,
//! drag and thrust).

use hal_sim::motion::{
    energy_momentum, to_inertial, Burn, Environment, Motion, Propagator, Rotation, Torque, G0,
    MU_EARTH, R_EARTH,
};

fn tumble(inertia: [f64; 3], omega0: [f64; 3], environment: Environment) -> Motion {
    Motion {
        rotation: Rotation::Euler {
            inertia,
            torque: Torque::None,
        },
        environment,
        omega0,
        attitude0: [1.0, 0.0, 0.0, 0.0],
        origin_offset: [0.0; 3],
        non_grav: [0.0; 3],
        burns: Vec::new(),
    }
}

#[test]
fn torque_free_conserves_energy_and_momentum_over_100_s() {
    let inertia = [1.0, 2.0, 3.0];
    let m = tumble(inertia, [0.3, 1.5, 0.4], Environment::Space);
    let tr = m.run(0.01, 10_001, 4);
    let (e0, h0) = energy_momentum(&inertia, &tr[0].omega);
    let (e1, h1) = energy_momentum(&inertia, &tr[10_000].omega);
    assert!(
        ((e1 - e0) / e0).abs() < 1e-9,
        "energy drift {}",
        (e1 - e0) / e0
    );
    assert!(
        ((h1 - h0) / h0).abs() < 1e-9,
        "momentum drift {}",
        (h1 - h0) / h0
    );
    // The inertial angular momentum vector is constant too (checks the attitude).
    let hi = |k: usize| {
        let w = tr[k].omega;
        to_inertial(
            &tr[k].attitude,
            &[inertia[0] * w[0], inertia[1] * w[1], inertia[2] * w[2]],
        )
    };
    let (a, b) = (hi(0), hi(10_000));
    let d = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
    assert!(d / h0 < 1e-8, "inertial momentum drift {}", d / h0);
}

/// Jacobi elliptic functions sn, cn, dn of `u` with parameter `m = k²` (0 ≤ m < 1) by the
/// arithmetic-geometric mean (Abramowitz & Stegun 16.4).
fn sn_cn_dn(u: f64, m: f64) -> (f64, f64, f64) {
    let mut a = vec![1.0];
    let mut c = vec![m.sqrt()];
    let mut b = (1.0 - m).sqrt();
    while c.last().unwrap().abs() > 1e-16 && a.len() < 40 {
        let an = *a.last().unwrap();
        a.push(0.5 * (an + b));
        c.push(0.5 * (an - b));
        b = (an * b).sqrt();
    }
    let n = a.len() - 1;
    if n == 0 {
        // m = 0: circular functions.
        return (u.sin(), u.cos(), 1.0);
    }
    let mut phi = (1u64 << n) as f64 * a[n] * u;
    let mut prev = phi;
    for i in (1..=n).rev() {
        prev = phi;
        phi = 0.5 * (phi + (c[i] / a[i] * phi.sin()).asin());
    }
    (phi.sin(), phi.cos(), phi.cos() / (prev - phi).cos())
}

#[test]
fn elliptic_functions_meet_their_identities() {
    for &(u, m) in &[(0.3, 0.2), (1.7, 0.9), (-2.2, 0.5), (5.0, 0.01)] {
        let (sn, cn, dn) = sn_cn_dn(u, m);
        assert!((sn * sn + cn * cn - 1.0).abs() < 1e-14);
        assert!((dn * dn + m * sn * sn - 1.0).abs() < 1e-14);
        // d sn / du = cn dn.
        let e = 1e-6;
        let d = (sn_cn_dn(u + e, m).0 - sn_cn_dn(u - e, m).0) / (2.0 * e);
        assert!((d - cn * dn).abs() < 1e-8, "u {u} m {m}");
    }
    // m = 0: circular functions.
    let (sn, cn, dn) = sn_cn_dn(0.7, 0.0);
    assert!((sn - 0.7f64.sin()).abs() < 1e-15 && (cn - 0.7f64.cos()).abs() < 1e-15);
    assert_eq!(dn, 1.0);
}

/// Torque-free asymmetric body, I1 < I2 < I3 and H² > 2 E I2 (Landau & Lifshitz §37): from
/// Ω(0) = (Ω10, 0, Ω30),
/// Ω1 = √((2E I3 − H²)/(I1 (I3 − I1))) cn τ, Ω2 = √((2E I3 − H²)/(I2 (I3 − I2))) sn τ,
/// Ω3 = √((H² − 2E I1)/(I3 (I3 − I1))) dn τ, τ = t √((I3 − I2)(H² − 2E I1)/(I1 I2 I3)),
/// k² = (I2 − I1)(2E I3 − H²) / ((I3 − I2)(H² − 2E I1)).
#[test]
fn torque_free_rotation_matches_the_jacobi_elliptic_solution() {
    let [i1, i2, i3]: [f64; 3] = [1.0, 2.0, 3.0];
    let (w10, w30): (f64, f64) = (1.2, 0.9);
    let two_e = i1 * w10 * w10 + i3 * w30 * w30;
    let h2 = (i1 * w10).powi(2) + (i3 * w30).powi(2);
    assert!(h2 > two_e * i2, "the case of Landau's formulas");
    let a1 = ((two_e * i3 - h2) / (i1 * (i3 - i1))).sqrt();
    let a2 = ((two_e * i3 - h2) / (i2 * (i3 - i2))).sqrt();
    let a3 = ((h2 - two_e * i1) / (i3 * (i3 - i1))).sqrt();
    let rate = ((i3 - i2) * (h2 - two_e * i1) / (i1 * i2 * i3)).sqrt();
    let m = (i2 - i1) * (two_e * i3 - h2) / ((i3 - i2) * (h2 - two_e * i1));
    assert!((a1 - w10).abs() < 1e-12 && (a3 - w30).abs() < 1e-12);

    let motion = tumble([i1, i2, i3], [w10, 0.0, w30], Environment::Space);
    let mut p = Propagator::new(motion, 0.0025);
    let mut worst: f64 = 0.0;
    let mut worst_domega: f64 = 0.0;
    for k in 0..=10_000 {
        // Sample instants off the integration grid, as parts sample.
        let t = k as f64 * 0.01 + 0.0013;
        let tr = p.truth_at(t);
        let (sn, cn, dn) = sn_cn_dn(rate * t, m);
        let w = [a1 * cn, a2 * sn, a3 * dn];
        for (a, b) in tr.omega.iter().zip(w.iter()) {
            worst = worst.max((a - b).abs());
        }
        // Ω′ from the derivatives of cn, sn, dn.
        let dw = [
            -a1 * rate * sn * dn,
            a2 * rate * cn * dn,
            -a3 * rate * m * sn * cn,
        ];
        for (a, b) in tr.domega.iter().zip(dw.iter()) {
            worst_domega = worst_domega.max((a - b).abs());
        }
    }
    eprintln!("max |Ω − Ω_analytic| over 100 s: {worst:.2e} rad/s, Ω′: {worst_domega:.2e}");
    assert!(
        worst < 1e-9,
        "Ω off the analytic solution by {worst:e} rad/s"
    );
    assert!(worst_domega < 1e-9, "Ω′ off by {worst_domega:e} rad/s²");
}

#[test]
fn propagator_answers_out_of_order_requests_consistently() {
    let m = tumble([1.0, 1.8, 2.5], [0.3, 1.7, -0.6], Environment::Space);
    let mut p = Propagator::new(m.clone(), 0.0025);
    let late = p.truth_at(3.0001);
    let early = p.truth_at(2.9937);
    let mut fresh = Propagator::new(m, 0.0025);
    let early2 = fresh.truth_at(2.9937);
    assert_eq!(early.omega, early2.omega);
    assert_eq!(p.truth_at(3.0001).omega, late.omega);
    // Restarting from 0 after the history has been dropped gives the same answer.
    let far = p.truth_at(30.0);
    let back = p.truth_at(0.5);
    assert_eq!(back.omega, fresh.truth_at(0.5).omega);
    assert_eq!(p.truth_at(30.0).omega, far.omega);
}

fn sym(a: &[f64; 6]) -> [[f64; 3]; 3] {
    [[a[0], a[3], a[4]], [a[3], a[1], a[5]], [a[4], a[5], a[2]]]
}

#[test]
fn orbit_gravity_gradient_is_traceless_with_the_radial_and_normal_eigenvalues() {
    let altitude = 400e3;
    let r = R_EARTH + altitude;
    let n2 = MU_EARTH / (r * r * r);
    let mut m = tumble(
        [1.0, 1.8, 2.5],
        [0.3, 1.7, -0.6],
        Environment::Orbit { altitude },
    );
    m.attitude0 = [0.8, 0.1, -0.5, 0.3];
    let mut p = Propagator::new(m.clone(), 0.0025);
    for &t in &[0.0, 17.3, 600.0] {
        let tr = p.truth_at(t);
        let g = m.gamma(t, &tr.attitude).0;
        // A = Γ + {Ω}².
        let w = tr.omega;
        let ww = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
        let a = tr.field.0;
        assert!((a[0] - g[0] - (w[0] * w[0] - ww)).abs() < 1e-14);
        assert!((a[5] - g[5] - w[1] * w[2]).abs() < 1e-14);
        assert!((g[0] + g[1] + g[2]).abs() < 1e-15 * n2);
        // The radial direction r̂ (body) is an eigenvector with eigenvalue −2n².
        let nt = n2.sqrt() * t;
        let c = hal_sim::motion::quat_matrix(&tr.attitude);
        let ri = [nt.cos(), nt.sin(), 0.0];
        let rb = [
            c[0][0] * ri[0] + c[1][0] * ri[1] + c[2][0] * ri[2],
            c[0][1] * ri[0] + c[1][1] * ri[1] + c[2][1] * ri[2],
            c[0][2] * ri[0] + c[1][2] * ri[1] + c[2][2] * ri[2],
        ];
        let gm = sym(&g);
        for i in 0..3 {
            let gr = gm[i][0] * rb[0] + gm[i][1] * rb[1] + gm[i][2] * rb[2];
            assert!((gr + 2.0 * n2 * rb[i]).abs() < 1e-12 * n2, "t {t}");
        }
        // The orbit normal (inertial z) has eigenvalue n².
        let zb = [c[2][0], c[2][1], c[2][2]];
        for i in 0..3 {
            let gz = gm[i][0] * zb[0] + gm[i][1] * zb[1] + gm[i][2] * zb[2];
            assert!((gz - n2 * zb[i]).abs() < 1e-12 * n2, "t {t}");
        }
    }
}

#[test]
fn ground_gives_one_g_up_and_the_origin_offset_adds_the_lever_arm() {
    let rho = [0.05, -0.02, 0.1];
    let m = Motion {
        rotation: Rotation::Turntable {
            axis: [0.0, 0.6, 0.8],
            rate: 2.0,
            spin_up: 4.0,
        },
        environment: Environment::Ground,
        omega0: [0.0; 3],
        attitude0: [0.9, 0.2, -0.3, 0.1],
        origin_offset: rho,
        non_grav: [0.0; 3],
        burns: Vec::new(),
    };
    let mut p = Propagator::new(m.clone(), 0.0025);
    let mut centred = m.clone();
    centred.origin_offset = [0.0; 3];
    let mut pc = Propagator::new(centred, 0.0025);
    for &t in &[0.5, 2.0, 7.0] {
        let tr = p.truth_at(t);
        let tc = pc.truth_at(t);
        // At the rotation centre: 1 g upward (inertial z), whatever the attitude.
        let up = to_inertial(&tc.attitude, &tc.sigma0);
        assert!(up[0].abs() < 1e-12 && up[1].abs() < 1e-12 && (up[2] - G0).abs() < 1e-12);
        // Γ = 0 on the ground: A = {Ω}².
        let w = tr.omega;
        let ww = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
        assert!((tr.field.0[0] - (w[0] * w[0] - ww)).abs() < 1e-12);
        // Offset origin: σ0 = f + Ω′ × ρ + {Ω}² ρ (eq. 12, rigid mount).
        let dw = tr.domega;
        let lever = [
            dw[1] * rho[2] - dw[2] * rho[1],
            dw[2] * rho[0] - dw[0] * rho[2],
            dw[0] * rho[1] - dw[1] * rho[0],
        ];
        let wr = w[0] * rho[0] + w[1] * rho[1] + w[2] * rho[2];
        for i in 0..3 {
            let centripetal = w[i] * wr - ww * rho[i];
            let expect = tc.sigma0[i] + lever[i] + centripetal;
            assert!((tr.sigma0[i] - expect).abs() < 1e-12, "t {t} axis {i}");
        }
        // Spin-up: Ω′ = rate / spin_up along the axis until 4 s, then 0.
        let expect = if t < 4.0 { 0.5 } else { 0.0 };
        assert!((dw[1] - 0.6 * expect).abs() < 1e-12 && (dw[2] - 0.8 * expect).abs() < 1e-12);
    }
}

#[test]
fn drag_is_inertial_and_a_burn_is_fixed_to_the_body_for_its_window() {
    let mut m = tumble([1.0, 1.8, 2.5], [0.3, 1.7, -0.6], Environment::Space);
    m.non_grav = [0.0, 0.0, -2e-6];
    m.burns = vec![Burn {
        start: 1.0,
        end: 3.0,
        accel: [0.4, 0.0, 0.0],
    }];
    let mut p = Propagator::new(m, 0.0025);
    for &(t, burning) in &[(0.5, false), (1.0, true), (2.9, true), (3.0, false)] {
        let tr = p.truth_at(t);
        let mut f = to_inertial(&tr.attitude, &tr.sigma0);
        if burning {
            let b = to_inertial(&tr.attitude, &[0.4, 0.0, 0.0]);
            for i in 0..3 {
                f[i] -= b[i];
            }
        }
        assert!(f[0].abs() < 1e-15 && f[1].abs() < 1e-15 && (f[2] + 2e-6).abs() < 1e-15);
    }
}
