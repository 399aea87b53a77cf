//! The core gateway firmware on the QEMU mps2-an386 board: Modbus TCP and the
//! robot link (see `board_mps2_an386::firmware`). The field-device firmware
//! (`field_device.rs`) is the same program with the web page, DHCP and the
//! DataSheet reader.
#![no_std]
#![no_main]

use board_mps2_an386 as board;

#[cortex_m_rt::entry]
fn main() -> ! {
    board::executor::run(board::firmware::start)
}
