//! Rigid-body motion (truth): Euler's equations with attitude, or a turntable, in an
//! environment (free space, circular low Earth orbit, ground laboratory). At each sample instant
//! it gives σ0, Ω′, Ω, A = Γ + {Ω}² — from which paper eq. (4) gives every channel's output.

mod propagator;

pub use propagator::Propagator;

use estimator_core::linalg::{cross, mat_t_vec, mat_vec, Mat3, Sym3, Vec3};

/// Standard gravity, m/s² (estimator-core's).
pub use estimator_core::G0;
/// Earth's gravitational parameter, m³/s².
pub const MU_EARTH: f64 = 3.986_004_418e14;
/// Earth's mean radius, m.
pub const R_EARTH: f64 = 6_371_000.0;

/// Body torque profile (body frame, N·m).
#[derive(Clone, Debug, PartialEq)]
pub enum Torque {
    /// Torque-free.
    None,
    /// `τ_k(t) = amplitude_k sin(2π f t + phase_k)`.
    Sinusoid {
        /// Amplitude per axis.
        amplitude: Vec3<f64>,
        /// Frequency, Hz.
        frequency: f64,
        /// Phase per axis, rad.
        phase: Vec3<f64>,
    },
    /// Piecewise constant: `(start time, torque)`, sorted by time; zero before the first.
    Steps(Vec<(f64, Vec3<f64>)>),
}

impl Torque {
    /// Torque at time `t`.
    pub fn at(&self, t: f64) -> Vec3<f64> {
        match self {
            Torque::None => [0.0; 3],
            Torque::Sinusoid {
                amplitude,
                frequency,
                phase,
            } => {
                let w = 2.0 * std::f64::consts::PI * frequency * t;
                [
                    amplitude[0] * (w + phase[0]).sin(),
                    amplitude[1] * (w + phase[1]).sin(),
                    amplitude[2] * (w + phase[2]).sin(),
                ]
            }
            Torque::Steps(steps) => steps
                .iter()
                .rev()
                .find(|(t0, _)| t >= *t0)
                .map(|s| s.1)
                .unwrap_or([0.0; 3]),
        }
    }
}

/// How the body rotates.
#[derive(Clone, Debug, PartialEq)]
pub enum Rotation {
    /// Euler's equations `I Ω′ = τ − Ω × I Ω` with principal moments `inertia` (kg·m²) along the
    /// body axes.
    Euler {
        /// Principal moments of inertia.
        inertia: Vec3<f64>,
        /// Body torque.
        torque: Torque,
    },
    /// A turntable: rotation about the fixed body axis `axis` (unit) at `rate` rad/s, reached
    /// from rest with constant angular acceleration over `spin_up` seconds (0: constant rate).
    Turntable {
        /// Spin axis (body frame).
        axis: Vec3<f64>,
        /// Final rate, rad/s.
        rate: f64,
        /// Spin-up time, s.
        spin_up: f64,
    },
    /// A calibration schedule: rest, rotations between poses and spins about body axes, one
    /// segment after another from rest ([`Segment`]).
    Schedule(Vec<Segment>),
}

/// One segment of a calibration schedule, from `start` to `end` (s). Every segment starts
/// and ends at rest with zero angular acceleration, so the rate is continuous and the
/// segments can follow one another in any order.
#[derive(Clone, Debug, PartialEq)]
pub struct Segment {
    /// Start, s.
    pub start: f64,
    /// End, s.
    pub end: f64,
    /// What the body does.
    pub kind: SegmentKind,
}

/// What the body does in a [`Segment`].
#[derive(Clone, Debug, PartialEq)]
pub enum SegmentKind {
    /// At rest (a static pose).
    Rest,
    /// Turns by `angle` (rad) about the body axis `axis` (unit), the rate following
    /// `(angle/T)(1 − cos 2πu)` over the segment (u = 0 … 1).
    Rotate {
        /// Axis, body frame, unit.
        axis: Vec3<f64>,
        /// Angle, rad.
        angle: f64,
    },
    /// Spins about the body axis `axis` (unit) at `rate` (rad/s), reached from rest over
    /// `ramp` seconds and back to rest over the last `ramp` seconds (raised-cosine ramps).
    Spin {
        /// Axis, body frame, unit.
        axis: Vec3<f64>,
        /// Rate, rad/s.
        rate: f64,
        /// Ramp time, s.
        ramp: f64,
    },
}

