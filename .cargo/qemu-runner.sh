#!/usr/bin/env bash
# Runs a thumbv7em-none-eabihf ELF on QEMU's mps2-an386 (Cortex-M4F) with semihosting.
# - qemu-bench: -icount shift=0, one guest instruction = 1 ns of virtual time, so SysTick
#   (25 MHz) counts instructions deterministically (40 instructions per tick).
# - board-qemu: -icount shift=5 (32 ns per instruction, a 31 MIPS core — a real M4F runs
#   100 MIPS and more: a sample set's work fits its 10 ms and the identification task, in
#   soft f64 below it, keeps up with 100 Hz; at shift=6 it lost a tenth of the window's
#   sets), run in out/qemu/ where it writes telemetry.bin through semihosting. A timeout
#   guards against a hang.
set -euo pipefail
elf="$(realpath "$1")"; shift
case "$(basename "$elf")" in
  board-qemu)
    out="${BOARD_QEMU_OUT:-out/qemu}"
    mkdir -p "$out"
    cd "$out"
    exec timeout 600 qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic -monitor none \
      -serial none -icount shift=5,sleep=off \
      -semihosting-config enable=on,target=native -kernel "$elf" "$@"
    ;;
  *)
    exec qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic -monitor none \
      -serial none -icount shift=0 \
      -semihosting-config enable=on,target=native -kernel "$elf" "$@"
    ;;
esac
