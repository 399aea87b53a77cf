#!/usr/bin/env bash
# Runs every check and test of the project, installing what it needs first.
# This is the README's test command and what CI runs (.ci/run).
#
# Each step is timed; the run stops at the first failing step. The last line
# is the total of tests passed and failed across all test runners.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
LOG_DIR=$(mktemp -d)

# The CPU time the machine spent (user, nice, system; every process, in
# clock ticks) since boot: a step's share of it, over its wall time, shows
# whether it kept both cores busy or waited.
cpu_ticks() {
  awk '/^cpu / { print $2 + $3 + $4; exit }' /proc/stat 2>/dev/null || echo 0
}
CORES=$(nproc 2>/dev/null || echo 1)
TICKS=$(getconf CLK_TCK 2>/dev/null || echo 100)

# "N cores busy": the step's CPU time over its wall time.
busy() {
  local ticks=$1 secs=$2
  awk -v t="$ticks" -v s="$secs" -v hz="$TICKS" -v n="$CORES" \
    'BEGIN { if (s < 1) s = 1; printf "%.1f/%d cores", t / hz / s, n }'
}

RUN_CPU0=$(cpu_ticks)
bash scripts/setup.sh

PASSED=0
FAILED=0
STEPS=()

# Every build of this run is also the clippy run (-D warnings) of the
# crates it builds: scripts/lint-env.sh says how, and the step after rustfmt
# proves it. So there is no separate `cargo clippy` of the host workspace:
# the host tests' build (every target of every crate) is it.
source scripts/lint-env.sh

# Adds the "test result: ok. N passed; M failed" lines of a log to the totals.
count_tests() {
  local p f
  p=$( (grep -Eo 'test result: [a-zA-Z]+\. [0-9]+ passed' "$1" || true) | awk '{s+=$4} END {print s+0}')
  f=$( (grep -Eo 'test result: [a-zA-Z]+\. [0-9]+ passed; [0-9]+ failed' "$1" || true) | awk '{s+=$6} END {print s+0}')
  PASSED=$((PASSED + p))
  FAILED=$((FAILED + f))
}

# TEST_ALL_FROM=<text>: skip the steps before the first whose name contains
# <text> (resuming after a failed step, on a tree that ran the earlier ones).
FROM=${TEST_ALL_FROM:-}

# Whether step NAME runs (not while TEST_ALL_FROM still skips; a skipped
# step is listed as such).
wanted() {
  if [ -n "$FROM" ]; then
    if [[ "$1" != *"$FROM"* ]]; then
      STEPS+=("skip      $1 (TEST_ALL_FROM)")
      return 1
    fi
    FROM=
  fi
  return 0
}

step() {
  local name=$1
  shift
  wanted "$name" || return 0
  local log="$LOG_DIR/step-${#STEPS[@]}.log"
  local start=$SECONDS cpu0
  cpu0=$(cpu_ticks)
  echo "==> $name"
  local status=0
  "$@" 2>&1 | tee "$log" || status=$?
  count_tests "$log"
  ended $status "$((SECONDS - start))s ($(busy $(($(cpu_ticks) - cpu0)) $((SECONDS - start))))" "$name"
}

# Adds a step's summary line (STATUS 0: ok); a failed step ends the run
# with the summary so far.
ended() {
  if [ "$1" = 0 ]; then
    STEPS+=("ok   $2  $3")
    return 0
  fi
  STEPS+=("FAIL $2  $3")
  printf '%s\n' "${STEPS[@]}"
  echo "$PASSED passed, $((FAILED > 0 ? FAILED : 1)) failed"
  exit 1
}

