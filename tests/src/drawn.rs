//! Scenarios drawn at random for the identification's generality checks: arrays, parts'
//! datasheet errors and motions nothing was tuned on.

use hal_sim::scenario::Scenario;

/// A scenario the identification was not tuned on: `parts` ADXL355 at random places 0.08–0.15
/// m from the origin in random orientations, each with datasheet-typical errors drawn (bias
/// ±0.2 m/s², scale ±1 %, cross-axis ±0.9 %, mounted off by ±0.5 mm and ±5 mrad), the origin
/// ±3 cm from the centre of mass, a random tumble (|Ω0| 0.8–2 rad/s, inertia 1–3 kg m²)
/// under a random attitude-control torque, and the reference gyro at `reference_hz`.
pub fn drawn_case(seed: u64, parts: usize, reference_hz: f64) -> Scenario {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut u = |a: f64, b: f64| rng.gen_range(a..b);
    let vec3 = |u: &mut dyn FnMut(f64, f64) -> f64, a: f64| [u(-a, a), u(-a, a), u(-a, a)];
    let fmt = |v: [f64; 3]| format!("[{:.6}, {:.6}, {:.6}]", v[0], v[1], v[2]);
    let direction = |u: &mut dyn FnMut(f64, f64) -> f64| loop {
        let v = [u(-1.0, 1.0), u(-1.0, 1.0), u(-1.0, 1.0)];
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if n > 0.2 && n <= 1.0 {
            break v.map(|x| x / n);
        }
    };
    let omega = u(0.8, 2.0);
    let w0 = direction(&mut u).map(|x| x * omega);
    // Principal moments of a rigid body: each at most the sum of the other two.
    let inertia = loop {
        let j = [u(1.0, 3.0), u(1.0, 3.0), u(1.0, 3.0)];
        if j[0] + j[1] >= j[2] && j[1] + j[2] >= j[0] && j[0] + j[2] >= j[1] {
            break j;
        }
    };
    let amplitude = [u(0.1, 0.4), u(0.1, 0.4), u(0.1, 0.4)];
    let tau = std::f64::consts::TAU;
    let (frequency, phase) = (u(0.08, 0.25), [u(0.0, tau), u(0.0, tau), u(0.0, tau)]);
    let origin = vec3(&mut u, 0.03);
    let mut text = format!(
        "rate = 100.0\nduration = 60.0\nseed = {seed}\nmodel = \"general\"\n\
         [body]\ninertia = {}\nomega0 = {}\norigin_offset = {}\n\
         torque = {{ kind = \"sinusoid\", amplitude = {}, frequency = {frequency:.4}, phase = {} }}\n\
         [environment]\nkind = \"orbit\"\naltitude = 400e3\n\
         [reference]\nnoise_density = 1e-4\nbias = [0.0, 0.0, 0.0]\nrate = {reference_hz}\n\
         [[bus]]\nname = \"spi1\"\nkind = \"spi\"\nclock_hz = 10e6\n",
        fmt(inertia),
        fmt(w0),
        fmt(origin),
        fmt(amplitude),
        fmt(phase)
    );
    for i in 0..parts {
        let r = u(0.08, 0.15);
        let at = direction(&mut u).map(|x| x * r);
        // A random rotation: x a random direction, y a random one made orthogonal to it.
        let x = direction(&mut u);
        let y = loop {
            let d = direction(&mut u);
            let dot = d[0] * x[0] + d[1] * x[1] + d[2] * x[2];
            let y0 = [d[0] - dot * x[0], d[1] - dot * x[1], d[2] - dot * x[2]];
            let ny = (y0[0] * y0[0] + y0[1] * y0[1] + y0[2] * y0[2]).sqrt();
            if ny > 0.3 {
                break y0.map(|v| v / ny);
            }
        };
        let z = [
            x[1] * y[2] - x[2] * y[1],
            x[2] * y[0] - x[0] * y[2],
            x[0] * y[1] - x[1] * y[0],
        ];
        let row = |v: [f64; 3]| format!("[{:.12}, {:.12}, {:.12}]", v[0], v[1], v[2]);
        let rows = format!("[{}, {}, {}]", row(x), row(y), row(z));
        let cross = format!(
            "[[0, {:.5}, {:.5}], [{:.5}, 0, {:.5}], [{:.5}, {:.5}, 0]]",
            u(-0.009, 0.009),
            u(-0.009, 0.009),
            u(-0.009, 0.009),
            u(-0.009, 0.009),
            u(-0.009, 0.009),
            u(-0.009, 0.009)
        );
        let scale = [
            1.0 + u(-0.01, 0.01),
            1.0 + u(-0.01, 0.01),
            1.0 + u(-0.01, 0.01),
        ];
        text += &format!(
            "[[part]]\nname = \"u{i}\"\ntype = \"adxl355\"\nbus = \"spi1\"\ncs = {i}\n\
             position = {}\norientation = {rows}\nnoise_density = 2.2e-4\nclock_ppm = {:.1}\n\
             bias = {}\nscale = {}\ncross = {cross}\nposition_error = {}\norientation_error = {}\n",
            fmt(at),
            u(-50.0, 50.0),
            fmt(vec3(&mut u, 0.2)),
            fmt(scale),
            fmt(vec3(&mut u, 0.0005)),
            fmt(vec3(&mut u, 0.005)),
        );
    }
    Scenario::parse(&text, &format!("drawn case {seed}")).expect("a valid drawn scenario")
}
