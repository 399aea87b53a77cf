#!/usr/bin/env bash
# Checks the systemd unit linux/dist/hans-gateway.service.
#
# (a) Always: the unit, its ExecStart pointed at the binary built here, passes
#     `systemd-analyze verify` without a remark (an unknown key is only a
#     remark there: any output fails), its hardening scores at most 2.0 of 10
#     in `systemd-analyze security` ("OK"), and the binary accepts ExecStart's
#     options.
# (b) Where systemd is PID 1 (and we are root, or sudo needs no password): runs
#     the unit's [Service] settings as a transient service (systemd-run), with a
#     state directory of its own and listening on 127.0.0.1 only; checks that it
#     serves the web page and Modbus (on 502 when that port is free: the
#     capability), runs as an unprivileged user, writes the setup code and, after
#     a save over Modbus, the configuration file with mode 0600, and is started
#     again after a crash (Restart=on-failure). Elsewhere (CI runs in a container
#     whose PID 1 is not systemd) it says why (b) is skipped.
#
# Needs systemd-analyze (apt package systemd) and for (b) mbpoll and python3,
# all installed by scripts/setup.sh. Every wait is bounded (WAIT seconds).
set -euo pipefail
cd "$(dirname "$0")/.."

UNIT=${UNIT:-linux/dist/hans-gateway.service}
WAIT=20
say() { echo "systemd-unit-test: $*"; }
fail() {
  say "FAIL: $*" >&2
  exit 1
}

source scripts/host-programs.sh && build_host_programs
BIN=$(pwd)/${CARGO_TARGET_DIR:-target}/debug/hans-gateway
[ -x "$BIN" ] || fail "no binary at $BIN"

