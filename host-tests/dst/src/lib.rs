//! Deterministic simulation testing of the gateway (the method FoundationDB
//! and TigerBeetle rely on).
//!
//! A seed makes a scenario: a random start configuration, a robot with
//! random timing and random faults (no reply, late reply, garbage, a reply
//! naming another command, `Fail`, dropped connections, errors, emergency
//! stops and the safety guard during motions, a controller that goes off
//! the network, a new controller connection in listen mode), and a sequence
//! of random PLC actions from three Modbus sessions (both channels, RAW,
//! trigger entries and bits, configuration edits and commands, heartbeats,
//! sessions closing and opening). The real gateway future runs it in
//! virtual time ([`hans_gateway::testkit`]), and [`Checker`] checks the
//! invariants after every action and every step of time:
//!
//! * every command the PLC fired ends in exactly one of Done, Error,
//!   CommandAborted, or is still Busy while the gateway has it (queued, in
//!   flight, its motion running); at the end, with the faults off, nothing
//!   stays Busy;
//! * the outputs follow the PLCopen rules (Busy visible at once, a rising
//!   edge while Busy ignored, outputs cleared when Execute falls, status
//!   words one of the valid combinations);
//! * no request is sent twice, nothing is sent after its command ended
//!   (so no motion goes out after a Stop aborted it), at most one request is
//!   in flight on a connection;
//! * jogs (codes 60-91): a keep-alive (`LongMoveEvent`) reaches the robot
//!   only while a jog command is Busy, never later than one reply time
//!   after its Execute fell, and never once the PLC heartbeat has been
//!   gone for the watch period; after Execute falls the stop
//!   (`LongJog…,0`) reaches the robot within one reply time unless the
//!   command ended otherwise or the link was lost;
//! * the queue's bounds (8 + the urgent lane; 39600 exactly when the
//!   ordinary queue is full, never for urgent commands), 39500 exactly when
//!   the link is not up, and the link-loss codes (39601, 39503, 39505) only
//!   when the link was lost.
//!
//! * EtherNet/IP (a third of the seeds, `enip.rs`): a Logix PLC opens an
//!   exclusive-owner class 1 connection at a random RPI, fires both
//!   channels' commands through the output assembly, closes it or falls
//!   silent. Its commands obey every rule above, exactly as Modbus's; the
//!   input assembly shows what the registers show; while it owns the
//!   command inputs every Modbus write to them is refused whole
//!   (exception 01), and an owner Forward_Open is admitted exactly when no
//!   command another master fired is Busy; when its connection closes or
//!   times out during a motion the watchdog is on for, the watchdog trips
//!   at once (the lost heartbeat: its stop, or its pause, or its report).
//!
//! A failure names its seed and step and replays exactly: `hans-dst --seed
//! N` (see the README).

use std::collections::BTreeMap;
use std::fmt::Write as _;

use embassy_time::{Duration, Instant};
use hans_gateway::config::{Config, WatchdogAction, WordOrder};
use hans_gateway::error::{ErrorSource, GatewayError, Outcome};
use hans_gateway::job::{Source, QUEUE_DEPTH, URGENT_DEPTH};
use hans_gateway::registers::{self as r, view};
use hans_gateway::state::{LinkState, Model, Phase};
use hans_gateway::testkit::broker::BrokerMode;
use hans_gateway::testkit::plc::{pdu, Answer};
use hans_gateway::testkit::rng::Rng;
use hans_gateway::testkit::robot::{Model as RobotModel, RandomFaults};
use hans_gateway::testkit::world::{MemStorage, World, WorldConfig};
use hans_gateway::{JOG_HEARTBEAT, JOG_KEEP_ALIVE as KEEP_ALIVE};

mod enip;

/// What one scenario did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// Scenarios run.
    pub scenarios: u64,
    /// PLC commands fired (rising edges of Execute and trigger bits).
    pub commands: u64,
    /// Of them, how many ended Done, Error, CommandAborted.
    pub done: u64,
    /// See `done`.
    pub errors: u64,
    /// See `done`.
    pub aborted: u64,
    /// Requests the robot received.
    pub requests: u64,
    /// Actions (PLC and robot) taken.
    pub actions: u64,
    /// Virtual time simulated, in milliseconds.
    pub virtual_ms: u64,
    /// Commands fired through the EtherNet/IP output assembly.
    pub enip_commands: u64,
    /// EtherNet/IP owner connections that closed or timed out during a
    /// watched motion (each one a watchdog trip checked).
    pub enip_lost: u64,
}

impl Stats {
    /// Adds `o`.
    pub fn add(&mut self, o: &Stats) {
        self.scenarios += o.scenarios;
        self.commands += o.commands;
        self.done += o.done;
        self.errors += o.errors;
        self.aborted += o.aborted;
        self.requests += o.requests;
        self.actions += o.actions;
        self.virtual_ms += o.virtual_ms;
        self.enip_commands += o.enip_commands;
        self.enip_lost += o.enip_lost;
    }
}

/// A broken invariant: where, and the last actions before it.
#[derive(Clone, Debug)]
pub struct Failure {
    /// The scenario's seed.
    pub seed: u64,
    /// The action after which it was found.
    pub step: usize,
    /// What broke.
    pub what: String,
    /// The scenario's actions up to there (the last 40).
    pub trace: Vec<String>,
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "seed {} step {}: {}", self.seed, self.step, self.what)?;
        for t in &self.trace {
            writeln!(f, "    {t}")?;
        }
        Ok(())
    }
}

/// What the checker knows of one source's current command.
#[derive(Clone, Copy, Debug, Default)]
struct Track {
    /// The command is a motion (may end in CommandAborted, 39602, source 2).
    motion: bool,
    /// It is a bring-up step (may end in 39605-39607).
    bring_up: bool,
    /// It is a `GrpStop` (its Done aborts the motions waiting).
    stop: bool,
    /// It is a jog (codes 60-71, 80-91).
    jog: bool,
    /// Its Execute fell while it ran (once is what stops it).
    released: bool,
    /// Messages it may send.
    steps: u8,
    /// The link was lost (or reset) since it was fired.
    link_lost: bool,
    /// Which firing this is (counted per scenario).
    id: u64,
    /// Phase and sends at the last check.
    phase: Phase,
    sends: u8,
}

