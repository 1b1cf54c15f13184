#!/usr/bin/env bash
# Flash and static RAM of the two board builds (flight profile), against the STM32H743 budgets
# (256 KiB flash; 128 KiB static RAM; docs/architecture.md, "Flash map"). Prints the figures;
# exits non-zero if a build is missing. Both budgets are reported, not in the exit status: the
# identification without a reference puts the image over both (estimator-core's tumble search
# in flash; the window kept as means, 128 KiB, in RAM), a capability kept over the budget. The
# limits that bind are the image slot, 384 KiB, and the AXI SRAM, 512 KiB (memory.x): the
# linker refuses an image beyond them. The sizes are deterministic for a toolchain, so this is
# a check, not a timed test. Flash = vector table + .text + .rodata + .data (its load image);
# static RAM = .data + .bss + .uninit (the stack is not static).
set -euo pipefail
cd "$(dirname "$0")/.."
SIZE="$(command -v size || command -v llvm-size)"
report() {
  local name="$1" elf="$2" flash_budget="$3" ram_budget="$4"
  [ -f "$elf" ] || { echo "size-report: $elf is missing (build it first)" >&2; exit 1; }
  "$SIZE" -A "$elf" | awk -v name="$name" -v fb="$flash_budget" -v rb="$ram_budget" '
    $1 == ".vector_table" || $1 == ".text" || $1 == ".rodata" { flash += $2 }
    $1 == ".data" { flash += $2; ram += $2 }
    $1 == ".bss" || $1 == ".uninit" { ram += $2 }
    END {
      fl = sprintf("%.1f KiB", flash / 1024); rl = sprintf("%.1f KiB", ram / 1024)
      if (fb > 0) {
        fs = (flash <= fb * 1024) ? "within" : "OVER (reported, not in the exit status)"
        rs = (ram <= rb * 1024) ? "within" : "OVER (reported, not in the exit status)"
        printf "%-16s flash %7d B (%s, %s the %d KiB budget)  static RAM %6d B (%s, %s the %d KiB budget)\n", name, flash, fl, fs, fb, ram, rl, rs, rb
      } else {
        printf "%-16s flash %7d B (%s)  static RAM %6d B (%s)\n", name, flash, fl, ram, rl
      }
    }'
}
report board-stm32h743 target/thumbv7em-none-eabihf/flight/board-stm32h743 256 128
report board-qemu target/thumbv7em-none-eabihf/flight/board-qemu 0 0
