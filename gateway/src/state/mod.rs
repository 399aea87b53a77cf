//! The gateway's state, typed: what it knows of the robot, the link, the
//! PLC's inputs, each source's handshake, the queue, the configuration.
//!
//! This is the model. The Modbus register map ([`crate::registers`]) is one
//! view of it: a read encodes from these values (word order applied there,
//! once), a write decodes into them and into typed events. Other views (a
//! web page's JSON) read the same values without knowing any register.
//!
//! The rules that change it live with their concerns: what a PLC event does
//! in `crate::plc`, what the robot's replies do in
//! `engine`. The methods here keep the handshakes consistent
//! (Busy, then exactly one outcome).

pub mod access;
pub mod firmware;
pub mod handshake;
pub mod history;
pub mod inputs;
pub mod owner;
pub mod robot;
#[cfg(feature = "mqtt")]
pub mod telemetry;

use core::net::Ipv4Addr;

use embassy_time::Instant;

pub use access::AccessState;
pub use handshake::{Handshake, Phase};
pub use inputs::{ChannelInputs, ChannelState, RawState, Text, Triggers};
pub use robot::{Io, RobotFlags, RobotStatus};

use crate::config::{Config, ConfigResult};
use crate::error::{GatewayError, Outcome};
use crate::job::{JobQueue, Source};

/// Robot link state (register `LINK_STATE`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LinkState {
    /// Down: waiting before the next attempt (backoff) or not configured.
    #[default]
    Down = 0,
    /// Connecting to the controller.
    Connecting = 1,
    /// Waiting for the controller to connect (listen mode).
    Listening = 2,
    /// Connected.
    Connected = 3,
}

impl LinkState {
    /// A short name for views.
    pub fn as_str(self) -> &'static str {
        match self {
            LinkState::Down => "down",
            LinkState::Connecting => "connecting",
            LinkState::Listening => "listening",
            LinkState::Connected => "connected",
        }
    }
}

/// The robot link, as far as views care.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkStatus {
    /// Its state.
    pub state: LinkState,
    /// Connections established since start (wraps).
    pub connects: u16,
    /// Why it last failed.
    pub last_error: Option<GatewayError>,
    /// Times a connected link was lost (timeouts and mismatches included;
    /// a controller replacing its connection in listen mode is not a loss).
    pub losses: u16,
    /// Listen mode: connections to the listen port refused because they
    /// did not come from the controller (wraps).
    pub refused: u16,
    /// The controller's address while connected.
    pub peer: Option<Ipv4Addr>,
    /// The controller's protocol level in use: configured, or detected on
    /// this connection (`None` until then, and while the link is down in
    /// detect mode).
    pub level: Option<hans_codec::ProtocolLevel>,
}

impl LinkStatus {
    /// Commands can be sent.
    pub fn is_up(&self) -> bool {
        self.state == LinkState::Connected
    }
}

/// Where an error text comes from (register `ERROR_TEXT_SOURCE`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TextSource {
    /// No text yet.
    #[default]
    None = 0,
    /// The controller's own (`GetErrorCodeStr`).
    Controller = 1,
    /// The gateway's table of known codes.
    Table = 2,
    /// A code neither knows.
    Unknown = 3,
}

/// Characters of an error text.
pub const ERROR_TEXT: usize = 128;

/// The text of the last robot error (registers `ERROR_TEXT_*`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ErrorText {
    /// The code explained.
    pub code: i32,
    /// Where the text comes from.
    pub source: TextSource,
    /// Texts stored since start (wraps).
    pub count: u16,
    /// The text.
    pub text: Text<ERROR_TEXT>,
}

impl ErrorText {
    /// Stores `text` for `code`.
    pub fn set(&mut self, code: i32, source: TextSource, text: &[u8]) {
        self.code = code;
        self.source = source;
        self.text.set(text);
        self.count = self.count.wrapping_add(1);
    }
}

