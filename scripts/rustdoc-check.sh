#!/usr/bin/env bash
# The published crates' documentation builds without a warning (broken
# intra-doc links, missing docs, bad HTML): the codec, the gateway with
# every feature, the firmware image, the Linux platform and EtherNet/IP.
# One package per `cargo doc`: with two packages, `pkg/feature` flags are
# not applied to the documented crate, and feature-gated modules go missing.
#
# Environment: CARGO_TARGET_DIR (scripts/test-all.sh gives it a directory
# of its own, target/rustdoc, so that it runs beside the host builds
# without waiting on their lock).
set -euo pipefail
cd "$(dirname "$0")/.."
export RUSTDOCFLAGS="-D warnings"
echo "--- rustdoc (codec)"
cargo doc -p hans-codec --no-deps --features defmt,v6 --locked
echo "--- rustdoc (gateway, every feature)"
cargo doc -p hans-gateway --no-deps \
  --features embassy-net,flash,testkit,web,v6,dhcp,datasheet,defmt,sntp,mqtt,update,enip --locked
echo "--- rustdoc (firmware image, Linux platform, EtherNet/IP)"
cargo doc -p hans-fw-image -p hans-gateway-linux -p hans-enip --no-deps --locked
