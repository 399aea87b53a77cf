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
_fw_root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
export CARGO_TARGET_THUMBV7EM_NONE_EABIHF_RUSTFLAGS="--remap-path-prefix=${CARGO_HOME:-$HOME/.cargo}/registry/src/= --remap-path-prefix=$_fw_root/="
unset _fw_root
