//! Reads a Hans / Huayan robot's state from a board: an embassy-net TCP
//! client for the controller's command port (10003) that asks
//! `ReadRobotState` and `ReadActPos` and reads the replies with the codec's
//! [`Framer`] and [`Reply`].
//!
//! The network stack belongs to your board, so this example has none of
//! its own: it is built as a library (`crate-type = ["lib"]` in
//! `codec/Cargo.toml`), `#![no_std]`, and its functions take the socket you
//! made. It builds on a PC (CI does this) and for a microcontroller:
//!
//! ```sh
//! cargo build -p hans-codec --example robot_state
//! cargo build -p hans-codec --example robot_state --target thumbv7em-none-eabihf
//! ```
//!
//! # Wiring it on a board
//!
//! 1. Depend on `hans-codec`, `embassy-net` (features `proto-ipv4`, `tcp`,
//!    `medium-ethernet`), `embedded-io-async`, `embassy-time` and an
//!    executor (`embassy-executor`), and copy this file into your firmware.
//! 2. Start the stack with your board's Ethernet driver as embassy-net
//!    documents it: `let (stack, runner) = embassy_net::new(driver, config,
//!    resources, seed);`, spawn a task that runs `runner.run().await`, then
//!    `stack.wait_config_up().await`. Your HAL provides the driver and the
//!    embassy-time driver.
//! 3. In a task, give a socket its buffers and a timeout (without one, a
//!    controller that never answers blocks the read forever), connect and
//!    poll:
//!
//! ```ignore
//! let (mut rx, mut tx) = ([0u8; 1024], [0u8; 256]);
//! let mut socket = TcpSocket::new(stack, &mut rx, &mut tx);
//! socket.set_timeout(Some(embassy_time::Duration::from_secs(3)));
//! connect(&mut socket, Ipv4Address::new(192, 168, 0, 10)).await?;
//! let mut robot = Client::new(&mut socket);
//! loop {
//!     let state = robot.robot_state().await?; // state.moving, state.error_code, ...
//!     let pos = robot.act_pos().await?; // pos.joints, pos.pose: exact `Decimal`s
//!     embassy_time::Timer::after_millis(100).await;
//! }
//! ```
//!
//! The controller answers one request at a time on this port, so the client
//! sends one and reads until its reply has come.
#![no_std]

use embassy_net::tcp::{ConnectError, TcpSocket};
use embassy_net::{IpAddress, IpEndpoint, Ipv4Address};
use embedded_io_async::{Read, Write};
use hans_codec::{
    request, response, Command, EncodeError, ErrorCode, FrameError, Framer, Reply, Response,
    RobotId,
};

/// The controller's command port.
pub const PORT: u16 = 10003;

/// The longest message read: the replies asked for here carry at most 24
/// numbers (`ReadActPos`); a longer message ends in [`Error::Frame`].
const REPLY_MAX: usize = 512;

/// Connects `socket` to the controller at `robot`, port [`PORT`].
pub async fn connect(socket: &mut TcpSocket<'_>, robot: Ipv4Address) -> Result<(), ConnectError> {
    socket
        .connect(IpEndpoint::new(IpAddress::Ipv4(robot), PORT))
        .await
}

/// Why a request got no usable reply.
#[derive(Debug)]
pub enum Error<E> {
    /// The socket failed (or timed out, with a timeout set).
    Io(E),
    /// The controller closed the connection.
    Closed,
    /// The request did not fit the send buffer.
    Encode(EncodeError),
    /// The reply was too long or held bytes that are not printable ASCII.
    Frame(FrameError),
    /// The controller refused the request (`Name,Fail,code,;`).
    Fail(ErrorCode),
    /// The controller could not parse the request (`errorcmd`).
    ErrorCmd,
    /// The reply was not the one expected (wrong name, fields or count).
    BadReply,
}

/// A command-port client over any byte stream: an embassy-net
/// `&mut TcpSocket` (or anything else that is
/// `embedded_io_async::{Read, Write}`).
pub struct Client<S> {
    io: S,
    framer: Framer<REPLY_MAX>,
}

impl<S: Read + Write> Client<S> {
    /// A client on a connected stream.
    pub fn new(io: S) -> Self {
        Client {
            io,
            framer: Framer::new(),
        }
    }

    /// The robot's state flags: moving, enabled, error code, brakes, ...
    pub async fn robot_state(&mut self) -> Result<response::ReadRobotState, Error<S::Error>> {
        let req = request::ReadRobotState { rbt_id: RobotId(0) };
        self.ask(&req, |r| match r {
            Response::ReadRobotState(s) => Some(s),
            _ => None,
        })
        .await
    }

    /// The actual joints, pose, tool and user frame.
    pub async fn act_pos(&mut self) -> Result<response::ReadActPos, Error<S::Error>> {
        let req = request::ReadActPos { rbt_id: RobotId(0) };
        self.ask(&req, |r| match r {
            Response::ReadActPos(p) => Some(p),
            _ => None,
        })
        .await
    }

    /// Sends `req` and reads until its reply has come; `take` picks the
    /// typed values out of the success reply.
    async fn ask<'r, T>(
        &mut self,
        req: &impl Command<'r>,
        take: impl FnOnce(Response<'_>) -> Option<T>,
    ) -> Result<T, Error<S::Error>> {
        let mut out = [0u8; 64];
        let n = req.encode(&mut out).map_err(Error::Encode)?;
        let out = out.get(..n).unwrap_or_default();
        self.io.write_all(out).await.map_err(Error::Io)?;
        // A reply left half-read by an earlier failure is not this one's.
        self.framer.reset();
        let mut chunk = [0u8; 128];
        loop {
            let got = self.io.read(&mut chunk).await.map_err(Error::Io)?;
            let mut input = chunk.get(..got).unwrap_or_default();
            if input.is_empty() {
                return Err(Error::Closed);
            }
            while !input.is_empty() {
                let (used, item) = self.framer.push(input);
                input = input.get(used..).unwrap_or_default();
                let Some(message) = item else { continue };
                let message = message.map_err(Error::Frame)?;
                return match Reply::parse(message, req.expect()) {
                    Ok(Reply::Ok(response)) => take(response).ok_or(Error::BadReply),
                    Ok(Reply::Fail(failure)) => Err(Error::Fail(failure.code)),
                    Ok(Reply::ErrorCmd(_)) => Err(Error::ErrorCmd),
                    Err(_) => Err(Error::BadReply),
                };
            }
        }
    }
}
