//! Jobs: what a rising edge puts in the queue, where its outcome goes, and
//! the queue itself ([`JobQueue`]).

use hans_codec::{Command, CommandId, Request};

use crate::config::WordOrder;
use crate::registers::{self as r, RegisterFile};

/// Longest protocol text of one job (RAW requests are at most 256
/// characters; typed commands stay well below).
pub const MSG_MAX: usize = 300;
/// Ordinary jobs the queue holds; an ordinary command fired when it is full
/// ends in Error [`GatewayError::QueueFull`] at once. Urgent commands
/// (see [`is_urgent`]) have their own room and are never refused.
pub const QUEUE_DEPTH: usize = 8;
/// Longest text of a job in the urgent lane (the document's form of every
/// urgent command is at most 25 characters).
pub const URGENT_MSG_MAX: usize = 32;
// An urgent job always fits back into an ordinary one ([`JobQueue::take`]).
const _: () = assert!(URGENT_MSG_MAX <= MSG_MAX);
/// Room of the urgent lane: one job per source (two channels, RAW, sixteen
/// trigger entries). A source has at most one job at a time (a rising edge
/// while Busy is ignored), so this lane cannot fill up.
pub const URGENT_DEPTH: usize = r::CHANNELS + 1 + r::TRIGGERS;

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
    /// The watchdog's action (no PLC outputs).
    Watchdog,
    /// The automatic `GrpReset` after a motion error (no PLC outputs).
    AutoReset,
}

/// Who reported an error (register `*_ERROR_SOURCE`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ErrorSource {
    /// The robot refused the command: ErrorID is its `Fail` code.
    RobotFail = 1,
    /// The robot reported an error during the motion: ErrorID is its
    /// `ReadRobotState` error code (or a gateway code if it gave none).
    RobotMotion = 2,
    /// The gateway: ErrorID is a [`GatewayError`] code.
    Gateway = 3,
}

/// The gateway's own error codes (ErrorID with error source 3). The
/// 395xx codes are the ones the vendor's SDKs use for the same situations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GatewayError {
    /// 39500: the robot link is down.
    NotConnected = 39500,
    /// 39501: a parameter is invalid (range, integer expected, unknown
    /// command code, text not ASCII or too long).
    BadParameter = 39501,
    /// 39502: the reply could not be read, or the robot answered `errorcmd`.
    BadReply = 39502,
    /// 39503: no reply within the reply timeout (the link is reset).
    ReplyTimeout = 39503,
    /// 39504: connecting to the robot failed (refused, unreachable, no
    /// answer within the connect timeout) or its port could not be listened
    /// on. Shown in `LINK_LAST_ERROR` only.
    ConnectFailed = 39504,
    /// 39505: the reply names another command (the link is reset).
    ReplyMismatch = 39505,
    /// 39600: the command queue is full.
    QueueFull = 39600,
    /// 39601: the robot link was lost while the command was queued or ran.
    LinkLost = 39601,
    /// 39602: the watchdog stopped the motion (PLC heartbeat missing).
    Watchdog = 39602,
    /// 39603: the trigger entry is empty.
    TriggerEmpty = 39603,
    /// 39604: the robot reported an error without a code.
    RobotErrorNoCode = 39604,
    /// 39605: the robot reported an emergency stop during the motion.
    EmergencyStop = 39605,
    /// 39606: the robot reported the safety guard during the motion.
    SafetyGuard = 39606,
    /// 39607: after a bring-up step (`ConnectToBox`, `Electrify`,
    /// `StartMaster`, `GrpEnable`) the robot did not reach the state the
    /// step leads to within [`super::fsm::STATE_TIMEOUT`], or went to a
    /// fault state instead (`FSM_STATE` shows where it is).
    StateNotReached = 39607,
}

impl GatewayError {
    /// The numeric code.
    pub const fn code(self) -> i32 {
        self as i32
    }

