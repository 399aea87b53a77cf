#!/usr/bin/env bash
# The communication robustness rig (issue 19; README.md beside this file).
#
#   bash host-tests/robustness/run.sh [--long] [--cases a,b] [--duration S] [--out FILE]
#
# Short form (default, what scripts/test-all.sh runs): every case with 4 s of
# traffic, the table in target/robustness/RESULTS-short.md. --long: 60 s a
# case, the table in host-tests/robustness/RESULTS.md (the evidence).
#
# Needs root (a network namespace and a TAP device). Makes the namespace
# hansrob-<pid> with the TAP device hrtap<pid> in it, gives the TAP's side
# the private addresses of the segment 10.0.2.0/24 (the firmware's factory
# network: the device 10.0.2.15 by DHCP, the robot simulator 10.0.2.100),
# and runs rig.py inside it: dnsmasq, hans-sim, QEMU, the PLC monitor and
# the traffic all stay in the namespace. At the end (and on Ctrl-C) every
# process started is ended by its PID and the namespace is removed.
#
# Environment: FIRMWARE_BIN_DIR (default firmware/target/thumbv7em-none-eabihf/release:
# field-device and bootloader-mps2, built here if missing), CARGO_TARGET_DIR.
set -euo pipefail
cd "$(dirname "$0")/../.."
ROOT=$(pwd)

long=0
rig_args=()
out=
while [ $# -gt 0 ]; do
  case $1 in
    --long) long=1; rig_args+=(--long) ;;
    --cases|--duration) rig_args+=("$1" "$2"); shift ;;
    --out) out=$2; shift ;;
    *) echo "run.sh: unknown argument $1" >&2; exit 2 ;;
  esac
  shift
done
if [ -z "$out" ]; then
  if [ $long = 1 ]; then out=$ROOT/host-tests/robustness/RESULTS.md; else out=$ROOT/target/robustness/RESULTS-short.md; fi
fi

export PYTHONDONTWRITEBYTECODE=1  # no __pycache__ beside the scripts
export PATH="$PATH:/usr/sbin:/sbin"  # ip, hping3, dnsmasq
[ "$(id -u)" -eq 0 ] || { echo "run.sh: needs root (ip netns, a TAP device)" >&2; exit 2; }
SETUP_FUZZ=0 bash scripts/setup.sh

# What runs: the field-device firmware and its bootloader (release), hans-fw
# (makes the flash file), hans-sim. Built only when missing: scripts/test-all.sh
# has built the firmware just before.
source scripts/firmware-env.sh
FW_TARGET=${CARGO_TARGET_DIR:-$ROOT/firmware/target}
HOST_TARGET=${CARGO_TARGET_DIR:-$ROOT/target}
BIN_DIR=${FIRMWARE_BIN_DIR:-$FW_TARGET/thumbv7em-none-eabihf/release}
if [ ! -s "$BIN_DIR/field-device" ] || [ ! -s "$BIN_DIR/bootloader-mps2" ]; then
  (cd firmware && CARGO_TARGET_DIR="$FW_TARGET" firmware_cargo build --release -p board-mps2-an386 --features field-device --bin field-device)
  (cd firmware && CARGO_TARGET_DIR="$FW_TARGET" firmware_cargo build --release -p bootloader-mps2)
fi
source scripts/host-programs.sh && CARGO_TARGET_DIR="$HOST_TARGET" build_host_programs

ns=hansrob-$$
tap=hrtap$(($$ % 100000))
logdir=$(mktemp -d /tmp/hans-robustness.XXXXXX)
rig_pid=

cleanup() {
  local status=$?
  trap - EXIT INT TERM
  if [ -n "$rig_pid" ] && kill -0 "$rig_pid" 2>/dev/null; then
    kill -TERM "$rig_pid" 2>/dev/null || true
    sleep 2
    kill -KILL "$rig_pid" 2>/dev/null || true
  fi
  if ip netns list | grep -qw "$ns"; then
    # Whatever still runs in our namespace was started by this run: by PID.
    for pid in $(ip netns pids "$ns" 2>/dev/null); do kill -KILL "$pid" 2>/dev/null || true; done
    ip netns del "$ns" || true
  fi
  if [ "${KEEP_LOGS:-0}" = 1 ] || [ $status != 0 ]; then
    echo "run.sh: logs in $logdir"
  else
    rm -rf "$logdir"
  fi
  exit $status
}
trap cleanup EXIT
trap 'exit 130' INT TERM

in_ns() { ip netns exec "$ns" "$@"; }
ip netns add "$ns"
in_ns ip link set lo up
in_ns ip tuntap add dev "$tap" mode tap
# Oversize frames (the eth-malformed case) need a larger MTU on our side.
in_ns ip link set "$tap" mtu 9000 up
for a in 10.0.2.2 10.0.2.100 10.0.2.10 10.0.2.11 10.0.2.20 10.0.2.21 10.0.2.22 10.0.2.40 10.0.2.41; do
  in_ns ip addr add "$a/24" dev "$tap"
done

echo "==> robustness rig: namespace $ns, TAP $tap, logs $logdir"
in_ns /usr/bin/python3 host-tests/robustness/rig.py --iface "$tap" \
  --firmware "$BIN_DIR/field-device" --sim "$HOST_TARGET/debug/hans-sim" \
  --out "$out" --logdir "$logdir" "${rig_args[@]}" &
rig_pid=$!
wait "$rig_pid"
