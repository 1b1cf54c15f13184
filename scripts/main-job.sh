#!/usr/bin/env bash
# The main job: ballisto estimate on the bundled example (tetrahedron of 4 tri-axial parts,
# torque-free tumble in orbit), then its errors against the truth.
set -euo pipefail
cd "$(dirname "$0")/.."
ex=examples/tetra-tumble
mkdir -p out
cargo run --release -q --bin ballisto -- estimate \
  --arrangement "$ex/arrangement.toml" --samples "$ex/samples.csv" --out out/estimates.csv
cargo run --release -q --bin ballisto -- compare "$ex/truth.csv" out/estimates.csv