    /// A short text for logs.
    pub const fn as_str(self) -> &'static str {
        match self {
            GatewayError::NotConnected => "robot link down",
            GatewayError::BadParameter => "bad parameter",
            GatewayError::BadReply => "bad reply",
            GatewayError::ReplyTimeout => "reply timeout",
            GatewayError::ConnectFailed => "connect failed",
            GatewayError::ReplyMismatch => "reply names another command",
            GatewayError::QueueFull => "queue full",
            GatewayError::LinkLost => "robot link lost",
            GatewayError::Watchdog => "watchdog",
            GatewayError::TriggerEmpty => "trigger entry empty",
            GatewayError::RobotErrorNoCode => "robot error without code",
            GatewayError::EmergencyStop => "emergency stop",
            GatewayError::SafetyGuard => "safety guard",
            GatewayError::StateNotReached => "state not reached",
        }
    }
}

/// How a command ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Outcome {
    /// Done.
    Done,
    /// Error with its source and ErrorID.
    Error(ErrorSource, i32),
    /// CommandAborted (another command stopped the motion).
    Aborted,
}

impl Outcome {
    /// A gateway error.
    pub const fn gateway(e: GatewayError) -> Outcome {
        Outcome::Error(ErrorSource::Gateway, e.code())
    }
}

/// Which values a successful reply puts in the result registers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Results {
    /// None.
    None,
    /// `ReadActPos`: joints, pose, TCP, UCS.
    ActPos,
}

/// A command waiting in the queue. `N` is the room for its text: jobs in
/// the urgent lane are short.
#[derive(Clone, Debug)]
pub struct Job<const N: usize = MSG_MAX> {
    /// Where it came from.
    pub source: Source,
    /// Its sequence number.
    pub seq: u16,
    /// One or more protocol messages, each ending in `;`, sent in turn.
    pub text: heapless::String<N>,
    /// It starts a motion (Done when the motion ends).
    pub motion: bool,
    /// An urgent command ([`is_urgent`]): it passes every ordinary command
    /// waiting in the queue.
    pub urgent: bool,
    /// Result registers to fill.
    pub results: Results,
}

/// `true` for the commands that must always get through at once: stop,
/// pause and continue (of motions and scripts), reset and disable. They
/// never wait for room in the queue and pass every ordinary command
/// waiting there (the one being sent still finishes: one request is in
/// flight at a time).
pub fn is_urgent(id: CommandId) -> bool {
    matches!(
        id,
        CommandId::GrpStop
            | CommandId::GrpInterrupt
            | CommandId::GrpContinue
            | CommandId::GrpReset
            | CommandId::GrpDisable
            | CommandId::StopScript
            | CommandId::PauseScript
            | CommandId::ContinueScript
    )
}

impl Job {
    /// A job of one protocol message written by the PLC (RAW or trigger):
    /// checked with the codec's grammar, sent as written (a missing
    /// terminator is added). An urgent command too long as written for the
    /// urgent lane ([`URGENT_MSG_MAX`], blanks around its fields, say) is
    /// sent in the codec's canonical form, which is short.
    pub fn from_text(source: Source, seq: u16, text: &str) -> Result<Job, GatewayError> {
        let t = text.trim_matches(|c: char| c == ' ' || c == '\0');
        if t.is_empty() {
            return Err(GatewayError::BadParameter);
        }
        // One message only: nothing but blanks after the first `;`.
        if let Some(i) = t.find(';') {
            if !t.get(i + 1..).unwrap_or("").trim().is_empty() {
                return Err(GatewayError::BadParameter);
            }
        }
        let req = Request::parse(t).map_err(|_| GatewayError::BadParameter)?;
        let id = req.command();
        let urgent = id.is_some_and(is_urgent);
        let mut out = heapless::String::new();
        out.push_str(t).map_err(|_| GatewayError::BadParameter)?;
        if !t.ends_with(';') {
            let tail = if t.ends_with(',') { ";" } else { ",;" };
            out.push_str(tail).map_err(|_| GatewayError::BadParameter)?;
        }
        if urgent && out.len() > URGENT_MSG_MAX {
            if let Some(short) = canonical(&req) {
                out = short;
            }
        }
        Ok(Job {
            source,
            seq,
            text: out,
            motion: id.is_some_and(CommandId::is_motion),
            urgent,
            results: Results::None,
        })
    }
}

