//! # hans-gateway
//!
//! A gateway between a PLC (Modbus TCP server) and a Hans / Huayan Elfin
//! robot controller (its TCP command port): the PLC writes a few registers
//! and the robot moves, with Busy, Done and Error coming back the PLCopen
//! way. The register map for PLC programmers is `REGISTERS.md` beside this
//! crate's `Cargo.toml`.
//!
//! The logic is `no_std`, allocation-free and board-independent; it runs on
//! embassy (embassy-sync, embassy-time) over a small socket interface
//! (`net`) with two adapters: tokio on Linux (feature `std`, used by the
//! `hans-gateway` binary and the tests) and embassy-net on boards (feature
//! `embassy-net`, entry point [`board::run`]).
//!
//! ## Where things are
//! | module | what |
//! |---|---|
//! | [`state`] | the typed state: robot status, link, inputs, handshakes, queue, configuration |
//! | [`registers`] | the Modbus register map, a view of the state (`map`: addresses; `view`: encode / decode) |
//! | [`job`] | typed jobs: channel command codes, RAW and trigger texts, urgent commands, the queue |
//! | `plc` | what a PLC's register write means: edges into jobs, the heartbeat, `CONFIG_COMMAND` |
//! | `engine` | the rules in time: motion completion, watchdog, bring-up, status polls |
//! | `hub` | the shared state and the signals between the tasks |
//! | `link` | robot link: connect or listen, one request in flight, framing, reply timeout |
//! | `modbus` | Modbus TCP server: sessions, function codes, exceptions (framing by `modbus-core`) |
//! | `admission` | who a listener serves: slots, per-address caps, idle eviction, the newcomer's wait (the Modbus server's and the page's) |
//! | `datasheet` | the status from the DataSheet port (feature `datasheet`) |
//! | [`config`] | the configuration and the table of its settings (network and allow-lists included) |
//! | `access` | the web password (salted hash), web sessions, the rate limit of wrong passwords |
//! | `audit` | the audit log: who changed what, from where, when (feature `audit`) |
//! | [`storage`] | the stored image, the storage task, RAM and flash storage |
//! | `clock` | time: embassy-time on boards and Linux, a virtual clock in tests |
//! | `net` | the socket interface and its adapters; TLS servers on Linux (`net::tls`) |
//! | `web` | the web page and its JSON API (feature `web`) |
//! | [`board`] | the entry point for boards (feature `embassy-net`) |
//! | `sparkplug` | Sparkplug B edge node: topics, metrics, payloads, publishing rules (feature `sparkplug`) |
//! | [`testkit`] | a virtual world for tests: clock, network, robot, PLC (feature `testkit`) |
//!
//! ## Bounds
//! Every buffer and queue is fixed: 4 Modbus clients at once, 3 from one
//! address, on [`MAX_SESSIONS`] sockets (one spare, so that a newcomer can
//! take an idle session's slot),
//! [`job::QUEUE_DEPTH`] queued commands (more end in Error 39600)
//! plus [`job::URGENT_DEPTH`] urgent ones (one per source: never full),
//! RAW requests of 256 characters and replies of 512 (longer replies are
//! cut and flagged), robot replies up to `link::REPLY_MAX` (1 KiB) bytes (longer:
//! Error 39502), Modbus ADUs of 260 bytes, DataSheet packets up to
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
//! [`run`], and never moved through the stack; temporaries of kilobytes
//! live in functions that are not inlined (loading the stored
//! configuration) or are avoided (Modbus bit reads are packed straight from
//! the registers). The measured high-water marks are in the memory budget
//! of `firmware/README.md`.
//!
//! ## Features
//! * `std` (default): tokio adapter, `log` output, embassy-time's std driver.
//! * `datasheet` (default): `datasheet`, the status from the DataSheet
//!   port (CFG_STATUS_SOURCE = 1; without it that value is refused).
//! * `embassy-net`: the embassy-net adapter and [`board`].
//! * `dhcp`: the DHCP client on boards ([`board::run`] applies `NET_DHCP`).
//! * `defmt`: log through defmt.
//! * `flash`: [`storage::flash::FlashStorage`] (sequential-storage over a
//!   `NorFlash`).
//! * `audit` (with `web`): the audit log, `audit`, kept by the storage.
//! * `sntp`: the audit log's wall time on boards from an SNTP server
//!   (`sntp`, run by [`board::run`]).
//! * `tls-server` (default, Linux): the page over HTTPS and Modbus/TCP
//!   Security (TLS with client certificates, roles from them), behind the
//!   tokio adapter (`net::tls`).
//! * `sparkplug`: `sparkplug`, the Sparkplug B edge node's messages and
//!   publishing rules (no networking).
//! * `testkit`: [`testkit`], the virtual world of the tests, simulations
//!   and fuzz targets (needs `std`).
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
pub(crate) mod clock;
pub mod config;
pub mod crc;
#[cfg(feature = "datasheet")]
pub(crate) mod datasheet;
pub(crate) mod engine;
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
pub use gateway::{run, Gateway, MqttOverride, Options, RobotOverride};
pub use storage::{AuditStore, ConfigStore, Medium, NoStorage, StorageError, WithAudit};
#[cfg(feature = "update")]
pub use update::{NoSlots, SlotStore, WithSlots};