/// Checks the invariants of the module documentation on a running world.
pub struct Checker {
    tracks: BTreeMap<u16, Track>,
    losses: u16,
    /// The robot's motion at the last check (its start).
    robot_motion: Option<Instant>,
    /// Outcomes seen: Done, Error, CommandAborted.
    ended: [u64; 3],
    /// Error outcomes seen, by ErrorID.
    pub codes: BTreeMap<i32, u64>,
    /// Firings so far, and those Busy at the last check.
    firings: u64,
    busy: Vec<(u16, u64)>,
    watchdog: bool,
    /// The robot's requests already looked at.
    log_seen: usize,
    /// Jogs whose Execute fell while they were Busy: source, firing, when,
    /// by when the stop must have reached the robot, and whether the jog
    /// ran then (else it was queued: it must not start, or must stop).
    releases: Vec<(u16, u64, Instant, Instant, bool)>,
    /// The configuration's reply timeout and the heartbeat period a jog
    /// needs (ms), the longest since start (a change applies to what is
    /// sent after it).
    reply_timeout_ms: u16,
    jog_period_ms: u16,
    /// When the robot last accepted the start of a jog (the heartbeat is
    /// counted from the later of it and the last beat).
    jog_start: Instant,
    /// At the last check: the EtherNet/IP owner's connection, the active
    /// motion and the watchdog trips when it started.
    enip_owner: Option<u32>,
    motion: Option<(Source, u16)>,
    /// The watchdog must have tripped (more than this many) by then, unless
    /// this motion ended otherwise: the owner's connection closed during a
    /// watched motion.
    lost_by: Option<(Instant, u16, Source)>,
    /// How many times that was checked.
    enip_lost: u64,
}

/// The heartbeat period a jog needs with `CFG_WATCHDOG_MS` = `watchdog_ms`.
fn jog_period(watchdog_ms: u16) -> u16 {
    if watchdog_ms == 0 {
        JOG_HEARTBEAT
    } else {
        watchdog_ms
    }
}

fn key(s: Source) -> u16 {
    s.code()
}

/// The valid `CHn_STATUS` / `RAW_STATUS` words.
const VALID_STATUS: [u16; 7] = [
    0,
    r::ST_BUSY | r::ST_QUEUED,
    r::ST_BUSY,
    r::ST_BUSY | r::ST_ACTIVE,
    r::ST_DONE,
    r::ST_ERROR,
    r::ST_ABORTED,
];

impl Checker {
    /// A checker for `w` as it is now.
    pub fn new(w: &World) -> Self {
        let (losses, watchdog) = w.model(|m| (m.link.losses, m.config.active.watchdog_ms != 0));
        Checker {
            tracks: BTreeMap::new(),
            losses,
            robot_motion: None,
            ended: [0; 3],
            codes: BTreeMap::new(),
            firings: 0,
            busy: Vec::new(),
            watchdog,
            log_seen: w.robot.log.len(),
            releases: Vec::new(),
            reply_timeout_ms: w.model(|m| m.config.active.reply_timeout_ms),
            jog_period_ms: jog_period(w.model(|m| m.config.active.watchdog_ms)),
            jog_start: Instant::from_ticks(0),
            enip_owner: None,
            motion: None,
            lost_by: None,
            enip_lost: 0,
        }
    }

    /// The EtherNet/IP rules of the module documentation: a closed owner
    /// connection during a watched motion trips the watchdog at once.
    fn check_enip(&mut self, w: &World) -> Result<(), String> {
        let now = w.now();
        let (owner, active, trips, watch, lost) = w.model(|m| {
            (
                m.owner.enip_owner.map(|o| o.connection),
                m.active_motion,
                m.plc.watchdog_trips,
                m.config.active.watchdog_ms != 0,
                m.plc.lost,
            )
        });
        if let Some((by, before, s)) = self.lost_by {
            if trips != before || active != Some(s) {
                self.lost_by = None;
            } else if now > by {
                let state = w.model(|m| {
                    format!(
                        "active {:?} ({:?}), lost {}, tripped {}, last beat {} ms",
                        m.active_motion,
                        m.active_motion.and_then(|s| m.handshake(s).copied()),
                        m.plc.lost,
                        m.plc.watchdog_tripped,
                        m.plc.last_beat.as_millis()
                    )
                });
                return Err(format!(
                    "the EtherNet/IP owner's connection closed during a watched motion; no watchdog trip by {} ms: {state}",
                    by.as_millis()
                ));
            }
        }
        // The owner's connection is gone; the motion that ran before runs
        // still (so it ran when the connection closed), watched, not yet
        // tripped for: the watchdog must act (its stop, pause or report).
        if let (Some(_), None, Some((s, at_start))) = (self.enip_owner, owner, self.motion) {
            if watch && active == Some(s) && at_start == trips {
                // At once the heartbeat is lost (the engine trips on it
                // when it next decides).
                if !lost {
                    return Err(format!(
                        "the EtherNet/IP owner's connection closed during {s:?}'s watched motion: the heartbeat is not lost"
                    ));
                }
                // At once: when the engine next decides, which a request in
                // flight may delay by its reply timeout.
                let by = now + ms(u64::from(self.reply_timeout_ms) + 20);
                self.lost_by = Some((by, trips, s));
                self.enip_lost += 1;
            }
        }
        self.enip_owner = owner;
        self.motion = match (active, self.motion) {
            (Some(s), Some((was, t))) if s == was => Some((s, t)),
            (Some(s), _) => Some((s, trips)),
            (None, _) => None,
        };
        Ok(())
    }

    /// The configuration changed (watchdog, reply timeout).
    fn config_changed(&mut self, w: &World) {
        let (watchdog_ms, reply) = w.model(|m| {
            (
                m.config.active.watchdog_ms,
                m.config.active.reply_timeout_ms,
            )
        });
        self.watchdog = watchdog_ms != 0;
        // A timeout can only have grown or shrunk for requests sent after
        // the change: keep the larger for the bounds on earlier ones.
        self.reply_timeout_ms = self.reply_timeout_ms.max(reply);
        self.jog_period_ms = self.jog_period_ms.max(jog_period(watchdog_ms));
    }

    /// The PLC let go of `source`'s Execute at `now`: if it is a jog that
    /// runs, its stop must follow.
    fn released(&mut self, source: Source, w: &World) {
        let Some(t) = self.tracks.get_mut(&key(source)) else {
            return;
        };
        let (busy, moving) = w.model(|m| {
            (
                m.is_busy(source),
                m.handshake(source).map(|h| h.phase) == Some(Phase::Moving),
            )
        });
        if t.jog && busy && !t.released {
            t.released = true;
            let now = w.now();
            let by = now + ms(u64::from(self.reply_timeout_ms) + 20);
            self.releases.push((key(source), t.id, now, by, moving));
        }
    }

