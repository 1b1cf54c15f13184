#!/usr/bin/env bash
# The test command: formatting, lints, every test, the target builds and their figures:
# instruction counts of the estimate under QEMU in the flashed profile (which fail if a mean
# exceeds the per-sample budget), the STM32H743 build, the QEMU board running the built-in
# scenario (boot 1: identification and commit; a reset; boot 2 on the stored calibration, a part
# stuck and isolated, then its sets stop; the watchdog's reset; boot 3 on the stored calibration)
# with the boots' telemetry decoded and checked against the host, and the flash / RAM report
# (which fails if the STM32H743 build is over its budget). The long sweeps, the Cortex-M7 counts
# and the QEMU board's tumble on the Cortex-M7 are `scripts/validate.sh`'s.
set -euo pipefail
cd "$(dirname "$0")/.."
# One run from scratch: incremental compilation's caches cost a fifth more build time here and
# never pay back within the run (set CARGO_INCREMENTAL=1 to keep them).
export CARGO_INCREMENTAL="${CARGO_INCREMENTAL:-0}"
started=$SECONDS
step() { echo "test.sh [$((SECONDS - started)) s]: $*" >&2; }
step "formatting and lints"
cargo fmt --all -- --check
cargo clippy --workspace --all-targets -- -D warnings
cargo clippy -p qemu-bench --profile flight --target thumbv7em-none-eabihf -- -D warnings
cargo clippy -p ballisto-fw --target thumbv7em-none-eabihf -- -D warnings
cargo clippy -p board-qemu --profile flight --target thumbv7em-none-eabihf -- -D warnings
step "the tests"
cargo nextest run --workspace --no-fail-fast
step "the doc tests"
cargo test --workspace --doc

# The STM32H743 (its own directory and target: its .cargo/config.toml, Cortex-M7 FPU, probe-rs
# runner): linted, then built from a user's board file (BALLISTO_ARRANGEMENT, read by its
# build.rs), then from the built-in board's, which the size report measures. It compiles while
# QEMU, one thread, runs below: its output is shown when it ends.
step "the STM32H743 board (alongside the QEMU runs)"
stm32_log=$(mktemp)
trap 'rm -f "$stm32_log"' EXIT
(
  cd firmware/boards/stm32h743
  cargo clippy --profile flight -- -D warnings
  BALLISTO_ARRANGEMENT=example-board.toml cargo build --profile flight
  cargo build --profile flight
) > "$stm32_log" 2>&1 &
stm32=$!

step "instruction counts under QEMU"
QEMU_BENCH_STRICT=1 cargo qemu-bench
# QEMU: runs the built-in scenario, writes out/qemu/telemetry*.bin.
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

step "the STM32H743 board"
status=0
wait "$stm32" || status=$?
cat "$stm32_log" >&2
[ "$status" = 0 ] || { echo "test.sh: the STM32H743 board's lint or build failed" >&2; exit "$status"; }
step "flash and RAM"
bash scripts/size-report.sh
step "done"
