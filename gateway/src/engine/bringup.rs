//! What the controller's FSM state (`ReadCurFSM`) tells the engine.
//!
//! The FSM changes at once when a motion starts, pauses or ends, while
//! `ReadRobotState`'s moving flag lags by about 50 ms (NOTES.md): a motion
//! is never Done while the FSM says it is under way ([`motion_under_way`]).
//!
//! The bring-up steps (`ConnectToBox`, `Electrify`, `StartMaster`,
//! `GrpEnable`) reply `OK` when the controller accepts them, long before
//! the box is connected, 48 V is on or the robot is enabled. A job goes on
//! to its next message, or is Done, only once the FSM shows that the step
//! has been reached ([`StepWait`]), polled every [`STATE_POLL`], for at
//! most [`STATE_TIMEOUT`] per step.

use embassy_time::Duration;
use hans_codec::{CommandId, FsmState};

use crate::error::GatewayError;

/// Period of `ReadCurFSM` while a bring-up step waits for its state.
pub(crate) const STATE_POLL: Duration = Duration::from_millis(50);
/// Longest wait for the state of one bring-up step; then the command ends
/// in Error [`GatewayError::StateNotReached`].
pub(crate) const STATE_TIMEOUT: Duration = Duration::from_secs(30);

/// `true` while the FSM says a motion is under way: 25 Moving,
/// 26 LongJogMoving, 27 RobotStopping, 32 RobotHolding (paused).
pub(crate) fn motion_under_way(state: FsmState) -> bool {
    matches!(
        state,
        FsmState::Moving
            | FsmState::LongJogMoving
            | FsmState::RobotStopping
            | FsmState::RobotHolding
    )
}

/// `true` in the fault states: 4-5 emergency stop, 9-12 safety guard,
/// 16-17 controller version / EtherCAT error, 20-22 out of the safe space,
/// collision stop, error. A motion that meets one has not finished: the
/// next `ReadRobotState` tells how it failed.
pub(crate) fn fault_state(state: FsmState) -> bool {
    matches!(i32::from(state), 4 | 5 | 9..=12 | 16 | 17 | 20..=22)
}

/// The state a bring-up step leads to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub(crate) enum StepWait {
    /// `ConnectToBox`: the electric box is connected (the FSM has left
    /// 0-3: not initialised, box disconnected or connecting).
    BoxConnected,
    /// `Electrify`: 48 V is on (the FSM has also left 6-8: switching off,
    /// off, switching on).
    Powered,
    /// `StartMaster`: the controller is connected (the FSM has also left
    /// 13-15 and 18: disconnecting, disconnected, connecting, checking).
    /// Typically 24 Disable next, or 33 StandBy if already enabled.
    MasterStarted,
    /// `GrpEnable`: the robot is enabled: 33 StandBy or another state of an
    /// enabled robot (25-27, 29-38, 41, 44-46).
    Enabled,
}

/// What the FSM says about a step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub(crate) enum Verdict {
    /// Not there yet.
    Wait,
    /// The step's state is reached.
    Reached,
    /// A fault state: the step cannot complete.
    Failed(GatewayError),
}

impl StepWait {
    /// The wait that follows `id`'s `OK`, for the bring-up steps.
    pub(crate) fn after(id: CommandId) -> Option<StepWait> {
        match id {
            CommandId::ConnectToBox => Some(StepWait::BoxConnected),
            CommandId::Electrify => Some(StepWait::Powered),
            CommandId::StartMaster => Some(StepWait::MasterStarted),
            CommandId::GrpEnable => Some(StepWait::Enabled),
            _ => None,
        }
    }

    /// A short text for logs.
    pub(crate) const fn as_str(self) -> &'static str {
        match self {
            StepWait::BoxConnected => "box connected",
            StepWait::Powered => "48 V on",
            StepWait::MasterStarted => "controller connected",
            StepWait::Enabled => "robot enabled",
        }
    }

    /// Judges FSM state `s`.
    pub(crate) fn verdict(self, s: FsmState) -> Verdict {
        use FsmState as F;
        let n = u16::try_from(i32::from(s)).unwrap_or(u16::MAX);
        // Faults first: no step completes through them.
        match s {
            F::EmergencyStopHandling | F::EmergencyStop => {
                return Verdict::Failed(GatewayError::EmergencyStop)
            }
            F::ControllerVersionError | F::EtherCATError => {
                return Verdict::Failed(GatewayError::StateNotReached)
            }
            _ => {}
        }
        let box_pending = n <= 3;
        let power_pending = box_pending || (6..=8).contains(&n);
        let master_pending = power_pending || (13..=15).contains(&n) || n == 18;
        let reached = match self {
            StepWait::BoxConnected => !box_pending,
            StepWait::Powered => !power_pending,
            StepWait::MasterStarted => !master_pending,
            StepWait::Enabled => matches!(n, 25..=27 | 29..=38 | 41 | 44..=46),
        };
        if reached {
            return Verdict::Reached;
        }
        if self == StepWait::Enabled {
            match s {
                F::SafetyGuardErrorHandling
                | F::SafetyGuardError
                | F::SafetyGuardHandling
                | F::SafetyGuard => return Verdict::Failed(GatewayError::SafetyGuard),
                F::Error | F::RobotOutofSafeSpace | F::RobotCollisionStop => {
                    return Verdict::Failed(GatewayError::StateNotReached)
                }
                _ => {}
            }
        }
        Verdict::Wait
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(w: StepWait, n: i32) -> Verdict {
        w.verdict(FsmState::from(n))
    }

    #[test]
    fn the_motion_states() {
        let under_way: Vec<i32> = (0..=47)
            .filter(|n| motion_under_way(FsmState::from(*n)))
            .collect();
        assert_eq!(under_way, [25, 26, 27, 32]);
    }

    #[test]
    fn each_bring_up_step_waits_for_its_state() {
        use StepWait::*;
        use Verdict::*;
        // The simulator's (and a controller's) path from power off.
        assert_eq!(v(BoxConnected, 2), Wait);
        assert_eq!(v(BoxConnected, 3), Wait);
        assert_eq!(v(BoxConnected, 7), Reached);
        assert_eq!(v(Powered, 7), Wait);
        assert_eq!(v(Powered, 8), Wait);
        assert_eq!(v(Powered, 14), Reached);
        assert_eq!(v(MasterStarted, 14), Wait);
        assert_eq!(v(MasterStarted, 15), Wait);
        assert_eq!(v(MasterStarted, 18), Wait);
        assert_eq!(v(MasterStarted, 24), Reached);
        assert_eq!(v(Enabled, 24), Wait);
        assert_eq!(v(Enabled, 23), Wait);
        assert_eq!(v(Enabled, 33), Reached);
        // Already up: every step is reached at once.
        for w in [BoxConnected, Powered, MasterStarted, Enabled] {
            assert_eq!(v(w, 33), Reached, "{w:?}");
        }
        // Faults.
        assert_eq!(v(Powered, 5), Failed(GatewayError::EmergencyStop));
        assert_eq!(v(MasterStarted, 17), Failed(GatewayError::StateNotReached));
        assert_eq!(v(Enabled, 22), Failed(GatewayError::StateNotReached));
        assert_eq!(v(Enabled, 12), Failed(GatewayError::SafetyGuard));
        // An unknown state is waited out (until the timeout).
        assert_eq!(v(Enabled, 99), Wait);
        assert_eq!(StepWait::after(CommandId::GrpEnable), Some(Enabled));
        assert_eq!(StepWait::after(CommandId::GrpDisable), None);
    }
}
