#!/usr/bin/env bash
# The PLC library's tests (issue 26, plc/): both ST parsers on every file,
# the portable-subset check and its negative cases, the SCL file against
# the generator, and the blocks run scan by scan against the real
# hans-gateway and hans-sim over Modbus TCP on 127.0.0.1.
# Installs what it needs, idempotently: a venv under target/ with pinned
# packages. Builds the two binaries once.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=target/plc-venv
if [ ! -x "$VENV/bin/python" ]; then
  python3 -m venv "$VENV"
fi
if ! "$VENV/bin/python" -c 'import blark, tree_sitter, tree_sitter_iec61131_3_st, pytest, lxml' 2>/dev/null; then
  "$VENV/bin/pip" install -q --disable-pip-version-check \
    blark==0.8.3 lark==1.3.1 tree-sitter==0.26.1 tree-sitter-iec61131-3-st==0.1.2 pytest==8.3.4 lxml==6.1.3
fi
cargo build -q --locked -p hans-gateway --bin hans-gateway
cargo build -q --locked -p hans-sim --bin hans-sim
export HANS_GATEWAY=$PWD/target/debug/hans-gateway HANS_SIM=$PWD/target/debug/hans-sim
export PLC_PARSE_CACHE=$PWD/$VENV/parse-cache
cd plc/tests
exec "../../$VENV/bin/python" -m pytest -q -p no:cacheprovider test_static.py test_blocks.py
