//! Jobs: what a rising edge puts in the queue, where its outcome goes.

use hans_codec::{CommandId, Request};

use crate::config::WordOrder;
use crate::registers::{self as r, RegisterFile};

/// Longest protocol text of one job (RAW requests are at most 256
/// characters; typed commands stay well below).
pub const MSG_MAX: usize = 300;
/// Jobs the queue holds; a command fired when it is full ends in Error
/// [`GatewayError::QueueFull`] at once.
pub const QUEUE_DEPTH: usize = 8;

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
            GatewayError::ReplyMismatch => "reply names another command",
            GatewayError::QueueFull => "queue full",
            GatewayError::LinkLost => "robot link lost",
            GatewayError::Watchdog => "watchdog",
            GatewayError::TriggerEmpty => "trigger entry empty",
            GatewayError::RobotErrorNoCode => "robot error without code",
            GatewayError::EmergencyStop => "emergency stop",
            GatewayError::SafetyGuard => "safety guard",
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

/// A command waiting in the queue.
#[derive(Clone, Debug)]
pub struct Job {
    /// Where it came from.
    pub source: Source,
    /// Its sequence number.
    pub seq: u16,
    /// One or more protocol messages, each ending in `;`, sent in turn.
    pub text: heapless::String<MSG_MAX>,
    /// It starts a motion (Done when the motion ends).
    pub motion: bool,
    /// It acts on a running motion (stop, pause, continue): it may pass
    /// motions waiting in the queue.
    pub interrupting: bool,
    /// Result registers to fill.
    pub results: Results,
}

/// `true` for commands that act on a running motion.
pub fn is_interrupting(id: CommandId) -> bool {
    matches!(
        id,
        CommandId::GrpStop
            | CommandId::GrpInterrupt
            | CommandId::GrpContinue
            | CommandId::StopScript
            | CommandId::PauseScript
            | CommandId::ContinueScript
    )
}

impl Job {
    /// A job of one protocol message written by the PLC (RAW or trigger):
    /// checked with the codec's grammar, sent as written (a missing
    /// terminator is added).
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
        let mut out = heapless::String::new();
        out.push_str(t).map_err(|_| GatewayError::BadParameter)?;
        if !t.ends_with(';') {
            let tail = if t.ends_with(',') { ";" } else { ",;" };
            out.push_str(tail).map_err(|_| GatewayError::BadParameter)?;
        }
        Ok(Job {
            source,
            seq,
            text: out,
            motion: id.is_some_and(CommandId::is_motion),
            interrupting: id.is_some_and(is_interrupting),
            results: Results::None,
        })
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
        assert!(j.interrupting && !j.motion);
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
