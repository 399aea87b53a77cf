#!/usr/bin/env bash
# Size report of firmware ELFs: flash (vector table + text + rodata + data)
# and static RAM (data + bss + uninit), against a budget.
#
#   scripts/firmware-size.sh [--budget core|field-device|bootloader] NAME=ELF...
#
# With --budget, every ELF given is checked against that budget and the
# script exits 1 if one is over:
#   core          the core gateway (Modbus and the robot link; no web page,
#                 no DHCP, no DataSheet reader, no updates: one image on a board
#                 with 256 KiB of flash or more): 160 KiB flash, 64 KiB static RAM.
#                 Why these figures: firmware/README.md.
#   field-device  everything a plant's device has (the page, accounts, the audit
#                 log, DHCP, SNTP, the DataSheet reader, V6, MQTT, updates, and the
#                 second PLC protocol to come): 480 KiB flash, 256 KiB static RAM.
#                 The flash must fit the smallest update slot (the QEMU board's,
#                 511 KiB of body; the NUCLEO's is 767) with room to spare, so that
#                 every later image still installs A/B; the RAM leaves the NUCLEO's
#                 512 KiB half for the stack (budget 80 KiB, firmware/qemu-tests) and
#                 its Ethernet DMA. Why these figures: firmware/README.md.
#   bootloader    the QEMU board's bootloader: 64 KiB flash (the code memory
#                 below the slot copy at 0x0001_0000), 16 KiB static RAM
# (`--budget` alone means `core`.) Without it the table is printed only.
# The stack is not static RAM: its high-water mark is measured at run time
# (painted stack) and printed by the QEMU tests.
set -euo pipefail

budget=""
if [ "${1:-}" = "--budget" ]; then
  shift
  case "${1:-}" in
    core | field-device | bootloader) budget=$1; shift ;;
    *) budget=core ;;
  esac
fi
[ $# -gt 0 ] || { echo "usage: $0 [--budget core|field-device] NAME=ELF..." >&2; exit 2; }

case "$budget" in
  core) FLASH_KIB=160; RAM_KIB=64 ;;
  field-device) FLASH_KIB=480; RAM_KIB=256 ;;
  bootloader) FLASH_KIB=64; RAM_KIB=16 ;;
  *) FLASH_KIB=0; RAM_KIB=0 ;;
esac
FLASH_BUDGET=$((FLASH_KIB * 1024))
RAM_BUDGET=$((RAM_KIB * 1024))

size_tool=$(command -v llvm-size || command -v size || true)
[ -n "$size_tool" ] || { echo "firmware-size: need llvm-size or binutils' size" >&2; exit 2; }

kib() { awk -v b="$1" 'BEGIN { printf "%.1f", b / 1024 }'; }

if [ -n "$budget" ]; then
  echo "budget $budget: $FLASH_KIB KiB flash, $RAM_KIB KiB static RAM"
fi
over=0
printf '%-32s %10s %10s %10s %10s %10s %12s\n' firmware text rodata data bss flash static-RAM
for arg in "$@"; do
  name=${arg%%=*}
  elf=${arg#*=}
  [ -f "$elf" ] || { echo "firmware-size: $elf not found" >&2; exit 2; }
  # `size -A` prints one "section size addr" line per section.
  read -r vec text rodata data bss uninit < <("$size_tool" -A "$elf" | awk '
    $1 == ".vector_table" { v = $2 } $1 == ".text" { t = $2 } $1 == ".rodata" { r = $2 }
    $1 == ".data" { d = $2 } $1 == ".bss" { b = $2 } $1 == ".uninit" { u = $2 }
    END { print v+0, t+0, r+0, d+0, b+0, u+0 }')
  flash=$((vec + text + rodata + data))
  ram=$((data + bss + uninit))
  printf '%-32s %10d %10d %10d %10d %7s KiB %9s KiB\n' "$name" $((vec + text)) "$rodata" "$data" \
    $((bss + uninit)) "$(kib $flash)" "$(kib $ram)"
  if [ -n "$budget" ]; then
    if [ $flash -gt $FLASH_BUDGET ] || [ $ram -gt $RAM_BUDGET ]; then
      echo "  OVER BUDGET ($budget): $name needs $(kib $flash) KiB flash (max $FLASH_KIB) and $(kib $ram) KiB static RAM (max $RAM_KIB)"
      over=1
    fi
  fi
done
if [ -n "$budget" ]; then
  if [ $over = 1 ]; then
    exit 1
  fi
  echo "budget $budget: every firmware above is within $FLASH_KIB KiB flash and $RAM_KIB KiB static RAM"
fi
