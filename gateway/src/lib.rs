//! # hans-gateway
//!
//! A gateway between a PLC (Modbus TCP server) and a Hans / Huayan Elfin
//! robot controller (its TCP command port): the PLC writes a few registers
//! and the robot moves, with Busy, Done and Error coming back the PLCopen
//! way. The register map for PLC programmers is `REGISTERS.md` beside this
//! crate's `Cargo.toml`; the page's API `WEB.md`; the telemetry's contract
//! `SPARKPLUG.md`.
//!
//! The logic is `no_std`, allocation-free and board-independent; it runs on
//! embassy (embassy-sync, embassy-time) over a small socket interface. A
//! platform gives it sockets ([`net::Net`]), a clock ([`Clock`]), a place to
//! keep things ([`Storage`]) and how it was started ([`Options`]), and runs
//! [`run`]: the boards do so through [`board::run`] (feature `embassy-net`,
//! crates in `firmware/`), Linux through the crate `hans-gateway-linux`
//! (`linux/`: tokio sockets with TLS, the TOML file, the binary). Those are
//! the platform API; the rest of the public items are the state and its
//! views that platforms and tests read (the register map, the settings
//! schema, the stored image and audit record formats).
//!
//! ## Where things are
//! | module | what |
//! |---|---|
//! | [`state`] | the typed state: robot status, link, inputs, handshakes, queue, configuration, firmware, the telemetry's connection |
//! | [`registers`] | the Modbus register map, a view of the state (`map`: addresses; `view`: encode / decode) |
//! | [`job`] | typed jobs: channel command codes, RAW and trigger texts, urgent commands, the queue |
//! | `plc` | what a PLC's register write means (edges into jobs, the heartbeat, `CONFIG_COMMAND`), and the port binding the Modbus server to the state |
//! | `engine` | the rules in time: motion completion, watchdog, bring-up, status polls, jogging |
//! | [`hub`] | plumbing: the shared state behind its lock, and the signals between the tasks |
//! | `link` | robot link: connect or listen, one request in flight, framing, reply timeout |
//! | `modbus` | Modbus TCP server: sessions, function codes, exceptions (framing by `modbus-core`) |
//! | `admission` | who a listener serves: slots, per-address caps, idle eviction, the newcomer's wait (Modbus and the page) |
//! | `datasheet` | the status from the DataSheet port (feature `datasheet`) |
//! | [`config`] | the configuration and the schema of its settings (network and allow-lists included) |
//! | [`access`] | accounts and roles, password hashes, the setup code, web sessions, the rate limit of guesses |
//! | [`audit`] | the audit log: who changed what, from where, when (feature `audit`) |
//! | [`storage`] | the stored image; the configuration and audit stores; flash storage |
//! | [`update`] | signed A/B updates: the slots, the upload's mailbox (feature `update`; the image format is the crate `hans-fw-image`) |
//! | [`clock`] | time: embassy-time on boards and Linux, a virtual clock in tests |
//! | [`net`] | the socket interface a platform implements (embassy-net's adapter here, tokio's in `linux/`) |
//! | `web` | the web page and its JSON API (feature `web`) |
//! | [`mqtt`] | the MQTT client and the Sparkplug B edge node (feature `mqtt`) |
//! | `sntp` | the audit log's wall time from a time server on boards (feature `sntp`) |
//! | [`enip`] | the EtherNet/IP adapter: the I/O assemblies as a view of the state, its listeners (feature `enip`; `ENIP.md`) |
//! | [`limits`], [`crc`], [`hex`], [`error`] | leaves: shared sizes and deadlines, the CRC-32, hex text, the error codes |
//! | `gateway` | the composition root: [`Options`], [`Gateway`], [`run`], the storage task |
//! | [`board`] | the entry point for boards (feature `embassy-net`) |
//! | [`testkit`] | a virtual world for tests: clock, network, robot, PLC (feature `testkit`) |
//!
//! ## Layers
//! Each module imports only modules of lower layers: a module can be read,
//! tested and changed with what is below it, and no cycle can form.
//! `scripts/layers.py` checks this table against the imports (following
//! the names this crate root re-exports to the modules that define them),
//! in CI.
//!
//! | layer | modules | what they are |
//! |---|---|---|
//! | 0 | `fmt`, `limits`, `crc`, `hex`, `clock`, `error`, `config`, `net` | leaves: logging, shared sizes, checksums, time, error codes, the settings schema, the socket interface |
//! | 1 | `access`, `job`, `admission`, `link` | accounts and sessions, typed jobs, who a listener serves, the robot link |
//! | 2 | `state` | the typed state |
//! | 3 | `registers` | the register map, a view of the state |
//! | 4 | `storage` | the stored image and the stores |
//! | 5 | `audit`, `update` | the audit log, the firmware slots |
//! | 6 | `hub` | the shared state and the signals |
//! | 7 | `modbus` | the Modbus server, over any register map |
//! | 8 | `plc`, `engine`, `datasheet`, `mqtt`, `sntp`, `web` | the services that run on the hub |
//! | 9 | `enip` | a second PLC protocol: a service over the PLC rules of `plc` |
//! | 10 | `gateway` | the composition root |
//! | 11 | `board` | the boards' entry point |
//!
//! ## Bounds
//! Every buffer and queue is fixed: 4 Modbus clients at once, 3 from one
//! address, on [`limits::MAX_SESSIONS`] sockets (one spare, so that a
//! newcomer can take an idle session's slot),
//! [`job::QUEUE_DEPTH`] queued commands (more end in Error 39600)
//! plus [`job::URGENT_DEPTH`] urgent ones (one per source: never full),
//! RAW requests of 256 characters and replies of 512 (longer replies are
//! cut and flagged), robot replies up to `link::REPLY_MAX` (1 KiB) bytes
//! (longer: Error 39502), Modbus ADUs of 260 bytes, DataSheet packets up to
//! `datasheet::PAYLOAD_MAX` bytes (longer ones are dropped and logged).
//!
//! Time limits: a robot connect `link::CONNECT_TIMEOUT` (the
//! DataSheet connection too), a bring-up step `engine::bringup::STATE_TIMEOUT`
//! (Error 39607), a DataSheet connection without data
//! `datasheet::SILENCE_TIMEOUT`, a silent Modbus client
//! `modbus::IDLE_TIMEOUT`, and a robot reply the configured
//! `CFG_REPLY_TIMEOUT_MS` (Error 39503).
//!
//! ## Stack
//! Large state (the register map, socket buffers, the futures of the
//! engine and the sessions) is built where it stays, inside the future of
//! [`run`], and never moved through the stack: the storage is lent to
//! [`Gateway::serve`], not moved in; the sessions are pinned one by one;
//! the state is built in a function of its own (`board::run`). Temporaries
//! of kilobytes live in functions that are not inlined. The QEMU tests hold
//! the high-water marks to a budget (`firmware/README.md`).
//!
//! ## Features
//! * `datasheet`: `datasheet`, the status from the DataSheet port
//!   (CFG_STATUS_SOURCE = 1; without it that value is refused).
//! * `embassy-net`: the embassy-net adapter and [`board`].
//! * `dhcp`: the DHCP client on boards ([`board::run`] applies `NET_DHCP`).
//! * `flash`: [`storage::flash::FlashStorage`] (sequential-storage over a
//!   `NorFlash`).
//! * `v6`: the V6 commands (jogging, the controller's error texts).
//! * `web` (with `audit`): the page, its JSON API, accounts, the audit log.
//! * `sntp`: the audit log's wall time on boards from an SNTP server
//!   (`sntp`, run by [`board::run`]).
//! * `mqtt`: [`mqtt`], the MQTT client and Sparkplug B edge node.
//! * `update` (with `web`): [`update`], signed A/B updates.
//! * `udp`: UDP sockets in the platform API ([`net::Net::udp`]).
//! * `enip` (with `udp`): [`enip`], the EtherNet/IP adapter, off until
//!   `enip.enabled` is set.
//! * `log` / `defmt`: log lines through `log` (Linux) or `defmt` (boards);
//!   without either, logging is off.
//! * `testkit`: [`testkit`], the virtual world of the tests, simulations
//!   and fuzz targets (host only).
//!
//! The default features are the Linux gateway's; the boards choose theirs.
// The gateway is one future of nested futures (engine, sessions, web
// connections, picoserve): computing its layout needs more depth than the
// default 128.
#![recursion_limit = "256"]
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]
#![cfg_attr(
    test,
    allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )
)]

