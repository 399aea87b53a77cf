//! The status polls on the command port: one round of read commands per
//! `CFG_POLL_MS` between PLC commands, and the reads the motion and
//! bring-up rules need.

use hans_codec::{request, Reply, ReplyExpect};

use crate::job::{Message, Wire};
use crate::state::{Io, RobotStatus};

/// One status read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub(crate) enum PollStep {
    /// `ReadRobotState`.
    RobotState,
    /// `ReadCurFSM`.
    Fsm,
    /// `ReadActPos`.
    ActPos,
    /// The read of an I/O group: `ReadBoxDI`, `ReadBoxDO`, `ReadBoxCI`,
    /// `ReadBoxCO` bits 0-7, `ReadEI`, `ReadEO` bits 0-2.
    Io(Io),
}

impl PollStep {
    /// A full round, in order.
    pub(crate) const ROUND: [PollStep; 9] = [
        PollStep::RobotState,
        PollStep::Fsm,
        PollStep::ActPos,
        PollStep::Io(Io::BoxDi),
        PollStep::Io(Io::BoxDo),
        PollStep::Io(Io::BoxCi),
        PollStep::Io(Io::BoxCo),
        PollStep::Io(Io::EndDi),
        PollStep::Io(Io::EndDo),
    ];

    /// Writes the request for robot `robot` into `out`.
    pub(crate) fn request(self, robot: u8, out: &mut [u8]) -> Option<Message> {
        let rbt_id = hans_codec::RobotId(i32::from(robot));
        let box8 = || heapless::Vec::<i32, 8>::from_iter(0..8);
        let end3 = || heapless::Vec::<i32, 3>::from_iter(0..3);
        match self {
            PollStep::RobotState => request::ReadRobotState { rbt_id }.wire(out),
            PollStep::Fsm => request::ReadCurFSM { rbt_id }.wire(out),
            PollStep::ActPos => request::ReadActPos { rbt_id }.wire(out),
            PollStep::Io(Io::BoxDi) => request::ReadBoxDI { bits: box8() }.wire(out),
            PollStep::Io(Io::BoxDo) => request::ReadBoxDO { bits: box8() }.wire(out),
            PollStep::Io(Io::BoxCi) => request::ReadBoxCI { bits: box8() }.wire(out),
            PollStep::Io(Io::BoxCo) => request::ReadBoxCO { bits: box8() }.wire(out),
            PollStep::Io(Io::EndDi) => request::ReadEI {
                rbt_id,
                bits: end3(),
            }
            .wire(out),
            PollStep::Io(Io::EndDo) => request::ReadEO {
                rbt_id,
                bits: end3(),
            }
            .wire(out),
        }
    }

    /// Copies a reply of this step into the status. A `Fail` reply to an
    /// I/O read (the robot lacks that I/O, say) makes the group unknown.
    pub(crate) fn apply(self, reply: &Reply<'_>, status: &mut RobotStatus) {
        match (reply, self) {
            (Reply::Ok(resp), _) => status.apply_response(resp),
            (_, PollStep::Io(io)) => status.io_refused(io),
            _ => {}
        }
    }
}

/// A reply read without a type: any name, the values as sent.
pub(crate) const UNTYPED: ReplyExpect = ReplyExpect {
    command: None,
    count: None,
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_step_writes_its_request_and_copies_its_reply() {
        let mut buf = [0u8; 64];
        let m = PollStep::RobotState.request(0, &mut buf).unwrap();
        assert_eq!(&buf[..m.len], b"ReadRobotState,0,;");
        let m = PollStep::Io(Io::BoxDo).request(0, &mut buf).unwrap();
        assert_eq!(&buf[..m.len], b"ReadBoxDO,0,1,2,3,4,5,6,7,;");
        let m2 = PollStep::Io(Io::EndDi).request(1, &mut buf).unwrap();
        assert_eq!(&buf[..m2.len], b"ReadEI,1,0,1,2,;");
        let mut s = RobotStatus::UNKNOWN;
        let rep = Reply::parse("ReadBoxDO,OK,1,0,0,1,0,0,0,1,;", m.expect).unwrap();
        PollStep::Io(Io::BoxDo).apply(&rep, &mut s);
        assert_eq!(s.io(Io::BoxDo), Some(0b1000_1001));
        let rep = Reply::parse("ReadBoxDO,Fail,20009,;", m.expect).unwrap();
        PollStep::Io(Io::BoxDo).apply(&rep, &mut s);
        assert_eq!(s.io(Io::BoxDo), None);
    }
}
