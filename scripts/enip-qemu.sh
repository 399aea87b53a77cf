#!/usr/bin/env bash
# The EtherNet/IP adapter of the QEMU field device (mps2-an386) against the
# PyPI scanners (pycomm3, cpppo, ethernetip) over the emulated Ethernet:
# turned on as an administrator does (page API, restart), discovery,
# explicit messaging, class 1 I/O at ENIP_QEMU_RPI_MS (10) for
# ENIP_QEMU_SECONDS (15) while a Modbus poller and a browser use the same
# device, the stack high-water mark at the end
# (host-tests/enip/qemu_scanners.py says what is checked).
#
#   bash scripts/enip-qemu.sh     (scripts/firmware-tests.sh runs it after
#                                  the QEMU tests, on the firmware it built)
#
# Needs root, as CI has: QEMU's user network drops every UDP datagram the
# guest sends while it is restricted (`restrict=on`: ListIdentity replies,
# the T->O datagrams), and unrestricted it would reach the host's network.
# So this makes a network namespace (hansenip-<pid>) with a TAP device in
# it, whose side holds 10.0.2.2 (the scanners, Modbus, the browser) and
# 10.0.2.100 (hans-sim, the firmware's factory robot address), and runs
# QEMU (scripts/qemu-run.sh NET=tap:...), the simulator and the scanners
# inside it; nothing leaves the namespace. At the end every process started
# is ended by its PID and the namespace is removed. About 45 s.
#
# Environment: FIRMWARE_BIN_DIR (default firmware/target/thumbv7em-none-eabihf/release:
# field-device and bootloader-mps2, which must be built), CARGO_TARGET_DIR
# (hans-sim, hans-fw: built here if missing), ENIP_QEMU_RPI_MS, ENIP_QEMU_SECONDS.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
export PATH="$PATH:/usr/sbin:/sbin"  # ip
[ "$(id -u)" -eq 0 ] || { echo "enip-qemu: needs root (ip netns, a TAP device)" >&2; exit 2; }

FW_TARGET=${CARGO_TARGET_DIR:-$ROOT/firmware/target}
HOST_TARGET=${CARGO_TARGET_DIR:-$ROOT/target}
BIN_DIR=${FIRMWARE_BIN_DIR:-$FW_TARGET/thumbv7em-none-eabihf/release}
for f in field-device bootloader-mps2; do
  [ -s "$BIN_DIR/$f" ] || { echo "enip-qemu: $BIN_DIR/$f is not built (scripts/firmware-tests.sh builds it)" >&2; exit 2; }
done
source scripts/enip-venv.sh
# Built by the host tests' step in scripts/test-all.sh (scripts/host-programs.sh):
# nothing is built twice.
source scripts/lint-env.sh
source scripts/host-programs.sh && CARGO_TARGET_DIR="$HOST_TARGET" build_host_programs

ns=hansenip-$$
tap=hetap$(($$ % 100000))
logdir=$(mktemp -d /tmp/hans-enip-qemu.XXXXXX)
run_pid=
cleanup() {
  local status=$?
  trap - EXIT INT TERM
  if [ -n "$run_pid" ] && kill -0 "$run_pid" 2>/dev/null; then
    kill -TERM "$run_pid" 2>/dev/null || true
    sleep 2
    kill -KILL "$run_pid" 2>/dev/null || true
  fi
  if ip netns list | grep -qw "$ns"; then
    # Whatever still runs in our namespace was started by this run: by PID.
    for pid in $(ip netns pids "$ns" 2>/dev/null); do kill -KILL "$pid" 2>/dev/null || true; done
    ip netns del "$ns" || true
  fi
  if [ "${KEEP_LOGS:-0}" = 1 ] || [ $status != 0 ]; then
    echo "enip-qemu: logs in $logdir"
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
in_ns ip link set "$tap" up
in_ns ip addr add 10.0.2.2/24 dev "$tap"
in_ns ip addr add 10.0.2.100/24 dev "$tap"

echo "==> EtherNet/IP on the QEMU field device: namespace $ns, TAP $tap"
in_ns timeout --kill-after=10 240 "$VENV/bin/python" host-tests/enip/qemu_scanners.py \
  --firmware "$BIN_DIR/field-device" --sim "$HOST_TARGET/debug/hans-sim" --iface "$tap" --logdir "$logdir" \
  --rpi-ms "${ENIP_QEMU_RPI_MS:-10}" --io-seconds "${ENIP_QEMU_SECONDS:-15}" &
run_pid=$!
wait "$run_pid"
