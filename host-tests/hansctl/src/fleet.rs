//! `hansctl fleet`: the table of Sparkplug B edge nodes, kept from the
//! messages a broker passes on, and the JSON line of each message.
//!
//! No clock, no sockets: each message comes with the time it arrived
//! (`apply`), the table is drawn for a given time (`render`), so the tests
//! own time. The MQTT side is `fleet/run.rs`.
//!
//! Rules (Sparkplug B 3.0, `gateway/SPARKPLUG.md`):
//! - NBIRTH: the node is ALIVE, with its `bdSeq`; its metrics are the
//!   birth's (all of them, replacing what was known). Its devices are down
//!   until their DBIRTH (a new session re-births them).
//! - NDEATH: the node is DEAD if the death's `bdSeq` is the birth's. An
//!   NDEATH with another `bdSeq` (or none) is a stale Will of an earlier
//!   session, delivered late: ignored (the event says so). With no birth
//!   seen, any NDEATH is taken. A dead node's devices are down.
//! - DBIRTH: the device is up, its metrics the birth's. DDEATH: down.
//! - NDATA, DDATA: metrics updated by name (or by the alias a birth gave).
//!   A node first seen through data (hansctl started after its birth) is
//!   `NO BIRTH` until one comes.
//! - NCMD, DCMD are a host's commands to the node: shown with `--json`,
//!   they change nothing in the table.
//! - Age: time since the node's last message (stale deaths excluded).
//! - A payload that is not Sparkplug B, or a topic of the wrong shape, is
//!   counted (on the node, if known, and in all) and never stops anything.

use std::collections::{BTreeMap, HashMap};
use std::fmt::Write as _;
use std::time::{Duration, Instant};

mod run;

pub(crate) use run::{run, Options};

use crate::json::{Json, Obj};
use crate::sparkplug::{MetricId, MsgType, Payload, Topic, TopicError, Value};

/// The node metric of the birth/death sequence.
const BD_SEQ: &str = "bdSeq";
/// The prefix of the command-event metrics (SPARKPLUG.md, "Command events").
const LAST_COMMAND: &str = "Last Command/";

/// A node's state, as the table shows it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Status {
    Alive,
    Dead,
    /// Data seen, no birth yet (hansctl started within a session).
    NoBirth,
}

impl Status {
    fn as_str(self) -> &'static str {
        match self {
            Status::Alive => "ALIVE",
            Status::Dead => "DEAD",
            Status::NoBirth => "NO BIRTH",
        }
    }
}

/// Metric values by name, and the aliases a birth gave.
#[derive(Clone, Debug, Default)]
struct Metrics {
    values: BTreeMap<String, Value>,
    aliases: HashMap<u64, String>,
}

impl Metrics {
    /// A birth: every metric, replacing what was known.
    fn seed(&mut self, p: &Payload) {
        self.values.clear();
        self.aliases.clear();
        for m in &p.metrics {
            if let (MetricId::Name(n), Some(a)) = (&m.id, m.alias) {
                self.aliases.insert(a, n.clone());
            }
        }
        self.update(p);
    }

    /// Data: each metric by name, in order (the last of a name wins).
    fn update(&mut self, p: &Payload) {
        for m in &p.metrics {
            if let Some(name) = self.name_of(&m.id) {
                self.values.insert(name, m.value.clone());
            }
        }
    }

    fn name_of(&self, id: &MetricId) -> Option<String> {
        match id {
            MetricId::Name(n) => Some(n.clone()),
            MetricId::Alias(a) => self.aliases.get(a).cloned(),
            MetricId::Anonymous => None,
        }
    }

    fn get(&self, name: &str) -> &Value {
        self.values.get(name).unwrap_or(&Value::Null)
    }
}

/// A device of a node (the gateway has one, `robot`).
#[derive(Clone, Debug, Default)]
struct Device {
    /// DBIRTH: `Some(true)`, DDEATH (or its node's death or rebirth):
    /// `Some(false)`; data without a birth seen: `None`.
    up: Option<bool>,
    metrics: Metrics,
}

/// One edge node.
#[derive(Clone, Debug)]
struct Node {
    status: Status,
    /// The `bdSeq` of the session the status is about.
    bd_seq: Option<u64>,
    metrics: Metrics,
    devices: BTreeMap<String, Device>,
    last_seen: Instant,
    malformed: u64,
}

impl Node {
    fn new(status: Status, now: Instant) -> Node {
        Node {
            status,
            bd_seq: None,
            metrics: Metrics::default(),
            devices: BTreeMap::new(),
            last_seen: now,
            malformed: 0,
        }
    }

    fn devices_down(&mut self) {
        for d in self.devices.values_mut() {
            d.up = Some(false);
        }
    }
}