# A step that runs in the background alongside the steps that follow it,
# until `join ID` waits for it: for work that fills the core the foreground
# steps leave idle (tests waiting on Chromium, scanners, one-crate builds,
# QEMU), where neither's result depends on the other's speed. It must not
# share a cargo target directory with the foreground steps (cargo would
# make one wait for the other's lock). Its output goes to its log and is
# printed whole at the join; its summary line has its wall time only (the
# CPU is shared).
#
#   step_bg ID [--idle] NAME COMMAND...
#
# --idle: it runs at the lowest priority (nice 19, and its own scheduling group's,
# since setsid gives it one), so it takes only what the foreground leaves.
declare -A BG_PID BG_NAME BG_LOG BG_START
step_bg() {
  local id=$1 idle=0
  shift
  if [ "$1" = --idle ]; then
    idle=1
    shift
  fi
  local name=$1
  shift
  wanted "$name" || return 0
  BG_NAME[$id]=$name
  BG_LOG[$id]="$LOG_DIR/bg-$id.log"
  BG_START[$id]=$SECONDS
  echo "==> $name (in the background; its output follows at the join)"
  # A process group of its own (setsid), so that stopping it stops all of it.
  setsid -w bash -c '
    if [ "$1" = 1 ]; then
      echo 19 >/proc/self/autogroup 2>/dev/null || true
      shift
      exec nice -n 19 "$@"
    fi
    shift
    exec "$@"' bg "$idle" "$@" >"${BG_LOG[$id]}" 2>&1 &
  BG_PID[$id]=$!
}
join() {
  local id=$1
  [ -n "${BG_PID[$id]:-}" ] || return 0
  local status=0 pid=${BG_PID[$id]}
  wait "$pid" || status=$?
  unset "BG_PID[$id]"
  echo "==> ${BG_NAME[$id]} (joined)"
  cat "${BG_LOG[$id]}"
  count_tests "${BG_LOG[$id]}"
  ended $status "$((SECONDS - BG_START[$id]))s (in the background)" "${BG_NAME[$id]}"
}
# A failing step ends the run: the background ones are stopped with it.
stop_bg() {
  local pid
  for pid in "${BG_PID[@]}"; do
    kill -- "-$pid" 2>/dev/null || true
  done
}
trap 'rm -rf "$LOG_DIR"; stop_bg' EXIT

# --- in the background from the start, each in a target directory of its
# own: the firmware's release builds at normal priority in a scheduling
# group of their own (a fair share of the cores: their long
# single-threaded fat-LTO links must be done before the QEMU tests need
# them; at the lowest priority the host steps starved them and the run
# waited ~6 minutes at the join, one core idle), with their size budgets;
# the fuzz targets' build (nightly) and the documentation at the lowest
# priority. They are joined where their results are needed.
step_bg firmware "firmware: release builds of both boards and bootloaders (each the clippy run of what it compiles), size budgets" \
  bash scripts/firmware-build.sh
step_bg fuzz-build --idle "fuzz targets build (nightly, host-tests/fuzz/target)" \
  bash host-tests/fuzz/run.sh --build-only
step_bg rustdoc --idle "rustdoc without warnings: codec, gateway (every feature), firmware image, Linux platform, EtherNet/IP" \
  env CARGO_TARGET_DIR="$ROOT/target/rustdoc" bash scripts/rustdoc-check.sh

# --- lints and docs
step "rustfmt" cargo fmt --all -- --check
step "the gateway's layer order (lib.rs) holds, and its check catches an upward import" \
  bash -c 'python3 scripts/layers.py && python3 scripts/layers.py --self-test'
step "every build lints: a clippy finding fails it (scripts/lint-env.sh)" bash scripts/lint-build-check.sh

# --- host tests: codec vectors and properties, DataSheet, simulator, hansctl,
# gateway unit tests, end to end (gateway + hans-sim + tokio-modbus + mbpoll,
# the embassy-net path on two in-process stacks, and the web page in headless
# Chromium: host-tests/web-e2e, screenshots in target/screenshots/)
# The corpus is compared with the protocol document, which is not part of
# the repository: it sits beside the checkout (../shared/spec) or where
# HANS_SPEC says. Without it this one comparison is skipped, loudly; the
# vector tests below still run every corpus line through the codec.
SPEC=${HANS_SPEC:-$ROOT/../shared/spec/HR-TCP-V1.0.0.3.zh.txt}
if [ -f "$SPEC" ]; then
  step "vectors are the document's example lines" \
    python3 host-tests/scripts/chapter4.py check host-tests/vectors/chapter4.txt "$SPEC"
else
  echo "==> vectors are the document's example lines: SKIPPED, no protocol document at $SPEC"
  STEPS+=("skip      vectors are the document's example lines (no document at $SPEC; set HANS_SPEC)")
