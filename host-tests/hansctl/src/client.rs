//! A blocking client for the command port: one request in flight, replies
//! framed by the codec, every wait bounded by the timeout.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

use hans_codec::{
    Command, EncodeError, Framer, LevelError, ProtocolLevel, Reply, ReplyExpect, Request, Response,
};

/// Why a request did not get a reply.
#[derive(Debug)]
pub enum ClientError {
    /// Could not connect.
    Connect(String),
    /// No complete reply within the timeout.
    Timeout,
    /// The connection closed or failed.
    Io(String),
    /// The reply could not be read.
    BadReply(String),
    /// The robot refused: name, code, detail.
    Fail(String, hans_codec::ErrorCode, String),
    /// `errorcmd` reply.
    ErrorCmd(String),
    /// The command is not one the chosen protocol level has; nothing was
    /// sent.
    Level(LevelError),
}

impl std::fmt::Display for ClientError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ClientError::Connect(e) => write!(f, "cannot connect: {e}"),
            ClientError::Timeout => f.write_str("no reply within the timeout"),
            ClientError::Io(e) => write!(f, "connection lost: {e}"),
            ClientError::BadReply(e) => write!(f, "bad reply: {e}"),
            ClientError::Fail(name, code, detail) => {
                write!(f, "{name} refused: Fail {code}")?;
                if !detail.is_empty() {
                    write!(f, " ({detail})")?;
                }
                Ok(())
            }
            ClientError::ErrorCmd(r) => {
                write!(f, "the controller could not parse the request: {r}")
            }
            ClientError::Level(e) => write!(f, "{e}: not sent"),
        }
    }
}

/// One connection to the command port.
pub struct Client {
    stream: TcpStream,
    framer: Box<Framer<65536>>,
    timeout: Duration,
    /// The controller's protocol level, when the user gave one: typed
    /// requests are written for it (`encode_at`).
    level: Option<ProtocolLevel>,
}

/// `HOST[:PORT]` with `port` as the default.
pub fn resolve(robot: &str, port: u16) -> Result<SocketAddr, ClientError> {
    let with_port =
        if robot.contains(':') && !robot.starts_with('[') && robot.matches(':').count() == 1
            || robot.starts_with('[') && robot.contains("]:")
        {
            robot.to_string()
        } else {
            format!("{robot}:{port}")
        };
    with_port
        .to_socket_addrs()
        .map_err(|e| ClientError::Connect(format!("{robot}: {e}")))?
        .next()
        .ok_or_else(|| ClientError::Connect(format!("{robot}: no address")))
}

impl Client {
    /// Connects within `timeout`; typed requests are checked against
    /// `level`, when given, before they are sent.
    pub fn connect(
        addr: SocketAddr,
        timeout: Duration,
        level: Option<ProtocolLevel>,
    ) -> Result<Client, ClientError> {
        let stream = TcpStream::connect_timeout(&addr, timeout)
            .map_err(|e| ClientError::Connect(format!("{addr}: {e}")))?;
        let _ = stream.set_nodelay(true);
        Ok(Client {
            stream,
            framer: Box::default(),
            timeout,
            level,
        })
    }

    /// Sends raw message text and returns the reply text.
    pub fn call_raw(&mut self, msg: &str) -> Result<String, ClientError> {
        self.stream
            .write_all(msg.as_bytes())
            .map_err(|e| ClientError::Io(e.to_string()))?;
        self.read_reply()
    }

    fn read_reply(&mut self) -> Result<String, ClientError> {
        let deadline = Instant::now() + self.timeout;
        let mut buf = [0u8; 4096];
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(ClientError::Timeout);
            }
            self.stream
                .set_read_timeout(Some(left))
                .map_err(|e| ClientError::Io(e.to_string()))?;
            let n = match self.stream.read(&mut buf) {
                Ok(0) => return Err(ClientError::Io("closed by the controller".into())),
                Ok(n) => n,
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) =>
                {
                    return Err(ClientError::Timeout)
                }
                Err(e) => return Err(ClientError::Io(e.to_string())),
            };
            let mut input = buf.get(..n).unwrap_or(&[]);
            while !input.is_empty() {
                let (used, item) = self.framer.push(input);
                input = input.get(used..).unwrap_or(&[]);
                match item {
                    Some(Ok(m)) => return Ok(m.to_string()),
                    Some(Err(e)) => return Err(ClientError::BadReply(e.to_string())),
                    None => {}
                }
            }
        }
    }

    /// Sends a typed request and returns its successful reply text; a
    /// `Fail` or `errorcmd` reply is an error.
    pub fn call<'a, C: Command<'a>>(&mut self, cmd: &C) -> Result<String, ClientError> {
        let mut buf = vec![0u8; 8192];
        let written = match self.level {
            Some(level) => cmd.encode_at(level, &mut buf),
            None => cmd.encode(&mut buf),
        };
        let n = written.map_err(|e| match e {
            EncodeError::Unsupported(e) => ClientError::Level(e),
            e => ClientError::BadReply(format!("cannot encode: {e}")),
        })?;
        let msg = String::from_utf8_lossy(buf.get(..n).unwrap_or(&[])).into_owned();
        let reply = self.call_raw(&msg)?;
        check(&reply, cmd.expect())?;
        Ok(reply)
    }
}

/// `Ok(())` for an OK reply of the expected shape.
pub fn check(reply: &str, expect: ReplyExpect) -> Result<(), ClientError> {
    match Reply::parse(reply, expect) {
        Ok(Reply::Ok(_)) => Ok(()),
        Ok(Reply::Fail(f)) => Err(ClientError::Fail(
            f.name.to_string(),
            f.code,
            f.detail.to_string(),
        )),
        Ok(Reply::ErrorCmd(_)) => Err(ClientError::ErrorCmd(reply.to_string())),
        Err(e) => Err(ClientError::BadReply(format!("{reply}: {e}"))),
    }
}

/// The typed response of a reply already checked by [`check`].
pub fn response<'r>(reply: &'r str, expect: ReplyExpect) -> Option<Response<'r>> {
    match Reply::parse(reply, expect) {
        Ok(Reply::Ok(r)) => Some(r),
        _ => None,
    }
}

/// A request from text, for `send`.
pub fn typed(msg: &str) -> Result<Request<'_>, String> {
    Request::parse(msg).map_err(|e| e.to_string())
}