/// The codec's canonical text of an urgent request ([`is_urgent`]), if it
/// fits the urgent lane. Each command's own encoder, which the typed
/// channels link anyway (`Request::encode` would add every command's
/// writer: ~4 KiB of flash).
fn canonical<const N: usize>(req: &Request<'_>) -> Option<heapless::String<N>> {
    let mut buf = [0u8; URGENT_MSG_MAX];
    let n = match req {
        Request::GrpStop(c) => c.encode(&mut buf),
        Request::GrpInterrupt(c) => c.encode(&mut buf),
        Request::GrpContinue(c) => c.encode(&mut buf),
        Request::GrpReset(c) => c.encode(&mut buf),
        Request::GrpDisable(c) => c.encode(&mut buf),
        Request::StopScript(c) => c.encode(&mut buf),
        Request::PauseScript(c) => c.encode(&mut buf),
        Request::ContinueScript(c) => c.encode(&mut buf),
        _ => return None,
    }
    .ok()?;
    let text = core::str::from_utf8(buf.get(..n)?).ok()?;
    heapless::String::try_from(text).ok()
}

impl<const N: usize> Job<N> {
    /// The same job with its text in room `M` (the urgent lane's or the
    /// ordinary one's); `None` if the text does not fit.
    fn with_room<const M: usize>(&self) -> Option<Job<M>> {
        Some(Job {
            source: self.source,
            seq: self.seq,
            text: heapless::String::try_from(self.text.as_str()).ok()?,
            motion: self.motion,
            urgent: self.urgent,
            results: self.results,
        })
    }
}

/// The command queue: ordinary commands in FIFO order ([`QUEUE_DEPTH`]),
/// and an urgent lane ([`URGENT_DEPTH`]) for the commands of [`is_urgent`],
/// which go first.
#[derive(Default)]
pub struct JobQueue {
    ordinary: heapless::Vec<Job, QUEUE_DEPTH>,
    urgent: heapless::Vec<Job<URGENT_MSG_MAX>, URGENT_DEPTH>,
}

/// What may leave the queue now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Gate {
    /// Anything (nothing runs on the robot).
    Open,
    /// A motion runs: ordinary commands go on, but a motion at the head of
    /// the ordinary queue waits (and so does everything behind it).
    MotionRunning,
    /// Only urgent commands (a bring-up step waits for its state).
    UrgentOnly,
}

impl JobQueue {
    /// An empty queue.
    pub const fn new() -> Self {
        JobQueue {
            ordinary: heapless::Vec::new(),
            urgent: heapless::Vec::new(),
        }
    }

    /// Queues a job; gives its source back when there is no room.
    pub fn push(&mut self, job: Job) -> Result<(), Source> {
        if job.urgent {
            if let Some(u) = job.with_room() {
                if self.urgent.push(u).is_ok() {
                    return Ok(());
                }
            }
        }
        let source = job.source;
        self.ordinary.push(job).map_err(|_| source)
    }

    /// Takes the next job allowed through `gate`: urgent jobs first.
    pub fn take(&mut self, gate: Gate) -> Option<Job> {
        if !self.urgent.is_empty() {
            // Always fits: URGENT_MSG_MAX <= MSG_MAX (asserted above).
            return self.urgent.remove(0).with_room();
        }
        let head = self.ordinary.first()?;
        let go = match gate {
            Gate::Open => true,
            Gate::MotionRunning => !head.motion,
            Gate::UrgentOnly => false,
        };
        go.then(|| self.ordinary.remove(0))
    }

    /// `true` if an urgent job waits.
    pub fn has_urgent(&self) -> bool {
        !self.urgent.is_empty()
    }

    /// Jobs waiting.
    pub fn len(&self) -> usize {
        self.ordinary.len() + self.urgent.len()
    }

