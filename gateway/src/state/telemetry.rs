//! The MQTT telemetry's connection, as the rest of the gateway sees it
//! (feature `mqtt`): its state and counters ([`Status`], held by the hub
//! and shown by the page) and why a connection ended ([`Error`]). Part of
//! the state, apart from the client (`crate::mqtt`) that keeps them, so
//! that the hub and the page hold them without depending on the client.

use core::cell::Cell;

use crate::net::NetError;

/// Why a connection ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Error {
    /// The socket failed.
    Net(NetError),
    /// The broker closed the connection.
    Closed,
    /// The broker did not answer or take data in time.
    Timeout,
    /// The broker refused the CONNECT with this return code (4: bad user
    /// name or password, 5: not authorised).
    Refused(u8),
    /// The broker sent something that is not MQTT 3.1.1 here.
    Protocol,
    /// A packet does not fit its buffer.
    TooLong,
    /// The primary host went offline (its STATE message).
    HostOffline,
    /// The broker's name has no address here (boards take an address;
    /// Linux resolves names).
    Unresolved,
    /// The group or edge node id is not a Sparkplug id (empty, longer
    /// than 32 bytes).
    BadId,
}

impl Error {
    /// A short text for logs and the status page.
    pub fn as_str(self) -> &'static str {
        match self {
            Error::Net(e) => e.as_str(),
            Error::Closed => "closed by the broker",
            Error::Timeout => "broker timeout",
            Error::Refused(_) => "refused by the broker",
            Error::Protocol => "protocol error",
            Error::TooLong => "packet too long",
            Error::HostOffline => "primary host offline",
            Error::Unresolved => "broker name not resolved",
            Error::BadId => "group or edge node id invalid (1-32 characters)",
        }
    }
}

impl From<NetError> for Error {
    fn from(e: NetError) -> Error {
        Error::Net(e)
    }
}

/// The client's counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// The client runs (`mqtt.enabled` with a broker).
    pub on: bool,
    /// Connected (CONNACK accepted) now.
    pub connected: bool,
    /// Connected, the births held until the primary host is online.
    pub waiting_for_host: bool,
    /// Accepted connections since start.
    pub connects: u32,
    /// Connection attempts and connections that ended in an error.
    pub failures: u32,
    /// The last error.
    pub last_error: Option<Error>,
    /// PUBLISH packets sent.
    pub sent: u32,
    /// Messages made but not sent (the connection failed while writing,
    /// or a birth did not fit).
    pub dropped: u32,
    /// Received packets too long for [`crate::mqtt::RX_BUF`], skipped.
    pub skipped: u32,
    /// The edge node's counters.
    pub node: NodeStats,
}

/// The Sparkplug edge node's counters, for the status page (the client's
/// `sparkplug::EdgeNode` keeps them).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NodeStats {
    /// Messages made (births, deaths, data), since start.
    pub messages: u32,
    /// Data metrics dropped because one alone did not fit a payload.
    pub dropped: u32,
    /// Command events that left the log before they were published (an
    /// upper bound).
    pub events_lost: u32,
    /// Metric writes refused in NCMD/DCMD.
    pub refused: u32,
    /// Command payloads that could not be decoded.
    pub malformed: u32,
    /// Births made on a host's request.
    pub rebirths: u32,
}

/// The client's state for others to read (the status page, tests).
#[derive(Debug, Default)]
pub struct Status(Cell<Stats>);

impl Status {
    /// No connection yet.
    pub const fn new() -> Status {
        Status(Cell::new(Stats {
            on: false,
            connected: false,
            waiting_for_host: false,
            connects: 0,
            failures: 0,
            last_error: None,
            sent: 0,
            dropped: 0,
            skipped: 0,
            node: NodeStats {
                messages: 0,
                dropped: 0,
                events_lost: 0,
                refused: 0,
                malformed: 0,
                rebirths: 0,
            },
        }))
    }

    /// The counters now.
    pub fn get(&self) -> Stats {
        self.0.get()
    }

    pub(crate) fn update(&self, f: impl FnOnce(&mut Stats)) {
        let mut s = self.0.get();
        f(&mut s);
        self.0.set(s);
    }
}
