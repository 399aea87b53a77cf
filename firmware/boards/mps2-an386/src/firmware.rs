//! The gateway firmware of this board, shared by its two binaries: `gateway`
//! (the core gateway: Modbus and the robot link) and `field-device` (feature
//! `field-device`: also the web page with its access control, DHCP, the
//! DataSheet reader, the Sparkplug B edge node, on when the host names a
//! broker, see [`factory_mqtt`](crate::factory_mqtt), the EtherNet/IP
//! adapter, off until `enip.enabled` is set, and signed updates).
//! Only the gateway library's features differ.
//!
//! Modbus TCP on port 502 and (field device) the web page on 80, at
//! 10.0.2.15 ([`FACTORY_NET`](crate::FACTORY_NET)); the robot is the
//! simulator at 10.0.2.100:10003 (forwarded by `scripts/qemu-run.sh` to the
//! host) unless the configuration names another. The core gateway keeps
//! its configuration in RAM (it runs without a flash file). The field
//! device has the flash file the bootloader started it from (`slots`): its
//! firmware slots (it takes signed updates) and its store, where the
//! configuration, the accounts and the audit log are kept across restarts
//! and updates. Port 5021 serves diagnostics (see [`diag`](crate::diag)).

use embassy_executor::Spawner;
#[cfg(not(feature = "field-device"))]
use hans_gateway::NoStorage;
use hans_gateway::{Config, Options};

use crate as board;

/// The first task: starts the board, then spawns the diagnostics port and
/// the gateway. Run it with [`executor::run`](crate::executor::run).
#[embassy_executor::task]
pub async fn start(spawner: Spawner) {
    // No address yet: the gateway applies its network settings.
    let stack = match board::init(spawner, embassy_net::Config::default()) {
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
        "gateway ({=str}): robot at {}:{=u16}",
        if cfg!(feature = "field-device") {
            "field device: web page, DHCP, DataSheet, V6, MQTT, EtherNet/IP"
        } else {
            "core"
        },
        board::SIM_IP,
        board::SIM_PORT
    );
}

#[embassy_executor::task]
async fn gateway(stack: embassy_net::Stack<'static>) -> ! {
    #[cfg(not(feature = "field-device"))]
    let storage = NoStorage;
    // The field device updates itself: the firmware slots of the flash file
    // it was started from, beside its store (configuration, accounts,
    // audit records) in the same file.
    // Kept here (in this task's static future) and lent to the gateway:
    // see `open_into`.
    #[cfg(feature = "field-device")]
    let mut store = None;
    #[cfg(feature = "field-device")]
    let storage = match board::slots::open_into(&mut store) {
        Ok(storage) => storage,
        Err(e) => board::fail(e),
    };
    // Only what differs from the library's defaults, so new options need no
    // change here.
    let base = Config::default();
    let options = Options {
        defaults: Config {
            robot_ip: board::SIM_IP,
            robot_port: board::SIM_PORT,
            net: board::factory_net(),
            // The Sparkplug edge node (the core has none): on when the
            // host names a broker (`mqtt=` on the command line).
            mqtt: if cfg!(feature = "field-device") {
                board::factory_mqtt(base.mqtt)
            } else {
                base.mqtt
            },
            ..base
        },
        network_managed: true,
        // The host's /dev/urandom through semihosting (see `seed`).
        seed: board::seed(stack),
        restart: Some(board::restart),
        // The web page's first administrator (the core has none).
        setup_code: if cfg!(feature = "field-device") {
            board::setup_code()
        } else {
            None
        },
        // No button to hold: the word `recovery` on QEMU's command line
        // instead (the field device's stored settings; the core stores
        // nothing).
        recovery: cfg!(feature = "field-device") && board::recovery(),
        // Images signed with the key the bootloader trusts, for this board.
        #[cfg(feature = "field-device")]
        update_key: Some(fw_keys::TRUSTED),
        #[cfg(feature = "field-device")]
        board: hans_gateway::update::layout::MPS2_AN386.board,
        // A test's failing self-check (`selfcheck=fail`).
        #[cfg(feature = "field-device")]
        self_check_fails: board::self_check_fails(),
        ..Options::default()
    };
    match hans_gateway::board::run(stack, storage, options).await {}
}
