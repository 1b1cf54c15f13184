#!/usr/bin/env bash
# Installs what the build and the tests need on a fresh machine (idempotent):
# the thumbv7em-none-eabihf target (firmware builds), QEMU (instruction counts, the QEMU board)
# and cargo-nextest (the test runner).
set -euo pipefail
rustup target add thumbv7em-none-eabihf >/dev/null
if ! cargo nextest --version >/dev/null 2>&1; then
  # A prebuilt binary (seconds); building it from source takes minutes.
  mkdir -p "${CARGO_HOME:-$HOME/.cargo}/bin"
  curl -LsSf https://get.nexte.st/latest/linux \
    | tar zxf - -C "${CARGO_HOME:-$HOME/.cargo}/bin" \
    || cargo install --locked cargo-nextest
fi
if ! command -v qemu-system-arm >/dev/null 2>&1; then
  SUDO=""
  if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq qemu-system-arm >/dev/null
fi
