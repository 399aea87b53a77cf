//! The audit log (IEC 62443-4-2 CR 2.8 auditable events, CR 2.11
//! timestamps): who changed what, from where, when, kept across restarts
//! and power cuts (feature `audit`, which `web` turns on).
//!
//! ## A record
//! A sequence number (across restarts: a gap means records were lost), a
//! boot counter (counts every start; kept in the log's own store, it
//! follows the newest kept record), the uptime in ms, the wall time in
//! Unix seconds when the gateway knows it (Linux: the host's clock; a
//! board: once a time server answered, `network.ntp_server`), the kind
//! ([`Kind`]), the actor (an account name, `-` for none), the interface
//! ([`Interface`]), the source IPv4 address when known, and a short detail.
//! Stored, a record is at most [`RECORD_MAX`] (128) bytes with a version
//! byte and a CRC ([`record`]); an actor is cut at `ACTOR_MAX` (16)
//! bytes, a detail at `DETAIL_MAX` (79, ending in `...`), and each value
//! of a configuration change at 24 (`log::VALUE_MAX`). Texts are printable
//! ASCII (other bytes are stored as `?`).
//!
//! ## What is recorded, and by whom
//! | kind | when | hook |
//! |---|---|---|
//! | `start` | every start (detail: the version) | `keep::started` (from `Gateway::load`) |
//! | `config-loaded` | at start: what was loaded (its CRC) or why the defaults | `keep::started` |
//! | `recovery` | a recovery start ([`crate::Options::recovery`]), then a `config` record per setting it changed, interface `button` | `keep::started` |
//! | `config` | a setting changed: `key: old -> new`; a trigger entry: `triggers.N = text` | `Hub::config_command` (Modbus `CONFIG_COMMAND` 1), `Hub::change` / `Hub::change_by` (the page), `Hub::write_registers` (trigger texts over Modbus) |
//! | `refused` | connections refused by an allow-list, or by the robot link's listen port (not the controller's address), counted per interface over a period (60 s, doubling while they go on, up to 1 h), with the last address | `Hub::admit_modbus`, `Hub::admit_web`, `Hub::audit_refused_robot` (the engine) |
//! | `stop` | the platform stopped the gateway in order (detail: why, e.g. `SIGTERM`); the running counting periods are ended and recorded first, a restart from the page ends them too | `Gateway::run_until`, `keep::closing` |
//! | `watchdog` | the PLC watchdog tripped | `engine::watchdog::audit_trip` |
//! | `lost` | records were lost before they could be kept (how many) | the log itself |
//! | `time` | the wall clock was set by a time server | `Log::set_wall_time` |
//! | `login`, `login-failed`, `logout`, `account-*`, `restart`, `firmware` | see below | the accounts and the page (`Event`) |
//!
//! ## For the accounts and the page: `Event`
//! `hub.audit(event)` records an event at once, never blocks and never
//! fails (no clock needed: the storage task stamps it within the same
//! executor turn):
//!
//! ```ignore
//! let from = peer.map(|p| *p.ip());
//! hub.audit(Event::Login { name: b"alice", ok: true, from });
//! hub.audit(Event::Login { name: tried, ok: false, from }); // the name as typed
//! hub.audit(Event::Logout { name: b"alice", from });
//! hub.audit(Event::Account { name: b"bob", change: AccountChange::Created { role: "operator" }, by: b"alice", from });
//! hub.audit(Event::Account { name: b"bob", change: AccountChange::Role { role: "admin" }, by: b"alice", from });
//! hub.audit(Event::Account { name: b"bob", change: AccountChange::Password, by: b"bob", from });
//! hub.audit(Event::Account { name: b"bob", change: AccountChange::Removed, by: b"alice", from });
//! hub.audit(Event::Restart { who: Who::web(b"alice", from) });
//! ```
//!
//! A configuration changed from the page should go through
//! `Hub::change_by(Who::web(account, from), f)`, so that its records name
//! the account and the address (`Hub::change` records them as `-`, from
//! no address).
//!
//! ## Bounds
//! * RAM: the newest `RING` (64) records, for the page; they are also
//!   the queue of records waiting to be kept. A record that would push out
//!   one not kept yet (the medium slower than the events for 64 records)
//!   loses that one; once records are kept again a `lost` record says how
//!   many. A medium that fails loses the record it failed on (counted the
//!   same way).
//! * Kept: on a board, a flash ring (`storage::flash`, sequential-storage's
//!   queue over its own sectors: when full, the oldest sector's records go);
//!   on Linux, a file beside the configuration file (`hans-gateway-linux`'s `audit_file`:
//!   appended and synced; at its size limit it is rotated, the previous
//!   file kept). Without persistent storage (the QEMU board, Linux without
//!   `--config`) only the RAM ring holds them.
//! * `GET /api/audit` (JSON, or `?format=csv`) pages through the whole log
//!   kept ([`page`]: `?before=SEQ&limit=N`, at most [`page::PAGE_MAX`]
//!   records a page, read from the medium into a fixed window), newest
//!   page first; where nothing is kept, through the RAM ring.
//! * The page answers a change once its records are kept on the medium
//!   (`Log::wait_kept`, at most 5 s): evidence that a client saw answered
//!   survives a crash right after.

