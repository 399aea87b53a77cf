//! The command codes of the channels: register inputs → a typed command,
//! checked against the protocol document's ranges when the PLC fires it.
//!
//! | code | command | parameters |
//! |---|---|---|
//! | 1 | power-on sequence: `ConnectToBox`, `Electrify`, `StartMaster` | — |
//! | 2 | `BlackOut` | — |
//! | 3 | `GrpEnable` | — |
//! | 4 | `GrpDisable` (urgent) | — |
//! | 5 | `GrpReset` (urgent) | — |
//! | 6 | `GrpStop` (urgent) | — |
//! | 7 | `GrpInterrupt` (pause, urgent) | — |
//! | 8 | `GrpContinue` (urgent) | — |
//! | 10 | joint move to joints (`WayPoint`, joint, use joints) | P0-P5 joints, P6 velocity, P7 acc, P8 radius, TEXT1 tool, TEXT2 frame |
//! | 11 | joint move to a pose (`WayPoint`, joint) | P0-P5 pose, P6-P8 as above |
//! | 12 | linear move to a pose (`WayPoint`, linear) | P0-P5 pose, P6-P8 as above |
//! | 13 | relative joint move (`MoveRelJ`) | P0 axis 0-5, P1 distance (sign = direction) |
//! | 14 | relative linear move (`MoveRelL`) | P0 axis 0-5, P1 distance, P2 frame 0 user / 1 tool |
//! | 20 | `SetOverride` | P0 ratio 0.01-1 |
//! | 21 | `SetBoxDO` | P0 bit 0-7, P1 value 0/1 |
//! | 22 | `SetEndDO` | P0 bit 0-2, P1 value 0/1 |
//! | 23 | `SetBoxCO` | P0 bit 0-7, P1 value 0/1 |
//! | 30 | `StartScript` | — |
//! | 31-33 | `StopScript`, `PauseScript`, `ContinueScript` (urgent) | — |
//! | 34 | `RunFunc` | TEXT1 function, TEXT2 parameters separated by `,` |
//! | 40 | `ReadActPos` | results R0-R5 joints, R6-R11 pose, R12-R17 tool, R18-R23 frame |
//! | 60-71 | joint jog (`LongJogJ` + `LongMoveEvent`, V6): 60 + 2 × axis + direction (J1- = 60, J1+ = 61, ..., J6+ = 71) | — (runs while Execute is held) |
//! | 80-91 | Cartesian jog (`LongJogL` + `LongMoveEvent`, V6): 80 + 2 × axis + direction (X- = 80, X+ = 81, Y, Z, Rx, Ry, Rz+ = 91) | — |
//!
//! Numbers the PLC gives are sent with three decimals (`50.000`); fields
//! the gateway fills itself are sent as integers (`0`, `1`), except the IK
//! reference joints of codes 11 and 12 (`ACT_JOINTS`, three decimals).

use hans_codec::{request, Decimal, RobotId, TextList};

use super::{JobKind, Message, Urgent, Wire};
use crate::error::GatewayError;

