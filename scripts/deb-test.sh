#!/usr/bin/env bash
# The Debian package of the Linux gateway, from build to purge, on this
# machine (CI's own: it installs a system package, so it needs root, as CI
# has):
#
#  1. builds it with cargo-deb (`cargo deb -p hans-gateway-linux`: a release
#     build of hans-gateway, as a release is made), and a second revision of
#     the same build for the upgrade. With DEB_PROFILE=dev it packages the
#     debug binary already in target/debug instead (`--no-build`): what CI
#     does, where the steps before built it and a release build of the same
#     sources would cost minutes to test the same package scripts, layout
#     and lint (cargo-deb 3.8 warns that it is meant for releases; setup.sh
#     pins that version);
#  2. lints it with Debian's lintian: an error fails, warnings are printed;
#  3. installs it (apt) and checks what it put where: the binary on PATH, the
#     system user, /etc/hans-gateway and the state directory with their
#     owners and modes, the example as a conffile, the unit (systemd-analyze
#     verify on the installed file) enabled, the documents;
#  4. starts the installed binary as the unit does (its ExecStart options,
#     as the user hans-gateway, umask 0077) but on 127.0.0.1 at free ports:
#     it serves the page and Modbus, writes the setup code in the state
#     directory, and a setting applied over Modbus is saved in
#     /etc/hans-gateway/gateway.toml with an audit record beside it;
#  5. upgrades to the second revision: the configuration and the audit log
#     are the same bytes, and the upgraded binary starts with the saved
#     setting;
#  6. removes it: the binary and the unit are gone, the configuration, the
#     audit log and the state directory stay; installs it again and purges
#     it: they are gone.
#
# Where systemd is PID 1 the package's own scripts would start the service
# on 0.0.0.0: a policy-rc.d that forbids starting services is put in place
# for the run (unless one exists), so nothing is started but the binary of
# step 4, on 127.0.0.1. A hans-gateway package already installed is not
# touched: the script stops and says so. The user the package made is
# deleted at the end if it was not there before. Every wait is bounded
# (WAIT seconds); the binary is stopped by its pid.
#
# Ends with "N passed, M failed" (the checks); exit status 1 on a failure.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
WAIT=20
PASSED=0
say() { echo "deb-test: $*"; }
fail() {
  say "FAIL: $*" >&2
  echo "$PASSED passed, 1 failed"
  exit 1
}
ok() {
  PASSED=$((PASSED + 1))
  say "ok: $*"
}

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  sudo -n true 2>/dev/null || fail "needs root (it installs a system package): run as root, or with sudo that asks no password"
  SUDO="sudo -n"
fi
if dpkg-query -W -f='${Status}' hans-gateway 2>/dev/null | grep -q installed; then
  fail "a hans-gateway package is installed on this machine: not touching it (remove it first to run this test)"
fi

