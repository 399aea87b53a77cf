//! `hansctl fleet` on a broker: subscribe, feed the table, show it.
//!
//! Output, decided here:
//! - `--json`: one line per message, at once (the table is still kept, for
//!   the aliases and the `bdSeq` rule).
//! - stdout a terminal: the table redrawn in place (cursor home, each line
//!   cleared to its end, the rest of the screen cleared), when something
//!   changed but at most 4 times a second, and every second for the ages.
//! - stdout not a terminal (a pipe, a file): the table printed as a block
//!   (a status line, the table, a blank line) at most once a second when
//!   something changed (a message came, the connection came or went) since
//!   the last block, and always once at the end. The last block is the
//!   final state.
//!
//! The end: `--for` elapsed or Ctrl-C (SIGINT), exit status 0. The first
//! connection and subscription must succeed within `--timeout` (and before
//! `--for` ends), else exit status 3; later losses are reported on stderr
//! and the client reconnects (and subscribes again) by itself.

use std::io::{IsTerminal, Write};
use std::time::{Duration, Instant};

use rumqttc::{AsyncClient, ConnectionError, Event, MqttOptions, Packet, QoS, SubscribeReasonCode};
use tokio::sync::mpsc;

use super::{Fleet, Status};
use crate::sparkplug::{Topic, WireMetric, WirePayload, WireValue, NAMESPACE};
use crate::Exit;

/// The largest message read: a gateway's NBIRTH is a few KiB, other nodes'
/// may be larger. rumqttc drops the connection on a larger one.
const MAX_PACKET: usize = 1 << 20;
/// How often the screen may be redrawn.
const FRAME: Duration = Duration::from_millis(250);
/// Pause between connection attempts.
const RETRY: Duration = Duration::from_millis(500);

/// What `hansctl fleet` was asked.
#[derive(Debug)]
pub(crate) struct Options {
    pub(crate) broker: String,
    pub(crate) group: Option<String>,
    pub(crate) json: bool,
    pub(crate) duration: Option<Duration>,
    pub(crate) client_id: Option<String>,
    /// Bound on the first connection and subscription.
    pub(crate) timeout: Duration,
    /// Ask a node seen without its birth for one (an NCMD
    /// `Node Control/Rebirth`), as a Sparkplug host application does.
    pub(crate) rebirth: bool,
}

/// `HOST:PORT`, `HOST` (port 1883), `[V6]:PORT`.
pub(crate) fn parse_broker(s: &str) -> Result<(String, u16), String> {
    let bad = || format!("{s:?}: expected HOST:PORT, e.g. 127.0.0.1:1883");
    let (host, port) = if let Some(rest) = s.strip_prefix('[') {
        let (host, after) = rest.split_once(']').ok_or_else(bad)?;
        match after {
            "" => (host, None),
            _ => (host, Some(after.strip_prefix(':').ok_or_else(bad)?)),
        }
    } else {
        // Several ':' without brackets: an IPv6 address, default port.
        match s.split_once(':') {
            Some((h, p)) if !p.contains(':') => (h, Some(p)),
            _ => (s, None),
        }
    };
    let port = match port {
        None => 1883,
        Some(p) => p.parse::<u16>().ok().filter(|p| *p != 0).ok_or_else(bad)?,
    };
    if host.is_empty() {
        return Err(bad());
    }
    Ok((host.to_string(), port))
}

/// A Sparkplug group id: 1 or more bytes, no `/`, `+`, `#`.
pub(crate) fn check_group(g: &str) -> Result<(), String> {
    if g.is_empty() || g.contains(['/', '+', '#']) {
        return Err(format!(
            "--group {g:?}: a group id is not empty and has no '/', '+' or '#'"
        ));
    }
    Ok(())
}

