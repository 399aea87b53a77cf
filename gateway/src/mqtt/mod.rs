//! The MQTT 3.1.1 client of the Sparkplug edge node (feature `mqtt`).
//!
//! [`run`] keeps one connection to the broker over the gateway's socket
//! interface (`crate::net`: the same code on tokio and embassy-net) and
//! drives a [`EdgeNode`]: CONNECT with the node's NDEATH as the Will (QoS 1,
//! not retained), SUBSCRIBE to its NCMD and its device's DCMD, then the
//! births and the data [`EdgeNode::poll`] gives, published at QoS 0;
//! rebirth requests are answered through [`EdgeNode::command`] (every
//! write is refused: MQTT sees the robot, never moves it). PINGREQ keeps
//! the connection alive. Any failure (refused, reset, closed, silent, a
//! write that does not finish) closes the socket, ends the Sparkplug
//! session ([`EdgeNode::disconnect`]: the broker publishes the Will) and
//! connects again after a backoff of 1 s, doubling to 30 s, back to 1 s
//! after an accepted CONNECT.
//!
//! ## Why the packets are written here
//! The client needs eight packets (CONNECT with a Will, CONNACK, PUBLISH
//! QoS 0 out and in, SUBSCRIBE/SUBACK, PINGREQ/PINGRESP, DISCONNECT), about
//! 250 lines in `packet`. The crates were checked (2026-11):
//! `mqttrs` 0.4.1 (last release 2021) encodes without `std` but keeps
//! SUBSCRIBE's topics in heapless 0.5 vectors beside our 0.9;
//! `rust-mqtt` 0.6.0 and `minimq` are whole clients that own the
//! connection, the keep-alive and the timers over `embedded-io-async` /
//! `embedded-nal`: they would need an adapter of our `Socket` and would
//! take the reconnect and time rules (virtual time in the tests, the
//! bounded reads below) out of our hands. Writing the packets keeps one
//! code path, virtual-time testable, at a few hundred bytes of flash.
//!
//! ## Bounds and time
//! * The broker is an IPv4 address and a port ([`Settings::broker`]);
//!   resolving a host name (the `mqtt.broker` setting may be one) is not
//!   done here: the caller resolves it first.
//! * Buffers: [`PAYLOAD_BUF`] for one Sparkplug payload, [`RX_BUF`] for a
//!   received packet (longer ones, e.g. a large retained message on a
//!   command topic, are skipped and counted, the connection stays),
//!   [`PACKET_BUF`] for the packets' headers.
//!   With the socket's two buffers of [`SOCKET_BUF`] and the edge node,
//!   [`run`]'s future is 11.1 KiB (measured on the host, 2026-11).
//! * Every wait is bounded: the TCP connect and the CONNACK
//!   [`CONNECT_TIMEOUT`], each write [`WRITE_TIMEOUT`] (a broker that does
//!   not take the data ends the connection: what was not sent is dropped
//!   and counted, births follow the next connect), a PINGRESP one
//!   keep-alive.
//! * It never holds the engine: the state is read under the hub's lock
//!   only while one payload is encoded (`Hub::with`), and every wait is
//!   this task's own.

pub mod packet;
pub mod sparkplug;

#[cfg(test)]
mod tests;

use core::convert::Infallible;
use core::net::{Ipv4Addr, SocketAddrV4};

use embassy_futures::select::{select, Either};
use embassy_time::{Duration, Instant};

use crate::clock::{with_deadline, with_timeout, Clock};
use crate::config::MqttConfig;
use crate::hub::Hub;
use crate::mqtt::sparkplug::topic::ID_MAX;
use crate::mqtt::sparkplug::{EdgeNode, Id, IdError, MessageType, NodeConfig};
use crate::net::{Net, Socket};
pub use crate::state::telemetry::{Error, Stats, Status};

pub use crate::mqtt::sparkplug::PAYLOAD_BUF;
use packet::{Frame, Packet, Will};

