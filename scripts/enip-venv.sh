# Sourced (not run) by the scripts that drive the EtherNet/IP scanners
# (scripts/enip-tests.sh, scripts/enip-qemu.sh): the PyPI scanners, pinned,
# in a venv under target/enip-venv (installed once, idempotently). Sets VENV.
VENV=${VENV:-$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/target/enip-venv}
if ! "$VENV/bin/python" -c 'import pycomm3, cpppo, ethernetip, eds_pie' 2>/dev/null; then
  echo "enip: pip install pycomm3 cpppo ethernetip eds_pie into $VENV"
  python3 -m venv "$VENV"
  "$VENV/bin/pip" install -q pycomm3==1.2.16 cpppo==5.2.5 ethernetip==1.2.0 eds_pie==1.2.0
fi