pub(crate) fn run(o: &Options) -> Result<(), Exit> {
    let (host, port) = parse_broker(&o.broker).map_err(|e| Exit(2, e))?;
    if let Some(g) = &o.group {
        check_group(g).map_err(|e| Exit(2, e))?;
    }
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| Exit(3, format!("cannot start the runtime: {e}")))?;
    rt.block_on(watch(o, host, port))
}

/// Where the table goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    Json,
    Terminal,
    Blocks,
}

/// The connection, as the status line says it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Link {
    Connecting,
    Subscribed,
    Lost,
}

struct Screen {
    mode: Mode,
    start: Instant,
    broker: String,
    filter: String,
    link: Link,
    losses: u32,
    last_draw: Option<Instant>,
    changed: bool,
}

impl Screen {
    fn status(&self, fleet: &Fleet, now: Instant) -> String {
        let (alive, dead, unborn) = fleet.counts();
        let link = match self.link {
            Link::Connecting => "connecting".to_string(),
            Link::Subscribed if self.losses == 0 => "subscribed".to_string(),
            Link::Subscribed => format!("subscribed; connections lost: {}", self.losses),
            Link::Lost => "connection lost, reconnecting".to_string(),
        };
        format!(
            "hansctl fleet: {} at {} ({link}), {}s: {} node(s), {alive} alive, {dead} dead, \
             {unborn} without a birth; {} malformed",
            self.filter,
            self.broker,
            now.saturating_duration_since(self.start).as_secs(),
            alive + dead + unborn,
            fleet.malformed(),
        )
    }

    /// Draws the table if it is time to (`end`: always, the last time).
    fn draw(&mut self, fleet: &Fleet, now: Instant, end: bool) -> Result<(), Exit> {
        let since = self.last_draw.map(|t| now.saturating_duration_since(t));
        let due = match self.mode {
            Mode::Json => false,
            Mode::Terminal => {
                end || since
                    .is_none_or(|s| (self.changed && s >= FRAME) || s >= Duration::from_secs(1))
            }
            Mode::Blocks => {
                end || (self.changed && since.is_none_or(|s| s >= Duration::from_secs(1)))
            }
        };
        if !due {
            return Ok(());
        }
        let mut lines = vec![self.status(fleet, now)];
        lines.extend(fleet.render(now));
        if fleet.counts() == (0, 0, 0) {
            lines.push("(no Sparkplug B node seen yet)".into());
        }
        let text = match self.mode {
            Mode::Terminal => {
                // Home, each line cleared to its end, then the rest of the
                // screen: no flicker, nothing of a longer table left.
                let mut t = String::from(if self.last_draw.is_none() {
                    "\x1b[H\x1b[2J"
                } else {
                    "\x1b[H"
                });
                for l in &lines {
                    t.push_str(l);
                    t.push_str("\x1b[K\n");
                }
                t.push_str("\x1b[J");
                t
            }
            _ => lines.join("\n") + "\n\n",
        };
        out(text.as_bytes())?;
        self.last_draw = Some(now);
        self.changed = false;
        Ok(())
    }
}

fn out(bytes: &[u8]) -> Result<(), Exit> {
    let mut o = std::io::stdout().lock();
    o.write_all(bytes)
        .and_then(|()| o.flush())
        .map_err(|e| Exit(3, format!("writing stdout: {e}")))
}