fi
SPEC6=${HANS_SPEC_V6:-$ROOT/../shared/spec/HuayanRobotV6-V1.0.19.1.zh.txt}
if [ -f "$SPEC6" ]; then
  step "V6 vectors are the V6 document's example lines" \
    python3 host-tests/scripts/chapter4.py check host-tests/vectors/v6/chapter4.txt "$SPEC6"
else
  echo "==> V6 vectors are the V6 document's example lines: SKIPPED, no document at $SPEC6"
  STEPS+=("skip      V6 vectors are the V6 document's example lines (no document at $SPEC6; set HANS_SPEC_V6)")
fi
# The V6 commands are behind the codec's `v6` feature, which the workspace
# build below does not turn on: their vectors, properties and typed tests run
# here, in a build of the codec and its tests alone.
# (Its benchmark is checked, and so linted, here too; the codec's defmt
# feature is linted by its thumbv7em build below.)
step "codec with the V6 commands (feature v6): vectors, properties, typed tests" \
  bash -c 'cargo check -p hans-host-tests --features v6 --benches --locked &&
    cargo test -p hans-codec -p hans-host-tests --features hans-host-tests/v6 --locked'
# hans-sim and hansctl build the codec with `v6`, and Cargo turns a feature on
# for the whole of one build: the V5-only vectors need a codec without it, so
# the codec and its tests run alone first, then everything else.
step "host tests: the codec without v6 (V5-only vectors)" cargo test -p hans-codec -p hans-host-tests --locked
# The rest of the workspace: one build, the binaries in two lanes (the
# browser tests wait on Chromium while the simulations use a core).
step "host tests (their build, every target of the workspace, is its clippy run)" \
  python3 scripts/host-tests.py --exclude hans-host-tests
# That build made the programs the later steps start (hans-gateway, hans-sim,
# hansctl, hans-fw): they use them as built (scripts/host-programs.sh).
[ -n "$FROM" ] || export HOST_PROGRAMS_BUILT=1
step "systemd unit (verify; run it where systemd is PID 1)" bash scripts/systemd-unit-test.sh
# Sparkplug B and its MQTT client are in `default`: the host tests above ran
# their unit tests (virtual time, fake broker), tests/mqtt.rs (Debian's
# Mosquitto, hans-gateway killed and frozen) and host-tests/e2e/tests/mqtt.rs
# (hans-sim -> gateway -> Mosquitto -> an independent consumer).

# --- the PLC function-block library (plc/): both ST parsers, the subset
# check, the SCL file, and the blocks against hans-gateway + hans-sim
step "PLC library (parsers, subset, SCL, blocks against the gateway)" bash scripts/plc-tests.sh
# The Debian package: its layout, maintainer scripts and unit, lintian,
# install, upgrade, remove and purge on this machine, the installed binary
# started (as root, as CI runs). It packages the debug hans-gateway the PLC
# step built (DEB_PROFILE=dev): a release build would cost minutes to test
# the same package; `bash scripts/deb-test.sh` alone builds the release one.
step "Debian package (cargo deb, lintian, install, upgrade, remove, the installed binary)" \
  env DEB_PROFILE=dev timeout --kill-after=30 600 bash scripts/deb-test.sh
# Sparkplug B as a plant's host reads it: every message of hans-gateway
# (births, data, commands' events, rebirth, DDEATH, the Will after SIGKILL
# and SIGTERM) decoded by Eclipse Tahu's JavaScript library (npm
# sparkplug-payload, pinned) and checked against the Sparkplug 3.0 TCK's
# edge-node assertions (the same debug binaries as the PLC library's step).
step "Sparkplug B read by Eclipse Tahu's decoder, TCK edge-node assertions" bash host-tests/sparkplug-tahu/run.sh

# --- EtherNet/IP: hans-enip's runner, then hans-gateway + hans-sim, against
# pycomm3, cpppo, ethernetip (PyPI) and tshark's dissectors; 10 s of class 1
# I/O against the runner, the issue's minute against the gateway, no
# datagram missed either way (bounded; the binaries are the host tests step's)
step "EtherNet/IP against pycomm3, cpppo, ethernetip and tshark (runner and gateway)" \
  env ENIP_IO_SECONDS=10 ENIP_GW_SECONDS=60 bash scripts/enip-tests.sh

