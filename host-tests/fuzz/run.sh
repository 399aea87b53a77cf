#!/usr/bin/env bash
# Builds every fuzz target and runs each for a bounded time.
#
#   bash host-tests/fuzz/run.sh [SECONDS_PER_TARGET]   (default 20)
#   bash host-tests/fuzz/run.sh --build-only           (the targets' build alone)
#
# Seeds come from the test vectors (seeds.py, into the git-ignored corpus/);
# a target with a dictionary (dicts/<target>.dict) gets it with -dict.
# Runs FUZZ_JOBS targets at a time (default 2). Fails (non-zero exit) after
# the batch with the first crash; libFuzzer leaves the input in
# artifacts/<target>/. Idempotent: run it again and it carries on from the
# corpus it built. Needs the nightly toolchain and cargo-fuzz
# (scripts/setup.sh installs both). Set FUZZ_TARGETS="framer reply" to run a
# subset.
#
# The gateway_modbus, gateway_robot and gateway_http targets build one world
# per process and reset what an input stored (fuzz_targets/common.rs), so
# a crash may also depend on what earlier inputs left (channel statuses, web
# sessions, the robot link; stored state is reset): rerun the crashing input
# alone first (cargo +nightly fuzz run <t> artifacts/<t>/crash-...); if it
# passes alone, it needs what ran before it in that process, which libFuzzer
# does not record.
set -euo pipefail
cd "$(dirname "$0")"

build_only=0
if [ "${1:-}" = --build-only ]; then
  build_only=1
  shift
fi
secs=${1:-20}
targets=(${FUZZ_TARGETS:-framer request reply datasheet gateway_modbus gateway_robot gateway_image gateway_http gateway_audit_page gateway_mqtt update_image update_upload enip_stream enip_cpf enip_cip})

if ! rustup toolchain list | grep -q '^nightly'; then
  echo "fuzz: the nightly toolchain is missing (bash scripts/setup.sh installs it)" >&2
  exit 1
fi
if ! cargo +nightly fuzz --version >/dev/null 2>&1; then
  echo "fuzz: cargo-fuzz is missing (bash scripts/setup.sh installs it)" >&2
  exit 1
fi

# The fuzz targets build with nightly's compiler: not with the stable
# clippy-driver that scripts/lint-env.sh may have set for stable builds
# (hans-fw, for the seed below, keeps it: it shares the host steps' build).
nightly() {
  env -u RUSTC_WORKSPACE_WRAPPER -u CLIPPY_ARGS cargo +nightly "$@"
}
nightly fuzz build
# (scripts/test-all.sh builds them first, in the background, and runs them
# later: the build uses its own target directory, host-tests/fuzz/target.)
[ $build_only = 0 ] || exit 0
python3 seeds.py
# The image target's seed: an image signed with the development key
# (firmware/keys/dev.key) by hans-fw, so that the fuzzer starts past the
# signature and mutates a body the header signed (seeds.py cannot sign).
mkdir -p corpus/update_image
seed_dir=$(mktemp -d)
head -c 3000 /dev/zero | tr '\0' '\125' >"$seed_dir/fw.bin"
(cd ../.. && source scripts/host-programs.sh && build_host_programs &&
  "${CARGO_TARGET_DIR:-target}/debug/hans-fw" sign --key firmware/keys/dev.key --board mps2-an386 \
    --version 1.2.0 "$seed_dir/fw.bin" -o "$seed_dir/fw.img" >/dev/null)
{ printf '\007\000'; cat "$seed_dir/fw.img"; } >corpus/update_image/signed-dev-key
rm -rf "$seed_dir"
# Two targets at a time (FUZZ_JOBS): libFuzzer runs one process on one
# core, and the machines this runs on have two.
jobs=${FUZZ_JOBS:-2}
logs=$(mktemp -d)
trap 'rm -rf "$logs"' EXIT
fuzz_one() {
  local t=$1 max_len=8192 dict=()
  mkdir -p "corpus/$t" "artifacts/$t"
  # The robot target gives each scripted reply simulated time, so its cost
  # grows with the input: 2 KiB still holds two replies at the link's 1 KiB
  # limit (or dozens of short ones), and keeps it above 2,000 inputs a second.
  [ "$t" = gateway_robot ] && max_len=2048
  # A target's dictionary of words (dicts/<target>.dict), if it has one.
  [ -f "dicts/$t.dict" ] && dict=(-dict="dicts/$t.dict")
  nightly fuzz run "$t" "corpus/$t" -- \
    -max_total_time="$secs" -timeout=10 -rss_limit_mb=2048 -max_len="$max_len" \
    "${dict[@]}" -print_final_stats=1 >"$logs/$t.log" 2>&1
}
failed=()
for ((i = 0; i < ${#targets[@]}; i += jobs)); do
  batch=("${targets[@]:i:jobs}")
  pids=()
  for t in "${batch[@]}"; do
    echo "==> fuzz $t for ${secs}s"
    fuzz_one "$t" &
    pids+=($!)
  done
  for k in "${!batch[@]}"; do
    t=${batch[$k]}
    status=0
    wait "${pids[$k]}" || status=$?
    echo "--- $t"
    grep -E 'stat::number_of_executed_units|stat::new_units_added|Done [0-9]+ runs' "$logs/$t.log" || true
    if [ "$status" -ne 0 ]; then
      tail -n 60 "$logs/$t.log" >&2
      echo "fuzz: $t FAILED (exit $status); the input is in host-tests/fuzz/artifacts/$t/" >&2
      failed+=("$t")
    fi
  done
  # A crash ends the run after its batch (its input is kept).
  [ ${#failed[@]} -eq 0 ] || exit 1
done
echo "fuzz: ${#targets[@]} targets, ${secs}s each, no crash"
