//! The broker's side of `gateway_mqtt`: what it knows of MQTT 3.1.1 and
//! Sparkplug B, written here independently of the gateway (not its
//! `mqtt::packet` nor femtopb): the framing, the protobuf of the payloads,
//! a model of the client's reader ([`Mirror`]: what the client must have
//! read of what the broker delivered) and the checks of every packet the
//! client sends on a connection ([`Conn`]).

use hans_gateway::mqtt::RX_BUF;

/// The node: group `G`, edge node `E`, device `robot`, and its topics.
pub const GROUP: &str = "G";
pub const EDGE: &str = "E";
pub const NCMD: &str = "spBv1.0/G/NCMD/E";
pub const DCMD: &str = "spBv1.0/G/DCMD/E/robot";
pub const NDEATH: &str = "spBv1.0/G/NDEATH/E";

// ---------------------------------------------------------------------------
// MQTT packets (OASIS MQTT 3.1.1, 2.2), written and framed.

/// A packet's fixed header at the start of `b`: `Ok(Some((header, body)))`
/// lengths once the remaining length is complete, `Ok(None)` before,
/// `Err(())` when it runs past 4 bytes.
pub fn header(b: &[u8]) -> Result<Option<(usize, usize)>, ()> {
    let mut body = 0usize;
    for i in 1..=4 {
        let Some(&byte) = b.get(i) else {
            return Ok(None);
        };
        body |= usize::from(byte & 0x7F) << (7 * (i - 1));
        if byte & 0x80 == 0 {
            return Ok(Some((i + 1, body)));
        }
    }
    Err(())
}

/// The remaining length `n` as MQTT writes it.
pub fn remaining(n: usize) -> Vec<u8> {
    let mut out = Vec::new();
    let mut n = n;
    loop {
        let b = (n % 128) as u8;
        n /= 128;
        out.push(if n > 0 { b | 0x80 } else { b });
        if n == 0 {
            return out;
        }
    }
}

/// A packet: the first byte, the remaining length, `body`.
pub fn packet(first: u8, body: &[u8]) -> Vec<u8> {
    let mut p = vec![first];
    p.extend(remaining(body.len()));
    p.extend_from_slice(body);
    p
}

/// An MQTT string: a big-endian length and the bytes.
pub fn mqtt_str(s: &[u8]) -> Vec<u8> {
    let mut v = (s.len() as u16).to_be_bytes().to_vec();
    v.extend_from_slice(s);
    v
}

/// Reads an MQTT string at `*at` of `b`.
pub fn read_str<'b>(b: &'b [u8], at: &mut usize) -> Option<&'b [u8]> {
    let n = usize::from(u16::from_be_bytes([*b.get(*at)?, *b.get(*at + 1)?]));
    let s = b.get(*at + 2..*at + 2 + n)?;
    *at += 2 + n;
    Some(s)
}

/// `b` in hex, for messages.
pub fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
}

// ---------------------------------------------------------------------------
// Protobuf (Sparkplug B payloads): written (commands), read (the gateway's).

/// Writes `v` as a protobuf varint.
pub fn varint(mut v: u64, out: &mut Vec<u8>) {
    loop {
        let b = (v & 0x7F) as u8;
        v >>= 7;
        if v == 0 {
            out.push(b);
            return;
        }
        out.push(b | 0x80);
    }
}

/// Writes a field's key.
pub fn key(field: u32, wire: u8, out: &mut Vec<u8>) {
    varint(u64::from(field << 3 | u32::from(wire)), out);
}

/// Writes a length-delimited field.
pub fn bytes_field(field: u32, b: &[u8], out: &mut Vec<u8>) {
    key(field, 2, out);
    varint(b.len() as u64, out);
    out.extend_from_slice(b);
}

/// A protobuf field as read: its number and value.
#[derive(Debug)]
pub enum Field<'b> {
    Varint(u64),
    Bytes(&'b [u8]),
    Fixed32,
}