/// The largest packet received whole (an NCMD/DCMD is a few dozen bytes).
pub const RX_BUF: usize = 1024;
/// The buffer of CONNECT, SUBSCRIBE and PUBLISH headers.
pub const PACKET_BUF: usize = 512;
/// The socket's own buffers (embassy-net), each.
pub const SOCKET_BUF: usize = 1024;
/// The TCP connect and the CONNACK must come within this.
pub const CONNECT_TIMEOUT: Duration = Duration::from_secs(10);
/// One packet must be written within this.
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(5);
/// The first wait before connecting again.
pub const BACKOFF_MIN: Duration = Duration::from_secs(1);
/// The longest wait before connecting again.
pub const BACKOFF_MAX: Duration = Duration::from_secs(30);
/// The longest the client waits without looking at the state.
pub const IDLE_LOOK: Duration = Duration::from_secs(1);
/// The SUBSCRIBE's packet id.
const SUBSCRIBE_ID: u16 = 1;

/// The client's settings.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// The broker (an address: names are resolved by the caller).
    pub broker: SocketAddrV4,
    /// The Sparkplug node (its edge id is also the MQTT client id).
    pub node: NodeConfig,
    /// The keep-alive told to the broker (whole seconds, 1 to 65535): a
    /// silent gateway is dead after 1.5 times it.
    pub keep_alive: Duration,
    /// The wall time at `Instant` 0 (ms since 1970 UTC), for the
    /// payloads' timestamps; without it they count from the start
    /// ([`EdgeNode::set_wall_time`]); the Linux platform sets it from the
    /// host's clock.
    pub utc_at_zero: Option<u64>,
    /// A Sparkplug 3.0 primary host: the births wait for its STATE online
    /// message (`spBv1.0/STATE/ID`, JSON `{"online":true,...}`), and its
    /// offline message ends the session (the broker publishes the NDEATH);
    /// the next one waits again.
    pub primary_host: Option<Id>,
    /// TLS to the broker, whose certificate must name this (its host name
    /// or address as configured); `None`: plain TCP.
    pub tls: Option<crate::config::HostName>,
    /// The user name and password the broker asks for; `None`: anonymous.
    pub login: Option<Login>,
}

/// A user name and password for the broker (CONNECT). Fixed size, so that
/// the gateway's start options stay `Copy`; the password is never shown
/// (`Debug` hides it), never stored in the configuration and never
/// served: Linux reads it from a file at start.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct Login {
    /// The user name.
    pub user: crate::config::HostName,
    password: [u8; Login::PASSWORD_MAX],
    password_len: u8,
}

impl Login {
    /// The longest password.
    pub const PASSWORD_MAX: usize = 64;

    /// `user` with `password` (printable ASCII, 1 to
    /// [`Login::PASSWORD_MAX`] bytes); `None` if the password is not.
    pub fn new(user: crate::config::HostName, password: &[u8]) -> Option<Login> {
        if password.is_empty() || !password.iter().all(|b| (0x20..0x7f).contains(b)) {
            return None;
        }
        let mut l = Login {
            user,
            password: [0; Login::PASSWORD_MAX],
            password_len: u8::try_from(password.len()).ok()?,
        };
        l.password
            .get_mut(..password.len())?
            .copy_from_slice(password);
        Some(l)
    }

    /// The password's bytes.
    fn password(&self) -> &[u8] {
        self.password
            .get(..usize::from(self.password_len))
            .unwrap_or(&[])
    }
}

impl core::fmt::Debug for Login {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "Login {{ user: {:?}, password: <{} bytes> }}",
            self.user, self.password_len
        )
    }
}

impl Settings {
    /// Node `node` to `broker`, keep-alive 30 s.
    pub fn new(broker: SocketAddrV4, node: NodeConfig) -> Settings {
        Settings {
            broker,
            node,
            keep_alive: Duration::from_secs(30),
            utc_at_zero: None,
            primary_host: None,
            tls: None,
            login: None,
        }
    }

