//! The status mirror: robot state copied into the status registers.
//!
//! Two sources: polling the command port (a round of read commands every
//! poll period, one request at a time, between PLC commands) or the
//! DataSheet port (see [`crate::datasheet`]). Motion completion always
//! polls `ReadRobotState` on the command port.

use hans_codec::{
    request, response, Command, Decimal, FsmState, Reply, ReplyExpect, Response, RobotId,
};

use crate::config::WordOrder;
use crate::registers::{self as r, RegisterFile};

/// Robot link state (register `LINK_STATE`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LinkState {
    /// Down: waiting before the next attempt (backoff) or not configured.
    Down = 0,
    /// Connecting to the controller.
    Connecting = 1,
    /// Waiting for the controller to connect (listen mode).
    Listening = 2,
    /// Connected.
    Connected = 3,
}

/// The read commands of one polling round, in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PollStep {
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
    /// A full round.
    pub const ROUND: [PollStep; 9] = [
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

    /// Writes the request into `out`; returns its length and the reply it
    /// expects.
    pub fn request(self, robot_id: u8, out: &mut [u8]) -> Option<(usize, ReplyExpect)> {
        let id = RobotId(i32::from(robot_id));
        let box8 =
            || heapless::Vec::<i32, 8>::from_slice(&[0, 1, 2, 3, 4, 5, 6, 7]).unwrap_or_default();
        let end3 = || heapless::Vec::<i32, 3>::from_slice(&[0, 1, 2]).unwrap_or_default();
        fn enc<'c, C: Command<'c>>(c: C, out: &mut [u8]) -> Option<(usize, ReplyExpect)> {
            Some((c.encode(out).ok()?, c.expect()))
        }
        match self {
            PollStep::RobotState => enc(request::ReadRobotState { rbt_id: id }, out),
            PollStep::Fsm => enc(request::ReadCurFSM { rbt_id: id }, out),
            PollStep::ActPos => enc(request::ReadActPos { rbt_id: id }, out),
            PollStep::Io(Io::BoxDi) => enc(request::ReadBoxDI { bits: box8() }, out),
            PollStep::Io(Io::BoxDo) => enc(request::ReadBoxDO { bits: box8() }, out),
            PollStep::Io(Io::BoxCi) => enc(request::ReadBoxCI { bits: box8() }, out),
            PollStep::Io(Io::BoxCo) => enc(request::ReadBoxCO { bits: box8() }, out),
            PollStep::Io(Io::EndDi) => enc(
                request::ReadEI {
                    rbt_id: id,
                    bits: end3(),
                },
                out,
            ),
            PollStep::Io(Io::EndDo) => enc(
                request::ReadEO {
                    rbt_id: id,
                    bits: end3(),
                },
                out,
            ),
        }
    }

    /// Copies a reply of this step into the registers. A `Fail` reply (the
    /// robot lacks that I/O, say) marks the value invalid.
    pub fn apply(self, reply: &Reply<'_>, regs: &mut RegisterFile, order: WordOrder) {
        match reply {
            Reply::Ok(resp) => apply_response(resp, regs, order),
            _ => {
                if let PollStep::Io(io) = self {
                    regs.set_bits(r::STATUS_IO_VALID, io.valid_bit(), false);
                }
            }
        }
    }
}

/// One of the I/O groups mirrored in `BOX_DI` ... `END_DO`, each with its
/// bit in `IO_VALID`. Both status sources write them through [`set_io`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Io {
    /// The box's digital inputs (`BOX_DI`).
    BoxDi,
    /// The box's digital outputs (`BOX_DO`).
    BoxDo,
    /// The box's configurable inputs (`BOX_CI`).
    BoxCi,
    /// The box's configurable outputs (`BOX_CO`).
    BoxCo,
    /// The tool flange's digital inputs (`END_DI`).
    EndDi,
    /// The tool flange's digital outputs (`END_DO`).
    EndDo,
}

impl Io {
    /// The group's register.
    pub const fn register(self) -> u16 {
        match self {
            Io::BoxDi => r::STATUS_BOX_DI,
            Io::BoxDo => r::STATUS_BOX_DO,
            Io::BoxCi => r::STATUS_BOX_CI,
            Io::BoxCo => r::STATUS_BOX_CO,
            Io::EndDi => r::STATUS_END_DI,
            Io::EndDo => r::STATUS_END_DO,
        }
    }

    /// The group's bit in `IO_VALID`.
    pub const fn valid_bit(self) -> u16 {
        match self {
            Io::BoxDi => 1 << 0,
            Io::BoxDo => 1 << 1,
            Io::BoxCi => 1 << 2,
            Io::BoxCo => 1 << 3,
            Io::EndDi => 1 << 4,
            Io::EndDo => 1 << 5,
        }
    }
}