/// Reads a varint at `*at` of `b`.
pub fn read_varint(b: &[u8], at: &mut usize) -> Option<u64> {
    let mut v = 0u64;
    for i in 0..10 {
        let byte = *b.get(*at)?;
        *at += 1;
        v |= u64::from(byte & 0x7F) << (7 * i);
        if byte & 0x80 == 0 {
            return Some(v);
        }
    }
    None
}

/// The fields of message `b`, in order (`None` if it is not protobuf of the
/// wire types the gateway writes).
pub fn fields(b: &[u8]) -> Option<Vec<(u64, Field<'_>)>> {
    let mut at = 0;
    let mut out = Vec::new();
    while at < b.len() {
        let k = read_varint(b, &mut at)?;
        let f = match k & 7 {
            0 => Field::Varint(read_varint(b, &mut at)?),
            2 => {
                let n = usize::try_from(read_varint(b, &mut at)?).ok()?;
                let v = b.get(at..at.checked_add(n)?)?;
                at += n;
                Field::Bytes(v)
            }
            5 => {
                b.get(at..at + 4)?;
                at += 4;
                Field::Fixed32
            }
            _ => return None,
        };
        out.push((k >> 3, f));
    }
    Some(out)
}

/// What a payload of the gateway says, once checked: a timestamp first,
/// metrics each with a UTF-8 name, a timestamp, a datatype and one value
/// (or null), then `seq` if any.
#[derive(Debug, Default)]
pub struct Payload {
    pub seq: Option<u64>,
    pub bd_seq: Option<u64>,
    pub metrics: usize,
}

/// Reads and checks a payload of the gateway (see [`Payload`]).
pub fn read_payload(b: &[u8]) -> Result<Payload, String> {
    let fs = fields(b).ok_or("not protobuf")?;
    let mut out = Payload::default();
    let mut it = fs.iter().peekable();
    match it.next() {
        Some((1, Field::Varint(_))) => {}
        f => return Err(format!("no timestamp first: {f:?}")),
    }
    while let Some((2, Field::Bytes(m))) = it.peek() {
        it.next();
        let mf = fields(m).ok_or("a metric is not protobuf")?;
        let [(1, Field::Bytes(name)), (3, Field::Varint(_)), (4, Field::Varint(_)), value] =
            mf.as_slice()
        else {
            return Err(format!("metric fields {mf:?}"));
        };
        let name = core::str::from_utf8(name).map_err(|_| "a name not UTF-8")?;
        match value {
            (7, Field::Varint(1))
            | (10, Field::Varint(_))
            | (12, Field::Fixed32)
            | (14, Field::Varint(0 | 1)) => {}
            (11, Field::Varint(v)) => {
                if name == "bdSeq" {
                    out.bd_seq = Some(*v);
                }
            }
            (15, Field::Bytes(s)) => {
                core::str::from_utf8(s).map_err(|_| "a string not UTF-8")?;
            }
            v => return Err(format!("metric {name}: value {v:?}")),
        }
        out.metrics += 1;
    }
    match it.next() {
        None => {}
        Some((3, Field::Varint(s))) if *s < 256 => out.seq = Some(*s),
        f => return Err(format!("after the metrics: {f:?}")),
    }
    if let Some(f) = it.next() {
        return Err(format!("after seq: {f:?}"));
    }
    Ok(out)
}

// ---------------------------------------------------------------------------
// The client's reader, modelled.

/// Where the client's reading of a connection is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// Waiting for the CONNACK (the first packet that fits its buffer).
    ConnAck,
    /// CONNACK 0 read: in session.
    Session,
    /// The client found an error (refused, a packet it cannot read): it
    /// reads no more of this connection.
    Ended,
}