impl Segment {
    /// The angular acceleration (body) at `t` inside the segment (zero outside).
    pub fn angular_acceleration(&self, t: f64) -> Vec3<f64> {
        if !(self.start..self.end).contains(&t) {
            return [0.0; 3];
        }
        let tau = std::f64::consts::TAU;
        let (axis, acc) = match &self.kind {
            SegmentKind::Rest => return [0.0; 3],
            SegmentKind::Rotate { axis, angle } => {
                let d = self.end - self.start;
                let u = (t - self.start) / d;
                (axis, angle / d * tau / d * (tau * u).sin())
            }
            SegmentKind::Spin { axis, rate, ramp } => {
                let up = t - self.start;
                let down = self.end - t;
                let acc = if *ramp <= 0.0 {
                    0.0
                } else if up < *ramp {
                    rate * std::f64::consts::PI / (2.0 * ramp)
                        * (std::f64::consts::PI * up / ramp).sin()
                } else if down < *ramp {
                    -rate * std::f64::consts::PI / (2.0 * ramp)
                        * (std::f64::consts::PI * down / ramp).sin()
                } else {
                    0.0
                };
                (axis, acc)
            }
        };
        [axis[0] * acc, axis[1] * acc, axis[2] * acc]
    }
}

/// Where the body is.
#[derive(Clone, Debug, PartialEq)]
pub enum Environment {
    /// Free float, no gravity gradient.
    Space,
    /// Circular orbit at `altitude` m: gravity gradient `Γ = n² (I − 3 r̂ r̂ᵀ)` (body frame).
    Orbit {
        /// Altitude above the mean Earth radius, m.
        altitude: f64,
    },
    /// Ground laboratory: constant 1 g specific force upward (inertial z), Γ = 0.
    Ground,
}

/// A motion scenario.
#[derive(Clone, Debug, PartialEq)]
pub struct Motion {
    /// Rotation model.
    pub rotation: Rotation,
    /// Environment.
    pub environment: Environment,
    /// Ω at t = 0 (body frame; Euler only).
    pub omega0: Vec3<f64>,
    /// Attitude at t = 0 (body → inertial quaternion `[w, x, y, z]`).
    pub attitude0: [f64; 4],
    /// Instrument origin seen from the centre of mass (free float) or from the rotation centre
    /// (ground), body frame, m.
    pub origin_offset: Vec3<f64>,
    /// Constant non-gravitational specific force (drag), inertial frame, m/s².
    pub non_grav: Vec3<f64>,
    /// Thruster burns: non-gravitational specific force fixed to the body over time windows.
    pub burns: Vec<Burn>,
}

/// A thruster burn: specific force `accel` (body frame, m/s²) for `start ≤ t < end`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Burn {
    /// Start time, s.
    pub start: f64,
    /// End time, s.
    pub end: f64,
    /// Specific force during the burn, body frame, m/s².
    pub accel: Vec3<f64>,
}

impl Motion {
    /// Non-gravitational specific force in the body frame at time `t` for the body → inertial
    /// rotation `c`: drag (inertial) plus any burn (body).
    fn non_gravitational(&self, t: f64, c: &Mat3<f64>) -> Vec3<f64> {
        let mut f = mat_t_vec(c, &self.non_grav);
        for b in self.burns.iter().filter(|b| b.start <= t && t < b.end) {
            for (fi, ai) in f.iter_mut().zip(b.accel.iter()) {
                *fi += ai;
            }
        }
        f
    }
}

/// The field at the instrument origin at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Truth {
    /// Time, s.
    pub t: f64,
    /// Specific force at the origin, m/s² (body).
    pub sigma0: Vec3<f64>,
    /// Angular acceleration, rad/s² (body).
    pub domega: Vec3<f64>,
    /// Angular rate, rad/s (body).
    pub omega: Vec3<f64>,
    /// A = Γ + {Ω}² (body).
    pub field: Sym3<f64>,
    /// Attitude (body → inertial quaternion).
    pub attitude: [f64; 4],
}

