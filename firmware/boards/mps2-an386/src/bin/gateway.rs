//! The gateway firmware on the QEMU mps2-an386 board.
//!
//! Modbus TCP on port 502; the robot is the simulator at 10.0.2.100:10003
//! (forwarded by `scripts/qemu-run.sh` to the host) unless the PLC configures
//! another address. The configuration is kept in RAM: this board has no
//! persistent storage. Port 5021 serves diagnostics (see `diag`).
#![no_std]
#![no_main]

use board_mps2_an386 as board;
use embassy_executor::Spawner;
use hans_gateway::{Config, NoStorage, Options};

#[cortex_m_rt::entry]
fn main() -> ! {
    board::executor::run(start)
}

#[embassy_executor::task]
async fn start(spawner: Spawner) {
    let stack = match board::init(spawner) {
        Ok(stack) => stack,
        Err(e) => board::fail(e),
    };
    match (board::diag::task(stack), gateway(stack)) {
        (Ok(diag), Ok(gateway)) => {
            spawner.spawn(diag);
            spawner.spawn(gateway);
        }
        _ => board::fail(board::BoardError::Spawn),
    }
    defmt::info!(
        "gateway: Modbus on 10.0.2.15:502, robot at {}:{=u16}",
        board::SIM_IP,
        board::SIM_PORT
    );
}

#[embassy_executor::task]
async fn gateway(stack: embassy_net::Stack<'static>) -> ! {
    let storage = NoStorage;
    // Only what differs from the library's defaults (Modbus on 502, no
    // override), so new options need no change here.
    let options = Options {
        defaults: Config {
            robot_ip: board::SIM_IP,
            robot_port: board::SIM_PORT,
            ..Config::default()
        },
        ..Options::default()
    };
    match hans_gateway::board::run(stack, storage, options).await {}
}
