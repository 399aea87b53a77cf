//! One answer per command of chapter 4: what each request does to the robot
//! and which reply it gets. Replies are built as typed codec values
//! (`hans_codec::response`) and encoded by the codec.
//!
//! Refusals: a command that the current state does not allow gets
//! `Fail,20018`; a parameter the document's ranges allow but the robot
//! cannot use (an unreachable pose, a robot id other than 0, a speed of 0,
//! an unknown path) gets `Fail,20006`; unknown tool / user frame names get
//! `Fail,20029` / `Fail,20030`; a path that is not ready `Fail,20042`;
//! an unknown script function `Fail,20601`; force-control commands outside
//! force control `Fail,40020`; `GrpContinue` while still braking
//! `Fail,40014`; tool Modbus when the end I/O is not EtherCAT `Fail,40058`.

use hans_codec::{request as rq, response as rs, Decimal, FsmState, Request, Response, RobotId};

use super::motion::{Path, PlanError};
use super::{
    reached, MoveKind, Planned, Robot, Script, Speed, Stage, Track, MAX_PATHS, MAX_PATH_POINTS,
    MAX_QUEUE,
};
use crate::kinematics::{self as k, Frame, Joints, Pose};

/// What the server must do besides sending the reply.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) enum Effect {
    #[default]
    None,
    /// `OSCmd,2`: the controller reboots (connections drop, refused for a
    /// while, then the robot is powered off).
    Reboot,
}

/// A failure code.
type Code = i32;
type Answer<'s> = Result<Response<'s>, Code>;

const STATE: Code = 20018;
const PARAM: Code = 20006;

/// Speeds of the jog-like relative moves, which carry none.
const JOG_JOINT_VEL: f64 = 30.0;
const JOG_JOINT_ACC: f64 = 90.0;
const JOG_LINEAR_VEL: f64 = 50.0;
const JOG_LINEAR_ACC: f64 = 200.0;
/// Largest payload of the simulated model (kg).
const MAX_PAYLOAD: f64 = 5.0;

fn dec(v: f64) -> Decimal {
    Decimal::from_f64(v, 3).unwrap_or(Decimal::ZERO)
}

fn decs<const N: usize>(v: [f64; N]) -> [Decimal; N] {
    v.map(dec)
}

fn f(d: Decimal) -> f64 {
    d.to_f64()
}

fn fs<const N: usize>(d: [Decimal; N]) -> [f64; N] {
    d.map(|x| x.to_f64())
}

fn b(v: bool) -> i32 {
    i32::from(v)
}

fn rbt(id: RobotId) -> Result<(), Code> {
    if id.0 == 0 {
        Ok(())
    } else {
        Err(PARAM)
    }
}

fn hv<T: Clone, const N: usize>(v: &[T]) -> heapless::Vec<T, N> {
    heapless::Vec::from_slice(v).unwrap_or_default()
}

fn idx(v: i32) -> usize {
    usize::try_from(v).unwrap_or(usize::MAX)
}

fn plan_err(_: PlanError) -> Code {
    PARAM
}

/// Wraps an angle difference into -180..180.
fn wrap(d: f64) -> f64 {
    (d + 180.0).rem_euclid(360.0) - 180.0
}

impl Robot {
    /// Executes one request at `now` and returns the reply text; `name` is
    /// the name as received (an alias is answered under the alias).
    pub fn handle(&mut self, req: &Request<'_>, name: &str, now: f64) -> (Vec<u8>, Effect) {
        self.update(now);
        let mut effect = Effect::None;
        let answer = match req.command() {
            None => Err(20005),
            Some(_) => match req.validate() {
                Err(_) => Err(PARAM),
                Ok(()) => self.exec(req, now, &mut effect),
            },
        };
        let text = match answer {
            Ok(resp) => encode_ok(&resp, name),
            Err(code) => fail_text(name, code, ""),
        };
        (text, effect)
    }

    fn fsm_now(&self, now: f64) -> FsmState {
        self.fsm(now)
    }

    fn need_standby(&self, now: f64) -> Result<(), Code> {
        if self.fsm_now(now) == FsmState::StandBy {
            Ok(())
        } else {
            Err(STATE)
        }
    }

    /// New motion is accepted in StandBy and (queued) while Moving.
    fn need_motion(&self, now: f64) -> Result<(), Code> {
        match self.fsm_now(now) {
            FsmState::StandBy | FsmState::Moving => Ok(()),
            _ => Err(STATE),
        }
    }

    fn need_box(&self) -> Result<(), Code> {
        if self.box_.is_on() && !self.estop {
            Ok(())
        } else {
            Err(STATE)
        }
    }

    fn need_end_io(&self) -> Result<(), Code> {
        if self.box_.is_on() && self.power.is_on() && self.master.is_on() && !self.estop {
            Ok(())
        } else {
            Err(STATE)
        }
    }

    fn tcp_named(&self, name: &str) -> Result<Pose, Code> {
        self.tcps.get(name).copied().ok_or(20029)
    }

    fn ucs_named(&self, name: &str) -> Result<Pose, Code> {
        self.ucss.get(name).copied().ok_or(20030)
    }

    fn seek(seek: i32, bit: i32, state: i32) -> Option<(usize, bool)> {
        (seek == 1).then(|| (idx(bit), state == 1))
    }