/// Packs I/O values (0 off, anything else on) into a register, value `i`
/// in bit `i`. Values beyond the sixteenth have no bit and are left out
/// (the codec's lists hold at most 16).
fn bits(values: &[i32]) -> u16 {
    values
        .iter()
        .take(16)
        .enumerate()
        .filter(|(_, v)| **v != 0)
        .fold(0, |acc, (i, _)| acc | (1 << i))
}

/// Writes an I/O group's values and marks them valid in `IO_VALID`.
pub fn set_io(regs: &mut RegisterFile, io: Io, values: &[i32]) {
    regs.set(io.register(), bits(values));
    regs.set_bits(r::STATUS_IO_VALID, io.valid_bit(), true);
}

/// Writes the six actual joint angles (`ACT_JOINTS`, f32 in °).
pub fn set_joints(regs: &mut RegisterFile, joints: &[Decimal; 6], order: WordOrder) {
    set_f32s(
        regs,
        r::STATUS_JOINTS,
        joints.iter().map(Decimal::to_f32),
        order,
    );
}

/// Writes the actual TCP pose (`ACT_POSE`, f32 in mm and °).
pub fn set_pose(regs: &mut RegisterFile, pose: &[Decimal; 6], order: WordOrder) {
    set_f32s(
        regs,
        r::STATUS_POSE,
        pose.iter().map(Decimal::to_f32),
        order,
    );
}

/// Writes six f32 values to the registers from `start` on.
fn set_f32s(
    regs: &mut RegisterFile,
    start: u16,
    values: impl Iterator<Item = f32>,
    order: WordOrder,
) {
    for (a, v) in (start..).step_by(2).zip(values.take(6)) {
        regs.set_f32(a, v, order);
    }
}

/// Sets `FSM_STATE` (65535 for states beyond 16 bits).
pub fn set_fsm(regs: &mut RegisterFile, state: FsmState) {
    let v = i32::from(state);
    regs.set(r::STATUS_FSM, u16::try_from(v).unwrap_or(u16::MAX));
}

/// Copies any status-bearing response into the registers.
pub fn apply_response(resp: &Response<'_>, regs: &mut RegisterFile, order: WordOrder) {
    match resp {
        Response::ReadRobotState(s) => apply_robot_state(s, regs, order),
        Response::ReadCurFSM(f) => set_fsm(regs, f.state),
        Response::ReadActPos(p) => {
            set_joints(regs, &p.joints, order);
            set_pose(regs, &p.pose, order);
        }
        Response::ReadBoxDI(v) => set_io(regs, Io::BoxDi, &v.values),
        Response::ReadBoxDO(v) => set_io(regs, Io::BoxDo, &v.values),
        Response::ReadBoxCI(v) => set_io(regs, Io::BoxCi, &v.values),
        Response::ReadBoxCO(v) => set_io(regs, Io::BoxCo, &v.values),
        Response::ReadEI(v) => set_io(regs, Io::EndDi, &v.values),
        Response::ReadEO(v) => set_io(regs, Io::EndDo, &v.values),
        _ => {}
    }
}

/// The flags of `ReadRobotState` as the `ROBOT_FLAGS` register.
pub fn flags_of(s: &response::ReadRobotState) -> u16 {
    let f = |v: i32, bit: u16| if v != 0 { bit } else { 0 };
    f(s.moving, r::FLAG_MOVING)
        | f(s.enabled, r::FLAG_ENABLED)
        | f(s.error, r::FLAG_ERROR)
        | f(s.paused, r::FLAG_PAUSED)
        | f(s.emergency_stop, r::FLAG_EMERGENCY_STOP)
        | f(s.safety_guard, r::FLAG_SAFETY_GUARD)
        | f(s.powered, r::FLAG_POWERED)
        | f(s.box_connected, r::FLAG_BOX_CONNECTED)
        | f(s.blending_done, r::FLAG_BLENDING_DONE)
        | f(s.in_position, r::FLAG_IN_POSITION)
        | f(s.brake_released, r::FLAG_BRAKE_RELEASED)
        | r::FLAG_VALID
}

/// Copies `ReadRobotState` into the registers.
pub fn apply_robot_state(s: &response::ReadRobotState, regs: &mut RegisterFile, order: WordOrder) {
    regs.set(r::STATUS_FLAGS, flags_of(s));
    regs.set_i32(r::STATUS_ERROR_CODE, s.error_code, order);
    regs.set(
        r::STATUS_ERROR_AXIS,
        u16::try_from(s.error_axis).unwrap_or(u16::MAX),
    );
}

