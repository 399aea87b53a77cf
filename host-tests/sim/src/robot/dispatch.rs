//! One answer per command: the table from each request to the handler of
//! its document section, the checks every request passes first, and the
//! encoding of the reply (typed codec values, written by the codec).
//!
//! | file | section |
//! |---|---|
//! | `power.rs` | 4.1 initialisation, 4.2 axis group |
//! | `scripts.rs` | 4.3 scripts |
//! | `io_commands.rs` | 4.4 I/O, tool-end Modbus (4.14) |
//! | `settings.rs` | 4.5 settings and state |
//! | `positions.rs` | 4.6 positions and velocities |
//! | `geometry.rs` | 4.7 kinematics and pose arithmetic |
//! | `frames.rs` | 4.8 tool and user frames |
//! | `force.rs` | 4.9 force control |
//! | `moves.rs` (`shapes.rs`) | 4.10 moves |
//! | `paths.rs` | 4.11 stored paths |
//! | `servo.rs` | 4.12 servo streaming |
//!
//! Every request is first checked here, in this order: a command the
//! simulator does not know, or that its protocol level does not have (the
//! codec's level data: `CommandId::available_at`), is `Fail,20005`; parameters outside the
//! document's ranges (the codec's `validate()`) and a robot id other than 0
//! are `Fail,20006`. Then its handler answers [`Answer::Done`] (`Name,OK,;`),
//! [`Answer::Values`], or a refusal code. Refusals shared by the sections: a
//! command the current state does not allow gets `Fail,20018`; a parameter
//! the ranges allow but the robot cannot use (an unreachable pose, a speed of
//! 0, an unknown path) gets `Fail,20006`. The sections' own codes are named
//! where they are used.

use hans_codec::types::Visitor;
use hans_codec::{response as rs, Decimal, FsmState, Request, Response};

use super::settings::MAX_PAYLOAD;
use super::values::{dec, decs, f, fs, idx};
use super::Robot;

/// What the server must do besides sending the reply.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) enum Effect {
    #[default]
    None,
    /// `OSCmd,2`: the controller reboots (connections drop, refused for a
    /// while, then the robot is powered off).
    Reboot,
}

/// A failure code (`Name,Fail,code,;`).
pub(super) type Code = i32;

/// A command the controller does not know.
pub(super) const UNKNOWN: Code = 20005;
/// A message whose fields do not read as the command.
pub(super) const FORMAT: Code = 20007;
/// A parameter the robot cannot use.
pub(super) const PARAM: Code = 20006;
/// A command the current state does not allow.
pub(super) const STATE: Code = 20018;

/// A handler's success.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Answer<'s> {
    /// Nothing to return: `Name,OK,;`.
    Done,
    /// The reply's values (boxed: some replies are large).
    Values(Box<Response<'s>>),
    /// The reply, written already (under the command's own name): for
    /// values that borrow what the handler built, such as lists of names.
    Encoded(Vec<u8>),
}

impl Answer<'_> {
    /// Success with the values of `r`, written now.
    pub(super) fn encoded<'r>(r: impl Into<Response<'r>>) -> Outcome<'static> {
        let resp = r.into();
        Ok(Answer::Encoded(encode_ok(&resp, resp.name())))
    }
}

/// What a handler answers: success, or the refusal's failure code.
pub(super) type Outcome<'s> = Result<Answer<'s>, Code>;

/// Success without values.
pub(super) fn done() -> Outcome<'static> {
    Ok(Answer::Done)
}

/// Success with the values of `r`.
pub(super) fn values<'s>(r: impl Into<Response<'s>>) -> Outcome<'s> {
    Ok(Answer::Values(Box::new(r.into())))
}

/// Finds a request's robot id (`nRbtID`, the parameter `rbt_id` of the
/// codec's table) as the request's fields are walked.
#[derive(Default)]
struct RobotIdOf {
    id: Option<i32>,
    depth: u32,
}

