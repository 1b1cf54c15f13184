//! The named scenarios shipped with `ballisto` (the files in `hal-sim/scenarios/`).

/// Names, in the order `--help` lists them.
pub const NAMES: [&str; 8] = [
    "tetra-orbit",
    "nine-channel",
    "ground-spin-mixed",
    "tetra-orbit-faults",
    "ground-calibration",
    "orbit-identify",
    "ground-thermal",
    "tetra-orbit-thermal",
];

/// The TOML text of a named scenario.
pub fn text(name: &str) -> Option<&'static str> {
    Some(match name {
        "tetra-orbit" => include_str!("../../scenarios/tetra-orbit.toml"),
        "nine-channel" => include_str!("../../scenarios/nine-channel.toml"),
        "ground-spin-mixed" => include_str!("../../scenarios/ground-spin-mixed.toml"),
        "tetra-orbit-faults" => include_str!("../../scenarios/tetra-orbit-faults.toml"),
        "ground-calibration" => include_str!("../../scenarios/ground-calibration.toml"),
        "orbit-identify" => include_str!("../../scenarios/orbit-identify.toml"),
        "ground-thermal" => include_str!("../../scenarios/ground-thermal.toml"),
        "tetra-orbit-thermal" => include_str!("../../scenarios/tetra-orbit-thermal.toml"),
        _ => return None,
    })
}
