#!/usr/bin/env bash
# hans-enip against implementations nobody here wrote, on loopback:
#   1. pycomm3, cpppo and ethernetip (PyPI) against the crate's loopback
#      runner (enip/examples/loopback_adapter.rs): explicit messaging, class
#      3, class 1 I/O at 10 ms RPI, Forward_Close, a scanner that stops
#      (host-tests/enip/scanners.py);
#   2. the EDS the crate writes for the runner's device, read by eds_pie
#      (an EDS parser and semantic checker, PyPI) and compared with what the
#      adapter serves (host-tests/enip/eds_check.py);
#   3. the whole exchange captured on lo (tshark, a capture filter on the
#      runner's ports, bounded in time) and decoded by Wireshark's ENIP, CIP
#      and CIP I/O dissectors: no malformed packet and no expert error in
#      anything the adapter sent;
#   4. the real gateway (`hans-gateway` with enip.enabled, hans-sim as the
#      robot) against the same scanners (host-tests/enip/gateway_scanners.py):
#      discovery, class 1 at 10 ms RPI for ENIP_GW_SECONDS (missed datagrams
#      counted both ways: T->O by the scanner from the sequence numbers, O->T
#      by the gateway, ENIP_MISSED and the owner connection's own count; none
#      may be missed), a move Done through the assemblies (Execute-to-Done timed),
#      Forward_Close, the connection dropped during a motion -> the
#      watchdog's stop; captured and decoded by tshark as in 3.
#
#   bash scripts/enip-tests.sh   (ENIP_IO_SECONDS / ENIP_GW_SECONDS: seconds of
#                                 class 1 I/O against the runner / the gateway;
#                                 defaults 20 / 60: the issue's minute)
#
# Installs what it needs, idempotently: Debian's tshark (non-interactive,
# no setuid dumpcap), and the PyPI packages, pinned, into a venv under
# target/enip-venv. Ports are free ones picked at start (the runner binds
# port 0), so runs do not collide with each other or with a real 44818/2222.
# Capturing on lo needs root (as CI runs) or the capture capability.
# Ends with "N passed, M failed"; exits non-zero on any failure.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
IO_SECONDS=${ENIP_IO_SECONDS:-20}
GW_SECONDS=${ENIP_GW_SECONDS:-60}
OUT=$ROOT/target/enip
VENV=$ROOT/target/enip-venv
mkdir -p "$OUT"

if ! command -v tshark >/dev/null; then
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  echo "enip-tests: apt-get install tshark"
  echo "wireshark-common wireshark-common/install-setuid boolean false" | $SUDO debconf-set-selections
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq tshark >/dev/null
fi
source scripts/enip-venv.sh

cargo build -q -p hans-enip --example loopback_adapter --locked
RUNNER=$ROOT/target/debug/examples/loopback_adapter
source "$ROOT/scripts/host-programs.sh" && build_host_programs

"$RUNNER" --eds "$OUT/loopback.eds"
EDS_LOG=$OUT/eds_check.log
eds_status=0
"$VENV/bin/python" host-tests/enip/eds_check.py "$OUT/loopback.eds" >"$EDS_LOG" 2>/dev/null || eds_status=$?
grep -E '^(ok|FAIL)' "$EDS_LOG" || true

rm -f "$OUT/ports" "$OUT/ready" "$OUT/capture.pcapng"
SCAN_LOG=$OUT/scanners.log
"$VENV/bin/python" host-tests/enip/scanners.py "$RUNNER" --io-seconds "$IO_SECONDS" \
  --ports-file "$OUT/ports" --ready-file "$OUT/ready" >"$SCAN_LOG" 2>&1 &
SCAN_PID=$!
TSHARK_PID=""
cleanup() {
  [ -n "$TSHARK_PID" ] && kill "$TSHARK_PID" 2>/dev/null || true
  kill "$SCAN_PID" 2>/dev/null || true
}
trap cleanup EXIT

for _ in $(seq 100); do
  [ -s "$OUT/ports" ] && break
  sleep 0.1
done
if [ ! -s "$OUT/ports" ]; then
  cat "$SCAN_LOG" >&2
  echo "enip-tests: the runner did not start" >&2
  exit 1