TARGET=${CARGO_TARGET_DIR:-$ROOT/target}
OUT=$TARGET/deb-test
rm -rf "$OUT"
mkdir -p "$OUT"
cleanups=()
cleanup() {
  local i
  for ((i = ${#cleanups[@]} - 1; i >= 0; i--)); do eval "${cleanups[$i]}" || true; done
}
trap cleanup EXIT
# Stopped by an outer timeout: the cleanups still run.
trap 'exit 143' TERM INT

# --- 1. build
start=$SECONDS
VERSION=$(cargo pkgid -p hans-gateway-linux | sed 's/.*[#@]//')
ARCH=$(dpkg --print-architecture)
DEB1=$OUT/hans-gateway_${VERSION}-1_${ARCH}.deb
DEB2=$OUT/hans-gateway_${VERSION}-2_${ARCH}.deb
PROFILE=${DEB_PROFILE:-release}
if [ "$PROFILE" = release ]; then
  cargo deb -p hans-gateway-linux --locked --strip -o "$DEB1"
else
  [ -x "$TARGET/debug/hans-gateway" ] ||
    fail "DEB_PROFILE=$PROFILE packages the binary already built: $TARGET/debug/hans-gateway is missing (cargo build -p hans-gateway-linux)"
  cargo deb -p hans-gateway-linux --locked --no-build --profile "$PROFILE" --strip -o "$DEB1"
fi
cargo deb -p hans-gateway-linux --locked --no-build --profile "$PROFILE" --strip --deb-revision 2 -o "$DEB2"
[ -f "$DEB1" ] && [ -f "$DEB2" ] || fail "cargo deb made no package"
ok "built $(basename "$DEB1") and $(basename "$DEB2") in $((SECONDS - start)) s ($(du -k "$DEB1" | cut -f1) KiB)"
say "contents:"
dpkg-deb --contents "$DEB1" | awk '{print "  " $1, $2, $6, $7, $8}'

# --- 2. lint
lint=$OUT/lintian.txt
# lintian reads the package only; as root it says so on stderr (kept apart).
if lintian --display-info --no-tag-display-limit --fail-on error "$DEB1" >"$lint" 2>"$OUT/lintian.stderr"; then
  ok "lintian: no error ($(grep -c '^W: ' "$lint" || true) warnings, $(grep -c '^I: ' "$lint" || true) notes)"
else
  cat "$lint" "$OUT/lintian.stderr" >&2
  fail "lintian found errors"
fi
sed 's/^/  /' "$lint"

# --- 3. install
if [ -d /run/systemd/system ] && [ ! -e /usr/sbin/policy-rc.d ]; then
  # Forbids deb-systemd-invoke (the package's scripts) to start services.
  printf '#!/bin/sh\nexit 101\n' | $SUDO tee /usr/sbin/policy-rc.d >/dev/null
  $SUDO chmod 0755 /usr/sbin/policy-rc.d
  cleanups+=("$SUDO rm -f /usr/sbin/policy-rc.d")
fi
user_before=0
getent passwd hans-gateway >/dev/null && user_before=1
cleanups+=("$SUDO apt-get purge -y -qq hans-gateway >/dev/null 2>&1; [ $user_before = 1 ] || $SUDO deluser --system --quiet hans-gateway >/dev/null 2>&1")
apt_install() { DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --allow-downgrades "$1" >"$OUT/apt.log" 2>&1 || { cat "$OUT/apt.log" >&2; fail "apt-get install $1"; }; }
apt_install "$DEB1"
[ "$(dpkg-query -W -f='${Version}' hans-gateway)" = "$VERSION-1" ] || fail "not installed as $VERSION-1"
[ "$(command -v hans-gateway)" = /usr/bin/hans-gateway ] || fail "hans-gateway is not /usr/bin/hans-gateway on PATH"
hans-gateway --version | grep -q "$VERSION" || fail "hans-gateway --version does not say $VERSION"
ok "installed: hans-gateway on PATH ($(hans-gateway --version))"

IFS=: read -r _ _ uid _ _ home shell < <(getent passwd hans-gateway) || fail "no user hans-gateway"
[ "$uid" -lt 1000 ] && [ "$home" = /var/lib/hans-gateway ] || fail "hans-gateway is not a system user with home /var/lib/hans-gateway (uid $uid, $home)"
case $shell in */nologin | */false) ;; *) fail "hans-gateway can log in ($shell)" ;; esac
owner_mode() { $SUDO stat -c '%U:%G %a' "$1"; }
[ "$(owner_mode /etc/hans-gateway)" = "hans-gateway:hans-gateway 750" ] || fail "/etc/hans-gateway: $(owner_mode /etc/hans-gateway)"
[ "$(owner_mode /var/lib/hans-gateway)" = "hans-gateway:hans-gateway 700" ] || fail "/var/lib/hans-gateway: $(owner_mode /var/lib/hans-gateway)"
dpkg-query -W -f='${Conffiles}\n' hans-gateway | grep -q '/etc/hans-gateway/gateway.toml.example' ||
  fail "the example is not a conffile"
[ ! -e /etc/hans-gateway/gateway.toml ] || fail "the package shipped a configuration file (the gateway writes it)"
ok "the user hans-gateway (uid $uid, $shell), /etc/hans-gateway 750 and /var/lib/hans-gateway 700 its own, the example a conffile"

UNIT=$(dpkg -L hans-gateway | grep '/systemd/system/hans-gateway.service$') || fail "no unit in the package"
if command -v systemd-analyze >/dev/null; then
  remarks=$(systemd-analyze verify "$UNIT" 2>&1) || fail "systemd-analyze verify $UNIT: $remarks"
  [ -z "$remarks" ] || fail "systemd-analyze verify $UNIT has remarks: $remarks"
fi
[ -L /etc/systemd/system/multi-user.target.wants/hans-gateway.service ] || fail "the unit is not enabled"
for doc in copyright changelog.Debian.gz REGISTERS.md WEB.md SPARKPLUG.md; do
  [ -f "/usr/share/doc/hans-gateway/$doc" ] || fail "no /usr/share/doc/hans-gateway/$doc"
done
ok "the unit $UNIT (systemd-analyze verify: no remark) is enabled; the documents are in /usr/share/doc/hans-gateway"

# --- 4. the installed binary, started as the unit starts it
free_port() {
  python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}
exec_start=$(sed -n 's/^ExecStart=//p' "$UNIT")
args=${exec_start#/usr/bin/hans-gateway }
[ "$args" != "$exec_start" ] || fail "ExecStart is not /usr/bin/hans-gateway: $exec_start"
gw_pid=""
start_gateway() {
  MODBUS_PORT=$(free_port)
  WEB_PORT=$(free_port)
  local run=$args
  run=${run//0.0.0.0:502/127.0.0.1:$MODBUS_PORT}
  run=${run//0.0.0.0:8080/127.0.0.1:$WEB_PORT}
  case $run in *0.0.0.0*) fail "ExecStart has an address this script does not replace: $args" ;; esac
  # shellcheck disable=SC2086 # ExecStart's words, as systemd splits them (no quotes in it)
  (cd /var/lib/hans-gateway && umask 0077 &&
    exec $SUDO setpriv --reuid=hans-gateway --regid=hans-gateway --init-groups /usr/bin/hans-gateway $run) \
    >"$OUT/gateway.log" 2>&1 &
  gw_pid=$!
  cleanups+=("kill $gw_pid 2>/dev/null")
  until_ok "the web page at 127.0.0.1:$WEB_PORT" serves_web
  until_ok "Modbus at 127.0.0.1:$MODBUS_PORT" serves_modbus
}
stop_gateway() {
  # setpriv execs the gateway: this pid is the gateway's (or sudo's, which
  # passes the signal on).
  kill "$gw_pid" 2>/dev/null || true
  wait "$gw_pid" 2>/dev/null || true
}
http_get() {
  timeout 5 bash -c 'exec 3<>"/dev/tcp/127.0.0.1/$0" || exit 0
    printf "GET %s HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n" "$1" >&3
    cat <&3 | tr -d "\\0"' "$WEB_PORT" "$1" 2>/dev/null || true
}
serves_web() { [[ $(http_get /api/status) == "HTTP/1.1 200"* ]]; }
serves_modbus() { timeout 5 mbpoll -m tcp -p "$MODBUS_PORT" -0 -r 0 -c 1 -1 127.0.0.1 >/dev/null 2>&1; }
until_ok() {
  local what=$1 deadline=$((SECONDS + WAIT))
  shift
  until "$@"; do
    if [ "$SECONDS" -ge "$deadline" ] || ! kill -0 "$gw_pid" 2>/dev/null; then
      cat "$OUT/gateway.log" >&2
      fail "$what: not within ${WAIT}s"
    fi
    sleep 0.2
  done
}
is() { [ "$(owner_mode "$1" 2>/dev/null)" = "$2" ]; }

start_gateway
pgrep -u hans-gateway -x hans-gateway >/dev/null || fail "the gateway does not run as hans-gateway"
until_ok "the setup code in /var/lib/hans-gateway/setup-code" is /var/lib/hans-gateway/setup-code "hans-gateway:hans-gateway 600"
# CFG_POLL_MS (105) = 50, then CONFIG_COMMAND (141) = 1: apply and save.
mbpoll -m tcp -p "$MODBUS_PORT" -0 -r 105 -1 127.0.0.1 50 >/dev/null
mbpoll -m tcp -p "$MODBUS_PORT" -0 -r 141 -1 127.0.0.1 1 >/dev/null
until_ok "the configuration /etc/hans-gateway/gateway.toml" is /etc/hans-gateway/gateway.toml "hans-gateway:hans-gateway 600"
$SUDO grep -q '^poll_ms = 50' /etc/hans-gateway/gateway.toml || fail "the saved file has no poll_ms = 50"
until_ok "the audit log /etc/hans-gateway/gateway.toml.audit" is /etc/hans-gateway/gateway.toml.audit "hans-gateway:hans-gateway 600"
stop_gateway
ok "the installed binary ran as hans-gateway with the unit's options (on 127.0.0.1): page, Modbus, setup code 600, a setting saved to /etc/hans-gateway/gateway.toml 600 with its audit log"

kept() { $SUDO sha256sum /etc/hans-gateway/gateway.toml /etc/hans-gateway/gateway.toml.audit; }
before=$(kept)

# --- 5. upgrade
apt_install "$DEB2"
[ "$(dpkg-query -W -f='${Version}' hans-gateway)" = "$VERSION-2" ] || fail "not upgraded to $VERSION-2"
[ "$(kept)" = "$before" ] || fail "the upgrade changed the configuration or the audit log"
[ "$(owner_mode /etc/hans-gateway)" = "hans-gateway:hans-gateway 750" ] || fail "after the upgrade /etc/hans-gateway: $(owner_mode /etc/hans-gateway)"
start_gateway
poll=$(mbpoll -m tcp -p "$MODBUS_PORT" -0 -r 105 -1 127.0.0.1 | sed -n 's/^\[105\]:[[:space:]]*//p')
stop_gateway
[ "$poll" = 50 ] || fail "after the upgrade CFG_POLL_MS reads '$poll', not the saved 50"
ok "upgraded to $VERSION-2: configuration and audit log the same bytes, the saved setting in force"

# --- 6. remove, purge
before=$(kept)
DEBIAN_FRONTEND=noninteractive $SUDO apt-get remove -y -qq hans-gateway >"$OUT/apt.log" 2>&1 || { cat "$OUT/apt.log" >&2; fail "apt-get remove"; }
[ ! -e /usr/bin/hans-gateway ] && [ ! -e "$UNIT" ] || fail "remove left the binary or the unit"
[ "$(kept)" = "$before" ] && [ -f /var/lib/hans-gateway/setup-code ] || fail "remove did not keep the configuration, the audit log and the state"
ok "removed: binary and unit gone; configuration, audit log and state directory kept"
apt_install "$DEB2"
DEBIAN_FRONTEND=noninteractive $SUDO apt-get purge -y -qq hans-gateway >"$OUT/apt.log" 2>&1 || { cat "$OUT/apt.log" >&2; fail "apt-get purge"; }
[ ! -e /etc/hans-gateway ] && [ ! -e /var/lib/hans-gateway ] || fail "purge left /etc/hans-gateway or /var/lib/hans-gateway"
! dpkg-statoverride --list /etc/hans-gateway >/dev/null || fail "purge left the statoverride"
! dpkg-query -W -f='${Status}' hans-gateway 2>/dev/null | grep -q ' installed' || fail "still installed after purge"
ok "reinstalled and purged: /etc/hans-gateway and /var/lib/hans-gateway gone"

echo "$PASSED passed, 0 failed"