async fn watch(o: &Options, host: String, port: u16) -> Result<(), Exit> {
    let start = Instant::now();
    let filter = format!("{NAMESPACE}/{}/#", o.group.as_deref().unwrap_or("+"));
    // rumqttc connects to "{host}:{port}": an IPv6 address needs brackets.
    let host = if host.contains(':') {
        format!("[{host}]")
    } else {
        host
    };
    let broker = format!("{host}:{port}");
    let client_id = o
        .client_id
        .clone()
        .unwrap_or_else(|| format!("hansctl-fleet-{}", std::process::id()));
    let mut mo = MqttOptions::new(client_id, host, port);
    mo.set_keep_alive(Duration::from_secs(10));
    mo.set_clean_session(true);
    mo.set_max_packet_size(MAX_PACKET, 4096);
    let (client, mut eventloop) = AsyncClient::new(mo, 16);

    // The event loop in its own task: its results come through a channel,
    // which this loop can wait on beside the timers without cancelling a
    // read half-way.
    let (tx, mut rx) = mpsc::channel::<Result<Event, ConnectionError>>(64);
    tokio::spawn(async move {
        loop {
            let ev = eventloop.poll().await;
            let failed = ev.is_err();
            if tx.send(ev).await.is_err() {
                return;
            }
            if failed {
                tokio::time::sleep(RETRY).await;
            }
        }
    });

    let mode = match (o.json, std::io::stdout().is_terminal()) {
        (true, _) => Mode::Json,
        (false, true) => Mode::Terminal,
        (false, false) => Mode::Blocks,
    };
    let mut screen = Screen {
        mode,
        start,
        broker: broker.clone(),
        filter: filter.clone(),
        link: Link::Connecting,
        losses: 0,
        last_draw: None,
        changed: false,
    };
    let mut fleet = Fleet::new();
    let tokio_start = tokio::time::Instant::from_std(start);
    let end = o.duration.map(|d| tokio_start + d);
    let connect_by = tokio_start + o.timeout;
    let mut frames = tokio::time::interval(FRAME);
    frames.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let ctrl_c = tokio::signal::ctrl_c();
    tokio::pin!(ctrl_c);
    let mut session = Session {
        client,
        filter,
        broker: broker.clone(),
        json: mode == Mode::Json,
        last_error: "no answer".into(),
        rebirth: o.rebirth,
        asked: std::collections::HashSet::new(),
    };

    loop {
        tokio::select! {
            _ = sleep_until(end) => {
                if screen.link == Link::Connecting {
                    return Err(Exit(3, format!(
                        "no subscription at {broker} before --for ended: {}",
                        session.last_error
                    )));
                }
                break;
            }
            _ = &mut ctrl_c => break,
            _ = tokio::time::sleep_until(connect_by), if screen.link == Link::Connecting => {
                return Err(Exit(3, format!(
                    "cannot connect to the broker {broker} within {} ms: {}",
                    o.timeout.as_millis(),
                    session.last_error
                )));
            }
            _ = frames.tick() => screen.draw(&fleet, Instant::now(), false)?,
            ev = rx.recv() => match ev {
                Some(ev) => session.take(ev, &mut screen, &mut fleet)?,
                None => return Err(Exit(3, "the MQTT client stopped".into())),
            },
        }
    }
    screen.draw(&fleet, Instant::now(), true)
}

/// The client's side of the loop: what each event of the MQTT client does.
struct Session {
    client: AsyncClient,
    filter: String,
    broker: String,
    json: bool,
    /// Why the last connection attempt failed, for the final error.
    last_error: String,
    /// See [`Options::rebirth`].
    rebirth: bool,
    /// Nodes asked for a birth already (once each).
    asked: std::collections::HashSet<(String, String)>,
}

