#!/usr/bin/env bash
# Runs the field-device firmware (web page, DHCP, DataSheet reader) of the
# QEMU board mps2-an386 with the robot simulator, its web page forwarded to
# the host, and prints where everything is: for browser tests against the
# firmware, and for trying the page by hand.
#
#   scripts/qemu-field-device.sh                # until Ctrl-C (or SIGTERM)
#   scripts/qemu-field-device.sh -- CMD ARGS...  # runs CMD, then stops all
#
# Once the page answers it prints, one per line:
#   HANS_WEB_URL=http://127.0.0.1:PORT/   the page (and /api/...)
#   HANS_MODBUS=127.0.0.1:PORT            the Modbus server
#   HANS_ADMIN=127.0.0.1:PORT             diagnostics (`report`, `exit`)
#   HANS_SIM=127.0.0.1:PORT               the simulator's command port
#   HANS_LOG=FILE                         the firmware's log (text with defmt-print)
# With a command, these are in its environment, and the script exits with
# the command's status. Without one, it ends when QEMU or the simulator
# ends by itself (with that status) or on Ctrl-C / SIGTERM (status 0).
#
# Environment: WEB_PORT, MODBUS_PORT, ADMIN_PORT, SIM_PORT (default: free
# ports on 127.0.0.1); SIM=0 to start no simulator (the caller runs one on
# SIM_PORT, e.g. in-process); SIM_ARGS: more hans-sim options (e.g.
# `--ready`: powered and enabled from the start); NO_BUILD=1 to use the firmware already built;
# MAX_SECONDS (default 3600) bounds QEMU's and the simulator's life;
# READY_SECONDS (default 60) bounds the wait for the page;
# LOG_DIR (default: a new temporary directory).
# Everything listens on 127.0.0.1 only; QEMU's guest has no other way out.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)

cmd=()
if [ "${1:-}" = "--" ]; then
  shift
  cmd=("$@")
elif [ $# -gt 0 ]; then
  echo "usage: $0 [-- CMD ARGS...]" >&2
  exit 2
fi

free_port() {
  python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}
WEB_PORT=${WEB_PORT:-$(free_port)}
MODBUS_PORT=${MODBUS_PORT:-$(free_port)}
ADMIN_PORT=${ADMIN_PORT:-$(free_port)}
SIM_PORT=${SIM_PORT:-$(free_port)}
MAX_SECONDS=${MAX_SECONDS:-3600}
READY_SECONDS=${READY_SECONDS:-60}
LOG_DIR=${LOG_DIR:-$(mktemp -d)}
mkdir -p "$LOG_DIR"
export WEB_PORT MODBUS_PORT ADMIN_PORT SIM_PORT

source scripts/firmware-env.sh
FW_TARGET=${CARGO_TARGET_DIR:-$ROOT/firmware/target}
HOST_TARGET=${CARGO_TARGET_DIR:-$ROOT/target}
ELF="$FW_TARGET/thumbv7em-none-eabihf/release/field-device"

if [ "${NO_BUILD:-0}" != 1 ]; then
  SETUP_FUZZ=0 bash scripts/setup.sh >&2
  echo "qemu-field-device: building the field-device firmware, its bootloader, hans-fw and hans-sim" >&2
  (cd firmware && CARGO_TARGET_DIR="$FW_TARGET" firmware_cargo build --release -q -p board-mps2-an386 \
    --features field-device --bin field-device &&
    CARGO_TARGET_DIR="$FW_TARGET" firmware_cargo build --release -q -p bootloader-mps2) >&2
  CARGO_TARGET_DIR="$HOST_TARGET" cargo build -q -p hans-fw >&2
  if [ "${SIM:-1}" != 0 ]; then
    CARGO_TARGET_DIR="$HOST_TARGET" cargo build --release -q -p hans-sim >&2
  fi
fi
[ -f "$ELF" ] || { echo "qemu-field-device: $ELF not built" >&2; exit 2; }

pids=()
cleanup() {
  trap '' INT TERM
  trap - EXIT
  for pid in "${pids[@]}"; do
    kill "$pid" 2>/dev/null || true
  done
  for pid in "${pids[@]}"; do
    wait "$pid" 2>/dev/null || true
  done
}
trap 'cleanup; exit 0' INT TERM
trap cleanup EXIT

if [ "${SIM:-1}" != 0 ]; then
  # The firmware uses the command port only (no fast port: several of
  # these may run at once). SIM_ARGS adds options (e.g. --ready).
  # shellcheck disable=SC2086 # SIM_ARGS is a list of words
  timeout --kill-after=5 "$MAX_SECONDS" "$HOST_TARGET/release/hans-sim" --host 127.0.0.1 \
    --command-port "$SIM_PORT" --datasheet-ports "" --no-fast-port ${SIM_ARGS:-} \
    >"$LOG_DIR/hans-sim.log" 2>&1 &
  pids+=($!)
fi
# The firmware's log: decoded to text when defmt-print is installed
# (scripts/setup.sh installs it), else the raw defmt frames.
if command -v defmt-print >/dev/null; then
  LOG="$LOG_DIR/field-device.log"
  timeout --kill-after=5 "$MAX_SECONDS" bash scripts/qemu-run.sh "$ELF" 2>"$LOG_DIR/qemu.log" >"$LOG" &
else
  LOG="$LOG_DIR/field-device.defmt"
  DEFMT_OUT="$LOG" timeout --kill-after=5 "$MAX_SECONDS" bash scripts/qemu-run.sh "$ELF" 2>"$LOG_DIR/qemu.log" &
fi
pids+=($!)

# Ready when the page answers (QEMU accepts on the forwarded port at once,
# but the guest answers only once it is up).
URL="http://127.0.0.1:$WEB_PORT/"
if ! python3 - "$URL" "$READY_SECONDS" <<'PY'; then
import sys, time, urllib.request
url, limit = sys.argv[1], float(sys.argv[2])
end = time.time() + limit
while time.time() < end:
    try:
        with urllib.request.urlopen(url + "api/session", timeout=3) as r:
            if r.status == 200:
                sys.exit(0)
    except Exception:
        pass
    time.sleep(0.3)
sys.exit(1)
PY
  echo "qemu-field-device: the page did not answer within ${READY_SECONDS} s; logs in $LOG_DIR" >&2
  exit 1
fi

export HANS_WEB_URL=$URL HANS_MODBUS=127.0.0.1:$MODBUS_PORT HANS_ADMIN=127.0.0.1:$ADMIN_PORT \
  HANS_SIM=127.0.0.1:$SIM_PORT HANS_LOG=$LOG
printf '%s\n' "HANS_WEB_URL=$HANS_WEB_URL" "HANS_MODBUS=$HANS_MODBUS" "HANS_ADMIN=$HANS_ADMIN" \
  "HANS_SIM=$HANS_SIM" "HANS_LOG=$HANS_LOG"

if ((${#cmd[@]})); then
  status=0
  "${cmd[@]}" || status=$?
  exit "$status"
fi
status=0
wait -n "${pids[@]}" || status=$?
echo "qemu-field-device: a process ended by itself (status $status); logs in $LOG_DIR" >&2
exit "$status"
