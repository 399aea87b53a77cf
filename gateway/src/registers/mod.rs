//! The Modbus register map: one view of the gateway's state.
//!
//! * [`map`]: every address, its type and access, declared once
//!   (`REGISTERS.md` is checked against it).
//! * [`config`]: which settings of the schema have registers, where, and
//!   their word layouts.
//! * [`view`]: a read encodes registers from the typed state; a write
//!   decodes into it and returns typed events (Execute rose on a channel,
//!   a trigger bit rose, the heartbeat changed, a configuration command).

pub mod config;
pub mod map;
pub mod view;

pub use map::*;
pub use view::{read, write, Edge, PlcEvents, WriteError};
