//! What the gateway knows of access: the stored password hash, the
//! network settings it runs with, the refusals it counted.

use crate::access::accounts::Accounts;
use crate::config::NetConfig;

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

    /// May the access settings (allow-lists, write protection, the web
    /// page's host name and open reading) be changed over Modbus? Not
    /// before an administrator exists (a device fresh from the factory is
    /// not open to the first Modbus client), except after a recovery start
    /// (the board's button: someone is at the device). With an
    /// administrator, the write protection decides (`CFG_WRITE_PROTECT`).
    pub fn modbus_may_change_access(&self) -> bool {
        self.recovery || self.accounts.admin_exists()
    }

    /// The configured network settings differ from the running ones (on
    /// platforms where they apply).
    pub fn restart_pending(&self, net: &NetConfig) -> bool {
        self.network_managed && *net != self.running
    }
}
