//! # hans-codec
//!
//! A `#![no_std]`, zero-allocation reader and writer for the TCP control
//! protocol of Hans / Huayan Elfin robots (HR-TCP V1.0.0.3): the
//! comma/semicolon command grammar of port 10003 with all 139 commands of
//! the document typed in both directions (and, with the `v6` feature, the
//! 74 that the V6 document V1.0.19.1 adds), which controller versions have
//! each command ([`ProtocolLevel`]), a streaming framer, failure replies and
//! named error codes, and the DataSheet packets of ports 10004-10006.
//!
//! It never panics on input, never allocates, and keeps numbers exact
//! ([`Decimal`]): text → value → text is byte-identical for every form a
//! controller sends.
//!
//! ## Where things are
//! | module | what |
//! |---|---|
//! | [`grammar`] | `Name,p1,...,;`, read leniently ([`RawMessage`]) |
//! | [`catalogue`] | the command table: [`request`], [`response`], [`Request`], [`Reply`] |
//! | [`framer`] | bytes from TCP → messages ([`Framer`]) |
//! | [`number`] | [`Decimal`] |
//! | [`types`] | parameter types: poses, lists, [`RobotId`], ranges |
//! | [`error`] | [`ParseError`], [`EncodeError`], [`RangeError`], [`ErrorCode`] |
//! | [`fsm`] | [`FsmState`] |
//! | [`datasheet`] | DataSheet header, deframer and JSON payload |
//! | [`level`] | protocol levels: which controller versions have which command |
//! | `path` | (feature `v6`) the path types of the V6 document |
//!
//! ## Example: send a way point, read the reply
//! ```
//! use hans_codec::{request, Command, Decimal, Framer, Reply, RobotId};
//!
//! let d = |s| Decimal::parse(s).unwrap();
//! let move_ = request::WayPoint {
//!     rbt_id: RobotId(0),
//!     pose: [d("420"), d("0"), d("445"), d("180"), d("0"), d("180")],
//!     joints: [d("0"), d("0"), d("90"), d("0"), d("90"), d("0")],
//!     tcp_name: "TCP",
//!     ucs_name: "Base",
//!     velocity: d("50"),
//!     acc: d("360"),
//!     move_type: 0,
//!     cmd_id: "1",
//!     ..Default::default()
//! };
//! let mut out = [0u8; 256];
//! let n = move_.encode(&mut out).unwrap();
//! assert_eq!(
//!     &out[..n],
//!     b"WayPoint,0,420,0,445,180,0,180,0,0,90,0,90,0,TCP,Base,50,360,0,0,0,0,0,0,1,;"
//! );
//! // ... write `&out[..n]` to the socket, then feed whatever comes back:
//! let mut framer = Framer::<512>::new();
//! for chunk in [&b"WayPoint,Fa"[..], b"il,20018,;"] {
//!     framer.feed(chunk, |msg| {
//!         let msg = msg.expect("framing error");
//!         match Reply::parse(msg, move_.expect()) {
//!             Ok(Reply::Ok(_)) => { /* accepted: poll ReadRobotState until it stops */ }
//!             Ok(Reply::Fail(f)) => assert_eq!(f.code.code(), 20018),
//!             Ok(Reply::ErrorCmd(_)) => { /* the controller could not parse it */ }
//!             Err(e) => panic!("bad reply: {e}"),
//!         }
//!     });
//! }
//! ```
//!
//! ## Protocol levels
//! Reading is lenient at every level: any known command parses. Writing can
//! be checked against the controller's version, so that a command it does
//! not have is a typed error before anything is sent:
//! ```
//! use hans_codec::{request, Command, EncodeError, LevelError, ProtocolLevel};
//!
//! let mut out = [0u8; 64];
//! let stop = request::GrpStop::default();
//! assert!(stop.encode_at(ProtocolLevel::V6, &mut out).is_ok());
//! let old = request::MoveJ::default(); // removed at HR5.50.3
//! assert!(matches!(
//!     old.encode_at(ProtocolLevel::parse("HR6.4.8").unwrap(), &mut out),
//!     Err(EncodeError::Unsupported(LevelError::Removed { .. }))
//! ));
//! assert!(old.encode_at(ProtocolLevel::V5, &mut out).is_ok());
//! ```
//!
//! ## Features
//! * `v6`: the V6 document's commands, and its forms of `ReadBoxAO` (mode
//!   and value per channel) and `SetPayload` (the update flag). Off by
//!   default: a build without it links none of them.
//! * `defmt`: derives `defmt::Format` on public types.
//!
//! Unknown command names are not errors: they pass through as
//! [`Request::Unknown`] / [`Response::Unknown`], so commands of newer
//! firmware keep working.
//!
//! ## On a board
//! The crate needs no allocator, no `std` and no critical section; every
//! buffer is the caller's ([`Framer`]`::<N>`, [`Deframer`]`::<N>`). The
//! crate's `examples/robot_state.rs` is a client for an embassy-net TCP
//! socket that reads `ReadRobotState` and `ReadActPos` from port 10003; its
//! doc comment says how to wire it on a board. MSRV: Rust 1.87.

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

pub mod catalogue;
pub mod datasheet;
pub mod error;
pub mod framer;
pub mod fsm;
pub mod grammar;
pub mod level;
pub mod number;
#[cfg(feature = "v6")]
pub mod path;
pub mod types;
pub mod writer;

pub use catalogue::{
    request, response, Command, CommandId, Failure, Reply, ReplyExpect, ReplyValues, Request,
    Response,
};
pub use datasheet::{DataSheet, Deframer};
pub use error::{EncodeError, ErrorCode, Expected, Got, ParseError, RangeError};
pub use framer::{FrameError, Framer};
pub use fsm::FsmState;
pub use grammar::{Kind, RawMessage};
pub use level::{LevelError, ProtocolLevel};
pub use number::Decimal;
pub use types::{
    CountedList, FreeText, Joints, PointList, Pose, Range, RobotId, TextList, ValueGroups, Visitor,
};

/// The README's examples, compiled and run as doc tests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
