#!/usr/bin/env bash
# The test command: formatting, lints, every test, the target build and its instruction
# counts under QEMU (which fail if the per-sample budget is exceeded).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo fmt --all -- --check
cargo clippy --workspace --all-targets -- -D warnings
cargo clippy -p qemu-bench --release --target thumbv7em-none-eabihf -- -D warnings
cargo clippy -p firmware --target thumbv7em-none-eabihf -- -D warnings
if cargo nextest --version >/dev/null 2>&1; then
  cargo nextest run --workspace --no-fail-fast
else
  cargo test --workspace --no-fail-fast
fi
cargo test --workspace --doc
cargo qemu-bench