    /// The jog invariants of the module documentation, on the robot's
    /// requests since the last check.
    fn check_jogs(&mut self, w: &World) -> Result<(), String> {
        let now = w.now();
        let log = &w.robot.log;
        let new = log.get(self.log_seen..).unwrap_or(&[]);
        self.log_seen = log.len();
        let (last_beat, jog_busy) = w.model(|m| {
            let busy = Source::all()
                .any(|s| m.is_busy(s) && self.tracks.get(&key(s)).is_some_and(|t| t.jog));
            (m.plc.last_beat, busy)
        });
        let period = self.jog_period_ms;
        let reply = ms(u64::from(self.reply_timeout_ms));
        for m in new {
            if m.text.starts_with("LongJog") && m.text.ends_with(",1,;") {
                self.jog_start = m.at;
            }
            if m.text.starts_with("LongMoveEvent") {
                if !jog_busy && now.saturating_duration_since(m.at) > reply {
                    return Err(format!(
                        "a keep-alive at {} ms with no jog Busy",
                        m.at.as_millis()
                    ));
                }
                if let Some((k, ..)) = self
                    .releases
                    .iter()
                    .find(|(_, _, at, _, _)| m.at > *at + reply + KEEP_ALIVE)
                {
                    return Err(format!(
                        "a keep-alive at {} ms, after source {k}'s jog was released",
                        m.at.as_millis()
                    ));
                }
                // The watchdog is judged before every keep-alive: none may
                // leave once the period has passed (margin: the robot's
                // reply latency, counted twice).
                let from = last_beat.max(self.jog_start);
                let gone = from + ms(u64::from(period)) + ms(10);
                if m.at > gone {
                    return Err(format!(
                        "a keep-alive at {} ms, the PLC heartbeat gone since {} ms",
                        m.at.as_millis(),
                        last_beat.as_millis()
                    ));
                }
            }
        }
        let tracks = &self.tracks;
        let mut kept = Vec::new();
        for (k, id, at, by, ran) in self.releases.drain(..) {
            let after = |suffix: &str| {
                log.iter().any(|m| {
                    m.at >= at && m.text.starts_with("LongJog") && m.text.ends_with(suffix)
                })
            };
            // A jog released while queued must not start (or must stop).
            let stopped = after(",0,;") || (!ran && !after(",1,;"));
            let t = tracks.get(&k).filter(|t| t.id == id);
            let excused = t.is_none_or(|t| {
                t.link_lost
                    || matches!(t.phase, Phase::Ended(Outcome::Aborted | Outcome::Error(..)))
            });
            if stopped || excused {
                continue;
            }
            if now > by {
                return Err(format!(
                    "source {k}: jog released at {} ms, no stop by {} ms",
                    at.as_millis(),
                    by.as_millis()
                ));
            }
            kept.push((k, id, at, by, ran));
        }
        self.releases = kept;
        Ok(())
    }

    /// The PLC is about to fire `source` with a command of this kind.
    fn fired(&mut self, source: Source, kind: Kind) {
        self.firings += 1;
        self.tracks.insert(
            key(source),
            Track {
                motion: kind.motion,
                bring_up: kind.bring_up,
                stop: kind.stop,
                jog: kind.jog,
                released: false,
                steps: kind.steps,
                id: self.firings,
                link_lost: false,
                phase: Phase::Queued,
                sends: 0,
            },
        );
    }

    /// The outcome (or phase) a fired command showed at its rising edge:
    /// judged there, by [`Scenario::fire`].
    fn observed(&mut self, source: Source, phase: Phase, sends: u8) {
        self.ended[1] += 1;
        if let Phase::Ended(Outcome::Error(_, c)) = phase {
            *self.codes.entry(c).or_default() += 1;
        }
        if let Some(t) = self.tracks.get_mut(&key(source)) {
            t.phase = phase;
            t.sends = sends;
        }
    }

    /// Checks every invariant on the state now.
    pub fn check(&mut self, w: &World) -> Result<(), String> {
        if let Some(v) = w.robot.violations.first() {
            return Err(format!("robot: {v}"));
        }
        let now = w.now();
        let tracks = &mut self.tracks;
        let (losses, up) = w.model(|m| (m.link.losses, m.link.state == LinkState::Connected));
        let lost = losses != self.losses || !up;
        self.losses = losses;
        // A link loss ends every command that was Busy before it: none of
        // them is kept for the next connection.
        if lost {
            let survivor = self.busy.iter().find(|(k, id)| {
                tracks.get(k).is_some_and(|t| t.id == *id)
                    && w.model(|m| Source::all().any(|s| key(s) == *k && m.is_busy(s)))
            });
            if let Some((k, _)) = survivor {
                return Err(format!("source {k}: Busy across a link loss"));
            }
        }
        let watchdog = self.watchdog;
        let robot_motion = w.robot.model.motion_start();
        let robot_motion_before = core::mem::replace(&mut self.robot_motion, robot_motion);
        // MC_Stop: a Stop that is Done now aborted every motion that waited
        // in the queue at the last check (none of them may run or be Done).
        let stopped = w.model(|m| {
            tracks.iter().any(|(k, t)| {
                t.stop
                    && !matches!(t.phase, Phase::Ended(_))
                    && Source::all().any(|s| {
                        key(s) == *k
                            && m.handshake(s).map(|h| h.phase) == Some(Phase::Ended(Outcome::Done))
                    })
            })
        });
        let waiting: Vec<u16> = if stopped {
            tracks
                .iter()
                .filter(|(_, t)| t.motion && t.phase == Phase::Queued && t.sends == 0)
                .map(|(k, _)| *k)
                .collect()
        } else {
            Vec::new()
        };
        let ended = &mut self.ended;
        let codes = &mut self.codes;
        w.model(|m| {
            check_views(m, now)?;
            check_queue(m)?;
            for source in Source::all() {
                let Some(h) = m.handshake(source).copied() else {
                    continue;
                };
                let Some(t) = tracks.get_mut(&key(source)) else {
                    if h.phase != Phase::Idle {
                        return Err(format!("{source:?}: {:?} though never fired", h.phase));
                    }
                    continue;
                };
                if lost && matches!(t.phase, Phase::Queued | Phase::Running | Phase::Moving) {
                    t.link_lost = true;
                }
                if h.sends > t.steps {
                    return Err(format!(
                        "{source:?}: sent {} times, {} steps",
                        h.sends, t.steps
                    ));
                }
                if matches!(t.phase, Phase::Ended(_)) && h.sends != t.sends {
                    return Err(format!("{source:?}: sent after it ended ({:?})", t.phase));
                }
                if h.phase != t.phase {
                    // A motion is Done only once the robot has finished it: the
                    // robot is idle, or in a motion it did not run at the
                    // last check (the next one, taken since).
                    // (A jog released before it started is Done unsent.)
                    if t.motion
                        && h.phase == Phase::Ended(Outcome::Done)
                        && !(t.jog && h.sends == 0)
                    {
                        if let Some(start) = robot_motion {
                            if robot_motion_before == Some(start) {
                                return Err(format!(
                                    "{source:?}: Done while the robot still runs its motion (since {} ms)",
                                    start.as_millis()
                                ));
                            }
                        }
                    }
                    if let Phase::Ended(o) = h.phase {
                        check_outcome(source, t, o, h.sends, watchdog)?;
                        if let Outcome::Error(_, c) = o {
                            *codes.entry(c).or_default() += 1;
                        }
                        ended[match o {
                            Outcome::Done => 0,
                            Outcome::Error(..) => 1,
                            Outcome::Aborted => 2,
                        }] += 1;
                    }
                }
                if waiting.contains(&key(source))
                    && !matches!(
                        h.phase,
                        Phase::Ended(Outcome::Aborted | Outcome::Error(ErrorSource::Gateway, _))
                    )
                {
                    return Err(format!(
                        "{source:?}: a motion that waited when a Stop was Done is {:?}, not CommandAborted",
                        h.phase
                    ));
                }
                t.phase = h.phase;
                t.sends = h.sends;
                match h.phase {
                    Phase::Queued if !m.queue.sources().any(|s| s == source) => {
                        return Err(format!("{source:?}: Queued but not in the queue"));
                    }
                    Phase::Moving if m.active_motion != Some(source) => {
                        return Err(format!("{source:?}: Moving but not the active motion"));
                    }
                    _ => {}
                }
            }
            if let Some(s) = m.active_motion {
                if m.handshake(s).map(|h| h.phase) != Some(Phase::Moving) {
                    return Err(format!("active motion {s:?} is not Moving"));
                }
            }
            Ok(())
        })?;
        let busy = w.model(|m| {
            Source::all()
                .filter(|s| m.is_busy(*s))
                .filter_map(|s| self.tracks.get(&key(s)).map(|t| (key(s), t.id)))
                .collect()
        });
        self.busy = busy;
        self.check_jogs(w)?;
        self.check_enip(w)
    }
}

