#!/usr/bin/env bash
# The gateway's Sparkplug B read by Eclipse Tahu's JavaScript library (npm
# `sparkplug-payload`, what Node-RED's Sparkplug nodes use), checked against
# the Sparkplug 3.0 TCK's edge-node assertions: tck.test.mjs says what and
# how.
#
#   host-tests/sparkplug-tahu/run.sh
#
# Installs the library, pinned by package-lock.json, into
# target/sparkplug-tahu/ (npm ci, install scripts off; again only when the
# lock file changed), builds hans-gateway and hans-sim (debug, as
# scripts/plc-tests.sh builds them: one build serves both), and runs the test
# with Node.js's test runner. Needs node and npm, Mosquitto and its clients,
# mbpoll (scripts/setup.sh installs them). Everything listens on 127.0.0.1 at
# free ports; the whole run is bounded (5 minutes) and every process it
# starts is stopped by its pid.
set -euo pipefail
cd "$(dirname "$0")/../.."
ROOT=$(pwd)
HERE=host-tests/sparkplug-tahu
TARGET=${CARGO_TARGET_DIR:-$ROOT/target}
DIR=$TARGET/sparkplug-tahu

if ! cmp -s "$HERE/package-lock.json" "$DIR/package-lock.json" ||
  [ ! -f "$DIR/node_modules/sparkplug-payload/package.json" ]; then
  echo "sparkplug-tahu: npm ci (sparkplug-payload, pinned) into $DIR"
  rm -rf "$DIR"
  mkdir -p "$DIR"
  cp "$HERE/package.json" "$HERE/package-lock.json" "$DIR/"
  (cd "$DIR" && npm ci --no-audit --no-fund --ignore-scripts --loglevel=error)
fi

source "$ROOT/scripts/host-programs.sh" && build_host_programs
# What Gateway/Version must say: the binary's (its package's) version.
GATEWAY_VERSION=$(cargo pkgid -p hans-gateway-linux | sed 's/.*[#@]//')

TAHU_DIR=$DIR HANS_GATEWAY=$TARGET/debug/hans-gateway HANS_SIM=$TARGET/debug/hans-sim \
  GATEWAY_VERSION=$GATEWAY_VERSION \
  timeout --kill-after=10 300 node --test --test-reporter=spec "$HERE/tck.test.mjs"
