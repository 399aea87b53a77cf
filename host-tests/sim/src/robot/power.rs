//! Sections 4.1 (initialisation: the box, 48 V, the master) and 4.2 (the
//! axis group: enable, reset, stop, pause, free drive).
//!
//! Each bring-up step raises its [`Stage`]; a step asked for while the one
//! before it is still rising is chained after it, so `ConnectToBox`,
//! `Electrify`, `StartMaster`, `GrpEnable` sent back to back end in
//! StandBy. Powering down stops any motion at once.

use hans_codec::{request as rq, response as rs, FsmState};

use super::dispatch::{done, values, Effect, Outcome, STATE};
use super::{Robot, Stage};

impl Robot {
    /// Everything that needs power stops and switches off: motion, scripts,
    /// free drive, enable.
    fn power_down(&mut self, now: f64) {
        self.abort_motion(now);
        self.script = None;
        self.free_drive = Stage::Off;
        self.ft_free = Stage::Off;
        self.enable = Stage::Off;
    }

    // ------------------------------------------------------------ 4.1

    pub(super) fn os_cmd(&mut self, c: &rq::OSCmd, now: f64, effect: &mut Effect) -> Outcome<'_> {
        self.power_down(now);
        self.power.lower(now, self.timing.blackout);
        if c.cmd_type == 2 {
            *effect = Effect::Reboot;
        }
        done()
    }

    pub(super) fn connect_to_box(&mut self, now: f64) -> Outcome<'_> {
        self.box_.raise(now, self.timing.box_connect);
        done()
    }

    pub(super) fn electrify(&mut self, now: f64) -> Outcome<'_> {
        if self.estop || !self.box_.coming() || matches!(self.power, Stage::Falling { .. }) {
            return Err(STATE);
        }
        let after = self.box_.ready_at(now);
        self.power.raise(after, self.timing.electrify);
        done()
    }

    pub(super) fn black_out(&mut self, now: f64) -> Outcome<'_> {
        self.power_down(now);
        self.power.lower(now, self.timing.blackout);
        done()
    }

    pub(super) fn start_master(&mut self, now: f64) -> Outcome<'_> {
        if self.estop || !self.power.coming() || matches!(self.master, Stage::Falling { .. }) {
            return Err(STATE);
        }
        let after = self.power.ready_at(now).max(self.box_.ready_at(now));
        self.master.raise(after, self.timing.start_master);
        done()
    }

    pub(super) fn close_master(&mut self, now: f64) -> Outcome<'_> {
        self.power_down(now);
        self.master.lower(now, self.timing.close_master);
        done()
    }

    pub(super) fn read_robot_model(&self) -> Outcome<'_> {
        values(rs::ReadRobotModel { model: &self.model })
    }

    // ------------------------------------------------------------ 4.2

    pub(super) fn grp_enable(&mut self, now: f64) -> Outcome<'_> {
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
        self.enable.raise(after, self.timing.enable);
        done()
    }

    pub(super) fn grp_disable(&mut self, now: f64) -> Outcome<'_> {
        if self.enable.coming() {
            self.abort_motion(now);
            self.script = None;
            self.free_drive = Stage::Off;
            self.ft_free = Stage::Off;
            self.enable.lower(now, self.timing.disable);
        }
        done()
    }

    pub(super) fn grp_reset(&mut self, now: f64) -> Outcome<'_> {
        if self.estop {
            return Err(STATE);
        }
        if self.error.take().is_some() {
            self.resetting_until = now + self.timing.reset.as_secs_f64();
        }
        if self.fsm(now) == FsmState::RobotHolding {
            self.abort_motion(now);
        }
        done()
    }

    pub(super) fn grp_stop(&mut self, now: f64) -> Outcome<'_> {
        self.stop(now);
        done()
    }

    pub(super) fn grp_interrupt(&mut self, now: f64) -> Outcome<'_> {
        if self.fsm(now) == FsmState::Moving && self.pause(now) {
            done()
        } else {
            Err(STATE)
        }
    }

    pub(super) fn grp_continue(&mut self, now: f64) -> Outcome<'_> {
        self.resume(now)?;
        done()
    }

    pub(super) fn grp_close_free_driver(&mut self, now: f64) -> Outcome<'_> {
        if !self.free_drive.coming() {
            return Err(STATE);
        }
        self.free_drive.lower(now, self.timing.free_drive);
        done()
    }

    pub(super) fn grp_open_free_driver(&mut self, now: f64) -> Outcome<'_> {
        self.need_standby(now)?;
        self.free_drive.raise(now, self.timing.free_drive);
        done()
    }

    // ------------------------------------------------ V6 document 4.1, 4.2

    pub(super) fn read_fast_cmd_port(&self) -> Outcome<'_> {
        let port = self.fast_port.ok_or(STATE)?;
        values(rs::ReadFastCmdPort {
            port: i32::from(port),
        })
    }

    /// `EnterSafetyGuard` / `EnterSafeGuard`: the safety guard forced on
    /// (a software stop: motion decelerates, FSM 12) or off.
    pub(super) fn enter_safe_guard(&mut self, on: bool, now: f64) -> Outcome<'_> {
        self.set_guard(on, now);
        done()
    }

    /// `XToStandby`: as far as the controller can go alone towards
    /// StandBy: the error reset, then every bring-up step still needed,
    /// chained. Refused under an emergency stop or an open safety guard.
    pub(super) fn x_to_standby(&mut self, now: f64) -> Outcome<'_> {
        if self.estop || self.guard {
            return Err(STATE);
        }
        if self.error.take().is_some() {
            self.resetting_until = now + self.timing.reset.as_secs_f64();
        }
        self.stop(now);
        self.script = None;
        self.free_drive.lower(now, self.timing.free_drive);
        self.ft_free.lower(now, self.timing.free_drive);
        self.box_.raise(now, self.timing.box_connect);
        let after = self.box_.ready_at(now);
        self.power.raise(after, self.timing.electrify);
        let after = self.power.ready_at(now);
        self.master.raise(after, self.timing.start_master);
        let after = self.master.ready_at(now).max(now.max(self.resetting_until));
        self.enable.raise(after, self.timing.enable);
        done()
    }

    pub(super) fn read_brake_status(&self) -> Outcome<'_> {
        let released = i32::from(self.enable.is_on() && !self.estop);
        values(rs::ReadBrakeStatus {
            brakes: [released; 6],
        })
    }
}
