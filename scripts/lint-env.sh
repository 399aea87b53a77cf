# Sourced (not run): makes every cargo build that follows also the clippy
# run of the crates it builds, with warnings as errors.
#
# Cargo runs clippy-driver (the compiler with clippy's lints) in place of
# rustc for the crates a command names (or all of a --workspace):
# RUSTC_WORKSPACE_WRAPPER, with CLIPPY_ARGS as its lint options, is what
# `cargo clippy` itself sets before it runs `cargo check`. A separate
# `cargo clippy` checks every crate once more, in check mode, whose results
# no build can reuse; this way each configuration that is built is also
# linted, and the builds of all steps share one kind of artifact (a build
# with and one without the wrapper are two builds: set it for all of them).
#
# Builds with another toolchain (nightly for the fuzz targets, the codec's
# MSRV) unset both variables for their command: this clippy-driver is the
# stable compiler. scripts/lint-build-check.sh proves a lint fails a build.
if [ -z "${RUSTC_WORKSPACE_WRAPPER:-}" ]; then
  RUSTC_WORKSPACE_WRAPPER=$(rustup which clippy-driver)
  export RUSTC_WORKSPACE_WRAPPER
  export CLIPPY_ARGS="-D__CLIPPY_HACKERY__warnings__CLIPPY_HACKERY__"
fi