impl Visitor for RobotIdOf {
    fn int(&mut self, name: &str, v: i32) {
        if self.depth == 0 && name == "rbt_id" && self.id.is_none() {
            self.id = Some(v);
        }
    }
    fn num(&mut self, _: &str, _: Decimal) {}
    fn text(&mut self, _: &str, _: &str) {}
    fn begin_list(&mut self, _: &str) {
        self.depth += 1;
    }
    fn end_list(&mut self) {
        self.depth = self.depth.saturating_sub(1);
    }
}

/// The robot id a request names, if it has one.
fn robot_id(req: &Request<'_>) -> Option<i32> {
    let mut v = RobotIdOf::default();
    req.visit(&mut v);
    v.id
}

impl Robot {
    /// Executes one request at `now` and returns the reply text; `name` is
    /// the name as received (an alias is answered under the alias).
    pub fn handle(&mut self, req: &Request<'_>, name: &str, now: f64) -> (Vec<u8>, Effect) {
        self.update(now);
        let mut effect = Effect::None;
        let answer = match self.admit(req) {
            Ok(()) => self.exec(req, now, &mut effect),
            Err(code) => Err(code),
        };
        let text = match answer {
            Ok(Answer::Done) => ok_text(name),
            Ok(Answer::Values(resp)) => encode_ok(&resp, name),
            Ok(Answer::Encoded(text)) => renamed(text, name),
            Err(code) => fail_text(name, code, ""),
        };
        (text, effect)
    }

    /// The checks every request passes before its handler runs.
    fn admit(&self, req: &Request<'_>) -> Result<(), Code> {
        match req.command() {
            Some(id) if id.available_at(self.level) => {}
            _ => return Err(UNKNOWN),
        }
        req.validate().map_err(|_| PARAM)?;
        match robot_id(req) {
            Some(id) if id != 0 => Err(PARAM),
            _ => Ok(()),
        }
    }

    // ------------------------------------------------ shared refusal rules

    /// Only in StandBy.
    pub(super) fn need_standby(&self, now: f64) -> Result<(), Code> {
        if self.fsm(now) == FsmState::StandBy {
            Ok(())
        } else {
            Err(STATE)
        }
    }

    /// New motion is accepted in StandBy and (queued) while Moving.
    pub(super) fn need_motion(&self, now: f64) -> Result<(), Code> {
        match self.fsm(now) {
            FsmState::StandBy | FsmState::Moving => Ok(()),
            _ => Err(STATE),
        }
    }

    /// Box I/O needs the box connected.
    pub(super) fn need_box(&self) -> Result<(), Code> {
        if self.box_.is_on() && !self.estop {
            Ok(())
        } else {
            Err(STATE)
        }
    }

    /// Tool-end I/O needs the arm powered.
    pub(super) fn need_end_io(&self) -> Result<(), Code> {
        if self.box_.is_on() && self.power.is_on() && self.master.is_on() && !self.estop {
            Ok(())
        } else {
            Err(STATE)
        }
    }

    // ------------------------------------------------------------- table