/// What became of one message.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Outcome {
    /// Taken into the table (or a command, which changes nothing).
    Applied,
    /// An NDEATH whose `bdSeq` is not the birth's: ignored.
    StaleDeath {
        death: Option<u64>,
        birth: Option<u64>,
    },
    /// The payload or the topic could not be read: counted.
    Malformed(String),
    /// A host application's STATE message: not a node's, skipped.
    HostState,
}

/// One message and what became of it: the line `--json` prints.
#[derive(Clone, Debug)]
pub(crate) struct Event {
    pub(crate) topic: String,
    pub(crate) kind: Option<MsgType>,
    pub(crate) group: Option<String>,
    pub(crate) node: Option<String>,
    pub(crate) device: Option<String>,
    pub(crate) payload: Option<Payload>,
    pub(crate) outcome: Outcome,
}

/// The table of every edge node seen.
#[derive(Debug, Default)]
pub(crate) struct Fleet {
    nodes: BTreeMap<(String, String), Node>,
    malformed: u64,
}

impl Fleet {
    pub(crate) fn new() -> Fleet {
        Fleet::default()
    }

    /// The status of node `node` of `group`, if seen.
    pub(crate) fn status(&self, group: &str, node: &str) -> Option<Status> {
        self.nodes
            .get(&(group.to_string(), node.to_string()))
            .map(|n| n.status)
    }

    /// Payloads or topics that could not be read, in all.
    pub(crate) fn malformed(&self) -> u64 {
        self.malformed
    }

    /// Takes one message, received at `now`, into the table.
    pub(crate) fn apply(&mut self, topic: &str, bytes: &[u8], now: Instant) -> Event {
        let mut ev = Event {
            topic: topic.to_string(),
            kind: None,
            group: None,
            node: None,
            device: None,
            payload: None,
            outcome: Outcome::Applied,
        };
        let t = match Topic::parse(topic) {
            Ok(t) => t,
            Err(TopicError::HostState) => {
                ev.outcome = Outcome::HostState;
                return ev;
            }
            Err(e) => {
                self.malformed += 1;
                ev.outcome = Outcome::Malformed(format!("topic: {e}"));
                return ev;
            }
        };
        ev.kind = Some(t.kind);
        ev.group = Some(t.group.to_string());
        ev.node = Some(t.node.to_string());
        ev.device = t.device.map(str::to_string);
        let key = (t.group.to_string(), t.node.to_string());
        let p = match Payload::decode(bytes) {
            Ok(p) => p,
            Err(e) => {
                self.malformed += 1;
                if let Some(n) = self.nodes.get_mut(&key) {
                    n.malformed += 1;
                    if !t.kind.is_command() {
                        n.last_seen = now;
                    }
                }
                ev.outcome = Outcome::Malformed(e.to_string());
                return ev;
            }
        };
        if !t.kind.is_command() {
            ev.outcome = self.take(&t, key, &p, now);
        }
        ev.payload = Some(p);
        ev
    }

    fn take(&mut self, t: &Topic<'_>, key: (String, String), p: &Payload, now: Instant) -> Outcome {
        let bd_seq = p.get(BD_SEQ).and_then(Value::as_u64);
        if t.kind == MsgType::NDeath {
            let node = self
                .nodes
                .entry(key)
                .or_insert_with(|| Node::new(Status::Dead, now));
            // With a birth seen, only its session's death counts.
            if node.status != Status::NoBirth && node.bd_seq.is_some() && bd_seq != node.bd_seq {
                return Outcome::StaleDeath {
                    death: bd_seq,
                    birth: node.bd_seq,
                };
            }
            node.status = Status::Dead;
            node.bd_seq = bd_seq;
            node.last_seen = now;
            node.devices_down();
            return Outcome::Applied;
        }
        let node = self
            .nodes
            .entry(key)
            .or_insert_with(|| Node::new(Status::NoBirth, now));
        node.last_seen = now;
        match (t.kind, t.device) {
            (MsgType::NBirth, _) => {
                node.status = Status::Alive;
                node.bd_seq = bd_seq;
                node.metrics.seed(p);
                node.devices_down();
            }
            (MsgType::NData, _) => node.metrics.update(p),
            (MsgType::DBirth, Some(d)) => {
                let dev = node.devices.entry(d.to_string()).or_default();
                dev.up = Some(true);
                dev.metrics.seed(p);
            }
            (MsgType::DDeath, Some(d)) => {
                let dev = node.devices.entry(d.to_string()).or_default();
                dev.up = Some(false);
                dev.metrics.update(p);
            }
            (MsgType::DData, Some(d)) => node
                .devices
                .entry(d.to_string())
                .or_default()
                .metrics
                .update(p),
            // Commands are not taken; a device type always has a device.
            _ => {}
        }
        Outcome::Applied
    }