    /// The settings of `cfg` (the configuration's `mqtt.*`) with the broker
    /// at `broker`; `own_id` is the edge node id when the configuration
    /// names none.
    pub fn from_config(
        cfg: &MqttConfig,
        broker: Ipv4Addr,
        own_id: &str,
    ) -> Result<Settings, IdError> {
        let edge = if cfg.edge.as_str().is_empty() {
            own_id
        } else {
            cfg.edge.as_str()
        };
        let mut node = NodeConfig::new(cfg.group.as_str(), edge)?;
        node.period = Duration::from_millis(cfg.period_ms.into());
        node.joint_deadband = f32::from(cfg.joint_deadband) / 100.0;
        node.pose_deadband = f32::from(cfg.pose_deadband) / 100.0;
        let mut s = Settings::new(SocketAddrV4::new(broker, cfg.port), node);
        s.keep_alive = Duration::from_secs(cfg.keep_alive_s.into());
        s.tls = cfg.tls.then_some(cfg.broker);
        s.primary_host = match cfg.primary_host.as_str() {
            "" => None,
            id => Some(Id::new(id)?),
        };
        Ok(s)
    }

    /// The primary host's STATE topic.
    fn state_topic(&self) -> Option<heapless::String<{ STATE_PREFIX.len() + ID_MAX }>> {
        let id = self.primary_host.as_ref()?;
        let mut t = heapless::String::new();
        t.push_str(STATE_PREFIX).ok()?;
        t.push_str(id.as_str()).ok()?;
        Some(t)
    }
}

/// The primary hosts' STATE topics begin with this.
const STATE_PREFIX: &str = "spBv1.0/STATE/";

/// What a primary host's STATE payload says: `Some(true)` online, `Some(false)` offline,
/// `None` not a STATE message (Sparkplug 3.0: a JSON object with a boolean
/// `online` and a `timestamp`; read here without a JSON parser: the
/// member's name, a colon, the word).
pub fn host_online_of(payload: &[u8]) -> Option<bool> {
    let key = b"\"online\"";
    let at = payload.windows(key.len()).position(|w| w == key)?;
    let rest = payload.get(at + key.len()..)?;
    let rest = rest.get(rest.iter().position(|b| !b.is_ascii_whitespace())?..)?;
    let rest = rest.strip_prefix(b":")?;
    let rest = rest.get(rest.iter().position(|b| !b.is_ascii_whitespace())?..)?;
    if rest.starts_with(b"true") {
        Some(true)
    } else if rest.starts_with(b"false") {
        Some(false)
    } else {
        None
    }
}

impl From<packet::TooLong> for Error {
    fn from(_: packet::TooLong) -> Error {
        Error::TooLong
    }
}

/// The buffers of one client.
struct Buffers {
    /// A Sparkplug payload (and the Will).
    pay: [u8; PAYLOAD_BUF],
    /// Packet headers, CONNECT, SUBSCRIBE.
    pkt: [u8; PACKET_BUF],
}

/// Received bytes, framed into packets.
struct Reader {
    buf: [u8; RX_BUF],
    len: usize,
    /// Bytes of a too-long packet still to throw away.
    skip: usize,
}

impl Reader {
    fn new() -> Reader {
        Reader {
            buf: [0; RX_BUF],
            len: 0,
            skip: 0,
        }
    }

    /// The length of the whole packet at the start of the buffer, if one
    /// is there (packets longer than the buffer are skipped).
    fn ready(&mut self, status: &Status) -> Result<Option<usize>, Error> {
        loop {
            if self.skip > 0 {
                let k = self.skip.min(self.len);
                self.consume(k);
                self.skip -= k;
                if self.skip > 0 {
                    return Ok(None);
                }
            }
            match packet::frame(self.buf.get(..self.len).unwrap_or(&[]), RX_BUF) {
                Frame::Incomplete => return Ok(None),
                Frame::Whole { len } => return Ok(Some(len)),
                Frame::TooLong { len } => {
                    status.update(|s| s.skipped = s.skipped.wrapping_add(1));
                    self.skip = len;
                }
                Frame::Malformed => return Err(Error::Protocol),
            }
        }
    }