/// Marks the robot status unknown (at start, and when the link is lost):
/// `FSM_STATE` 65535, `ROBOT_FLAGS` 0 (valid bit clear), error code and
/// axis 0, override, joints and pose NaN, I/O registers and `IO_VALID` 0.
/// Nothing of an earlier link survives, so no old value can pass for a
/// current one.
pub fn invalidate(regs: &mut RegisterFile, order: WordOrder) {
    regs.set(r::STATUS_FSM, u16::MAX);
    regs.set(r::STATUS_FLAGS, 0);
    regs.set_i32(r::STATUS_ERROR_CODE, 0, order);
    regs.set(r::STATUS_ERROR_AXIS, 0);
    regs.set_f32(r::STATUS_OVERRIDE, f32::NAN, order);
    let nan = || core::iter::repeat(f32::NAN);
    set_f32s(regs, r::STATUS_JOINTS, nan(), order);
    set_f32s(regs, r::STATUS_POSE, nan(), order);
    for a in r::STATUS_BOX_DI..=r::STATUS_IO_VALID {
        regs.set(a, 0);
    }
}

/// The actual joints from the status registers (IK reference).
pub fn joints(regs: &RegisterFile, order: WordOrder) -> [f32; 6] {
    let mut j = [0.0; 6];
    for (i, v) in j.iter_mut().enumerate() {
        let x = regs.get_f32(r::STATUS_JOINTS + 2 * i as u16, order);
        *v = if x.is_finite() { x } else { 0.0 };
    }
    j
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn robot_state_and_io_replies_fill_the_registers() {
        let mut regs = RegisterFile::new();
        let mut buf = [0u8; 64];
        let (n, exp) = PollStep::RobotState.request(0, &mut buf).unwrap();
        assert_eq!(&buf[..n], b"ReadRobotState,0,;");
        let rep = Reply::parse("ReadRobotState,OK,1,1,0,0,0,0,0,0,0,1,1,0,0,;", exp).unwrap();
        PollStep::RobotState.apply(&rep, &mut regs, WordOrder::HighFirst);
        assert_eq!(
            regs.get(r::STATUS_FLAGS),
            r::FLAG_VALID
                | r::FLAG_MOVING
                | r::FLAG_ENABLED
                | r::FLAG_POWERED
                | r::FLAG_BOX_CONNECTED
        );
        let (n, exp) = PollStep::Io(Io::BoxDo).request(0, &mut buf).unwrap();
        assert_eq!(&buf[..n], b"ReadBoxDO,0,1,2,3,4,5,6,7,;");
        let rep = Reply::parse("ReadBoxDO,OK,1,0,0,1,0,0,0,1,;", exp).unwrap();
        PollStep::Io(Io::BoxDo).apply(&rep, &mut regs, WordOrder::HighFirst);
        assert_eq!(regs.get(r::STATUS_BOX_DO), 0b1000_1001);
        assert_eq!(regs.get(r::STATUS_IO_VALID), 1 << 1);
        let rep = Reply::parse("ReadBoxDO,Fail,20009,;", exp).unwrap();
        PollStep::Io(Io::BoxDo).apply(&rep, &mut regs, WordOrder::HighFirst);
        assert_eq!(regs.get(r::STATUS_IO_VALID), 0);
        let (_, exp) = PollStep::ActPos.request(0, &mut buf).unwrap();
        let rep = Reply::parse(
            "ReadActPos,OK,1,2,3,4,5,6,420,0,445,180,0,180,0,0,0,0,0,0,0,0,0,0,0,0,;",
            exp,
        )
        .unwrap();
        PollStep::ActPos.apply(&rep, &mut regs, WordOrder::LowFirst);
        assert_eq!(
            joints(&regs, WordOrder::LowFirst),
            [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]
        );
        assert_eq!(regs.get_f32(r::STATUS_POSE + 4, WordOrder::LowFirst), 445.0);
        invalidate(&mut regs, WordOrder::HighFirst);
        assert_eq!(regs.get(r::STATUS_FSM), 0xFFFF);
        assert_eq!(regs.get(r::STATUS_FLAGS), 0);
        assert!(regs
            .get_f32(r::STATUS_POSE + 10, WordOrder::HighFirst)
            .is_nan());
        assert_eq!(regs.get(r::STATUS_BOX_DO), 0);
        // The IK reference of moves to a pose stays finite.
        assert_eq!(joints(&regs, WordOrder::HighFirst), [0.0; 6]);
    }
}
