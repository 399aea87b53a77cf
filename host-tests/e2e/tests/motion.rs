//! Motion commands end to end (PLC -> gateway -> hans-sim on 127.0.0.1):
//! when Done may rise, what a stop ends, and that stop, pause and continue
//! always get through.

use std::time::{Duration, Instant};

use hans_e2e::{code, gateway_error, GatewayError, Plc, Rig, SRC_ROBOT_FAIL, WAIT};
use hans_gateway::registers as r;
use hans_sim::{Config, Fault, FaultRule, FsmState};

const ENDED: u16 = r::ST_DONE | r::ST_ERROR | r::ST_ABORTED;

/// Waits until the simulator has received `n` more messages named `name`
/// (the gateway's own pace as the clock).
async fn wait_polls(rig: &Rig, name: &str, n: usize) {
    let seen = rig.received(name).len();
    let start = Instant::now();
    while rig.received(name).len() < seen + n {
        assert!(start.elapsed() < WAIT, "{n} more {name} never came");
        tokio::time::sleep(hans_e2e::POLL_PAUSE).await;
    }
}

/// Finding H1: after Pause and Continue the moving flag lags the motion by
/// ~50 ms (the FSM does not); Done rose 2 ms after Continue while the robot
/// still moved. Done must mean the robot has finished.
#[tokio::test]
async fn after_pause_and_continue_done_waits_for_the_end_of_the_motion() {
    let mut rig = Rig::start(Config::ready()).await;
    let target = rig.plc.start_move(0, 60.0, 30.0, 360.0, 1).await;
    let st = Plc::ch_status(0);
    rig.plc
        .wait_reg(st, "active", |v| v & r::ST_ACTIVE != 0)
        .await;
    // Paused once the move is well under way (10 of its 60 degrees).
    let from = rig.sim.state().act_joints[0];
    let start = Instant::now();
    while (rig.sim.state().act_joints[0] - from).abs() < 10.0 {
        assert!(start.elapsed() < WAIT, "the move does not go");
        tokio::time::sleep(hans_e2e::POLL_PAUSE).await;
    }
    let e = rig.plc.run(1, code::PAUSE, &[], 2).await;
    assert!(e.done(), "pause: {e:?}");
    // Held and standing still: the commanded joints the same at two
    // instants (the controller refuses GrpContinue while it brakes: 40014).
    let start = Instant::now();
    let mut before = rig.sim.state();
    loop {
        tokio::time::sleep(hans_e2e::POLL_PAUSE).await;
        let s = rig.sim.state();
        let still = s.time > before.time && s.cmd_joints == before.cmd_joints;
        if s.fsm == FsmState::RobotHolding && still {
            break;
        }
        assert!(start.elapsed() < WAIT, "not held: {:?}", s.fsm);
        before = s;
    }
    // Held: the gateway polls the motion (every 10 ms) and must not call
    // it Done. Three of its polls after the robot stood still.
    wait_polls(&rig, "ReadRobotState", 3).await;
    assert_eq!(
        rig.plc.read1(st).await & (r::ST_BUSY | ENDED),
        r::ST_BUSY,
        "paused: still Busy"
    );
    let e = rig.plc.run(1, code::CONTINUE, &[], 3).await;
    assert!(e.done(), "continue: {e:?}");
    let start = Instant::now();
    let status = loop {
        let v = rig.plc.read1(st).await;
        if v & ENDED != 0 {
            break v;
        }
        assert!(start.elapsed() < WAIT, "the move never ended");
        tokio::time::sleep(Duration::from_millis(2)).await;
    };
    let s = rig.sim.state();
    assert_eq!(status & ENDED, r::ST_DONE, "{status:#x}");
    assert_eq!(
        s.fsm,
        FsmState::StandBy,
        "Done while the robot is in {:?}",
        s.fsm
    );
    assert!(
        (s.act_joints[0] - f64::from(target[0])).abs() < 0.01,
        "Done at J1 = {} (target {})",
        s.act_joints[0],
        target[0]
    );
    rig.stop().await;
}