    /// The packet of `len` bytes at the start.
    fn packet(&self, len: usize) -> Result<Packet<'_>, Error> {
        self.buf
            .get(..len)
            .and_then(packet::parse)
            .ok_or(Error::Protocol)
    }

    fn consume(&mut self, n: usize) {
        let n = n.min(self.len);
        self.buf.copy_within(n..self.len, 0);
        self.len -= n;
    }

    /// Reads what the socket has (waits for at least one byte).
    async fn fill<S: Socket>(&mut self, sock: &mut S) -> Result<(), Error> {
        let room = self.buf.get_mut(self.len..).unwrap_or(&mut []);
        if room.is_empty() {
            // Cannot happen: a full buffer holds a whole or a too-long packet.
            return Err(Error::TooLong);
        }
        let n = sock.read(room).await?;
        if n == 0 {
            return Err(Error::Closed);
        }
        self.len += n;
        Ok(())
    }
}

/// Writes `bytes` within [`WRITE_TIMEOUT`].
async fn send<C: Clock, S: Socket>(clock: &C, sock: &mut S, bytes: &[u8]) -> Result<(), Error> {
    match with_timeout(clock, WRITE_TIMEOUT, sock.write_all(bytes)).await {
        Ok(r) => Ok(r?),
        Err(_) => Err(Error::Timeout),
    }
}

/// Keeps the edge node `settings.node` connected to the broker, for ever
/// (see the module documentation). `status` shows how it goes.
pub async fn run<C: Clock, N: Net>(
    hub: &Hub,
    clock: &C,
    net: &N,
    settings: &Settings,
    status: &Status,
) -> Infallible {
    let mut rx = [0u8; SOCKET_BUF];
    let mut tx = [0u8; SOCKET_BUF];
    let mut sock = net.socket(&mut rx, &mut tx);
    status.update(|s| s.on = true);
    let mut node = EdgeNode::new(settings.node.clone());
    if let Some(utc) = settings.utc_at_zero {
        node.set_wall_time(Instant::from_ticks(0), utc);
    }
    let mut bufs = Buffers {
        pay: [0; PAYLOAD_BUF],
        pkt: [0; PACKET_BUF],
    };
    let mut reader = Reader::new();
    let mut backoff = BACKOFF_MIN;
    loop {
        reader.len = 0;
        reader.skip = 0;
        let Err(e) = session(
            hub,
            clock,
            &mut sock,
            &mut node,
            settings,
            status,
            &mut bufs,
            &mut reader,
            &mut backoff,
        )
        .await;
        let _ = with_timeout(clock, WRITE_TIMEOUT, sock.close()).await;
        node.disconnect();
        status.update(|s| {
            s.connected = false;
            s.waiting_for_host = false;
            s.failures = s.failures.wrapping_add(1);
            s.last_error = Some(e);
            s.node = node.stats();
        });
        warn!(
            "mqtt: {}; connecting again in {} ms",
            e.as_str(),
            backoff.as_millis()
        );
        clock.sleep(backoff).await;
        backoff = (backoff * 2).min(BACKOFF_MAX);
    }
}