    /// Nodes by status: (alive, dead, without a birth).
    pub(crate) fn counts(&self) -> (usize, usize, usize) {
        let n = |s| self.nodes.values().filter(|n| n.status == s).count();
        (n(Status::Alive), n(Status::Dead), n(Status::NoBirth))
    }

    /// The table at `now`: a header line, then one line per node (and one
    /// more per further device), sorted by group and node.
    pub(crate) fn render(&self, now: Instant) -> Vec<String> {
        let mut rows: Vec<[String; COLUMNS]> = Vec::new();
        for ((group, name), node) in &self.nodes {
            let mut devices: Vec<(&str, Option<&Device>)> = node
                .devices
                .iter()
                .map(|(id, d)| (id.as_str(), Some(d)))
                .collect();
            if devices.is_empty() {
                devices.push(("-", None));
            }
            for (i, (dev_id, dev)) in devices.into_iter().enumerate() {
                let first = i == 0;
                let node_cell = |s: String| if first { s } else { String::new() };
                rows.push([
                    node_cell(group.clone()),
                    node_cell(name.clone()),
                    node_cell(node.status.as_str().to_string()),
                    dev_id.to_string(),
                    link(node, dev),
                    dev.map_or("-".into(), |d| fsm(&d.metrics)),
                    dev.map_or("-".into(), |d| robot_error(&d.metrics)),
                    node_cell(last_command(&node.metrics)),
                    node_cell(result(&node.metrics)),
                    node_cell(age(now.saturating_duration_since(node.last_seen))),
                    node_cell(node.malformed.to_string()),
                ]);
            }
        }
        table(&rows)
    }
}

const COLUMNS: usize = 11;
const HEADER: [&str; COLUMNS] = [
    "GROUP",
    "NODE",
    "STATUS",
    "DEVICE",
    "LINK",
    "FSM",
    "ERROR",
    "LAST COMMAND",
    "RESULT",
    "AGE",
    "BAD",
];
/// The widest a column may grow (characters); longer text is cut with `~`.
const WIDTH: [usize; COLUMNS] = [16, 24, 8, 12, 18, 20, 32, 40, 22, 8, 5];

fn table(rows: &[[String; COLUMNS]]) -> Vec<String> {
    let cut = |s: &str, max: usize| -> String {
        if s.chars().count() <= max {
            s.to_string()
        } else {
            let mut t: String = s.chars().take(max.saturating_sub(1)).collect();
            t.push('~');
            t
        }
    };
    let cells: Vec<Vec<String>> = std::iter::once(HEADER.map(str::to_string))
        .chain(rows.iter().cloned())
        .map(|r| r.iter().zip(WIDTH).map(|(c, w)| cut(c, w)).collect())
        .collect();
    let mut widths = [0usize; COLUMNS];
    for r in &cells {
        for (w, c) in widths.iter_mut().zip(r) {
            *w = (*w).max(c.chars().count());
        }
    }
    cells
        .iter()
        .map(|r| {
            let mut line = String::new();
            for (i, (c, w)) in r.iter().zip(widths).enumerate() {
                if i + 1 == COLUMNS {
                    line.push_str(c);
                } else {
                    let _ = write!(line, "{c:<w$}  ");
                }
            }
            line.trim_end().to_string()
        })
        .collect()
}

/// `up`/`down` from the device's birth and death (`-` none seen, `?` data
/// without a birth), then the node's `Link/State` metric, unless the node
/// is dead (its metrics are then only what it last said).
fn link(node: &Node, dev: Option<&Device>) -> String {
    let up = match dev.map(|d| d.up) {
        None => "-",
        Some(None) => "?",
        Some(Some(true)) => "up",
        Some(Some(false)) => "down",
    };
    if node.status == Status::Dead {
        return up.to_string();
    }
    match node.metrics.get("Link/State") {
        Value::Null => up.to_string(),
        state => format!("{up} ({state})"),
    }
}

/// `FSM/Name`, else `FSM/Code`.
fn fsm(m: &Metrics) -> String {
    match (m.get("FSM/Name").as_str(), m.get("FSM/Code")) {
        (Some(name), _) => name.to_string(),
        (None, Value::Null) => "-".into(),
        (None, code) => code.to_string(),
    }
}

/// `Error/Text`, else `Error/Code` when not 0.
fn robot_error(m: &Metrics) -> String {
    match (m.get("Error/Text").as_str(), m.get("Error/Code").as_i64()) {
        (Some(text), _) if !text.is_empty() => text.to_string(),
        (_, Some(code)) if code != 0 => format!("code {code}"),
        _ => "-".into(),
    }
}