/// Command codes (register `CHn_COMMAND`).
pub mod code {
    /// Power-on sequence.
    pub const POWER_ON: u16 = 1;
    /// `BlackOut`.
    pub const POWER_OFF: u16 = 2;
    /// `GrpEnable`.
    pub const ENABLE: u16 = 3;
    /// `GrpDisable`.
    pub const DISABLE: u16 = 4;
    /// `GrpReset`.
    pub const RESET: u16 = 5;
    /// `GrpStop`.
    pub const STOP: u16 = 6;
    /// `GrpInterrupt`.
    pub const PAUSE: u16 = 7;
    /// `GrpContinue`.
    pub const CONTINUE: u16 = 8;
    /// Joint move to joint values.
    pub const MOVE_J_JOINTS: u16 = 10;
    /// Joint move to a pose.
    pub const MOVE_J_POSE: u16 = 11;
    /// Linear move to a pose.
    pub const MOVE_L_POSE: u16 = 12;
    /// Relative joint move.
    pub const MOVE_REL_J: u16 = 13;
    /// Relative linear move.
    pub const MOVE_REL_L: u16 = 14;
    /// `SetOverride`.
    pub const SET_OVERRIDE: u16 = 20;
    /// `SetBoxDO`.
    pub const SET_BOX_DO: u16 = 21;
    /// `SetEndDO`.
    pub const SET_END_DO: u16 = 22;
    /// `SetBoxCO`.
    pub const SET_BOX_CO: u16 = 23;
    /// `StartScript`.
    pub const START_SCRIPT: u16 = 30;
    /// `StopScript`.
    pub const STOP_SCRIPT: u16 = 31;
    /// `PauseScript`.
    pub const PAUSE_SCRIPT: u16 = 32;
    /// `ContinueScript`.
    pub const CONTINUE_SCRIPT: u16 = 33;
    /// `RunFunc`.
    pub const RUN_FUNC: u16 = 34;
    /// `ReadActPos`.
    pub const READ_ACT_POS: u16 = 40;
    /// Joint jog: `JOG_J + 2 × axis + direction` (axis 0-5 = J1-J6,
    /// direction 1 = positive).
    pub const JOG_J: u16 = 60;
    /// Cartesian jog: `JOG_L + 2 × axis + direction` (axis 0-5 = X, Y, Z,
    /// Rx, Ry, Rz).
    pub const JOG_L: u16 = 80;
    /// Every code but the jog ones, in order.
    pub const ALL: [u16; 23] = [
        POWER_ON,
        POWER_OFF,
        ENABLE,
        DISABLE,
        RESET,
        STOP,
        PAUSE,
        CONTINUE,
        MOVE_J_JOINTS,
        MOVE_J_POSE,
        MOVE_L_POSE,
        MOVE_REL_J,
        MOVE_REL_L,
        SET_OVERRIDE,
        SET_BOX_DO,
        SET_END_DO,
        SET_BOX_CO,
        START_SCRIPT,
        STOP_SCRIPT,
        PAUSE_SCRIPT,
        CONTINUE_SCRIPT,
        RUN_FUNC,
        READ_ACT_POS,
    ];
}

/// A name of 32 characters at most (tool, frame, function, its parameters).
pub type Name = heapless::String<32>;

/// The three absolute moves (codes 10-12), all `WayPoint`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MoveKind {
    /// Code 10: joint move to joint values.
    JointToJoints,
    /// Code 11: joint move to a pose (IK reference: the actual joints).
    JointToPose,
    /// Code 12: linear move to a pose.
    LinearToPose,
}

/// An absolute move.
#[derive(Clone, Debug, PartialEq)]
pub struct Move {
    /// Which move.
    pub kind: MoveKind,
    /// Target joints (code 10) or pose (11, 12).
    pub target: [Decimal; 6],
    /// IK reference joints for moves to a pose (the actual joints when
    /// fired; zero when unknown).
    pub reference: [Decimal; 6],
    /// Tool frame name.
    pub tool: Name,
    /// User frame name.
    pub frame: Name,
    /// Velocity.
    pub velocity: Decimal,
    /// Acceleration.
    pub acc: Decimal,
    /// Blend radius.
    pub radius: Decimal,
    /// `strCmdID`: the sequence number.
    pub cmd_id: u16,
}

/// A typed command of a channel (the urgent codes become [`Urgent`]).
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    /// Code 1: `ConnectToBox`, `Electrify`, `StartMaster`, each after the
    /// state of the one before.
    PowerOn,
    /// Code 2: `BlackOut`.
    PowerOff,
    /// Code 3: `GrpEnable`.
    Enable,
    /// Codes 10-12.
    Move(Move),
    /// Code 13: `MoveRelJ`.
    MoveRelJ {
        /// Axis 0-5.
        axis: i32,
        /// 0 negative, 1 positive.
        direction: i32,
        /// Distance [°].
        distance: Decimal,
    },
    /// Code 14: `MoveRelL`.
    MoveRelL {
        /// Axis 0-5 (X, Y, Z, Rx, Ry, Rz).
        axis: i32,
        /// 0 negative, 1 positive.
        direction: i32,
        /// Distance [mm or °].
        distance: Decimal,
        /// 0 user frame, 1 tool frame.
        tool_motion: i32,
    },
    /// Code 20: `SetOverride`.
    SetOverride(Decimal),
    /// Code 21: `SetBoxDO`.
    SetBoxDo {
        /// Bit 0-7.
        bit: i32,
        /// 0/1.
        value: i32,
    },
    /// Code 22: `SetEndDO`.
    SetEndDo {
        /// Bit 0-2.
        bit: i32,
        /// 0/1.
        value: i32,
    },
    /// Code 23: `SetBoxCO`.
    SetBoxCo {
        /// Bit 0-7.
        bit: i32,
        /// 0/1.
        value: i32,
    },
    /// Code 30: `StartScript`.
    StartScript,
    /// Code 34: `RunFunc`.
    RunFunc {
        /// Function name.
        name: Name,
        /// Its parameters, separated by `,`.
        params: Name,
    },
    /// Code 40: `ReadActPos`, into the result registers.
    ReadActPos,
    /// Codes 60-71 and 80-91: a long jog, running while Execute is held.
    Jog(Jog),
}

