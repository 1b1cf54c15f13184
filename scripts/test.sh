#!/usr/bin/env bash
# The test command: formatting, lints, every test, the target builds and their figures:
# instruction counts of the estimate under QEMU in the flashed profile (which fail if a mean
# exceeds the per-sample budget), the STM32H743 build, the QEMU board running the built-in
# scenario (boot 1: identification and commit; a reset; boot 2 on the stored calibration, a part
# stuck and isolated, then its sets stop; the watchdog's reset; boot 3 on the stored calibration)
# with the boots' telemetry decoded and checked against the host, the same scenario followed live
# over the board's UART on a pseudo-terminal by `ballisto capture` (scripts/qemu-live.sh) and
# checked against the boots' files, and the flash / RAM report
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
# The firmware packages for the target, named (never the whole workspace: features unify),
# in one run: their dependencies are checked once.
cargo clippy -p qemu-bench -p ballisto-fw -p board-qemu --profile flight \
  --target thumbv7em-none-eabihf -- -D warnings
step "the builds"
cargo nextest run --workspace --no-run
QEMU_BENCH_STRICT=1 cargo build -p qemu-bench --profile flight --target thumbv7em-none-eabihf
cargo build -p board-qemu --profile flight --target thumbv7em-none-eabihf

# While the tests run: QEMU (one thread per run: counts under -icount do not depend on the
# host's load) and the STM32H743 (its own directory and target: its .cargo/config.toml,
# Cortex-M7 FPU, probe-rs runner; linted, then built from a user's board file —
# BALLISTO_ARRANGEMENT, read by its build.rs — then from the built-in board's, which the size
# report measures). Their output is shown when they end.
step "the tests, and alongside them the QEMU runs and the STM32H743 board"
logs=$(mktemp -d)
trap 'rm -rf "$logs"' EXIT
(
  # Instruction counts of the flashed profile (a mean over its budget fails: QEMU_BENCH_STRICT
  # above); then the QEMU board's built-in scenario, writing out/qemu/telemetry*.bin.
  bash .cargo/qemu-runner.sh target/thumbv7em-none-eabihf/flight/qemu-bench
  bash .cargo/qemu-runner.sh target/thumbv7em-none-eabihf/flight/board-qemu
  # The same image followed live over its UART (the ground tool built with the tests).
  bash scripts/qemu-live.sh out/qemu-live
) > "$logs/qemu" 2>&1 &
qemu=$!
(
  cd firmware/boards/stm32h743
  cargo clippy --profile flight -- -D warnings
  BALLISTO_ARRANGEMENT=example-board.toml cargo build --profile flight
  cargo build --profile flight
) > "$logs/stm32" 2>&1 &
stm32=$!
# `ended NAME PID`: waits for a job, shows its output, fails if it failed.
ended() {
  local status=0
  wait "$2" || status=$?
  cat "$logs/$1" >&2
  [ "$status" = 0 ] || { echo "test.sh: $1 failed" >&2; exit "$status"; }
}
tests=0
cargo nextest run --workspace --no-fail-fast || tests=$?
step "the doc tests"
cargo test --workspace --doc || tests=$?
step "the QEMU runs"
ended qemu "$qemu"
[ "$tests" = 0 ] || { echo "test.sh: the tests failed" >&2; exit "$tests"; }
# The host side with the binaries the tests built (no second, release build of the host crates).
./target/debug/ballisto decode out/qemu/telemetry-boot1.bin --out out/qemu/estimates-boot1.csv \
  --log out/qemu/log-boot1.txt
./target/debug/ballisto decode out/qemu/telemetry.bin --out out/qemu/estimates.csv \
  --log out/qemu/log.txt
./target/debug/ballisto decode out/qemu/telemetry-boot3.bin --out out/qemu/estimates-boot3.csv \
  --log out/qemu/log-boot3.txt
BOARD_QEMU_TELEMETRY="$PWD/out/qemu/telemetry.bin" BOARD_QEMU_LIVE="$PWD/out/qemu-live" \
  cargo nextest run --workspace -E 'binary(builtin_scenario) | binary(capture)' \
  --run-ignored only --no-capture
step "the STM32H743 board"
ended stm32 "$stm32"
step "flash and RAM"
bash scripts/size-report.sh
step "done"
