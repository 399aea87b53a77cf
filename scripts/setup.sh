#!/usr/bin/env bash
# Installs everything the project needs on a fresh Debian machine with rustup
# (https://rustup.rs, or Debian's `rustup` package). Idempotent: each step
# checks first and does nothing when already done.
set -euo pipefail

if ! command -v rustup >/dev/null; then
  echo "setup: rustup not found. Install it (https://rustup.rs, or 'apt-get install rustup'" >&2
  echo "       then 'rustup default stable') and run this again." >&2
  exit 1
fi

need_apt=()
# A C toolchain links the host binaries and builds libFuzzer; python3 seeds the
# fuzzers and checks the vectors against the protocol document.
command -v cc >/dev/null || need_apt+=(build-essential)
command -v python3 >/dev/null || need_apt+=(python3)
command -v qemu-system-arm >/dev/null || need_apt+=(qemu-system-arm)
command -v mbpoll >/dev/null || need_apt+=(mbpoll)
# socat relays QEMU's guest forward to the simulator, one relay per connection.
command -v socat >/dev/null || need_apt+=(socat)
[ -x /usr/sbin/mosquitto ] || command -v mosquitto >/dev/null || need_apt+=(mosquitto) # the MQTT broker of gateway/tests/mqtt.rs
command -v mosquitto_sub >/dev/null || need_apt+=(mosquitto-clients) # mosquitto_sub, the README's and the demo's raw view of the telemetry
command -v openssl >/dev/null || need_apt+=(openssl) # the test CAs and certificates of the TLS tests (gateway/tests/mqtt.rs)
# llvm-size and llvm-objdump read the Cortex-M binaries for the size reports;
# llvm-readelf and llvm-objcopy make the QEMU field device's flash file (qemu-run.sh).
command -v llvm-size >/dev/null && command -v llvm-objcopy >/dev/null && command -v llvm-readelf >/dev/null || need_apt+=(llvm)
# Headless Chromium drives the web page in the browser tests (host-tests/web-e2e).
command -v chromium >/dev/null || need_apt+=(chromium)
command -v systemd-analyze >/dev/null || need_apt+=(systemd) # checks linux/dist/hans-gateway.service
# The robustness rig (host-tests/robustness): a network namespace with a TAP
# device (ip), floods (hping3), crafted frames (scapy for Debian's python3),
# a DHCP server for the firmware's DHCP client (dnsmasq), a technician's
# ping (iputils-ping).
command -v ip >/dev/null || need_apt+=(iproute2)
command -v ping >/dev/null || need_apt+=(iputils-ping)
command -v hping3 >/dev/null || [ -x /usr/sbin/hping3 ] || need_apt+=(hping3)
/usr/bin/python3 -c 'import scapy' 2>/dev/null || need_apt+=(python3-scapy)
command -v dnsmasq >/dev/null || [ -x /usr/sbin/dnsmasq ] || need_apt+=(dnsmasq-base)
if [ "${SETUP_FUZZ:-1}" = 1 ]; then
  # test-all.sh only: Debian's package checker for the gateway's package
  # (scripts/deb-test.sh), and Node.js with npm for Eclipse Tahu's
  # JavaScript Sparkplug decoder (host-tests/sparkplug-tahu).
  command -v lintian >/dev/null || need_apt+=(lintian)
  command -v node >/dev/null || need_apt+=(nodejs)
  command -v npm >/dev/null || need_apt+=(npm)
fi
if ((${#need_apt[@]})); then
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  echo "setup: apt-get install ${need_apt[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${need_apt[@]}" >/dev/null
fi

for component in rustfmt clippy; do
  if ! rustup component list --installed | grep -q "^$component"; then
    echo "setup: rustup component add $component"
    rustup component add "$component"
  fi
done

if ! rustup target list --installed | grep -qx thumbv7em-none-eabihf; then
  echo "setup: rustup target add thumbv7em-none-eabihf"
  rustup target add thumbv7em-none-eabihf
fi

# defmt-print turns the firmware's log (defmt frames) into text: scripts/qemu-run.sh
# pipes QEMU's output through it, the QEMU tests decode their logs with it.
if ! command -v defmt-print >/dev/null; then
  echo "setup: cargo install defmt-print --locked"
  cargo install --locked --quiet defmt-print
fi

if [ "${SETUP_FUZZ:-1}" = 1 ]; then
  if ! rustup toolchain list | grep -q '^nightly'; then
    echo "setup: rustup toolchain install nightly --profile minimal"
    rustup toolchain install nightly --profile minimal
  fi
  if ! cargo fuzz --version >/dev/null 2>&1; then
    echo "setup: cargo install cargo-fuzz"
    cargo install --locked --quiet cargo-fuzz
  fi
  # cargo-deb makes the gateway's Debian package (scripts/deb-test.sh);
  # pinned, as CI packages a dev build with it (see deb-test.sh).
  if [ "$(cargo deb --version 2>/dev/null)" != "cargo-deb 3.8.0" ]; then
    echo "setup: cargo install cargo-deb 3.8.0"
    cargo install --locked --quiet cargo-deb --version 3.8.0
  fi
fi
