//! An MQTT broker in the virtual world (feature `mqtt`), for the
//! simulations that check the PLC sees the same gateway whatever the
//! broker does ([`BrokerMode`]), and for the tests of what the gateway
//! publishes and when. Its framing is its own (not the client's
//! `mqtt::packet`): it answers CONNECT, SUBSCRIBE and PINGREQ, counts what
//! it is sent and keeps the last [`PUBLISHED_KEPT`] PUBLISH packets.

use std::collections::VecDeque;
use std::net::{Ipv4Addr, SocketAddrV4};

use embassy_time::{Duration, Instant};

use crate::testkit::net::{SimNet, SimStream};

/// The broker's address in the world.
pub const BROKER: SocketAddrV4 = SocketAddrV4::new(Ipv4Addr::new(10, 0, 0, 50), 1883);

/// How many PUBLISH packets [`SimBroker::published`] keeps: the oldest
/// is dropped for a new one beyond (a long simulation publishes for
/// hours; a test looks at the last few).
pub const PUBLISHED_KEPT: usize = 256;

/// A PUBLISH packet the broker received.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Published {
    /// When it arrived (the network has no delay: when it was sent).
    pub at: Instant,
    /// Its topic.
    pub topic: std::string::String,
    /// Its payload.
    pub payload: std::vec::Vec<u8>,
}

/// What the broker does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BrokerMode {
    /// Accepts, answers, takes everything.
    Up,
    /// Refuses connections (nothing listens).
    Refusing,
    /// Never answers a connect (its host is gone).
    Blackhole,
    /// Accepts and answers, then closes each connection after this long.
    Flapping(Duration),
    /// Accepts, then refuses the CONNECT (return code 5: not authorised).
    BadPassword,
}

/// The broker.
pub struct SimBroker {
    net: SimNet,
    /// Its mode.
    pub mode: BrokerMode,
    conn: Option<(SimStream, Instant)>,
    inbox: VecDeque<u8>,
    /// CONNECTs it accepted.
    pub connects: u32,
    /// PUBLISH packets it received.
    pub publishes: u32,
    /// The last [`PUBLISHED_KEPT`] of them, oldest first.
    pub published: VecDeque<Published>,
}

impl SimBroker {
    /// A broker on `net` at [`BROKER`], in `mode`.
    pub fn new(net: &SimNet, mode: BrokerMode) -> SimBroker {
        match mode {
            BrokerMode::Refusing => net.unlisten(BROKER),
            BrokerMode::Blackhole => net.blackhole(*BROKER.ip(), true),
            _ => net.listen(BROKER),
        }
        SimBroker {
            net: net.clone(),
            mode,
            conn: None,
            inbox: VecDeque::new(),
            connects: 0,
            publishes: 0,
            published: VecDeque::new(),
        }
    }

    /// When it next has something to do by itself (a flapping broker's
    /// close).
    pub fn next_wakeup(&self) -> Option<Instant> {
        match (self.mode, &self.conn) {
            (BrokerMode::Flapping(d), Some((_, since))) => Some(*since + d),
            _ => None,
        }
    }

    /// Does what is due at `now`; `true` if it did something.
    pub fn step(&mut self, now: Instant) -> bool {
        let mut acted = false;
        if let Some((c, since)) = &mut self.conn {
            let flap = matches!(self.mode, BrokerMode::Flapping(d) if now >= *since + d);
            if flap || !c.is_open() {
                c.close();
                self.conn = None;
                self.inbox.clear();
                acted = true;
            }
        }
        if self.conn.is_none() {
            if let Some(s) = self.net.accept(BROKER) {
                self.conn = Some((s, now));
                acted = true;
            }
        }
        let Some((c, _)) = &mut self.conn else {
            return acted;
        };
        let got = c.read();
        if !got.is_empty() {
            acted = true;
            self.inbox.extend(got);
        }
        while let Some((first, len)) = packet(&self.inbox) {
            let bytes: std::vec::Vec<u8> = self.inbox.drain(..len).collect();
            let answer: &[u8] = match first >> 4 {
                1 if self.mode == BrokerMode::BadPassword => &[0x20, 2, 0, 5],
                1 => {
                    self.connects += 1;
                    &[0x20, 2, 0, 0]
                }
                3 => {
                    self.publishes += 1;
                    if let Some((topic, payload)) = publish(&bytes) {
                        if self.published.len() >= PUBLISHED_KEPT {
                            self.published.pop_front();
                        }
                        self.published.push_back(Published {
                            at: now,
                            topic,
                            payload: payload.to_vec(),
                        });
                    }
                    &[]
                }
                // SUBACK for packet id 1 (the client's), every topic QoS 0.
                8 => &[0x90, 5, 0, 1, 0, 0, 0],
                12 => &[0xD0, 0],
                _ => &[],
            };
            if !answer.is_empty() {
                c.write(answer);
            }
        }
        acted
    }
}

/// The topic and payload of the whole PUBLISH packet `p` (`None`: not
/// one the broker can read).
fn publish(p: &[u8]) -> Option<(std::string::String, &[u8])> {
    let first = *p.first()?;
    // The remaining length's bytes end at the first without bit 7.
    let header = 2 + p.iter().skip(1).take(4).position(|b| b & 0x80 == 0)?;
    let body = p.get(header..)?;
    let n = usize::from(u16::from_be_bytes([*body.first()?, *body.get(1)?]));
    let topic = core::str::from_utf8(body.get(2..2 + n)?).ok()?;
    // QoS 1 and 2 have a packet identifier after the topic.
    let id = if first & 0x06 == 0 { 0 } else { 2 };
    Some((topic.into(), body.get(2 + n + id..)?))
}

/// The first whole packet of `b`: its first byte and its length.
fn packet(b: &VecDeque<u8>) -> Option<(u8, usize)> {
    let first = *b.front()?;
    let (mut n, mut mult) = (0usize, 1usize);
    for i in 1..5 {
        let byte = *b.get(i)?;
        n += usize::from(byte & 0x7f) * mult;
        mult *= 128;
        if byte & 0x80 == 0 {
            return (b.len() >= i + 1 + n).then_some((first, i + 1 + n));
        }
    }
    None
}
