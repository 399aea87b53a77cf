//! How long the controller's slow operations take, and where the robot
//! starts.

use std::time::Duration;

/// How long the controller's slow operations take, in simulated time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timing {
    /// `ConnectToBox`: FSM 3 ElectricBoxConnecting for this long.
    pub box_connect: Duration,
    /// `Electrify`: FSM 8 Electrifying48V.
    pub electrify: Duration,
    /// `BlackOut` / `OSCmd`: FSM 6 Blackouting48V.
    pub blackout: Duration,
    /// `StartMaster`: FSM 15 ControllerConnecting.
    pub start_master: Duration,
    /// `CloseMaster`: FSM 13 ControllerDisconnecting.
    pub close_master: Duration,
    /// `GrpEnable`: FSM 23 Enabling.
    pub enable: Duration,
    /// `GrpDisable`: FSM 28 Disabling.
    pub disable: Duration,
    /// `GrpReset` of an error: FSM 19 Reseting.
    pub reset: Duration,
    /// Opening / closing free drive (FSM 29 / 30, 44 / 45).
    pub free_drive: Duration,
    /// How long `StartScript` / `RunFunc` run (FSM 34).
    pub script: Duration,
    /// Pausing / stopping a script (FSM 35 / 37).
    pub script_transition: Duration,
    /// `EndPushMovePath`: path state 2 (computing) before 3 (ready); also
    /// the `MovePathJ` computation of `EndPushPathPoints` (`stateJ`).
    pub path_compute: Duration,
    /// `MovePathL`: computing before the motion starts (the robot counts as
    /// moving meanwhile; the document says 2-4 s); also the `MovePathL`
    /// computation of `EndPushPathPoints` (`stateL`).
    pub path_l_compute: Duration,
    /// Force control: searching (state 1) before search done (state 2).
    pub force_search: Duration,
    /// `ReadRobotState`'s moving flag follows the motion this much later
    /// (the vendor documents ~50 ms); the FSM state changes at once.
    pub moving_flag_lag: Duration,
    /// The actual position follows the command position this much later;
    /// `nInPos` becomes 1 this long after the command position stops.
    pub actual_lag: Duration,
    /// A long jog (or `MoveJTo`, `MoveLTo`, `MoveAlignToZ`) stops this long
    /// after its start or the last `LongMoveEvent`: the V6 document's
    /// "period not over 200 ms, or the long jog stops" (4.10.18).
    pub long_move_keepalive: Duration,
    /// `LoadIdentify`: the identification runs (FSM 41) this long.
    pub load_identify: Duration,
}

impl Default for Timing {
    fn default() -> Self {
        let ms = Duration::from_millis;
        Timing {
            box_connect: ms(200),
            electrify: ms(500),
            blackout: ms(300),
            start_master: ms(300),
            close_master: ms(200),
            enable: ms(200),
            disable: ms(100),
            reset: ms(100),
            free_drive: ms(100),
            script: ms(3000),
            script_transition: ms(100),
            path_compute: ms(300),
            path_l_compute: ms(2000),
            force_search: ms(500),
            moving_flag_lag: ms(50),
            actual_lag: ms(20),
            long_move_keepalive: ms(200),
            load_identify: ms(5000),
        }
    }
}

impl Timing {
    /// Every operation completes at once and no flag lags (scripts still run
    /// for [`Timing::script`], payload identification for
    /// [`Timing::load_identify`], and a long jog still needs its
    /// `LongMoveEvent`s).
    pub fn instant() -> Timing {
        let z = Duration::ZERO;
        Timing {
            box_connect: z,
            electrify: z,
            blackout: z,
            start_master: z,
            close_master: z,
            enable: z,
            disable: z,
            reset: z,
            free_drive: z,
            script_transition: z,
            path_compute: z,
            path_l_compute: z,
            force_search: z,
            moving_flag_lag: z,
            actual_lag: z,
            ..Timing::default()
        }
    }
}

/// Where the robot is when the simulator starts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Initial {
    /// Box disconnected, 48 V off (FSM 2): the client runs the bring-up.
    #[default]
    PoweredOff,
    /// Brought up and enabled (FSM 33 StandBy).
    StandBy,
}
