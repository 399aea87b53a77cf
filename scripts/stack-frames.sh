#!/usr/bin/env bash
# The largest stack frames of a firmware, to find what made the stack grow.
#
#   scripts/stack-frames.sh [FIRMWARE] [N]
#   scripts/stack-frames.sh --elf ELF [N]
#
# FIRMWARE: field-device (default), gateway (the core), smoke,
# nucleo-f767zi, nucleo-f767zi-field-device. Builds it in release as CI
# does (scripts/firmware-env.sh, the same profile and features), with
# rustc's -Zemit-stack-sizes, into a target directory of its own
# ($CARGO_TARGET_DIR or firmware/target, then stack-frames/: the release
# builds are left alone), then prints its N (default 25) largest frames in
# bytes, largest first, with demangled names (llvm-readobj --stack-sizes,
# llvm-cxxfilt). --elf reads an ELF built with -Zemit-stack-sizes instead.
#
# A frame is one function's own stack (its locals and spills, fixed at
# compile time), paid on every call or poll of it; the stack's high-water
# mark (the QEMU tests print it) is the deepest chain of frames plus the
# interrupts. So one large frame high on the deepest path (a task's poll, a
# join's poll) costs the whole time, and is where a future built on the
# stack before it moves into its task's static storage shows up: a frame
# about the size of that future (size_of_val, or -Zprint-type-sizes).
#
# The compiler: -Z flags need a nightly rustc. The nightly that
# scripts/setup.sh installs (for cargo fuzz) is the minimal profile without
# the thumbv7em-none-eabihf target, and this script installs nothing, so by
# default it uses the stable toolchain that builds the firmware, with
# RUSTC_BOOTSTRAP=1 to accept the flag: the frames are then exactly those
# of the release firmware the QEMU tests run (another rustc lays out frames
# differently). STACK_FRAMES_TOOLCHAIN=nightly uses the nightly instead
# (after `rustup target add --toolchain nightly thumbv7em-none-eabihf`).
#
# Cost: a release build of one firmware (~2-6 min on 2 cores the first
# time, ~1-2 min after a change in the gateway); not part of CI.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)

elf=""
if [ "${1:-}" = "--elf" ]; then
  elf=${2:?"usage: $0 --elf ELF [N]"}
  count=${3:-25}
else
  firmware=${1:-field-device}
  count=${2:-25}
fi
case $count in '' | *[!0-9]*) echo "stack-frames: N must be a number, not '$count'" >&2; exit 2 ;; esac

for tool in llvm-readobj llvm-cxxfilt; do
  command -v "$tool" >/dev/null || { echo "stack-frames: $tool not found (Debian's llvm package; scripts/setup.sh installs it)" >&2; exit 2; }
done

if [ -z "$elf" ]; then
  case $firmware in
    field-device) build=(-p board-mps2-an386 --features field-device --bin field-device) ;;
    gateway | smoke) build=(-p board-mps2-an386 --bin "$firmware") ;;
    nucleo-f767zi) build=(-p board-nucleo-f767zi --bin nucleo-f767zi) ;;
    nucleo-f767zi-field-device) build=(-p board-nucleo-f767zi --features field-device --bin nucleo-f767zi-field-device) ;;
    *) echo "stack-frames: unknown firmware '$firmware' (field-device, gateway, smoke, nucleo-f767zi, nucleo-f767zi-field-device)" >&2; exit 2 ;;
  esac
  toolchain=${STACK_FRAMES_TOOLCHAIN:-}
  if [ -n "$toolchain" ] && ! rustup "+$toolchain" target list --installed 2>/dev/null | grep -qx thumbv7em-none-eabihf; then
    echo "stack-frames: toolchain $toolchain has no thumbv7em-none-eabihf target (rustup target add --toolchain $toolchain thumbv7em-none-eabihf)" >&2
    exit 2
  fi
  # shellcheck source=firmware-env.sh
  source scripts/firmware-env.sh
  export CARGO_TARGET_THUMBV7EM_NONE_EABIHF_RUSTFLAGS="$CARGO_TARGET_THUMBV7EM_NONE_EABIHF_RUSTFLAGS -Zemit-stack-sizes"
  [ -n "$toolchain" ] || export RUSTC_BOOTSTRAP=1
  target=${CARGO_TARGET_DIR:-$ROOT/firmware/target}/stack-frames
  echo "stack-frames: building $firmware (release, -Zemit-stack-sizes, ${toolchain:-default toolchain}) into $target" >&2
  (cd firmware && CARGO_TARGET_DIR="$target" cargo ${toolchain:+"+$toolchain"} build --release --quiet "${build[@]}")
  elf=$target/thumbv7em-none-eabihf/release/$firmware
fi
[ -f "$elf" ] || { echo "stack-frames: $elf not found" >&2; exit 2; }

# Names of generic futures run to kilobytes: cut at STACK_FRAMES_WIDTH
# characters (default 200; 0: whole).
width=${STACK_FRAMES_WIDTH:-200}
case $width in '' | *[!0-9]*) echo "stack-frames: STACK_FRAMES_WIDTH must be a number" >&2; exit 2 ;; esac

# llvm-readobj prints one entry per function: "Functions: [NAME]" then
# "Size: 0xN" (hex).
frames=$(llvm-readobj --stack-sizes "$elf" 2>/dev/null | awk '
  function hex(s,   i, v) {
    v = 0; s = tolower(s); sub(/^0x/, "", s)
    for (i = 1; i <= length(s); i++) v = v * 16 + index("0123456789abcdef", substr(s, i, 1)) - 1
    return v
  }
  /^ *Functions: \[/ { f = $0; sub(/.*Functions: \[/, "", f); sub(/\]$/, "", f) }
  /^ *Size: 0x/ { print hex($2), f }')
[ -n "$frames" ] || { echo "stack-frames: $elf has no .stack_sizes section (not built with -Zemit-stack-sizes)" >&2; exit 2; }

echo "largest stack frames of $elf (bytes, KiB, function):"
# (awk, not head, takes the first N: it reads to the end, so sort is not
# cut off by SIGPIPE, which pipefail would turn into a failure.)
echo "$frames" | sort -rn | awk -v n="$count" 'NR <= n' | llvm-cxxfilt |
  awk -v w="$width" '{
    n = $1; name = substr($0, index($0, " ") + 1)
    if (w > 0 && length(name) > w) name = substr(name, 1, w) "..."
    printf "%8d %6.1f  %s\n", n, n / 1024, name
  }'
