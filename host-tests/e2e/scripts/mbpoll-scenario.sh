#!/usr/bin/env bash
# A PLC session with mbpoll (Debian's Modbus master) against a running
# gateway: set a box output, make a relative joint move and wait for Done,
# read the position through RAW. Usage: mbpoll-scenario.sh HOST PORT
# Exits non-zero (with a message) on the first unexpected answer.
#
# Register addresses, status bits and command codes: the defaults below are
# those of gateway/src/registers.rs and gateway/src/engine/commands.rs.
# tests/mbpoll.rs sets every one of them from those modules, so a change of
# the map reaches this script; run by hand, set them if the map has moved.
set -euo pipefail
[ $# -eq 2 ] || { echo "usage: $0 HOST PORT" >&2; exit 2; }
HOST=$1
PORT=$2
: "${STATUS_VERSION:=0}"      # register: map version
: "${VERSION:=258}"           # its value (hans_gateway::registers::MAP_VERSION, 1.2)
: "${STATUS_LINK_STATE:=3}"   # register: robot link state, 3 = up
: "${CH0:=200}"               # channel 0: Execute (CH_CONTROL), code at +1, sequence at +2
: "${CH0_PARAMS:=204}"        # channel 0: P0 (CH_PARAMS), f32 high word first
: "${CH0_STATUS:=260}"        # channel 0: status (CH_STATUS), sequence echo at +1
: "${RAW_CONTROL:=600}"       # RAW: Execute; sequence at +1, request text at +2
: "${RAW_STATUS:=730}"        # RAW: status
: "${RAW_REPLY:=737}"         # RAW: reply text
: "${ST_DONE:=2}"             # status bit Done
: "${ST_ENDED:=14}"           # status bits Done | Error | Aborted
: "${CODE_SET_BOX_DO:=21}"
: "${CODE_MOVE_REL_J:=13}"
EXEC_COIL=$((CH0 * 16))       # coil view: bit 0 of channel 0's Execute register
# -0: protocol (0-based) addresses; -1: one poll; -a 1: unit id 1.
MB=(mbpoll -m tcp -p "$PORT" -a 1 -0 -1 -o 5)

read_reg() { # ADDRESS -> value of one holding register
  "${MB[@]}" -t 4 -r "$1" -c 1 "$HOST" | awk -F'\t' '/^\[/ {print $2; exit}'
}
write_regs() { # ADDRESS VALUES...
  local a=$1
  shift
  "${MB[@]}" -t 4 -r "$a" "$HOST" "$@" >/dev/null
}
wait_end() { # STATUS_ADDRESS -> prints the status once Done/Error/Aborted
  for _ in $(seq 1 400); do
    local s
    s=$(read_reg "$1")
    if (( (s & ST_ENDED) != 0 )); then
      echo "$s"
      return 0
    fi
    sleep 0.05
  done
  echo "timeout waiting at register $1" >&2
  return 1
}

# The link must be up (LINK_STATE = 3).
for _ in $(seq 1 200); do
  [ "$(read_reg "$STATUS_LINK_STATE")" = 3 ] && break
  sleep 0.05
done
[ "$(read_reg "$STATUS_LINK_STATE")" = 3 ] || { echo "robot link not up" >&2; exit 1; }
v=$(read_reg "$STATUS_VERSION")
[ "$v" = "$VERSION" ] || { echo "map version $v, expected $VERSION" >&2; exit 1; }

# 1. SetBoxDO bit 4 = 1: sequence 5, P0 = 4.0, P1 = 1.0 (floats, high word first).
write_regs $((CH0 + 1)) "$CODE_SET_BOX_DO" 5 0
"${MB[@]}" -t 4:float -B -r "$CH0_PARAMS" "$HOST" 4 1 >/dev/null
write_regs "$CH0" 1
s=$(wait_end "$CH0_STATUS")
(( (s & ST_DONE) != 0 )) || { echo "SetBoxDO not Done (status $s)" >&2; exit 1; }
[ "$(read_reg $((CH0_STATUS + 1)))" = 5 ] || { echo "sequence not echoed" >&2; exit 1; }
write_regs "$CH0" 0
[ "$(read_reg "$CH0_STATUS")" = 0 ] || { echo "outputs not cleared" >&2; exit 1; }

# 2. Relative joint move J1 +2 degrees through the coil view of Execute.
write_regs $((CH0 + 1)) "$CODE_MOVE_REL_J" 6 0
"${MB[@]}" -t 4:float -B -r "$CH0_PARAMS" "$HOST" 0 2 >/dev/null
"${MB[@]}" -t 0 -r "$EXEC_COIL" "$HOST" 1 >/dev/null
s=$(wait_end "$CH0_STATUS")
(( (s & ST_DONE) != 0 )) || { echo "move not Done (status $s)" >&2; exit 1; }
"${MB[@]}" -t 0 -r "$EXEC_COIL" "$HOST" 0 >/dev/null

# 3. RAW: sequence 9, ReadActPos,0,; -> Done and a reply starting with
# ReadActPos,OK ("Re" "ad" "Ac" "tP" "os" ",0" ",;" as 16-bit words).
write_regs $((RAW_CONTROL + 1)) 9 0x5265 0x6164 0x4163 0x7450 0x6F73 0x2C30 0x2C3B 0
write_regs "$RAW_CONTROL" 1
s=$(wait_end "$RAW_STATUS")
(( (s & ST_DONE) != 0 )) || { echo "RAW not Done (status $s)" >&2; exit 1; }
[ "$(read_reg "$RAW_REPLY")" = 21093 ] || { echo "RAW reply does not start with 'Re'" >&2; exit 1; }
write_regs "$RAW_CONTROL" 0
echo "mbpoll scenario: ok"
