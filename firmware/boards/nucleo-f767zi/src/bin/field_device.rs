//! The field-device firmware for the NUCLEO-F767ZI (feature `field-device`):
//! the core gateway plus the web page with its access control, the DHCP
//! client and the DataSheet reader. Held to 256 KiB of flash and 128 KiB
//! of static RAM (`scripts/firmware-size.sh`). The board code is the core
//! firmware's (`src/board/`); only the gateway library's features differ.
#![no_std]
#![no_main]
// The gateway future nests deeply (see `src/main.rs`).
#![recursion_limit = "256"]

#[path = "../board/mod.rs"]
mod board;

use embassy_executor::Spawner;

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    board::run(spawner).await
}
