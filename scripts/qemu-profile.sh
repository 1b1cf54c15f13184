#!/usr/bin/env bash
# Where one per-sample estimate's instructions go on the Cortex-M4F (QEMU mps2-an386), by
# source line of estimator-core: `bash scripts/qemu-profile.sh [general|free-float]`.
# Builds qemu-bench for one model in the budget's configuration with 200 and with 1 200
# samples (QEMU_BENCH_ONLY, QEMU_BENCH_SAMPLES), runs both under `-d in_asm,exec,nochain`,
# counts every executed guest instruction, symbolizes each address (innermost inlined frame and
# outermost estimator-core frame, llvm-symbolizer) and prints the difference per sample: the
# precomputation and the bench's own motion (soft-float f64) drop out. About 5 minutes and
# 2 GB of temporary log per run; needs python3 and llvm-symbolizer. A developer's tool, not in CI.
set -euo pipefail
cd "$(dirname "$0")/.."
model="${1:-general}"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
run() {
  local n="$1" dir="target/profile-$model-$1"
  QEMU_BENCH_SAMPLES="$n" QEMU_BENCH_ONLY="$model" CARGO_TARGET_DIR="$dir" \
    cargo build -q -p qemu-bench --profile flight --target thumbv7em-none-eabihf
  local elf="$dir/thumbv7em-none-eabihf/flight/qemu-bench"
  cp "$elf" "$tmp/elf-$n"
  qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic -monitor none -serial none \
    -icount shift=0 -semihosting-config enable=on,target=native -kernel "$elf" \
    -d in_asm,exec,nochain -D "$tmp/log-$n" > "$tmp/out-$n"
  python3 scripts/qemu-profile.py count "$tmp/log-$n" > "$tmp/pc-$n"
  rm -f "$tmp/log-$n"
}
run 200 & run 1200 & wait
grep "N = 12" "$tmp/out-1200" || true
python3 scripts/qemu-profile.py diff "$tmp/pc-200" "$tmp/elf-200" "$tmp/pc-1200" "$tmp/elf-1200" 1000