/// The bytes the broker delivered on one connection, framed and read as
/// the client must: packets longer than [`RX_BUF`] skipped (counted), a
/// remaining length of more than 4 bytes or a packet too short for its
/// type ends the connection, the first packet must be a CONNACK, later
/// ones must not.
pub struct Mirror {
    /// Delivered bytes not yet framed.
    buf: Vec<u8>,
    /// Bytes of a too-long packet still to pass over.
    skip: usize,
    pub phase: Phase,
    /// A CONNACK 0 was read.
    pub accepted: bool,
    /// Packets too long for the client's buffer.
    pub skipped: u32,
    /// The PUBACKs the client owes, in order (QoS 1 PUBLISH ids).
    pub acks: Vec<u16>,
    /// The primary host's STATE topic, if the node has one.
    pub state: Option<&'static str>,
    /// The births may go: no primary host, or its STATE said online.
    pub host_online: bool,
}

impl Mirror {
    pub fn new(state: Option<&'static str>) -> Mirror {
        Mirror {
            buf: Vec::new(),
            skip: 0,
            phase: Phase::ConnAck,
            accepted: false,
            skipped: 0,
            acks: Vec::new(),
            state,
            host_online: state.is_none(),
        }
    }

    /// The broker delivered `bytes`.
    pub fn feed(&mut self, bytes: &[u8]) {
        if self.phase == Phase::Ended {
            return;
        }
        self.buf.extend_from_slice(bytes);
        loop {
            if self.skip > 0 {
                let k = self.skip.min(self.buf.len());
                self.buf.drain(..k);
                self.skip -= k;
                if self.skip > 0 {
                    return;
                }
            }
            match header(&self.buf) {
                Err(()) => return self.end(),
                Ok(None) => return,
                Ok(Some((h, n))) if h + n > RX_BUF => {
                    self.skipped += 1;
                    self.skip = h + n;
                }
                Ok(Some((h, n))) => {
                    if self.buf.len() < h + n {
                        return;
                    }
                    let p: Vec<u8> = self.buf.drain(..h + n).collect();
                    self.read(p[0], &p[h..]);
                    if self.phase == Phase::Ended {
                        return;
                    }
                }
            }
        }
    }

    fn end(&mut self) {
        self.phase = Phase::Ended;
        self.buf.clear();
    }

    fn read(&mut self, first: u8, body: &[u8]) {
        let u16_at = |k: usize| body.get(k..k + 2).map(|b| u16::from_be_bytes([b[0], b[1]]));
        match (self.phase, first >> 4) {
            (Phase::ConnAck, 2) if body.len() >= 2 && body[1] == 0 => {
                self.phase = Phase::Session;
                self.accepted = true;
            }
            // Refused, short, or not a CONNACK.
            (Phase::ConnAck, _) => self.end(),
            // A CONNACK in session (or a short one).
            (Phase::Session, 2) => self.end(),
            (Phase::Session, 9) if body.len() < 2 => self.end(),
            (Phase::Session, 3) => {
                let qos = (first >> 1) & 3;
                let Some(topic) = u16_at(0) else {
                    return self.end();
                };
                let k = 2 + usize::from(topic);
                if body.len() < k {
                    return self.end();
                }
                let mut payload = k;
                if qos > 0 {
                    match u16_at(k) {
                        Some(id) if qos == 1 => self.acks.push(id),
                        Some(_) => {}
                        None => return self.end(),
                    }
                    payload += 2;
                }
                if self.state.map(str::as_bytes) == Some(&body[2..k]) {
                    match online(&body[payload..]) {
                        Some(true) => self.host_online = true,
                        // The session ends: the node is dead for the host.
                        Some(false) => self.end(),
                        None => {}
                    }
                }
            }
            _ => {}
        }
    }
}

