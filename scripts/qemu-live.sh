#!/usr/bin/env bash
# The QEMU board's built-in scenario followed live: its UART0 on a pseudo-terminal
# (`-serial pty`), read by `ballisto capture` as the board's three boots go by (two resets),
# while the board also writes each boot's telemetry file through semihosting. The capture
# (estimates, log, raw bytes) and the files land together in one directory, so that the live
# record can be checked against the file decode of the same bytes
# (`ballisto/tests/capture.rs`, run by the test command).
#
#   bash scripts/qemu-live.sh [DIR]      (default out/qemu-live)
#
# Needs the board's image and the ground tool built (`BOARD_QEMU_ELF`, `BALLISTO` to name
# others). The machine starts halted (`-S`) and is let go once the capture has the port open,
# so that no byte is sent before anyone listens. The virtual clock follows the host's while
# the processor sleeps (`-icount sleep=on`, where the test command's deterministic run has
# sleep=off): a UART drained by a host process in real time must see real time pass.
# The run goes into a new directory beside DIR, which replaces DIR only when it succeeded; a
# failed run's directory is kept and named.
set -euo pipefail
cd "$(dirname "$0")/.."
elf="$(realpath "${BOARD_QEMU_ELF:-target/thumbv7em-none-eabihf/flight/board-qemu}")"
ballisto="$(realpath "${BALLISTO:-target/debug/ballisto}")"
dir="${1:-out/qemu-live}"
mkdir -p "$(dirname "$dir")"
run="$(mktemp -d "$dir.run.XXXXXX")"
fail() {
  echo "qemu-live.sh: $*; the run is kept in $run" >&2
  [ -f "$run/qemu.txt" ] && sed 's/^/  qemu: /' "$run/qemu.txt" >&2
  [ -f "$run/capture.txt" ] && sed 's/^/  capture: /' "$run/capture.txt" >&2
  exit 1
}
# `waitfor FILE PATTERN`: until FILE holds a line matching PATTERN (30 s at most).
waitfor() {
  for _ in $(seq 300); do
    grep -q -- "$2" "$1" 2>/dev/null && return 0
    sleep 0.1
  done
  return 1
}

mkfifo "$run/monitor.in" "$run/monitor.out"
(
  cd "$run"
  exec timeout 600 qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic \
    -monitor pipe:monitor -serial pty -S -icount shift=5,sleep=on \
    -semihosting-config enable=on,target=native -kernel "$elf"
) > "$run/qemu.txt" 2>&1 &
qemu=$!
# QEMU holds the monitor's pipes open read-write; its replies are drained here.
cat "$run/monitor.out" > "$run/monitor.txt" &
waitfor "$run/qemu.txt" 'char device redirected to' || fail "QEMU did not open a pseudo-terminal"
pty="$(sed -n 's/.*char device redirected to \(\/dev\/[^ ]*\) .*/\1/p' "$run/qemu.txt" | head -1)"
"$ballisto" capture --port "$pty" --out "$run/estimates.csv" --log "$run/log.txt" \
  --raw "$run/capture.bin" --idle 5 2> "$run/capture.txt" &
capture=$!
waitfor "$run/capture.txt" 'open, following' || fail "the capture did not open $pty"
echo cont > "$run/monitor.in"
status=0
wait "$qemu" || status=$?
[ "$status" = 0 ] || { kill "$capture" 2>/dev/null || true; fail "the board failed ($status)"; }
status=0
wait "$capture" || status=$?
[ "$status" = 0 ] || fail "the capture failed ($status)"
sed 's/^/qemu-live.sh: /' "$run/qemu.txt" "$run/capture.txt" >&2
rm -f "$run/monitor.in" "$run/monitor.out"
rm -rf "$dir"
mv "$run" "$dir"
echo "qemu-live.sh: the live capture and the board's files are in $dir" >&2
