#!/usr/bin/env bash
# Proves that the builds of scripts/test-all.sh lint (scripts/lint-env.sh):
# a crate with a clippy finding (a `&Vec` parameter, clippy::ptr_arg) must
# fail to build, and builds once the finding is fixed. A crate of its own in
# a temporary directory (a second or two to build).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/lint-env.sh
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
mkdir "$dir/src"
cat >"$dir/Cargo.toml" <<'TOML'
[package]
name = "lint-build-check"
version = "0.0.0"
edition = "2021"
publish = false
[workspace]
TOML
echo 'pub fn len(v: &Vec<u8>) -> usize { v.len() }' >"$dir/src/lib.rs"
if out=$(cd "$dir" && cargo build --offline 2>&1); then
  echo "lint-build-check: a crate with a clippy finding built: the builds do not lint" >&2
  echo "$out" >&2
  exit 1
fi
if ! grep -q "ptr_arg" <<<"$out"; then
  echo "lint-build-check: the build failed, but not on clippy::ptr_arg:" >&2
  echo "$out" >&2
  exit 1
fi
echo 'pub fn len(v: &[u8]) -> usize { v.len() }' >"$dir/src/lib.rs"
(cd "$dir" && cargo build --offline -q)
echo "lint-build-check: a clippy finding fails the build (clippy::ptr_arg), the fixed crate builds"