/// A jog (codes 60-71, 80-91): MC_Jog's hold semantics, see
/// `REGISTERS.md` (Jogging).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Jog {
    /// Cartesian (`LongJogL`) rather than joint (`LongJogJ`).
    pub cartesian: bool,
    /// Joint J1-J6 or direction X-Rz as 0-5.
    pub axis: u8,
    /// The positive direction.
    pub positive: bool,
}

impl Jog {
    /// The jog of command `code`, if it is a jog code.
    pub fn of(code: u16) -> Option<Jog> {
        let (cartesian, off) = match code {
            c if (code::JOG_J..code::JOG_J + 12).contains(&c) => (false, c - code::JOG_J),
            c if (code::JOG_L..code::JOG_L + 12).contains(&c) => (true, c - code::JOG_L),
            _ => return None,
        };
        Some(Jog {
            cartesian,
            axis: (off / 2) as u8,
            positive: off % 2 == 1,
        })
    }

    /// The jog request: start (`on`) or stop.
    #[cfg(feature = "v6")]
    pub fn request(&self, robot: u8, on: bool, buf: &mut [u8]) -> Option<Message> {
        let (rbt_id, axis) = (RobotId(i32::from(robot)), i32::from(self.axis));
        let (direction, state) = (i32::from(self.positive), i32::from(on));
        if self.cartesian {
            request::LongJogL {
                rbt_id,
                axis,
                direction,
                state,
            }
            .wire(buf)
        } else {
            request::LongJogJ {
                rbt_id,
                axis,
                direction,
                state,
            }
            .wire(buf)
        }
    }

    /// The keep-alive, `LongMoveEvent`.
    #[cfg(feature = "v6")]
    pub fn keep_alive(robot: u8, buf: &mut [u8]) -> Option<Message> {
        request::LongMoveEvent {
            rbt_id: RobotId(i32::from(robot)),
        }
        .wire(buf)
    }

    /// The controller version that has long jogs.
    #[cfg(feature = "v6")]
    pub fn since() -> hans_codec::ProtocolLevel {
        hans_codec::CommandId::LongJogJ.since()
    }
}

/// What a channel's registers hold when Execute rises.
#[derive(Clone, Copy, Debug)]
pub struct Inputs<'a> {
    /// Command code.
    pub code: u16,
    /// P0-P11.
    pub params: &'a [f32; 12],
    /// TEXT1 (trimmed).
    pub text1: &'a str,
    /// TEXT2 (trimmed).
    pub text2: &'a str,
    /// Sequence number.
    pub seq: u16,
    /// Actual joints (IK reference for moves to a pose), if known.
    pub joints: Option<[f32; 6]>,
}

const BAD: GatewayError = GatewayError::BadParameter;

fn dec(v: f32) -> Result<Decimal, GatewayError> {
    Decimal::from_f32(v, 3).ok_or(BAD)
}

fn int(v: f32) -> Result<i32, GatewayError> {
    let i = v as i32;
    if i as f32 == v {
        Ok(i)
    } else {
        Err(BAD)
    }
}

fn six(p: &[f32]) -> Result<[Decimal; 6], GatewayError> {
    let mut out = [Decimal::ZERO; 6];
    for (o, v) in out.iter_mut().zip(p) {
        *o = dec(*v)?;
    }
    Ok(out)
}

fn name(t: &str, default: &str) -> Result<Name, GatewayError> {
    Name::try_from(if t.is_empty() { default } else { t }).map_err(|_| BAD)
}

/// Splits a signed distance into the protocol's direction and distance.
fn signed(v: f32) -> Result<(i32, Decimal), GatewayError> {
    Ok((i32::from(v >= 0.0), dec(v.abs())?))
}

