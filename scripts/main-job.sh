#!/usr/bin/env bash
# The main job: the host simulator on the built-in scenario tetra-orbit (4 x ADXL355 read through
# their simulated SPI registers, torque-free tumble in orbit), the estimator over the record,
# errors against the truth and a plot (out/tetra-orbit/estimates.png).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo run --release -q --bin ballisto -- sim --scenario tetra-orbit --out out/tetra-orbit --estimate
