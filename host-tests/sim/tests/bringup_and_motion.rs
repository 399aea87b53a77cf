//! The bring-up sequence and a move with its timing and flags, on the
//! simulator's manual clock (fully deterministic).

mod support;

use hans_sim::{Config, FsmState};
use support::{close, manual, ms, Client};

#[tokio::test]
async fn bring_up_steps_through_the_fsm_to_standby() {
    let sim = manual(Config::default()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    assert_eq!(c.fsm().await, 2, "starts with the box disconnected");
    // Motion is refused before bring-up.
    assert_eq!(c.fail("GrpEnable,0,;").await, 20018);
    c.ok("ConnectToBox,;").await;
    assert_eq!(c.fsm().await, 3);
    sim.advance(ms(200));
    assert_eq!(c.fsm().await, 7, "box connected, 48 V off");
    c.ok("Electrify,;").await;
    assert_eq!(c.fsm().await, 8);
    sim.advance(ms(500));
    assert_eq!(c.fsm().await, 14);
    c.ok("StartMaster,;").await;
    assert_eq!(c.fsm().await, 15);
    sim.advance(ms(300));
    assert_eq!(c.fsm().await, 24);
    let s = c.state().await;
    assert_eq!(
        (s[1], s[9], s[10]),
        (0, 1, 1),
        "disabled, powered, box connected"
    );
    c.ok("GrpEnable,0,;").await;
    assert_eq!(c.fsm().await, 23);
    sim.advance(ms(200));
    assert_eq!(c.fsm().await, 33);
    assert_eq!(sim.fsm(), FsmState::StandBy);
    let s = c.state().await;
    assert_eq!(s[1], 1, "enabled");
    sim.shutdown().await;
}

#[tokio::test]
async fn bring_up_sent_back_to_back_is_chained() {
    let sim = manual(Config::default()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    for m in [
        "ConnectToBox,0,;",
        "Electrify,;",
        "StartMaster,;",
        "GrpPowerOn,0,;",
    ] {
        c.ok(m).await;
    }
    assert_eq!(c.fsm().await, 3);
    sim.advance(ms(200 + 500 + 300 + 200));
    assert_eq!(c.fsm().await, 33);
    sim.shutdown().await;
}

#[tokio::test]
async fn a_joint_move_takes_its_profile_time_with_the_documented_flags() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    assert_eq!(c.fsm().await, 33);
    // J1 0 -> 90 at 50 °/s, 100 °/s²: 0.5 s up, 1.3 s cruise, 0.5 s down.
    c.ok("WayPoint,0,0,0,0,0,0,0,90,0,90,0,90,0,TCP,Base,50,100,0,0,1,0,0,0,wp7,;")
        .await;
    assert_eq!(c.fsm().await, 25, "FSM changes at once");
    let s = c.state().await;
    assert_eq!(
        (s[0], s[11], s[12]),
        (0, 0, 0),
        "moving flag lags; not done, not in position"
    );
    assert_eq!(c.values("ReadCurWayPointID,0,;").await, ["wp7"]);
    sim.advance(ms(60));
    assert_eq!(c.state().await[0], 1, "moving flag after ~50 ms");
    sim.advance(ms(1440)); // t = 1.5 s: 0.5 s accelerating + 1.0 s cruising
    let cmd = c.numbers("ReadCmdPos,0,;").await;
    assert!((cmd[0] - 62.5).abs() < 1e-3, "J1 at t=1.5 s: {}", cmd[0]);
    let act = c.numbers("ReadActPos,0,;").await;
    assert!(act[0] < cmd[0], "the actual position lags the command");
    let vel = c.numbers("ReadCmdJointVel,0,;").await;
    assert!((vel[0] - 50.0).abs() < 0.1, "cruise speed {}", vel[0]);
    sim.advance(ms(799)); // t = 2.299 s
    assert_eq!(c.fsm().await, 25);
    sim.advance(ms(2)); // t = 2.301 s: command position arrived
    assert_eq!(c.fsm().await, 33);
    let s = c.state().await;
    assert_eq!(
        (s[0], s[11], s[12]),
        (1, 1, 0),
        "still flagged moving, done, not yet in position"
    );
    sim.advance(ms(20));
    assert_eq!(c.state().await[12], 1, "in position 20 ms later");
    sim.advance(ms(30));
    assert_eq!(
        c.state().await[0],
        0,
        "moving flag clears ~50 ms after the end"
    );
    let act = c.numbers("ReadActPos,0,;").await;
    assert!(
        close(&act[..6], &[90.0, 0.0, 90.0, 0.0, 90.0, 0.0], 1e-9),
        "{act:?}"
    );
    // The pose of those joints: the arm turned 90° about the base.
    assert!(close(&act[6..9], &[0.0, 420.0, 445.0], 1e-3), "{act:?}");
    sim.shutdown().await;
}

#[tokio::test]
async fn override_scales_the_move() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    c.ok("SetOverride,0,0.5,;").await;
    // 10° at 50 °/s, 100 °/s² scaled to 25 °/s, 50 °/s²: 0.5 s + 0.15 s + 0.5 s.
    c.ok("MoveRelJ,0,0,1,10,;").await; // jog speed 30 °/s, 90 °/s² -> 15, 45
                                       // 10° with v=15, a=45: accel 1/3 s (2.5°), cruise 5°/15 = 1/3 s, decel 1/3 s.
    sim.advance(ms(990));
    assert_eq!(c.fsm().await, 25);
    sim.advance(ms(20));
    assert_eq!(c.fsm().await, 33);
    let q = c.numbers("ReadCmdPos,0,;").await;
    assert!((q[0] - 10.0).abs() < 1e-9);
    // Refused while moving, as the document says.
    c.ok("MoveRelJ,0,0,0,10,;").await;
    assert_eq!(c.fail("SetOverride,0,1,;").await, 20018);
    sim.shutdown().await;
}

/// The README's "`nInPos` 1 at t0+D+20 ms", taken literally: the manual clock
/// advanced to exactly that instant must show the flag, although the
/// simulator's event time is a sum of `f64` durations.
#[tokio::test]
async fn in_position_is_set_exactly_at_the_documented_instant() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    // Starting at t0 = 100 ms, t0 + D + 20 ms in f64 lands one ulp below the
    // simulator's sum of the same durations.
    sim.advance(ms(100));
    // D = 2.3 s (see the move test above).
    c.ok("WayPoint,0,0,0,0,0,0,0,90,0,90,0,90,0,TCP,Base,50,100,0,0,1,0,0,0,wp8,;")
        .await;
    sim.advance(ms(2300 + 19));
    assert_eq!(c.state().await[12], 0, "not in position 1 ms early");
    sim.advance(ms(1));
    assert_eq!(c.state().await[12], 1, "in position at t0+D+20 ms");
    sim.shutdown().await;
}
