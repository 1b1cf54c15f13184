#!/usr/bin/env bash
# The QEMU board's tumble (`board_qemu::tumble`: identification without a reference → commit →
# reset → boot on the record) on QEMU's Cortex-M7 (mps2-an500), with the double-precision FPU
# the STM32H743 has: the board-qemu application built as the STM32H743 board builds it
# (`target-cpu=cortex-m7`, profile flight), in its own target directory. The search is f64: in
# the soft f64 of mps2-an386's Cortex-M4F QEMU did not finish it in 20 minutes. The same
# memory map as mps2-an386; `tumble` on the semihosting command line chooses the scenario.
# Writes out/qemu-tumble/, decodes both boots' telemetry and checks them against the host's run
# of the same scenario (tests/tests/builtin_tumble.rs).
set -euo pipefail
cd "$(dirname "$0")/.."
CARGO_TARGET_DIR=target/m7 \
  RUSTFLAGS="-C link-arg=-Tlink.x -C target-cpu=cortex-m7" \
  cargo build -p board-qemu --profile flight --target thumbv7em-none-eabihf
elf="$PWD/target/m7/thumbv7em-none-eabihf/flight/board-qemu"
out=out/qemu-tumble
rm -rf "$out"
mkdir -p "$out"
# -icount shift=2: one instruction per 4 ns, a 250 MIPS core (the STM32H743's M7 runs at 400 MHz
# and issues up to two a cycle); mps2-an386 runs at shift=5, a 31 MIPS M4F
# (.cargo/qemu-runner.sh).
(cd "$out" && timeout 900 qemu-system-arm -machine mps2-an500 -cpu cortex-m7 -nographic \
  -monitor none -serial none -icount shift=2,sleep=off \
  -semihosting-config enable=on,target=native,arg=board-qemu,arg=tumble -kernel "$elf")
cargo build -q --bin ballisto
for boot in telemetry-boot1 telemetry; do
  ./target/debug/ballisto decode "$out/$boot.bin" --out "$out/estimates${boot#telemetry}.csv" \
    --log "$out/log${boot#telemetry}.txt"
done
BOARD_QEMU_TUMBLE="$PWD/$out/telemetry.bin" \
  cargo nextest run -p e2e-tests --test builtin_tumble --run-ignored only --no-capture
