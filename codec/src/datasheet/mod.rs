//! DataSheet service (chapter 5): packet header, deframer and JSON payload.
//!
//! A controller pushes its state on ports 10004, 10005 and 10006 at 20, 10
//! and 5 Hz, as a stream of packets: a 12-byte header (magic `LTBR`, total
//! length, payload length; see [`header`]) followed by a JSON payload (see
//! [`sheet`]). Ports 10014-10016 send a binary struct with no published
//! layout; this crate does not read them.
//!
//! | piece | what | type |
//! |---|---|---|
//! | [`header`] | the 12-byte header, zero-copy | [`Packet`], [`emit_header`] |
//! | [`deframer`] | TCP bytes → payloads | [`Deframer`] |
//! | [`json`] | the JSON tokenizer | [`json::Tokenizer`] |
//! | [`sheet`] | payload ↔ typed values | [`DataSheet`] |
//!
//! ## Example: read a DataSheet stream
//! ```
//! use hans_codec::datasheet::{DataSheet, Deframer};
//! use hans_codec::FsmState;
//!
//! // A controller side (the simulator) writes a packet...
//! let mut sheet = DataSheet::default();
//! sheet.state.robot_state = Some(FsmState::StandBy);
//! let mut wire = [0u8; 12 + DataSheet::MAX_JSON_LEN];
//! let n = sheet.write_packet(&mut wire).unwrap();
//!
//! // ...and a client feeds whatever its socket returns.
//! let mut deframer = Deframer::<4096>::new();
//! let mut latest = None;
//! for read in wire[..n].chunks(100) {
//!     deframer.feed(read, |item| match item {
//!         Ok(payload) => match DataSheet::parse(payload) {
//!             Ok(s) => latest = Some(s),
//!             Err(e) => { /* log `e`, keep the previous sheet */ }
//!         },
//!         Err(e) => { /* header rejected; the deframer resynchronises */ }
//!     });
//! }
//! assert_eq!(latest.unwrap().state.robot_state, Some(FsmState::StandBy));
//! ```

pub mod deframer;
pub mod header;
pub mod json;
mod names;
mod read;
mod scan;
pub mod sheet;

pub use deframer::Deframer;
pub use header::{emit_header, HeaderError, Packet, HEADER_LEN, MAGIC, MAX_PAYLOAD};
pub use sheet::{
    BoxAnalogIo, BoxIo, DataSheet, DataSheetError, EndIo, FieldExpected, FtData, HardLoad,
    PosAndVel, Position, Script, StateAndError,
};
