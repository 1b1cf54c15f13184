//! Regenerates the bundled example `examples/tetra-tumble/` (arrangement, samples, truth):
//! four tri-axial parts on a regular tetrahedron (circumradius 0.15 m, 0.003 m/s² noise),
//! torque-free tumbling of an asymmetric body in low Earth orbit, 100 Hz for 20 s.
//!
//! `cargo run -p e2e-tests --example gen_example -- DIR`

use std::path::PathBuf;

use ballisto::samples_csv::write_samples;
use ballisto::truth_csv::write_truth;
use hal_sim::ideal::simulate_outputs;
use hal_sim::motion::{Environment, Motion, Rotation, Torque};
use rand::SeedableRng;
use test_fixtures::families;

fn main() {
    let dir = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "examples/tetra-tumble".into()),
    );
    std::fs::create_dir_all(&dir).expect("create the output directory");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2026);
    let file = families::tetrahedron(0.15, 0.003, Some(&mut rng));
    std::fs::write(dir.join("arrangement.toml"), file.to_toml()).expect("write arrangement.toml");
    let loaded = file
        .load("arrangement.toml")
        .expect("the family arrangement is valid");
    let motion = Motion {
        rotation: Rotation::Euler {
            inertia: [1.0, 1.8, 2.5],
            torque: Torque::None,
        },
        environment: Environment::Orbit { altitude: 400e3 },
        omega0: [0.3, 1.7, -0.6],
        attitude0: [1.0, 0.0, 0.0, 0.0],
        origin_offset: [0.02, -0.01, 0.03],
        non_grav: [0.0; 3],
        burns: Vec::new(),
    };
    let truth = motion.run(0.01, 2000, 4);
    let out = simulate_outputs(&loaded, &truth, true, 7);
    write_samples(&dir.join("samples.csv"), &loaded.names, &truth, &out)
        .expect("write samples.csv");
    write_truth(&dir.join("truth.csv"), &truth).expect("write truth.csv");
    println!(
        "wrote {} ({} samples, {} channels)",
        dir.display(),
        truth.len(),
        loaded.names.len()
    );
}
