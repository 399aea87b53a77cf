# Sourced (not run) by the scripts that start the host programs
# (hans-gateway, hans-sim, hansctl, hans-fw):
#
#   source scripts/host-programs.sh && build_host_programs
#
# One cargo command builds them all (debug, in ${CARGO_TARGET_DIR:-target}),
# with one feature resolution: a command per program (`cargo build -p
# hans-sim`) would resolve the features of that package alone and rebuild
# the codec, the gateway and their dependencies with another feature set,
# once for each selection.
#
# In scripts/test-all.sh the host tests' build (scripts/host-tests.py) has
# made every one of them already, from the same tree, with the workspace's
# test features; test-all.sh then sets HOST_PROGRAMS_BUILT=1 and this only
# checks that they are there (building them again in the selection below
# would compile the gateway and the codec a further time).
build_host_programs() {
  local dir=${CARGO_TARGET_DIR:-target}/debug p
  if [ -n "${HOST_PROGRAMS_BUILT:-}" ]; then
    for p in hans-gateway hans-sim hansctl hans-fw; do
      [ -x "$dir/$p" ] || {
        echo "host-programs: HOST_PROGRAMS_BUILT is set but $dir/$p is missing" >&2
        return 1
      }
    done
    return 0
  fi
  cargo build --workspace --exclude hans-host-tests --bins --locked -q
}
