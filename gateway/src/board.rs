//! The entry point for boards (feature `embassy-net`).
//!
//! A board does three things: build its `embassy_net::Stack` (and spawn the
//! stack's runner), pick a [`Storage`] (flash, or [`NoStorage`] where there
//! is none), and run [`run`] from one task:
//!
//! ```text
//! #[embassy_executor::task]
//! async fn gateway(stack: embassy_net::Stack<'static>) -> ! {
//!     let storage = hans_gateway::NoStorage;
//!     let options = hans_gateway::Options::default(); // Modbus on port 502
//!     match hans_gateway::board::run(stack, storage, options).await {}
//! }
//! // in main: spawner.spawn(gateway(stack).unwrap());
//! ```
//!
//! Everything the gateway needs (sockets, buffers, queue, register map)
//! lives inside the future of [`run`] (the storage too: it is moved in), so
//! the task's static storage holds it:
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

use crate::clock::SystemClock;
use crate::gateway::{Options, MAX_SESSIONS};
use crate::net::embassy::EmbassyNet;
use crate::storage::Storage;

#[allow(unused_imports)]
use crate::storage::NoStorage;

/// TCP sockets the gateway uses: the Modbus sessions, two for the robot
/// link and one for the DataSheet.
pub const SOCKETS: usize = MAX_SESSIONS + 3;

/// Runs the gateway on the board's network stack until the future is
/// dropped (it never returns).
pub async fn run<S: Storage>(
    stack: embassy_net::Stack<'_>,
    storage: S,
    options: Options,
) -> Infallible {
    let net = EmbassyNet::new(stack);
    crate::gateway::run(&net, &SystemClock, storage, options).await
}
