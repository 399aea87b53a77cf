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
//! | 34 | `RunFunc` | TEXT1 function, TEXT2 parameters separated by `,` (at most [`RUN_FUNC_PARAMS`]) |
//! | 40 | `ReadActPos` | results R0-R5 joints, R6-R11 pose, R12-R17 tool, R18-R23 frame |
//! | 60-71 | joint jog (`LongJogJ` + `LongMoveEvent`, V6): 60 + 2 × axis + direction (J1- = 60, J1+ = 61, ..., J6+ = 71) | — (runs while Execute is held) |
//! | 80-91 | Cartesian jog (`LongJogL` + `LongMoveEvent`, V6): 80 + 2 × axis + direction (X- = 80, X+ = 81, Y, Z, Rx, Ry, Rz+ = 91) | — |
//!
//! Numbers the PLC gives are sent with three decimals (`50.000`); fields
//! the gateway fills itself are sent as integers (`0`, `1`), except the IK
//! reference joints of codes 11 and 12 (`ACT_JOINTS`, three decimals).
//!
//! What each code builds, its motion class and its messages are one table,
//! [`TABLE`].

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
    /// Every code but the jog ones, in order (read from the command table).
    pub const ALL: [u16; super::count_codes()] = super::list_codes();
}

/// A name of 32 characters at most (tool, frame, function, its parameters).
pub(crate) type Name = heapless::String<32>;

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
        let mut out = None;
        self.with_request(RobotId(i32::from(robot)), on, &mut |r| {
            out = r.wire(buf);
        });
        out
    }

    /// Calls `f` with the jog request: start (`on`) or stop.
    #[cfg(feature = "v6")]
    fn with_request(&self, rbt_id: RobotId, on: bool, f: &mut dyn FnMut(&dyn Wire)) {
        let axis = i32::from(self.axis);
        let (direction, state) = (i32::from(self.positive), i32::from(on));
        if self.cartesian {
            f(&request::LongJogL {
                rbt_id,
                axis,
                direction,
                state,
            })
        } else {
            f(&request::LongJogJ {
                rbt_id,
                axis,
                direction,
                state,
            })
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

/// P0 bit, P1 value (codes 21-23).
fn bit_value(p: &[f32; 12]) -> Result<(i32, i32), GatewayError> {
    Ok((int(p[0])?, int(p[1])?))
}

/// Most parameters a `RunFunc` (code 34) sends. The limit is the
/// gateway's own: the protocol document (4.3.1 `RunFunc`) gives none, and
/// the codec's `TextList` takes any number. The gateway splits TEXT2
/// (`CHn_TEXT2`: 16 registers, 32 characters) into a list of this many
/// slices on the stack; 32 characters hold 16 parameters that are not empty
/// (`1,2,...,6` is 31), a 17th is only there when some are empty (a
/// trailing `,`, or `,,`). More parameters than this are refused
/// (39501, nothing sent), never cut: a function must not run with
/// parameters missing.
pub(crate) const RUN_FUNC_PARAMS: usize = 16;

/// The parameters of a `RunFunc`: TEXT2 split at `,`, each trimmed;
/// [`GatewayError::BadParameter`] if there are more than
/// [`RUN_FUNC_PARAMS`].
fn run_func_params(params: &str) -> Result<heapless::Vec<&str, RUN_FUNC_PARAMS>, GatewayError> {
    let mut items = heapless::Vec::new();
    if !params.is_empty() {
        for p in params.split(',') {
            items.push(p.trim()).map_err(|_| BAD)?;
        }
    }
    Ok(items)
}

/// How a command ends, as far as the queue and the engine care: its motion
/// class.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Class {
    /// Not a motion: Done at the robot's reply (the bring-up steps once
    /// the robot is in the state they lead to).
    Reply,
    /// A motion: Done when the robot has finished it.
    Motion,
    /// A jog: a motion that runs while Execute is held (`REGISTERS.md`,
    /// Jogging).
    Held,
}

/// One message of a command: calls `f` with its codec request. `None`
/// when the command is not the one of the entry, or has no request in this
/// build.
pub(crate) type Step = fn(&Command, RobotId, &mut dyn FnMut(&dyn Wire)) -> Option<()>;

/// Calls `f` with `request`: the end of every [`Step`].
fn emit(f: &mut dyn FnMut(&dyn Wire), request: &dyn Wire) -> Option<()> {
    f(request);
    Some(())
}

/// What an ordinary (not urgent) command code does.
pub struct Spec {
    /// Its motion class.
    pub class: Class,
    /// Builds the typed command from the registers, given the code fired.
    /// [`build`] then checks each step's request against the document's
    /// ranges.
    pub build: fn(u16, &Inputs<'_>) -> Result<Command, GatewayError>,
    /// `true` for the commands `build` makes (finds the entry of a
    /// [`Command`]).
    pub is: fn(&Command) -> bool,
    /// Its messages, sent in turn: one per step.
    pub steps: &'static [Step],
}

/// What a command code does.
pub(crate) enum Does {
    /// An urgent command: the urgent lane, sent in its canonical form
    /// ([`Urgent::encode`]).
    Urgent(Urgent),
    /// An ordinary command, queued.
    Send(Spec),
}

/// One entry of [`TABLE`]: a command code, or a run of codes that build
/// alike.
pub(crate) struct Entry {
    /// The first code.
    pub first: u16,
    /// The last code (the same as `first` but for runs).
    pub last: u16,
    /// What it does.
    pub does: Does,
}

impl Entry {
    const fn urgent(code: u16, u: Urgent) -> Entry {
        Entry {
            first: code,
            last: code,
            does: Does::Urgent(u),
        }
    }

    const fn send(first: u16, last: u16, spec: Spec) -> Entry {
        Entry {
            first,
            last,
            does: Does::Send(spec),
        }
    }

    /// A jog run (it is left out of [`code::ALL`]).
    const fn is_jog(&self) -> bool {
        matches!(
            self.does,
            Does::Send(Spec {
                class: Class::Held,
                ..
            })
        )
    }
}

/// Every command code: what it builds, its motion class and its messages
/// (steps), in order of code. [`build`], [`Command::is_motion`],
/// [`Command::steps`], [`Command::with_request`] and [`code::ALL`] read it:
/// adding a code is one entry here (and, if it carries values, a variant of
/// [`Command`]).
pub(crate) const TABLE: &[Entry] = &[
    Entry::send(
        code::POWER_ON,
        code::POWER_ON,
        Spec {
            class: Class::Reply,
            build: |_, _| Ok(Command::PowerOn),
            is: |c| matches!(c, Command::PowerOn),
            steps: &[
                |_, _, f| emit(f, &request::ConnectToBox {}),
                |_, _, f| emit(f, &request::Electrify {}),
                |_, _, f| emit(f, &request::StartMaster {}),
            ],
        },
    ),
    Entry::send(
        code::POWER_OFF,
        code::POWER_OFF,
        Spec {
            class: Class::Reply,
            build: |_, _| Ok(Command::PowerOff),
            is: |c| matches!(c, Command::PowerOff),
            steps: &[|_, _, f| emit(f, &request::BlackOut {})],
        },
    ),
    Entry::send(
        code::ENABLE,
        code::ENABLE,
        Spec {
            class: Class::Reply,
            build: |_, _| Ok(Command::Enable),
            is: |c| matches!(c, Command::Enable),
            steps: &[|_, rbt_id, f| emit(f, &request::GrpEnable { rbt_id })],
        },
    ),
    Entry::urgent(code::DISABLE, Urgent::Disable),
    Entry::urgent(code::RESET, Urgent::Reset),
    Entry::urgent(code::STOP, Urgent::Stop),
    Entry::urgent(code::PAUSE, Urgent::Pause),
    Entry::urgent(code::CONTINUE, Urgent::Continue),
    Entry::send(
        code::MOVE_J_JOINTS,
        code::MOVE_L_POSE,
        Spec {
            class: Class::Motion,
            build: build_move,
            is: |c| matches!(c, Command::Move(_)),
            steps: &[way_point],
        },
    ),
    Entry::send(
        code::MOVE_REL_J,
        code::MOVE_REL_J,
        Spec {
            class: Class::Motion,
            build: |_, inp| {
                let (direction, distance) = signed(inp.params[1])?;
                Ok(Command::MoveRelJ {
                    axis: int(inp.params[0])?,
                    direction,
                    distance,
                })
            },
            is: |c| matches!(c, Command::MoveRelJ { .. }),
            steps: &[|c, rbt_id, f| {
                let &Command::MoveRelJ {
                    axis,
                    direction,
                    distance,
                } = c
                else {
                    return None;
                };
                emit(
                    f,
                    &request::MoveRelJ {
                        rbt_id,
                        axis,
                        direction,
                        distance,
                    },
                )
            }],
        },
    ),
    Entry::send(
        code::MOVE_REL_L,
        code::MOVE_REL_L,
        Spec {
            class: Class::Motion,
            build: |_, inp| {
                let (direction, distance) = signed(inp.params[1])?;
                Ok(Command::MoveRelL {
                    axis: int(inp.params[0])?,
                    direction,
                    distance,
                    tool_motion: int(inp.params[2])?,
                })
            },
            is: |c| matches!(c, Command::MoveRelL { .. }),
            steps: &[|c, rbt_id, f| {
                let &Command::MoveRelL {
                    axis,
                    direction,
                    distance,
                    tool_motion,
                } = c
                else {
                    return None;
                };
                emit(
                    f,
                    &request::MoveRelL {
                        rbt_id,
                        axis,
                        direction,
                        distance,
                        tool_motion: Some(tool_motion),
                    },
                )
            }],
        },
    ),
    Entry::send(
        code::SET_OVERRIDE,
        code::SET_OVERRIDE,
        Spec {
            class: Class::Reply,
            build: |_, inp| Ok(Command::SetOverride(dec(inp.params[0])?)),
            is: |c| matches!(c, Command::SetOverride(_)),
            steps: &[|c, rbt_id, f| {
                let &Command::SetOverride(ratio) = c else {
                    return None;
                };
                emit(f, &request::SetOverride { rbt_id, ratio })
            }],
        },
    ),
    Entry::send(
        code::SET_BOX_DO,
        code::SET_BOX_DO,
        Spec {
            class: Class::Reply,
            build: |_, inp| {
                let (bit, value) = bit_value(inp.params)?;
                Ok(Command::SetBoxDo { bit, value })
            },
            is: |c| matches!(c, Command::SetBoxDo { .. }),
            steps: &[|c, _, f| {
                let &Command::SetBoxDo { bit, value } = c else {
                    return None;
                };
                emit(f, &request::SetBoxDO { bit, value })
            }],
        },
    ),
    Entry::send(
        code::SET_END_DO,
        code::SET_END_DO,
        Spec {
            class: Class::Reply,
            build: |_, inp| {
                // The document allows bit 3 (older tool ends had four
                // outputs), but tool ends have three and END_DO reads
                // outputs 0-2 only (`ReadEO`): keep the code and the
                // register in agreement.
                let (bit, value) = bit_value(inp.params)?;
                if bit > 2 {
                    return Err(BAD);
                }
                Ok(Command::SetEndDo { bit, value })
            },
            is: |c| matches!(c, Command::SetEndDo { .. }),
            steps: &[|c, rbt_id, f| {
                let &Command::SetEndDo { bit, value } = c else {
                    return None;
                };
                emit(f, &request::SetEndDO { rbt_id, bit, value })
            }],
        },
    ),
    Entry::send(
        code::SET_BOX_CO,
        code::SET_BOX_CO,
        Spec {
            class: Class::Reply,
            build: |_, inp| {
                let (bit, value) = bit_value(inp.params)?;
                Ok(Command::SetBoxCo { bit, value })
            },
            is: |c| matches!(c, Command::SetBoxCo { .. }),
            steps: &[|c, _, f| {
                let &Command::SetBoxCo { bit, value } = c else {
                    return None;
                };
                emit(f, &request::SetBoxCO { bit, value })
            }],
        },
    ),
    Entry::send(
        code::START_SCRIPT,
        code::START_SCRIPT,
        Spec {
            class: Class::Reply,
            build: |_, _| Ok(Command::StartScript),
            is: |c| matches!(c, Command::StartScript),
            steps: &[|_, _, f| emit(f, &request::StartScript {})],
        },
    ),
    Entry::urgent(code::STOP_SCRIPT, Urgent::StopScript),
    Entry::urgent(code::PAUSE_SCRIPT, Urgent::PauseScript),
    Entry::urgent(code::CONTINUE_SCRIPT, Urgent::ContinueScript),
    Entry::send(
        code::RUN_FUNC,
        code::RUN_FUNC,
        Spec {
            class: Class::Reply,
            build: |_, inp| {
                if inp.text1.is_empty() {
                    return Err(BAD);
                }
                let params = name(inp.text2, "")?;
                run_func_params(&params)?;
                Ok(Command::RunFunc {
                    name: name(inp.text1, "")?,
                    params,
                })
            },
            is: |c| matches!(c, Command::RunFunc { .. }),
            steps: &[|c, _, f| {
                let Command::RunFunc { name, params } = c else {
                    return None;
                };
                let items = run_func_params(params).ok()?;
                emit(
                    f,
                    &request::RunFunc {
                        func_name: name,
                        params: TextList::new(&items),
                    },
                )
            }],
        },
    ),
    Entry::send(
        code::READ_ACT_POS,
        code::READ_ACT_POS,
        Spec {
            class: Class::Reply,
            build: |_, _| Ok(Command::ReadActPos),
            is: |c| matches!(c, Command::ReadActPos),
            steps: &[|_, rbt_id, f| emit(f, &request::ReadActPos { rbt_id })],
        },
    ),
    Entry::send(
        code::JOG_J,
        code::JOG_J + 11,
        Spec {
            class: Class::Held,
            build: build_jog,
            is: |c| matches!(c, Command::Jog(j) if !j.cartesian),
            steps: &[jog_start],
        },
    ),
    Entry::send(
        code::JOG_L,
        code::JOG_L + 11,
        Spec {
            class: Class::Held,
            build: build_jog,
            is: |c| matches!(c, Command::Jog(j) if j.cartesian),
            steps: &[jog_start],
        },
    ),
];

/// Codes 10-12.
fn build_move(code: u16, inp: &Inputs<'_>) -> Result<Command, GatewayError> {
    let p = inp.params;
    let kind = match code {
        code::MOVE_J_JOINTS => MoveKind::JointToJoints,
        code::MOVE_J_POSE => MoveKind::JointToPose,
        _ => MoveKind::LinearToPose,
    };
    let reference = match (kind, inp.joints) {
        (MoveKind::JointToJoints, _) | (_, None) => [Decimal::ZERO; 6],
        (_, Some(j)) => six(&j)?,
    };
    Ok(Command::Move(Move {
        kind,
        target: six(&p[..6])?,
        reference,
        tool: name(inp.text1, "TCP")?,
        frame: name(inp.text2, "Base")?,
        velocity: dec(p[6])?,
        acc: dec(p[7])?,
        radius: dec(p[8])?,
        cmd_id: inp.seq,
    }))
}

/// The `WayPoint` of codes 10-12.
fn way_point(c: &Command, rbt_id: RobotId, f: &mut dyn FnMut(&dyn Wire)) -> Option<()> {
    let Command::Move(m) = c else {
        return None;
    };
    let to_joints = m.kind == MoveKind::JointToJoints;
    let mut id = itoa::Buffer::new();
    emit(
        f,
        &request::WayPoint {
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
        },
    )
}

/// Codes 60-71, 80-91.
fn build_jog(code: u16, _: &Inputs<'_>) -> Result<Command, GatewayError> {
    match Jog::of(code) {
        // Without the V6 commands (the core firmwares) there is no jog.
        Some(_) if !cfg!(feature = "v6") => Err(GatewayError::NotSupported),
        Some(j) => Ok(Command::Jog(j)),
        None => Err(BAD),
    }
}

/// The jog's start (`LongJogJ` / `LongJogL`, state 1); none without V6.
fn jog_start(c: &Command, rbt_id: RobotId, f: &mut dyn FnMut(&dyn Wire)) -> Option<()> {
    let Command::Jog(j) = c else {
        return None;
    };
    #[cfg(feature = "v6")]
    {
        j.with_request(rbt_id, true, f);
        Some(())
    }
    #[cfg(not(feature = "v6"))]
    {
        let _ = (j, rbt_id, f);
        None
    }
}

/// The entry of command code `code`.
pub(crate) fn entry(code: u16) -> Option<&'static Entry> {
    TABLE.iter().find(|e| (e.first..=e.last).contains(&code))
}

/// How many codes [`code::ALL`] holds: those of [`TABLE`] but the jogs.
const fn count_codes() -> usize {
    let (mut n, mut rest) = (0, TABLE);
    while let [e, tail @ ..] = rest {
        if !e.is_jog() {
            n += (e.last - e.first + 1) as usize;
        }
        rest = tail;
    }
    n
}

/// The codes of [`TABLE`] but the jogs, in order.
// Evaluated by the compiler (`code::ALL`): an index out of bounds fails the
// build.
#[allow(clippy::indexing_slicing)]
const fn list_codes<const N: usize>() -> [u16; N] {
    let (mut out, mut n, mut rest) = ([0; N], 0, TABLE);
    while let [e, tail @ ..] = rest {
        if !e.is_jog() {
            let mut c = e.first;
            while c <= e.last {
                out[n] = c;
                n += 1;
                c += 1;
            }
        }
        rest = tail;
    }
    out
}

/// Builds the job of command code `inp.code` as the command table says: a typed
/// command (or urgent command), checked against the document's ranges.
/// Unknown codes, values out of range and non-integers where integers are
/// needed are [`GatewayError::BadParameter`].
pub fn build(inp: &Inputs<'_>, robot: u8) -> Result<JobKind, GatewayError> {
    let spec = match entry(inp.code).map(|e| &e.does) {
        None => return Err(BAD),
        Some(Does::Urgent(u)) => return Ok(JobKind::Urgent(*u)),
        Some(Does::Send(spec)) => spec,
    };
    let cmd = (spec.build)(inp.code, inp)?;
    // Every step's request must pass the document's ranges.
    for step in 0..cmd.steps() {
        cmd.with_request(step, robot, &mut |r| r.check().map_err(|_| BAD))
            .ok_or(BAD)??;
    }
    Ok(JobKind::Command(cmd))
}

impl Command {
    /// Its entry in the command table (every command built has one).
    pub fn spec(&self) -> Option<&'static Spec> {
        TABLE.iter().find_map(|e| match &e.does {
            Does::Send(s) if (s.is)(self) => Some(s),
            _ => None,
        })
    }

    /// A motion (Done when the robot has finished it).
    pub fn is_motion(&self) -> bool {
        self.spec().is_some_and(|s| s.class != Class::Reply)
    }

    /// Messages sent in turn.
    pub fn steps(&self) -> u8 {
        self.spec().map_or(0, |s| s.steps.len() as u8)
    }

    /// Writes message `step` for robot `robot` into `buf`.
    pub fn encode(&self, step: u8, robot: u8, buf: &mut [u8]) -> Option<Message> {
        self.with_request(step, robot, &mut |r| r.wire(buf))?
    }

    /// Calls `f` with the codec request of message `step`, built by the
    /// command's the command table entry: the one place each command's request is
    /// built, for checking and for sending. `None` for a step the command
    /// does not have.
    pub fn with_request<R>(
        &self,
        step: u8,
        robot: u8,
        f: &mut dyn FnMut(&dyn Wire) -> R,
    ) -> Option<R> {
        let step = self.spec()?.steps.get(usize::from(step))?;
        let mut out = None;
        step(self, RobotId(i32::from(robot)), &mut |r| out = Some(f(r)))?;
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::{Job, JobKind, Source};

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
    fn run_func_over_its_parameter_limit_is_refused() {
        // 16 parameters: all sent.
        let sixteen = "1,2,3,4,5,6,7,8,9,0,1,2,3,4,5,6";
        let j = job(code::RUN_FUNC, &[], "F", sixteen, 0).unwrap();
        assert_eq!(text(&j, 0), format!("RunFunc,F,{sixteen},;"));
        // A 17th (TEXT2's 32 characters hold one only when some are empty)
        // was dropped and the rest sent: now the command is refused.
        for seventeen in [",,,,,,,,,,,,,,,,", "1,2,3,4,5,6,7,8,9,0,1,2,3,4,5,6,"] {
            let e = job(code::RUN_FUNC, &[], "F", seventeen, 0);
            assert_eq!(e, Err(GatewayError::BadParameter), "{seventeen:?}");
        }
        // A command made some other way sends nothing either.
        let c = Command::RunFunc {
            name: Name::try_from("F").unwrap(),
            params: Name::try_from(",,,,,,,,,,,,,,,,").unwrap(),
        };
        assert!(c.encode(0, 0, &mut [0u8; 300]).is_none());
    }

    #[test]
    fn run_func_over_its_limit_ends_the_channel_in_error() {
        use crate::config::Config;
        use crate::plc::apply;
        use crate::registers::{self as r, write};
        use crate::state::{LinkState, Model};
        let mut m = Model::new(Config::default(), Config::default());
        m.link.state = LinkState::Connected;
        let words = |t: &[u8]| -> Vec<u16> {
            t.chunks(2)
                .map(|c| u16::from_be_bytes([c[0], *c.get(1).unwrap_or(&0)]))
                .collect()
        };
        let b = r::channel_base(0);
        write(&mut m, b + r::CH_TEXT1, &words(b"F")).unwrap();
        let params = b"1,2,3,4,5,6,7,8,9,0,1,2,3,4,5,6,";
        write(&mut m, b + r::CH_TEXT2, &words(params)).unwrap();
        let ev = write(&mut m, b, &[1, code::RUN_FUNC, 5]).unwrap();
        apply(
            &mut m,
            &ev,
            embassy_time::Instant::from_millis(10),
            crate::state::owner::Commander::Modbus,
        );
        let hs = m.handshake(Source::Channel(0)).unwrap();
        assert_eq!(hs.error(), (39501, 3));
        assert!(m.queue.is_empty());
    }

    #[test]
    fn the_table_is_in_order_and_each_entry_knows_its_commands() {
        for w in TABLE.windows(2) {
            assert!(w[0].first <= w[0].last && w[0].last < w[1].first);
        }
        let all: Vec<u16> = TABLE.iter().flat_map(|e| e.first..=e.last).collect();
        for c in all {
            let e = entry(c).unwrap();
            let j = job(c, &[1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 10.0, 10.0], "F", "", 0).unwrap();
            match (&e.does, &j.kind) {
                (Does::Urgent(u), JobKind::Urgent(k)) => assert_eq!(u, k),
                (Does::Send(s), JobKind::Command(cmd)) => {
                    assert!(core::ptr::eq(cmd.spec().unwrap(), s), "code {c}");
                    assert_eq!(usize::from(cmd.steps()), s.steps.len());
                    assert_eq!(cmd.is_motion(), s.class != Class::Reply);
                }
                _ => panic!("code {c}: {:?}", j.kind),
            }
        }
        assert!(job(code::MOVE_REL_L, &[1.0, 1.0], "", "", 0)
            .unwrap()
            .is_motion());
        assert!(!job(code::READ_ACT_POS, &[], "", "", 0).unwrap().is_motion());
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