fi
read -r PORT IO_PORT <"$OUT/ports"
echo "runner: encapsulation on tcp/udp $PORT, I/O on udp $IO_PORT"

# The capture: only the runner's ports, stopped by duration at the latest.
tshark -i lo -f "host 127.0.0.1 and (port $PORT or port $IO_PORT)" \
  -a "duration:$((IO_SECONDS + 90))" -w "$OUT/capture.pcapng" >"$OUT/tshark.log" 2>&1 &
TSHARK_PID=$!
for _ in $(seq 100); do
  grep -q "Capturing on" "$OUT/tshark.log" && break
  sleep 0.1
done
grep -q "Capturing on" "$OUT/tshark.log" || { cat "$OUT/tshark.log" >&2; echo "enip-tests: tshark did not start" >&2; exit 1; }
touch "$OUT/ready"

status=0
wait "$SCAN_PID" || status=$?
cat "$SCAN_LOG" | grep -v '^ ' | grep -E '^(ok|FAIL|figures|[0-9]+ passed)' || true
# Let the last packets reach the capture, then stop it.
sleep 0.5
kill -INT "$TSHARK_PID" 2>/dev/null || true
wait "$TSHARK_PID" 2>/dev/null || true
TSHARK_PID=""

PASSED=$(grep -Eo '^[0-9]+ passed' "$SCAN_LOG" | awk '{print $1}' || echo 0)
FAILED=$(grep -Eo '[0-9]+ failed$' "$SCAN_LOG" | awk '{print $1}' || echo 1)
PASSED=${PASSED:-0}
FAILED=${FAILED:-1}
[ "$status" -eq 0 ] || { [ "$FAILED" -gt 0 ] || FAILED=1; }
EDS_PASSED=$(grep -Eo '^[0-9]+ passed' "$EDS_LOG" | awk '{print $1}' || echo 0)
EDS_FAILED=$(grep -Eo '[0-9]+ failed$' "$EDS_LOG" | awk '{print $1}' || echo 1)
PASSED=$((PASSED + ${EDS_PASSED:-0}))
FAILED=$((FAILED + ${EDS_FAILED:-1}))
[ "$eds_status" -eq 0 ] || { [ "${EDS_FAILED:-1}" -gt 0 ] || FAILED=$((FAILED + 1)); }

tcheck() {
  if [ "$2" = ok ]; then
    echo "ok   $1"
    PASSED=$((PASSED + 1))
  else
    echo "FAIL $1"
    FAILED=$((FAILED + 1))
  fi
}
DEC=(-d "tcp.port==$PORT,enip" -d "udp.port==$PORT,enip" -d "udp.port==$IO_PORT,cipio")
count() { tshark -r "$OUT/capture.pcapng" "${DEC[@]}" -Y "$1" 2>/dev/null | wc -l; }
FROM_ADAPTER="(tcp.srcport==$PORT || udp.srcport==$PORT || udp.srcport==$IO_PORT)"
total=$(count "$FROM_ADAPTER")
enip=$(count "(tcp.srcport==$PORT || udp.srcport==$PORT) && enip")
cip=$(count "$FROM_ADAPTER && cip")
io=$(count "udp.srcport==$IO_PORT && cipio")
bad=$(count "$FROM_ADAPTER && (_ws.malformed || _ws.expert.severity == error)")
bad_any=$(count "_ws.malformed || _ws.expert.severity == error")
echo "tshark: $total packets from the adapter: $enip ENIP, $cip CIP, $io CIP I/O; malformed or expert errors: $bad (any sender: $bad_any)"
[ "$enip" -gt 10 ] && tcheck "tshark decodes the adapter's encapsulation replies ($enip)" ok || tcheck "tshark decodes the adapter's encapsulation replies ($enip)" fail
[ "$io" -ge $((IO_SECONDS * 90)) ] && tcheck "tshark decodes the adapter's class 1 datagrams as CIP I/O ($io)" ok || tcheck "tshark decodes the adapter's class 1 datagrams as CIP I/O ($io)" fail
[ "$bad" -eq 0 ] && tcheck "no malformed packet or expert error from the adapter" ok || {
  tshark -r "$OUT/capture.pcapng" "${DEC[@]}" -Y "$FROM_ADAPTER && (_ws.malformed || _ws.expert.severity == error)" 2>/dev/null | head -20
  tcheck "no malformed packet or expert error from the adapter ($bad)" fail
}
tshark -r "$OUT/capture.pcapng" "${DEC[@]}" -q -z expert 2>/dev/null >"$OUT/expert.txt" || true
echo "(capture: $OUT/capture.pcapng, expert summary: $OUT/expert.txt, scanner log: $SCAN_LOG)"

