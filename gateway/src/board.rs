//! The entry point for boards (feature `embassy-net`).
//!
//! A board does three things: build its `embassy_net::Stack` (and spawn the
//! stack's runner), pick a [`Storage`] (flash, or [`RamStorage`] where there
//! is none), and run [`run`] from one task:
//!
//! ```text
//! #[embassy_executor::task]
//! async fn gateway(stack: embassy_net::Stack<'static>) -> ! {
//!     static STORAGE: static_cell::StaticCell<hans_gateway::RamStorage> = static_cell::StaticCell::new();
//!     let storage = STORAGE.init(hans_gateway::RamStorage::new());
//!     let options = hans_gateway::Options::default(); // Modbus on port 502
//!     match hans_gateway::board::run(stack, storage, options).await {}
//! }
//! // in main: spawner.spawn(gateway(stack).unwrap());
//! ```
//!
//! Everything the gateway needs (sockets, buffers, queue, register map)
//! lives inside the future of [`run`], so the task's static storage holds it:
//! no other statics, no allocator. Its size is printed by
//! `core::mem::size_of_val` of the future if you need it; see the crate
//! docs for the RAM budget.
//!
//! The robot address and all other settings come from storage (written by
//! the PLC through the configuration registers) or from
//! [`Options::defaults`](crate::Options) when storage is empty. The stack
//! needs [`SOCKETS`] TCP sockets for the gateway (`StackResources<N>` with
//! `N` ≥ [`SOCKETS`] plus what the board uses itself).

use core::convert::Infallible;

use crate::config::Storage;
use crate::gateway::{Options, MAX_SESSIONS};
use crate::net::embassy::EmbassyNet;

#[allow(unused_imports)]
use crate::config::RamStorage;

/// TCP sockets the gateway uses: the Modbus sessions, two for the robot
/// link and one for the DataSheet.
pub const SOCKETS: usize = MAX_SESSIONS + 3;

/// Runs the gateway on the board's network stack until the future is
/// dropped (it never returns).
pub async fn run(
    stack: embassy_net::Stack<'_>,
    storage: &mut dyn Storage,
    options: Options,
) -> Infallible {
    let net = EmbassyNet::new(stack);
    crate::gateway::run(&net, storage, options).await
}