/// One connection, until it fails.
#[allow(clippy::too_many_arguments)]
async fn session<C: Clock, S: Socket>(
    hub: &Hub,
    clock: &C,
    sock: &mut S,
    node: &mut EdgeNode,
    settings: &Settings,
    status: &Status,
    bufs: &mut Buffers,
    reader: &mut Reader,
    backoff: &mut Duration,
) -> Result<Infallible, Error> {
    let start = clock.now();
    let connected = match &settings.tls {
        Some(name) => {
            with_deadline(
                clock,
                start + CONNECT_TIMEOUT,
                sock.connect_tls(settings.broker, name.as_str()),
            )
            .await
        }
        None => {
            with_deadline(
                clock,
                start + CONNECT_TIMEOUT,
                sock.connect(settings.broker),
            )
            .await
        }
    };
    match connected {
        Ok(r) => r?,
        Err(_) => return Err(Error::Timeout),
    }
    let keep_alive_s = u16::try_from(settings.keep_alive.as_secs().max(1)).unwrap_or(u16::MAX);
    let keep_alive = Duration::from_secs(keep_alive_s.into());
    let will = node
        .connect(clock.now(), &mut bufs.pay)
        .map_err(|_| Error::TooLong)?;
    let n = packet::connect(
        &mut bufs.pkt,
        settings.node.edge.as_str(),
        keep_alive_s,
        Some(Will {
            topic: will.topic.as_str(),
            payload: will.payload,
            qos: MessageType::NDeath.qos(),
        }),
        settings
            .login
            .as_ref()
            .map(|l| (l.user.as_str(), l.password())),
    )?;
    send(clock, sock, bufs.pkt.get(..n).unwrap_or(&[])).await?;
    // CONNACK first.
    let connack_by = start + CONNECT_TIMEOUT;
    let len = loop {
        if let Some(len) = reader.ready(status)? {
            break len;
        }
        match with_deadline(clock, connack_by, reader.fill(sock)).await {
            Ok(r) => r?,
            Err(_) => return Err(Error::Timeout),
        }
    };
    match reader.packet(len)? {
        Packet::ConnAck { code: 0 } => {}
        Packet::ConnAck { code } => return Err(Error::Refused(code)),
        _ => return Err(Error::Protocol),
    }
    reader.consume(len);
    *backoff = BACKOFF_MIN;
    status.update(|s| {
        s.connected = true;
        s.connects = s.connects.wrapping_add(1);
    });
    info!("mqtt: connected, bdSeq {}", node.bd_seq());
    let ncmd = node.topic(MessageType::NCmd);
    let dcmd = node.topic(MessageType::DCmd);
    let state = settings.state_topic();
    let n = match &state {
        Some(st) => packet::subscribe(
            &mut bufs.pkt,
            SUBSCRIBE_ID,
            &[ncmd.as_str(), dcmd.as_str(), st.as_str()],
        )?,
        None => packet::subscribe(&mut bufs.pkt, SUBSCRIBE_ID, &[ncmd.as_str(), dcmd.as_str()])?,
    };
    send(clock, sock, bufs.pkt.get(..n).unwrap_or(&[])).await?;
    // With a primary host, nothing is published until it is online.
    let mut host_online = state.is_none();
    status.update(|s| s.waiting_for_host = !host_online);
    let mut last_sent = clock.now();
    let mut ping_sent: Option<Instant> = None;
    loop {
        if host_online {
            publish_due(hub, clock, sock, node, status, bufs, &mut last_sent).await?;
        }
        let mut commanded = false;
        while let Some(len) = reader.ready(status)? {
            match reader.packet(len)? {
                Packet::Publish {
                    topic,
                    qos,
                    id,
                    payload,
                } => {
                    if let Some(id) = id.filter(|_| qos == 1) {
                        send(clock, sock, &packet::puback(id)).await?;
                        last_sent = clock.now();
                    }
                    if state.as_ref().is_some_and(|st| st.as_str() == topic) {
                        match host_online_of(payload) {
                            Some(true) if !host_online => {
                                info!("mqtt: the primary host is online: births");
                                host_online = true;
                                commanded = true;
                                status.update(|s| s.waiting_for_host = false);
                            }
                            Some(false) => return Err(Error::HostOffline),
                            _ => {}
                        }
                    } else if let Some(ty) = node.inbound(topic) {
                        // Malformed and refused commands are counted by the node.
                        let _ = node.command(ty, payload);
                        commanded = true;
                    }
                }
                Packet::PingResp => ping_sent = None,
                Packet::SubAck { granted, .. } => {
                    if !granted {
                        warn!("mqtt: the broker refused the command subscription");
                    }
                }
                Packet::ConnAck { .. } => return Err(Error::Protocol),
                Packet::Other(_) => {}
            }
            reader.consume(len);
        }
        // Births or a rebirth may be due at once after a command (or the
        // host's STATE); other packets change nothing to publish.
        if host_online && commanded {
            publish_due(hub, clock, sock, node, status, bufs, &mut last_sent).await?;
        }
        let now = clock.now();
        if let Some(t) = ping_sent {
            if now >= t + keep_alive {
                return Err(Error::Timeout);
            }
        } else if now >= last_sent + keep_alive / 2 {
            send(clock, sock, &packet::PINGREQ).await?;
            last_sent = now;
            ping_sent = Some(now);
        }
        let ping_at = match ping_sent {
            Some(t) => t + keep_alive,
            None => last_sent + keep_alive / 2,
        };
        // Woken by the broker, by a change of the state (then no earlier
        // than the node's next round: at most one round per period), or
        // at the latest after IDLE_LOOK (the uptime, a change without a
        // `Hub::with`) or for the keep-alive.
        let round_at = node.next_round();
        let change = async {
            hub.changed.wait().await;
            clock.sleep_until(round_at).await;
        };
        let look_at = ping_at.min(now + IDLE_LOOK);
        match with_deadline(clock, look_at, select(reader.fill(sock), change)).await {
            Ok(Either::First(r)) => r?,
            Ok(Either::Second(())) | Err(_) => {}
        }
    }
}

