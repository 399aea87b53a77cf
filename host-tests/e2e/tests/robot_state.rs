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
    let flags = rig.plc.read1(r::STATUS_FLAGS).await;
    assert_eq!(
        flags & (r::FLAG_ENABLED | r::FLAG_POWERED | r::FLAG_VALID),
        r::FLAG_ENABLED | r::FLAG_POWERED | r::FLAG_VALID,
        "ROBOT_FLAGS agree with FSM_STATE at Done: {flags:#x}"
    );
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

/// Finding M2: after the robot link was lost, FSM_STATE and ROBOT_FLAGS
/// kept their old values (only the valid bit cleared). Every robot value
/// must read "unknown" while there is no link.
#[tokio::test]
async fn without_a_link_the_robot_status_reads_unknown() {
    let Rig { sim, gw, mut plc } = Rig::start(Config::ready()).await;
    plc.wait_status().await;
    plc.wait_reg(r::STATUS_FSM, "FSM StandBy", |v| v == 33)
        .await;
    plc.wait_reg(r::STATUS_IO_VALID, "I/O read", |v| v == 0x3F)
        .await;
    sim.shutdown().await;
    plc.wait_reg(r::STATUS_LINK_STATE, "link down", |v| v != 3)
        .await;
    let s = plc.read(0, 50).await;
    assert_eq!(s[usize::from(r::STATUS_FSM)], 0xFFFF, "FSM_STATE");
    assert_eq!(s[usize::from(r::STATUS_FLAGS)], 0, "ROBOT_FLAGS");
    assert_eq!(hans_e2e::i32_of(&s[8..10]), 0, "ROBOT_ERROR_CODE");
    assert_eq!(s[usize::from(r::STATUS_AGE_MS)], 0xFFFF, "STATUS_AGE_MS");
    for i in 0..12 {
        let a = usize::from(r::STATUS_JOINTS) + 2 * i;
        assert!(hans_e2e::f32_of(&s[a..]).is_nan(), "position value {i}");
    }
    assert!(hans_e2e::f32_of(&s[usize::from(r::STATUS_OVERRIDE)..]).is_nan());
    assert_eq!(
        &s[usize::from(r::STATUS_BOX_DI)..=usize::from(r::STATUS_IO_VALID)],
        [0; 7],
        "I/O"
    );
    drop(plc);
    gw.stop();
}

/// Finding (error codes): a refused connect showed 39500 ("not
/// connected", a command code) in LINK_LAST_ERROR; REGISTERS.md names
/// 39504 for it.
#[tokio::test]
async fn a_refused_connect_shows_39504_in_link_last_error() {
    use std::net::{Ipv4Addr, SocketAddrV4};

    use hans_gateway_linux::{HostOptions, RunningGateway};

    // Nothing listens on port 1 of the loopback: every connect is refused.
    let gw = RunningGateway::start(HostOptions::new(
        SocketAddrV4::new(Ipv4Addr::LOCALHOST, 0),
        SocketAddrV4::new(Ipv4Addr::LOCALHOST, 1),
    ))
    .expect("start the gateway");
    let mut plc = hans_e2e::Plc::connect(gw.modbus_addr()).await;
    let e = plc
        .wait_reg(r::STATUS_LINK_LAST_ERROR, "a link error", |v| v != 0)
        .await;
    assert_eq!(i32::from(e), hans_e2e::GatewayError::ConnectFailed.code());
    // A command fired meanwhile is refused with 39500 (not sent).
    let ended = plc.run(0, code::RESET, &[], 1).await;
    assert_eq!(
        (ended.error_id, ended.error_source),
        hans_e2e::gateway_error(hans_e2e::GatewayError::NotConnected)
    );
    drop(plc);
    gw.stop();
}
