#!/usr/bin/env bash
# The whole system with no hardware: the field-device firmware (gateway, web
# page, DHCP, DataSheet reader) on an emulated board (QEMU mps2-an386)
# connected to the robot simulator.
#
#   scripts/demo.sh
#
# Installs what it needs (scripts/setup.sh), builds the firmware and hans-sim,
# starts both, prints the web page's address and the Modbus address to point
# a PLC or mbpoll at, and stops everything on Ctrl-C. It says each stage as it
# starts and how long it took; the first build compiles everything (the
# firmware in release with LTO: minutes, printed with the stage), later runs
# build nothing. The firmware's log is decoded to text by defmt-print
# (installed by setup; without it the raw frames go to a file, not the
# terminal). If either process ends by itself (a port already taken, say),
# the other is stopped too and the script exits with its status.
#
# The simulator and the image tool are built in the dev profile, as the
# robustness rig builds them (host-tests/robustness/run.sh): one build serves
# both, and a debug hans-sim keeps a robot's pace easily.
#
# With Debian's mosquitto installed (setup installs it), an MQTT broker runs
# too and the firmware publishes the cell as a Sparkplug B edge node to it:
# the script prints the mosquitto_sub and hansctl fleet lines to watch it.
#
# The README's "first ten minutes" and gateway/REGISTERS.md's example are
# run against this script, line by line, by host-tests/scripts/first_hour.py.
#
# Environment: WEB_PORT (default 8080), MODBUS_PORT (default 5020), SIM_PORT
# (default 10003), ADMIN_PORT (default 5021), BROKER_PORT (default 18830;
# NO_BROKER=1: none). Everything listens on 127.0.0.1 only.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)

WEB_PORT=${WEB_PORT:-8080}
MODBUS_PORT=${MODBUS_PORT:-5020}
SIM_PORT=${SIM_PORT:-10003}
ADMIN_PORT=${ADMIN_PORT:-5021}
BROKER_PORT=${BROKER_PORT:-18830}
export WEB_PORT MODBUS_PORT SIM_PORT ADMIN_PORT

# Stages: said as each starts, with its time when it ends.
STAGES=4
stage_no=0
stage_start=$SECONDS
started=$SECONDS
stage() {
  if [ "$stage_no" -gt 0 ]; then
    echo "demo: stage $stage_no/$STAGES done in $(elapsed $((SECONDS - stage_start)))"
  fi
  stage_no=$((stage_no + 1))
  stage_start=$SECONDS
  echo "demo: stage $stage_no/$STAGES: $*"
}
elapsed() {
  if [ "$1" -ge 60 ]; then printf '%dm%02ds' $(($1 / 60)) $(($1 % 60)); else printf '%ds' "$1"; fi
}

stage "tools (scripts/setup.sh installs what is missing: apt packages, Rust targets, defmt-print)"
SETUP_FUZZ=0 bash scripts/setup.sh

source scripts/firmware-env.sh
FW_TARGET=${CARGO_TARGET_DIR:-$ROOT/firmware/target}
HOST_TARGET=${CARGO_TARGET_DIR:-$ROOT/target}
ELF="$FW_TARGET/thumbv7em-none-eabihf/release/field-device"

if [ -f "$ELF" ]; then
  first=" (built before: only what changed is compiled)"
else
  # On 2 cores with the crates already downloaded (README, "The first ten
  # minutes"; measured 2026-11-30 from a fresh clone on an idle 2-core
  # machine: 2m11s); a first download or a busy machine adds minutes.
  first=" (the first build: about 2 minutes on 2 cores, more on a busy machine; the firmware and its dependencies in release with LTO)"
fi
stage "building the field-device firmware and its bootloader$first"
(cd firmware && CARGO_TARGET_DIR="$FW_TARGET" firmware_cargo build --release -p board-mps2-an386 \
  --features field-device --bin field-device &&
  CARGO_TARGET_DIR="$FW_TARGET" firmware_cargo build --release -p bootloader-mps2)
stage "building the robot simulator (hans-sim) and the image tool (hans-fw, which makes the flash file the bootloader starts the firmware from)"
# (scripts/test-all.sh has built them: scripts/host-programs.sh.)
[ -n "${HOST_PROGRAMS_BUILT:-}" ] || CARGO_TARGET_DIR="$HOST_TARGET" cargo build -q -p hans-sim -p hans-fw --locked
stage "starting the simulator, the MQTT broker and the firmware under QEMU"

pids=()
cleanup() {
  # Ignore further Ctrl-C while stopping (bash would otherwise end itself
  # when a child it waits for dies of SIGINT, before the rest is stopped).
  trap '' INT TERM
  trap - EXIT
  for pid in "${pids[@]}"; do
    kill "$pid" 2>/dev/null || true
  done
  for pid in "${pids[@]}"; do
    wait "$pid" 2>/dev/null || true
  done
  rm -f "${broker_conf:-}"
  echo "demo: stopped"
}
trap 'cleanup; exit 130' INT TERM
trap cleanup EXIT

