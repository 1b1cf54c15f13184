#!/usr/bin/env bash
# Installs what the build and the tests need on a fresh machine (idempotent):
# the thumbv7em-none-eabihf target (firmware builds) and QEMU (instruction counts).
set -euo pipefail
rustup target add thumbv7em-none-eabihf >/dev/null
if ! command -v qemu-system-arm >/dev/null 2>&1; then
  SUDO=""
  if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq qemu-system-arm >/dev/null
fi