/// `Source: Text` of the last command event.
fn last_command(m: &Metrics) -> String {
    let get = |k: &str| m.get(&format!("{LAST_COMMAND}{k}")).clone();
    match (get("Source"), get("Text")) {
        (Value::Null, _) => "-".into(),
        (source, Value::Str(text)) if !text.is_empty() => format!("{source}: {text}"),
        (source, _) => match get("Code") {
            Value::Null => source.to_string(),
            code => format!("{source}: code {code}"),
        },
    }
}

/// `done 120ms`, `error 20018 45ms`, `aborted 3ms`.
fn result(m: &Metrics) -> String {
    let get = |k: &str| m.get(&format!("{LAST_COMMAND}{k}")).clone();
    let mut s = match get("Result") {
        Value::Null => return "-".into(),
        r => r.to_string(),
    };
    if let Some(id) = get("Error Id").as_i64().filter(|id| *id != 0) {
        let _ = write!(s, " {id}");
    }
    if let Some(ms) = get("Duration").as_u64() {
        let _ = write!(s, " {ms}ms");
    }
    s
}

/// `0.4s`, `12s`, `3m05s`, `2h03m`.
pub(crate) fn age(d: Duration) -> String {
    let s = d.as_secs();
    match s {
        0..=9 => format!("{:.1}s", d.as_secs_f64()),
        10..=59 => format!("{s}s"),
        60..=3599 => format!("{}m{:02}s", s / 60, s % 60),
        _ => format!("{}h{:02}m", s / 3600, s / 60 % 60),
    }
}

/// A metric value as JSON: integers exact, a Float with its own shortest
/// digits (`0.1`, not `0.10000000149011612`), non-finite numbers as the
/// strings `NaN`, `inf`, `-inf` (JSON has no such numbers), bytes as hex.
fn value_json(v: &Value) -> Json {
    let float = |text: String, f: f64| {
        if f.is_finite() {
            Json::Float(text.parse().unwrap_or(f))
        } else {
            Json::Str(text)
        }
    };
    match v {
        Value::Null => Json::Null,
        Value::Bool(b) => Json::Bool(*b),
        Value::Int(i) => Json::Long(*i),
        Value::UInt(u) => Json::ULong(*u),
        Value::Float(f) => float(f.to_string(), f64::from(*f)),
        Value::Double(f) => float(f.to_string(), *f),
        Value::Str(s) => Json::Str(s.clone()),
        Value::Bytes(_) => Json::Str(v.to_string()),
    }
}

impl Event {
    /// The node's table row changed or may have (everything but host
    /// STATE messages).
    pub(crate) fn changes_table(&self) -> bool {
        self.outcome != Outcome::HostState
    }

    /// The `--json` line: `type`, `group`, `node`, `device`, `seq`,
    /// `timestamp`, `metrics` (value by name; the last of a name when a
    /// message has several, aliases by name when a birth named them, else
    /// `alias N`), and when present `commands` (each command event of an
    /// NDATA: the `Last Command/*` metrics without the prefix, plus its
    /// `timestamp`), `stale` (an ignored NDEATH, with `note`), `error` (a
    /// malformed message, with `topic`). `None` for a host's STATE message.
    pub(crate) fn to_json(&self, fleet: &Fleet) -> Option<Json> {
        if self.outcome == Outcome::HostState {
            return None;
        }
        let mut o = Obj::new();
        o.insert("type", self.kind.map(MsgType::as_str));
        o.insert("group", self.group.as_deref());
        o.insert("node", self.node.as_deref());
        o.insert("device", self.device.as_deref());
        let p = self.payload.as_ref();
        o.insert("seq", p.and_then(|p| p.seq).map_or(Json::Null, Json::ULong));
        o.insert(
            "timestamp",
            p.and_then(|p| p.timestamp).map_or(Json::Null, Json::ULong),
        );
        if let Some(p) = p {
            let aliases = self.aliases(fleet);
            let mut metrics = Obj::new();
            for m in &p.metrics {
                let name = match &m.id {
                    MetricId::Name(n) => n.clone(),
                    MetricId::Alias(a) => aliases
                        .and_then(|al| al.get(a).cloned())
                        .unwrap_or_else(|| format!("alias {a}")),
                    MetricId::Anonymous => continue,
                };
                metrics.insert(&name, value_json(&m.value));
            }
            o.insert("metrics", Json::Obj(metrics));
            if self.kind == Some(MsgType::NData) {
                let commands = command_events(p);
                if !commands.is_empty() {
                    o.insert("commands", Json::Arr(commands));
                }
            }
        }
        match &self.outcome {
            Outcome::StaleDeath { death, birth } => {
                o.insert("stale", true);
                let show = |v: &Option<u64>| v.map_or("none".to_string(), |v| v.to_string());
                o.insert(
                    "note",
                    format!(
                        "bdSeq {} is not the birth's {}: an earlier session's death, ignored",
                        show(death),
                        show(birth)
                    ),
                );
            }
            Outcome::Malformed(e) => {
                o.insert("topic", self.topic.as_str());
                o.insert("error", e.as_str());
            }
            Outcome::Applied | Outcome::HostState => {}
        }
        Some(Json::Obj(o))
    }

