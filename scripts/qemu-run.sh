#!/usr/bin/env bash
# Runs a firmware ELF on QEMU's mps2-an386 machine with user-mode networking
# (or on a TAP device: NET below).
# This is the cargo runner of firmware/ (`cargo run --bin gateway` from there).
#
#   scripts/qemu-run.sh FIRMWARE.elf
#
# Environment:
#   NET          `user` (default): QEMU's user-mode network with the forwards
#                below; `tap:IFNAME`: the LAN9118 on the existing TAP device
#                IFNAME instead (QEMU opens it, no up/down scripts), a real
#                Ethernet segment: whoever made the device gives its other
#                side addresses and runs the simulator (10.0.2.100:10003, the
#                firmware's factory robot address) there. No forward applies
#                then (MODBUS_PORT, SIM_PORT, ADMIN_PORT, WEB_PORT are
#                ignored; MQTT_PORT still hands in the word
#                `mqtt=10.0.2.100:1883`). host-tests/robustness runs it so,
#                on a TAP device inside a network namespace it makes.
#   MODBUS_PORT  host port forwarded to the firmware's Modbus port 502
#                (default 5020; bound on 127.0.0.1 only)
#   SIM_PORT     host port of the robot simulator; the firmware reaches it as
#                10.0.2.100:10003 (default 10003), through socat
#   ADMIN_PORT   host port forwarded to the firmware's test/diagnostics port
#                5021, if set (QEMU gateway firmware only)
#   WEB_PORT     host port forwarded to the firmware's web page on port 80, if
#                set (the field-device firmware serves it; open
#                http://127.0.0.1:WEB_PORT/)
#   FIRMWARE_ARGS  words the firmware reads as its command line (semihosting;
#                QEMU's -append): `dhcp` makes the QEMU board's factory network
#                setting DHCP (QEMU's user network has a DHCP server)
#   SETUP_CODE   the one-time code for the web page's first administrator
#                (field-device firmware): handed in as the word `setup=CODE`
#                of the command line; without it the firmware makes one and
#                prints it in its log
#   MQTT_PORT    host port of an MQTT broker on 127.0.0.1, if set
#                (field-device firmware): the firmware reaches it as
#                10.0.2.100:1883, through socat, and is handed the word
#                `mqtt=10.0.2.100:1883` of the command line, which turns its
#                Sparkplug B edge node on with that broker (without it, MQTT
#                stays off)
#   DEFMT_OUT    file to write the raw defmt log stream to; when unset the
#                stream is decoded with defmt-print if it is installed, else
#                written raw to stdout
#
# A firmware linked for the update slots (the field device: its vector table
# at 0x0001_0400, hans_fw_image::layout::MPS2_AN386.entry) runs as on
# a device with updates: QEMU starts the bootloader (firmware/bootloader-mps2,
# beside the ELF), which checks the image in the flash file's active slot,
# copies it to RAM and starts it. The flash file is a host file the guest
# reads and writes through semihosting (the word `flash=PATH`), made from the
# ELF by scripts/fw-image.sh: llvm-objcopy -O binary, `hans-fw sign` with
# the development key, `hans-fw install`. The bootloader's log is text on
# stderr (`hans-boot:`).
#   FLASH_FILE   the flash file: kept and used as it is when it exists (a
#                restart of QEMU keeps the flash: the configuration, an update
#                and its boot state), else made there; default a new
#                temporary file each run (removed when QEMU ends)
#   FW_VERSION   the version the image is signed with (default 0.1.0)
#   BOOTLOADER   the bootloader ELF (default: bootloader-mps2 beside the ELF)
#   HANS_FW      the hans-fw program (default: target/{debug,release}/hans-fw
#                of the host workspace, else on PATH)
#
# QEMU's exit status is the firmware's semihosting exit code (0 pass, 1 fail).
# `restrict=on` isolates the guest: its only ways out are the forwards below,
# and every host-side socket QEMU opens is on 127.0.0.1.
set -euo pipefail

elf=${1:?usage: qemu-run.sh FIRMWARE.elf}
modbus_port=${MODBUS_PORT:-5020}
sim_port=${SIM_PORT:-10003}

net=${NET:-user}
case $net in
  user) ;;
  tap:?*)
    ifname=${net#tap:}
    case $ifname in
      *[!A-Za-z0-9_.-]*) echo "qemu-run.sh: NET=tap:IFNAME: '$ifname' is not an interface name" >&2; exit 2 ;;
    esac
    ;;
  *) echo "qemu-run.sh: NET must be 'user' or 'tap:IFNAME', not '$net'" >&2; exit 2 ;;