pub(crate) mod keep;
pub(crate) mod log;
pub mod page;
pub mod record;

use core::net::Ipv4Addr;

pub(crate) use log::Log;
#[cfg(test)]
pub(crate) use log::RING;
pub use record::{Interface, Kind, Record, Short, RECORD_MAX};
#[cfg(test)]
pub(crate) use record::{ACTOR_MAX, DETAIL_MAX};

/// Who did something: an account (or none), through which interface,
/// from which address.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Who<'a> {
    /// The account's name; empty for none (shown as `-`).
    pub actor: &'a [u8],
    /// Through which interface.
    pub interface: Interface,
    /// From which address, when known.
    pub from: Option<Ipv4Addr>,
}

impl Who<'static> {
    /// The gateway itself.
    pub(crate) const SYSTEM: Who<'static> = Who {
        actor: b"",
        interface: Interface::System,
        from: None,
    };

    /// A Modbus client (no accounts there).
    pub(crate) const fn modbus(from: Option<Ipv4Addr>) -> Self {
        Who {
            actor: b"",
            interface: Interface::Modbus,
            from,
        }
    }
}

impl<'a> Who<'a> {
    /// The account `actor` (empty: none) on the page, from `from`.
    pub(crate) const fn web(actor: &'a [u8], from: Option<Ipv4Addr>) -> Self {
        Who {
            actor,
            interface: Interface::Web,
            from,
        }
    }
}

/// An event the accounts and the page record (see the module
/// documentation for how).
#[derive(Clone, Copy, Debug)]
pub(crate) enum Event<'a> {
    /// A login on the page: `ok` or refused. `name` is the account's name,
    /// or for a refusal the name as it was typed (cut at 16 bytes, shown
    /// printable).
    Login {
        /// The account (or the name tried).
        name: &'a [u8],
        /// Succeeded.
        ok: bool,
        /// The client's address.
        from: Option<Ipv4Addr>,
    },
    /// A session ended by its user.
    Logout {
        /// The account.
        name: &'a [u8],
        /// The client's address.
        from: Option<Ipv4Addr>,
    },
    /// An account changed, by an administrator (or, for a password, by
    /// its owner).
    Account {
        /// The account changed.
        name: &'a [u8],
        /// What changed.
        change: AccountChange<'a>,
        /// Who changed it (an account's name).
        by: &'a [u8],
        /// The client's address.
        from: Option<Ipv4Addr>,
    },
    /// A restart was asked for.
    Restart {
        /// By whom.
        who: Who<'a>,
    },
    /// A firmware update: what was installed, or why not.
    #[cfg(feature = "update")]
    Firmware {
        /// By whom.
        who: Who<'a>,
        /// What (cut at 79 bytes).
        detail: &'a str,
    },
}

/// What changed in an account ([`Event::Account`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum AccountChange<'a> {
    /// Created with this role (`viewer`, `operator`, `admin`).
    Created {
        /// Its role's word.
        role: &'a str,
    },
    /// Removed.
    Removed,
    /// Given this role.
    Role {
        /// The new role's word.
        role: &'a str,
    },
    /// Its password was set.
    Password,
}

#[cfg(test)]
mod tests;