    fn accept(&mut self, plan: Planned, now: f64) -> Answer<'static> {
        if self.push_move(plan, now) {
            Err(0)
        } else {
            Err(STATE)
        }
    }

    /// A joint move to `target` at `v` °/s, `a` °/s² (before the override).
    fn joint_move(
        &self,
        target: Joints,
        v: f64,
        a: f64,
        cmd_id: Option<&str>,
        seek: Option<(usize, bool)>,
    ) -> Result<Planned, Code> {
        if !(v > 0.0 && a > 0.0 && self.limits.contains(&target)) {
            return Err(PARAM);
        }
        let start = self.plan_start();
        let path = Path::joint_line(start, target);
        let len = path.length();
        let mut v = v;
        for i in 0..6 {
            let d = (target[i] - start[i]).abs();
            if d > 1e-9 {
                v = v.min(self.joint_max_vel[i] * len / d);
            }
        }
        let ov = self.override_ratio;
        Ok(Planned {
            path,
            speed: Speed::Trap {
                v: (v * ov).max(1e-3),
                a: (a * ov).max(1e-3),
            },
            cmd_id: cmd_id.map(str::to_string),
            seek,
            kind: MoveKind::Move,
        })
    }

    /// A Cartesian move through TCP frames (base frame) with tool `tcp`.
    fn linear_move(
        &self,
        frames: &[Frame],
        tcp: &Pose,
        v: f64,
        a: f64,
        cmd_id: Option<&str>,
        seek: Option<(usize, bool)>,
    ) -> Result<Planned, Code> {
        if !(v > 0.0 && a > 0.0) {
            return Err(PARAM);
        }
        let path = Path::cartesian(
            self.plan_start(),
            frames,
            &Frame::from_pose(tcp),
            &self.limits,
        )
        .map_err(plan_err)?;
        let ov = self.override_ratio;
        Ok(Planned {
            path,
            speed: Speed::Trap {
                v: (v.min(self.linear_max[0]) * ov).max(1e-3),
                a: (a.min(self.linear_max[1]) * ov).max(1e-3),
            },
            cmd_id: cmd_id.map(str::to_string),
            seek,
            kind: MoveKind::Move,
        })
    }

    /// The TCP frame (base) where the next move starts, for tool `tcp`.
    fn start_tcp_frame(&self, tcp: &Pose) -> Frame {
        k::forward(&self.plan_start()).mul(&Frame::from_pose(tcp))
    }

    /// A way-point style move: joint (`linear == false`) or linear.
    #[allow(clippy::too_many_arguments)]
    fn way_point(
        &mut self,
        now: f64,
        pose: &Pose,
        joints: &Joints,
        tcp: Pose,
        ucs: Pose,
        v: f64,
        a: f64,
        linear: bool,
        use_joint: bool,
        cmd_id: &str,
        seek: Option<(usize, bool)>,
    ) -> Answer<'static> {
        self.need_motion(now)?;
        let plan = if linear {
            let target = Frame::from_pose(&ucs).mul(&Frame::from_pose(pose));
            self.linear_move(&[target], &tcp, v, a, Some(cmd_id), seek)?
        } else {
            let target = if use_joint {
                *joints
            } else {
                k::inverse(&k::flange_of(pose, &tcp, &ucs), joints, &self.limits).ok_or(PARAM)?
            };
            self.joint_move(target, v, a, Some(cmd_id), seek)?
        };
        self.accept(plan, now)
    }

    fn script_start(&mut self, now: f64) {
        self.script = Some(Script::Running {
            until: now + self.timing.script.as_secs_f64(),
        });
    }

    fn track_mut(&mut self, name: &str, cartesian: bool) -> Result<&mut Track, Code> {
        match self.tracks.get_mut(name) {
            Some(t) if t.cartesian == cartesian => Ok(t),
            _ => Err(PARAM),
        }
    }

    fn new_track(&mut self, name: &str, t: Track) -> Result<(), Code> {
        if !self.tracks.contains_key(name) && self.tracks.len() >= MAX_PATHS {
            return Err(PARAM);
        }
        self.tracks.insert(name.to_string(), t);
        Ok(())
    }

    fn blank_track(&self, cartesian: bool) -> Track {
        Track {
            cartesian,
            points: Vec::new(),
            state: 0,
            ready_at: 0.0,
            speed_ratio: 1.0,
            vel: 100.0,
            acc: 2500.0,
            tcp: self.tcp,
            ucs: self.ucs,
        }
    }

    fn push_points(&mut self, name: &str, cartesian: bool, pts: &[[f64; 6]]) -> Answer<'static> {
        if !self.tracks.contains_key(name) {
            let t = self.blank_track(cartesian);
            self.new_track(name, t)?;
        }
        let t = self.track_mut(name, cartesian)?;
        if !matches!(t.state, 0 | 1) || t.points.len() + pts.len() > MAX_PATH_POINTS {
            return Err(PARAM);
        }
        t.points.extend_from_slice(pts);
        t.state = 1;
        Err(0)
    }

    fn tcp_velocity(&self, now: f64, actual: bool) -> Pose {
        let dt = 0.001;
        let q = |t| {
            if actual {
                self.act_joints(t)
            } else {
                self.cmd_joints(t)
            }
        };
        let p1 = k::forward_pose(&q(now), &self.tcp, &self.ucs);
        let p0 = k::forward_pose(&q(now - dt), &self.tcp, &self.ucs);
        let mut v = [0.0; 6];
        for i in 0..6 {
            let d = if i < 3 {
                p1[i] - p0[i]
            } else {
                wrap(p1[i] - p0[i])
            };
            v[i] = d / dt;
        }
        v
    }

    fn joint_vel(&self, now: f64, actual: bool) -> Joints {
        let dt = 0.001;
        let (a, b) = if actual {
            (self.act_joints(now), self.act_joints(now - dt))
        } else {
            (self.cmd_joints(now), self.cmd_joints(now - dt))
        };
        let mut v = [0.0; 6];
        for i in 0..6 {
            v[i] = (a[i] - b[i]) / dt;
        }
        v
    }

    /// The command. `Err(0)` is the shorthand for "OK without values"
    /// (turned into the empty success reply by [`encode_ok`]'s caller).
    fn exec<'s>(&'s mut self, req: &'s Request<'_>, now: f64, effect: &mut Effect) -> Answer<'s> {
        match self.exec_inner(req, now, effect) {
            Err(0) => Ok(empty_ok(req)),
            other => other,
        }
    }

    #[allow(clippy::too_many_lines)]
    fn exec_inner<'s>(
        &'s mut self,
        req: &'s Request<'_>,
        now: f64,
        effect: &mut Effect,
    ) -> Answer<'s> {
        use Request as R;
        let t = self.timing;
        let done = Err(0);
        match req {
            // ------------------------------------------------------ 4.1
            R::OSCmd(c) => {
                self.abort_motion(now);
                self.script = None;
                self.free_drive = Stage::Off;
                self.ft_free = Stage::Off;
                self.enable = Stage::Off;
                self.power.lower(now, t.blackout);
                if c.cmd_type == 2 {
                    *effect = Effect::Reboot;
                }
                done
            }
            R::ConnectToBox(_) => {
                self.box_.raise(now, t.box_connect);
                done
            }
            R::Electrify(_) => {
                if self.estop || !self.box_.coming() || matches!(self.power, Stage::Falling { .. })
                {
                    return Err(STATE);
                }
                let after = self.box_.ready_at(now);
                self.power.raise(after, t.electrify);
                done
            }
            R::BlackOut(_) => {
                self.abort_motion(now);
                self.script = None;
                self.free_drive = Stage::Off;
                self.ft_free = Stage::Off;
                self.enable = Stage::Off;
                self.power.lower(now, t.blackout);
                done
            }
            R::StartMaster(_) => {
                if self.estop
                    || !self.power.coming()
                    || matches!(self.master, Stage::Falling { .. })
                {
                    return Err(STATE);
                }
                let after = self.power.ready_at(now).max(self.box_.ready_at(now));
                self.master.raise(after, t.start_master);
                done
            }
            R::CloseMaster(_) => {
                self.abort_motion(now);
                self.script = None;
                self.free_drive = Stage::Off;
                self.ft_free = Stage::Off;
                self.enable = Stage::Off;
                self.master.lower(now, t.close_master);
                done
            }
            R::IsSimulation(_) => Ok(rs::IsSimulation { simulated: 1 }.into()),
            R::ReadControllerState(_) => Ok(rs::ReadControllerState { started: 1 }.into()),
            R::ReadRobotModel(_) => Ok(rs::ReadRobotModel { model: &self.model }.into()),

            // ------------------------------------------------------ 4.2
            R::GrpEnable(c) => {
                rbt(c.rbt_id)?;
                if self.estop
                    || self.guard
                    || self.error.is_some()
                    || !self.master.coming()
                    || !self.power.coming()
                    || matches!(self.enable, Stage::Falling { .. })
                {
                    return Err(STATE);
                }
                let after = self
                    .master
                    .ready_at(now)
                    .max(self.power.ready_at(now))
                    .max(now.max(self.resetting_until));
                self.enable.raise(after, t.enable);
                done
            }
            R::GrpDisable(c) => {
                rbt(c.rbt_id)?;
                if self.enable.coming() {
                    self.abort_motion(now);
                    self.script = None;
                    self.free_drive = Stage::Off;
                    self.ft_free = Stage::Off;
                    self.enable.lower(now, t.disable);
                }
                done
            }
            R::GrpReset(c) => {
                rbt(c.rbt_id)?;
                if self.estop {
                    return Err(STATE);
                }
                if self.error.take().is_some() {
                    self.resetting_until = now + t.reset.as_secs_f64();
                }
                if self.fsm_now(now) == FsmState::RobotHolding {
                    self.abort_motion(now);
                }
                done
            }
            R::GrpStop(c) => {
                rbt(c.rbt_id)?;
                self.stop(now);
                done
            }
            R::GrpInterrupt(c) => {
                rbt(c.rbt_id)?;
                if self.fsm_now(now) == FsmState::Moving && self.pause(now) {
                    done
                } else {
                    Err(STATE)
                }
            }
            R::GrpContinue(c) => {
                rbt(c.rbt_id)?;
                self.resume(now)?;
                done
            }
            R::GrpCloseFreeDriver(c) => {
                rbt(c.rbt_id)?;
                if !self.free_drive.coming() {
                    return Err(STATE);
                }
                self.free_drive.lower(now, t.free_drive);
                done
            }
            R::GrpOpenFreeDriver(c) => {
                rbt(c.rbt_id)?;
                self.need_standby(now)?;
                self.free_drive.raise(now, t.free_drive);
                done
            }

            // ------------------------------------------------------ 4.3
            R::RunFunc(c) => {
                self.need_standby(now)?;
                if !self.script_functions.iter().any(|f| f == c.func_name) {
                    return Err(20601);
                }
                self.script_start(now);
                Ok(rs::RunFunc {
                    func_name: c.func_name,
                }
                .into())
            }
            R::StartScript(_) => {
                self.need_standby(now)?;
                self.script_start(now);
                done
            }
            R::StopScript(_) => {
                if matches!(
                    self.script,
                    Some(Script::Running { .. } | Script::Pausing { .. } | Script::Held { .. })
                ) {
                    self.script = Some(Script::Stopping {
                        until: now + t.script_transition.as_secs_f64(),
                    });
                }
                done
            }
            R::PauseScript(_) => match self.script {
                Some(Script::Running { until }) => {
                    self.script = Some(Script::Pausing {
                        until: now + t.script_transition.as_secs_f64(),
                        remaining: until - now,
                    });
                    done
                }
                _ => Err(STATE),
            },
            R::ContinueScript(_) => match self.script {
                Some(Script::Held { remaining }) => {
                    self.script = Some(Script::Running {
                        until: now + remaining,
                    });
                    done
                }
                _ => Err(STATE),
            },

            // ------------------------------------------------------ 4.4
            R::ReadBoxInfo(c) => {
                rbt(c.rbt_id)?;
                let powered = self.power.is_on() && !self.estop;
                let current = if self.enable.is_on() { 1.2 } else { 0.3 };
                Ok(rs::ReadBoxInfo {
                    connected: b(self.box_.is_on()),
                    power_48v: b(powered),
                    out_voltage: dec(if powered { 48.0 } else { 0.0 }),
                    out_current: dec(if powered { current } else { 0.0 }),
                    remote_button: 0,
                    three_stage_button: 0,
                    voltage_12v: None,
                    current_12v: None,
                }
                .into())
            }
            R::ReadBoxCI(c) => {
                self.need_box()?;
                let v: Vec<i32> = c.bits.iter().map(|&i| b(self.io.ci[idx(i)])).collect();
                Ok(rs::ReadBoxCI { values: hv(&v) }.into())
            }
            R::ReadBoxDI(c) => {
                self.need_box()?;
                let v: Vec<i32> = c.bits.iter().map(|&i| b(self.io.di[idx(i)])).collect();
                Ok(rs::ReadBoxDI { values: hv(&v) }.into())
            }
            R::ReadBoxCO(c) => {
                self.need_box()?;
                let v: Vec<i32> = c.bits.iter().map(|&i| b(self.io.co[idx(i)])).collect();
                Ok(rs::ReadBoxCO { values: hv(&v) }.into())
            }
            R::ReadBoxDO(c) => {
                self.need_box()?;
                let v: Vec<i32> = c.bits.iter().map(|&i| b(self.io.do_[idx(i)])).collect();
                Ok(rs::ReadBoxDO { values: hv(&v) }.into())
            }
            R::ReadBoxAI(c) => {
                self.need_box()?;
                let v: Vec<Decimal> = c
                    .channels
                    .iter()
                    .map(|&i| dec(self.io.ai[idx(i)]))
                    .collect();
                Ok(rs::ReadBoxAI { values: hv(&v) }.into())
            }
            R::ReadBoxAO(c) => {
                self.need_box()?;
                let v: Vec<Decimal> = c
                    .channels
                    .iter()
                    .map(|&i| dec(self.io.ao[idx(i)]))
                    .collect();
                Ok(rs::ReadBoxAO { values: hv(&v) }.into())
            }
            R::SetBoxCO(c) => {
                self.need_box()?;
                self.io.co[idx(c.bit)] = c.value == 1;
                done
            }
            R::SetBoxDO(c) => {
                self.need_box()?;
                self.io.do_[idx(c.bit)] = c.value == 1;
                done
            }
            R::SetBoxAOMode(c) => {
                self.need_box()?;
                self.io.ao_mode[idx(c.channel)] = c.mode;
                done
            }
            R::SetBoxAO(c) => {
                self.need_box()?;
                let v = f(c.value);
                let ok = match c.mode {
                    1 => (0.0..=10.0).contains(&v),
                    _ => (4.0..=20.0).contains(&v),
                };
                if !ok {
                    return Err(PARAM);
                }
                let ch = idx(c.channel);
                self.io.ao_mode[ch] = c.mode;
                self.io.ao[ch] = v;
                done
            }
            R::SetEndDO(c) => {
                rbt(c.rbt_id)?;
                self.need_end_io()?;
                self.io.end_do[idx(c.bit)] = c.value == 1;
                done
            }
            R::ReadEI(c) => {
                rbt(c.rbt_id)?;
                self.need_end_io()?;
                let v: Vec<i32> = c.bits.iter().map(|&i| b(self.io.end_di[idx(i)])).collect();
                Ok(rs::ReadEI { values: hv(&v) }.into())
            }
            R::ReadEO(c) => {
                rbt(c.rbt_id)?;
                self.need_end_io()?;
                let v: Vec<i32> = c.bits.iter().map(|&i| b(self.io.end_do[idx(i)])).collect();
                Ok(rs::ReadEO { values: hv(&v) }.into())
            }
            R::ReadEAI(c) => {
                rbt(c.rbt_id)?;
                self.need_end_io()?;
                Ok(rs::ReadEAI {
                    value: dec(self.io.end_ai[idx(c.channel)]),
                }
                .into())
            }

            // ------------------------------------------------------ 4.5
            R::SetOverride(c) => {
                rbt(c.rbt_id)?;
                if self.active.is_some() || !self.queue.is_empty() {
                    return Err(STATE);
                }
                self.override_ratio = f(c.ratio);
                done
            }
            R::SetToolMotion(c) => {
                rbt(c.rbt_id)?;
                self.tool_motion = c.state == 1;
                done
            }
            R::SetPayload(c) => {
                rbt(c.rbt_id)?;
                if f(c.mass) > MAX_PAYLOAD {
                    return Err(PARAM);
                }
                done
            }
            R::SetJointMaxVel(c) => {
                rbt(c.rbt_id)?;
                self.joint_max_vel = fs(c.joints);
                done
            }
            R::SetJointMaxAcc(c) => {
                rbt(c.rbt_id)?;
                self.joint_max_acc = fs(c.joints);
                done
            }
            R::SetLinearMaxVel(c) => {
                rbt(c.rbt_id)?;
                self.linear_max[0] = f(c.max_vel);
                done
            }
            R::SetLinearMaxAcc(c) => {
                rbt(c.rbt_id)?;
                self.linear_max[1] = f(c.max_acc);
                done
            }
            R::SetMaxAcsRange(c) => {
                rbt(c.rbt_id)?;
                let (max, min) = (fs(c.max), fs(c.min));
                if (0..6).any(|i| min[i] >= max[i]) {
                    return Err(PARAM);
                }
                self.limits = k::Limits { max, min };
                done
            }
            R::SetMaxPcsRange(c) => {
                rbt(c.rbt_id)?;
                let (max, min) = (fs(c.max), fs(c.min));
                if (0..3).any(|i| min[i] > max[i]) {
                    return Err(PARAM);
                }
                done
            }
            R::ReadJointMaxVel(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::ReadJointMaxVel {
                    joints: decs(self.joint_max_vel),
                }
                .into())
            }
            R::ReadJointMaxAcc(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::ReadJointMaxAcc {
                    joints: decs(self.joint_max_acc),
                }
                .into())
            }
            R::ReadJointMaxJerk(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::ReadJointMaxJerk {
                    joints: decs(self.joint_max_jerk),
                }
                .into())
            }
            R::ReadLinearMaxVel(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::ReadLinearMaxVel {
                    max_vel: dec(self.linear_max[0]),
                    max_acc: dec(self.linear_max[1]),
                    max_jerk: dec(self.linear_max[2]),
                }
                .into())
            }
            R::ReadEmergencyInfo(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::ReadEmergencyInfo {
                    estop_error: 0,
                    estop: b(self.estop),
                    safety_guard_error: 0,
                    safety_guard: b(self.guard),
                }
                .into())
            }
            R::ReadRobotState(c) => {
                rbt(c.rbt_id)?;
                let fl = self.flags(now);
                Ok(rs::ReadRobotState {
                    moving: b(fl.moving),
                    enabled: b(fl.enabled),
                    error: b(fl.error),
                    error_code: fl.error_code,
                    error_axis: fl.error_axis,
                    brake_released: b(fl.brake_released),
                    paused: b(fl.paused),
                    emergency_stop: b(fl.emergency_stop),
                    safety_guard: b(fl.safety_guard),
                    powered: b(fl.powered),
                    box_connected: b(fl.box_connected),
                    blending_done: b(fl.blending_done),
                    in_position: b(fl.in_position),
                }
                .into())
            }
            R::ReadCurWayPointID(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::ReadCurWayPointID {
                    id: &self.waypoint_id,
                }
                .into())
            }
            R::ReadAxisErrorCode(c) => {
                rbt(c.rbt_id)?;
                let mut axes = [0; 6];
                let code = self.error.map_or(0, |e| {
                    if let Some(a) = axes.get_mut(idx(e.axis)) {
                        *a = e.code;
                    }
                    e.code
                });
                Ok(rs::ReadAxisErrorCode { code, axes }.into())
            }
            R::ReadCurFSM(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::ReadCurFSM {
                    state: self.fsm_now(now),
                }
                .into())
            }

            // ------------------------------------------------------ 4.6
            R::ReadActPos(c) => {
                rbt(c.rbt_id)?;
                let q = self.act_joints(now);
                Ok(rs::ReadActPos {
                    joints: decs(q),
                    pose: decs(k::forward_pose(&q, &self.tcp, &self.ucs)),
                    tcp: decs(self.tcp),
                    ucs: decs(self.ucs),
                }
                .into())
            }
            R::ReadCmdPos(c) => {
                rbt(c.rbt_id)?;
                let q = self.cmd_joints(now);
                Ok(rs::ReadCmdPos {
                    joints: decs(q),
                    pose: decs(k::forward_pose(&q, &self.tcp, &self.ucs)),
                }
                .into())
            }
            R::ReadCmdJointVel(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::ReadCmdJointVel {
                    joints: decs(self.joint_vel(now, false)),
                }
                .into())
            }
            R::ReadActJointVel(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::ReadActJointVel {
                    joints: decs(self.joint_vel(now, true)),
                }
                .into())
            }
            R::ReadCmdTcpVel(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::ReadCmdTcpVel {
                    velocity: decs(self.tcp_velocity(now, false)),
                }
                .into())
            }
            R::ReadActTcpVel(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::ReadActTcpVel {
                    velocity: decs(self.tcp_velocity(now, true)),
                }
                .into())
            }
            R::ReadCmdJointCur(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::ReadCmdJointCur {
                    joints: decs(self.snapshot(now).act_joint_cur),
                }
                .into())
            }
            R::ReadActJointCur(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::ReadActJointCur {
                    joints: decs(self.snapshot(now).act_joint_cur),
                }
                .into())
            }
            R::ReadTcpVelocity(c) => {
                rbt(c.rbt_id)?;
                let speed = |v: Pose| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                Ok(rs::ReadTcpVelocity {
                    cmd: dec(speed(self.tcp_velocity(now, false))),
                    act: dec(speed(self.tcp_velocity(now, true))),
                }
                .into())
            }

            // ------------------------------------------------------ 4.7
            R::Quaternion2RPY(c) => {
                rbt(c.rbt_id)?;
                let m = k::quat_to_mat(fs(c.quaternion)).ok_or(PARAM)?;
                Ok(rs::Quaternion2RPY {
                    rpy: decs(k::mat_to_rpy(&m)),
                }
                .into())
            }
            R::RPY2Quaternion(c) => {
                rbt(c.rbt_id)?;
                let [rx, ry, rz] = fs(c.rpy);
                Ok(rs::RPY2Quaternion {
                    quaternion: decs(k::mat_to_quat(&k::rpy_to_mat(rx, ry, rz))),
                }
                .into())
            }
            R::GetInverseKin(c) => {
                rbt(c.rbt_id)?;
                let target = k::flange_of(&fs(c.pose), &fs(c.tcp), &fs(c.ucs));
                let q = k::inverse(&target, &fs(c.reference), &self.limits).ok_or(PARAM)?;
                Ok(rs::GetInverseKin { joints: decs(q) }.into())
            }
            R::GetForwardKin(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::GetForwardKin {
                    pose: decs(k::forward_pose(&fs(c.joints), &fs(c.tcp), &fs(c.ucs))),
                }
                .into())
            }
            R::Base2UcsTcp(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::Base2UcsTcp {
                    pose: decs(k::base_to_ucs_tcp(&fs(c.pose), &fs(c.tcp), &fs(c.ucs))),
                }
                .into())
            }
            R::UcsTcp2Base(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::UcsTcp2Base {
                    pose: decs(k::ucs_tcp_to_base(&fs(c.pose), &fs(c.tcp), &fs(c.ucs))),
                }
                .into())
            }
            R::PoseAdd(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::PoseAdd {
                    pose: decs(k::pose_add(&fs(c.pose1), &fs(c.pose2))),
                }
                .into())
            }
            R::PoseSub(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::PoseSub {
                    pose: decs(k::pose_sub(&fs(c.pose1), &fs(c.pose2))),
                }
                .into())
            }
            R::PoseTrans(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::PoseTrans {
                    pose: decs(k::pose_trans(&fs(c.pose1), &fs(c.pose2))),
                }
                .into())
            }
            R::PoseInverse(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::PoseInverse {
                    pose: decs(k::pose_inverse(&fs(c.pose))),
                }
                .into())
            }
            R::PoseDist(c) => {
                rbt(c.rbt_id)?;
                let (d, a) = k::pose_dist(&fs(c.pose1), &fs(c.pose2));
                Ok(rs::PoseDist {
                    distance: dec(d),
                    angle: dec(a),
                }
                .into())
            }
            R::PoseInterpolate(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::PoseInterpolate {
                    pose: decs(k::pose_interpolate(&fs(c.pose1), &fs(c.pose2), f(c.alpha))),
                }
                .into())
            }
            R::PoseDefdFrame(c) => {
                rbt(c.rbt_id)?;
                let pts = [c.p1, c.p2, c.p3, c.p4, c.p5, c.p6].map(fs);
                Ok(rs::PoseDefdFrame {
                    ucs: decs(k::pose_defd_frame(&pts).ok_or(PARAM)?),
                }
                .into())
            }

            // ------------------------------------------------------ 4.8
            R::SetCurTCP(c) => {
                rbt(c.rbt_id)?;
                if self.active.is_some() {
                    return Err(STATE);
                }
                self.tcp = fs(c.tcp);
                done
            }
            R::SetCurUCS(c) => {
                rbt(c.rbt_id)?;
                if self.active.is_some() {
                    return Err(STATE);
                }
                self.ucs = fs(c.ucs);
                done
            }
            R::ReadCurTCP(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::ReadCurTCP {
                    tcp: decs(self.tcp),
                }
                .into())
            }
            R::ReadCurUCS(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::ReadCurUCS {
                    ucs: decs(self.ucs),
                }
                .into())
            }
            R::SetTCPByName(c) => {
                rbt(c.rbt_id)?;
                let p = self.tcp_named(c.name)?;
                if self.active.is_some() {
                    return Err(STATE);
                }
                self.tcp = p;
                done
            }
            R::SetUCSByName(c) => {
                rbt(c.rbt_id)?;
                let p = self.ucs_named(c.name)?;
                if self.active.is_some() {
                    return Err(STATE);
                }
                self.ucs = p;
                done
            }
            R::ReadTCPByName(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::ReadTCPByName {
                    tcp: decs(self.tcp_named(c.name)?),
                }
                .into())
            }
            R::ReadUCSByName(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::ReadUCSByName {
                    ucs: decs(self.ucs_named(c.name)?),
                }
                .into())
            }

            // ------------------------------------------------------ 4.9
            R::SetForceControlState(c) => {
                rbt(c.rbt_id)?;
                if c.state == 1 {
                    if self.ft_on.is_none() {
                        self.need_motion(now)?;
                        self.ft_on = Some(now);
                    }
                } else if self.ft_on.take().is_some() {
                    self.ft_free.lower(now, t.free_drive);
                    if self.active.is_none() {
                        self.idle_since = self.idle_since.max(now);
                    }
                }
                done
            }
            R::ReadFTControlState(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::ReadFTControlState {
                    state: self.ft_state(now),
                }
                .into())
            }
            R::GrpFCInterrupt(rq::GrpFCInterrupt { rbt_id })
            | R::GrpFCContinue(rq::GrpFCContinue { rbt_id }) => {
                rbt(*rbt_id)?;
                if self.ft_on.is_none() {
                    return Err(40020);
                }
                done
            }
            R::SetForceZero(c) => {
                rbt(c.rbt_id)?;
                self.ft_data = [0.0; 6];
                done
            }
            R::SetForceToolCoordinateMotion(rq::SetForceToolCoordinateMotion {
                rbt_id, ..
            })
            | R::HRSetMaxSearchVelocities(rq::HRSetMaxSearchVelocities { rbt_id, .. })
            | R::HRSetControlFreedom(rq::HRSetControlFreedom { rbt_id, .. })
            | R::HRSetForceControlStrategy(rq::HRSetForceControlStrategy { rbt_id, .. })
            | R::SetFTPosition(rq::SetFTPosition { rbt_id, .. })
            | R::HRSetPIDControlParams(rq::HRSetPIDControlParams { rbt_id, .. })
            | R::HRSetMassParams(rq::HRSetMassParams { rbt_id, .. })
            | R::HRSetDampParams(rq::HRSetDampParams { rbt_id, .. })
            | R::HRSetStiffParams(rq::HRSetStiffParams { rbt_id, .. })
            | R::HRSetControlGoal(rq::HRSetControlGoal { rbt_id, .. })
            | R::HRSetForceDistanceLimit(rq::HRSetForceDistanceLimit { rbt_id, .. })
            | R::SetMoveTraceParams(rq::SetMoveTraceParams { rbt_id, .. })
            | R::SetMoveTraceInitParams(rq::SetMoveTraceInitParams { rbt_id, .. })
            | R::SetMoveTraceUcs(rq::SetMoveTraceUcs { rbt_id, .. })
            | R::SetTrackingState(rq::SetTrackingState { rbt_id, .. })
            | R::SetMovePathOverride(rq::SetMovePathOverride { rbt_id, .. }) => {
                rbt(*rbt_id)?;
                done
            }
            R::HRSetForceDataLimit(c) => {
                rbt(c.rbt_id)?;
                let (max, min) = (fs(c.max), fs(c.min));
                if (0..6).any(|i| min[i] > max[i]) {
                    return Err(PARAM);
                }
                done
            }
            R::SetForceFreeDriveMode(c) => {
                rbt(c.rbt_id)?;
                if c.mode == 1 {
                    if !self.ft_free.coming() {
                        self.need_standby(now)?;
                        self.ft_free.raise(now, t.free_drive);
                    }
                } else {
                    self.ft_free.lower(now, t.free_drive);
                }
                done
            }
            R::ReadFTCabData(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::ReadFTCabData {
                    data: decs(self.ft_data),
                }
                .into())
            }

            // ------------------------------------------------------ 4.10
            R::MoveRelJ(c) => {
                rbt(c.rbt_id)?;
                self.need_motion(now)?;
                let mut target = self.plan_start();
                let d = f(c.distance);
                target[idx(c.axis)] += if c.direction == 1 { d } else { -d };
                let plan = self.joint_move(target, JOG_JOINT_VEL, JOG_JOINT_ACC, None, None)?;
                self.accept(plan, now)
            }
            R::MoveRelL(c) => {
                rbt(c.rbt_id)?;
                self.need_motion(now)?;
                let d = f(c.distance) * if c.direction == 1 { 1.0 } else { -1.0 };
                let tool = c.tool_motion.map_or(self.tool_motion, |m| m == 1);
                let tcp = self.tcp;
                let start = self.start_tcp_frame(&tcp);
                let ucs = Frame::from_pose(&self.ucs);
                let axis = idx(c.axis);
                let mut delta = [0.0; 6];
                delta[axis] = d;
                let target = if tool {
                    start.mul(&Frame::from_pose(&delta))
                } else {
                    // Translate / rotate about the user frame's axes, keeping
                    // the TCP point fixed for rotations.
                    let mut r = Frame::IDENTITY;
                    r.r = Frame::from_pose(&[0.0, 0.0, 0.0, delta[3], delta[4], delta[5]]).r;
                    let r_base = ucs.r;
                    let rot = k::mat_mul(&r_base, &k::mat_mul(&r.r, &k::transpose(&r_base)));
                    let shift = k::mat_vec(&r_base, &[delta[0], delta[1], delta[2]]);
                    Frame {
                        r: k::mat_mul(&rot, &start.r),
                        p: [
                            start.p[0] + shift[0],
                            start.p[1] + shift[1],
                            start.p[2] + shift[2],
                        ],
                    }
                };
                let (v, a) = if axis < 3 {
                    (JOG_LINEAR_VEL, JOG_LINEAR_ACC)
                } else {
                    (JOG_JOINT_VEL, JOG_JOINT_ACC)
                };
                let plan = self.linear_move(&[target], &tcp, v, a, None, None)?;
                self.accept(plan, now)
            }
            R::WayPointRel(c) => {
                rbt(c.rbt_id)?;
                self.need_motion(now)?;
                let tcp = self.tcp_named(c.tcp_name)?;
                let ucs = self.ucs_named(c.ucs_name)?;
                let add = c.rel_move_type == 1;
                let target = fs(c.target);
                let seek = Self::seek(c.seek, c.io_bit, c.io_state);
                let (v, a) = (f(c.velocity), f(c.acc));
                if c.move_type == 0 {
                    let mut q = if c.use_point_list == 1 {
                        fs(c.joints)
                    } else {
                        self.plan_start()
                    };
                    for i in 0..6 {
                        if c.axis_mask[i] == 1 {
                            q[i] = if add { q[i] + target[i] } else { target[i] };
                        }
                    }
                    let plan = self.joint_move(q, v, a, Some(c.cmd_id), seek)?;
                    self.accept(plan, now)
                } else {
                    let mut p = if c.use_point_list == 1 {
                        fs(c.pose)
                    } else {
                        let q = self.plan_start();
                        k::forward_pose(&q, &tcp, &ucs)
                    };
                    for i in 0..6 {
                        if c.axis_mask[i] == 1 {
                            p[i] = if add { p[i] + target[i] } else { target[i] };
                        }
                    }
                    let frame = Frame::from_pose(&ucs).mul(&Frame::from_pose(&p));
                    let plan = self.linear_move(&[frame], &tcp, v, a, Some(c.cmd_id), seek)?;
                    self.accept(plan, now)
                }
            }
            R::WayPointEx(c) => {
                rbt(c.rbt_id)?;
                self.way_point(
                    now,
                    &fs(c.pose),
                    &fs(c.joints),
                    fs(c.tcp),
                    fs(c.ucs),
                    f(c.velocity),
                    f(c.acc),
                    c.move_type == 1,
                    c.use_joint == 1,
                    c.cmd_id,
                    Self::seek(c.seek, c.io_bit, c.io_state),
                )
            }
            R::WayPoint(c) => {
                rbt(c.rbt_id)?;
                let tcp = self.tcp_named(c.tcp_name)?;
                let ucs = self.ucs_named(c.ucs_name)?;
                self.way_point(
                    now,
                    &fs(c.pose),
                    &fs(c.joints),
                    tcp,
                    ucs,
                    f(c.velocity),
                    f(c.acc),
                    c.move_type == 1,
                    c.use_joint == 1,
                    c.cmd_id,
                    Self::seek(c.seek, c.io_bit, c.io_state),
                )
            }
            R::WayPoint2(c) => {
                rbt(c.rbt_id)?;
                let tcp = self.tcp_named(c.tcp_name)?;
                let ucs = self.ucs_named(c.ucs_name)?;
                let seek = Self::seek(c.seek, c.io_bit, c.io_state);
                if c.move_type == 2 {
                    self.need_motion(now)?;
                    let u = Frame::from_pose(&ucs);
                    let start = self.start_tcp_frame(&tcp);
                    let aux = u.mul(&Frame::from_pose(&fs(c.aux_pose)));
                    let end = u.mul(&Frame::from_pose(&fs(c.end_pose)));
                    let frames = arc_frames(&start, &aux, &end, false, 1.0, false).ok_or(PARAM)?;
                    let plan = self.linear_move(
                        &frames,
                        &tcp,
                        f(c.velocity),
                        f(c.acc),
                        Some(c.cmd_id),
                        seek,
                    )?;
                    self.accept(plan, now)
                } else {
                    self.way_point(
                        now,
                        &fs(c.end_pose),
                        &fs(c.joints),
                        tcp,
                        ucs,
                        f(c.velocity),
                        f(c.acc),
                        c.move_type == 1,
                        c.use_joint == 1,
                        c.cmd_id,
                        seek,
                    )
                }
            }
            R::MoveJ(c) => {
                rbt(c.rbt_id)?;
                let tcp = self.tcp_named(c.tcp_name)?;
                let ucs = self.ucs_named(c.ucs_name)?;
                self.way_point(
                    now,
                    &fs(c.pose),
                    &fs(c.joints),
                    tcp,
                    ucs,
                    f(c.velocity),
                    f(c.acc),
                    false,
                    c.use_joint == 1,
                    c.cmd_id,
                    Self::seek(c.seek, c.io_bit, c.io_state),
                )
            }
            R::MoveL(c) => {
                rbt(c.rbt_id)?;
                let tcp = self.tcp_named(c.tcp_name)?;
                let ucs = self.ucs_named(c.ucs_name)?;
                self.way_point(
                    now,
                    &fs(c.pose),
                    &fs(c.joints),
                    tcp,
                    ucs,
                    f(c.velocity),
                    f(c.acc),
                    true,
                    false,
                    c.cmd_id,
                    Self::seek(c.seek, c.io_bit, c.io_state),
                )
            }
            R::MoveC(c) => {
                rbt(c.rbt_id)?;
                self.need_motion(now)?;
                let tcp = self.tcp_named(c.tcp_name)?;
                let ucs = Frame::from_pose(&self.ucs_named(c.ucs_name)?);
                let start = ucs.mul(&Frame::from_pose(&fs(c.start)));
                let aux = ucs.mul(&Frame::from_pose(&fs(c.aux)));
                let end = ucs.mul(&Frame::from_pose(&fs(c.end)));
                let turns = f(c.rad_len).trunc().max(1.0);
                let mut frames = vec![start];
                frames.extend(
                    arc_frames(
                        &start,
                        &aux,
                        &end,
                        c.circle_type == 0,
                        turns,
                        c.fixed_posture == 1,
                    )
                    .ok_or(PARAM)?,
                );
                let plan =
                    self.linear_move(&frames, &tcp, f(c.velocity), f(c.acc), Some(c.cmd_id), None)?;
                self.accept(plan, now)
            }
            R::MoveZ(c) => {
                rbt(c.rbt_id)?;
                self.need_motion(now)?;
                let tcp = self.tcp_named(c.tcp_name)?;
                let ucs = Frame::from_pose(&self.ucs_named(c.ucs_name)?);
                let start = ucs.mul(&Frame::from_pose(&fs(c.start)));
                let end = ucs.mul(&Frame::from_pose(&fs(c.end)));
                let plane = (c.enable_plane == 1).then(|| ucs.mul(&Frame::from_pose(&fs(c.plane))));
                let pitch = if c.enable_density == 1 && f(c.density) > 0.0 {
                    f(c.density)
                } else {
                    f(c.width).abs().max(1.0)
                };
                let frames = zigzag_frames(&start, &end, plane.as_ref(), &ucs, f(c.width), pitch)
                    .ok_or(PARAM)?;
                let plan =
                    self.linear_move(&frames, &tcp, f(c.velocity), f(c.acc), Some(c.cmd_id), None)?;
                self.accept(plan, now)
            }
            R::MoveE(c) => {
                rbt(c.rbt_id)?;
                self.need_motion(now)?;
                let tcp = self.tcp_named(c.tcp_name)?;
                let ucs = Frame::from_pose(&self.ucs_named(c.ucs_name)?);
                let mut frames: Vec<Frame> = [c.p1, c.p2, c.p3, c.p4, c.p5]
                    .iter()
                    .map(|p| ucs.mul(&Frame::from_pose(&fs(*p))))
                    .collect();
                if c.orient_mode == 1 {
                    frames.push(frames[0]);
                }
                if c.move_type == 1 {
                    let r = frames[0].r;
                    for fr in &mut frames {
                        fr.r = r;
                    }
                }
                let plan =
                    self.linear_move(&frames, &tcp, f(c.velocity), f(c.acc), Some(c.cmd_id), None)?;
                self.accept(plan, now)
            }
            R::MoveS(c) => {
                rbt(c.rbt_id)?;
                self.need_motion(now)?;
                let tcp = self.tcp_named(c.tcp_name)?;
                let ucs = Frame::from_pose(&self.ucs_named(c.ucs_name)?);
                let start = self.start_tcp_frame(&tcp);
                let (frames, length, turn_deg) =
                    spiral_frames(&start, &ucs, f(c.increment), f(c.diameter));
                // The document gives the spiral's speed in °/s of turning.
                let per_deg = if turn_deg > 0.0 {
                    length / turn_deg
                } else {
                    1.0
                };
                let plan = self.linear_move(
                    &frames,
                    &tcp,
                    f(c.velocity) * per_deg,
                    f(c.acc) * per_deg,
                    Some(c.cmd_id),
                    None,
                )?;
                self.accept(plan, now)
            }

            // ------------------------------------------------------ 4.11
            R::StartPushMovePath(c) => {
                rbt(c.rbt_id)?;
                let mut t = self.blank_track(false);
                t.speed_ratio = f(c.speed_ratio);
                self.new_track(c.track, t)?;
                done
            }
            R::PushMovePathJ(c) => {
                rbt(c.rbt_id)?;
                if !self.tracks.contains_key(c.track) {
                    return Err(PARAM);
                }
                self.push_points(c.track, false, &[fs(c.joints)])
            }
            R::EndPushMovePath(c) => {
                rbt(c.rbt_id)?;
                let limits = self.limits;
                let ready_at = now + t.path_compute.as_secs_f64();
                let tr = self.tracks.get_mut(c.track).ok_or(PARAM)?;
                if tr.cartesian {
                    tr.state = if tr.points.is_empty() { 5 } else { 4 };
                } else if tr.points.len() < 2 || !tr.points.iter().all(|q| limits.contains(q)) {
                    tr.state = 5;
                } else {
                    tr.state = 2;
                    tr.ready_at = ready_at;
                    if reached(now, ready_at) {
                        tr.state = 3;
                    }
                }
                done
            }
            R::MovePath(c) => {
                rbt(c.rbt_id)?;
                let tr = match self.tracks.get(c.track) {
                    Some(t) if !t.cartesian && t.state == 3 => t.clone(),
                    _ => return Err(20042),
                };
                self.need_motion(now)?;
                let mut pts = vec![self.plan_start()];
                pts.extend_from_slice(&tr.points);
                let path = Path::joint_polyline(&pts);
                let ratio = tr.speed_ratio.max(0.01) * self.override_ratio;
                let vmax = self
                    .joint_max_vel
                    .iter()
                    .copied()
                    .fold(f64::INFINITY, f64::min);
                let amax = self
                    .joint_max_acc
                    .iter()
                    .copied()
                    .fold(f64::INFINITY, f64::min);
                let plan = Planned {
                    path,
                    speed: Speed::Trap {
                        v: (vmax * ratio).max(1e-3),
                        a: (amax * ratio).max(1e-3),
                    },
                    cmd_id: None,
                    seek: None,
                    kind: MoveKind::Move,
                };
                self.accept(plan, now)
            }
            R::ReadMovePathState(c) => {
                rbt(c.rbt_id)?;
                Ok(rs::ReadMovePathState {
                    state: self.tracks.get(c.track).map_or(0, |t| t.state),
                }
                .into())
            }
            R::UpdateMovePathName(c) => {
                rbt(c.rbt_id)?;
                let tr = self.tracks.remove(c.track).ok_or(PARAM)?;
                self.tracks.insert(c.new_name.to_string(), tr);
                done
            }
            R::DelMovePath(c) => {
                rbt(c.rbt_id)?;
                self.tracks.remove(c.track).ok_or(PARAM)?;
                done
            }
            R::ReadSoftMotionProgress(c) => {
                rbt(c.rbt_id)?;
                let (p, i) = match &self.active {
                    Some(seg) => match seg.plan.kind {
                        MoveKind::PathL(n) => {
                            let len = seg.plan.path.length();
                            let p = if len > 0.0 {
                                (seg.s_at(now).0 / len).clamp(0.0, 1.0)
                            } else {
                                0.0
                            };
                            (p, (p * n as f64).floor() as i32)
                        }
                        MoveKind::Dwell => (0.0, 0),
                        MoveKind::Move => self.last_path_l.unwrap_or((0.0, 0)),
                    },
                    None => self.last_path_l.unwrap_or((0.0, 0)),
                };
                Ok(rs::ReadSoftMotionProgress {
                    progress: Decimal::from_f64(p, 6).unwrap_or(Decimal::ZERO),
                    index: i,
                }
                .into())
            }
            R::InitMovePathL(c) => {
                rbt(c.rbt_id)?;
                let tcp = self.tcp_named(c.tcp_name)?;
                let ucs = self.ucs_named(c.ucs_name)?;
                let (v, a) = (f(c.velocity), f(c.acc));
                if !(v > 0.0 && a > 0.0) {
                    return Err(PARAM);
                }
                let mut t = self.blank_track(true);
                t.vel = v;
                t.acc = a;
                t.tcp = tcp;
                t.ucs = ucs;
                self.new_track(c.track, t)?;
                done
            }
            R::PushMovePathL(c) => {
                rbt(c.rbt_id)?;
                if !self.tracks.contains_key(c.track) {
                    return Err(PARAM);
                }
                self.push_points(c.track, true, &[fs(c.pose)])
            }
            R::PushMovePaths(c) => {
                rbt(c.rbt_id)?;
                let pts: Vec<[f64; 6]> = c.points.iter().map(fs).collect();
                if pts.is_empty() {
                    return Err(PARAM);
                }
                self.push_points(c.track, c.move_type == 1, &pts)
            }
            R::MovePathL(c) => {
                rbt(c.rbt_id)?;
                let tr = match self.tracks.get(c.track) {
                    Some(t) if t.cartesian && matches!(t.state, 1 | 4) && !t.points.is_empty() => {
                        t.clone()
                    }
                    _ => return Err(20042),
                };
                self.need_motion(now)?;
                let u = Frame::from_pose(&tr.ucs);
                let frames: Vec<Frame> = tr
                    .points
                    .iter()
                    .map(|p| u.mul(&Frame::from_pose(p)))
                    .collect();
                let mut plan = self.linear_move(&frames, &tr.tcp, tr.vel, tr.acc, None, None)?;
                plan.kind = MoveKind::PathL(tr.points.len());
                let dwell = Planned {
                    path: Path::dwell(self.plan_start()),
                    speed: Speed::Timed(t.path_l_compute.as_secs_f64()),
                    cmd_id: None,
                    seek: None,
                    kind: MoveKind::Dwell,
                };
                if self.queue.len() + 2 > MAX_QUEUE {
                    return Err(STATE);
                }
                self.last_path_l = Some((0.0, 0));
                self.push_move(dwell, now);
                self.accept(plan, now)
            }

            // ------------------------------------------------------ 4.12
            R::StartServo(c) => {
                rbt(c.rbt_id)?;
                self.need_motion(now)?;
                self.servo = Some(f(c.servo_time));
                done
            }
            R::PushServoJ(c) => {
                rbt(c.rbt_id)?;
                let dur = self.servo.ok_or(STATE)?;
                self.need_motion(now)?;
                let target = fs(c.joints);
                if !self.limits.contains(&target) {
                    return Err(PARAM);
                }
                let plan = Planned {
                    path: Path::joint_line(self.plan_start(), target),
                    speed: Speed::Timed(dur),
                    cmd_id: None,
                    seek: None,
                    kind: MoveKind::Move,
                };
                self.accept(plan, now)
            }
            R::PushServoP(c) => {
                rbt(c.rbt_id)?;
                let dur = self.servo.ok_or(STATE)?;
                self.need_motion(now)?;
                let flange = k::flange_of(&fs(c.pose), &fs(c.tcp), &fs(c.ucs));
                let target = k::inverse(&flange, &self.plan_start(), &self.limits).ok_or(PARAM)?;
                let plan = Planned {
                    path: Path::joint_line(self.plan_start(), target),
                    speed: Speed::Timed(dur),
                    cmd_id: None,
                    seek: None,
                    kind: MoveKind::Move,
                };
                self.accept(plan, now)
            }

            // ------------------------------------------------------ 4.14
            R::HRAppCmd(_) => done,
            R::WriteHoldingRegisters(c) => {
                rbt(c.rbt_id)?;
                self.need_end_io()?;
                if !self.end_io_ethercat {
                    return Err(40058);
                }
                let data = c.data.as_slice();
                if !(c.function == 16 || (c.function == 6 && data.len() == 1)) {
                    return Err(PARAM);
                }
                let mut values = Vec::with_capacity(data.len());
                for &v in data {
                    let v = if (0..=65535).contains(&v) {
                        v as u16
                    } else if (-32768..0).contains(&v) {
                        v as i16 as u16
                    } else {
                        return Err(PARAM);
                    };
                    values.push(v);
                }
                let addr = u16::try_from(c.address).map_err(|_| PARAM)?;
                if !self.io.write_registers(idx(c.slave), addr, &values) {
                    return Err(PARAM);
                }
                done
            }
            R::ReadHoldingRegisters(c) => {
                rbt(c.rbt_id)?;
                self.need_end_io()?;
                if !self.end_io_ethercat {
                    return Err(40058);
                }
                if !matches!(c.function, 3 | 4) {
                    return Err(PARAM);
                }
                let addr = u16::try_from(c.address).map_err(|_| PARAM)?;
                let values = self
                    .io
                    .read_registers(idx(c.slave), addr, idx(c.count))
                    .ok_or(PARAM)?;
                let v: Vec<i32> = values.iter().map(|&x| i32::from(x)).collect();
                Ok(rs::ReadHoldingRegisters { values: hv(&v) }.into())
            }
            R::Unknown(_) => Err(20005),
        }
    }
}