WORK=$(mktemp -d)
cleanups=()
cleanup() {
  local i
  for ((i = ${#cleanups[@]} - 1; i >= 0; i--)); do eval "${cleanups[$i]}" || true; done
  rm -rf "$WORK"
}
trap cleanup EXIT

# --- (a) the unit as systemd reads it
exec_start=$(sed -n 's/^ExecStart=//p' "$UNIT")
[ "$(printf '%s\n' "$exec_start" | wc -l)" -eq 1 ] || fail "$UNIT: not one ExecStart line"
case "$exec_start" in
  /usr/bin/hans-gateway\ *) ;;
  *) fail "$UNIT: ExecStart does not start with /usr/bin/hans-gateway (the Debian package's path): $exec_start" ;;
esac
args=${exec_start#/usr/bin/hans-gateway }
mkdir "$WORK/a"
sed "s#^ExecStart=/usr/bin/hans-gateway #ExecStart=$BIN #" "$UNIT" >"$WORK/a/hans-gateway.service"
remarks=$(systemd-analyze verify "$WORK/a/hans-gateway.service" 2>&1) ||
  fail "systemd-analyze verify: $remarks"
[ -z "$remarks" ] || fail "systemd-analyze verify has remarks: $remarks"
say "(a) systemd-analyze verify: no remark"
# 20 = 2.0 on the 0-10 scale systemd-analyze prints.
if ! exposure=$(systemd-analyze security --offline=yes --threshold=20 "$WORK/a/hans-gateway.service" 2>&1); then
  printf '%s\n' "$exposure" >&2
  fail "systemd-analyze security: exposure above 2.0"
fi
say "(a) systemd-analyze security: $(printf '%s\n' "$exposure" | grep 'Overall exposure' | sed 's/^[^:]*: //')"
# Options the binary does not know, or values of the wrong form, are refused
# before --help is reached (status 2).
# shellcheck disable=SC2086 # ExecStart's words, as systemd splits them (no quotes in it)
"$BIN" $args --help >/dev/null || fail "the binary refuses ExecStart's options: $args"
say "(a) the binary accepts ExecStart's options"

# --- (b) the unit run by systemd
pid1=$(ps -p 1 -o comm= || true)
if [ "$pid1" != systemd ]; then
  say "(b) SKIPPED: PID 1 is '${pid1:-unknown}', not systemd (a container?): the unit was checked (a) but not run"
  exit 0
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if sudo -n true 2>/dev/null; then
    SUDO="sudo -n"
  else
    say "(b) SKIPPED: starting a system service needs root (run as root, or with sudo that asks no password)"
    exit 0
  fi
fi

free_port() {
  python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}
# 502 when free: binding it needs the unit's CAP_NET_BIND_SERVICE.
if $SUDO python3 -c 'import socket; socket.socket().bind(("127.0.0.1", 502))' 2>/dev/null; then
  MODBUS_PORT=502
else
  MODBUS_PORT=$(free_port)
  say "(b) note: 127.0.0.1:502 is taken, Modbus on $MODBUS_PORT (the capability is not exercised)"
fi
WEB_PORT=$(free_port)

NAME=hans-gateway-test-$$
STATE=/var/lib/$NAME
# The binary where the service can run it (ProtectHome and PrivateTmp may
# hide the build directory).
RUNDIR=/run/$NAME
$SUDO install -d -m 0755 "$RUNDIR"
cleanups+=("$SUDO rm -rf '$RUNDIR'")
$SUDO install -m 0755 "$BIN" "$RUNDIR/hans-gateway"

run_args=$args
run_args=${run_args//\/var\/lib\/hans-gateway\//$STATE/}
run_args=${run_args//\/etc\/hans-gateway\//$STATE/}
run_args=${run_args//0.0.0.0:502/127.0.0.1:$MODBUS_PORT}
run_args=${run_args//0.0.0.0:8080/127.0.0.1:$WEB_PORT}
case "$run_args" in
  *0.0.0.0* | */var/lib/hans-gateway/* | */etc/hans-gateway/*) fail "ExecStart has addresses or paths this script does not replace: $args" ;;
esac

props=()
while IFS= read -r line; do
  case "$line" in
    '' | '#'* | '['*) ;;
    # The package's user and /etc/hans-gateway (scripts/deb-test.sh checks
    # them installed): here a user made for the run and the state directory.
    ExecStart=* | StateDirectory=* | WorkingDirectory=* | User=* | Group=* | ReadWritePaths=*) ;;
    *) props+=(-p "$line") ;;
  esac
done < <(sed -n '/^\[Service\]/,/^\[/p' "$UNIT")
props+=(-p "StateDirectory=$NAME" -p "WorkingDirectory=$STATE" -p DynamicUser=yes)

cleanups+=("$SUDO systemctl stop '$NAME' 2>/dev/null; $SUDO systemctl reset-failed '$NAME' 2>/dev/null; $SUDO rm -rf '/var/lib/private/$NAME' '$STATE'")
# shellcheck disable=SC2086 # the options' words, as in the unit
$SUDO systemd-run --quiet --collect --unit="$NAME" "${props[@]}" "$RUNDIR/hans-gateway" $run_args
say "(b) started $NAME: Modbus 127.0.0.1:$MODBUS_PORT, web 127.0.0.1:$WEB_PORT, state $STATE"

# The answer to GET $1 on the web port (empty when nothing answers).
http_get() {
  timeout 5 bash -c 'exec 3<>"/dev/tcp/127.0.0.1/$0" || exit 0
    printf "GET %s HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n" "$1" >&3
    cat <&3 | tr -d "\\0"' "$WEB_PORT" "$1" 2>/dev/null || true
}
# Runs "$@" until it succeeds; fails the test after WAIT seconds.
until_ok() {
  local what=$1 deadline=$((SECONDS + WAIT))
  shift
  until "$@"; do
    [ "$SECONDS" -lt "$deadline" ] || fail "$what: not within ${WAIT}s ($($SUDO systemctl is-active "$NAME" || true))"
    sleep 0.2
  done
}
serves_web() {
  local answer
  answer=$(http_get /api/status)
  [[ $answer == "HTTP/1.1 200"* ]]
}
serves_modbus() { timeout 5 mbpoll -m tcp -p "$MODBUS_PORT" -0 -r 0 -c 1 -1 127.0.0.1 >/dev/null 2>&1; }
mode_of() { $SUDO stat -c %a "$1" 2>/dev/null || true; }
is_private() { [ "$(mode_of "$1")" = 600 ]; }

until_ok "the web page at 127.0.0.1:$WEB_PORT" serves_web
until_ok "Modbus at 127.0.0.1:$MODBUS_PORT" serves_modbus
say "(b) serves the web page and Modbus"

main_pid=$($SUDO systemctl show -p MainPID --value "$NAME")
user=$(ps -o user= -p "$main_pid" | tr -d ' ')
[ -n "$user" ] && [ "$user" != root ] || fail "runs as '${user:-?}', not as a user of its own"
say "(b) runs as $user"

until_ok "the setup code in $STATE/setup-code (mode 0600)" is_private "$STATE/setup-code"
code=$($SUDO cat "$STATE/setup-code")
for path in / /api/status /api/session; do
  answer=$(http_get "$path")
  [[ $answer == "HTTP/1.1 "* ]] || fail "no answer to GET $path"
  [[ $answer != *"$code"* ]] || fail "GET $path shows the setup code"
done
say "(b) setup code written with mode 0600, not served"

# A save (CONFIG_COMMAND, register 141, = 1) writes the configuration file.
timeout 5 mbpoll -m tcp -p "$MODBUS_PORT" -0 -r 141 -1 127.0.0.1 1 >/dev/null ||
  fail "writing CONFIG_COMMAND over Modbus"
until_ok "the configuration file $STATE/gateway.toml (mode 0600)" is_private "$STATE/gateway.toml"
say "(b) configuration saved with mode 0600"

# A crash: systemd starts it again (Restart=on-failure, RestartSec=2).
$SUDO systemctl kill --signal=SIGKILL "$NAME"
restarted() { [ "$($SUDO systemctl show -p NRestarts --value "$NAME")" -ge 1 ] && serves_web; }
until_ok "a restart after SIGKILL" restarted
say "(b) started again after a crash"
say "ok"
