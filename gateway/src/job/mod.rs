//! Jobs: what a rising edge of Execute (or a trigger bit) puts in the queue.
//!
//! A job carries its typed request, built once when the PLC fires it:
//!
//! * [`Command`] for the command codes of the channels (`command.rs`):
//!   owned, typed fields, checked against the protocol document's ranges
//!   when built;
//! * [`Urgent`] for stop, pause, continue, reset, disable (and the script
//!   versions), whichever source fired them: they travel in the urgent lane
//!   and are sent in the protocol's canonical form;
//! * [`TextJob`] for RAW requests and trigger entries (`text.rs`): the
//!   PLC's text, checked by the codec's grammar once, sent as written, with
//!   what the engine needs to know about it (command, reply shape) kept
//!   beside it.
//!
//! When the engine sends a job it asks it for the bytes of each message
//! ([`Job::encode`]); nothing is parsed again.

pub(crate) mod command;
pub(crate) mod queue;
pub(crate) mod text;

use hans_codec::{request, CommandId, EncodeError, RangeError, ReplyExpect, RobotId};

pub use command::{build, code, Command, Inputs};
pub use queue::{Gate, JobQueue, QUEUE_DEPTH, URGENT_DEPTH};
pub use text::{TextJob, TEXT_MAX};

use crate::error::GatewayError;

/// Number of command channels (the sizes of the state: the registers and
/// the page are views of them).
pub const CHANNELS: usize = 2;
/// Entries of the trigger table.
pub const TRIGGERS: usize = 16;

/// Where a command came from, and so where its outputs go.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Source {
    /// Command channel 0 or 1.
    Channel(u8),
    /// The RAW channel.
    Raw,
    /// Trigger-table entry 0-15.
    Trigger(u8),
}

impl Source {
    /// Every source: the channels, RAW, the trigger entries.
    pub fn all() -> impl Iterator<Item = Source> {
        (0..CHANNELS as u8)
            .map(Source::Channel)
            .chain(core::iter::once(Source::Raw))
            .chain((0..TRIGGERS as u8).map(Source::Trigger))
    }

    /// The value of register `ACTIVE_MOTION` for this source.
    pub fn code(self) -> u16 {
        match self {
            Source::Channel(i) => 1 + u16::from(i),
            Source::Raw => 3,
            Source::Trigger(i) => 16 + u16::from(i),
        }
    }

    /// A short name for logs.
    pub fn name(self) -> &'static str {
        match self {
            Source::Channel(_) => "ch",
            Source::Raw => "raw",
            Source::Trigger(_) => "trigger",
        }
    }

    /// The entry number for triggers, the channel number for channels.
    pub fn index(self) -> u8 {
        match self {
            Source::Channel(i) | Source::Trigger(i) => i,
            Source::Raw => 0,
        }
    }
}

/// The commands that must always get through at once: stop, pause and
/// continue (of motions and scripts), reset and disable. They never wait for
/// room in the queue and pass every ordinary command waiting there (the one
/// being sent still finishes: one request is in flight at a time).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Urgent {
    /// `GrpStop`.
    Stop,
    /// `GrpInterrupt` (pause).
    Pause,
    /// `GrpContinue`.
    Continue,
    /// `GrpReset`.
    Reset,
    /// `GrpDisable`.
    Disable,
    /// `StopScript`.
    StopScript,
    /// `PauseScript`.
    PauseScript,
    /// `ContinueScript`.
    ContinueScript,
}

impl Urgent {
    /// The urgent command `id` is, if it is one.
    pub fn of(id: CommandId) -> Option<Urgent> {
        Some(match id {
            CommandId::GrpStop => Urgent::Stop,
            CommandId::GrpInterrupt => Urgent::Pause,
            CommandId::GrpContinue => Urgent::Continue,
            CommandId::GrpReset => Urgent::Reset,
            CommandId::GrpDisable => Urgent::Disable,
            CommandId::StopScript => Urgent::StopScript,
            CommandId::PauseScript => Urgent::PauseScript,
            CommandId::ContinueScript => Urgent::ContinueScript,
            _ => return None,
        })
    }

    /// Its command.
    pub fn id(self) -> CommandId {
        match self {
            Urgent::Stop => CommandId::GrpStop,
            Urgent::Pause => CommandId::GrpInterrupt,
            Urgent::Continue => CommandId::GrpContinue,
            Urgent::Reset => CommandId::GrpReset,
            Urgent::Disable => CommandId::GrpDisable,
            Urgent::StopScript => CommandId::StopScript,
            Urgent::PauseScript => CommandId::PauseScript,
            Urgent::ContinueScript => CommandId::ContinueScript,
        }
    }