/// The success reply without values of a request.
fn empty_ok(req: &Request<'_>) -> Response<'static> {
    use Request as R;
    macro_rules! empty {
        ($($C:ident),* $(,)?) => {
            match req {
                $( R::$C(_) => Response::$C(rs::$C {}), )*
                _ => Response::GrpStop(rs::GrpStop {}),
            }
        };
    }
    empty!(
        OSCmd,
        ConnectToBox,
        Electrify,
        BlackOut,
        StartMaster,
        CloseMaster,
        GrpEnable,
        GrpDisable,
        GrpReset,
        GrpStop,
        GrpInterrupt,
        GrpContinue,
        GrpCloseFreeDriver,
        GrpOpenFreeDriver,
        StartScript,
        StopScript,
        PauseScript,
        ContinueScript,
        SetBoxCO,
        SetBoxDO,
        SetBoxAOMode,
        SetBoxAO,
        SetEndDO,
        SetOverride,
        SetToolMotion,
        SetPayload,
        SetJointMaxVel,
        SetJointMaxAcc,
        SetLinearMaxVel,
        SetLinearMaxAcc,
        SetMaxAcsRange,
        SetMaxPcsRange,
        SetCurTCP,
        SetCurUCS,
        SetTCPByName,
        SetUCSByName,
        SetForceControlState,
        SetForceToolCoordinateMotion,
        GrpFCInterrupt,
        GrpFCContinue,
        SetForceZero,
        HRSetMaxSearchVelocities,
        HRSetControlFreedom,
        HRSetForceControlStrategy,
        SetFTPosition,
        HRSetPIDControlParams,
        HRSetMassParams,
        HRSetDampParams,
        HRSetStiffParams,
        HRSetControlGoal,
        HRSetForceDataLimit,
        HRSetForceDistanceLimit,
        SetForceFreeDriveMode,
        MoveRelJ,
        MoveRelL,
        WayPointRel,
        WayPointEx,
        WayPoint,
        WayPoint2,
        MoveJ,
        MoveL,
        MoveC,
        MoveZ,
        MoveE,
        MoveS,
        StartPushMovePath,
        PushMovePathJ,
        EndPushMovePath,
        MovePath,
        UpdateMovePathName,
        DelMovePath,
        InitMovePathL,
        PushMovePathL,
        PushMovePaths,
        MovePathL,
        SetMovePathOverride,
        StartServo,
        PushServoJ,
        PushServoP,
        SetMoveTraceParams,
        SetMoveTraceInitParams,
        SetMoveTraceUcs,
        SetTrackingState,
        HRAppCmd,
        WriteHoldingRegisters,
    )
}

/// Encodes a success reply, under the name the request used (an alias
/// such as `GrpPowerOn` is answered as `GrpPowerOn,OK,;`).
fn encode_ok(resp: &Response<'_>, name: &str) -> Vec<u8> {
    let mut buf = vec![0u8; 16 * 1024];
    match resp.encode(&mut buf) {
        Ok(n) => {
            buf.truncate(n);
            let canonical = resp.name();
            if canonical != name && buf.starts_with(canonical.as_bytes()) {
                let mut out = name.as_bytes().to_vec();
                out.extend_from_slice(&buf[canonical.len()..]);
                return out;
            }
            buf
        }
        // Only on a simulator bug (a value the codec cannot write).
        Err(_) => fail_text(name, 20007, ""),
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

/// TCP frames along an arc from `start` through `aux` to `end` (the start
/// itself excluded), or `turns` full circles when `full`. Orientation is
/// interpolated from start to end, or kept when `fixed`.
fn arc_frames(
    start: &Frame,
    aux: &Frame,
    end: &Frame,
    full: bool,
    turns: f64,
    fixed: bool,
) -> Option<Vec<Frame>> {
    let (c, r, u, v, ang) = k::circle_through(start.p, aux.p, end.p)?;
    let total = if full {
        turns * 2.0 * std::f64::consts::PI
    } else {
        ang
    };
    let n = ((total * r / 5.0).ceil() as usize).clamp(8, 720);
    Some(
        (1..=n)
            .map(|i| {
                let t = total * i as f64 / n as f64;
                let frac = i as f64 / n as f64;
                Frame {
                    r: if fixed {
                        start.r
                    } else {
                        k::slerp(&start.r, &end.r, frac)
                    },
                    p: k::circle_point(c, r, u, v, t),
                }
            })
            .collect(),
    )
}

/// A zig-zag from `start` to `end`, `width` wide, one turn every `pitch` mm
/// of advance, in the plane through start, end and `plane` (or the user
/// frame's XY plane).
fn zigzag_frames(
    start: &Frame,
    end: &Frame,
    plane: Option<&Frame>,
    ucs: &Frame,
    width: f64,
    pitch: f64,
) -> Option<Vec<Frame>> {
    let d = [
        end.p[0] - start.p[0],
        end.p[1] - start.p[1],
        end.p[2] - start.p[2],
    ];
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if len < 1e-6 {
        return None;
    }
    let dir = [d[0] / len, d[1] / len, d[2] / len];
    let normal = match plane {
        Some(p) => {
            let w = [
                p.p[0] - start.p[0],
                p.p[1] - start.p[1],
                p.p[2] - start.p[2],
            ];
            let n = [
                dir[1] * w[2] - dir[2] * w[1],
                dir[2] * w[0] - dir[0] * w[2],
                dir[0] * w[1] - dir[1] * w[0],
            ];
            let nn = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if nn < 1e-6 {
                return None;
            }
            [n[0] / nn, n[1] / nn, n[2] / nn]
        }
        None => [ucs.r[0][2], ucs.r[1][2], ucs.r[2][2]],
    };
    // Sideways direction: in the plane, across the travel.
    let side = [
        normal[1] * dir[2] - normal[2] * dir[1],
        normal[2] * dir[0] - normal[0] * dir[2],
        normal[0] * dir[1] - normal[1] * dir[0],
    ];
    let n = ((len / pitch.max(0.1)).ceil() as usize).clamp(1, 500);
    let mut frames = Vec::with_capacity(n + 1);
    for i in 1..=n {
        let t = i as f64 / n as f64;
        let off = if i == n {
            0.0
        } else if i % 2 == 1 {
            width / 2.0
        } else {
            -width / 2.0
        };
        frames.push(Frame {
            r: k::slerp(&start.r, &end.r, t),
            p: [
                start.p[0] + d[0] * t + side[0] * off,
                start.p[1] + d[1] * t + side[1] * off,
                start.p[2] + d[2] * t + side[2] * off,
            ],
        });
    }
    let mut all = vec![*start];
    all.extend(frames);
    Some(all)
}

/// An Archimedean spiral in the user frame's XY plane around the start:
/// radius from 1 mm growing by `incr` per turn up to `end_radius`. Returns
/// the frames, the path length (mm) and the total turning (°).
fn spiral_frames(start: &Frame, ucs: &Frame, incr: f64, end_radius: f64) -> (Vec<Frame>, f64, f64) {
    let turns = ((end_radius - 1.0) / incr.max(1e-3)).clamp(0.0, 200.0);
    let total = turns * 2.0 * std::f64::consts::PI;
    let n = ((turns * 72.0).ceil() as usize).clamp(2, 3000);
    let (ux, uy) = (
        [ucs.r[0][0], ucs.r[1][0], ucs.r[2][0]],
        [ucs.r[0][1], ucs.r[1][1], ucs.r[2][1]],
    );
    let mut frames = Vec::with_capacity(n);
    let mut length = 0.0;
    let mut prev = start.p;
    for i in 0..=n {
        let th = total * i as f64 / n as f64;
        let r = 1.0 + incr * th / (2.0 * std::f64::consts::PI);
        let (s, c) = th.sin_cos();
        let p = [
            start.p[0] + r * (c * ux[0] + s * uy[0]),
            start.p[1] + r * (c * ux[1] + s * uy[1]),
            start.p[2] + r * (c * ux[2] + s * uy[2]),
        ];
        length += k::distance(prev, p);
        prev = p;
        frames.push(Frame { r: start.r, p });
    }
    (frames, length, total.to_degrees())
}