/// Finding M1: the position registers were up to one poll period old when
/// Done rose. At Done they must show where the robot stopped.
#[tokio::test]
async fn at_done_the_position_registers_are_final() {
    let mut rig = Rig::start(Config::ready()).await;
    let st = Plc::ch_status(0);
    for (seq, delta) in [(1u16, 25.0f32), (2, -25.0), (3, 25.0)] {
        rig.plc.start_move(0, delta, 60.0, 360.0, seq).await;
        let e = rig.plc.wait_end(st).await;
        assert!(e.done(), "{e:?}");
        // Read at once: no polling round may have run since Done.
        let joints = rig.plc.joints().await;
        let pose = rig.plc.pose().await;
        let s = rig.sim.state();
        for i in 0..6 {
            assert!(
                (f64::from(joints[i]) - s.act_joints[i]).abs() < 0.01,
                "move {seq}: J{} = {} at Done, robot at {}",
                i + 1,
                joints[i],
                s.act_joints[i]
            );
            assert!(
                (f64::from(pose[i]) - s.act_pose[i]).abs() < 0.01,
                "move {seq}: pose[{i}] = {} at Done, robot at {}",
                pose[i],
                s.act_pose[i]
            );
        }
        rig.plc.write(r::channel_base(0), &[0]).await;
    }
    rig.stop().await;
}

/// Finding H2: a Stop must end the running motion and every motion waiting
/// in the gateway's queue in CommandAborted, and none of them may be sent;
/// a waiting non-motion command still goes out.
#[tokio::test]
async fn stop_aborts_the_waiting_motions_and_none_is_sent() {
    let mut rig = Rig::start(Config::ready()).await;
    rig.plc.start_move(0, 90.0, 10.0, 100.0, 1).await;
    let st = Plc::ch_status(0);
    rig.plc
        .wait_reg(st, "active", |v| v & r::ST_ACTIVE != 0)
        .await;
    // Entry 0 (a motion) waits behind the running one; entry 1 behind it.
    let bits = rig
        .plc
        .fire_triggers(&[(0, "MoveRelJ,0,1,1,5,;"), (1, "SetBoxDO,5,1,;")])
        .await;
    assert_eq!(rig.plc.read1(r::TRIG_BUSY).await, bits, "both waiting");
    let e = rig.plc.run(1, code::STOP, &[], 2).await;
    assert!(e.done(), "stop: {e:?}");
    let e = rig.plc.wait_end(st).await;
    assert_eq!(e.status & ENDED, r::ST_ABORTED, "running move: {e:?}");
    rig.plc
        .wait_reg(r::TRIG_BUSY, "triggers ended", |v| v == 0)
        .await;
    assert_eq!(
        rig.plc.read1(r::TRIG_ABORTED).await,
        1 << 0,
        "waiting motion"
    );
    assert_eq!(
        rig.plc.read1(r::TRIG_DONE).await,
        1 << 1,
        "waiting SetBoxDO"
    );
    // Jobs go in order: an aborted motion still queued would go before
    // this one.
    assert!(rig
        .plc
        .run(1, code::SET_BOX_DO, &[2.0, 1.0], 3)
        .await
        .done());
    assert!(
        rig.received("MoveRelJ").is_empty(),
        "an aborted motion was sent: {:?}",
        rig.commands_received()
    );
    assert_eq!(rig.received("WayPoint").len(), 1);
    assert!(rig.sim.io().do_[5], "the SetBoxDO went out");
    rig.stop().await;
}