# The one-time code that creates the page's first administrator: the host
# hands it in (qemu-run.sh passes SETUP_CODE as `setup=CODE`), as someone at
# a board reads it from its probe's log. New each run.
alphabet=23456789ABCDEFGHJKMNPQRSTUVWXYZ_ # as hans_gateway::SetupCode's
code=""
for b in $(od -An -N12 -tu1 /dev/urandom); do code+=${alphabet:$((b % 32)):1}; done
export SETUP_CODE="${code:0:4}-${code:4:4}-${code:8:4}"

"$HOST_TARGET/debug/hans-sim" --host 127.0.0.1 --command-port "$SIM_PORT" --datasheet-ports "" &
pids+=($!)
broker=""
mosquitto_bin=$(command -v mosquitto || echo /usr/sbin/mosquitto)
if [ "${NO_BROKER:-0}" != 1 ] && [ -x "$mosquitto_bin" ]; then
  broker_conf=$(mktemp --suffix=.conf)
  printf 'listener %s 127.0.0.1\nallow_anonymous true\npersistence false\n' "$BROKER_PORT" >"$broker_conf"
  "$mosquitto_bin" -c "$broker_conf" >/dev/null 2>&1 &
  pids+=($!)
  # qemu-run.sh forwards the firmware's 10.0.2.100:1883 to it and turns the
  # firmware's telemetry on (mqtt=10.0.2.100:1883).
  export MQTT_PORT=$BROKER_PORT
  broker="
  MQTT broker:        127.0.0.1:$BROKER_PORT (Sparkplug B, group cells; MQTT sees the robot, never moves it)
  Watch it:           mosquitto_sub -h 127.0.0.1 -p $BROKER_PORT -t 'spBv1.0/cells/#' -v
  Fleet view:         cargo run -p hansctl -- fleet --broker 127.0.0.1:$BROKER_PORT --group cells
                      (started after the gateway: it shows within 10 s, at the gateway's
                      next message, and asks it for its birth)"
fi
if command -v defmt-print >/dev/null; then
  # qemu-run.sh pipes the log through defmt-print: text in the terminal.
  bash scripts/qemu-run.sh "$ELF" &
else
  # Raw defmt frames are binary: keep them out of the terminal.
  DEFMT_OUT=$(mktemp --suffix=.defmt)
  echo "demo: defmt-print not installed: the firmware's raw log goes to $DEFMT_OUT" \
    "(decode: defmt-print -e $ELF < $DEFMT_OUT)"
  DEFMT_OUT=$DEFMT_OUT bash scripts/qemu-run.sh "$ELF" &
fi
pids+=($!)

# Ready when the firmware answers Modbus (QEMU's forward accepts connections
# before the firmware is up, so a connection alone proves nothing): at most
# 60 s, and not once a process has ended (the wait below reports that).
ready=0
deadline=$((SECONDS + 60))
while [ "$SECONDS" -lt "$deadline" ]; do
  if timeout 3 mbpoll -m tcp -p "$MODBUS_PORT" -0 -r 0 -c 1 -1 -o 1 127.0.0.1 >/dev/null 2>&1; then
    ready=1
    break
  fi
  alive=1
  for pid in "${pids[@]}"; do kill -0 "$pid" 2>/dev/null || alive=0; done
  [ "$alive" = 1 ] || break
  sleep 0.5
done
if [ "$ready" = 1 ]; then
  echo "demo: stage $stage_no/$STAGES done in $(elapsed $((SECONDS - stage_start))); ready $(elapsed $((SECONDS - started))) after the start"
else
  echo "demo: the firmware does not answer Modbus on 127.0.0.1:$MODBUS_PORT yet (see its log above)" >&2
fi

cat <<MSG

  Field-device firmware running under QEMU (mps2-an386), robot simulator on 127.0.0.1:$SIM_PORT.

  Web page:           http://127.0.0.1:$WEB_PORT/
                      (a fresh device changes nothing until its first administrator
                      exists: create it there with the setup code $SETUP_CODE)
  Modbus TCP server:  127.0.0.1:$MODBUS_PORT   (unit id: any)
  Try:                mbpoll -m tcp -p $MODBUS_PORT -0 -r 0 -c 8 -1 127.0.0.1
  Diagnostics:        echo report | socat - TCP:127.0.0.1:$ADMIN_PORT$broker

  Next:               README.md, "The first ten minutes": the page, the administrator,
                      power on, enable and a move from Modbus, the fleet view.
  Ctrl-C stops everything.

MSG

# Ends when either process ends (or on Ctrl-C, through the trap).
status=0
wait -n "${pids[@]}" || status=$?
# Ctrl-C reaches QEMU and the simulator too (one process group): they end
# with status 0, possibly before the trap runs. A failure has another status.
if [ "$status" != 0 ]; then
  echo "demo: a process ended by itself (status $status); stopping the other" >&2
fi
exit "$status"
