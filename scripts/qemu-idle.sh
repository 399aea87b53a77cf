#!/usr/bin/env bash
# Idle CPU of a firmware under QEMU: the share of one host core QEMU takes
# while the firmware has nothing to do (the robot link up to hans-sim in
# StandBy, no PLC, no browser), from QEMU's /proc/PID/stat (user + system
# time) over SECONDS, after SETTLE seconds for the start.
#
#   scripts/qemu-idle.sh ELF [SECONDS]        (default 10; SETTLE default 5)
#
# HANS_SIM names the simulator program (default: target/{release,debug}/
# hans-sim of the host workspace); without one the robot link keeps
# reconnecting, which the figure then includes (the script says so).
# Everything it starts listens on 127.0.0.1 and is stopped by its PID.
set -euo pipefail
elf=${1:?usage: qemu-idle.sh ELF [SECONDS]}
secs=${2:-10}
settle=${SETTLE:-5}
root=$(cd "$(dirname "$0")/.." && pwd)
port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }
sim_port=$(port)
modbus_port=$(port)
log=$(mktemp -d)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  rm -rf "$log"
}
trap cleanup EXIT

sim=${HANS_SIM:-}
if [ -z "$sim" ]; then
  for p in "$root/target/release/hans-sim" "$root/target/debug/hans-sim"; do
    if [ -x "$p" ]; then sim=$p; break; fi
  done
fi
if [ -n "$sim" ]; then
  timeout $((settle + secs + 30)) "$sim" --host 127.0.0.1 --command-port "$sim_port" \
    --datasheet-ports "" >"$log/sim.log" 2>&1 &
  pids+=($!)
else
  echo "qemu-idle: no hans-sim: the robot link reconnects during the measurement" >&2
fi

SIM_PORT=$sim_port MODBUS_PORT=$modbus_port DEFMT_OUT=$log/defmt \
  timeout $((settle + secs + 30)) bash "$root/scripts/qemu-run.sh" "$elf" 2>"$log/qemu.err" &
pids+=($!)
qemu=$!
sleep "$settle"
# The QEMU process: qemu-run.sh execs it (under timeout's PID, its child).
qpid=$(pgrep -P "$qemu" -f qemu-system-arm | head -1 || true)
[ -n "$qpid" ] || { echo "qemu-idle: QEMU did not start:" >&2; cat "$log/qemu.err" >&2; exit 1; }
ticks() { awk '{ print $14 + $15 }' "/proc/$qpid/stat"; }
hz=$(getconf CLK_TCK)
t0=$(date +%s.%N)
c0=$(ticks)
sleep "$secs"
c1=$(ticks)
t1=$(date +%s.%N)
awk -v c="$((c1 - c0))" -v hz="$hz" -v t0="$t0" -v t1="$t1" -v elf="$(basename "$elf")" \
  'BEGIN { printf "qemu-idle: %s: %.1f %% of a host core over %.1f s idle\n", elf, 100 * c / hz / (t1 - t0), t1 - t0 }'
