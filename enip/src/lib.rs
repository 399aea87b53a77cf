//! # hans-enip
//!
//! A `#![no_std]`, allocation-free, sans-IO EtherNet/IP adapter (target):
//! the bytes of the encapsulation protocol and CIP, the objects a scanner
//! reads (Identity, Message Router, Assembly, Connection Manager, TCP/IP
//! Interface, Ethernet Link), class 1 implicit I/O and class 3 connected
//! messaging, and an EDS file writer. It owns no socket and no clock: the
//! caller hands it TCP bytes, UDP datagrams and the time, and sends what it
//! returns.
#![no_std]
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
    allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)
)]

#[macro_use]
mod macros;

pub mod adapter;
pub mod app;
pub mod device;
pub mod eds;
pub mod framer;
pub mod objects;
pub mod time;
pub mod wire;

pub use adapter::{Adapter, Config, ConnectionInfo, IoOutcome, LinkId, TcpAction};
pub use app::{Application, CloseReason, ConnectionId, Event, WriteOrigin};
pub use device::{
    Assembly, AssemblyKind, ConnectionKind, Device, EthernetLinkInfo, Identity, IoConnection,
    Revision, TcpIpInfo,
};
pub use framer::{Frame, Framer};
pub use time::Instant;