/// The PLC's heartbeat and the watchdog that watches it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PlcState {
    /// `PLC_HEARTBEAT` as written.
    pub heartbeat: u16,
    /// When it last changed.
    pub last_beat: Instant,
    /// The watchdog tripped (latched until the heartbeat changes).
    pub watchdog_tripped: bool,
    /// Trips since start (wraps).
    pub watchdog_trips: u16,
    /// The PLC that owned the command inputs is gone (its EtherNet/IP
    /// connection closed or timed out) while a motion ran: a lost
    /// heartbeat the watchdog acts on at once, without waiting for its
    /// period. Cleared when the heartbeat changes, and by the engine once
    /// the watchdog acted or no motion runs.
    pub lost: bool,
}

pub use crate::job::CHANNELS;

/// Words of the PLC's edit of the configuration registers.
pub const PLC_EDIT_WORDS: usize = 52;

/// The PLC's edit of the configuration registers: words as written, a
/// value out of range included, until `CONFIG_COMMAND` 1 checks them.
pub type PlcEdit = [u16; PLC_EDIT_WORDS];

/// The configuration: the one in use and the PLC's edit of it.
#[derive(Clone, Debug, PartialEq)]
pub struct ConfigState {
    /// The configuration in use.
    pub active: Config,
    /// The PLC's unapplied edit of the configuration registers, as the
    /// register view wrote it (not interpreted here); `None`: no edit, the
    /// registers show the configuration in use.
    pub edit: Option<PlcEdit>,
    /// What the last `CONFIG_COMMAND` did.
    pub result: ConfigResult,
    /// The first invalid register of a refused edit.
    pub bad_addr: u16,
    /// Saves to persistent storage since start (wraps).
    pub saves: u16,
    /// Bumped each time a configuration is applied.
    pub generation: u32,
    /// What `CONFIG_COMMAND` 3 loads: the factory defaults with the robot
    /// address given at start (host `--robot`, a board's default).
    pub factory: Config,
}

impl ConfigState {
    /// Makes `new` the configuration in use (the engine follows it once
    /// woken); the registers show it.
    pub fn apply(&mut self, new: Config) {
        self.active = new;
        self.edit = None;
        self.generation = self.generation.wrapping_add(1);
        info!("config: applied");
    }
}

/// Everything the gateway knows.
pub struct Model {
    /// The robot's status.
    pub robot: RobotStatus,
    /// The robot link.
    pub link: LinkStatus,
    /// The command channels.
    pub channels: [ChannelState; CHANNELS],
    /// The RAW channel.
    pub raw: RawState,
    /// The trigger table.
    pub triggers: Triggers,
    /// The configuration.
    pub config: ConfigState,
    /// The PLC heartbeat and watchdog.
    pub plc: PlcState,
    /// Commands waiting.
    pub queue: JobQueue,
    /// Whose motion runs on the robot.
    pub active_motion: Option<Source>,
    /// The gateway's own heartbeat: +1 every poll period (wraps).
    pub ticks: u16,
    /// Modbus clients connected.
    pub sessions: u16,
    /// Their addresses.
    pub modbus_peers: heapless::Vec<core::net::SocketAddrV4, { crate::limits::MAX_SESSIONS }>,
    /// Password, network settings in use, refusals.
    pub access: AccessState,
    /// The last commands and link events.
    pub log: history::CommandLog,
    /// The text of the last robot error.
    pub error_text: ErrorText,
    /// The firmware: versions, update state.
    pub firmware: firmware::Firmware,
    /// Who owns the command inputs (Modbus, or an EtherNet/IP owner).
    pub owner: owner::Ownership,
    /// What this platform keeps across a restart.
    pub keeps: Keeps,
}

/// What survives a restart, from the platform's storage (set once at
/// start): a device that keeps nothing loses its settings, accounts and
/// audit records at each restart, and its views must say so.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Keeps {
    /// The configuration, the accounts and the trigger table: the
    /// storage's `storage::Medium` is not `None`.
    pub config: bool,
    /// The audit log's records (an `AuditStore` that is persistent).
    pub audit: bool,
}