/// The register view agrees with the model and shows only valid words.
fn check_views(m: &Model, now: Instant) -> Result<(), String> {
    for (base, name) in [
        (r::channel_base(0) + r::CH_STATUS, "CH0_STATUS"),
        (r::channel_base(1) + r::CH_STATUS, "CH1_STATUS"),
        (r::RAW_STATUS, "RAW_STATUS"),
    ] {
        let st = view::read(m, base, now);
        if !VALID_STATUS.contains(&st) {
            return Err(format!("{name} = {st:#06x}"));
        }
    }
    let bits =
        [r::TRIG_BUSY, r::TRIG_DONE, r::TRIG_ERROR, r::TRIG_ABORTED].map(|a| view::read(m, a, now));
    for i in 0..16 {
        let n = bits.iter().filter(|b| *b & (1 << i) != 0).count();
        if n > 1 {
            return Err(format!(
                "trigger {i}: {n} of BUSY/DONE/ERROR/ABORTED at once"
            ));
        }
    }
    // The input assembly is one more view of the same state: each
    // channel's status, sequence echo, ErrorID and source as the registers
    // (judged where the adapter runs: the scenarios without it spend
    // nothing on it).
    if m.config.active.enip_enabled {
        check_assembly(m, now)?;
    }
    let used = view::read(m, r::STATUS_QUEUE_USED, now);
    if usize::from(used) != m.queue.len() {
        return Err(format!("QUEUE_USED {used}, queue {}", m.queue.len()));
    }
    Ok(())
}

/// The input assembly shows what the registers show.
fn check_assembly(m: &Model, now: Instant) -> Result<(), String> {
    let mut image = [0u8; hans_gateway::enip::assembly::SIZE];
    hans_gateway::enip::assembly::encode_input(m, now, &mut image);
    let word = |at: usize| u16::from_le_bytes([image[at], image[at + 1]]);
    for (ch, at) in [
        (0, hans_gateway::enip::assembly::input::CH0),
        (1, hans_gateway::enip::assembly::input::CH1),
    ] {
        let base = r::channel_base(ch);
        let id = i32::from_le_bytes([image[at + 4], image[at + 5], image[at + 6], image[at + 7]]);
        let regs = (
            view::read(m, base + r::CH_STATUS, now),
            view::read(m, base + r::CH_SEQ_ECHO, now),
            view::read(m, base + r::CH_ERROR_ID, now),
            view::read(m, base + r::CH_ERROR_ID + 1, now),
            view::read(m, base + r::CH_ERROR_SOURCE, now),
        );
        // The registers' ErrorID in the configured word order.
        let (hi, lo) = ((id as u32 >> 16) as u16, id as u16);
        let (first, second) = match m.config.active.word_order {
            WordOrder::HighFirst => (hi, lo),
            WordOrder::LowFirst => (lo, hi),
        };
        let ids = (word(at), word(at + 2), first, second, word(at + 8));
        if regs != ids {
            return Err(format!(
                "channel {ch}: the input assembly shows {ids:?}, the registers {regs:?}"
            ));
        }
    }
    Ok(())
}

fn check_queue(m: &Model) -> Result<(), String> {
    if m.queue.len() > QUEUE_DEPTH + URGENT_DEPTH {
        return Err(format!("queue holds {}", m.queue.len()));
    }
    let mut seen = Vec::new();
    for s in m.queue.sources() {
        if seen.contains(&s) {
            return Err(format!("{s:?} twice in the queue"));
        }
        seen.push(s);
    }
    Ok(())
}

/// An outcome must be one the situation allows.
fn check_outcome(
    source: Source,
    t: &Track,
    o: Outcome,
    sends: u8,
    watchdog: bool,
) -> Result<(), String> {
    let bad = |why: &str| Err(format!("{source:?}: {o:?} {why} ({t:?})"));
    match o {
        Outcome::Done => Ok(()),
        Outcome::Aborted if !t.motion => bad("but not a motion"),
        Outcome::Aborted => Ok(()),
        Outcome::Error(ErrorSource::RobotFail, _) => Ok(()),
        Outcome::Error(ErrorSource::RobotMotion, _) if !t.motion => bad("but not a motion"),
        Outcome::Error(ErrorSource::RobotMotion, _) => Ok(()),
        Outcome::Error(ErrorSource::Gateway, code) => match GatewayError::from_code(code) {
            None => bad("unknown gateway code"),
            Some(GatewayError::NotConnected | GatewayError::QueueFull) => {
                bad("after the command was queued (only at the rising edge)")
            }
            Some(
                GatewayError::LinkLost | GatewayError::ReplyTimeout | GatewayError::ReplyMismatch,
            ) if !t.link_lost => bad("without a link loss"),
            // The cause goes to the command whose own request failed.
            Some(GatewayError::ReplyTimeout | GatewayError::ReplyMismatch) if sends == 0 => {
                bad("but its request was never sent")
            }
            Some(GatewayError::Watchdog) if !(t.motion && (watchdog || t.jog)) => {
                bad("without a watched motion")
            }
            Some(
                GatewayError::EmergencyStop
                | GatewayError::SafetyGuard
                | GatewayError::RobotErrorNoCode,
            ) if !(t.motion || t.bring_up) => bad("but neither a motion nor a bring-up step"),
            Some(GatewayError::StateNotReached) if !t.bring_up => bad("but not a bring-up step"),
            Some(GatewayError::NotSupported) if !t.jog => bad("but not a jog"),
            Some(GatewayError::ConnectFailed) => bad("(a link code only)"),
            Some(_) => Ok(()),
        },
    }
}

