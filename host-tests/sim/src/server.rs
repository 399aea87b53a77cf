//! The command port: listening, client mode, and the one-message-at-a-time
//! rule of the controller.
//!
//! # What the simulator does with the bytes of one connection
//! * Bytes are collected until a `;` ends a message (the codec's
//!   [`Framer`]). That message is answered. Whatever else arrived in the
//!   same read — further messages, or the start of one — is discarded, as
//!   the controller does ("it processes the first well-formed message and
//!   discards the rest"). A client must keep one request in flight.
//! * **Incomplete message**: bytes without a `;` followed by a quiet period
//!   ([`crate::Config::incomplete_timeout`], 200 ms by default) of no more
//!   bytes. They are answered `errorcmd,20007,;` and dropped. A request
//!   split across TCP segments that arrive closer together than that is
//!   read as one message.
//! * **Unparseable**: a message with non-printable bytes, longer than
//!   [`MAX_MESSAGE`] bytes, without a valid name, or empty (a `;` with
//!   nothing but whitespace before it, e.g. a lone `;`) is answered
//!   `errorcmd,20007,;`. Whitespace alone (a line end sent after a
//!   message) is not a message and gets no answer. A valid name with
//!   malformed fields gets `Name,Fail,20007,;`; an unknown name
//!   `Name,Fail,20005,;`.
//! * Each connection is served on its own task; the robot is shared, so
//!   commands from several connections interleave one at a time.

use std::collections::VecDeque;
use std::io;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use hans_codec::{CommandId, Framer, ParseError, RawMessage, Request};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpSocket, TcpStream};
use tokio::sync::{mpsc, watch};
use tokio::task::JoinSet;

use crate::clock::Clock;
use crate::faults::{Action, Faults};
use crate::robot::dispatch::{fail_text, Effect};
use crate::robot::{Initial, Robot};

/// Longest message accepted on the command port (bytes, `;` included).
/// Longer ones are answered `errorcmd,20007,;`.
pub const MAX_MESSAGE: usize = 64 * 1024;
/// Most command connections served at once (listening and client mode
/// together); further connections are accepted and closed at once.
pub const MAX_CONNECTIONS: usize = 64;

/// The reply to bytes that are not a message at all.
pub(crate) const ERRORCMD: &[u8] = b"errorcmd,20007,;";

/// `Fail,20005`: a command the controller does not know (or that this
/// port does not serve).
const UNKNOWN_COMMAND: i32 = 20005;

/// State shared by every task of one simulator.
pub(crate) struct Shared {
    pub robot: Mutex<Robot>,
    pub clock: Clock,
    pub faults: Faults,
    pub received: Mutex<VecDeque<String>>,
    pub received_capacity: usize,
    pub incomplete_timeout: Duration,
    pub reboot_time: Duration,
    /// Bumped to close every command connection.
    pub drop_gen: watch::Sender<u64>,
    pub shutdown: watch::Sender<bool>,
    pub refuse: mpsc::Sender<Duration>,
    pub connections: AtomicUsize,
    pub outgoing: Mutex<Option<tokio::task::AbortHandle>>,
}

impl Shared {
    pub fn robot(&self) -> std::sync::MutexGuard<'_, Robot> {
        self.robot.lock().unwrap_or_else(|e| e.into_inner())
    }

    pub fn now(&self) -> f64 {
        self.clock.now().as_secs_f64()
    }

    fn record(&self, msg: &str) {
        let mut g = self.received.lock().unwrap_or_else(|e| e.into_inner());
        if self.received_capacity == 0 {
            return;
        }
        if g.len() >= self.received_capacity {
            g.pop_front();
        }
        g.push_back(msg.to_string());
    }

    pub fn drop_connections(&self) {
        self.drop_gen.send_modify(|g| *g = g.wrapping_add(1));
        if let Some(h) = self
            .outgoing
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .take()
        {
            h.abort();
        }
    }

    /// `OSCmd,2`: connections drop, the port refuses for a while, and the
    /// robot comes back powered off.
    fn reboot(&self) {
        self.drop_connections();
        let _ = self.refuse.try_send(self.reboot_time);
        let mut robot = self.robot();
        let mut fresh = Robot::new(robot.timing, Initial::PoweredOff, robot.level);
        fresh.model = robot.model.clone();
        fresh.script_functions = robot.script_functions.clone();
        fresh.fast_port = robot.fast_port;
        *robot = fresh;
    }
}