impl Model {
    /// A gateway that knows nothing yet, with configuration `config`
    /// (`factory`: what `CONFIG_COMMAND` 3 loads).
    pub fn new(config: Config, factory: Config) -> Self {
        Model {
            robot: RobotStatus::UNKNOWN,
            link: LinkStatus::default(),
            channels: Default::default(),
            raw: RawState::default(),
            triggers: Triggers::default(),
            config: ConfigState {
                active: config,
                edit: None,
                result: ConfigResult::Ok,
                bad_addr: 0,
                saves: 0,
                generation: 0,
                factory,
            },
            plc: PlcState {
                heartbeat: 0,
                last_beat: Instant::from_ticks(0),
                watchdog_tripped: false,
                watchdog_trips: 0,
                lost: false,
            },
            queue: JobQueue::new(),
            active_motion: None,
            ticks: 0,
            sessions: 0,
            modbus_peers: heapless::Vec::new(),
            access: AccessState::new(config.net),
            log: history::CommandLog::default(),
            error_text: ErrorText::default(),
            firmware: firmware::Firmware::NONE,
            owner: owner::Ownership::default(),
            keeps: Keeps::default(),
        }
    }

    /// A source's handshake.
    pub fn handshake(&self, source: Source) -> Option<&Handshake> {
        match source {
            Source::Channel(i) => self.channels.get(usize::from(i)).map(|c| &c.handshake),
            Source::Raw => Some(&self.raw.handshake),
            Source::Trigger(i) => self.triggers.handshakes.get(usize::from(i)),
        }
    }

    fn handshake_mut(&mut self, source: Source) -> Option<&mut Handshake> {
        match source {
            Source::Channel(i) => self
                .channels
                .get_mut(usize::from(i))
                .map(|c| &mut c.handshake),
            Source::Raw => Some(&mut self.raw.handshake),
            Source::Trigger(i) => self.triggers.handshakes.get_mut(usize::from(i)),
        }
    }

    /// The source's Execute (a channel's bit 0, RAW's; a trigger entry's
    /// bit) is high.
    pub fn execute_held(&self, source: Source) -> bool {
        match source {
            Source::Channel(i) => self
                .channels
                .get(usize::from(i))
                .is_some_and(|c| c.inputs.execute()),
            Source::Raw => self.raw.execute(),
            Source::Trigger(i) => self.triggers.bits & (1 << i) != 0,
        }
    }

    /// `true` while the source's command is queued or runs.
    pub fn is_busy(&self, source: Source) -> bool {
        self.handshake(source).is_some_and(Handshake::is_busy)
    }

    /// A rising edge at `now`: Busy and Queued, echoes latched, the last
    /// command's results and reply forgotten; logged.
    pub fn start(&mut self, source: Source, seq: u16, code: u16, now: Instant) {
        self.log.started(source, code, now);
        match source {
            Source::Channel(i) => {
                if let Some(c) = self.channels.get_mut(usize::from(i)) {
                    c.results = None;
                }
            }
            Source::Raw => self.raw.clear_reply(),
            Source::Trigger(_) => {}
        }
        if let Some(h) = self.handshake_mut(source) {
            h.start(seq, code);
        }
    }

    /// The source's job left the queue and is being sent.
    pub fn set_running(&mut self, source: Source) {
        if let Some(h) = self.handshake_mut(source) {
            h.phase = Phase::Running;
        }
    }

    /// A message of the source's command (`text`) goes to the robot.
    pub fn note_send(&mut self, source: Source, text: &[u8]) {
        self.log.sent(source, text);
        if let Some(h) = self.handshake_mut(source) {
            h.sends = h.sends.saturating_add(1);
        }
    }

    /// The source's motion runs on the robot.
    pub fn set_moving(&mut self, source: Source) {
        if let Some(h) = self.handshake_mut(source) {
            h.phase = Phase::Moving;
        }
        self.active_motion = Some(source);
    }

    /// The robot replied `text` to the source's command.
    pub fn note_reply(&mut self, source: Source, text: &[u8]) {
        self.log.replied(source, text);
    }