/// The texts RAW and the trigger entries send: motions, outputs, urgent
/// commands (some with blanks), reads, an unknown name, and bad ones.
const TEXTS: &[&str] = &[
    "MoveRelJ,0,1,1,5,;",
    "MoveRelL,0,2,0,10,0,;",
    "WayPoint,0,420,0,445,180,0,180,0,0,90,0,90,0,TCP,Base,50,360,0,1,0,0,0,0,w1,;",
    "SetBoxDO,1,1,;",
    "SetBoxDO,2,0",
    "SetOverride,0,0.5,;",
    "SetEndDO,0,1,1,;",
    "GrpStop,0,;",
    "GrpInterrupt,0,;",
    "GrpContinue,0,;",
    "GrpReset,0,;",
    " GrpStop , 0 ,;",
    "StopScript,;",
    "ReadActPos,0,;",
    "ReadBoxDI,0,1,;",
    "ReadCurFSM,0,;",
    "ReadVersion,;",
    "GrpEnable,0,;",
    "GrpStop,0,;GrpReset,0,;",
    "MoveRelJ,0,abc,;",
    "",
];

fn text_words(t: &str, max: usize) -> Vec<u16> {
    let b = t.as_bytes();
    (0..max.min(b.len() / 2 + 1))
        .map(|i| {
            let at = |k: usize| u16::from(b.get(k).copied().unwrap_or(0));
            (at(2 * i) << 8) | at(2 * i + 1)
        })
        .collect()
}

/// What kind of command the PLC fires, for the checker.
#[derive(Clone, Copy, Debug)]
struct Kind {
    motion: bool,
    bring_up: bool,
    urgent: bool,
    stop: bool,
    jog: bool,
    steps: u8,
}

/// The kind of a RAW or trigger text.
fn text_kind(t: &str) -> Kind {
    let name = t.split(',').next().unwrap_or("").trim();
    Kind {
        motion: matches!(name, "MoveRelJ" | "MoveRelL" | "WayPoint"),
        bring_up: matches!(name, "GrpEnable"),
        urgent: matches!(
            name,
            "GrpStop"
                | "GrpInterrupt"
                | "GrpContinue"
                | "GrpReset"
                | "GrpDisable"
                | "StopScript"
                | "PauseScript"
                | "ContinueScript"
        ),
        stop: name == "GrpStop",
        jog: false,
        steps: 1,
    }
}

fn f32_words(v: f32, order: WordOrder) -> [u16; 2] {
    let b = v.to_bits();
    let (hi, lo) = ((b >> 16) as u16, b as u16);
    match order {
        WordOrder::HighFirst => [hi, lo],
        WordOrder::LowFirst => [lo, hi],
    }
}

/// A scenario in progress.
pub struct Scenario {
    /// Its seed.
    pub seed: u64,
    rng: Rng,
    /// The world.
    pub world: World,
    /// The invariant checker.
    pub checker: Checker,
    trace: Vec<String>,
    heartbeat: u16,
    seq: u16,
    /// The robot comes back on the network then.
    online_at: Option<Instant>,
    /// The EtherNet/IP PLC, in a third of the seeds.
    enip: Option<enip::EnipPlc>,
    /// What it did.
    pub stats: Stats,
}

fn ms(v: u64) -> Duration {
    Duration::from_millis(v)
}

impl Scenario {
    /// The scenario of `seed`, started (the gateway connected).
    pub fn new(seed: u64) -> Self {
        Scenario::with_broker(seed, None)
    }

    /// The scenario of `seed` with the gateway's MQTT telemetry on, to a
    /// broker doing `broker` (`None`: telemetry off). The broker draws
    /// nothing from the scenario's random numbers: the same seed makes the
    /// same PLC actions and robot faults whatever it does.
    pub fn with_broker(seed: u64, broker: Option<BrokerMode>) -> Self {
        let mut rng = Rng::new(seed);
        let watchdog_ms = if rng.chance(300) {
            50 + rng.below(950) as u16
        } else {
            0
        };
        let config = Config {
            poll_ms: 10 + rng.below(91) as u16,
            reply_timeout_ms: 50 + rng.below(1950) as u16,
            word_order: if rng.chance(500) {
                WordOrder::HighFirst
            } else {
                WordOrder::LowFirst
            },
            watchdog_ms,
            watchdog_action: *rng.pick(&[
                WatchdogAction::ReportOnly,
                WatchdogAction::Stop,
                WatchdogAction::Pause,
            ]),
            wait_blending_done: rng.chance(200),
            wait_in_position: rng.chance(200),
            start_grace_ms: rng.below(400) as u16,
            auto_reset: rng.chance(300),
            enip_enabled: enip::enabled(seed),
            ..Config::default()
        };
        let config = enip::watched(seed, config);
        let mut world = World::new(WorldConfig {
            seed: rng.next_u64(),
            listen_mode: rng.chance(200),
            config,
            plcs: 3,
            storage: MemStorage::default(),
            web: false,
            recovery: false,
            setup_code: None,
            broker,
            self_check_fails: false,
        });
        let mut p = || rng.below(12) as u32;
        world.robot.faults = RandomFaults {
            no_reply: p() / 3,
            late: p() / 4,
            garbage: p() / 3,
            wrong_name: p() / 3,
            fail: p() * 3,
            drop: p() / 3,
            motion_error: p() * 4,
            estop: p() * 2,
            guard: p() * 2,
        };
        world.robot.latency = Duration::from_micros(100 + rng.below(3000));
        world.robot.model = if rng.chance(100) {
            RobotModel::powered_off()
        } else {
            RobotModel::default()
        };
        world.robot.model.flag_lag = ms(rng.below(80));
        world.robot.model.step_time = ms(20 + rng.below(500));
        world.run_for(ms(300));
        // Most trigger entries hold a message from the start.
        for n in 0..16 {
            if rng.chance(800) {
                let text = *rng.pick(TEXTS);
                let mut words = text_words(text, 96);
                words.resize(words.len().max(1), 0);
                world.request(0, &pdu::write(r::trigger_text(n), &words));
            }
        }
        let checker = Checker::new(&world);
        Scenario {
            seed,
            rng,
            world,
            checker,
            trace: Vec::new(),
            heartbeat: 0,
            seq: 0,
            online_at: None,
            enip: enip::enabled(seed).then(enip::EnipPlc::default),
            stats: Stats {
                scenarios: 1,
                ..Stats::default()
            },
        }
    }