/// Binds a listener with `SO_REUSEADDR`, so that a port given up by
/// [`accept_loop`] while refusing can be taken again.
pub(crate) fn bind(addr: SocketAddr) -> io::Result<TcpListener> {
    let socket = if addr.is_ipv4() {
        TcpSocket::new_v4()?
    } else {
        TcpSocket::new_v6()?
    };
    socket.set_reuseaddr(true)?;
    socket.bind(addr)?;
    socket.listen(1024)
}

/// Accepts command connections until shutdown; gives up the port while
/// asked to refuse connections.
pub(crate) async fn accept_loop(
    shared: Arc<Shared>,
    listener: TcpListener,
    mut refuse_rx: mpsc::Receiver<Duration>,
) {
    let addr = listener.local_addr().ok();
    let mut listener = Some(listener);
    let mut tasks = JoinSet::new();
    let mut shutdown = shared.shutdown.subscribe();
    loop {
        // Reap finished connection tasks so the set stays small.
        while tasks.try_join_next().is_some() {}
        tokio::select! {
            _ = shutdown.changed() => break,
            Some(d) = refuse_rx.recv() => {
                listener = None;
                tokio::select! {
                    _ = shutdown.changed() => break,
                    _ = tokio::time::sleep(d) => {}
                }
                // Take the port back; retry briefly if it is still busy.
                if let Some(a) = addr {
                    for _ in 0..50 {
                        match bind(a) {
                            Ok(l) => { listener = Some(l); break; }
                            Err(_) => tokio::time::sleep(Duration::from_millis(20)).await,
                        }
                    }
                }
                if listener.is_none() {
                    eprintln!("hans-sim: could not listen again on {addr:?}");
                    break;
                }
            }
            r = accept_opt(listener.as_ref()), if listener.is_some() => {
                if let Ok((stream, _)) = r {
                    if shared.connections.load(Ordering::SeqCst) >= MAX_CONNECTIONS {
                        drop(stream);
                        continue;
                    }
                    tasks.spawn(serve(shared.clone(), stream, Port::Command));
                }
            }
        }
    }
    tasks.shutdown().await;
}

async fn accept_opt(l: Option<&TcpListener>) -> io::Result<(TcpStream, SocketAddr)> {
    match l {
        Some(l) => l.accept().await,
        None => std::future::pending().await,
    }
}

/// Client mode: closes the previous outgoing connection, connects to
/// `addr` and serves the command protocol over it.
pub(crate) async fn connect_out(shared: &Arc<Shared>, addr: SocketAddr) -> io::Result<()> {
    if let Some(old) = shared
        .outgoing
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .take()
    {
        old.abort();
    }
    let stream = tokio::time::timeout(Duration::from_secs(5), TcpStream::connect(addr))
        .await
        .map_err(|_| io::Error::new(io::ErrorKind::TimedOut, "connect timed out"))??;
    let handle = tokio::spawn(serve(shared.clone(), stream, Port::Command));
    *shared.outgoing.lock().unwrap_or_else(|e| e.into_inner()) = Some(handle.abort_handle());
    Ok(())
}

struct ConnGuard<'a>(&'a AtomicUsize);

impl Drop for ConnGuard<'_> {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
    }
}

/// Which port a connection came in on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Port {
    /// The command port (10003): every command.
    Command,
    /// The fast command port (10001): the commands of [`FAST_COMMANDS`].
    Fast,
}

