//! # hans-enip
//!
//! A `#![no_std]`, allocation-free, sans-IO EtherNet/IP adapter (target):
//! the bytes of the encapsulation protocol and CIP, the objects a scanner
//! reads (Identity, Message Router, Assembly, Connection Manager, TCP/IP
//! Interface, Ethernet Link), class 1 implicit I/O and class 3 connected
//! messaging, and an EDS file writer. It owns no socket and no clock: the
//! caller hands it TCP bytes, UDP datagrams and the time, and sends what it
//! returns. It never panics on input, never allocates and has no `unsafe`.
//!
//! ## Where things are
//! | module | what |
//! |---|---|
//! | [`wire`] | the byte formats, one file each (encapsulation, CPF, EPATH, Message Router, Connection Manager, class 1) |
//! | [`framer`] | encapsulation packets out of a TCP stream ([`Framer`]) |
//! | [`adapter`] | the state machine ([`Adapter`]): sessions, explicit messages, connections, watchdogs |
//! | [`app`] | what the adapter asks of its user ([`Application`]) and tells it ([`Event`]) |
//! | [`device`] | identity, interface values, assemblies and connection points ([`Device`]) |
//! | [`objects`] | the CIP objects |
//! | [`eds`] | the EDS writer |
//! | [`time`] | [`Instant`], microseconds from the caller's clock |
//!
//! ## Driving it
//! ```
//! use core::net::Ipv4Addr;
//! use hans_enip::wire::cip::GeneralStatus;
//! use hans_enip::*;
//!
//! static ASM: [Assembly; 2] = [
//!     Assembly { instance: 100, kind: AssemblyKind::Input, size: 4, name: "in" },
//!     Assembly { instance: 150, kind: AssemblyKind::Output, size: 4, name: "out" },
//! ];
//! static CONN: [IoConnection; 1] = [IoConnection {
//!     kind: ConnectionKind::ExclusiveOwner, o_to_t: 150, t_to_o: 100, config: 1, name: "Owner",
//! }];
//! static DEVICE: Device = Device { assemblies: &ASM, connections: &CONN };
//!
//! struct Robot { out: [u8; 4] }
//! impl Application for Robot {
//!     fn identity(&self) -> Identity<'_> {
//!         Identity { vendor_id: 0xFFFE, device_type: 0x0C, product_code: 1,
//!                    revision: Revision { major: 1, minor: 1 }, status: 0, serial: 7,
//!                    product_name: "Robot gateway" }
//!     }
//!     fn tcp_ip(&self) -> TcpIpInfo<'_> {
//!         let ip = Ipv4Addr::new(192, 168, 1, 50);
//!         TcpIpInfo { status: 1, config_capability: 0, config_control: 0, ip,
//!                     netmask: Ipv4Addr::new(255, 255, 255, 0), gateway: Ipv4Addr::UNSPECIFIED,
//!                     dns1: Ipv4Addr::UNSPECIFIED, dns2: Ipv4Addr::UNSPECIFIED,
//!                     domain: "", host_name: "robot" }
//!     }
//!     fn ethernet_link(&self) -> EthernetLinkInfo {
//!         EthernetLinkInfo { speed_mbps: 100, flags: 1, mac: [2, 0, 0, 0, 0, 1] }
//!     }
//!     fn read_assembly(&mut self, _instance: u16, buf: &mut [u8]) { buf.copy_from_slice(&self.out) }
//!     fn write_assembly(&mut self, _: u16, data: &[u8], _: WriteOrigin) -> Result<(), GeneralStatus> {
//!         self.out.copy_from_slice(data);
//!         Ok(())
//!     }
//!     fn event(&mut self, _event: Event) { /* a timed-out owner is a lost heartbeat */ }
//! }
//!
//! let mut adapter: Adapter<'_, 4, 4> = Adapter::new(&DEVICE, Config::default());
//! let mut robot = Robot { out: [0; 4] };
//! let mut framer = Framer::<600>::new(); // one per TCP connection
//! let (mut reply, now) = ([0u8; 600], Instant::from_millis(5));
//!
//! // RegisterSession, as it arrives on TCP port 44818 (in any pieces).
//! let bytes = [0x65, 0, 4, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 0, 0, 0, 0, 1, 0, 0, 0];
//! let mut rest = &bytes[..];
//! while !rest.is_empty() {
//!     rest = &rest[framer.push(rest)..];
//!     if let Some(frame) = framer.frame() {
//!         let peer = Ipv4Addr::new(192, 168, 1, 10);
//!         match adapter.handle_tcp(LinkId(0), peer, frame, now, &mut robot, &mut reply) {
//!             TcpAction::Reply(n) => assert_eq!(&reply[..2], &[0x65, 0]), // send reply[..n]
//!             TcpAction::Close => { /* close the socket, then adapter.tcp_closed(..) */ }
//!             TcpAction::None => {}
//!         }
//!     }
//! }
//! assert_eq!(adapter.session_count(), 1);
//! // UDP 2222 datagrams go to adapter.handle_io(from, datagram, now, &mut robot);
//! // at adapter.poll_at() (and after each input), send what poll returns:
//! while let Some((to, n)) = adapter.poll(now, &mut robot, &mut reply) {
//!     let _ = (to, &reply[..n]); // a T->O datagram for `to`
//! }
//! ```
//!
//! ## Features
//! * `defmt`: derives `defmt::Format` on public types and logs through defmt.
//!
//! MSRV: Rust 1.87.

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