# --- no_std builds for the microcontroller target
step "codec builds for thumbv7em-none-eabihf (with defmt and v6: their clippy run)" \
  cargo build -p hans-codec --target thumbv7em-none-eabihf --features defmt,v6 --locked
step "codec example (embassy-net client) builds for thumbv7em-none-eabihf" \
  cargo build -p hans-codec --example robot_state --target thumbv7em-none-eabihf --locked
# The gateway library for the board target: the firmware builds lint it as
# the boards ship it (core and field device, scripts/firmware-build.sh);
# this check (a clippy run, scripts/lint-env.sh) lints a configuration no
# board ships: the MQTT client and the DataSheet reader without the web page
# (its command log then holds one entry).
step "gateway with MQTT and DataSheet but no web page: clippy for thumbv7em-none-eabihf" \
  cargo check -p hans-gateway --target thumbv7em-none-eabihf --no-default-features --features embassy-net,defmt,flash,datasheet,mqtt --locked

# --- the footprint goal (the benchmarks are built, and linted, by the host
# tests' step; measure them with `cargo bench`)
step "codec footprint on Cortex-M4F (V5 codec <= 32 KiB, V5 + V6 <= 48 KiB)" bash host-tests/scripts/footprint.sh --check

# --- the documentation, built in the background since the start
join rustdoc

# --- firmware: the release builds (in the background since the start),
# then the QEMU tests
join firmware
# Bounded fuzzing, 12 s a target (wall time), at the lowest priority beside
# the QEMU tests, which keep one core busy (the fuzz targets were built in
# the background, in their own target directory, host-tests/fuzz/target).
join fuzz-build
step_bg fuzz --idle "fuzz: codec (framer, request, reply, DataSheet), gateway (Modbus session, robot bytes, stored image, HTTP, audit export paging, MQTT broker input, firmware image and its upload) and EtherNet/IP (encapsulation stream, CPF items, CIP requests), 12 s each" bash host-tests/fuzz/run.sh 12
step "firmware: QEMU tests, EtherNet/IP scanners on the QEMU field device (the release builds joined above)" bash scripts/firmware-tests.sh

join fuzz

# --- the last steps keep less than a core busy (QEMU and the demo's
# programs mostly wait), so three run side by side: the codec as a crate
# (its package's verify build and the MSRV toolchain's checks, at the lowest
# priority, in a target directory of its own), the first hour (the demo's
# fixed ports on 127.0.0.1) and the robustness rig (its own network
# namespace; its thresholds, p99 <= 100 ms, leave room for a shared machine:
# its long form, the evidence, runs alone).
step_bg codec-crate --idle "codec as a crate: cargo package, publish --dry-run, check with its declared MSRV toolchain" \
  env CARGO_TARGET_DIR="$ROOT/target/codec-crate" bash scripts/codec-publish-check.sh

# The first hour as written: README's "The first ten minutes" and
# REGISTERS.md's example, line by line, against scripts/demo.sh (the
# firmware step built the field device; the host tests' build the demo's
# hans-sim and hans-fw, which the robustness rig starts too). The demo's
# ports (8080, 5020, 10003, 5021, 18830) must be free.
step_bg first-hour "the README's first ten minutes and REGISTERS.md's example, as written, against the demo" \
  env FIRST_HOUR_BUILD_WAIT=600 timeout --kill-after=60 1200 python3 host-tests/scripts/first_hour.py

# --- communication robustness (issue 19): the field device under QEMU on a
# TAP device in a network namespace, storms and malformed traffic at every
# layer while a PLC monitor watches its essential functions; short form, 4 s
# a case (~3 min; the long form, 60 s a case, is `run.sh --long` and writes
# host-tests/robustness/RESULTS.md). Needs root, as CI has.
step "robustness rig, short form (every case 4 s; table in target/robustness/RESULTS-short.md)" \
  bash host-tests/robustness/run.sh
join first-hour
join codec-crate

echo
echo "Summary:"
printf '  %s\n' "${STEPS[@]}"
echo "  total $SECONDS s ($(busy $(($(cpu_ticks) - RUN_CPU0)) $SECONDS)), setup included"
echo "$PASSED passed, $FAILED failed"