/// The commands the V6 document marks "can be sent on the fast command
/// port" (注：该命令可使用快速命令端口发送). The fast port answers any
/// other command `Fail,20005`, as one it does not serve (the document says
/// nothing of them).
pub const FAST_COMMANDS: &[CommandId] = &[
    CommandId::IsSimulation,
    CommandId::ReadControllerState,
    CommandId::GetErrorCodeStr,
    CommandId::ReadRobotModel,
    CommandId::PackageVersion,
    CommandId::ReadEI,
    CommandId::ReadEO,
    CommandId::ReadEAI,
    CommandId::ReadMaxPayload,
    CommandId::ReadPayload,
    CommandId::ReadOverride,
    CommandId::ReadJointMaxVel,
    CommandId::ReadJointMaxAcc,
    CommandId::ReadJointMaxJerk,
    CommandId::ReadLinearMaxVel,
    CommandId::ReadRobotState,
    CommandId::ReadCurWayPointID,
    CommandId::ReadAxisErrorCode,
    CommandId::ReadCurFSM,
    CommandId::ReadPointByName,
    CommandId::ReadMotorAndJointEncode,
    CommandId::ReadActPos,
    CommandId::ReadCmdPos,
    CommandId::ReadCmdJointVel,
    CommandId::ReadActJointVel,
    CommandId::ReadActTcpVel,
    CommandId::ReadCmdJointCur,
    CommandId::ReadActJointCur,
    CommandId::ReadTcpVelocity,
    CommandId::ReadTcpVel,
    CommandId::Quaternion2RPY,
    CommandId::RPY2Quaternion,
    CommandId::GetInverseKin,
    CommandId::GetForwardKin,
    CommandId::Base2UcsTcp,
    CommandId::UcsTcp2Base,
    CommandId::PoseSub,
    CommandId::PoseTrans,
    CommandId::PoseInverse,
    CommandId::PoseDist,
    CommandId::PoseInterpolate,
    CommandId::PoseDefdFrame,
    CommandId::GetInverseDynamics,
    CommandId::ReadCurTCP,
    CommandId::ReadCurUCS,
    CommandId::ReadTCPByName,
    CommandId::ReadUCSByName,
    CommandId::ReadPathState,
];

/// Accepts connections on the fast command port until shutdown.
pub(crate) async fn fast_accept_loop(shared: Arc<Shared>, listener: TcpListener) {
    let counter = shared.clone();
    let full = move |_: usize| counter.connections.load(Ordering::SeqCst) >= MAX_CONNECTIONS;
    let serving = shared.clone();
    serve_clients(&shared, listener, full, move |stream| {
        serve(serving.clone(), stream, Port::Fast)
    })
    .await;
}

/// Accepts clients on `listener` until shutdown and runs `serve` for each
/// (as a task, all stopped at shutdown). While `full(tasks running)` says
/// so, a new client is closed at once.
pub(crate) async fn serve_clients<F, Fut>(
    shared: &Shared,
    listener: TcpListener,
    full: impl Fn(usize) -> bool,
    mut serve: F,
) where
    F: FnMut(TcpStream) -> Fut,
    Fut: std::future::Future<Output = ()> + Send + 'static,
{
    let mut tasks = JoinSet::new();
    let mut shutdown = shared.shutdown.subscribe();
    loop {
        while tasks.try_join_next().is_some() {}
        tokio::select! {
            _ = shutdown.changed() => break,
            r = listener.accept() => {
                if let Ok((stream, _)) = r {
                    if full(tasks.len()) {
                        drop(stream);
                        continue;
                    }
                    tasks.spawn(serve(stream));
                }
            }
        }
    }
    tasks.shutdown().await;
}

