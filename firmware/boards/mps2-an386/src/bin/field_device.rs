//! The field-device firmware on the QEMU mps2-an386 board (feature
//! `field-device`): the core gateway plus the web page on port 80 with its
//! access control, the DHCP client and the DataSheet reader (see
//! `board_mps2_an386::firmware`). `scripts/qemu-field-device.sh` runs it with
//! the page forwarded to the host.
#![no_std]
#![no_main]

use board_mps2_an386 as board;

#[cortex_m_rt::entry]
fn main() -> ! {
    board::executor::run(board::firmware::start)
}
