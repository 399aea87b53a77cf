#!/usr/bin/env bash
# Flash and RAM cost of hans-enip on a Cortex-M4F (thumbv7em-none-eabihf,
# opt-level "z", LTO, panic = abort), from enip/footprint:
#   * flash: the adapter binary (TCP framer, encapsulation, objects, class 1
#     and 3, 4 sessions and 4 connections) minus the baseline (the same
#     runtime and harness without it), and the same with the EDS writer;
#   * RAM: the size of the adapter's state and of one framer on the target.
#
#   bash scripts/enip-size.sh [--check]   (--check: exit 1 over 32 KiB of flash for the adapter)
set -euo pipefail
cd "$(dirname "$0")/../enip/footprint"
size_tool=$(command -v llvm-size || true)
nm_tool=$(command -v llvm-nm || true)
[ -n "$size_tool" ] && [ -n "$nm_tool" ] || { echo "enip-size: needs llvm-size and llvm-nm (Debian: llvm)" >&2; exit 2; }
dir="${CARGO_TARGET_DIR:-target}/thumbv7em-none-eabihf/release"
cargo build --release --quiet --locked --bin adapter --features eds
cp "$dir/adapter" "$dir/adapter-eds"
cargo build --release --quiet --locked
flash() { "$size_tool" -B "$1" | awk 'NR == 2 { print $1 + $2 }'; }
base=$(flash "$dir/baseline")
adapter=$(($(flash "$dir/adapter") - base))
eds=$(($(flash "$dir/adapter-eds") - base))
echo "$(rustc --version)"
kib() { awk -v n="$1" 'BEGIN { printf "%.1f", n / 1024 }'; }
printf 'flash, adapter:                %6d B = %5s KiB\n' "$adapter" "$(kib "$adapter")"
printf 'flash, adapter and EDS writer: %6d B = %5s KiB\n' "$eds" "$(kib "$eds")"
"$nm_tool" -S "$dir/ram" | grep ENIP_ | while read -r _ size _ name; do
  printf 'RAM, %-20s %6d B\n' "$name:" "$((16#$size))"
done
if [ "${1:-}" = --check ] && [ "$adapter" -gt $((32 * 1024)) ]; then
  echo "enip-size: the adapter takes more than 32 KiB of flash" >&2
  exit 1
fi
