//! The core gateway firmware for the NUCLEO-F767ZI: Modbus TCP and the robot
//! link, configuration in flash; no web page, no DHCP, no DataSheet reader
//! (the field-device firmware, `src/bin/field_device.rs`, has them). Held to
//! 128 KiB of flash and 64 KiB of static RAM (`scripts/firmware-size.sh`).
#![no_std]
#![no_main]
// The gateway is one future of nested futures (engine, sessions, web
// connections, picoserve): computing its layout needs more depth than the
// default 128.
#![recursion_limit = "256"]

mod board;

use embassy_executor::Spawner;

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    board::run(spawner).await
}
