#!/usr/bin/env bash
# Firmware checks: builds every firmware in release with its size budgets
# (scripts/firmware-build.sh: rustfmt, every build also the clippy run of
# what it compiles from this repository; a no-op when test-all.sh has
# already run it in the background), then runs the QEMU tests
# (firmware/qemu-tests: smoke firmware; gateway
# firmware with the robot simulator, run in-process, and a Modbus client;
# field-device firmware over HTTP; the bootloader on flash files; signed
# updates through the page's API: bad images refused while the PLC is
# served, an update installed and confirmed, one rolled back), which print
# the stack high-water marks (a test fails when its firmware's mark is over
# its budget: firmware/qemu-tests/src/lib.rs, STACK_BUDGETS), the web
# page's load time and the update's figures. Last, the field device's
# EtherNet/IP adapter against the PyPI scanners (scripts/enip-qemu.sh, as
# root: QEMU on a TAP device in a network namespace), with its class 1
# figures and its stack high-water mark.
#
# To run the field-device firmware for a browser (or by hand) instead, with
# its web page forwarded to the host: scripts/qemu-field-device.sh.
#
# Bounded: each QEMU and simulator process runs under timeout(1) and is
# stopped by the tests on every exit path; the whole test run is under a
# timeout here as well. Only 127.0.0.1 is used on the host.
#
# Environment: CARGO_TARGET_DIR (default: firmware/target for the firmware,
# target/ for the host crates, as cargo does).
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)

SETUP_FUZZ=0 bash scripts/setup.sh

FW_TARGET=${CARGO_TARGET_DIR:-$ROOT/firmware/target}
HOST_TARGET=${CARGO_TARGET_DIR:-$ROOT/target}
BIN_DIR="$FW_TARGET/thumbv7em-none-eabihf/release"

# The host side of the QEMU tests is built with the lint wrapper of the
# host steps (scripts/lint-env.sh), so that it reuses their artifacts. No
# --locked for the QEMU test crate: it has its own Cargo.lock but depends by
# path on the simulator; cargo adds what is missing and keeps the rest.
source scripts/lint-env.sh

# The host side of the QEMU tests (hans-fw, which makes the field device's
# flash file; the browser test; the QEMU test crate) builds in the
# background while the firmware builds run (when they have not run yet):
# those are long single-threaded links (fat LTO, one codegen unit), and the
# host builds use another target directory. Waited for before the tests.
HOST_BUILD_LOG=$(mktemp)
setsid -w bash -c '
  set -e
  source scripts/host-programs.sh
  CARGO_TARGET_DIR="$1" build_host_programs
  CARGO_TARGET_DIR="$1" cargo test -p hans-web-e2e --features qemu --test web_qemu --locked --no-run
  CARGO_TARGET_DIR="$1" cargo test --manifest-path firmware/qemu-tests/Cargo.toml --no-run
' host-build "$HOST_TARGET" >"$HOST_BUILD_LOG" 2>&1 &
HOST_BUILD=$!
LOG=$(mktemp)
trap 'kill -- "-$HOST_BUILD" 2>/dev/null || true; rm -f "$HOST_BUILD_LOG" "$LOG"' EXIT

bash scripts/firmware-build.sh

# The field-device firmware's web page in headless Chromium (host-tests/web-e2e,
# tests/web_qemu.rs): the page loads from the firmware under QEMU with the live
# status of hans-sim, follows a move and takes a form edit; its load time is
# printed, not asserted. Screenshots in $HOST_TARGET/screenshots/.
echo "==> the host side of the QEMU tests (built in the background)"
host_status=0
wait "$HOST_BUILD" || host_status=$?
cat "$HOST_BUILD_LOG"
[ $host_status = 0 ] || { echo "firmware-tests: the host side of the QEMU tests did not build" >&2; exit 1; }

echo "==> web page from the QEMU field-device firmware (headless Chromium)"
FIRMWARE_BIN_DIR="$BIN_DIR" CARGO_TARGET_DIR="$HOST_TARGET" \
  timeout --kill-after=10 600 \
  cargo test -p hans-web-e2e --features qemu --test web_qemu --locked -- --nocapture

echo "==> QEMU tests"
# One test at a time: each runs a QEMU, and the machine has two cores.
set +e
FIRMWARE_BIN_DIR="$BIN_DIR" CARGO_TARGET_DIR="$HOST_TARGET" \
  timeout --kill-after=10 900 \
  cargo test --manifest-path firmware/qemu-tests/Cargo.toml -- --test-threads=1 --nocapture \
  2>&1 | tee "$LOG"
status=${PIPESTATUS[0]}
set -e

# The EtherNet/IP adapter of the same field-device image against the PyPI
# scanners (discovery, explicit messaging, class 1 I/O while Modbus and the
# page are used): QEMU on a TAP device in a network namespace, as root
# (QEMU's restricted user network drops the guest's UDP). ENIP_QEMU=0 leaves
# it out (a run without root), and says so.
echo "==> EtherNet/IP on the QEMU field device (scripts/enip-qemu.sh)"
if [ "${ENIP_QEMU:-1}" = 0 ]; then
  echo "  left out (ENIP_QEMU=0)"
else
  set +e
  FIRMWARE_BIN_DIR="$BIN_DIR" CARGO_TARGET_DIR="$HOST_TARGET" timeout --kill-after=10 300 \
    bash scripts/enip-qemu.sh 2>&1 | tee -a "$LOG"
  enip_status=${PIPESTATUS[0]}
  set -e
  [ "$enip_status" = 0 ] || status=1
fi

echo "==> stack high-water marks measured under QEMU (painted stack)"
# Each QEMU test prints "<test>: stack_used=N stack_size=M ..." at its end,
# and fails if N is over its firmware's budget (STACK_BUDGETS in
# firmware/qemu-tests/src/lib.rs, the one place they are declared).
grep -oE '[a-z0-9-]+: stack_used=[0-9]+ stack_size=[0-9]+' "$LOG" | grep -v '^diag:' | sed 's/^/  /' || echo "  (none reported)"
grep -E '^[a-z0-9-]+: stack high-water mark .* is over' "$LOG" | sed 's/^/  OVER BUDGET: /' || true
echo "==> web page load time from the field-device firmware under QEMU (reported, not asserted)"
grep -E '^[a-z0-9-]+: page load round' "$LOG" | sed 's/^/  /' || echo "  (none reported)"
echo "==> firmware update under QEMU (tests/update.rs; reported, not asserted)"
# (A test's first line follows its "test ... " line: matched anywhere.)
grep -oE '(update: (full image uploaded|the PLC, idle|the PLC during the uploads|longest engine stall|swap and restart|B confirmed)|update-rollback: B on trial).*' "$LOG" |
  sed 's/^/  /' || echo "  (none reported)"
echo "==> EtherNet/IP class 1 on the QEMU field device (scripts/enip-qemu.sh; reported, and missed datagrams fail it)"
grep -E '^figures: ' "$LOG" | sed 's/^/  /' || echo "  (none reported)"
exit "$status"
