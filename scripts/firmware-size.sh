#!/usr/bin/env bash
# Size report of firmware ELFs: flash (vector table + text + rodata + data)
# and static RAM (data + bss + uninit), against the gateway's budget.
#
#   scripts/firmware-size.sh [--budget] NAME=ELF...
#
# With --budget, every ELF is checked against the gateway goal (128 KiB
# flash, 64 KiB static RAM) and the script exits 1 if one is over.
# The stack is not static RAM: its high-water mark is measured at run time
# (painted stack) and printed by the QEMU tests.
set -euo pipefail

FLASH_BUDGET=$((128 * 1024))
RAM_BUDGET=$((64 * 1024))

budget=0
if [ "${1:-}" = "--budget" ]; then
  budget=1
  shift
fi
[ $# -gt 0 ] || { echo "usage: $0 [--budget] NAME=ELF..." >&2; exit 2; }

size_tool=$(command -v llvm-size || command -v size || true)
[ -n "$size_tool" ] || { echo "firmware-size: need llvm-size or binutils' size" >&2; exit 2; }

kib() { awk -v b="$1" 'BEGIN { printf "%.1f", b / 1024 }'; }

over=0
printf '%-28s %10s %10s %10s %10s %10s %12s\n' firmware text rodata data bss flash static-RAM
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
  printf '%-28s %10d %10d %10d %10d %7s KiB %9s KiB\n' "$name" $((vec + text)) "$rodata" "$data" \
    $((bss + uninit)) "$(kib $flash)" "$(kib $ram)"
  if [ $budget = 1 ]; then
    if [ $flash -gt $FLASH_BUDGET ] || [ $ram -gt $RAM_BUDGET ]; then
      echo "  OVER BUDGET: $name needs $(kib $flash) KiB flash (max 128) and $(kib $ram) KiB static RAM (max 64)"
      over=1
    fi
  fi
done
if [ $budget = 1 ]; then
  if [ $over = 1 ]; then
    exit 1
  fi
  echo "budget: every firmware above is within 128 KiB flash and 64 KiB static RAM"
fi
