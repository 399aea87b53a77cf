#!/usr/bin/env bash
# Makes a signed update image from a firmware ELF linked for the update
# slots (the field device): the raw bytes the bootloader copies
# (llvm-objcopy -O binary), signed with `hans-fw sign`. The one place that
# does this: scripts/qemu-run.sh makes its flash file here, and the QEMU
# update tests (firmware/qemu-tests/tests/update.rs) their images to upload.
#
#   scripts/fw-image.sh FIRMWARE.elf OUT.img
#       the signed image (what `POST /api/firmware` takes)
#   scripts/fw-image.sh --flash FIRMWARE.elf OUT.flash
#       a whole flash of the QEMU board with that image active, nothing to
#       swap (`hans-fw install --layout mps2-an386`)
#
# Environment:
#   FW_VERSION  the version signed, X.Y.Z (default 0.1.0)
#   FW_KEY      the secret key (default firmware/keys/dev.key, the
#               development key: never for a plant's devices)
#   FW_BOARD    the board the image is for (default mps2-an386)
#   HANS_FW     the hans-fw program (default: target/{debug,release}/hans-fw
#               of the host workspace, under CARGO_TARGET_DIR if set, else on
#               PATH)
set -euo pipefail

usage="usage: fw-image.sh [--flash] FIRMWARE.elf OUT"
flash=0
if [ "${1:-}" = --flash ]; then
  flash=1
  shift
fi
elf=${1:?$usage}
out=${2:?$usage}
root=$(cd "$(dirname "$0")/.." && pwd)

hans_fw=${HANS_FW:-}
if [ -z "$hans_fw" ]; then
  for t in "${CARGO_TARGET_DIR:-$root/target}" "$root/target"; do
    for p in debug release; do
      if [ -z "$hans_fw" ] && [ -x "$t/$p/hans-fw" ]; then hans_fw=$t/$p/hans-fw; fi
    done
  done
  [ -n "$hans_fw" ] || hans_fw=$(command -v hans-fw || true)
fi
[ -n "$hans_fw" ] || {
  echo "fw-image.sh: hans-fw is needed: cargo build -p hans-fw, or set HANS_FW" >&2
  exit 2
}

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
llvm-objcopy -O binary "$elf" "$work/firmware.bin"
"$hans_fw" sign --key "${FW_KEY:-$root/firmware/keys/dev.key}" --board "${FW_BOARD:-mps2-an386}" \
  --version "${FW_VERSION:-0.1.0}" "$work/firmware.bin" -o "$work/firmware.img" >/dev/null
if [ $flash = 1 ]; then
  "$hans_fw" install --layout mps2-an386 --out "$out" "$work/firmware.img" >/dev/null
else
  mv "$work/firmware.img" "$out"
fi
