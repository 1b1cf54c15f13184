#!/usr/bin/env bash
# The test command: formatting, lints, every test, the target builds and their figures:
# instruction counts of the estimate under QEMU in the flashed profile (which fail if a mean
# exceeds the per-sample budget), the STM32H743 build, the QEMU board running the built-in
# scenario (boot 1: identification and commit; a reset; boot 2 on the stored calibration, a part
# stuck and isolated, then its sets stop; the watchdog's reset; boot 3 on the stored calibration)
# with the boots' telemetry decoded and checked against the host, the same
# board on QEMU's Cortex-M7 identifying a tumble without a reference (scripts/qemu-board-m7.sh),
# and the flash / RAM report
# (which fails if the STM32H743 build is over its budget).
set -euo pipefail
cd "$(dirname "$0")/.."
started=$SECONDS
step() { echo "test.sh [$((SECONDS - started)) s]: $*" >&2; }
step "formatting and lints"
cargo fmt --all -- --check
cargo clippy --workspace --all-targets -- -D warnings
cargo clippy -p qemu-bench --profile flight --target thumbv7em-none-eabihf -- -D warnings
cargo clippy -p ballisto-fw --target thumbv7em-none-eabihf -- -D warnings
cargo clippy -p board-qemu --profile flight --target thumbv7em-none-eabihf -- -D warnings
(cd firmware/boards/stm32h743 && cargo clippy --profile flight -- -D warnings)
step "the tests"
cargo nextest run --workspace --no-fail-fast
step "the doc tests"
cargo test --workspace --doc
step "instruction counts under QEMU"
QEMU_BENCH_STRICT=1 cargo qemu-bench
bash scripts/qemu-bench-m7.sh

# The boards. STM32H743: built from its directory (its .cargo/config.toml: Cortex-M7 FPU,
# probe-rs runner). QEMU: runs the built-in scenario, writes out/qemu/telemetry.bin.
# The STM32H743 image from a user's board file (BALLISTO_ARRANGEMENT, read by its build.rs), then
# the built-in board's, which the size report measures.
step "the boards"
(cd firmware/boards/stm32h743 && BALLISTO_ARRANGEMENT=example-board.toml cargo build --profile flight)
(cd firmware/boards/stm32h743 && cargo build --profile flight)
step "the QEMU board's built-in scenario"
cargo run -p board-qemu --profile flight --target thumbv7em-none-eabihf
# The host side with the binaries the tests built (no second, release build of the host crates).
cargo build -q --bin ballisto
./target/debug/ballisto decode out/qemu/telemetry-boot1.bin --out out/qemu/estimates-boot1.csv \
  --log out/qemu/log-boot1.txt
./target/debug/ballisto decode out/qemu/telemetry.bin --out out/qemu/estimates.csv \
  --log out/qemu/log.txt
./target/debug/ballisto decode out/qemu/telemetry-boot3.bin --out out/qemu/estimates-boot3.csv \
  --log out/qemu/log-boot3.txt
BOARD_QEMU_TELEMETRY="$PWD/out/qemu/telemetry.bin" \
  cargo nextest run -p e2e-tests --test builtin_scenario --run-ignored only --no-capture
step "the QEMU board's tumble on the Cortex-M7 (identification without a reference)"
bash scripts/qemu-board-m7.sh
step "flash and RAM"
bash scripts/size-report.sh
step "done"
