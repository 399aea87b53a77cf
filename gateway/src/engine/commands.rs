//! The typed commands of the command channels: command code + parameters
//! → protocol text, written with the codec's request structs (so numbers,
//! names and ranges follow the command table).
//!
//! | code | command | parameters |
//! |---|---|---|
//! | 1 | power-on sequence: `ConnectToBox`, `Electrify`, `StartMaster` | — |
//! | 2 | `BlackOut` | — |
//! | 3 | `GrpEnable` | — |
//! | 4 | `GrpDisable` | — |
//! | 5 | `GrpReset` | — |
//! | 6 | `GrpStop` | — |
//! | 7 | `GrpInterrupt` (pause) | — |
//! | 8 | `GrpContinue` | — |
//! | 10 | joint move to joints (`WayPoint`, joint, use joints) | P0-P5 joints, P6 velocity, P7 acc, P8 radius, TEXT1 tool, TEXT2 frame |
//! | 11 | joint move to a pose (`WayPoint`, joint) | P0-P5 pose, P6-P8 as above |
//! | 12 | linear move to a pose (`WayPoint`, linear) | P0-P5 pose, P6-P8 as above |
//! | 13 | relative joint move (`MoveRelJ`) | P0 axis 0-5, P1 distance (sign = direction) |
//! | 14 | relative linear move (`MoveRelL`) | P0 axis 0-5, P1 distance, P2 frame 0 user / 1 tool |
//! | 20 | `SetOverride` | P0 ratio 0.01-1 |
//! | 21 | `SetBoxDO` | P0 bit 0-7, P1 value 0/1 |
//! | 22 | `SetEndDO` | P0 bit 0-2, P1 value 0/1 |
//! | 23 | `SetBoxCO` | P0 bit 0-7, P1 value 0/1 |
//! | 30-33 | `StartScript`, `StopScript`, `PauseScript`, `ContinueScript` | — |
//! | 34 | `RunFunc` | TEXT1 function, TEXT2 parameters separated by `,` |
//! | 40 | `ReadActPos` | results R0-R5 joints, R6-R11 pose, R12-R17 tool, R18-R23 frame |

use hans_codec::{request, Command, CommandId, Decimal, RobotId, TextList};

use super::job::{is_urgent, GatewayError, Job, Results, Source, MSG_MAX};
use crate::registers::CH_PARAM_COUNT;

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
}

/// What a channel's registers hold when Execute rises.
pub struct Inputs<'a> {
    /// Command code.
    pub code: u16,
    /// P0-P11.
    pub params: [f32; CH_PARAM_COUNT],
    /// TEXT1.
    pub text1: &'a str,
    /// TEXT2.
    pub text2: &'a str,
    /// Robot id from the configuration.
    pub robot_id: u8,
    /// Actual joints (IK reference for moves to a pose).
    pub joints: [f32; 6],
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

fn or_default<'a>(t: &'a str, d: &'a str) -> &'a str {
    if t.is_empty() {
        d
    } else {
        t
    }
}

/// Encodes `cmd` (after checking its ranges) and appends it to `out`.
fn put<'c, C: Command<'c>>(
    cmd: &C,
    out: &mut heapless::String<MSG_MAX>,
) -> Result<(), GatewayError> {
    let mut buf = [0u8; MSG_MAX];
    let n = cmd.validate().ok().and_then(|()| cmd.encode(&mut buf).ok());
    append(&buf, n, out)
}

/// The part of [`put`] that does not depend on the command (one copy in
/// flash instead of one per command).
#[inline(never)]
fn append(
    buf: &[u8],
    n: Option<usize>,
    out: &mut heapless::String<MSG_MAX>,
) -> Result<(), GatewayError> {
    let s = n
        .and_then(|n| buf.get(..n))
        .and_then(|b| core::str::from_utf8(b).ok())
        .ok_or(BAD)?;
    out.push_str(s).map_err(|_| BAD)
}