/// Finding H2, the watchdog's stop: the motions waiting behind the stopped
/// one end in CommandAborted and are not sent.
#[tokio::test]
async fn the_watchdog_stop_aborts_the_waiting_motions() {
    let mut rig = Rig::start(Config::ready()).await;
    rig.plc.configure(&[(r::CONFIG_WATCHDOG_MS, 1000)]).await;
    rig.plc.start_move(0, 90.0, 10.0, 100.0, 1).await;
    let st = Plc::ch_status(0);
    rig.plc
        .wait_reg(st, "active", |v| v & r::ST_ACTIVE != 0)
        .await;
    rig.plc.fire_triggers(&[(3, "MoveRelJ,0,1,1,5,;")]).await;
    let e = rig.plc.wait_end(st).await;
    assert_eq!(
        (e.error_id, e.error_source),
        gateway_error(GatewayError::Watchdog),
        "{e:?}"
    );
    rig.plc
        .wait_reg(r::TRIG_BUSY, "trigger ended", |v| v == 0)
        .await;
    assert_eq!(rig.plc.read1(r::TRIG_ABORTED).await, 1 << 3);
    // Jobs go in order: an aborted motion still queued would go before
    // this one.
    assert!(rig
        .plc
        .run(1, code::SET_BOX_DO, &[2.0, 1.0], 3)
        .await
        .done());
    assert!(
        rig.received("MoveRelJ").is_empty(),
        "{:?}",
        rig.commands_received()
    );
    assert_eq!(rig.received("GrpStop").len(), 1);
    rig.stop().await;
}

/// Finding H3: with the queue full, Stop and Pause were refused (39600);
/// and a Stop waited behind every queued command. They must always get
/// through, ahead of the waiting commands.
#[tokio::test]
async fn stop_and_pause_get_through_a_full_queue_first() {
    let mut rig = Rig::start(Config::ready()).await;
    rig.sim.faults().add(
        FaultRule::new(Fault::Delay(Duration::from_millis(200)))
            .only("SetBoxDO")
            .times(16),
    );
    let text = |i: usize| format!("SetBoxDO,{},1,;", i % 8);
    let entries: Vec<(usize, String)> = (0..8).map(|i| (i, text(i))).collect();
    let refs: Vec<(usize, &str)> = entries.iter().map(|(i, t)| (*i, t.as_str())).collect();
    rig.plc.fire_triggers(&refs).await;
    // One is with the robot, seven wait; one more fills the queue.
    rig.plc
        .wait_reg(r::STATUS_QUEUE_USED, "seven waiting", |v| v == 7)
        .await;
    rig.plc
        .write(
            r::trigger_text(8),
            &hans_e2e::text_words(&text(8), usize::from(r::TRIG_TEXT_REGS)),
        )
        .await;
    rig.plc.write(r::TRIG_BITS, &[0x1FF]).await;
    assert_eq!(rig.plc.read1(r::STATUS_QUEUE_USED).await, 8, "queue full");
    assert_eq!(rig.plc.read1(r::TRIG_ERROR).await, 0);
    // Stop on channel 1 and Pause on channel 0, both while it is full.
    rig.plc.command(1, code::STOP, &[], 1).await;
    rig.plc.command(0, code::PAUSE, &[], 2).await;
    let stop = rig.plc.wait_end(Plc::ch_status(1)).await;
    assert!(stop.done(), "stop: {stop:?}");
    let pause = rig.plc.wait_end(Plc::ch_status(0)).await;
    assert_ne!(
        pause.error_id,
        GatewayError::QueueFull.code(),
        "pause refused: {pause:?}"
    );
    // Nothing moves, so the robot refuses the pause itself (its own code).
    assert_eq!(pause.error_source, SRC_ROBOT_FAIL, "{pause:?}");
    let sent = rig.commands_received();
    let at = |name: &str| sent.iter().position(|m| m.starts_with(name));
    assert!(
        at("GrpStop").is_some_and(|i| i <= 2) && at("GrpInterrupt").is_some_and(|i| i <= 3),
        "stop and pause did not pass the queue: {sent:?}"
    );
    rig.plc
        .wait_reg(r::TRIG_BUSY, "queue drained", |v| v == 0)
        .await;
    assert_eq!(rig.plc.read1(r::TRIG_DONE).await, 0x1FF);
    rig.stop().await;
}
