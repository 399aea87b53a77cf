//! What the gateway knows of access: the stored password hash, the
//! network settings it runs with, the refusals it counted.

use crate::access::accounts::Accounts;
use crate::config::{Config, NetConfig};

/// Access state (register `ACCESS` and the refusal counters; the web
/// page's access section).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AccessState {
    /// The accounts of the web page (saved with the configuration).
    pub accounts: Accounts,
    /// The network settings in use since start (the configuration's
    /// may differ: they take effect at the next start).
    pub running: NetConfig,
    /// The network settings come from the configuration on this platform
    /// (boards); on Linux they are the operating system's and the command
    /// line's.
    pub network_managed: bool,
    /// Started with the factory network and access settings (a board's
    /// button held at power-up).
    pub recovery: bool,
    /// The web page is served.
    pub web_on: bool,
    /// Modbus connections refused by the allow-list (wraps).
    pub modbus_refused: u16,
    /// Web connections refused by the allow-list (wraps).
    pub web_refused: u16,
    /// Modbus writes refused by the write protection or by a TLS
    /// client's role (wraps).
    pub writes_refused: u16,
}

impl AccessState {
    /// Nothing refused yet, no password, running with `net`.
    pub fn new(net: NetConfig) -> Self {
        AccessState {
            accounts: Accounts::NONE,
            running: net,
            network_managed: false,
            recovery: false,
            web_on: false,
            modbus_refused: 0,
            web_refused: 0,
            writes_refused: 0,
        }
    }

    /// May the protected settings (the robot endpoint, the link mode, the
    /// network and access settings: `config::schema::PROTECTED`) be changed
    /// over Modbus, with `config` in use? Only where an administrator
    /// allowed configuration over Modbus (`access.modbus_config`, on the
    /// page or in the file: off in the factory state, and off for a device
    /// commissioned before the setting existed), or after a recovery start
    /// (the board's button: someone is at the device; the core firmware,
    /// which has no page, changes them only then).
    pub fn modbus_may_change_protected(&self, config: &Config) -> bool {
        self.recovery || config.modbus_config
    }

    /// The configured network settings differ from the running ones (on
    /// platforms where they apply).
    pub fn restart_pending(&self, net: &NetConfig) -> bool {
        self.network_managed && *net != self.running
    }
}