/// Builds the job of a typed command.
pub fn build(source: Source, seq: u16, inp: &Inputs<'_>) -> Result<Job, GatewayError> {
    let id = RobotId(i32::from(inp.robot_id));
    let p = &inp.params;
    let mut text = heapless::String::new();
    let mut results = Results::None;
    let cmd_id = itoa_buf(seq);
    let cmd_id = cmd_id.as_str();
    let command = match inp.code {
        code::POWER_ON => {
            put(&request::ConnectToBox {}, &mut text)?;
            put(&request::Electrify {}, &mut text)?;
            put(&request::StartMaster {}, &mut text)?;
            CommandId::StartMaster
        }
        code::POWER_OFF => {
            put(&request::BlackOut {}, &mut text)?;
            CommandId::BlackOut
        }
        code::ENABLE => {
            put(&request::GrpEnable { rbt_id: id }, &mut text)?;
            CommandId::GrpEnable
        }
        code::DISABLE => {
            put(&request::GrpDisable { rbt_id: id }, &mut text)?;
            CommandId::GrpDisable
        }
        code::RESET => {
            put(&request::GrpReset { rbt_id: id }, &mut text)?;
            CommandId::GrpReset
        }
        code::STOP => {
            put(&request::GrpStop { rbt_id: id }, &mut text)?;
            CommandId::GrpStop
        }
        code::PAUSE => {
            put(&request::GrpInterrupt { rbt_id: id }, &mut text)?;
            CommandId::GrpInterrupt
        }
        code::CONTINUE => {
            put(&request::GrpContinue { rbt_id: id }, &mut text)?;
            CommandId::GrpContinue
        }
        code::MOVE_J_JOINTS | code::MOVE_J_POSE | code::MOVE_L_POSE => {
            let to_joints = inp.code == code::MOVE_J_JOINTS;
            let target = six(p.get(..6).unwrap_or(&[]))?;
            let w = request::WayPoint {
                rbt_id: id,
                pose: if to_joints {
                    [Decimal::ZERO; 6]
                } else {
                    target
                },
                joints: if to_joints { target } else { six(&inp.joints)? },
                tcp_name: or_default(inp.text1, "TCP"),
                ucs_name: or_default(inp.text2, "Base"),
                velocity: dec(p[6])?,
                acc: dec(p[7])?,
                radius: dec(p[8])?,
                move_type: i32::from(inp.code == code::MOVE_L_POSE),
                use_joint: i32::from(to_joints),
                seek: 0,
                io_bit: 0,
                io_state: 0,
                cmd_id,
            };
            put(&w, &mut text)?;
            CommandId::WayPoint
        }
        code::MOVE_REL_J => {
            put(
                &request::MoveRelJ {
                    rbt_id: id,
                    axis: int(p[0])?,
                    direction: i32::from(p[1] >= 0.0),
                    distance: dec(if p[1] < 0.0 { -p[1] } else { p[1] })?,
                },
                &mut text,
            )?;
            CommandId::MoveRelJ
        }
        code::MOVE_REL_L => {
            put(
                &request::MoveRelL {
                    rbt_id: id,
                    axis: int(p[0])?,
                    direction: i32::from(p[1] >= 0.0),
                    distance: dec(if p[1] < 0.0 { -p[1] } else { p[1] })?,
                    tool_motion: Some(int(p[2])?),
                },
                &mut text,
            )?;
            CommandId::MoveRelL
        }
        code::SET_OVERRIDE => {
            put(
                &request::SetOverride {
                    rbt_id: id,
                    ratio: dec(p[0])?,
                },
                &mut text,
            )?;
            CommandId::SetOverride
        }
        code::SET_BOX_DO => {
            put(
                &request::SetBoxDO {
                    bit: int(p[0])?,
                    value: int(p[1])?,
                },
                &mut text,
            )?;
            CommandId::SetBoxDO
        }
        code::SET_BOX_CO => {
            put(
                &request::SetBoxCO {
                    bit: int(p[0])?,
                    value: int(p[1])?,
                },
                &mut text,
            )?;
            CommandId::SetBoxCO
        }
        code::SET_END_DO => {
            // The document allows bit 3 (older tool ends had four outputs),
            // but tool ends have three and END_DO reads outputs 0-2 only
            // (`ReadEO`): keep the code and the register in agreement.
            let bit = int(p[0])?;
            if bit > 2 {
                return Err(BAD);
            }
            put(
                &request::SetEndDO {
                    rbt_id: id,
                    bit,
                    value: int(p[1])?,
                },
                &mut text,
            )?;
            CommandId::SetEndDO
        }
        code::START_SCRIPT => {
            put(&request::StartScript {}, &mut text)?;
            CommandId::StartScript
        }
        code::STOP_SCRIPT => {
            put(&request::StopScript {}, &mut text)?;
            CommandId::StopScript
        }
        code::PAUSE_SCRIPT => {
            put(&request::PauseScript {}, &mut text)?;
            CommandId::PauseScript
        }
        code::CONTINUE_SCRIPT => {
            put(&request::ContinueScript {}, &mut text)?;
            CommandId::ContinueScript
        }
        code::RUN_FUNC => {
            if inp.text1.is_empty() {
                return Err(BAD);
            }
            let mut items = heapless::Vec::<&str, 16>::new();
            if !inp.text2.is_empty() {
                for f in inp.text2.split(',') {
                    items.push(f.trim()).map_err(|_| BAD)?;
                }
            }
            put(
                &request::RunFunc {
                    func_name: inp.text1,
                    params: TextList::new(&items),
                },
                &mut text,
            )?;
            CommandId::RunFunc
        }
        code::READ_ACT_POS => {
            put(&request::ReadActPos { rbt_id: id }, &mut text)?;
            results = Results::ActPos;
            CommandId::ReadActPos
        }
        _ => return Err(BAD),
    };
    Ok(Job {
        source,
        seq,
        text,
        motion: command.is_motion(),
        urgent: is_urgent(command),
        results,
    })
}

