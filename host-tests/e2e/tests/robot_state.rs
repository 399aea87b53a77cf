//! The robot's state as the PLC sees it (PLC -> gateway -> hans-sim on
//! 127.0.0.1): what Done of the bring-up commands guarantees, and what the
//! status registers say when the robot link is gone.

use hans_e2e::{code, Rig};
use hans_gateway::registers as r;
use hans_sim::{Config, FsmState};

/// Finding M3: Power on was Done 11 ms after Execute with the FSM still 2
/// (the three steps went out back to back). Done of Power on must mean the
/// controller is up (FSM 24 Disable from power off), Done of Enable that
/// the robot is enabled (FSM 33 StandBy).
#[tokio::test]
async fn power_on_and_enable_are_done_when_the_robot_is_there() {
    let mut rig = Rig::start(Config::default()).await;
    assert_eq!(rig.sim.fsm(), FsmState::ElectricBoxDisconnect);
    let e = rig.plc.run(0, code::POWER_ON, &[], 1).await;
    assert!(e.done(), "power on: {e:?}");
    assert_eq!(
        rig.sim.fsm(),
        FsmState::Disable,
        "robot at Done of Power on"
    );
    assert_eq!(rig.plc.read1(r::STATUS_FSM).await, 24, "FSM_STATE at Done");
    let e = rig.plc.run(0, code::ENABLE, &[], 2).await;
    assert!(e.done(), "enable: {e:?}");
    assert_eq!(rig.sim.fsm(), FsmState::StandBy, "robot at Done of Enable");
    assert_eq!(rig.plc.read1(r::STATUS_FSM).await, 33, "FSM_STATE at Done");
    // Each step waited for its state: the next one went out after it.
    assert_eq!(
        rig.commands_received(),
        [
            "ConnectToBox,;",
            "Electrify,;",
            "StartMaster,;",
            "GrpEnable,0,;"
        ]
    );
    rig.stop().await;
}
