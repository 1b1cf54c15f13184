//! Arrangement families used by tests and scenarios: regular tetrahedra of tri-axial parts,
//! irregular sets of tri-axial parts, the 9-channel single-axis ballistometer, mixed noise.

use rand::Rng;

use crate::arrangement_file::{ArrangementFile, ChannelSpec, Noise, SensorSpec, IDENTITY};
use crate::noise::gaussian;

/// A uniformly random rotation matrix (sensor → body), rows.
pub fn random_rotation<R: Rng>(rng: &mut R) -> [[f64; 3]; 3] {
    let mut q = [gaussian(rng), gaussian(rng), gaussian(rng), gaussian(rng)];
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    for v in q.iter_mut() {
        *v /= n;
    }
    estimator_core::linalg::quat_to_mat(q)
}

fn part(name: String, position: [f64; 3], orientation: [[f64; 3]; 3], noise: f64) -> SensorSpec {
    SensorSpec {
        name,
        position,
        orientation: Some(orientation),
        noise: Some(Noise::Same(noise)),
        part: None,
        address: None,
    }
}

/// Four tri-axial parts at the vertices of a regular tetrahedron of circumradius `radius`
/// (12 channels), each with a random orientation when `rng` is given.
pub fn tetrahedron<R: Rng>(radius: f64, noise: f64, rng: Option<&mut R>) -> ArrangementFile {
    let k = radius / 3f64.sqrt();
    let vertices = [[k, k, k], [k, -k, -k], [-k, k, -k], [-k, -k, k]];
    let mut sensors = Vec::new();
    let mut rng = rng;
    for (i, v) in vertices.iter().enumerate() {
        let o = match rng.as_deref_mut() {
            Some(r) => random_rotation(r),
            None => IDENTITY,
        };
        sensors.push(part(format!("u{i}"), *v, o, noise));
    }
    ArrangementFile {
        model: Some("general".into()),
        channels: vec![],
        sensors,
    }
}

/// `parts` tri-axial parts at random positions within ±`extent` m, random orientations.
pub fn irregular<R: Rng>(rng: &mut R, parts: usize, extent: f64, noise: f64) -> ArrangementFile {
    let sensors = (0..parts)
        .map(|i| {
            let p = [
                rng.gen_range(-extent..extent),
                rng.gen_range(-extent..extent),
                rng.gen_range(-extent..extent),
            ];
            part(format!("u{i}"), p, random_rotation(rng), noise)
        })
        .collect();
    ArrangementFile {
        model: Some("general".into()),
        channels: vec![],
        sensors,
    }
}

/// The 9-channel single-axis ballistometer: two tangential sensors at the point `r` along each
/// axis, plus three radial ones at the midpoints of the edges joining those points.
pub fn nine_channel(r: f64, noise: f64) -> ArrangementFile {
    let mut channels = Vec::new();
    let e = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let names = ["x", "y", "z"];
    for i in 0..3 {
        let pos = [e[i][0] * r, e[i][1] * r, e[i][2] * r];
        for j in 0..3 {
            if j != i {
                channels.push(ChannelSpec {
                    name: format!("t{}{}", names[i], names[j]),
                    position: pos,
                    axis: e[j],
                    noise: Some(noise),
                });
            }
        }
    }
    let h = std::f64::consts::FRAC_1_SQRT_2;
    for (name, pos, axis) in [
        ("rxy", [r / 2.0, r / 2.0, 0.0], [h, h, 0.0]),
        ("rxz", [r / 2.0, 0.0, r / 2.0], [h, 0.0, h]),
        ("ryz", [0.0, r / 2.0, r / 2.0], [0.0, h, h]),
    ] {
        channels.push(ChannelSpec {
            name: name.into(),
            position: pos,
            axis,
            noise: Some(noise),
        });
    }
    ArrangementFile {
        model: Some("free-float".into()),
        channels,
        sensors: vec![],
    }
}

/// Irregular parts with mixed noise: every other part is `ratio` times noisier.
pub fn mixed_noise<R: Rng>(
    rng: &mut R,
    parts: usize,
    extent: f64,
    noise: f64,
    ratio: f64,
) -> ArrangementFile {
    let mut f = irregular(rng, parts, extent, noise);
    for (i, s) in f.sensors.iter_mut().enumerate() {
        if i % 2 == 1 {
            s.noise = Some(Noise::Same(noise * ratio));
        }
    }
    f
}