#[cfg(any(test, feature = "testkit"))]
extern crate std;

#[macro_use]
mod fmt;

pub mod access;
pub(crate) mod admission;
#[cfg(feature = "audit")]
pub mod audit;
#[cfg(feature = "embassy-net")]
pub mod board;
pub mod clock;
pub mod config;
pub mod crc;
#[cfg(feature = "datasheet")]
pub(crate) mod datasheet;
pub(crate) mod engine;
#[cfg(feature = "enip")]
pub mod enip;
pub mod error;
mod gateway;
pub mod hex;
pub mod hub;
pub mod job;
pub mod limits;
pub(crate) mod link;
pub(crate) mod modbus;
#[cfg(feature = "mqtt")]
pub mod mqtt;
pub mod net;
pub(crate) mod plc;
pub mod registers;
#[cfg(any(test, feature = "sntp"))]
pub(crate) mod sntp;
pub mod state;
pub mod storage;
#[cfg(any(test, feature = "testkit"))]
pub mod testkit;
#[cfg(feature = "update")]
pub mod update;
#[cfg(feature = "web")]
pub(crate) mod web;

pub use access::accounts::{Account, AccountError, Accounts, Role, UserName, ACCOUNTS};
pub use access::password::PasswordHash;
pub use access::setup::{SetupCode, SETUP_CODE_LEN};
pub use clock::{Clock, SystemClock};
pub use config::Config;
/// The jog timing a PLC follows: the keep-alive period and the PLC
/// heartbeat a jog needs (REGISTERS.md, jogging).
pub use engine::jog::{HEARTBEAT as JOG_HEARTBEAT, KEEP_ALIVE as JOG_KEEP_ALIVE};
#[cfg(feature = "update")]
pub use gateway::TRIAL_CHECK;
pub use gateway::{needs, Storage};
pub use gateway::{run, run_until, Gateway, MqttOverride, Options, RobotOverride, Stopped};
pub use storage::{AuditStore, ConfigStore, Medium, NoStorage, StorageError, WithAudit};
#[cfg(feature = "update")]
pub use update::{NoSlots, SlotStore, WithSlots};
