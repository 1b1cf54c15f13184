#!/usr/bin/env bash
# The same instruction counts as `cargo qemu-bench`, on QEMU's Cortex-M7 (mps2-an500) with the
# double-precision FPU the STM32H743 has (FPv5-D16: `target-cpu=cortex-m7`, as the board builds), in its
# own target directory (the flags differ from the M4F build). Figures only, no verdict: the
# budget is counted on the M4F (`cargo qemu-bench`); this shows what the f64 parts — the
# precomputation and the identification's sums and solve — cost where they are
# hardware instructions.
set -euo pipefail
cd "$(dirname "$0")/.."
CARGO_TARGET_DIR=target/m7 \
  RUSTFLAGS="-C link-arg=-Tlink.x -C target-cpu=cortex-m7" \
  cargo build -p qemu-bench --profile flight --target thumbv7em-none-eabihf
echo "qemu-bench on mps2-an500 (Cortex-M7, FPv5 double precision):"
timeout 600 qemu-system-arm -machine mps2-an500 -cpu cortex-m7 -nographic -monitor none \
  -serial none -icount shift=0 -semihosting-config enable=on,target=native \
  -kernel target/m7/thumbv7em-none-eabihf/flight/qemu-bench