/// Builds the job of command code `inp.code`: a typed command (or urgent
/// command), checked against the document's ranges. Unknown codes, values
/// out of range and non-integers where integers are needed are
/// [`GatewayError::BadParameter`].
pub fn build(inp: &Inputs<'_>, robot: u8) -> Result<JobKind, GatewayError> {
    let p = inp.params;
    let urgent = |u| Ok(JobKind::Urgent(u));
    let bit_value = || Ok::<_, GatewayError>((int(p[0])?, int(p[1])?));
    let cmd = match inp.code {
        code::POWER_ON => Command::PowerOn,
        code::POWER_OFF => Command::PowerOff,
        code::ENABLE => Command::Enable,
        code::DISABLE => return urgent(Urgent::Disable),
        code::RESET => return urgent(Urgent::Reset),
        code::STOP => return urgent(Urgent::Stop),
        code::PAUSE => return urgent(Urgent::Pause),
        code::CONTINUE => return urgent(Urgent::Continue),
        code::STOP_SCRIPT => return urgent(Urgent::StopScript),
        code::PAUSE_SCRIPT => return urgent(Urgent::PauseScript),
        code::CONTINUE_SCRIPT => return urgent(Urgent::ContinueScript),
        code::MOVE_J_JOINTS | code::MOVE_J_POSE | code::MOVE_L_POSE => {
            let kind = match inp.code {
                code::MOVE_J_JOINTS => MoveKind::JointToJoints,
                code::MOVE_J_POSE => MoveKind::JointToPose,
                _ => MoveKind::LinearToPose,
            };
            let reference = match (kind, inp.joints) {
                (MoveKind::JointToJoints, _) | (_, None) => [Decimal::ZERO; 6],
                (_, Some(j)) => six(&j)?,
            };
            Command::Move(Move {
                kind,
                target: six(&p[..6])?,
                reference,
                tool: name(inp.text1, "TCP")?,
                frame: name(inp.text2, "Base")?,
                velocity: dec(p[6])?,
                acc: dec(p[7])?,
                radius: dec(p[8])?,
                cmd_id: inp.seq,
            })
        }
        code::MOVE_REL_J => {
            let (direction, distance) = signed(p[1])?;
            Command::MoveRelJ {
                axis: int(p[0])?,
                direction,
                distance,
            }
        }
        code::MOVE_REL_L => {
            let (direction, distance) = signed(p[1])?;
            Command::MoveRelL {
                axis: int(p[0])?,
                direction,
                distance,
                tool_motion: int(p[2])?,
            }
        }
        code::SET_OVERRIDE => Command::SetOverride(dec(p[0])?),
        code::SET_BOX_DO => {
            let (bit, value) = bit_value()?;
            Command::SetBoxDo { bit, value }
        }
        code::SET_BOX_CO => {
            let (bit, value) = bit_value()?;
            Command::SetBoxCo { bit, value }
        }
        code::SET_END_DO => {
            // The document allows bit 3 (older tool ends had four outputs),
            // but tool ends have three and END_DO reads outputs 0-2 only
            // (`ReadEO`): keep the code and the register in agreement.
            let (bit, value) = bit_value()?;
            if bit > 2 {
                return Err(BAD);
            }
            Command::SetEndDo { bit, value }
        }
        code::START_SCRIPT => Command::StartScript,
        code::RUN_FUNC => {
            if inp.text1.is_empty() {
                return Err(BAD);
            }
            Command::RunFunc {
                name: name(inp.text1, "")?,
                params: name(inp.text2, "")?,
            }
        }
        code::READ_ACT_POS => Command::ReadActPos,
        c => match Jog::of(c) {
            // Without the V6 commands (the core firmwares) there is no jog.
            Some(_) if !cfg!(feature = "v6") => return Err(GatewayError::NotSupported),
            Some(j) => Command::Jog(j),
            None => return Err(BAD),
        },
    };
    // Every step's request must pass the document's ranges.
    for step in 0..cmd.steps() {
        cmd.with_request(step, robot, &mut |r| r.check().map_err(|_| BAD))
            .ok_or(BAD)??;
    }
    Ok(JobKind::Command(cmd))
}

impl Command {
    /// A motion (Done when the robot has finished it).
    pub fn is_motion(&self) -> bool {
        matches!(
            self,
            Command::Move(_)
                | Command::MoveRelJ { .. }
                | Command::MoveRelL { .. }
                | Command::Jog(_)
        )
    }

    /// Messages sent in turn.
    pub fn steps(&self) -> u8 {
        match self {
            Command::PowerOn => 3,
            _ => 1,
        }
    }

