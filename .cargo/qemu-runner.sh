#!/usr/bin/env bash
# Runs a thumbv7em-none-eabihf ELF on QEMU's mps2-an386 (Cortex-M4F) with semihosting.
# -icount shift=0: one guest instruction = 1 ns of virtual time, so SysTick (25 MHz) counts
# instructions deterministically (40 instructions per tick).
set -euo pipefail
elf="$1"; shift
exec qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic -monitor none \
  -serial none -icount shift=0 \
  -semihosting-config enable=on,target=native -kernel "$elf" "$@"
