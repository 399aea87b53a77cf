#!/usr/bin/env bash
# Builds every firmware in release and checks its size: rustfmt of the
# firmware workspace and its host tests, the NUCLEO's debugging
# configuration (checked, not built), then for each board the core gateway
# and the field-device firmware (feature `field-device`: web page, DHCP,
# DataSheet reader, ...), the QEMU board's smoke firmware and both
# bootloaders; then the size report with its budgets (scripts/firmware-size.sh:
# core 160 KiB flash / 64 KiB static RAM, field device 480 / 256, bootloader
# 64 / 16; all tables are printed before a budget fails the run).
#
# Every build here is also the clippy run (-D warnings) of what it compiles
# from this repository: the firmware workspace's crates, and the gateway,
# codec, EtherNet/IP and image crates it depends on by path, each in the
# configuration a board ships (firmware_cargo in scripts/firmware-env.sh
# says how).
#
# scripts/firmware-tests.sh runs this first (a no-op when nothing changed);
# scripts/test-all.sh runs it from its start in the background, at low
# priority, in the time the host steps leave a core idle: it uses its own
# target directory (firmware/target), so it never waits on theirs.
#
# Environment: CARGO_TARGET_DIR (default: firmware/target).
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)

source scripts/firmware-env.sh
FW_TARGET=${CARGO_TARGET_DIR:-$ROOT/firmware/target}
BIN_DIR="$FW_TARGET/thumbv7em-none-eabihf/release"

# No --locked: firmware/ has its own Cargo.lock but depends by path on the
# gateway and the codec; a dependency those crates add must not break this
# step until someone refreshes the lock file. Cargo adds what is missing and
# keeps the rest. Every build is a clippy run: scripts/lint-env.sh's wrapper,
# given to every crate by firmware_cargo (scripts/firmware-env.sh).
source scripts/lint-env.sh
export CARGO_TARGET_DIR="$FW_TARGET"

echo "==> firmware: rustfmt; the NUCLEO's debugging configuration"
(cd firmware && cargo fmt --all -- --check)
(cd firmware/qemu-tests && cargo fmt -- --check)
# The NUCLEO's debugging build (panic locations in the log) must keep
# building: the one configuration checked and not built.
(cd firmware && firmware_cargo check --release -p board-nucleo-f767zi --features panic-location --all-targets)

# The field-device binaries have `required-features = ["field-device"]`: the
# core builds leave them out, and the field-device builds name them alone, so
# that no build overwrites a core binary with a field-device one.
echo "==> build firmware (release): mps2-an386 (QEMU): core gateway and smoke"
(cd firmware && firmware_cargo build --release -p board-mps2-an386 --bins)
echo "==> build firmware (release): mps2-an386 (QEMU): field device"
(cd firmware && firmware_cargo build --release -p board-mps2-an386 --features field-device --bin field-device)
echo "==> build firmware (release): mps2-an386 (QEMU): bootloader"
# The crates only the bootloaders and the field devices use are named, so
# that this build compiles (and lints) them on their own too.
(cd firmware && firmware_cargo build --release -p bootloader-mps2 -p fw-boot -p semihosting-flash -p fw-keys)
echo "==> build firmware (release): nucleo-f767zi: core gateway"
(cd firmware && firmware_cargo build --release -p board-nucleo-f767zi --bin nucleo-f767zi)
echo "==> build firmware (release): nucleo-f767zi: field device"
(cd firmware && firmware_cargo build --release -p board-nucleo-f767zi --features field-device --bin nucleo-f767zi-field-device)
echo "==> build firmware (release): nucleo-f767zi: bootloader"
(cd firmware && firmware_cargo build --release -p bootloader-nucleo)

echo "==> firmware size"
bash scripts/firmware-size.sh smoke="$BIN_DIR/smoke"
size_status=0
bash scripts/firmware-size.sh --budget core \
  gateway-mps2-an386="$BIN_DIR/gateway" \
  gateway-nucleo-f767zi="$BIN_DIR/nucleo-f767zi" || size_status=1
bash scripts/firmware-size.sh --budget field-device \
  field-device-mps2-an386="$BIN_DIR/field-device" \
  field-device-nucleo-f767zi="$BIN_DIR/nucleo-f767zi-field-device" || size_status=1
bash scripts/firmware-size.sh --budget bootloader \
  bootloader-mps2-an386="$BIN_DIR/bootloader-mps2" \
  bootloader-nucleo-f767zi="$BIN_DIR/bootloader-nucleo" || size_status=1
[ $size_status = 0 ] || { echo "firmware size: over budget (see above)" >&2; exit 1; }