/// Decimal text of `v` (the way-point id is the sequence number).
fn itoa_buf(v: u16) -> heapless::String<5> {
    let mut digits = [0u8; 5];
    let mut n = v;
    let mut i = digits.len();
    loop {
        i -= 1;
        if let Some(d) = digits.get_mut(i) {
            *d = b'0' + (n % 10) as u8;
        }
        n /= 10;
        if n == 0 || i == 0 {
            break;
        }
    }
    let mut s = heapless::String::new();
    for &d in digits.get(i..).unwrap_or(&[]) {
        let _ = s.push(char::from(d));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn inputs(code: u16, params: &[f32]) -> Inputs<'static> {
        let mut p = [0.0; CH_PARAM_COUNT];
        p[..params.len()].copy_from_slice(params);
        Inputs {
            code,
            params: p,
            text1: "",
            text2: "",
            robot_id: 0,
            joints: [0.0, 0.0, 90.0, 0.0, 90.0, 0.0],
        }
    }

    #[test]
    fn moves_become_way_points() {
        let j = build(
            Source::Channel(0),
            42,
            &inputs(
                code::MOVE_L_POSE,
                &[420.0, 0.0, 445.0, 180.0, 0.0, 180.0, 50.0, 360.0, 0.0],
            ),
        )
        .unwrap();
        assert_eq!(
            j.text.as_str(),
            "WayPoint,0,420.000,0.000,445.000,180.000,0.000,180.000,0.000,0.000,90.000,0.000,90.000,0.000,TCP,Base,50.000,360.000,0.000,1,0,0,0,0,42,;"
        );
        assert!(j.motion && !j.urgent);
        let j = build(
            Source::Channel(0),
            1,
            &inputs(code::MOVE_REL_J, &[2.0, -5.5]),
        )
        .unwrap();
        assert_eq!(j.text.as_str(), "MoveRelJ,0,2,0,5.500,;");
        assert!(j.motion);
    }

    #[test]
    fn power_on_is_a_sequence_and_stop_interrupts() {
        let j = build(Source::Channel(1), 0, &inputs(code::POWER_ON, &[])).unwrap();
        assert_eq!(j.text.as_str(), "ConnectToBox,;Electrify,;StartMaster,;");
        let j = build(Source::Channel(1), 0, &inputs(code::STOP, &[])).unwrap();
        assert_eq!(j.text.as_str(), "GrpStop,0,;");
        assert!(j.urgent);
    }

    #[test]
    fn bad_parameters_are_refused() {
        let e = |c, p: &[f32]| build(Source::Raw, 0, &inputs(c, p)).unwrap_err();
        assert_eq!(e(code::SET_BOX_DO, &[1.5, 1.0]), GatewayError::BadParameter);
        assert_eq!(e(code::SET_BOX_DO, &[8.0, 1.0]), GatewayError::BadParameter);
        // Tool-end outputs 0-2, the ones END_DO shows.
        assert_eq!(e(code::SET_END_DO, &[3.0, 1.0]), GatewayError::BadParameter);
        assert!(build(Source::Raw, 0, &inputs(code::SET_END_DO, &[2.0, 1.0])).is_ok());
        assert_eq!(e(code::SET_OVERRIDE, &[1.5]), GatewayError::BadParameter);
        assert_eq!(
            e(code::SET_OVERRIDE, &[f32::NAN]),
            GatewayError::BadParameter
        );
        assert_eq!(e(999, &[]), GatewayError::BadParameter);
        assert_eq!(e(code::RUN_FUNC, &[]), GatewayError::BadParameter);
        let ok = build(Source::Raw, 0, &inputs(code::SET_OVERRIDE, &[0.5])).unwrap();
        assert_eq!(ok.text.as_str(), "SetOverride,0,0.500,;");
    }

    #[test]
    fn run_func_splits_its_parameters() {
        let mut i = inputs(code::RUN_FUNC, &[]);
        i.text1 = "Pick";
        i.text2 = "1, a";
        let j = build(Source::Raw, 0, &i).unwrap();
        assert_eq!(j.text.as_str(), "RunFunc,Pick,1,a,;");
        assert_eq!(itoa_buf(0).as_str(), "0");
        assert_eq!(itoa_buf(65535).as_str(), "65535");
    }
}