/// Publishes every message the node has now.
async fn publish_due<C: Clock, S: Socket>(
    hub: &Hub,
    clock: &C,
    sock: &mut S,
    node: &mut EdgeNode,
    status: &Status,
    bufs: &mut Buffers,
    last_sent: &mut Instant,
) -> Result<(), Error> {
    loop {
        let now = clock.now();
        let (n, pay) = (&mut *node, &mut bufs.pay);
        let msg = match hub.peek(move |m| n.poll(now, m, pay)) {
            Ok(Some(msg)) => msg,
            Ok(None) => break,
            Err(_) => {
                // Cannot happen with PAYLOAD_BUF; retried at the next poll.
                status.update(|s| s.dropped = s.dropped.wrapping_add(1));
                break;
            }
        };
        let h = packet::publish_head(&mut bufs.pkt, msg.topic.as_str(), msg.payload.len())?;
        let sent = match send(clock, sock, bufs.pkt.get(..h).unwrap_or(&[])).await {
            Ok(()) => send(clock, sock, msg.payload).await,
            Err(e) => Err(e),
        };
        if let Err(e) = sent {
            status.update(|s| s.dropped = s.dropped.wrapping_add(1));
            return Err(e);
        }
        *last_sent = clock.now();
        status.update(|s| s.sent = s.sent.wrapping_add(1));
    }
    status.update(|s| s.node = node.stats());
    Ok(())
}

/// The telemetry as the configuration in use says (`mqtt.*`, read once:
/// the settings apply at the next start): nothing while `mqtt.enabled` is
/// off or no broker is named; else the broker's address (an address, or a
/// name the platform resolves: `Net::resolve`, tried again with the
/// backoff), then [`run`]. `own_id` is the edge node id when the
/// configuration names none; `version` is the software's
/// ([`NodeConfig::version`]); `utc_at_zero` and `login` as in
/// [`Settings`]. The hub's `mqtt` status shows how it goes.
pub async fn serve<C: Clock, N: Net>(
    hub: &Hub,
    clock: &C,
    net: &N,
    own_id: &str,
    version: &'static str,
    utc_at_zero: Option<u64>,
    login: Option<Login>,
) -> Infallible {
    let cfg = hub.with(|m| m.config.active.mqtt);
    let status = &hub.mqtt;
    if !cfg.enabled || cfg.broker.as_str().is_empty() {
        return core::future::pending().await;
    }
    status.update(|s| s.on = true);
    let mut backoff = BACKOFF_MIN;
    let broker = loop {
        let name = cfg.broker.as_str();
        let ip = match name.parse::<Ipv4Addr>() {
            Ok(ip) => Some(ip),
            Err(_) => net.resolve(name).await,
        };
        if let Some(ip) = ip {
            break ip;
        }
        status.update(|s| {
            s.failures = s.failures.wrapping_add(1);
            s.last_error = Some(Error::Unresolved);
        });
        warn!(
            "mqtt: the broker's name has no address here; again in {} ms",
            backoff.as_millis()
        );
        clock.sleep(backoff).await;
        backoff = (backoff * 2).min(BACKOFF_MAX);
    };
    let mut settings = match Settings::from_config(&cfg, broker, own_id) {
        Ok(s) => s,
        Err(_) => {
            status.update(|s| s.last_error = Some(Error::BadId));
            warn!("mqtt: {}", Error::BadId.as_str());
            return core::future::pending().await;
        }
    };
    settings.node.version = version;
    settings.utc_at_zero = utc_at_zero;
    settings.login = login;
    info!(
        "mqtt: Sparkplug edge node {} of group {} to the broker",
        settings.node.edge.as_str(),
        settings.node.group.as_str()
    );
    run(hub, clock, net, &settings, status).await
}