    fn note(&mut self, what: String) {
        let t = self.world.now().as_millis();
        self.trace.push(format!("{t:>8} ms  {what}"));
        if self.trace.len() > 40 {
            self.trace.remove(0);
        }
    }

    fn fail(&self, step: usize, what: String) -> Failure {
        Failure {
            seed: self.seed,
            step,
            what,
            trace: self.trace.clone(),
        }
    }

    fn plc(&mut self) -> usize {
        self.rng.below(self.world.plcs.len() as u64) as usize
    }

    /// PLC `i` writes; the answer (exceptions are legitimate for bad edits).
    fn write(&mut self, i: usize, addr: u16, values: &[u16]) -> Answer {
        let i = i.min(self.world.plcs.len().saturating_sub(1));
        self.world.request(i, &pdu::write(addr, values))
    }

    /// Fires `source` after writing what `prepare` gives, and checks the
    /// rising-edge rules at once.
    fn fire(&mut self, source: Source, kind: Kind) -> Result<(), String> {
        self.fire_via(source, kind, false)
    }

    /// [`Scenario::fire`], the edge written through the output assembly
    /// when `enip` (a channel's Execute).
    fn fire_via(&mut self, source: Source, kind: Kind, enip: bool) -> Result<(), String> {
        let urgent = kind.urgent;
        let (busy, seq_before, link_up, full) = self.world.model(|m| {
            let h = m.handshake(source).copied().unwrap_or_default();
            (h.is_busy(), h.seq_echo, m.link.is_up(), m.queue.is_full())
        });
        if !busy {
            self.checker.fired(source, kind);
            self.stats.commands += 1;
        }
        let i = self.plc();
        match source {
            Source::Channel(c) if enip => self.enip_execute(c, true),
            Source::Channel(c) => {
                self.write(i, r::channel_base(usize::from(c)), &[1]);
            }
            Source::Raw => {
                self.write(i, r::RAW_CONTROL, &[1]);
            }
            Source::Trigger(n) => {
                let bits = self.world.model(|m| m.triggers.bits) | (1 << n);
                self.write(i, r::TRIG_BITS, &[bits]);
            }
        }
        let h = self
            .world
            .model(|m| m.handshake(source).copied().unwrap_or_default());
        // The outcomes only a rising edge gives are judged here; any other
        // (the link lost in the same instant, say) by the next check.
        let at_edge = matches!(
            h.phase,
            Phase::Ended(Outcome::Error(
                ErrorSource::Gateway,
                39500 | 39501 | 39600 | 39603
            ))
        );
        if !busy && at_edge {
            self.checker.observed(source, h.phase, h.sends);
        }
        if busy {
            if h.seq_echo != seq_before {
                return Err(format!("{source:?}: an edge while Busy was not ignored"));
            }
            return Ok(());
        }
        match h.phase {
            _ if !at_edge => Ok(()),
            Phase::Ended(Outcome::Error(ErrorSource::Gateway, code)) => {
                let e = GatewayError::from_code(code);
                match e {
                    Some(GatewayError::BadParameter | GatewayError::TriggerEmpty) => Ok(()),
                    Some(GatewayError::NotConnected) if !link_up => Ok(()),
                    Some(GatewayError::QueueFull) if full && link_up && !urgent => Ok(()),
                    _ => Err(format!(
                        "{source:?}: ended at its rising edge in {code} (link up {link_up}, queue full {full})"
                    )),
                }
            }
            other => Err(format!("{source:?}: {other:?} right after its rising edge")),
        }
        .and_then(|()| {
            if !link_up || !full {
                if let Phase::Ended(Outcome::Error(_, 39600)) = h.phase {
                    return Err(format!("{source:?}: 39600 with room in the queue"));
                }
            }
            if link_up {
                if let Phase::Ended(Outcome::Error(_, 39500)) = h.phase {
                    return Err(format!("{source:?}: 39500 with the link up"));
                }
            }
            Ok(())
        })
    }

    /// A channel command: code and parameters, then Execute.
    fn channel(&mut self, ch: u8) -> Result<(), String> {
        const CODES: &[u16] = &[
            1, 2, 3, 4, 5, 6, 7, 8, 10, 11, 12, 13, 13, 14, 14, 20, 21, 22, 23, 30, 31, 32, 33, 34,
            40, 99, 60, 67, 71, 80, 85, 91,
        ];
        let code = *self.rng.pick(CODES);
        let r = &mut self.rng;
        let params: Vec<f32> = match code {
            10..=12 => vec![0.0, 10.0, 90.0, 0.0, 90.0, 0.0, 30.0, 100.0, 0.0],
            13 | 14 => vec![
                r.below(7) as f32,
                (r.below(40) as f32) - 20.0,
                r.below(2) as f32,
            ],
            20 => vec![if r.chance(900) { 0.5 } else { 1.5 }],
            21..=23 => vec![r.below(9) as f32, r.below(2) as f32],
            _ => vec![],
        };
        let kind = Kind {
            motion: matches!(code, 10..=14 | 60..=71 | 80..=91),
            bring_up: matches!(code, 1 | 3),
            urgent: matches!(code, 4..=8 | 31..=33),
            stop: code == 6,
            jog: matches!(code, 60..=71 | 80..=91),
            steps: if code == 1 { 3 } else { 1 },
        };
        if self.enip_drives() {
            return self.enip_channel(ch, code, &params, kind);
        }
        let order = self.world.model(|m| m.config.active.word_order);
        self.seq = self.seq.wrapping_add(1);
        let mut words = vec![0, code, self.seq, 0];
        for p in &params {
            words.extend(f32_words(*p, order));
        }
        let base = r::channel_base(usize::from(ch));
        let i = self.plc();
        // Execute is written low with the inputs when the source is idle;
        // while it is high (Busy or showing an outcome) the inputs only.
        let high = self
            .world
            .model(|m| m.channels[usize::from(ch)].inputs.execute());
        if high {
            self.write(i, base + 1, &words[1..]);
        } else {
            self.write(i, base, &words);
        }
        self.note(format!("ch{ch}: code {code} {params:?}"));
        if high {
            // A rising edge needs Execute low first.
            self.checker.released(Source::Channel(ch), &self.world);
            self.write(i, base, &[0]);
        }
        self.fire(Source::Channel(ch), kind)
    }

