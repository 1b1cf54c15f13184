//! A deterministic benchmark scenario shared by the QEMU instruction counts and the host
//! criterion benchmark: a tetrahedral (12-channel) or doubled (24-channel) arrangement of
//! tri-axial parts and an analytic tumbling motion, in plain `f64` (no allocation).

use estimator_core::linalg::{cross, dot, Sym3};
use estimator_core::Arrangement;

/// Channels of the 12-channel arrangement: 4 tri-axial parts on a regular tetrahedron.
pub fn arrangement<const CAP: usize>(channels: usize) -> Arrangement<CAP> {
    let mut a = Arrangement::<CAP>::new();
    let k = 0.1;
    let vertices = [[k, k, k], [k, -k, -k], [-k, k, -k], [-k, -k, k]];
    let mut part = 0;
    while a.len() < channels {
        let v = vertices[part % 4];
        // Every second tetrahedron is rotated and scaled so 24 channels are not duplicates.
        let (s, c) = if part >= 4 {
            (0.6f64, 0.8f64)
        } else {
            (0.0, 1.0)
        };
        let pos = [
            v[0] * (1.0 + 0.5 * s),
            c * v[1] - s * v[2],
            s * v[1] + c * v[2],
        ];
        for axis in [[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]] {
            if a.len() < channels {
                // Positions and axes are valid by construction.
                let _ = a.push(pos, axis, 0.002);
            }
        }
        part += 1;
    }
    // Each tri-axial part's channels are one part (the protection levels' faults).
    let mut parts = [0u8; CAP];
    for (i, p) in parts.iter_mut().enumerate() {
        *p = (i / 3) as u8;
    }
    a.set_parts(&parts);
    a
}

/// The field at time `t`: a smooth tumble (σ0, Ω′, Ω, A = {Ω}²).
pub fn field(t: f64) -> ([f64; 3], [f64; 3], [f64; 3], Sym3<f64>) {
    let w = [
        1.2 * libm::cos(0.7 * t) + 0.3,
        0.9 * libm::sin(0.5 * t) - 0.4,
        0.8 + 0.5 * libm::sin(0.9 * t),
    ];
    let dw = [
        -0.84 * libm::sin(0.7 * t),
        0.45 * libm::cos(0.5 * t),
        0.45 * libm::cos(0.9 * t),
    ];
    let sigma0 = [0.02 * libm::sin(t), -0.01, 0.03 * libm::cos(0.3 * t)];
    (sigma0, dw, w, Sym3::skew_squared(&w))
}

/// Channel outputs (paper eq. 4) at time `t`, with deterministic Gaussian pseudo-noise of
/// standard deviation `noise` (the arrangement's declared channel noise: a friendlier noise
/// would undercount the Gauss–Newton passes the estimator takes on real data).
pub fn outputs<const CAP: usize>(arr: &Arrangement<CAP>, t: f64, noise: f64, out: &mut [f64]) {
    let (s0, dw, _w, a) = field(t);
    for (i, (ch, o)) in arr.channels().iter().zip(out.iter_mut()).enumerate() {
        let ideal = dot(&ch.axis, &s0)
            + dot(&cross(&ch.position, &ch.axis), &dw)
            + dot(&ch.axis, &a.mul_vec(&ch.position));
        *o = ideal + noise * gaussian(i, t);
    }
}

/// A standard normal draw for channel `i` at time `t`: Box–Muller on two hashed uniforms, so
/// the QEMU count and the host benchmark see the same noise without a generator's state.
pub fn gaussian(i: usize, t: f64) -> f64 {
    let uniform = |salt: f64| {
        let h = libm::sin((i as f64 + 1.0) * 12.9898 + t * 78.233 + salt) * 43758.5453;
        h - libm::floor(h)
    };
    // In (0, 1]: the logarithm stays finite.
    let u1 = 1.0 - uniform(0.0);
    let u2 = uniform(4.1414);
    libm::sqrt(-2.0 * libm::log(u1)) * libm::cos(2.0 * core::f64::consts::PI * u2)
}

/// Sample interval of the scenario, s.
pub const DT: f64 = 0.01;