    /// `true` when nothing waits.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Removes the oldest waiting motion job and returns its source (a stop
    /// ends them all).
    pub fn take_motion(&mut self) -> Option<Source> {
        let i = self.ordinary.iter().position(|j| j.motion)?;
        Some(self.ordinary.remove(i).source)
    }

    /// Removes the oldest job (urgent lane first) and returns its source.
    pub fn pop_source(&mut self) -> Option<Source> {
        if !self.urgent.is_empty() {
            return Some(self.urgent.remove(0).source);
        }
        if self.ordinary.is_empty() {
            return None;
        }
        Some(self.ordinary.remove(0).source)
    }
}

impl Source {
    /// The value of register `ACTIVE_MOTION` for this source.
    pub fn code(self) -> u16 {
        match self {
            Source::Channel(i) => 1 + u16::from(i),
            Source::Raw => 3,
            Source::Trigger(i) => 16 + u16::from(i),
            Source::Watchdog | Source::AutoReset => 0,
        }
    }

    /// A short name for logs.
    pub fn name(self) -> &'static str {
        match self {
            Source::Channel(0) => "ch0",
            Source::Channel(_) => "ch1",
            Source::Raw => "raw",
            Source::Trigger(_) => "trigger",
            Source::Watchdog => "watchdog",
            Source::AutoReset => "auto-reset",
        }
    }

    /// The entry number for triggers, the channel number for channels.
    pub fn index(self) -> u8 {
        match self {
            Source::Channel(i) | Source::Trigger(i) => i,
            _ => 0,
        }
    }

    fn status_reg(self) -> Option<u16> {
        match self {
            Source::Channel(i) => Some(r::channel_base(usize::from(i)) + r::CH_STATUS),
            Source::Raw => Some(r::RAW_STATUS),
            _ => None,
        }
    }

    /// `true` while the command of this source is queued or running.
    pub fn is_busy(self, regs: &RegisterFile) -> bool {
        match self {
            Source::Trigger(i) => regs.get(r::TRIG_BUSY) & (1 << i) != 0,
            s => s
                .status_reg()
                .is_some_and(|a| regs.get(a) & r::ST_BUSY != 0),
        }
    }

    /// Clears Done, Error, CommandAborted and ErrorID (a new command starts,
    /// or Execute fell while not busy).
    pub fn clear_outputs(self, regs: &mut RegisterFile) {
        match self {
            Source::Trigger(i) => {
                let m = 1 << i;
                for a in [r::TRIG_DONE, r::TRIG_ERROR, r::TRIG_ABORTED] {
                    regs.set_bits(a, m, false);
                }
                regs.set_i32(r::TRIG_ERROR_ID + 2 * u16::from(i), 0, WordOrder::HighFirst);
                regs.set(r::TRIG_ERROR_SOURCE + u16::from(i), 0);
            }
            Source::Channel(_) | Source::Raw => {
                if let Some(a) = self.status_reg() {
                    regs.set_bits(a, r::ST_DONE | r::ST_ERROR | r::ST_ABORTED, false);
                    regs.set_i32(a + 2, 0, WordOrder::HighFirst);
                    regs.set(a + 4, 0);
                }
            }
            _ => {}
        }
    }

    /// Marks the command started: Busy (and Queued), sequence echoed.
    pub fn set_started(self, regs: &mut RegisterFile, seq: u16, command: u16) {
        self.clear_outputs(regs);
        match self {
            Source::Trigger(i) => regs.set_bits(r::TRIG_BUSY, 1 << i, true),
            Source::Channel(i) => {
                let b = r::channel_base(usize::from(i));
                regs.set_bits(b + r::CH_STATUS, r::ST_BUSY | r::ST_QUEUED, true);
                regs.set(b + r::CH_SEQ_ECHO, seq);
                regs.set(b + r::CH_COMMAND_ECHO, command);
                for k in 0..(r::CH_RESULT_COUNT as u16 * 2) {
                    regs.set(b + r::CH_RESULTS + k, 0);
                }
            }
            Source::Raw => {
                regs.set_bits(r::RAW_STATUS, r::ST_BUSY | r::ST_QUEUED, true);
                regs.set(r::RAW_SEQ_ECHO, seq);
                regs.set(r::RAW_REPLY_LEN, 0);
                regs.set(r::RAW_REPLY_TRUNCATED, 0);
                regs.set_text(r::RAW_REPLY, r::RAW_REPLY_REGS, b"");
            }
            _ => {}
        }
    }

    /// The job left the queue and is being sent.
    pub fn set_dequeued(self, regs: &mut RegisterFile) {
        if let Some(a) = self.status_reg() {
            regs.set_bits(a, r::ST_QUEUED, false);
        }
    }

    /// Its motion runs on the robot (or no longer does).
    pub fn set_active(self, regs: &mut RegisterFile, on: bool) {
        if let Some(a) = self.status_reg() {
            regs.set_bits(a, r::ST_ACTIVE, on);
        }
    }

    /// Ends the command: Busy off, exactly one of Done, Error, Aborted on.
    pub fn set_outcome(self, regs: &mut RegisterFile, outcome: Outcome, order: WordOrder) {
        let (bit, src, code) = match outcome {
            Outcome::Done => (r::ST_DONE, 0, 0),
            Outcome::Error(s, c) => (r::ST_ERROR, s as u16, c),
            Outcome::Aborted => (r::ST_ABORTED, 0, 0),
        };
        match self {
            Source::Trigger(i) => {
                let m = 1 << i;
                regs.set_bits(r::TRIG_BUSY, m, false);
                let a = match outcome {
                    Outcome::Done => r::TRIG_DONE,
                    Outcome::Error(..) => r::TRIG_ERROR,
                    Outcome::Aborted => r::TRIG_ABORTED,
                };
                regs.set_bits(a, m, true);
                regs.set_i32(r::TRIG_ERROR_ID + 2 * u16::from(i), code, order);
                regs.set(r::TRIG_ERROR_SOURCE + u16::from(i), src);
            }
            Source::Channel(_) | Source::Raw => {
                if let Some(a) = self.status_reg() {
                    let v = regs.get(a) & !(r::ST_BUSY | r::ST_QUEUED | r::ST_ACTIVE);
                    regs.set(a, v | bit);
                    regs.set_i32(a + 2, code, order);
                    regs.set(a + 4, src);
                }
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raw_text_is_checked_and_terminated() {
        let j = Job::from_text(Source::Raw, 1, "GrpStop,0").unwrap();
        assert_eq!(j.text.as_str(), "GrpStop,0,;");
        assert!(j.urgent && !j.motion);
        let j = Job::from_text(Source::Raw, 1, "MoveRelJ,0,1,1,5,;\0\0").unwrap();
        assert!(j.motion);
        assert_eq!(j.text.as_str(), "MoveRelJ,0,1,1,5,;");
        assert_eq!(
            Job::from_text(Source::Raw, 1, "GrpStop,0,;GrpReset,0,;").unwrap_err(),
            GatewayError::BadParameter
        );
        assert!(Job::from_text(Source::Raw, 1, "  ").is_err());
        // Unknown names pass through (newer firmware).
        assert!(Job::from_text(Source::Raw, 1, "ReadVersion,;").is_ok());
    }

    #[test]
    fn every_urgent_command_has_a_short_canonical_form() {
        // Each urgent command, written with blanks too long for the urgent
        // lane, is queued there in the codec's canonical form.
        let urgent: Vec<CommandId> = CommandId::ALL
            .iter()
            .copied()
            .filter(|&id| is_urgent(id))
            .collect();
        assert_eq!(urgent.len(), 8);
        for id in urgent {
            let wide = format!("{},{:>30},;", id.name(), 0);
            let j = Job::from_text(Source::Raw, 1, &wide).unwrap();
            assert!(j.urgent, "{wide}");
            assert!(j.text.len() <= URGENT_MSG_MAX, "{wide} -> {}", j.text);
            assert!(j.text.starts_with(id.name()) && j.text.ends_with(";"));
            assert!(!j.text.contains(' '), "{}", j.text);
            let mut q = JobQueue::new();
            q.push(j).unwrap();
            assert!(q.has_urgent(), "{wide}");
        }
    }

    fn job(source: Source, text: &str) -> Job {
        Job::from_text(source, 0, text).unwrap()
    }

    #[test]
    fn urgent_commands_pass_a_full_queue_and_stop_finds_the_motions() {
        let mut q = JobQueue::new();
        q.push(job(Source::Trigger(0), "MoveRelJ,0,1,1,5,;"))
            .unwrap();
        for i in 1..QUEUE_DEPTH as u8 {
            q.push(job(Source::Trigger(i), "SetBoxDO,1,1,;")).unwrap();
        }
        let refused = q.push(job(Source::Raw, "SetBoxDO,2,1,;")).unwrap_err();
        assert_eq!(refused, Source::Raw);
        // Every source may queue an urgent command at once, all accepted.
        let urgent = ["GrpStop,0,;", "GrpInterrupt,0,;", "GrpContinue,0,;"];
        for (i, t) in urgent.iter().enumerate() {
            q.push(job(Source::Trigger(10 + i as u8), t)).unwrap();
        }
        // Long but valid: kept without the blanks.
        q.push(job(Source::Raw, "GrpReset,                     0      ,;"))
            .unwrap();
        assert_eq!(q.len(), QUEUE_DEPTH + 4);
        // Urgent first, in order, even while a motion blocks the queue.
        for t in urgent {
            let j = q.take(Gate::UrgentOnly).unwrap();
            assert_eq!(j.text.as_str(), t);
        }
        assert_eq!(
            q.take(Gate::MotionRunning).unwrap().text.as_str(),
            "GrpReset,0,;"
        );
        assert!(!q.has_urgent());
        // The motion at the head waits, and everything behind it.
        assert!(q.take(Gate::MotionRunning).is_none());
        assert!(q.take(Gate::UrgentOnly).is_none());
        // A stop takes the waiting motions out; the rest goes on.
        assert_eq!(q.take_motion(), Some(Source::Trigger(0)));
        assert_eq!(q.take_motion(), None);
        assert_eq!(
            q.take(Gate::MotionRunning).unwrap().source,
            Source::Trigger(1)
        );
        assert_eq!(q.pop_source(), Some(Source::Trigger(2)));
        assert_eq!(q.len(), QUEUE_DEPTH - 3);
    }

    #[test]
    fn outputs_follow_the_handshake() {
        let mut regs = RegisterFile::new();
        let s = Source::Channel(1);
        s.set_started(&mut regs, 7, 3);
        assert!(s.is_busy(&regs));
        let st = r::channel_base(1) + r::CH_STATUS;
        assert_eq!(regs.get(st), r::ST_BUSY | r::ST_QUEUED);
        s.set_outcome(
            &mut regs,
            Outcome::Error(ErrorSource::RobotFail, 20018),
            WordOrder::HighFirst,
        );
        assert_eq!(regs.get(st), r::ST_ERROR);
        assert_eq!(regs.get_u32(st + 2, WordOrder::HighFirst), 20018);
        assert_eq!(regs.get(st + 4), 1);
        assert_eq!(regs.get(r::channel_base(1) + r::CH_SEQ_ECHO), 7);
        s.clear_outputs(&mut regs);
        assert_eq!(regs.get(st), 0);
        let t = Source::Trigger(5);
        t.set_started(&mut regs, 0, 0);
        assert_eq!(regs.get(r::TRIG_BUSY), 1 << 5);
        t.set_outcome(&mut regs, Outcome::Done, WordOrder::HighFirst);
        assert_eq!(
            (regs.get(r::TRIG_BUSY), regs.get(r::TRIG_DONE)),
            (0, 1 << 5)
        );
    }
}