    fn release(&mut self, source: Source) -> Result<(), String> {
        let i = self.plc();
        let (busy, high) = self.world.model(|m| {
            let high = match source {
                Source::Channel(c) => m.channels[usize::from(c)].inputs.execute(),
                Source::Raw => m.raw.execute(),
                Source::Trigger(n) => m.triggers.bits & (1 << n) != 0,
            };
            (m.is_busy(source), high)
        });
        if high {
            self.checker.released(source, &self.world);
        }
        match source {
            Source::Channel(c) => {
                self.write(i, r::channel_base(usize::from(c)), &[0]);
            }
            Source::Raw => {
                self.write(i, r::RAW_CONTROL, &[0]);
            }
            Source::Trigger(n) => {
                let bits = self.world.model(|m| m.triggers.bits) & !(1 << n);
                self.write(i, r::TRIG_BITS, &[bits]);
            }
        }
        self.note(format!("release {source:?}"));
        let h = self
            .world
            .model(|m| m.handshake(source).copied().unwrap_or_default());
        // A falling edge (Execute was high) of a command no longer Busy
        // clears its outputs; one that fell while Busy shows its outcome
        // until the next rising edge.
        if high && !busy && h.phase != Phase::Idle {
            return Err(format!(
                "{source:?}: outputs not cleared when Execute fell ({:?})",
                h.phase
            ));
        }
        Ok(())
    }

    fn raw(&mut self) -> Result<(), String> {
        let t = *self.rng.pick(TEXTS);
        let i = self.plc();
        if self.world.model(|m| m.raw.execute()) {
            self.write(i, r::RAW_CONTROL, &[0]);
        }
        let mut words = text_words(t, 128);
        words.resize(words.len().max(1), 0);
        self.write(i, r::RAW_REQUEST, &words);
        self.note(format!("raw {t:?}"));
        self.fire(Source::Raw, text_kind(t))
    }

    fn trigger(&mut self) -> Result<(), String> {
        let n = self.rng.below(16) as u8;
        let i = self.plc();
        if self.rng.chance(300) {
            let t = *self.rng.pick(TEXTS);
            let mut words = text_words(t, 96);
            words.resize(words.len().max(1), 0);
            self.write(i, r::trigger_text(usize::from(n)), &words);
            self.note(format!("trigger {n} text {t:?}"));
            return Ok(());
        }
        if self.world.model(|m| m.triggers.bits & (1 << n) != 0) {
            return self.release(Source::Trigger(n));
        }
        let text = self.world.model(|m| {
            String::from_utf8_lossy(m.triggers.entries[usize::from(n)].bytes()).into_owned()
        });
        self.note(format!("trigger {n} fires {text:?}"));
        self.fire(Source::Trigger(n), text_kind(&text))
    }

    fn config(&mut self) {
        let i = self.plc();
        let (reg, value) = match self.rng.below(7) {
            0 => (r::CONFIG_POLL_MS, 5 + self.rng.below(100) as u16),
            1 => (r::CONFIG_REPLY_TIMEOUT_MS, 40 + self.rng.below(2000) as u16),
            2 => (
                r::CONFIG_WATCHDOG_MS,
                if self.rng.chance(500) {
                    0
                } else {
                    30 + self.rng.below(1000) as u16
                },
            ),
            3 => (r::CONFIG_WATCHDOG_ACTION, self.rng.below(4) as u16),
            4 => (r::CONFIG_FLOAT_WORD_ORDER, self.rng.below(2) as u16),
            5 => (r::CONFIG_START_GRACE_MS, self.rng.below(6000) as u16),
            _ => (r::CONFIG_MOTION_POLICY, self.rng.below(5) as u16),
        };
        self.write(i, reg, &[value]);
        let cmd = *self.rng.pick(&[1u16, 1, 1, 2, 3]);
        let a = self.write(i, r::CONTROL_CONFIG_COMMAND, &[cmd]);
        self.note(format!("config {reg} = {value}, command {cmd}: {a:?}"));
        self.checker.config_changed(&self.world);
    }

    fn robot_fault(&mut self) {
        let now = self.world.now();
        match self.rng.below(6) {
            0 => {
                self.world.robot.drop_connections();
                self.note("robot: connections dropped".into());
            }
            1 if self.world.robot.model.in_motion() => {
                self.world.robot.model.emergency_stop(now);
                self.note("robot: emergency stop".into());
            }
            2 => {
                self.world.robot.model.clear_faults();
                self.note("robot: faults cleared".into());
            }
            3 => {
                let back = ms(50 + self.rng.below(5000));
                self.world.robot.set_offline(true);
                self.online_at = Some(now + back);
                self.note(format!("robot: offline for {} ms", back.as_millis()));
            }
            4 => {
                self.world.robot.reconnect_now(now);
                self.note("robot: a new connection (listen mode)".into());
            }
            _ => {
                self.world.robot.model.motion_time = ms(20 + self.rng.below(2000));
            }
        }
    }

    fn session_churn(&mut self) {
        let i = self.plc();
        self.world.plcs[i].close();
        self.world.run_for(ms(1));
        let from = std::net::SocketAddrV4::new(
            std::net::Ipv4Addr::new(10, 0, 0, 30 + i as u8),
            52000 + self.rng.below(1000) as u16,
        );
        if let Some(s) = self
            .world
            .net
            .connect(from, hans_gateway::testkit::world::MODBUS_PORT)
        {
            self.world.plcs[i] = hans_gateway::testkit::plc::Plc::new(s);
        }
        self.note(format!("plc {i}: reconnected"));
    }