impl Truth {
    /// Ideal output of a channel (paper eq. 4): `s·σ0 + (R × s)·Ω′ + s·A R`.
    pub fn channel(&self, position: &Vec3<f64>, axis: &Vec3<f64>) -> f64 {
        let d = |a: &Vec3<f64>, b: &Vec3<f64>| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        d(axis, &self.sigma0)
            + d(&cross(position, axis), &self.domega)
            + d(axis, &self.field.mul_vec(position))
    }
}

/// Body → inertial rotation matrix of a quaternion.
pub fn quat_matrix(q: &[f64; 4]) -> Mat3<f64> {
    estimator_core::linalg::quat_to_mat(*q)
}

fn quat_mul(a: &[f64; 4], b: &[f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

impl Motion {
    /// Ω′ for state `omega` at time `t`.
    pub fn angular_acceleration(&self, t: f64, omega: &Vec3<f64>) -> Vec3<f64> {
        match &self.rotation {
            Rotation::Euler { inertia, torque } => {
                let tau = torque.at(t);
                let iw = [
                    inertia[0] * omega[0],
                    inertia[1] * omega[1],
                    inertia[2] * omega[2],
                ];
                let gyro = cross(omega, &iw);
                [
                    (tau[0] - gyro[0]) / inertia[0],
                    (tau[1] - gyro[1]) / inertia[1],
                    (tau[2] - gyro[2]) / inertia[2],
                ]
            }
            Rotation::Schedule(segments) => segments
                .iter()
                .find(|s| s.start <= t && t < s.end)
                .map_or([0.0; 3], |s| s.angular_acceleration(t)),
            Rotation::Turntable {
                axis,
                rate,
                spin_up,
            } => {
                let acc = if *spin_up > 0.0 && t < *spin_up {
                    rate / spin_up
                } else {
                    0.0
                };
                [axis[0] * acc, axis[1] * acc, axis[2] * acc]
            }
        }
    }

    pub(crate) fn initial_omega(&self) -> Vec3<f64> {
        match &self.rotation {
            Rotation::Euler { .. } => self.omega0,
            Rotation::Schedule(_) => [0.0; 3],
            Rotation::Turntable {
                axis,
                rate,
                spin_up,
            } => {
                let r = if *spin_up > 0.0 { 0.0 } else { *rate };
                [axis[0] * r, axis[1] * r, axis[2] * r]
            }
        }
    }

    /// Truth at the instants `k dt`, `k = 0..n`, integrating with `substeps` RK4 steps per
    /// sample interval.
    pub fn run(&self, dt: f64, n: usize, substeps: usize) -> Vec<Truth> {
        let mut p = Propagator::new(self.clone(), dt / substeps.max(1) as f64);
        (0..n).map(|k| p.truth_at(k as f64 * dt)).collect()
    }

    pub(crate) fn deriv(&self, t: f64, q: &[f64; 4], w: &Vec3<f64>) -> ([f64; 4], Vec3<f64>) {
        let dq = quat_mul(q, &[0.0, w[0], w[1], w[2]]);
        (
            [0.5 * dq[0], 0.5 * dq[1], 0.5 * dq[2], 0.5 * dq[3]],
            self.angular_acceleration(t, w),
        )
    }

    pub(crate) fn rk4(&self, t: f64, q: &[f64; 4], w: &Vec3<f64>, h: f64) -> ([f64; 4], Vec3<f64>) {
        let add4 = |a: &[f64; 4], b: &[f64; 4], k: f64| {
            [
                a[0] + k * b[0],
                a[1] + k * b[1],
                a[2] + k * b[2],
                a[3] + k * b[3],
            ]
        };
        let add3 = |a: &Vec3<f64>, b: &Vec3<f64>, k: f64| {
            [a[0] + k * b[0], a[1] + k * b[1], a[2] + k * b[2]]
        };
        let (q1, w1) = self.deriv(t, q, w);
        let (q2, w2) = self.deriv(t + h / 2.0, &add4(q, &q1, h / 2.0), &add3(w, &w1, h / 2.0));
        let (q3, w3) = self.deriv(t + h / 2.0, &add4(q, &q2, h / 2.0), &add3(w, &w2, h / 2.0));
        let (q4, w4) = self.deriv(t + h, &add4(q, &q3, h), &add3(w, &w3, h));
        let mut qn = [0.0; 4];
        for i in 0..4 {
            qn[i] = q[i] + h / 6.0 * (q1[i] + 2.0 * q2[i] + 2.0 * q3[i] + q4[i]);
        }
        let norm = qn.iter().map(|v| v * v).sum::<f64>().sqrt();
        for v in qn.iter_mut() {
            *v /= norm;
        }
        let mut wn = [0.0; 3];
        for i in 0..3 {
            wn[i] = w[i] + h / 6.0 * (w1[i] + 2.0 * w2[i] + 2.0 * w3[i] + w4[i]);
        }
        (qn, wn)
    }

    /// Gravity-gradient tensor Γ (body frame) at time `t` and attitude `q`.
    pub fn gamma(&self, t: f64, q: &[f64; 4]) -> Sym3<f64> {
        match self.environment {
            Environment::Orbit { altitude } => {
                let r = R_EARTH + altitude;
                let n2 = MU_EARTH / (r * r * r);
                let nt = n2.sqrt() * t;
                let rhat_i = [nt.cos(), nt.sin(), 0.0];
                let c = quat_matrix(q); // body → inertial
                let rb = mat_t_vec(&c, &rhat_i);
                let mut g = Sym3([
                    n2 * (1.0 - 3.0 * rb[0] * rb[0]),
                    n2 * (1.0 - 3.0 * rb[1] * rb[1]),
                    n2 * (1.0 - 3.0 * rb[2] * rb[2]),
                    -3.0 * n2 * rb[0] * rb[1],
                    -3.0 * n2 * rb[0] * rb[2],
                    -3.0 * n2 * rb[1] * rb[2],
                ]);
                // Exactly traceless.
                let tr = g.trace() / 3.0;
                for i in 0..3 {
                    g.0[i] -= tr;
                }
                g
            }
            _ => Sym3::zero(),
        }
    }

    pub(crate) fn truth(&self, t: f64, q: &[f64; 4], w: &Vec3<f64>) -> Truth {
        let domega = self.angular_acceleration(t, w);
        let gamma = self.gamma(t, q);
        let field = gamma.add_scaled(1.0, &Sym3::skew_squared(w));
        let c = quat_matrix(q);
        // Specific force at the reference point (centre of mass / rotation centre), body frame.
        let mut base = self.non_gravitational(t, &c);
        if self.environment == Environment::Ground {
            let up = mat_t_vec(&c, &[0.0, 0.0, G0]);
            base = [base[0] + up[0], base[1] + up[1], base[2] + up[2]];
        }
        // Paper eq. (12) with a rigid mount: σ0 = f + (Γ + {Ω′} + {Ω}²) ρ.
        let rho = &self.origin_offset;
        let lever = cross(&domega, rho);
        let fr = field.mul_vec(rho);
        let sigma0 = [
            base[0] + lever[0] + fr[0],
            base[1] + lever[1] + fr[1],
            base[2] + lever[2] + fr[2],
        ];
        Truth {
            t,
            sigma0,
            domega,
            omega: *w,
            field,
            attitude: *q,
        }
    }
}

/// Kinetic energy `½ Ωᵀ I Ω` and angular momentum magnitude `|I Ω|` (for conservation checks).
pub fn energy_momentum(inertia: &Vec3<f64>, w: &Vec3<f64>) -> (f64, f64) {
    let iw = [inertia[0] * w[0], inertia[1] * w[1], inertia[2] * w[2]];
    let e = 0.5 * (iw[0] * w[0] + iw[1] * w[1] + iw[2] * w[2]);
    (e, (iw[0] * iw[0] + iw[1] * iw[1] + iw[2] * iw[2]).sqrt())
}

/// Rotates a body vector to inertial.
pub fn to_inertial(q: &[f64; 4], v: &Vec3<f64>) -> Vec3<f64> {
    mat_vec(&quat_matrix(q), v)
}