    /// Ends a source's command at `now` (Busy off, exactly one outcome on)
    /// and logs it. Its motion, if it ran one, no longer runs.
    pub fn finish(&mut self, source: Source, outcome: Outcome, now: Instant) {
        self.log.ended(source, outcome, now);
        if self.active_motion == Some(source) {
            self.active_motion = None;
        }
        if let Some(h) = self.handshake_mut(source) {
            h.finish(outcome);
        }
        match outcome {
            Outcome::Done => info!("{} {}: done", source.name(), source.index()),
            Outcome::Aborted => info!("{} {}: aborted", source.name(), source.index()),
            Outcome::Error(s, code) => warn!(
                "{} {}: error {} (source {})",
                source.name(),
                source.index(),
                code,
                s as u8
            ),
        }
    }

    /// Execute (or the trigger bit) fell: the outcome clears unless Busy.
    pub fn release(&mut self, source: Source) {
        if let Some(h) = self.handshake_mut(source) {
            h.release();
        }
    }

    /// Ends every queued command with gateway error `e` at `now`.
    pub fn fail_queue(&mut self, e: GatewayError, now: Instant) {
        for source in self.queue.drain_sources() {
            self.finish(source, Outcome::gateway(e), now);
        }
    }

    /// A stop ended the motions at `now`: every motion still waiting in
    /// the queue ends in CommandAborted and is never sent.
    pub fn abort_queued_motions(&mut self, now: Instant) {
        for source in self.queue.take_motions() {
            self.finish(source, Outcome::Aborted, now);
        }
    }

    /// Milliseconds since the robot status was refreshed, if it was on
    /// this link.
    pub fn status_age_ms(&self, now: Instant) -> Option<u64> {
        self.robot
            .updated
            .map(|t| now.saturating_duration_since(t).as_millis())
    }

    /// The watchdog watches the running motion (it is on and a motion runs).
    pub fn watchdog_armed(&self) -> bool {
        self.active_motion.is_some() && self.config.active.watchdog_ms != 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::ErrorSource;
    use crate::job::{text, Job};

    fn queued(m: &mut Model, source: Source, t: &str) {
        let (kind, robot) = text::build(t.as_bytes()).unwrap();
        m.start(source, 1, 0, Instant::from_ticks(0));
        m.queue
            .push(Job {
                source,
                seq: 1,
                robot: robot.unwrap_or(0),
                kind,
            })
            .unwrap();
    }

    #[test]
    fn queue_failures_and_stops_end_each_command_once() {
        let mut m = Model::new(Config::default(), Config::default());
        queued(&mut m, Source::Channel(0), "MoveRelJ,0,1,1,5,;");
        queued(&mut m, Source::Raw, "SetBoxDO,1,1,;");
        queued(
            &mut m,
            Source::Trigger(3),
            "WayPoint,0,0,0,0,0,0,0,0,0,0,0,0,0,TCP,Base,1,1,0,0,1,0,0,0,x,;",
        );
        let t = Instant::from_ticks(0);
        m.abort_queued_motions(t);
        let phase = |m: &Model, s| m.handshake(s).unwrap().phase;
        assert_eq!(
            phase(&m, Source::Channel(0)),
            Phase::Ended(Outcome::Aborted)
        );
        assert_eq!(
            phase(&m, Source::Trigger(3)),
            Phase::Ended(Outcome::Aborted)
        );
        assert_eq!(phase(&m, Source::Raw), Phase::Queued);
        m.fail_queue(GatewayError::LinkLost, t);
        assert_eq!(
            phase(&m, Source::Raw),
            Phase::Ended(Outcome::Error(ErrorSource::Gateway, 39601))
        );
        assert!(m.queue.is_empty());
        m.set_moving(Source::Channel(1));
        assert_eq!(m.active_motion, Some(Source::Channel(1)));
        m.finish(Source::Channel(1), Outcome::Done, t);
        assert_eq!(m.active_motion, None);
    }
}
