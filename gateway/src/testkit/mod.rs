//! A virtual world for tests, simulations and fuzzing (feature `testkit`,
//! host only): the real gateway future on a simulated network
//! ([`net::SimNet`]), in virtual time ([`clock::VirtualClock`]), with a
//! robot controller that misbehaves on demand ([`robot::SimRobot`]) and
//! PLCs speaking Modbus TCP ([`plc::Plc`]), run by a deterministic executor
//! ([`world::World`]).
//!
//! ```
//! use hans_gateway::registers as r;
//! use hans_gateway::testkit::world::{World, WorldConfig};
//! use embassy_time::Duration;
//!
//! let mut w = World::new(WorldConfig::default());
//! w.run_for(Duration::from_secs(1)); // the gateway connects and polls
//! assert_eq!(w.reg(r::STATUS_LINK_STATE), 3);
//! w.set(r::channel_base(0), &[1, 6]); // Execute, code 6 (Stop)
//! w.run_for(Duration::from_millis(10));
//! assert_eq!(w.reg(r::channel_base(0) + r::CH_STATUS), r::ST_DONE);
//! ```

// A test harness: a panic is a failed test, with its reason.
#![allow(
    clippy::panic,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::indexing_slicing
)]

pub mod broker;
pub mod clock;
#[cfg(feature = "enip")]
pub mod enip;
#[cfg(feature = "update")]
pub mod flash;
pub mod net;
pub mod plc;
pub mod rng;
pub mod robot;
pub mod world;