    /// The handler of each command, in the document's order.
    fn exec<'s>(&'s mut self, req: &'s Request<'_>, now: f64, effect: &mut Effect) -> Outcome<'s> {
        use Request as R;
        match req {
            // 4.1 initialisation
            R::OSCmd(c) => self.os_cmd(c, now, effect),
            R::ConnectToBox(_) => self.connect_to_box(now),
            R::Electrify(_) => self.electrify(now),
            R::BlackOut(_) => self.black_out(now),
            R::StartMaster(_) => self.start_master(now),
            R::CloseMaster(_) => self.close_master(now),
            R::IsSimulation(_) => values(rs::IsSimulation { simulated: 1 }),
            R::ReadControllerState(_) => values(rs::ReadControllerState { started: 1 }),
            R::ReadRobotModel(_) => self.read_robot_model(),

            // 4.2 axis group
            R::GrpEnable(_) => self.grp_enable(now),
            R::GrpDisable(_) => self.grp_disable(now),
            R::GrpReset(_) => self.grp_reset(now),
            R::GrpStop(_) => self.grp_stop(now),
            R::GrpInterrupt(_) => self.grp_interrupt(now),
            R::GrpContinue(_) => self.grp_continue(now),
            R::GrpCloseFreeDriver(_) => self.grp_close_free_driver(now),
            R::GrpOpenFreeDriver(_) => self.grp_open_free_driver(now),

            // 4.3 scripts
            R::RunFunc(c) => self.run_func(c, now),
            R::StartScript(_) => self.start_script(now),
            R::StopScript(_) => self.stop_script(now),
            R::PauseScript(_) => self.pause_script(now),
            R::ContinueScript(_) => self.continue_script(now),

            // 4.4 I/O
            R::ReadBoxInfo(_) => self.read_box_info(),
            R::ReadBoxCI(c) => self.read_box_ci(c),
            R::ReadBoxDI(c) => self.read_box_di(c),
            R::ReadBoxCO(c) => self.read_box_co(c),
            R::ReadBoxDO(c) => self.read_box_do(c),
            R::ReadBoxAI(c) => self.read_box_ai(c),
            R::ReadBoxAO(c) => self.read_box_ao(c),
            R::SetBoxCO(c) => self.set_box_co(c),
            R::SetBoxDO(c) => self.set_box_do(c),
            R::SetBoxAOMode(c) => self.set_box_ao_mode(c),
            R::SetBoxAO(c) => self.set_box_ao(c),
            R::SetEndDO(c) => self.set_end_do(c),
            R::ReadEI(c) => self.read_ei(c),
            R::ReadEO(c) => self.read_eo(c),
            R::ReadEAI(c) => self.read_eai(c),

            // 4.5 settings and state
            R::SetOverride(c) => self.set_override(c),
            R::SetToolMotion(c) => {
                self.tool_motion = c.state == 1;
                done()
            }
            R::SetPayload(c) => self.set_payload(c),
            R::SetJointMaxVel(c) => {
                self.joint_max_vel = fs(c.joints);
                done()
            }
            R::SetJointMaxAcc(c) => {
                self.joint_max_acc = fs(c.joints);
                done()
            }
            R::SetLinearMaxVel(c) => {
                self.linear_max[0] = f(c.max_vel);
                done()
            }
            R::SetLinearMaxAcc(c) => {
                self.linear_max[1] = f(c.max_acc);
                done()
            }
            R::SetMaxAcsRange(c) => self.set_max_acs_range(c),
            R::SetMaxPcsRange(c) => self.set_max_pcs_range(c),
            R::ReadJointMaxVel(_) => values(rs::ReadJointMaxVel {
                joints: decs(self.joint_max_vel),
            }),
            R::ReadJointMaxAcc(_) => values(rs::ReadJointMaxAcc {
                joints: decs(self.joint_max_acc),
            }),
            R::ReadJointMaxJerk(_) => values(rs::ReadJointMaxJerk {
                joints: decs(self.joint_max_jerk),
            }),
            R::ReadLinearMaxVel(_) => self.read_linear_max_vel(),
            R::ReadEmergencyInfo(_) => self.read_emergency_info(),
            R::ReadRobotState(_) => self.read_robot_state(now),
            R::ReadCurWayPointID(_) => values(rs::ReadCurWayPointID {
                id: &self.waypoint_id,
            }),
            R::ReadAxisErrorCode(_) => self.read_axis_error_code(),
            R::ReadCurFSM(_) => values(rs::ReadCurFSM {
                state: self.fsm(now),
            }),

            // 4.6 positions and velocities
            R::ReadActPos(_) => self.read_act_pos(now),
            R::ReadCmdPos(_) => self.read_cmd_pos(now),
            R::ReadCmdJointVel(_) => values(rs::ReadCmdJointVel {
                joints: decs(self.joint_vel(now, false)),
            }),
            R::ReadActJointVel(_) => values(rs::ReadActJointVel {
                joints: decs(self.joint_vel(now, true)),
            }),
            R::ReadCmdTcpVel(_) => values(rs::ReadCmdTcpVel {
                velocity: decs(self.tcp_velocity(now, false)),
            }),
            R::ReadActTcpVel(_) => values(rs::ReadActTcpVel {
                velocity: decs(self.tcp_velocity(now, true)),
            }),
            R::ReadCmdJointCur(_) => values(rs::ReadCmdJointCur {
                joints: decs(self.snapshot(now).act_joint_cur),
            }),
            R::ReadActJointCur(_) => values(rs::ReadActJointCur {
                joints: decs(self.snapshot(now).act_joint_cur),
            }),
            R::ReadTcpVelocity(_) => self.read_tcp_velocity(now),

            // 4.7 kinematics and pose arithmetic
            R::Quaternion2RPY(c) => self.quaternion_to_rpy(c),
            R::RPY2Quaternion(c) => self.rpy_to_quaternion(c),
            R::GetInverseKin(c) => self.get_inverse_kin(c),
            R::GetForwardKin(c) => self.get_forward_kin(c),
            R::Base2UcsTcp(c) => self.base_to_ucs_tcp(c),
            R::UcsTcp2Base(c) => self.ucs_tcp_to_base(c),
            R::PoseAdd(c) => self.pose_add(c),
            R::PoseSub(c) => self.pose_sub(c),
            R::PoseTrans(c) => self.pose_trans(c),
            R::PoseInverse(c) => self.pose_inverse(c),
            R::PoseDist(c) => self.pose_dist(c),
            R::PoseInterpolate(c) => self.pose_interpolate(c),
            R::PoseDefdFrame(c) => self.pose_defd_frame(c),

            // 4.8 tool and user frames
            R::SetCurTCP(c) => self.set_cur_tcp(c),
            R::SetCurUCS(c) => self.set_cur_ucs(c),
            R::ReadCurTCP(_) => values(rs::ReadCurTCP {
                tcp: decs(self.tcp),
            }),
            R::ReadCurUCS(_) => values(rs::ReadCurUCS {
                ucs: decs(self.ucs),
            }),
            R::SetTCPByName(c) => self.set_tcp_by_name(c),
            R::SetUCSByName(c) => self.set_ucs_by_name(c),
            R::ReadTCPByName(c) => self.read_tcp_by_name(c),
            R::ReadUCSByName(c) => self.read_ucs_by_name(c),

            // 4.9 force control
            R::SetForceControlState(c) => self.set_force_control_state(c, now),
            R::ReadFTControlState(_) => self.read_ft_control_state(now),
            R::GrpFCInterrupt(_) | R::GrpFCContinue(_) => self.need_force_control(),
            R::SetForceZero(_) => self.set_force_zero(),
            // Tuning and tracking parameters: accepted, not modelled.
            R::SetForceToolCoordinateMotion(_)
            | R::HRSetMaxSearchVelocities(_)
            | R::HRSetControlFreedom(_)
            | R::HRSetForceControlStrategy(_)
            | R::SetFTPosition(_)
            | R::HRSetPIDControlParams(_)
            | R::HRSetMassParams(_)
            | R::HRSetDampParams(_)
            | R::HRSetStiffParams(_)
            | R::HRSetControlGoal(_)
            | R::HRSetForceDistanceLimit(_)
            | R::SetMoveTraceParams(_)
            | R::SetMoveTraceInitParams(_)
            | R::SetMoveTraceUcs(_)
            | R::SetTrackingState(_)
            | R::SetMovePathOverride(_) => done(),
            R::HRSetForceDataLimit(c) => self.hr_set_force_data_limit(c),
            R::SetForceFreeDriveMode(c) => self.force_free_drive(c.mode == 1, now),
            R::ReadFTCabData(_) => self.read_ft_cab_data(),

            // 4.10 moves
            R::MoveRelJ(c) => self.move_rel_j(c, now),
            R::MoveRelL(c) => self.move_rel_l(c, now),
            R::WayPointRel(c) => self.way_point_rel(c, now),
            R::WayPointEx(c) => self.way_point_ex(c, now),
            R::WayPoint(c) => self.way_point(c, now),
            R::WayPoint2(c) => self.way_point2(c, now),
            R::MoveJ(c) => self.move_j(c, now),
            R::MoveL(c) => self.move_l(c, now),
            R::MoveC(c) => self.move_c(c, now),
            R::MoveZ(c) => self.move_z(c, now),
            R::MoveE(c) => self.move_e(c, now),
            R::MoveS(c) => self.move_s(c, now),

            // 4.11 stored paths
            R::StartPushMovePath(c) => self.start_push_move_path(c),
            R::PushMovePathJ(c) => self.push_move_path_j(c),
            R::EndPushMovePath(c) => self.end_push_move_path(c, now),
            R::MovePath(c) => self.move_path(c, now),
            R::ReadMovePathState(c) => self.read_move_path_state(c),
            R::UpdateMovePathName(c) => self.update_move_path_name(c),
            R::DelMovePath(c) => self.del_move_path(c),
            R::ReadSoftMotionProgress(_) => self.read_soft_motion_progress(now),
            R::InitMovePathL(c) => self.init_move_path_l(c),
            R::PushMovePathL(c) => self.push_move_path_l(c),
            R::PushMovePaths(c) => self.push_move_paths(c),
            R::MovePathL(c) => self.move_path_l(c, now),

            // 4.12 servo
            R::StartServo(c) => self.start_servo(c, now),
            R::PushServoJ(c) => self.push_servo_j(c, now),
            R::PushServoP(c) => self.push_servo_p(c, now),

            // 4.14 extensions: the app interface, tool-end Modbus
            R::HRAppCmd(_) => done(),
            R::WriteHoldingRegisters(c) => self.write_holding_registers(c),
            R::ReadHoldingRegisters(c) => self.read_holding_registers(c),

            // ------------- the V6 document's additions, by its sections
            // 4.1
            R::GetErrorCodeStr(c) => self.get_error_code_str(c),
            R::PackageVersion(_) => values(rs::PackageVersion {
                version: &self.package_version,
            }),
            R::ReadFastCmdPort(_) => self.read_fast_cmd_port(),
            // 4.2
            R::EnterSafetyGuard(c) => self.enter_safe_guard(c.flag == 1, now),
            R::EnterSafeGuard(c) => self.enter_safe_guard(c.flag == 1, now),
            R::XToStandby(_) => self.x_to_standby(now),
            R::SetTriStageSwitch(c) => {
                self.stored.tri_stage = (c.enable, c.mode);
                done()
            }
            R::ReadBrakeStatus(_) => self.read_brake_status(),
            // 4.3
            R::SwitchScript(c) => self.switch_script(c),
            R::ReadDefaultScript(_) => self.read_default_script(),
            R::EnableRunningUnsavedProgram(c) => {
                self.stored.run_unsaved = c.enabled == 1;
                done()
            }
            // 4.4
            R::CdsSetIO(c) => self.cds_set_io(c),
            R::SetCIConfig(c) => self.set_ci_config(c),
            R::ReadCIConfig(c) => self.read_ci_config(c),
            R::SetCOConfig(c) => {
                self.stored.co_config[idx(c.bit)] = c.function;
                done()
            }
            R::ReadCOConfig(_) => values(rs::ReadCOConfig {
                functions: self.stored.co_config,
            }),
            // 4.5
            R::SetCollideLevel(c) => {
                self.stored.collide_level = c.level;
                done()
            }
            R::SetSafeGuardConfig(c) => {
                self.stored.safe_guard = [c.enable, c.mode, c.bit1, c.bit2];
                done()
            }
            R::ReadMaxPayload(_) => values(rs::ReadMaxPayload {
                max_payload: dec(MAX_PAYLOAD),
            }),
            R::ReadPayload(_) => self.read_payload(),
            R::ReadOverride(_) => values(rs::ReadOverride {
                ratio: dec(self.override_ratio),
            }),
            R::ReadPointByName(c) => self.read_point_by_name(c),
            R::ReadMotorAndJointEncode(_) => self.read_motor_and_joint_encode(now),
            // 4.6
            R::ReadTcpVel(_) => self.read_tcp_vel(now),
            // 4.7
            R::ReadActCoord(c) => self.read_act_coord(c, now),
            R::GetInverseDynamics(c) => self.get_inverse_dynamics(c),
            // 4.8
            R::ConfigTCP(c) => self.config_tcp(c),
            R::ConfigUCS(c) => self.config_ucs(c),
            R::SetDftTCP(c) => self.set_dft_tcp(c),
            R::CalTCPOrt(c) => self.cal_tcp_ort(c),
            R::SetBaseInstallingAngle(c) => {
                self.stored.base_angle = (c.rotation, c.tilt);
                done()
            }
            R::GetBaseInstallingAngle(_) => values(rs::GetBaseInstallingAngle {
                rotation: self.stored.base_angle.0,
                tilt: self.stored.base_angle.1,
            }),
            R::ReadTCPList(_) => self.read_tcp_list(),
            // 4.9
            R::SetFTMotionFreedom(c) => {
                self.stored.ft_freedom = c.freedom;
                done()
            }
            R::SetFTFreeDriveState(c) => self.force_free_drive(c.state == 1, now),
            R::ReadFTFreeDriveSpeedMode(_) => values(rs::ReadFTFreeDriveSpeedMode {
                mode: self.stored.ft_speed_mode,
            }),
            R::SetFTFreeDriveSpeedMode(c) => {
                self.stored.ft_speed_mode = c.mode;
                done()
            }
            R::SetFTFreeFactor(c) => {
                self.stored.ft_free_factor = (f(c.linear), f(c.angular));
                done()
            }
            R::SetTangentForceBounds(c) => self.set_tangent_force_bounds(c),
            R::SetFTCalibration(c) => self.set_ft_calibration(c),
            R::ReadForceData(_) => self.read_force_data(),
            R::ReadFTFreeFactor(_) => self.read_ft_free_factor(),
            R::SetFTUCS(c) => {
                self.stored.ft_ucs = fs(c.ucs);
                done()
            }
            R::ReadFTUCS(_) => values(rs::ReadFTUCS {
                ucs: decs(self.stored.ft_ucs),
            }),
            // 4.10 jogging and hold-to-move
            R::MoveAlignToZ(c) => self.move_align_to_z(c, now),
            R::MoveJTo(c) => self.move_j_to(c, now),
            R::MoveLTo(c) => self.move_l_to(c, now),
            R::ShortJogJ(c) => self.short_jog_j(c, now),
            R::ShortJogL(c) => self.short_jog_l(c, now),
            R::LongJogJ(c) => self.long_jog_j(c, now),
            R::LongJogL(c) => self.long_jog_l(c, now),
            R::LongMoveEvent(_) => self.long_move_event(now),
            // 4.11 paths
            R::InitPath(c) => self.init_path(c),
            R::PushPathPoints(c) => self.push_path_points(c),
            R::EndPushPathPoints(c) => self.end_push_path_points(c, now),
            R::DelPath(c) => self.del_path(c),
            R::ReadPath(c) => self.read_path(c),
            R::UpdatePathName(c) => self.update_path_name(c),
            R::ReadPathState(c) => self.read_path_state(c),
            R::MovePathJ(c) => self.move_path_j(c, now),
            R::MovePathJOL(c) => self.move_path_jol(c, now),
            R::GetMovePathJOLIndex(_) => self.get_move_path_jol_index(),
            R::SetPathRefJoints(c) => self.set_path_ref_joints(c),
            // 4.12 velocity control
            R::SpeedJ(c) => self.speed_j(c, now),
            R::SpeedL(c) => self.speed_l(c, now),
            // 4.14 pose tracking: accepted, not modelled
            R::SetPoseTrackingMaxMotionLimit(_)
            | R::SetPoseTrackingStopTimeOut(_)
            | R::SetPoseTrackingPIDParams(_)
            | R::SetPoseTrackingTargetPos(_)
            | R::SetUpdateTrackingPose(_) => done(),
            R::SetPoseTrackingState(c) => {
                self.stored.pose_tracking = c.state == 1;
                done()
            }
            // 4.15 tool-end Modbus settings, payload identification
            R::SetEndModbusInfo(c) => self.set_end_modbus_info(c),
            R::LoadIdentify(_) => self.start_load_identify(now),
            R::GetLoadIdentifyResult(_) => self.get_load_identify_result(now),

            R::Unknown(_) => Err(UNKNOWN),
        }
    }
}

