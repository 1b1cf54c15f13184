#!/usr/bin/env bash
# rustc wrapper (build.rustc-wrapper in config.toml): for the embedded target only, strips the
# build machine's crate-registry directory from the source paths rustc records, so the panic
# locations flashed into the image read `embassy-stm32-0.6.0/src/spi/mod.rs`, not
# `/root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/embassy-stm32-0.6.0/src/spi/mod.rs`.
# Measured on the STM32H743 image (flight profile): 37 such paths, 2 183 B of .rodata under
# /root/.cargo, more under a longer CARGO_HOME; so without this the size of what is flashed
# (and whether it meets its budget) depended on where the machine keeps its Cargo home.
# Cargo's own `trim-paths` does this but is not stable (Rust 1.95). Host builds are left alone.
set -euo pipefail
remap=()
for arg in "$@"; do
  if [ "$arg" = "thumbv7em-none-eabihf" ] || [ "$arg" = "--target=thumbv7em-none-eabihf" ]; then
    for dir in "${CARGO_HOME:-$HOME/.cargo}"/registry/src/*/; do
      [ -d "$dir" ] && remap+=("--remap-path-prefix=$dir=")
    done
    break
  fi
done
exec "$@" "${remap[@]}"