    /// The aliases the node's or device's birth gave.
    fn aliases<'f>(&self, fleet: &'f Fleet) -> Option<&'f HashMap<u64, String>> {
        let key = (self.group.clone()?, self.node.clone()?);
        let node = fleet.nodes.get(&key)?;
        match &self.device {
            None => Some(&node.metrics.aliases),
            Some(d) => node.devices.get(d).map(|d| &d.metrics.aliases),
        }
    }
}

/// The command events of an NDATA: a new event starts at each
/// `Last Command/Source`, or when a `Last Command/*` name comes again.
fn command_events(p: &Payload) -> Vec<Json> {
    let mut events: Vec<Obj> = Vec::new();
    let mut current: Option<Obj> = None;
    for m in &p.metrics {
        let MetricId::Name(name) = &m.id else {
            continue;
        };
        let Some(key) = name.strip_prefix(LAST_COMMAND) else {
            continue;
        };
        let starts = key == "Source" || current.as_ref().is_some_and(|c| c.get(key).is_some());
        if starts {
            events.extend(current.take());
        }
        let ev = current.get_or_insert_with(|| {
            let mut o = Obj::new();
            o.insert("timestamp", m.timestamp.map_or(Json::Null, Json::ULong));
            o
        });
        ev.insert(key, value_json(&m.value));
    }
    events.extend(current);
    events.into_iter().map(Json::Obj).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sparkplug::tests::{encode, metric};
    use crate::sparkplug::{WireMetric, WireValue};

    const G: &str = "spBv1.0/Plant A";

    fn s(v: &str) -> Option<WireValue> {
        Some(WireValue::String(v.into()))
    }

    fn nbirth(bd: u64, link: &str) -> Vec<u8> {
        encode(
            Some(0),
            vec![
                // As the gateway writes it: INT64 (Sparkplug 3.0's rule).
                metric("bdSeq", 4, Some(WireValue::Long(bd))),
                metric("Link/State", 12, s(link)),
                metric("Last Command/Source", 12, None),
                metric("Last Command/Result", 12, None),
            ],
        )
    }

    fn death(bd: Option<u64>) -> Vec<u8> {
        let m = bd.map(|bd| metric("bdSeq", 4, Some(WireValue::Long(bd))));
        encode(None, m.into_iter().collect())
    }

    fn dbirth(fsm: &str) -> Vec<u8> {
        encode(
            Some(1),
            vec![
                metric("FSM/Code", 3, Some(WireValue::Int(33))),
                metric("FSM/Name", 12, s(fsm)),
                metric("Error/Code", 3, Some(WireValue::Int(0))),
                metric("Error/Text", 12, None),
            ],
        )
    }

    fn command(source: &str, text: &str, result: &str, id: i32, ms: u32) -> Vec<WireMetric> {
        vec![
            metric("Last Command/Source", 12, s(source)),
            metric("Last Command/Code", 6, Some(WireValue::Int(1))),
            metric("Last Command/Text", 12, s(text)),
            metric("Last Command/Result", 12, s(result)),
            metric("Last Command/Error Id", 3, Some(WireValue::Int(id as u32))),
            metric("Last Command/Error Source", 5, Some(WireValue::Int(1))),
            // Int32, as the gateway writes it (no UInt32: SPARKPLUG.md).
            metric("Last Command/Duration", 3, Some(WireValue::Int(ms))),
        ]
    }

    /// The one row of `node` (its first line).
    fn row(f: &Fleet, now: Instant, node: &str) -> String {
        f.render(now)
            .into_iter()
            .find(|l| l.split("  ").nth(1).map(str::trim) == Some(node))
            .unwrap_or_else(|| panic!("no row for {node}: {:#?}", f.render(now)))
    }

    #[test]
    fn birth_then_the_death_of_its_session_makes_the_node_dead() {
        let t0 = Instant::now();
        let mut f = Fleet::new();
        let ev = f.apply(&format!("{G}/NBIRTH/cell-7"), &nbirth(4, "connected"), t0);
        assert_eq!(ev.outcome, Outcome::Applied);
        assert_eq!(f.counts(), (1, 0, 0));
        let r = row(&f, t0, "cell-7");
        assert!(r.contains("ALIVE") && r.contains("- (connected)"), "{r}");

        let ev = f.apply(&format!("{G}/NDEATH/cell-7"), &death(Some(4)), t0);
        assert_eq!(ev.outcome, Outcome::Applied);
        assert_eq!(f.counts(), (0, 1, 0));
        assert!(row(&f, t0, "cell-7").contains("DEAD"));
    }

    #[test]
    fn a_death_of_another_session_is_ignored() {
        let t0 = Instant::now();
        let mut f = Fleet::new();
        f.apply(&format!("{G}/NBIRTH/cell-7"), &nbirth(4, "connected"), t0);
        // The Will of the session before (bdSeq 3), delivered late; and
        // one without bdSeq: neither matches the birth's.
        let later = t0 + Duration::from_secs(30);
        for (bd, shown) in [(Some(3), "3"), (None, "none")] {
            let ev = f.apply(&format!("{G}/NDEATH/cell-7"), &death(bd), later);
            assert_eq!(
                ev.outcome,
                Outcome::StaleDeath {
                    death: bd,
                    birth: Some(4)
                }
            );
            let j = ev.to_json(&f).unwrap().to_string();
            assert!(j.contains(r#""stale":true"#), "{j}");
            assert!(
                j.contains(&format!("bdSeq {shown} is not the birth's 4")),
                "{j}"
            );
        }
        assert_eq!(f.counts(), (1, 0, 0));
        // A stale death is not the node's message: the age goes on.
        assert!(row(&f, later, "cell-7").contains("30s"));
        // Its own session's death counts; a rebirth (next bdSeq) revives.
        f.apply(&format!("{G}/NDEATH/cell-7"), &death(Some(4)), later);
        assert_eq!(f.counts(), (0, 1, 0));
        f.apply(&format!("{G}/NBIRTH/cell-7"), &nbirth(5, "down"), later);
        assert_eq!(f.counts(), (1, 0, 0));
        let ev = f.apply(&format!("{G}/NDEATH/cell-7"), &death(Some(4)), later);
        assert!(matches!(ev.outcome, Outcome::StaleDeath { .. }));
        assert_eq!(f.counts(), (1, 0, 0));
    }

    #[test]
    fn a_node_without_a_birth_seen_takes_any_death() {
        let t0 = Instant::now();
        let mut f = Fleet::new();
        let data = encode(
            Some(9),
            vec![metric("Queue/Used", 6, Some(WireValue::Int(2)))],
        );
        f.apply(&format!("{G}/NDATA/cell-8"), &data, t0);
        assert_eq!(f.counts(), (0, 0, 1));
        assert!(row(&f, t0, "cell-8").contains("NO BIRTH"));
        f.apply(&format!("{G}/NDEATH/cell-8"), &death(Some(200)), t0);
        assert_eq!(f.counts(), (0, 1, 0));
        // A death of a node never seen: known dead.
        f.apply(&format!("{G}/NDEATH/cell-9"), &death(Some(1)), t0);
        assert_eq!(f.counts(), (0, 2, 0));
    }

    #[test]
    fn device_birth_and_death_drive_the_link_and_data_updates_by_name() {
        let t0 = Instant::now();
        let mut f = Fleet::new();
        f.apply(&format!("{G}/NBIRTH/cell-7"), &nbirth(0, "connecting"), t0);
        f.apply(&format!("{G}/DBIRTH/cell-7/robot"), &dbirth("StandBy"), t0);
        let link_up = encode(Some(2), vec![metric("Link/State", 12, s("connected"))]);
        f.apply(&format!("{G}/NDATA/cell-7"), &link_up, t0);
        let r = row(&f, t0, "cell-7");
        assert!(r.contains("robot") && r.contains("up (connected)"), "{r}");
        assert!(r.contains("StandBy"), "{r}");
        assert!(!r.contains("(connecting)"), "{r}");

        let err = encode(
            Some(3),
            vec![
                metric("FSM/Name", 12, None),
                metric("FSM/Code", 3, Some(WireValue::Int(-2i32 as u32))),
                metric("Error/Code", 3, Some(WireValue::Int(20018))),
            ],
        );
        f.apply(&format!("{G}/DDATA/cell-7/robot"), &err, t0);
        let r = row(&f, t0, "cell-7");
        assert!(r.contains("-2") && r.contains("code 20018"), "{r}");
        let text = encode(Some(4), vec![metric("Error/Text", 12, s("joint 2 limit"))]);
        f.apply(&format!("{G}/DDATA/cell-7/robot"), &text, t0);
        assert!(row(&f, t0, "cell-7").contains("joint 2 limit"));

        f.apply(
            &format!("{G}/DDEATH/cell-7/robot"),
            &encode(Some(5), vec![]),
            t0,
        );
        assert!(row(&f, t0, "cell-7").contains("down (connected)"));
        f.apply(&format!("{G}/DBIRTH/cell-7/robot"), &dbirth("Moving"), t0);
        assert!(row(&f, t0, "cell-7").contains("up (connected)"));
        // The node's death takes its devices down.
        f.apply(&format!("{G}/NDEATH/cell-7"), &death(Some(0)), t0);
        let r = row(&f, t0, "cell-7");
        assert!(r.contains("DEAD") && r.contains("robot   down "), "{r}");
        assert!(!r.contains("(connected)"), "a dead node's link state: {r}");
    }

    #[test]
    fn command_events_set_the_last_command_and_each_is_in_the_json() {
        let t0 = Instant::now();
        let mut f = Fleet::new();
        f.apply(&format!("{G}/NBIRTH/cell-7"), &nbirth(0, "connected"), t0);
        assert!(row(&f, t0, "cell-7").contains("  -  "), "null command");
        // Two commands finished within a period: one NDATA.
        let mut metrics = command("Channel 0", "MoveJ,0,1,2,3,4,5,;", "done", 0, 1200);
        metrics.extend(command("Trigger 3", "", "error", 20018, 45));
        let ev = f.apply(&format!("{G}/NDATA/cell-7"), &encode(Some(1), metrics), t0);
        let r = row(&f, t0, "cell-7");
        assert!(r.contains("Trigger 3: code 1"), "the last event wins: {r}");
        assert!(r.contains("error 20018 45ms"), "{r}");

        let j: serde_json::Value =
            serde_json::from_str(&ev.to_json(&f).unwrap().to_string()).unwrap();
        assert_eq!(j["type"], "NDATA");
        assert_eq!(j["group"], "Plant A");
        assert_eq!(j["node"], "cell-7");
        assert_eq!(j["device"], serde_json::Value::Null);
        assert_eq!(j["seq"], 1);
        assert_eq!(j["metrics"]["Last Command/Source"], "Trigger 3");
        let c = j["commands"].as_array().unwrap();
        assert_eq!(c.len(), 2, "{j}");
        assert_eq!(c[0]["Source"], "Channel 0");
        assert_eq!(c[0]["Text"], "MoveJ,0,1,2,3,4,5,;");
        assert_eq!(c[0]["Result"], "done");
        assert_eq!(c[0]["Duration"], 1200);
        assert_eq!(c[0]["timestamp"], 1_700_000_000_000u64);
        assert_eq!(c[1]["Result"], "error");
        assert_eq!(c[1]["Error Id"], 20018);

        let single = command("RAW", "GrpStop,0,;", "aborted", 0, 3);
        f.apply(&format!("{G}/NDATA/cell-7"), &encode(Some(2), single), t0);
        let r = row(&f, t0, "cell-7");
        assert!(
            r.contains("RAW: GrpStop,0,;") && r.contains("aborted 3ms"),
            "{r}"
        );
    }

    #[test]
    fn a_metric_without_its_prefix_order_still_splits_events() {
        // An event without Source first: a repeated name starts the next.
        let metrics = vec![
            metric("Last Command/Result", 12, s("done")),
            metric("Last Command/Result", 12, s("error")),
            metric("Queue/Used", 6, Some(WireValue::Int(0))),
        ];
        let p = Payload::decode(&encode(Some(1), metrics)).unwrap();
        let c = command_events(&p);
        assert_eq!(c.len(), 2);
        assert_eq!(
            c[1].to_string(),
            r#"{"timestamp":1700000000000,"Result":"error"}"#
        );
    }

    #[test]
    fn malformed_messages_are_counted_and_shown_never_taken() {
        let t0 = Instant::now();
        let mut f = Fleet::new();
        f.apply(&format!("{G}/NBIRTH/cell-7"), &nbirth(0, "connected"), t0);
        let later = t0 + Duration::from_secs(3);
        let ev = f.apply(&format!("{G}/NDATA/cell-7"), b"\xff\xff\xff", later);
        assert!(
            matches!(&ev.outcome, Outcome::Malformed(e) if e.contains("not a Sparkplug B payload"))
        );
        let j = ev.to_json(&f).unwrap().to_string();
        assert!(
            j.contains(r#""type":"NDATA""#) && j.contains(r#""error":"not a Sparkplug"#),
            "{j}"
        );
        let ev = f.apply("spBv1.0/Plant A/NOTE/cell-7", &[], later);
        let j = ev.to_json(&f).unwrap().to_string();
        assert!(
            j.contains(r#""type":null"#) && j.contains("unknown message type"),
            "{j}"
        );
        assert_eq!(f.malformed(), 2);
        // Still a message on the node's topic: the age restarts.
        let r = row(&f, later + Duration::from_millis(500), "cell-7");
        assert!(
            r.ends_with(" 1") && r.contains("ALIVE") && r.contains("0.5s"),
            "{r}"
        );
        // A host's STATE message: skipped, no line.
        let ev = f.apply("spBv1.0/STATE/scada", b"{\"online\":true}", later);
        assert!(ev.to_json(&f).is_none() && !ev.changes_table());
        assert_eq!(f.malformed(), 2);
    }

    #[test]
    fn commands_to_a_node_change_nothing() {
        let t0 = Instant::now();
        let mut f = Fleet::new();
        let rebirth = encode(
            None,
            vec![metric(
                "Node Control/Rebirth",
                11,
                Some(WireValue::Boolean(true)),
            )],
        );
        let ev = f.apply(&format!("{G}/NCMD/cell-7"), &rebirth, t0);
        assert_eq!(f.counts(), (0, 0, 0));
        let j = ev.to_json(&f).unwrap().to_string();
        assert!(
            j.contains(r#""type":"NCMD""#) && j.contains(r#""Node Control/Rebirth":true"#),
            "{j}"
        );
    }

    #[test]
    fn aliases_from_the_birth_name_data_metrics() {
        let t0 = Instant::now();
        let mut f = Fleet::new();
        let mut m = metric("FSM/Name", 12, s("StandBy"));
        m.alias = Some(7);
        f.apply(&format!("{G}/NBIRTH/cell-7"), &nbirth(0, "connected"), t0);
        f.apply(
            &format!("{G}/DBIRTH/cell-7/robot"),
            &encode(Some(1), vec![m]),
            t0,
        );
        let by_alias = WireMetric {
            name: None,
            alias: Some(7),
            ..metric("", 12, s("Moving"))
        };
        let unknown = WireMetric {
            name: None,
            alias: Some(8),
            ..metric("", 11, Some(WireValue::Boolean(false)))
        };
        let ev = f.apply(
            &format!("{G}/DDATA/cell-7/robot"),
            &encode(Some(2), vec![by_alias, unknown]),
            t0,
        );
        assert!(row(&f, t0, "cell-7").contains("Moving"));
        let j = ev.to_json(&f).unwrap().to_string();
        assert!(
            j.contains(r#""FSM/Name":"Moving""#) && j.contains(r#""alias 8":false"#),
            "{j}"
        );
    }

    #[test]
    fn values_in_json_keep_their_digits() {
        assert_eq!(value_json(&Value::Float(0.1)).to_string(), "0.1");
        assert_eq!(value_json(&Value::Float(-12.75)).to_string(), "-12.75");
        assert_eq!(value_json(&Value::Double(1e-7)).to_string(), "0.0000001");
        assert_eq!(value_json(&Value::Float(f32::NAN)).to_string(), r#""NaN""#);
        assert_eq!(
            value_json(&Value::Double(f64::NEG_INFINITY)).to_string(),
            r#""-inf""#
        );
        assert_eq!(
            value_json(&Value::UInt(u64::MAX)).to_string(),
            "18446744073709551615"
        );
        assert_eq!(
            value_json(&Value::Int(i64::MIN)).to_string(),
            "-9223372036854775808"
        );
        assert_eq!(value_json(&Value::Null).to_string(), "null");
        assert_eq!(
            value_json(&Value::Bytes(vec![0, 255])).to_string(),
            r#""00ff""#
        );
    }

    #[test]
    fn rows_are_sorted_long_text_is_cut_and_further_devices_get_lines() {
        let t0 = Instant::now();
        let mut f = Fleet::new();
        for node in ["b", "a"] {
            f.apply(&format!("{G}/NBIRTH/{node}"), &nbirth(0, "connected"), t0);
        }
        f.apply(&format!("{G}/DBIRTH/a/robot"), &dbirth("StandBy"), t0);
        f.apply(&format!("{G}/DBIRTH/a/arm2"), &dbirth("Error"), t0);
        let long = "x".repeat(100);
        let text = encode(Some(3), vec![metric("Error/Text", 12, s(&long))]);
        f.apply(&format!("{G}/DDATA/a/robot"), &text, t0);
        let lines = f.render(t0 + Duration::from_secs(125));
        assert_eq!(lines.len(), 4, "{lines:#?}");
        assert!(
            lines[0].starts_with("GROUP    NODE  STATUS  DEVICE"),
            "{}",
            lines[0]
        );
        assert!(
            lines[1].contains("arm2") && lines[1].contains("2m05s"),
            "{}",
            lines[1]
        );
        assert!(
            lines[2].trim_start().starts_with("robot")
                && lines[2].contains(&format!("{}~", "x".repeat(31)))
        );
        assert!(!lines[2].contains(&"x".repeat(33)));
        assert!(lines[3].contains("  b  "));
    }

    #[test]
    fn ages() {
        assert_eq!(age(Duration::from_millis(400)), "0.4s");
        assert_eq!(age(Duration::from_secs(12)), "12s");
        assert_eq!(age(Duration::from_secs(185)), "3m05s");
        assert_eq!(age(Duration::from_secs(7380)), "2h03m");
    }
}