/// Serves one command connection until it closes, is dropped or the
/// simulator stops.
pub(crate) async fn serve(shared: Arc<Shared>, mut stream: TcpStream, port: Port) {
    shared.connections.fetch_add(1, Ordering::SeqCst);
    let _guard = ConnGuard(&shared.connections);
    let _ = stream.set_nodelay(true);
    let mut framer: Box<Framer<MAX_MESSAGE>> = Box::default();
    let mut buf = vec![0u8; 64 * 1024];
    let mut drops = shared.drop_gen.subscribe();
    let mut shutdown = shared.shutdown.subscribe();
    loop {
        let pending = framer.pending() > 0;
        let quiet = shared.incomplete_timeout;
        let read = async {
            if pending {
                tokio::time::timeout(quiet, stream.read(&mut buf)).await
            } else {
                Ok(stream.read(&mut buf).await)
            }
        };
        // `None`: an incomplete message went quiet for `incomplete_timeout`.
        let got = tokio::select! {
            _ = drops.changed() => return,
            _ = shutdown.changed() => return,
            r = read => match r {
                Err(_elapsed) => None,
                Ok(Ok(0)) | Ok(Err(_)) => return,
                Ok(Ok(n)) => Some(n),
            },
        };
        // `None`: what arrived is not a message the controller can read, so
        // it answers `errorcmd` (below, the one place that writes it).
        let msg = match got {
            None => None,
            Some(n) => {
                let data = buf.get(..n).unwrap_or(&[]);
                if framer.pending() == 0 && starts_with_empty_message(data) {
                    // The framer skips empty messages; the controller answers
                    // one like any message it cannot read (and, as the first
                    // message of this read, discards the rest).
                    None
                } else {
                    match framer.push(data).1 {
                        None => continue,
                        Some(Ok(m)) => Some(m.to_string()),
                        Some(Err(_)) => None,
                    }
                }
            }
        };
        // One message per read: the rest of this read (or the quiet partial
        // message) is discarded.
        framer.reset();
        let keep = match msg {
            Some(m) => respond(&shared, &mut stream, &m, port).await,
            None => stream.write_all(ERRORCMD).await.is_ok(),
        };
        if !keep {
            return;
        }
    }
}

/// `true` when the first message of `data` (read between messages) is
/// empty: a `;` with only the grammar's whitespace before it (the framer
/// skips such messages; a controller answers them).
/// Whitespace alone is not a message (line ends a terminal sends after `;`).
fn starts_with_empty_message(data: &[u8]) -> bool {
    data.iter()
        .find(|&&b| !hans_codec::grammar::is_space(b))
        .is_some_and(|&b| b == b';')
}

/// Answers one message; `false` when the connection must close.
async fn respond(shared: &Arc<Shared>, stream: &mut TcpStream, msg: &str, port: Port) -> bool {
    shared.record(msg);
    let raw = RawMessage::parse(msg);
    let name = raw.map(|r| r.name()).unwrap_or("");
    let plan = shared.faults.plan_for(name);
    let mut effect = Effect::None;
    let known = CommandId::from_name(name);
    let level = shared.robot().level;
    let reply: Vec<u8> = if !plan.action.executes() {
        Vec::new()
    } else if port == Port::Fast && !known.is_some_and(|id| FAST_COMMANDS.contains(&id)) {
        fail_text(name, UNKNOWN_COMMAND, "")
    } else {
        match Request::parse(msg) {
            Ok(req) => {
                let now = shared.now();
                let (text, e) = shared.robot().handle(&req, name, now);
                effect = e;
                text
            }
            Err(ParseError::Grammar(_)) => ERRORCMD.to_vec(),
            // A name the controller's level does not have is unknown to it,
            // whatever its fields.
            Err(_) if known.is_some_and(|id| !id.available_at(level)) => {
                fail_text(name, UNKNOWN_COMMAND, "")
            }
            Err(_) => fail_text(name, 20007, ""),
        }
    };
    if !plan.delay.is_zero() {
        tokio::time::sleep(plan.delay).await;
    }
    let out: Option<Vec<u8>> = match plan.action {
        Action::Reply => Some(reply),
        Action::NoReply => None,
        Action::Drop => {
            if effect == Effect::Reboot {
                shared.reboot();
            }
            return false;
        }
        Action::Replace(g) => Some(g),
        Action::Prefix(mut g) => {
            g.extend_from_slice(&reply);
            Some(g)
        }
        Action::Fail(code, detail) => Some(fail_text(name, code, &detail)),
        Action::ErrorCmd => Some(ERRORCMD.to_vec()),
    };
    if let Some(bytes) = out {
        let ok = match plan.split {
            Some((chunk, pause)) => {
                let mut ok = true;
                for (i, part) in bytes.chunks(chunk).enumerate() {
                    if i > 0 {
                        tokio::time::sleep(pause).await;
                    }
                    if stream.write_all(part).await.is_err() || stream.flush().await.is_err() {
                        ok = false;
                        break;
                    }
                }
                ok
            }
            None => stream.write_all(&bytes).await.is_ok(),
        };
        if !ok {
            return false;
        }
    }
    if effect == Effect::Reboot {
        shared.reboot();
        return false;
    }
    true
}