/// The reply of a command that returns nothing: `Name,OK,;`, under the
/// name the request used.
fn ok_text(name: &str) -> Vec<u8> {
    format!("{name},OK,;").into_bytes()
}

/// Encodes a success reply, under the name the request used (an alias
/// such as `GrpPowerOn` is answered as `GrpPowerOn,OK,;`).
fn encode_ok(resp: &Response<'_>, name: &str) -> Vec<u8> {
    // Replies are short but for lists of names (paths, tools).
    for size in [16 * 1024, 1024 * 1024] {
        let mut buf = vec![0u8; size];
        match resp.encode(&mut buf) {
            Ok(n) => {
                buf.truncate(n);
                return renamed(buf, name);
            }
            Err(hans_codec::EncodeError::BufferTooSmall) => continue,
            Err(_) => break,
        }
    }
    // Only on a simulator bug (a value the codec cannot write).
    fail_text(name, FORMAT, "")
}

/// A reply written under its command's name, under `name` instead (the
/// alias the request used).
fn renamed(text: Vec<u8>, name: &str) -> Vec<u8> {
    let Some(id) = hans_codec::CommandId::from_name(name) else {
        return text;
    };
    let canonical = id.name();
    match text.strip_prefix(canonical.as_bytes()) {
        Some(rest) if canonical != name => {
            let mut out = name.as_bytes().to_vec();
            out.extend_from_slice(rest);
            out
        }
        _ => text,
    }
}

/// `Name,Fail,code,;` or `Name,Fail,code,detail,;`.
pub(crate) fn fail_text(name: &str, code: i32, detail: &str) -> Vec<u8> {
    let name = if name.is_empty() { "errorcmd" } else { name };
    let mut buf = vec![0u8; 1024 + detail.len()];
    let fail = hans_codec::Failure {
        name,
        code: code.into(),
        detail,
    };
    match fail.encode(&mut buf) {
        Ok(n) => {
            buf.truncate(n);
            buf
        }
        Err(_) => format!("{name},Fail,{code},;").into_bytes(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_robot_id_is_found_in_any_command() {
        let id = |m| robot_id(&Request::parse(m).unwrap());
        assert_eq!(id("ReadCurFSM,3,;"), Some(3));
        assert_eq!(id("ReadCurFSM,;"), Some(0), "omitted: robot 0");
        assert_eq!(id("SetBoxDO,1,1,;"), None, "box commands have none");
        assert_eq!(
            id("WayPoint,1,420,0,445,180,0,180,0,0,90,0,90,0,TCP,Base,50,360,0,0,0,0,0,0,1,;"),
            Some(1)
        );
    }
}