impl Session {
    fn take(
        &mut self,
        ev: Result<Event, ConnectionError>,
        screen: &mut Screen,
        fleet: &mut Fleet,
    ) -> Result<(), Exit> {
        let (filter, broker) = (&self.filter, &self.broker);
        match ev {
            Ok(Event::Incoming(Packet::ConnAck(_))) => {
                // A clean session each time: subscribe on every connect.
                self.client
                    .try_subscribe(filter.as_str(), QoS::AtLeastOnce)
                    .map_err(|e| Exit(3, format!("cannot subscribe to {filter}: {e}")))?;
            }
            Ok(Event::Incoming(Packet::SubAck(ack))) => {
                if ack.return_codes.contains(&SubscribeReasonCode::Failure) {
                    return Err(Exit(
                        3,
                        format!("the broker {broker} refused the subscription to {filter}"),
                    ));
                }
                let again = if screen.link == Link::Connecting {
                    ""
                } else {
                    " again"
                };
                eprintln!("hansctl: fleet: subscribed{again} to {filter} at {broker}");
                screen.link = Link::Subscribed;
                screen.changed = true;
            }
            Ok(Event::Incoming(Packet::Publish(p))) => {
                let ev = fleet.apply(&p.topic, &p.payload, Instant::now());
                self.ask_birth(&p.topic, fleet);
                if self.json {
                    if let Some(j) = ev.to_json(fleet) {
                        out(format!("{j}\n").as_bytes())?;
                    }
                }
                screen.changed |= ev.changes_table();
            }
            Ok(_) => {}
            Err(ConnectionError::ConnectionRefused(code)) => {
                return Err(Exit(
                    3,
                    format!("the broker {broker} refused the connection: {code:?}"),
                ));
            }
            Err(e) => {
                self.last_error = e.to_string();
                if screen.link == Link::Subscribed {
                    eprintln!("hansctl: fleet: connection to {broker} lost ({e}); reconnecting");
                    screen.link = Link::Lost;
                    screen.losses += 1;
                    screen.changed = true;
                }
            }
        }
        Ok(())
    }
}

impl Session {
    /// A node whose data arrives before its birth (it was born before this
    /// view subscribed: births are not retained) is asked once for a
    /// rebirth, so that the table has all its metrics; `--no-rebirth`
    /// keeps the view silent. The gateway obeys this one command only.
    fn ask_birth(&mut self, topic: &str, fleet: &Fleet) {
        if !self.rebirth {
            return;
        }
        let Ok(t) = Topic::parse(topic) else {
            return;
        };
        let (group, node) = (t.group, t.node);
        if fleet.status(group, node) != Some(Status::NoBirth) {
            return;
        }
        if !self.asked.insert((group.to_string(), node.to_string())) {
            return;
        }
        let payload = rebirth_request();
        let topic = format!("{NAMESPACE}/{group}/NCMD/{node}");
        if self
            .client
            .try_publish(topic.as_str(), QoS::AtMostOnce, false, payload)
            .is_ok()
            && !self.json
        {
            eprintln!("hansctl: fleet: asked {group}/{node} for its birth (seen without one)");
        }
    }
}

/// An NCMD payload that asks for a rebirth.
pub(crate) fn rebirth_request() -> Vec<u8> {
    use prost::Message as _;
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64);
    WirePayload {
        timestamp: Some(now),
        metrics: vec![WireMetric {
            name: Some("Node Control/Rebirth".to_string()),
            alias: None,
            timestamp: Some(now),
            datatype: Some(11),
            is_null: None,
            value: Some(WireValue::Boolean(true)),
        }],
        seq: None,
    }
    .encode_to_vec()
}

/// Sleeps until `t`, or for ever.
async fn sleep_until(t: Option<tokio::time::Instant>) {
    match t {
        Some(t) => tokio::time::sleep_until(t).await,
        None => std::future::pending().await,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn broker_addresses() {
        assert_eq!(
            parse_broker("127.0.0.1:1884"),
            Ok(("127.0.0.1".into(), 1884))
        );
        assert_eq!(
            parse_broker("broker.local"),
            Ok(("broker.local".into(), 1883))
        );
        assert_eq!(parse_broker("[::1]:8883"), Ok(("::1".into(), 8883)));
        assert_eq!(parse_broker("[::1]"), Ok(("::1".into(), 1883)));
        for bad in [
            "",
            ":1883",
            "host:",
            "host:0",
            "host:99999",
            "[::1",
            "[::1]x",
        ] {
            assert!(parse_broker(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn group_ids() {
        assert!(check_group("Plant A").is_ok());
        for bad in ["", "a/b", "+", "a#"] {
            assert!(check_group(bad).is_err(), "{bad:?}");
        }
    }
}