/// What a STATE payload says, as the client reads it (a JSON object, read
/// without a parser: the first `"online"`, blanks, a colon, blanks, then
/// `true` or `false` as the start of what follows).
pub fn online(payload: &[u8]) -> Option<bool> {
    let key = b"\"online\"";
    let at = payload.windows(key.len()).position(|w| w == key)?;
    let blank = |b: &u8| b" \t\n\r\x0c".contains(b);
    let mut rest = &payload[at + key.len()..];
    while rest.first().is_some_and(blank) {
        rest = &rest[1..];
    }
    rest = rest.strip_prefix(b":")?;
    while rest.first().is_some_and(blank) {
        rest = &rest[1..];
    }
    if rest.starts_with(b"true") {
        Some(true)
    } else if rest.starts_with(b"false") {
        Some(false)
    } else {
        None
    }
}

// ---------------------------------------------------------------------------
// What the gateway sends, checked.

/// Where a connection's packets from the gateway are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    Connect,
    Subscribe,
    NBirth,
    Born,
}

/// One connection the broker accepted.
pub struct Conn {
    /// Its index since the start: the `bdSeq` of its Will (mod 256).
    pub index: usize,
    pub mirror: Mirror,
    /// Bytes from the gateway not yet framed.
    pub out: Vec<u8>,
    pub stage: Stage,
    /// The `bdSeq` of its Will (its NBIRTH's).
    will_bd_seq: u64,
    /// The next `seq` expected.
    seq: u8,
    device_born: bool,
    /// PUBACKs seen.
    pub acks: usize,
    /// PUBLISH packets seen.
    pub publishes: u32,
}

impl Conn {
    pub fn new(index: usize, state: Option<&'static str>) -> Conn {
        Conn {
            index,
            mirror: Mirror::new(state),
            out: Vec::new(),
            stage: Stage::Connect,
            will_bd_seq: 0,
            seq: 0,
            device_born: false,
            acks: 0,
            publishes: 0,
        }
    }

    /// Takes bytes from the gateway and checks every whole packet.
    pub fn take(&mut self, bytes: &[u8], keep_alive_s: u16) {
        self.out.extend_from_slice(bytes);
        loop {
            let (h, n) = match header(&self.out) {
                Ok(Some((h, n))) if self.out.len() >= h + n => (h, n),
                Ok(_) => return,
                Err(()) => panic!("a remaining length of 5 bytes: {}", hex(&self.out)),
            };
            let p: Vec<u8> = self.out.drain(..h + n).collect();
            self.check(p[0], &p[h..], keep_alive_s);
        }
    }