# 4. The real gateway, on free ports of its own, captured as above.
free_port() { "$VENV/bin/python" -c 'import socket,sys; s=socket.socket(socket.AF_INET, getattr(socket, sys.argv[1])); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])' "$1"; }
GW_PORT=$(free_port SOCK_STREAM)
GW_IO=$(free_port SOCK_DGRAM)
rm -f "$OUT/gw-ready" "$OUT/gateway.pcapng"
GW_LOG=$OUT/gateway-scanners.log
tshark -i lo -f "host 127.0.0.1 and (port $GW_PORT or port $GW_IO)" \
  -a "duration:$((GW_SECONDS + 90))" -w "$OUT/gateway.pcapng" >"$OUT/tshark-gw.log" 2>&1 &
TSHARK_PID=$!
for _ in $(seq 100); do
  grep -q "Capturing on" "$OUT/tshark-gw.log" && break
  sleep 0.1
done
touch "$OUT/gw-ready"
gw_status=0
timeout $((GW_SECONDS + 120)) "$VENV/bin/python" host-tests/enip/gateway_scanners.py \
  target/debug/hans-gateway target/debug/hans-sim --enip-port "$GW_PORT" --io-port "$GW_IO" \
  --io-seconds "$GW_SECONDS" --ready-file "$OUT/gw-ready" >"$GW_LOG" 2>&1 || gw_status=$?
grep -E '^(ok|FAIL|figures|[0-9]+ passed)' "$GW_LOG" || true
sleep 0.5
kill -INT "$TSHARK_PID" 2>/dev/null || true
wait "$TSHARK_PID" 2>/dev/null || true
TSHARK_PID=""
GW_PASSED=$(grep -Eo '^[0-9]+ passed' "$GW_LOG" | awk '{print $1}' || echo 0)
GW_FAILED=$(grep -Eo '[0-9]+ failed$' "$GW_LOG" | awk '{print $1}' || echo 1)
PASSED=$((PASSED + ${GW_PASSED:-0}))
FAILED=$((FAILED + ${GW_FAILED:-1}))
[ "$gw_status" -eq 0 ] || { [ "${GW_FAILED:-1}" -gt 0 ] || FAILED=$((FAILED + 1)); }
DEC=(-d "tcp.port==$GW_PORT,enip" -d "udp.port==$GW_PORT,enip" -d "udp.port==$GW_IO,cipio")
gcount() { tshark -r "$OUT/gateway.pcapng" "${DEC[@]}" -Y "$1" 2>/dev/null | wc -l; }
FROM_GW="(tcp.srcport==$GW_PORT || udp.srcport==$GW_PORT || udp.srcport==$GW_IO)"
gw_total=$(gcount "$FROM_GW")
gw_io=$(gcount "udp.srcport==$GW_IO && cipio")
gw_bad=$(gcount "$FROM_GW && (_ws.malformed || _ws.expert.severity == error)")
echo "tshark (gateway): $gw_total packets from the gateway, $gw_io CIP I/O; malformed or expert errors: $gw_bad"
[ "$gw_io" -ge $((GW_SECONDS * 80)) ] && tcheck "tshark decodes the gateway's class 1 datagrams as CIP I/O ($gw_io)" ok \
  || tcheck "tshark decodes the gateway's class 1 datagrams as CIP I/O ($gw_io)" fail
[ "$gw_bad" -eq 0 ] && tcheck "no malformed packet or expert error from the gateway" ok || {
  tshark -r "$OUT/gateway.pcapng" "${DEC[@]}" -Y "$FROM_GW && (_ws.malformed || _ws.expert.severity == error)" 2>/dev/null | head -20
  tcheck "no malformed packet or expert error from the gateway ($gw_bad)" fail
}
echo "(gateway capture: $OUT/gateway.pcapng, log: $GW_LOG)"
echo "$PASSED passed, $FAILED failed"
[ "$FAILED" -eq 0 ]