    /// Writes message `step` for robot `robot` into `buf`.
    pub fn encode(&self, step: u8, robot: u8, buf: &mut [u8]) -> Option<Message> {
        self.with_request(step, robot, &mut |r| r.wire(buf))?
    }

    /// Calls `f` with the codec request of message `step`: the one place
    /// each command's request is built, for checking and for sending.
    /// `None` for a step the command does not have.
    pub fn with_request<R>(
        &self,
        step: u8,
        robot: u8,
        f: &mut dyn FnMut(&dyn Wire) -> R,
    ) -> Option<R> {
        let rbt_id = RobotId(i32::from(robot));
        if step >= self.steps() {
            return None;
        }
        Some(match self {
            Command::PowerOn => match step {
                0 => f(&request::ConnectToBox {}),
                1 => f(&request::Electrify {}),
                _ => f(&request::StartMaster {}),
            },
            Command::PowerOff => f(&request::BlackOut {}),
            Command::Enable => f(&request::GrpEnable { rbt_id }),
            Command::Move(m) => {
                let to_joints = m.kind == MoveKind::JointToJoints;
                let mut id = itoa::Buffer::new();
                f(&request::WayPoint {
                    rbt_id,
                    pose: if to_joints {
                        [Decimal::ZERO; 6]
                    } else {
                        m.target
                    },
                    joints: if to_joints { m.target } else { m.reference },
                    tcp_name: &m.tool,
                    ucs_name: &m.frame,
                    velocity: m.velocity,
                    acc: m.acc,
                    radius: m.radius,
                    move_type: i32::from(m.kind == MoveKind::LinearToPose),
                    use_joint: i32::from(to_joints),
                    seek: 0,
                    io_bit: 0,
                    io_state: 0,
                    cmd_id: id.format(m.cmd_id),
                })
            }
            Command::MoveRelJ {
                axis,
                direction,
                distance,
            } => f(&request::MoveRelJ {
                rbt_id,
                axis: *axis,
                direction: *direction,
                distance: *distance,
            }),
            Command::MoveRelL {
                axis,
                direction,
                distance,
                tool_motion,
            } => f(&request::MoveRelL {
                rbt_id,
                axis: *axis,
                direction: *direction,
                distance: *distance,
                tool_motion: Some(*tool_motion),
            }),
            Command::SetOverride(ratio) => f(&request::SetOverride {
                rbt_id,
                ratio: *ratio,
            }),
            Command::SetBoxDo { bit, value } => f(&request::SetBoxDO {
                bit: *bit,
                value: *value,
            }),
            Command::SetBoxCo { bit, value } => f(&request::SetBoxCO {
                bit: *bit,
                value: *value,
            }),
            Command::SetEndDo { bit, value } => f(&request::SetEndDO {
                rbt_id,
                bit: *bit,
                value: *value,
            }),
            Command::StartScript => f(&request::StartScript {}),
            Command::RunFunc { name, params } => {
                let mut items = heapless::Vec::<&str, 16>::new();
                if !params.is_empty() {
                    for p in params.split(',') {
                        // 32 characters hold at most 16 parameters.
                        let _ = items.push(p.trim());
                    }
                }
                f(&request::RunFunc {
                    func_name: name,
                    params: TextList::new(&items),
                })
            }
            Command::ReadActPos => f(&request::ReadActPos { rbt_id }),
            #[cfg(feature = "v6")]
            Command::Jog(j) => {
                let (axis, direction) = (i32::from(j.axis), i32::from(j.positive));
                if j.cartesian {
                    f(&request::LongJogL {
                        rbt_id,
                        axis,
                        direction,
                        state: 1,
                    })
                } else {
                    f(&request::LongJogJ {
                        rbt_id,
                        axis,
                        direction,
                        state: 1,
                    })
                }
            }
            #[cfg(not(feature = "v6"))]
            Command::Jog(_) => return None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::{Job, Source};

    fn inputs(code: u16, params: &[f32]) -> ([f32; 12], u16) {
        let mut p = [0.0; 12];
        p[..params.len()].copy_from_slice(params);
        (p, code)
    }

    fn job(code: u16, params: &[f32], t1: &str, t2: &str, seq: u16) -> Result<Job, GatewayError> {
        let (p, code) = inputs(code, params);
        let inp = Inputs {
            code,
            params: &p,
            text1: t1,
            text2: t2,
            seq,
            joints: Some([0.0, 0.0, 90.0, 0.0, 90.0, 0.0]),
        };
        Ok(Job {
            source: Source::Channel(0),
            seq,
            robot: 0,
            kind: build(&inp, 0)?,
        })
    }

    fn text(j: &Job, step: u8) -> String {
        let mut buf = [0u8; 300];
        let m = j.encode(step, &mut buf).unwrap();
        String::from_utf8(buf[..m.len].to_vec()).unwrap()
    }

    #[test]
    fn moves_become_way_points() {
        let j = job(
            code::MOVE_L_POSE,
            &[420.0, 0.0, 445.0, 180.0, 0.0, 180.0, 50.0, 360.0, 0.0],
            "",
            "",
            42,
        )
        .unwrap();
        assert_eq!(
            text(&j, 0),
            "WayPoint,0,420.000,0.000,445.000,180.000,0.000,180.000,0.000,0.000,90.000,0.000,90.000,0.000,TCP,Base,50.000,360.000,0.000,1,0,0,0,0,42,;"
        );
        assert!(j.is_motion() && !j.is_urgent());
        let j = job(code::MOVE_REL_J, &[2.0, -5.5], "", "", 1).unwrap();
        assert_eq!(text(&j, 0), "MoveRelJ,0,2,0,5.500,;");
        assert!(j.is_motion());
        // Code 10: the pose fields the gateway fills are integers.
        let j = job(code::MOVE_J_JOINTS, &[1.0; 9], "T", "U", 3).unwrap();
        assert_eq!(
            text(&j, 0),
            "WayPoint,0,0,0,0,0,0,0,1.000,1.000,1.000,1.000,1.000,1.000,T,U,1.000,1.000,1.000,0,1,0,0,0,3,;"
        );
    }

    #[test]
    fn power_on_is_a_sequence_and_stop_is_urgent() {
        let j = job(code::POWER_ON, &[], "", "", 0).unwrap();
        assert_eq!(j.steps(), 3);
        let all: Vec<String> = (0..3).map(|s| text(&j, s)).collect();
        assert_eq!(all, ["ConnectToBox,;", "Electrify,;", "StartMaster,;"]);
        let mut buf = [0u8; 64];
        assert!(j.encode(3, &mut buf).is_none());
        let j = job(code::STOP, &[], "", "", 0).unwrap();
        assert_eq!(text(&j, 0), "GrpStop,0,;");
        assert!(j.is_urgent());
    }

    #[test]
    fn bad_parameters_are_refused() {
        let e = |c, p: &[f32]| job(c, p, "", "", 0).unwrap_err();
        assert_eq!(e(code::SET_BOX_DO, &[1.5, 1.0]), GatewayError::BadParameter);
        assert_eq!(e(code::SET_BOX_DO, &[8.0, 1.0]), GatewayError::BadParameter);
        // Tool-end outputs 0-2, the ones END_DO shows.
        assert_eq!(e(code::SET_END_DO, &[3.0, 1.0]), GatewayError::BadParameter);
        assert!(job(code::SET_END_DO, &[2.0, 1.0], "", "", 0).is_ok());
        assert_eq!(e(code::SET_OVERRIDE, &[1.5]), GatewayError::BadParameter);
        assert_eq!(
            e(code::SET_OVERRIDE, &[f32::NAN]),
            GatewayError::BadParameter
        );
        assert_eq!(e(999, &[]), GatewayError::BadParameter);
        assert_eq!(e(code::RUN_FUNC, &[]), GatewayError::BadParameter);
        let ok = job(code::SET_OVERRIDE, &[0.5], "", "", 0).unwrap();
        assert_eq!(text(&ok, 0), "SetOverride,0,0.500,;");
    }

    #[test]
    fn run_func_splits_its_parameters() {
        let j = job(code::RUN_FUNC, &[], "Pick", "1, a", 0).unwrap();
        assert_eq!(text(&j, 0), "RunFunc,Pick,1,a,;");
    }

    #[test]
    fn every_code_builds_with_valid_inputs() {
        // Valid for every command: axis/bit 1, value/distance 1, ratio 0.5 is
        // not 1... so ratio 1.0 is used (in range 0.01-1).
        for c in code::ALL {
            let j = job(c, &[1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 10.0, 10.0], "F", "", 0);
            assert!(j.is_ok(), "code {c}: {j:?}");
        }
    }
}
