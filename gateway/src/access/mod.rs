//! Access control: who may change the gateway.
//!
//! * Who may connect at all: the allow-lists of the configuration
//!   ([`crate::config::AllowList`]), checked by the Modbus and web servers
//!   when a client connects (a refused client is closed at once and
//!   counted).
//! * Who may change the configuration over the web: a password, stored as
//!   a salted hash ([`password`]); sessions opened with it and the
//!   rate limit of wrong passwords (`session`).
//! * Who may change it over Modbus: everyone allowed to connect, unless the
//!   write protection (`CFG_WRITE_PROTECT`) is on; then only an authorized
//!   web session changes the configuration (and lifts the protection).
//!   A Modbus/TCP Security client (Linux) writes only if its certificate's
//!   certificate claims the operator's or the administrator's role
//!   (`crate::modbus::Grant`; the platform's TLS reads the claim).
//!
//! The threat model (what this protects against on a plant network, and
//! what it does not) is in the top-level README.

pub mod accounts;
pub mod password;
pub mod setup;
// Sessions and the rate limit serve the web page only.
#[cfg(feature = "web")]
pub(crate) mod session;
// The guesses of the page's logins and setup code.
#[cfg(feature = "web")]
pub(crate) mod limit;
