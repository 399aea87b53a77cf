#!/usr/bin/env bash
# Checks that hans-codec is a crate others can depend on:
#   1. `cargo package` builds the packaged crate on its own (what crates.io
#      would get; also lists the files and their total size);
#   2. `cargo publish --dry-run` passes (uploads nothing; reads the crates.io
#      index);
#   3. the crate compiles (`cargo check`: what an older compiler refuses, it
#      refuses there) with the toolchain of the `rust-version` it declares
#      (installed with rustup when missing), for the host and for
#      thumbv7em-none-eabihf, without and with its features.
# It fails if any of them fails, or if the MSRV toolchain cannot be had.
# Uncommitted changes are packaged as they are (--allow-dirty), so the check
# also works in a working tree with edits.
set -euo pipefail
cd "$(dirname "$0")/.."

echo "--- cargo package -p hans-codec"
cargo package -p hans-codec --allow-dirty --locked
files=$(cargo package -p hans-codec --allow-dirty --locked --list 2>/dev/null)
echo "$files" | sed 's/^/    /'
bytes=$(cd codec && echo "$files" | grep -v -e '^Cargo.toml.orig$' -e '^\.cargo_vcs_info.json$' \
  -e '^Cargo.lock$' -e '^Cargo.toml$' | xargs -d '\n' du -cb | tail -1 | cut -f1)
echo "    $(echo "$files" | wc -l) files; the sources, examples, README and licenses: $bytes bytes"
# A package of a few hundred KiB at most: test corpora belong to host-tests/.
if ((bytes > 1024 * 1024)); then
  echo "codec-publish-check: the package holds $bytes bytes of files (more than 1 MiB)" >&2
  exit 1
fi

echo "--- cargo publish --dry-run -p hans-codec"
# The package was built on its own just above: the dry run checks the rest
# (metadata, the crates.io index) without building it a second time.
cargo publish --dry-run --no-verify -p hans-codec --allow-dirty --locked

# The MSRV as declared in the package (the workspace's `rust-version`).
msrv=$(cargo metadata --no-deps --format-version 1 --locked | python3 -c '
import json, sys
pkg = [p for p in json.load(sys.stdin)["packages"] if p["name"] == "hans-codec"][0]
print(pkg["rust_version"] or "")')
if [[ -z "$msrv" ]]; then
  echo "codec-publish-check: hans-codec declares no rust-version" >&2
  exit 1
fi
echo "--- MSRV: hans-codec declares rust-version $msrv"
# Its own compiler: not the stable clippy-driver of scripts/lint-env.sh
# (which would build with itself, whatever toolchain runs cargo).
unset RUSTC_WORKSPACE_WRAPPER CLIPPY_ARGS
if ! rustup run "$msrv" rustc --version >/dev/null 2>&1; then
  echo "installing the Rust $msrv toolchain"
  rustup toolchain install "$msrv" --profile minimal
fi
rustup target add --toolchain "$msrv" thumbv7em-none-eabihf
got=$(rustup run "$msrv" rustc --version)
echo "    $got"
# `1.87` must be a 1.87.x compiler, `1.87.0` exactly 1.87.0.
case "$got" in
  "rustc $msrv "* | "rustc $msrv."*) ;;
  *)
    echo "codec-publish-check: the toolchain for $msrv is '$got', not the declared MSRV" >&2
    exit 1
    ;;
esac
rustup run "$msrv" cargo check -p hans-codec --lib --locked
rustup run "$msrv" cargo check -p hans-codec --lib --locked --features v6,defmt
rustup run "$msrv" cargo check -p hans-codec --lib --locked --features v6,defmt \
  --target thumbv7em-none-eabihf
echo "codec-publish-check: package, publish dry-run and the MSRV ($msrv) check passed"
