#!/usr/bin/env bash
# The main job: the firmware (its sampling and estimation tasks, drivers included) run by the host
# simulator on the built-in scenario tetra-orbit (4 x ADXL355 on a simulated SPI bus, external
# sync, torque-free tumble in orbit): the firmware's samples and estimates, the truth, errors
# against it, the firmware's counters and a plot (out/tetra-orbit/estimates.png).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo run --bin ballisto -- sim --firmware --scenario tetra-orbit --out out/tetra-orbit
