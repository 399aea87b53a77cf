//! The controller's finite-state machine (`ReadCurFSM`, DataSheet `robotState`).

enum_with_unknown! {
    /// The FSM state 0-46 reported by `ReadCurFSM` and the DataSheet's
    /// `robotState`. Values outside 0-46 survive as `Unknown`. Names follow the
    /// vendor's SDKs (including their spellings `Reseting`, `RobotOutofSafeSpace`).
    pub enum FsmState {
        /// 0: not initialised.
        UnInitialize = 0,
        /// 1: initialising.
        Initialize = 1,
        /// 2: disconnected from the electric box control board.
        ElectricBoxDisconnect = 2,
        /// 3: connecting to the electric box.
        ElectricBoxConnecting = 3,
        /// 4: handling an emergency stop.
        EmergencyStopHandling = 4,
        /// 5: emergency stop.
        EmergencyStop = 5,
        /// 6: cutting 48 V power to the arm.
        Blackouting48V = 6,
        /// 7: 48 V power to the arm is off.
        Blackout48V = 7,
        /// 8: switching 48 V power on.
        Electrifying48V = 8,
        /// 9: handling a safety-guard error.
        SafetyGuardErrorHandling = 9,
        /// 10: safety-guard error.
        SafetyGuardError = 10,
        /// 11: handling a safety-guard stop.
        SafetyGuardHandling = 11,
        /// 12: safety guard active.
        SafetyGuard = 12,
        /// 13: de-initialising the controller.
        ControllerDisconnecting = 13,
        /// 14: controller not initialised.
        ControllerDisconnect = 14,
        /// 15: initialising the controller.
        ControllerConnecting = 15,
        /// 16: controller version too old.
        ControllerVersionError = 16,
        /// 17: EtherCAT error.
        EtherCATError = 17,
        /// 18: checking the controller after initialisation.
        ControllerChecking = 18,
        /// 19: resetting the robot.
        Reseting = 19,
        /// 20: robot out of its safe space.
        RobotOutofSafeSpace = 20,
        /// 21: collision stop.
        RobotCollisionStop = 21,
        /// 22: robot error.
        Error = 22,
        /// 23: enabling.
        Enabling = 23,
        /// 24: disabled.
        Disable = 24,
        /// 25: moving.
        Moving = 25,
        /// 26: long jog moving.
        LongJogMoving = 26,
        /// 27: stopping.
        RobotStopping = 27,
        /// 28: disabling.
        Disabling = 28,
        /// 29: opening free drive.
        RobotOpeningFreeDriver = 29,
        /// 30: closing free drive.
        RobotClosingFreeDriver = 30,
        /// 31: free drive.
        FreeDriver = 31,
        /// 32: paused (holding).
        RobotHolding = 32,
        /// 33: standing by, ready for motion.
        StandBy = 33,
        /// 34: script running.
        ScriptRunning = 34,
        /// 35: pausing the script.
        ScriptHoldHandling = 35,
        /// 36: script paused.
        ScriptHolding = 36,
        /// 37: stopping the script.
        ScriptStopping = 37,
        /// 38: script stopped.
        ScriptStopped = 38,
        /// 39: HRApp component disconnected.
        HRAppDisconnected = 39,
        /// 40: HRApp component error.
        HRAppError = 40,
        /// 41: identifying the payload.
        RobotLoadIdentify = 41,
        /// 42: operating the brakes.
        Braking = 42,
        /// 43: temperature too low.
        TemperatureTooLow = 43,
        /// 44: opening force-control free drive.
        FTOpeningFreeDriver = 44,
        /// 45: closing force-control free drive.
        FTClosingFreeDriver = 45,
        /// 46: force-control free drive.
        FTFreeDriver = 46,
    }
}

impl FsmState {
    /// `true` in the states where the robot accepts a new motion command
    /// (`StandBy`) or is executing one (`Moving`, `LongJogMoving`).
    pub fn is_operational(self) -> bool {
        matches!(
            self,
            FsmState::StandBy | FsmState::Moving | FsmState::LongJogMoving
        )
    }
}
