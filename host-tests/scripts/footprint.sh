#!/usr/bin/env bash
# Flash and RAM cost of the codec on a Cortex-M4F (thumbv7em-none-eabihf,
# opt-level "z", LTO, panic = abort): builds host-tests/footprint and prints
# text/data/bss of each profile and what it adds over the baseline (the same
# runtime and harness without the codec).
#
#   bash host-tests/scripts/footprint.sh [--check]
#
# Profiles: client (writes any request for a protocol level, frames and reads
# any reply), server (frames, reads and validates any request, writes any
# reply), full (both), datasheet (DataSheet deframer and JSON decoder), and
# full-v6: full with the codec's `v6` feature (the V6 document's commands
# too). Flash = text + data. With --check, exits 1 when the V5 command-port
# codec (full) exceeds 32 KiB or the V5 + V6 one (full-v6) 48 KiB. Exits 2 on
# an unknown argument or without llvm-size or binutils' size.
set -euo pipefail
cd "$(dirname "$0")/../footprint"

check=0
for arg in "$@"; do
  case "$arg" in
    --check) check=1 ;;
    *) echo "usage: $0 [--check]   (unknown argument: $arg)" >&2; exit 2 ;;
  esac
done

size_tool=$(command -v llvm-size || command -v size || true)
[ -n "$size_tool" ] || { echo "footprint: need llvm-size or binutils' size" >&2; exit 2; }

if ! rustup target list --installed | grep -qx thumbv7em-none-eabihf; then
  echo "footprint: rustup target add thumbv7em-none-eabihf (scripts/setup.sh does it)" >&2
  exit 1
fi
dir="${CARGO_TARGET_DIR:-target}/thumbv7em-none-eabihf/release"
# `full` with the V6 commands first, kept aside; then every profile without.
cargo build --release --quiet --features v6 --bin full
cp "$dir/full" "$dir/full-v6"
cargo build --release --quiet
read_size() { # prints "text data bss" of an ELF
  "$size_tool" -B "$1" | awk 'NR == 2 { print $1, $2, $3 }'
}

# The figures (and the 32 KiB check, which has little margin) depend on the
# compiler: say which one made them.
echo "$(rustc --version) ($(basename "$size_tool"))"
read -r bt bd bb < <(read_size "$dir/baseline")
base=$((bt + bd))
printf '%-10s %8s %6s %6s %12s\n' profile text data bss "codec flash"
printf '%-10s %8d %6d %6d %12s\n' baseline "$bt" "$bd" "$bb" "-"
declare -A flash
for p in client server full datasheet full-v6; do
  read -r t d b < <(read_size "$dir/$p")
  codec=$((t + d - base))
  kib=$(awk -v n="$codec" 'BEGIN { printf "%.1f", n / 1024 }')
  printf '%-10s %8d %6d %6d %7d B = %5s KiB\n' "$p" "$t" "$d" "$b" "$codec" "$kib"
  flash[$p]=$codec
done
over=0
verdict() { # profile, goal in KiB, what
  local goal=$(($2 * 1024)) got=${flash[$1]}
  if [ "$got" -le "$goal" ]; then
    echo "$3 ($1): $got B, within the $2 KiB goal"
  else
    echo "$3 ($1): $got B, OVER the $2 KiB goal by $((got - goal)) B"
    over=1
  fi
}
verdict full 32 "V5 command-port codec"
verdict full-v6 48 "V5 + V6 command-port codec"
[ "$check" = 1 ] && [ "$over" = 1 ] && exit 1
exit 0
