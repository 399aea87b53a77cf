//! The sizes and deadlines other modules and the platforms size things by:
//! a leaf (it imports nothing of the crate), so that whoever needs a bound
//! reads it here without importing the module that enforces it.
//!
//! Each module keeps the bounds only it uses (the Modbus frame deadline,
//! the web connection's buffers); what is here is shared: by the state
//! (tables sized per session), the views, the board's socket count or the
//! Linux platform's TLS handshake.

use embassy_time::Duration;

/// Modbus clients served at once (`MODBUS_SESSIONS` reads 0 to this).
pub const MODBUS_CLIENTS: usize = 4;

/// Sockets of the Modbus server (the gateway runs a session future for
/// each): one more than [`MODBUS_CLIENTS`], so that one always accepts a
/// newcomer, which may then take an idle session's slot.
pub const MAX_SESSIONS: usize = MODBUS_CLIENTS + 1;

/// Socket buffer size of each Modbus session (each direction).
pub const MODBUS_BUF: usize = 512;

/// Socket buffer size of each robot-link socket (each direction).
pub const LINK_BUF: usize = 1024;

/// A web request (line, headers and body) must be whole this long after its
/// first byte; a TLS handshake on the page's port (Linux) must end within
/// it too. The longest request (6 KiB) is four or five segments: well
/// within this on any link a browser uses, a lost segment included (sent
/// again within a second).
pub const WEB_REQUEST_DEADLINE: Duration = Duration::from_secs(2);
