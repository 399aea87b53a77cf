//! The PLCopen handshake of one source (a channel, RAW, a trigger entry):
//! Busy while its command is queued or runs, then exactly one of Done,
//! Error or CommandAborted until the PLC lets go of Execute (or fires the
//! next command).

use crate::error::{ErrorSource, Outcome};

/// Where a source's command is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Phase {
    /// Nothing to show (never fired, or the outputs were cleared).
    #[default]
    Idle,
    /// Busy, waiting in the queue.
    Queued,
    /// Busy: being sent, or waiting for a bring-up step's state.
    Running,
    /// Busy: its motion runs on the robot.
    Moving,
    /// Ended: how.
    Ended(Outcome),
}

impl Phase {
    /// Its word in the views (`idle`, `queued`, `running`, `moving`, or the
    /// outcome's: the page, the API, the Sparkplug metrics).
    pub const fn as_str(self) -> &'static str {
        match self {
            Phase::Idle => "idle",
            Phase::Queued => "queued",
            Phase::Running => "running",
            Phase::Moving => "moving",
            Phase::Ended(o) => o.as_str(),
        }
    }
}

/// A source's handshake outputs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Handshake {
    /// Where its command is.
    pub phase: Phase,
    /// The sequence number latched at the rising edge.
    pub seq_echo: u16,
    /// The command code latched at the rising edge (channels).
    pub command_echo: u16,
    /// Messages of the current command sent to the robot so far (a job is
    /// never sent twice: at most its number of steps).
    pub sends: u8,
    /// Execute fell while the command was Busy (a jog stops on it, even if
    /// Execute rose again at once: an edge while Busy is ignored).
    pub released: bool,
}

impl Handshake {
    /// Busy: queued, being sent, or its motion runs.
    pub fn is_busy(&self) -> bool {
        matches!(self.phase, Phase::Queued | Phase::Running | Phase::Moving)
    }

    /// The outcome, once ended.
    pub fn outcome(&self) -> Option<Outcome> {
        match self.phase {
            Phase::Ended(o) => Some(o),
            _ => None,
        }
    }

    /// ErrorID and error source (0, 0 unless Error).
    pub fn error(&self) -> (i32, u16) {
        match self.phase {
            Phase::Ended(Outcome::Error(source, id)) => (id, source as u16),
            _ => (0, 0),
        }
    }

    /// A rising edge started a command: Busy and Queued, echoes latched.
    pub fn start(&mut self, seq: u16, command: u16) {
        *self = Handshake {
            phase: Phase::Queued,
            seq_echo: seq,
            command_echo: command,
            sends: 0,
            released: false,
        };
    }

    /// The command ended.
    pub fn finish(&mut self, outcome: Outcome) {
        self.phase = Phase::Ended(outcome);
    }

    /// Execute fell: the outcome clears (not while Busy: a command that
    /// still runs shows its outcome until the next rising edge). The echoes
    /// stay.
    pub fn release(&mut self) {
        if self.is_busy() {
            self.released = true;
        } else {
            self.phase = Phase::Idle;
        }
    }
}

/// The error source of an outcome, for views (0 unless Error).
pub fn source_code(o: Option<Outcome>) -> u16 {
    match o {
        Some(Outcome::Error(s, _)) => s as u16,
        _ => 0,
    }
}

impl ErrorSource {
    /// A short name for views.
    pub fn as_str(self) -> &'static str {
        match self {
            ErrorSource::RobotFail => "robot refused",
            ErrorSource::RobotMotion => "robot error during the motion",
            ErrorSource::Gateway => "gateway",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::GatewayError;
    use crate::registers::map::{ST_ACTIVE, ST_BUSY, ST_ERROR, ST_QUEUED};

    #[test]
    fn outputs_follow_the_handshake() {
        let mut h = Handshake::default();
        h.start(7, 3);
        assert!(h.is_busy());
        assert_eq!(crate::registers::view::status_bits(&h), ST_BUSY | ST_QUEUED);
        h.phase = Phase::Moving;
        assert_eq!(crate::registers::view::status_bits(&h), ST_BUSY | ST_ACTIVE);
        // Execute falls while Busy: nothing changes.
        h.release();
        assert!(h.is_busy());
        h.finish(Outcome::Error(ErrorSource::RobotFail, 20018));
        assert_eq!(crate::registers::view::status_bits(&h), ST_ERROR);
        assert_eq!(h.error(), (20018, 1));
        assert_eq!(h.seq_echo, 7);
        h.release();
        assert_eq!(
            (
                crate::registers::view::status_bits(&h),
                h.error(),
                h.seq_echo
            ),
            (0, (0, 0), 7)
        );
        h.start(8, 3);
        h.finish(Outcome::gateway(GatewayError::QueueFull));
        assert_eq!(h.error(), (39600, 3));
    }
}