    /// One random action, then some time; the invariants after each.
    pub fn step(&mut self, n: usize) -> Result<(), Failure> {
        if self.online_at.is_some_and(|t| self.world.now() >= t) {
            self.online_at = None;
            self.world.robot.set_offline(false);
            self.note("robot: back online".into());
        }
        let r = self.rng.below(100);
        // While the EtherNet/IP PLC owns the command inputs, the Modbus
        // PLCs' actions on them are probes of the ownership rule; the
        // channels are driven through the assemblies (if it talks).
        let owned = self.enip_owns();
        let drives = self.enip_drives();
        // The EtherNet/IP PLC's connection ends during a motion more often
        // than the 9 % of its connection actions would make it: that is the
        // case the watchdog must catch (no random number drawn otherwise).
        let moving = drives && self.world.model(|m| m.active_motion.is_some());
        let r = if moving && self.rng.chance(80) { 95 } else { r };
        let result = match r {
            30..=41 if drives => {
                let ch = self.rng.below(2) as u8;
                self.enip_release(ch)
            }
            42..=67 if owned => self.enip_probe(),
            68..=79 if drives => {
                self.enip_heartbeat();
                Ok(())
            }
            0..=41 | 68..=79 if owned && !drives => self.enip_probe(),
            91..=99 if self.enip.is_some() => self.enip_connection(),
            0..=29 => {
                let ch = self.rng.below(2) as u8;
                self.channel(ch)
            }
            30..=41 => {
                let ch = self.rng.below(2) as u8;
                self.release(Source::Channel(ch))
            }
            42..=51 => self.raw(),
            52..=55 => self.release(Source::Raw),
            56..=67 => self.trigger(),
            68..=79 => {
                self.heartbeat = self.heartbeat.wrapping_add(1);
                let i = self.plc();
                let hb = self.heartbeat;
                self.write(i, r::CONTROL_HEARTBEAT, &[hb]);
                Ok(())
            }
            80..=82 => {
                self.config();
                Ok(())
            }
            83..=89 => {
                self.robot_fault();
                Ok(())
            }
            90 => {
                self.session_churn();
                Ok(())
            }
            _ => Ok(()),
        };
        self.stats.actions += 1;
        result
            .and_then(|()| self.checker.check(&self.world))
            .map_err(|e| self.fail(n, e))?;
        // A jog held: sometimes the PLC falls silent for a while (no
        // heartbeat, no release), as a hung PLC does.
        let jogging = self.world.model(|m| {
            m.active_motion
                .is_some_and(|a| self.checker.tracks.get(&key(a)).is_some_and(|t| t.jog))
        });
        let wait = match self.rng.below(20) {
            _ if jogging && self.rng.chance(300) => ms(900 + self.rng.below(2000)),
            0 => ms(500 + self.rng.below(3000)),
            1..=5 => ms(self.rng.below(200)),
            _ => ms(self.rng.below(30)),
        };
        let end = self.world.now() + wait;
        self.advance(end, n)
    }

    /// The end: faults off, the robot back, a paused motion continued, the
    /// heartbeat kept; after a while nothing may be Busy any more.
    pub fn drain(&mut self, n: usize) -> Result<(), Failure> {
        self.note("drain".into());
        self.enip_stop();
        self.checker
            .check(&self.world)
            .map_err(|e| self.fail(n, e))?;
        let w = &mut self.world;
        w.robot.faults = RandomFaults::default();
        w.robot.script.clear();
        w.robot.set_offline(false);
        w.robot.model.motion_time = ms(200);
        // Jogs run while Execute is held: the PLC lets go of both channels.
        for ch in 0..2 {
            if w.model(|m| m.channels[ch].inputs.execute()) {
                self.checker.released(Source::Channel(ch as u8), w);
                w.request(0, &pdu::write(r::channel_base(ch), &[0]));
            }
        }
        let end = w.now() + Duration::from_secs(45);
        let mut beat = self.heartbeat;
        while w.now() < end {
            let idle = w.model(|m| m.queue.is_empty() && Source::all().all(|s| !m.is_busy(s)));
            if idle {
                break;
            }
            let t = w.now() + ms(40);
            while w.turn(t) {
                self.checker
                    .check(w)
                    .map_err(|e| fail_at(self.seed, n, e, &self.trace))?;
            }
            beat = beat.wrapping_add(1);
            let i = 0;
            w.request(i, &pdu::write(r::CONTROL_HEARTBEAT, &[beat]));
            let paused = w.model(|m| m.active_motion.is_some()) && w.robot.model.paused();
            if paused {
                // A motion paused on the robot is Busy until Continue: send
                // it from a trigger entry that is free.
                let free = w.model(|m| (0..16u8).find(|n| !m.is_busy(Source::Trigger(*n))));
                if let Some(n) = free {
                    self.checker
                        .fired(Source::Trigger(n), text_kind("GrpContinue,0,;"));
                    let words = text_words("GrpContinue,0,;", 96);
                    let bits = w.model(|m| m.triggers.bits) & !(1 << n);
                    w.request(0, &pdu::write(r::trigger_text(usize::from(n)), &words));
                    w.request(0, &pdu::write(r::TRIG_BITS, &[bits]));
                    w.request(0, &pdu::write(r::TRIG_BITS, &[bits | (1 << n)]));
                }
            }
            if w.robot.model.estop || w.robot.model.guard || w.robot.model.error.is_some() {
                w.robot.model.clear_faults();
            }
        }
        self.checker
            .check(&self.world)
            .map_err(|e| self.fail(n, e))?;
        let busy: Vec<Source> = self
            .world
            .model(|m| Source::all().filter(|s| m.is_busy(*s)).collect());
        if !busy.is_empty() {
            return Err(self.fail(n, format!("still Busy after the drain: {busy:?}")));
        }
        Ok(())
    }

    /// Counts outcomes and requests into the stats.
    pub fn finish(mut self) -> Stats {
        let [d, e, a] = self.checker.ended;
        self.stats.done += d;
        self.stats.errors += e;
        self.stats.aborted += a;
        self.stats.requests += self.world.robot.log.len() as u64;
        self.stats.virtual_ms += self.world.now().as_millis();
        self.stats.enip_lost += self.checker.enip_lost;
        self.stats
    }
}

fn fail_at(seed: u64, step: usize, what: String, trace: &[String]) -> Failure {
    Failure {
        seed,
        step,
        what,
        trace: trace.to_vec(),
    }
}

/// Runs the scenario of `seed` for `steps` actions and the drain.
pub fn run(seed: u64, steps: usize) -> Result<Stats, Failure> {
    let mut s = Scenario::new(seed);
    s.checker.check(&s.world).map_err(|e| s.fail(0, e))?;
    for n in 0..steps {
        s.step(n)?;
    }
    s.drain(steps)?;
    Ok(s.finish())
}

/// Runs the scenario of `seed` for `steps` actions and the drain with the
/// broker doing `broker`; also returns the fingerprint of what the PLCs
/// were answered, and when (`World::plc_trace`).
pub fn run_with_broker(
    seed: u64,
    steps: usize,
    broker: Option<BrokerMode>,
) -> Result<(Stats, u64), Failure> {
    let mut s = Scenario::with_broker(seed, broker);
    s.checker.check(&s.world).map_err(|e| s.fail(0, e))?;
    for n in 0..steps {
        s.step(n)?;
    }
    s.drain(steps)?;
    let trace = s.world.plc_trace;
    Ok((s.finish(), trace))
}

/// A short report line.
pub fn summary(stats: &Stats, secs: f64) -> String {
    let mut out = String::new();
    let _ = write!(
        out,
        "{} scenarios, {} commands ({} over EtherNet/IP; {} Done, {} Error, {} CommandAborted), {} robot requests, {} EtherNet/IP owners lost during a watched motion, {:.0} s simulated in {:.1} s: {:.0} commands/s",
        stats.scenarios,
        stats.commands,
        stats.enip_commands,
        stats.done,
        stats.errors,
        stats.aborted,
        stats.requests,
        stats.enip_lost,
        stats.virtual_ms as f64 / 1000.0,
        secs,
        stats.commands as f64 / secs.max(1e-9)
    );
    out
}
