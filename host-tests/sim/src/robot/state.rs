//! What the robot's state reads as: the FSM state (the table in the
//! module `robot`) and the `ReadRobotState` flags.

use hans_codec::FsmState;

use super::queue::{MoveKind, Phase};
use super::{reached, Robot, Script, Stage};

/// The `ReadRobotState` flags.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Flags {
    /// `nMovingState` (lags the motion by [`Timing::moving_flag_lag`](super::Timing::moving_flag_lag)).
    pub moving: bool,
    /// `nEnableState`.
    pub enabled: bool,
    /// `nErrorState`.
    pub error: bool,
    /// `nErrorCode`.
    pub error_code: i32,
    /// `nErrorAxis`.
    pub error_axis: i32,
    /// `nBreaking`: true = brakes released.
    pub brake_released: bool,
    /// `nPause`.
    pub paused: bool,
    /// `nEmergencyStop`.
    pub emergency_stop: bool,
    /// `nSaftyGuard`.
    pub safety_guard: bool,
    /// `nElectrify`.
    pub powered: bool,
    /// `nIsConnectToBox`.
    pub box_connected: bool,
    /// `nBlendingDone`: no way point running or waiting.
    pub blending_done: bool,
    /// `nInPos`: the actual position has reached the command position.
    pub in_position: bool,
}

impl Robot {
    /// The FSM state at `now` (after [`Robot::update`]).
    pub fn fsm(&self, now: f64) -> FsmState {
        use FsmState as F;
        if self.estop {
            return F::EmergencyStop;
        }
        match self.box_ {
            Stage::On => {}
            Stage::Rising { .. } => return F::ElectricBoxConnecting,
            _ => return F::ElectricBoxDisconnect,
        }
        match self.power {
            Stage::On => {}
            Stage::Rising { .. } => return F::Electrifying48V,
            Stage::Falling { .. } => return F::Blackouting48V,
            Stage::Off => return F::Blackout48V,
        }
        match self.master {
            Stage::On => {}
            Stage::Rising { .. } => return F::ControllerConnecting,
            Stage::Falling { .. } => return F::ControllerDisconnecting,
            Stage::Off => return F::ControllerDisconnect,
        }
        if self.guard {
            return F::SafetyGuard;
        }
        if self.error.is_some() {
            return F::Error;
        }
        if !reached(now, self.resetting_until) {
            return F::Reseting;
        }
        match self.enable {
            Stage::On => {}
            Stage::Rising { .. } => return F::Enabling,
            Stage::Falling { .. } => return F::Disabling,
            Stage::Off => return F::Disable,
        }
        match self.free_drive {
            Stage::Rising { .. } => return F::RobotOpeningFreeDriver,
            Stage::On => return F::FreeDriver,
            Stage::Falling { .. } => return F::RobotClosingFreeDriver,
            Stage::Off => {}
        }
        match self.ft_free {
            Stage::Rising { .. } => return F::FTOpeningFreeDriver,
            Stage::On => return F::FTFreeDriver,
            Stage::Falling { .. } => return F::FTClosingFreeDriver,
            Stage::Off => {}
        }
        match self.script {
            Some(Script::Running { .. }) => return F::ScriptRunning,
            Some(Script::Pausing { .. }) => return F::ScriptHoldHandling,
            Some(Script::Held { .. }) => return F::ScriptHolding,
            Some(Script::Stopping { .. }) => return F::ScriptStopping,
            None => {}
        }
        if self.load_identify_running(now) {
            return F::RobotLoadIdentify;
        }
        match &self.active {
            Some(seg) => match (seg.phase, seg.plan.kind) {
                (Phase::Stop, _) => F::RobotStopping,
                (Phase::Pause, _) => F::RobotHolding,
                (Phase::Run, MoveKind::Hold) => F::LongJogMoving,
                (Phase::Run, _) => F::Moving,
            },
            None if !self.queue.is_empty() || self.ft_on.is_some() => F::Moving,
            None => F::StandBy,
        }
    }

    /// The `ReadRobotState` flags at `now`.
    pub fn flags(&self, now: f64) -> Flags {
        let lagged = now - Self::secs(self.timing.moving_flag_lag);
        let moving = if self.motion_running() {
            reached(lagged, self.busy_since)
        } else {
            reached(lagged, self.busy_since) && !reached(lagged, self.idle_since)
        } || self.ft_on.is_some_and(|since| reached(lagged, since));
        let enabled = self.enable.is_on() && !self.estop;
        let settled = !self.motion_running()
            && reached(now, self.idle_since + Self::secs(self.timing.actual_lag));
        Flags {
            moving,
            enabled,
            error: self.error.is_some(),
            error_code: self.error.map_or(0, |e| e.code),
            error_axis: self.error.map_or(0, |e| e.axis),
            brake_released: enabled,
            paused: self
                .active
                .as_ref()
                .is_some_and(|s| s.phase == Phase::Pause),
            emergency_stop: self.estop,
            safety_guard: self.guard,
            powered: self.power.is_on() && !self.estop,
            box_connected: self.box_.is_on(),
            blending_done: self.active.is_none() && self.queue.is_empty(),
            in_position: settled,
        }
    }
}
