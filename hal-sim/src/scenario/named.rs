//! The named scenarios shipped with `ballisto` (the files in `hal-sim/scenarios/`).

/// Names, in the order `--help` lists them.
pub const NAMES: [&str; 6] = [
    "tetra-orbit",
    "nine-channel",
    "ground-spin-mixed",
    "tetra-orbit-faults",
    "ground-calibration",
    "orbit-identify",
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
        _ => return None,
    })
}