esac
if [ "$net" = user ]; then
  nic="user,model=lan9118,restrict=on"
  nic+=",hostfwd=tcp:127.0.0.1:${modbus_port}-10.0.2.15:502"
  if [ -n "${ADMIN_PORT:-}" ]; then
    nic+=",hostfwd=tcp:127.0.0.1:${ADMIN_PORT}-10.0.2.15:5021"
  fi
  if [ -n "${WEB_PORT:-}" ]; then
    nic+=",hostfwd=tcp:127.0.0.1:${WEB_PORT}-10.0.2.15:80"
  fi
  # `cmd:` spawns one relay per guest connection, so every connection the
  # firmware opens is a new connection to the simulator, and one attempted
  # while the simulator is down fails as it would on a real network. (A
  # `tcp:` chardev target would be one shared stream, opened once at QEMU's
  # start, that fails QEMU when the simulator is not up yet and never
  # reconnects after the simulator restarts.)
  command -v socat >/dev/null || { echo "qemu-run.sh: socat is needed (apt-get install socat)" >&2; exit 2; }
  nic+=",guestfwd=tcp:10.0.2.100:10003-cmd:socat - TCP:127.0.0.1:${sim_port}"
  # The broker the same way: one relay per connection, so the firmware's
  # reconnects reach a broker started (or restarted) after QEMU.
  if [ -n "${MQTT_PORT:-}" ]; then
    case $MQTT_PORT in
      *[!0-9]*) echo "qemu-run.sh: MQTT_PORT must be a port number, not '$MQTT_PORT'" >&2; exit 2 ;;
    esac
    nic+=",guestfwd=tcp:10.0.2.100:1883-cmd:socat - TCP:127.0.0.1:${MQTT_PORT}"
  fi
else
  # The segment is the TAP device's: no forwards, no relays.
  nic="tap,ifname=${ifname},script=no,downscript=no,model=lan9118"
fi

args=${FIRMWARE_ARGS:-}
kernel=$elf
# The vector table's address: 0x0001_0400 for a firmware of the update slots.
vectors=$(llvm-readelf -S --wide "$elf" 2>/dev/null |
  awk '{ for (i = 1; i < NF; i++) if ($i == ".vector_table") print $(i + 2) }')
if [ "$vectors" = 00010400 ]; then
  root=$(cd "$(dirname "$0")/.." && pwd)
  kernel=${BOOTLOADER:-$(dirname "$elf")/bootloader-mps2}
  [ -f "$kernel" ] || {
    echo "qemu-run.sh: $elf starts through the bootloader, $kernel is not built:" >&2
    echo "  (cd firmware && cargo build --release -p bootloader-mps2), or set BOOTLOADER" >&2
    exit 2
  }
  flash=${FLASH_FILE:-}
  if [ -z "$flash" ]; then
    tmp=$(mktemp -d)
    flash=$tmp/flash.bin
    # Removed once QEMU (this process, after the exec below) has ended.
    (while kill -0 $$ 2>/dev/null; do sleep 1; done; rm -rf "$tmp") </dev/null >/dev/null 2>&1 &
    disown
  fi
  if [ ! -f "$flash" ]; then
    bash "$root/scripts/fw-image.sh" --flash "$elf" "$flash"
  fi
  args="${args:+$args }flash=$(realpath "$flash")"
fi

qemu=(qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic -monitor none
  -serial none -semihosting-config enable=on,target=native -nic "$nic" -kernel "$kernel")
if [ -n "${SETUP_CODE:-}" ]; then
  args="${args:+$args }setup=$SETUP_CODE"
fi
if [ -n "${MQTT_PORT:-}" ]; then
  args="${args:+$args }mqtt=10.0.2.100:1883"
fi
if [ -n "$args" ]; then
  qemu+=(-append "$args")
fi

if [ -n "${DEFMT_OUT:-}" ]; then
  exec "${qemu[@]}" >"$DEFMT_OUT"
elif command -v defmt-print >/dev/null; then
  # Decode the log. QEMU stays this script's process (exec), so whoever
  # stops this script stops QEMU, and its status is the script's; the
  # decoder ends when QEMU's output closes.
  exec "${qemu[@]}" > >(defmt-print -e "$elf")
else
  exec "${qemu[@]}"
fi
