# Sourced (not run) by the scripts that build firmware: source scripts/firmware-env.sh
#
# Panic locations are kept in flash (the panic handler logs file and line),
# and rustc writes them as absolute paths: the registry's
# ($CARGO_HOME/registry/src/index.crates.io-HASH/...) and this checkout's.
# That cost 4.4 KiB of the core firmware's 128 KiB, and more the longer the
# checkout's path, so one source built from two directories differed in
# size. Remapped, a location reads `index.crates.io-HASH/smoltcp-0.13.1/src/...`
# or `gateway/src/link.rs`: 2.3 KiB less, and the same size from any directory.
#
# Cargo appends CARGO_TARGET_<triple>_RUSTFLAGS to the rustflags of
# firmware/.cargo/config.toml (the linker scripts stay); a build by hand
# without this file works too, only larger.
#
# CI may run without HOME (cargo then asks the password database, and so do
# we) and in a directory whose path holds a space (this variable is split at
# whitespace: such a prefix is left out, with a warning, and the build is
# only larger).
_fw_root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
_fw_home=${HOME:-$(getent passwd "$(id -u)" | cut -d: -f6)}
_fw_flags=""
for _fw_prefix in "${CARGO_HOME:-$_fw_home/.cargo}/registry/src/" "$_fw_root/"; do
  case $_fw_prefix in
    *[[:space:]]*) echo "firmware-env: not remapping '$_fw_prefix' (it holds whitespace)" >&2 ;;
    *) _fw_flags="$_fw_flags --remap-path-prefix=$_fw_prefix=" ;;
  esac
done
export CARGO_TARGET_THUMBV7EM_NONE_EABIHF_RUSTFLAGS="${_fw_flags# }"
unset _fw_root _fw_home _fw_flags _fw_prefix

# firmware_cargo ARGS...: cargo for a firmware build. Where the lint wrapper
# of scripts/lint-env.sh is in effect (scripts/test-all.sh,
# scripts/firmware-build.sh), clippy-driver becomes the wrapper of every
# crate of the build (RUSTC_WRAPPER) rather than of the firmware
# workspace's members alone: it then lints, -D warnings, the gateway, the
# codec and the other crates the boards use by path, as they ship, and
# compiles the registry's crates as rustc does (cargo caps their lints).
# Every firmware build of a run uses the same form, so that none rebuilds
# what another built (cargo's fingerprints include the wrapper). Without
# the lint wrapper (the demo, by hand): plain cargo.
firmware_cargo() {
  if [ -n "${RUSTC_WORKSPACE_WRAPPER:-}" ]; then
    env -u RUSTC_WORKSPACE_WRAPPER RUSTC_WRAPPER="$RUSTC_WORKSPACE_WRAPPER" cargo "$@"
  else
    cargo "$@"
  fi
}