    fn check(&mut self, first: u8, body: &[u8], keep_alive_s: u16) {
        let what = || format!("connection {}: {first:02x} {}", self.index, hex(body));
        match (self.stage, first) {
            (Stage::Connect, 0x10) => {
                let mut k = 0;
                assert_eq!(read_str(body, &mut k), Some(&b"MQTT"[..]), "{}", what());
                let [ka0, ka1] = keep_alive_s.to_be_bytes();
                assert_eq!(
                    body.get(6..10),
                    Some(&[4, 0x0E, ka0, ka1][..]),
                    "level 4, clean session, a Will of QoS 1 not retained, the keep-alive: {}",
                    what()
                );
                let mut k = 10;
                assert_eq!(read_str(body, &mut k), Some(EDGE.as_bytes()), "{}", what());
                assert_eq!(
                    read_str(body, &mut k),
                    Some(NDEATH.as_bytes()),
                    "{}",
                    what()
                );
                let will = read_str(body, &mut k).unwrap_or_else(|| panic!("no Will: {}", what()));
                assert_eq!(k, body.len(), "no user name: {}", what());
                let p = read_payload(will).unwrap_or_else(|e| panic!("the Will: {e}: {}", what()));
                assert_eq!(p.seq, None, "NDEATH has no seq");
                assert_eq!(p.metrics, 1, "NDEATH: bdSeq only");
                let bd = p
                    .bd_seq
                    .unwrap_or_else(|| panic!("the Will's bdSeq: {}", what()));
                assert_eq!(bd, self.index as u64 % 256, "one bdSeq more per connection");
                self.will_bd_seq = bd;
                self.stage = Stage::Subscribe;
            }
            (Stage::Subscribe, 0x82) => {
                assert!(
                    self.mirror.accepted,
                    "SUBSCRIBE before a CONNACK 0: {}",
                    what()
                );
                let mut want = vec![0, 1];
                want.extend(mqtt_str(NCMD.as_bytes()));
                want.push(0);
                want.extend(mqtt_str(DCMD.as_bytes()));
                want.push(0);
                if let Some(st) = self.mirror.state {
                    want.extend(mqtt_str(st.as_bytes()));
                    want.push(0);
                }
                assert_eq!(body, &want[..], "{}", what());
                self.stage = Stage::NBirth;
            }
            (Stage::NBirth | Stage::Born, 0x30) => self.publish(body),
            // Waiting for a primary host, the client pings and acknowledges.
            (Stage::Born, 0xC0) => assert!(body.is_empty(), "PINGREQ: {}", what()),
            (Stage::NBirth, 0xC0) if self.mirror.state.is_some() => {
                assert!(body.is_empty(), "PINGREQ: {}", what())
            }
            (Stage::Born, 0x40) | (Stage::NBirth, 0x40) if self.born_or_waiting() => {
                let id = match body {
                    [a, b] => u16::from_be_bytes([*a, *b]),
                    _ => panic!("PUBACK: {}", what()),
                };
                assert_eq!(
                    self.mirror.acks.get(self.acks),
                    Some(&id),
                    "a PUBACK for a QoS 1 PUBLISH, in order (owed {:?}, {} sent): {}",
                    self.mirror.acks,
                    self.acks,
                    what()
                );
                self.acks += 1;
            }
            (stage, _) => panic!("at {stage:?}: {}", what()),
        }
    }

    /// PUBACKs may go: born, or waiting for a primary host.
    fn born_or_waiting(&self) -> bool {
        self.stage == Stage::Born || self.mirror.state.is_some()
    }

    fn publish(&mut self, body: &[u8]) {
        let mut k = 0;
        let topic = read_str(body, &mut k).unwrap_or_else(|| panic!("PUBLISH {}", hex(body)));
        let topic = core::str::from_utf8(topic).expect("a topic in UTF-8");
        let p = read_payload(&body[k..])
            .unwrap_or_else(|e| panic!("{topic}: {e}: {}", hex(&body[k..])));
        let ty = match topic.strip_prefix("spBv1.0/G/") {
            Some("NBIRTH/E") => "NBIRTH",
            Some("NDATA/E") => "NDATA",
            Some("DBIRTH/E/robot") => "DBIRTH",
            Some("DDATA/E/robot") => "DDATA",
            Some("DDEATH/E/robot") => "DDEATH",
            _ => panic!("a topic not the node's to publish: {topic}"),
        };
        self.publishes += 1;
        if ty == "NBIRTH" {
            assert!(
                self.mirror.host_online,
                "NBIRTH before the primary host is online"
            );
            assert_eq!(p.seq, Some(0), "NBIRTH seq");
            assert_eq!(
                p.bd_seq,
                Some(self.will_bd_seq),
                "NBIRTH bdSeq is the Will's"
            );
            self.stage = Stage::Born;
            self.seq = 1;
            self.device_born = false;
            return;
        }
        assert_eq!(self.stage, Stage::Born, "{ty} before the NBIRTH");
        assert_eq!(p.seq, Some(u64::from(self.seq)), "{ty}: seq");
        self.seq = self.seq.wrapping_add(1);
        match ty {
            "DBIRTH" => {
                assert!(!self.device_born, "DBIRTH twice");
                self.device_born = true;
            }
            "DDEATH" => {
                assert!(self.device_born, "DDEATH of a device not born");
                self.device_born = false;
            }
            "DDATA" => assert!(self.device_born, "DDATA of a device not born"),
            _ => assert!(p.metrics > 0, "an empty NDATA"),
        }
    }
}
