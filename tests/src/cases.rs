//! Test cases: arrangement families × motions (issue: "regular tetrahedra of tri-axial parts,
//! irregular arrangements of 5–8 tri-axial parts with random orientations, a 9-channel
//! single-axis ballistometer, mixed-noise parts; torque-free tumbling of an asymmetric body,
//! torque manoeuvres, 1 g on the ground with spin").

use ballisto_config::arrangement_file::{ArrangementFile, LoadedArrangement};
use estimator_core::Model;
use hal_sim::ideal::simulate_outputs;
use hal_sim::motion::{Environment, Motion, Rotation, Torque, Truth};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use test_fixtures::families;

/// Arrangement family.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// Regular tetrahedron of 4 tri-axial parts (12 channels), random orientations.
    Tetrahedron,
    /// 5–8 tri-axial parts at random positions and orientations.
    Irregular,
    /// 9 single-axis channels (model F only).
    NineChannel,
    /// 6 tri-axial parts, every other one 5× noisier.
    MixedNoise,
}

/// Motion family.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MotionKind {
    /// Torque-free tumbling of an asymmetric body in orbit.
    Tumble,
    /// Torque manoeuvres (sinusoidal torques) in space.
    Manoeuvre,
    /// 1 g on the ground, spinning on a tilted turntable.
    GroundSpin,
}

/// One generated case.
pub struct Case {
    /// Name for messages.
    pub name: String,
    /// Arrangement file.
    pub file: ArrangementFile,
    /// Loaded arrangement.
    pub loaded: LoadedArrangement,
    /// Truth per sample.
    pub truth: Vec<Truth>,
    /// Noisy outputs per sample (channel order).
    pub outputs: Vec<Vec<f64>>,
    /// Model to use.
    pub model: Model,
}

/// Noise of the "quiet" parts, m/s² RMS per sample (ADXL355-class at 100 Hz is ~0.002).
pub const NOISE: f64 = 0.003;
/// Sample interval, s.
pub const DT: f64 = 0.01;

/// Builds a case from a seed.
pub fn make(family: Family, motion: MotionKind, model: Model, seed: u64, samples: usize) -> Case {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let file = match family {
        Family::Tetrahedron => families::tetrahedron(0.15, NOISE, Some(&mut rng)),
        Family::Irregular => {
            let parts = rng.gen_range(5..=8);
            families::irregular(&mut rng, parts, 0.15, NOISE)
        }
        Family::NineChannel => families::nine_channel(0.15, NOISE),
        Family::MixedNoise => families::mixed_noise(&mut rng, 6, 0.15, NOISE, 5.0),
    };
    let loaded = file.load("case").expect("family arrangement loads");
    let dir = test_fixtures::families::random_rotation(&mut rng)[0];
    let rate = rng.gen_range(1.0..3.0);
    let m = match motion {
        MotionKind::Tumble => Motion {
            rotation: Rotation::Euler {
                inertia: [1.0, 1.8, 2.5],
                torque: Torque::None,
            },
            environment: Environment::Orbit { altitude: 400e3 },
            omega0: [dir[0] * rate, dir[1] * rate, dir[2] * rate],
            attitude0: [1.0, 0.0, 0.0, 0.0],
            origin_offset: [0.02, -0.01, 0.03],
            non_grav: [0.0; 3],
            burns: Vec::new(),
        },
        MotionKind::Manoeuvre => Motion {
            rotation: Rotation::Euler {
                inertia: [1.0, 1.5, 2.0],
                torque: Torque::Sinusoid {
                    amplitude: [1.5, 2.0, 2.5],
                    frequency: 0.3,
                    phase: [0.0, 1.0, 2.0],
                },
            },
            environment: Environment::Space,
            omega0: [dir[0] * rate, dir[1] * rate, dir[2] * rate],
            attitude0: [1.0, 0.0, 0.0, 0.0],
            origin_offset: [0.0; 3],
            non_grav: [0.05, 0.0, -0.02],
            burns: Vec::new(),
        },
        MotionKind::GroundSpin => Motion {
            rotation: Rotation::Turntable {
                axis: dir,
                rate,
                spin_up: 0.0,
            },
            environment: Environment::Ground,
            omega0: [0.0; 3],
            attitude0: [0.9, 0.2, -0.3, 0.1],
            origin_offset: [0.0; 3],
            non_grav: [0.0; 3],
            burns: Vec::new(),
        },
    };
    let truth = m.run(DT, samples, 4);
    let outputs = simulate_outputs(&loaded, &truth, true, seed ^ 0x5eed);
    Case {
        name: format!("{family:?}/{motion:?}/{model:?}/seed {seed}"),
        file,
        loaded,
        truth,
        outputs,
        model,
    }
}
