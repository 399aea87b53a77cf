#!/usr/bin/env bash
# A PLC session with mbpoll (Debian's Modbus master) against a running
# gateway: set a box output, make a relative joint move and wait for Done,
# read the position through RAW. Usage: mbpoll-scenario.sh HOST PORT
# Exits non-zero (with a message) on the first unexpected answer.
set -euo pipefail
HOST=$1
PORT=$2
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
    if (( (s & 14) != 0 )); then
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
  [ "$(read_reg 3)" = 3 ] && break
  sleep 0.05
done
[ "$(read_reg 3)" = 3 ] || { echo "robot link not up" >&2; exit 1; }
[ "$(read_reg 0)" = 256 ] || { echo "unexpected version" >&2; exit 1; }

# 1. SetBoxDO bit 4 = 1: code 21, sequence 5, P0 = 4.0, P1 = 1.0 (floats, high word first).
write_regs 201 21 5 0
"${MB[@]}" -t 4:float -B -r 204 "$HOST" 4 1 >/dev/null
write_regs 200 1
s=$(wait_end 260)
(( (s & 2) != 0 )) || { echo "SetBoxDO not Done (status $s)" >&2; exit 1; }
[ "$(read_reg 261)" = 5 ] || { echo "sequence not echoed" >&2; exit 1; }
write_regs 200 0
[ "$(read_reg 260)" = 0 ] || { echo "outputs not cleared" >&2; exit 1; }

# 2. Relative joint move J1 +2 degrees (code 13) through the coil view of Execute.
write_regs 201 13 6 0
"${MB[@]}" -t 4:float -B -r 204 "$HOST" 0 2 >/dev/null
"${MB[@]}" -t 0 -r 3200 "$HOST" 1 >/dev/null
s=$(wait_end 260)
(( (s & 2) != 0 )) || { echo "move not Done (status $s)" >&2; exit 1; }
"${MB[@]}" -t 0 -r 3200 "$HOST" 0 >/dev/null

# 3. RAW: ReadActPos,0,; -> Done and a reply starting with ReadActPos,OK
# ("Re" "ad" "Ac" "tP" "os" ",0" ",;" as 16-bit words).
write_regs 601 9 0x5265 0x6164 0x4163 0x7450 0x6F73 0x2C30 0x2C3B 0
write_regs 600 1
s=$(wait_end 730)
(( (s & 2) != 0 )) || { echo "RAW not Done (status $s)" >&2; exit 1; }
[ "$(read_reg 737)" = 21093 ] || { echo "RAW reply does not start with 'Re'" >&2; exit 1; }
write_regs 600 0
echo "mbpoll scenario: ok"