    /// Writes the canonical message for robot `rbt`.
    pub fn encode(self, rbt: u8, buf: &mut [u8]) -> Option<Message> {
        let rbt_id = RobotId(i32::from(rbt));
        match self {
            Urgent::Stop => request::GrpStop { rbt_id }.wire(buf),
            Urgent::Pause => request::GrpInterrupt { rbt_id }.wire(buf),
            Urgent::Continue => request::GrpContinue { rbt_id }.wire(buf),
            Urgent::Reset => request::GrpReset { rbt_id }.wire(buf),
            Urgent::Disable => request::GrpDisable { rbt_id }.wire(buf),
            Urgent::StopScript => request::StopScript {}.wire(buf),
            Urgent::PauseScript => request::PauseScript {}.wire(buf),
            Urgent::ContinueScript => request::ContinueScript {}.wire(buf),
        }
    }
}

/// A message ready to send: its length in the caller's buffer, the reply it
/// expects, and its command (`None` for names the codec does not know).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Message {
    /// Bytes written.
    pub len: usize,
    /// The reply's shape.
    pub expect: ReplyExpect,
    /// The command.
    pub id: Option<CommandId>,
}

/// A codec request, as far as the gateway uses it: object-safe, so that one
/// function per command builds its request ([`Command::with_request`]) for
/// both checking and sending.
pub trait Wire {
    /// Which command.
    fn id(&self) -> CommandId;
    /// Checks the ranges of the protocol document.
    fn check(&self) -> Result<(), RangeError>;
    /// Writes the canonical message.
    fn write(&self, buf: &mut [u8]) -> Result<usize, EncodeError>;
    /// The reply it expects.
    fn reply(&self) -> ReplyExpect;
    /// [`Self::write`] with what the engine needs to send it.
    fn wire(&self, buf: &mut [u8]) -> Option<Message> {
        let len = self.write(buf).ok()?;
        Some(Message {
            len,
            expect: self.reply(),
            id: Some(self.id()),
        })
    }
}

impl<'a, C: hans_codec::Command<'a>> Wire for C {
    fn id(&self) -> CommandId {
        C::ID
    }
    fn check(&self) -> Result<(), RangeError> {
        self.validate()
    }
    fn write(&self, buf: &mut [u8]) -> Result<usize, EncodeError> {
        self.encode(buf)
    }
    fn reply(&self) -> ReplyExpect {
        self.expect()
    }
}

/// What a job sends.
#[derive(Clone, Debug, PartialEq)]
pub enum JobKind {
    /// A command code of a channel (not an urgent one).
    Command(Command),
    /// An urgent command, from any source.
    Urgent(Urgent),
    /// A RAW request or a trigger entry.
    Text(TextJob),
}

/// A command waiting in the queue or being sent.
#[derive(Clone, Debug, PartialEq)]
pub struct Job {
    /// Where it came from.
    pub source: Source,
    /// Its sequence number (0 for trigger entries).
    pub seq: u16,
    /// The robot id `nRbtID` of its requests.
    pub robot: u8,
    /// What it sends.
    pub kind: JobKind,
}

impl Job {
    /// It starts a motion (Done when the motion ends).
    pub fn is_motion(&self) -> bool {
        match &self.kind {
            JobKind::Command(c) => c.is_motion(),
            JobKind::Urgent(_) => false,
            JobKind::Text(t) => t.id.is_some_and(CommandId::is_motion),
        }
    }

    /// It passes every ordinary command in the queue.
    pub fn is_urgent(&self) -> bool {
        matches!(self.kind, JobKind::Urgent(_))
    }

    /// How many messages it sends in turn.
    pub fn steps(&self) -> u8 {
        match &self.kind {
            JobKind::Command(c) => c.steps(),
            _ => 1,
        }
    }

    /// Writes message `step` (0-based) into `buf`.
    pub fn encode(&self, step: u8, buf: &mut [u8]) -> Option<Message> {
        match &self.kind {
            JobKind::Command(c) => c.encode(step, self.robot, buf),
            JobKind::Urgent(u) => u.encode(self.robot, buf),
            JobKind::Text(t) => t.encode(buf),
        }
    }

    /// The jog it starts (codes 60-71, 80-91).
    pub fn jog(&self) -> Option<command::Jog> {
        match &self.kind {
            JobKind::Command(Command::Jog(j)) => Some(*j),
            _ => None,
        }
    }

    /// Its result registers are filled from the reply (code 40).
    pub fn fills_results(&self) -> bool {
        matches!(self.kind, JobKind::Command(Command::ReadActPos))
    }
}

/// Why a job could not be built: shown to the PLC as ErrorID (source 3).
pub type BuildError = GatewayError;
