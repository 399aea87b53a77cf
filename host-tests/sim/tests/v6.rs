//! The V6 document's commands and the protocol levels, over TCP on the
//! manual clock: refusals at each level, jogging (start, hold, release,
//! keep-alive timeout) seen through every state reader, hold-to-move, the
//! new path commands, error texts, payload and override, the fast port.

mod support;

use hans_codec::datasheet::{DataSheet, Deframer};
use hans_sim::{Config, FsmState, ProtocolLevel, Sim};
use support::{close, manual, ms, Client, WAIT};
use tokio::io::AsyncReadExt;
use tokio::net::TcpStream;

/// The next packet of the 20 Hz DataSheet port.
async fn next_sheet(sim: &Sim) -> DataSheet {
    let mut s = TcpStream::connect(sim.datasheet_addrs()[0]).await.unwrap();
    let mut deframer: Box<Deframer<65536>> = Box::default();
    let mut buf = vec![0u8; 16384];
    let deadline = tokio::time::Instant::now() + WAIT;
    loop {
        let n = tokio::time::timeout_at(deadline, s.read(&mut buf))
            .await
            .expect("a packet within the bound")
            .unwrap();
        assert!(n > 0, "stream closed");
        let mut sheet = None;
        deframer.feed(&buf[..n], |item| {
            sheet = sheet.take().or(DataSheet::parse(item.unwrap()).ok());
        });
        if let Some(sheet) = sheet {
            return sheet;
        }
    }
}

fn v5() -> Config {
    Config {
        protocol: ProtocolLevel::V5,
        ..Config::ready()
    }
}

/// `ReadCmdPos` joints.
async fn joints(c: &mut Client) -> Vec<f64> {
    c.numbers("ReadCmdPos,0,;").await[..6].to_vec()
}

/// `ReadActPos` pose (X..Rz).
async fn pose(c: &mut Client) -> Vec<f64> {
    c.numbers("ReadActPos,0,;").await[6..12].to_vec()
}

#[tokio::test]
async fn at_v5_the_v6_commands_are_unknown_as_on_an_old_controller() {
    let sim = manual(v5()).await;
    assert_eq!(sim.protocol(), ProtocolLevel::V5);
    assert_eq!(sim.fast_addr(), None, "no fast port before HR6.5.1");
    let mut c = Client::connect(sim.command_addr()).await;
    for m in [
        "LongJogJ,0,1,1,1,;",
        "LongMoveEvent,0,;",
        "ShortJogL,0,1,1,;",
        "GetErrorCodeStr,20018,;",
        "ReadFastCmdPort,;",
        "InitPath,0,0,ccc,0.5,20,;",
        "MovePathJ,0,ccc,;",
        "ReadOverride,0,;",
        "ReadPayload,0,;",
        // Even with fields the codec cannot read: the name is unknown.
        "LongJogJ,0,x,;",
    ] {
        let code = if m.starts_with("ReadOverride") {
            // The revision table gives ReadOverride to every controller.
            0
        } else {
            20005
        };
        let r = c.call(m).await;
        let name = m.split(',').next().unwrap();
        if code == 0 {
            assert!(r.starts_with(&format!("{name},OK,")), "{m} -> {r}");
        } else {
            assert_eq!(r, format!("{name},Fail,20005,;"), "{m}");
        }
    }
    assert_eq!(sim.fsm(), FsmState::StandBy, "nothing moved");
    // HR-TCP's forms of the replies the V6 document changed.
    assert_eq!(
        c.call("ReadBoxInfo,0,;").await,
        "ReadBoxInfo,OK,1,1,48.000,1.200,0,0,;"
    );
    c.ok("SetBoxAO,1,8.8,2,;").await;
    assert_eq!(c.values("ReadBoxAO,0,1,;").await, ["0.000", "8.800"]);
    assert_eq!(c.fail("SetPayload,0,1,0,0,0,1,;").await, 20007, "bUpdateDB");
    c.ok("SetPayload,0,1,0,0,0,;").await;
    // HR-TCP's own commands work.
    c.ok("MoveJ,0,0,0,0,0,0,0,10,0,90,0,90,0,TCP,Base,50,100,0,1,0,0,0,mj,;")
        .await;
    sim.shutdown().await;
}

#[tokio::test]
async fn at_v6_the_removed_commands_are_unknown() {
    let sim = manual(Config::ready()).await;
    assert_eq!(sim.protocol(), ProtocolLevel::V6);
    let mut c = Client::connect(sim.command_addr()).await;
    for m in [
        "MoveJ,0,0,0,0,0,0,0,10,0,90,0,90,0,TCP,Base,50,100,0,1,0,0,0,mj,;",
        "MoveL,0,420,10,445,180,0,180,0,0,90,0,90,0,TCP,Base,50,100,0,0,0,0,ml,;",
        "StartPushMovePath,0,P1,0.5,2,;",
        "InitMovePathL,0,L1,100,2500,1000000,Base,TCP,;",
    ] {
        let name = m.split(',').next().unwrap();
        assert_eq!(c.call(m).await, format!("{name},Fail,20005,;"), "{m}");
    }
    assert_eq!(sim.fsm(), FsmState::StandBy, "nothing moved");
    // The same move by the commands that stay.
    c.ok("WayPoint,0,0,0,0,0,0,0,10,0,90,0,90,0,TCP,Base,50,100,0,0,1,0,0,0,w,;")
        .await;
    assert_eq!(sim.fsm(), FsmState::Moving);
    // A controller between the two: HR6.4.8 still has HR-TCP's paths, and
    // has velocity control but not ReadFastCmdPort (HR6.5.1).
    let mid = manual(Config {
        protocol: ProtocolLevel::parse("HR6.4.8").unwrap(),
        ..Config::ready()
    })
    .await;
    assert_eq!(mid.fast_addr(), None);
    let mut m = Client::connect(mid.command_addr()).await;
    m.ok("StartPushMovePath,0,P1,0.5,2,;").await;
    assert_eq!(m.fail("ReadFastCmdPort,;").await, 20005);
    assert_eq!(
        m.fail("MoveJ,0,0,0,0,0,0,0,10,0,90,0,90,0,TCP,Base,50,100,0,1,0,0,0,mj,;")
            .await,
        20005
    );
    sim.shutdown().await;
    mid.shutdown().await;
}

#[tokio::test]
async fn the_robot_id_is_checked_once_for_every_command() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    for m in [
        "ReadCurFSM,1,;",
        "GrpStop,2,;",
        "LongJogJ,1,0,1,1,;",
        "ReadPathState,3,x,;",
        "SetOverride,5,0.5,;",
    ] {
        assert_eq!(c.fail(m).await, 20006, "{m}");
    }
    assert_eq!(c.fail("ReadCurFSM,6,;").await, 20006, "outside 0-5");
    assert_eq!(sim.fsm(), FsmState::StandBy);
    sim.shutdown().await;
}

#[tokio::test]
async fn a_short_jog_steps_two_degrees_or_millimetres() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    // J2 positive: 2° in 0.4 s (a triangle up to 10 °/s).
    c.ok("ShortJogJ,0,1,1,;").await;
    assert_eq!(c.fsm().await, 25, "an ordinary move");
    assert_eq!(c.fail("ShortJogJ,0,1,1,;").await, 20018, "one at a time");
    sim.advance(ms(200));
    let mid = joints(&mut c).await;
    assert!((mid[1] - 1.0).abs() < 1e-6, "halfway at the peak: {mid:?}");
    let v = c.numbers("ReadCmdJointVel,0,;").await;
    assert!((v[1] - 10.0).abs() < 0.1, "10 °/s at the peak: {v:?}");
    sim.advance(ms(201));
    assert_eq!(c.fsm().await, 33);
    assert!(close(
        &joints(&mut c).await,
        &[0.0, 2.0, 90.0, 0.0, 90.0, 0.0],
        1e-9
    ));
    // Y positive in the user frame: 2 mm.
    let before = pose(&mut c).await;
    c.ok("ShortJogL,0,1,1,;").await;
    sim.advance(ms(1000));
    let after = pose(&mut c).await;
    assert!(
        (after[1] - before[1] - 2.0).abs() < 1e-3,
        "{before:?} -> {after:?}"
    );
    assert!((after[0] - before[0]).abs() < 1e-3 && (after[2] - before[2]).abs() < 1e-3);
    // Rz negative: 2° about the TCP, which stays where it is.
    c.ok("ShortJogL,0,5,0,;").await;
    sim.advance(ms(1000));
    let turned = pose(&mut c).await;
    assert!(close(&turned[..3], &after[..3], 1e-3), "{turned:?}");
    let d = (turned[5] - after[5] + 540.0).rem_euclid(360.0) - 180.0;
    assert!((d + 2.0).abs() < 1e-3, "Rz {} -> {}", after[5], turned[5]);
    // Not while disabled.
    c.ok("GrpDisable,0,;").await;
    sim.advance(ms(200));
    assert_eq!(c.fail("ShortJogJ,0,1,1,;").await, 20018);
    sim.shutdown().await;
}

/// A long jog of J1: runs while LongMoveEvent comes, every reader shows it,
/// and it stops on release.
#[tokio::test]
async fn a_long_jog_runs_while_held_and_stops_on_release() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    c.ok("LongJogJ,0,0,1,1,;").await;
    assert_eq!(c.fsm().await, 26, "LongJogMoving");
    assert_eq!(sim.fsm(), FsmState::LongJogMoving);
    assert_eq!(c.state().await[0], 0, "the moving flag lags");
    let mut last = 0.0;
    // Held for 2 s: an event every 150 ms.
    for _ in 0..13 {
        sim.advance(ms(150));
        c.ok("LongMoveEvent,0,;").await;
        let q = joints(&mut c).await[0];
        assert!(q > last, "J1 keeps moving: {q} after {last}");
        last = q;
    }
    // t = 1.95 s: 0.2 s ramp (1°) then 10 °/s.
    assert!((last - (1.0 + 10.0 * 1.75)).abs() < 1e-6, "J1 {last}");
    let s = c.state().await;
    assert_eq!((s[0], s[11]), (1, 0), "moving, not done");
    let act = c.numbers("ReadActPos,0,;").await;
    assert!(act[0] > 17.0 && act[0] < last, "actual lags: {}", act[0]);
    assert!(
        act[7] > 0.0,
        "the pose turns with J1 (Y of the TCP): {act:?}"
    );
    let snap = sim.state();
    assert_eq!(snap.fsm, FsmState::LongJogMoving);
    assert!(snap.flags.moving && (snap.act_joint_vel[0] - 10.0).abs() < 0.1);
    // The DataSheet the port pushes says the same.
    let sheet = next_sheet(&sim).await;
    assert_eq!(sheet.state.robot_state, Some(FsmState::LongJogMoving));
    assert_eq!(sheet.state.moving, Some(true));
    let j1 = sheet.pos_and_vel.position.unwrap().joints[0].to_f64();
    assert!((j1 - act[0]).abs() < 1e-3, "{j1} vs {}", act[0]);
    // Release: brakes at once (0.2 s, 1° more), then StandBy.
    c.ok("LongJogJ,0,0,1,0,;").await;
    assert_eq!(c.fsm().await, 27, "stopping");
    assert_eq!(c.fail("LongMoveEvent,0,;").await, 20018, "nothing held");
    sim.advance(ms(200));
    assert_eq!(c.fsm().await, 33);
    let stopped = joints(&mut c).await[0];
    assert!((stopped - (last + 1.0)).abs() < 1e-6, "{stopped} vs {last}");
    sim.advance(ms(1000));
    assert_eq!(joints(&mut c).await[0], stopped, "stays");
    let s = c.state().await;
    assert_eq!((s[0], s[11], s[12]), (0, 1, 1), "still, done, in position");
    // Releasing again is harmless.
    c.ok("LongJogJ,0,0,1,0,;").await;
    sim.shutdown().await;
}

/// Without LongMoveEvent the jog stops 200 ms after the last one (the
/// document's period), braking from that instant, whenever the client
/// looks next.
#[tokio::test]
async fn a_long_jog_stops_when_the_events_stop() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    c.ok("LongJogJ,0,5,0,1,;").await;
    sim.advance(ms(150));
    c.ok("LongMoveEvent,0,;").await;
    sim.advance(ms(199));
    assert_eq!(c.fsm().await, 26, "199 ms after the last event");
    sim.advance(ms(2));
    assert_eq!(c.fsm().await, 27, "201 ms: braking");
    assert_eq!(c.fail("LongMoveEvent,0,;").await, 20018, "too late");
    sim.advance(ms(1000));
    assert_eq!(c.fsm().await, 33);
    // Lapsed at t = 0.35 s: -(1 + 10·0.15) = -2.5°, then 1° of braking.
    let q = joints(&mut c).await[5];
    assert!((q + 3.5).abs() < 1e-6, "J6 {q}");

    // Looking only long after: the same end, decided by the clock.
    c.ok("LongJogJ,0,5,1,1,;").await;
    sim.advance(ms(5000));
    assert_eq!(c.fsm().await, 33);
    // 0.2 s at most to lapse: 0.2 s ramp (1°) only, then 1° of braking.
    let q2 = joints(&mut c).await[5];
    assert!((q2 - (q + 2.0)).abs() < 1e-6, "J6 {q2}");
    // A longer keep-alive is an option of the simulator.
    let slow = manual(Config {
        timing: hans_sim::Timing {
            long_move_keepalive: ms(500),
            ..hans_sim::Timing::default()
        },
        ..Config::ready()
    })
    .await;
    let mut s = Client::connect(slow.command_addr()).await;
    s.ok("LongJogJ,0,0,1,1,;").await;
    slow.advance(ms(450));
    assert_eq!(s.fsm().await, 26);
    slow.advance(ms(100));
    assert_eq!(s.fsm().await, 27);
    slow.shutdown().await;
    sim.shutdown().await;
}

#[tokio::test]
async fn a_long_jog_stops_at_the_joint_limit() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    // J5 is at 90, its limit 180: 90° at 10 °/s.
    c.ok("LongJogJ,0,4,1,1,;").await;
    for _ in 0..100 {
        sim.advance(ms(100));
        if c.call("LongMoveEvent,0,;").await != "LongMoveEvent,OK,;" {
            break;
        }
    }
    assert_eq!(c.fsm().await, 33, "ended at the limit");
    assert!((joints(&mut c).await[4] - 180.0).abs() < 1e-6);
    assert_eq!(c.fail("LongJogJ,0,4,1,1,;").await, 20006, "nowhere to go");
    c.ok("LongJogJ,0,4,0,1,;").await;
    sim.shutdown().await;
}

#[tokio::test]
async fn a_cartesian_long_jog_moves_the_tcp_along_the_axis() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    let start = pose(&mut c).await;
    c.ok("LongJogL,0,2,0,1,;").await; // Z negative
    assert_eq!(c.fsm().await, 26);
    // Re-sending the same jog keeps it alive too.
    for i in 0..10 {
        sim.advance(ms(100));
        if i % 2 == 0 {
            c.ok("LongMoveEvent,0,;").await;
        } else {
            c.ok("LongJogL,0,2,0,1,;").await;
        }
    }
    // t = 1 s: 0.2 s ramp (3 mm) then 30 mm/s.
    let p = c.numbers("ReadCmdPos,0,;").await;
    assert!(
        close(&p[6..9], &[start[0], start[1], start[2] - 27.0], 1e-2),
        "{p:?}"
    );
    assert!(close(&p[9..12], &start[3..6], 1e-3), "orientation kept");
    assert!((c.numbers("ReadTcpVel,0,;").await[0] - 30.0).abs() < 0.1);
    // Another jog while this one runs is refused.
    assert_eq!(c.fail("LongJogJ,0,0,1,1,;").await, 20018);
    c.ok("LongJogL,0,2,0,0,;").await;
    sim.advance(ms(300));
    assert_eq!(c.fsm().await, 33);
    sim.shutdown().await;
}

#[tokio::test]
async fn move_to_targets_runs_while_held() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    // J1 to 5°: 0.2 s ramp, cruise, ramp: 0.7 s.
    c.ok("MoveJTo,0,5,0,90,0,90,0,;").await;
    assert_eq!(c.fsm().await, 26);
    for _ in 0..4 {
        sim.advance(ms(150));
        c.ok("LongMoveEvent,0,;").await;
    }
    assert_eq!(c.fsm().await, 26, "t = 0.6 s");
    sim.advance(ms(150));
    assert_eq!(c.fsm().await, 33, "arrived");
    assert!(close(
        &joints(&mut c).await,
        &[5.0, 0.0, 90.0, 0.0, 90.0, 0.0],
        1e-9
    ));
    assert_eq!(
        c.fail("LongMoveEvent,0,;").await,
        20018,
        "arrived: nothing held"
    );
    // Not kept alive: stops short of the target.
    c.ok("MoveLTo,0,420,0,400,180,0,180,TCP,Base,;").await;
    sim.advance(ms(2000));
    assert_eq!(c.fsm().await, 33);
    let z = pose(&mut c).await[2];
    assert!(z > 430.0 && z < 445.0, "stopped on the way: {z}");
    assert_eq!(
        c.fail("MoveJTo,0,500,0,90,0,90,0,;").await,
        20006,
        "outside the limits"
    );
    // Aligning the tool's Z axis: already aligned (tool down).
    assert_eq!(
        c.values("MoveAlignToZ,0,TCP,Base,;").await[0],
        "1",
        "aligned already"
    );
    sim.shutdown().await;
}

#[tokio::test]
async fn move_align_to_z_turns_the_tool_onto_the_nearest_axis() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    c.ok("ShortJogJ,0,4,1,;").await; // J5 92°: tool 2° off vertical
    sim.advance(ms(1000));
    let before = pose(&mut c).await;
    let r = c.numbers("MoveAlignToZ,0,TCP,Base,;").await;
    assert_eq!(r[0], 0.0, "not aligned yet");
    // The joints that turn the tool about its TCP until it points down.
    let q: Vec<String> = r[1..].iter().map(|v| v.to_string()).collect();
    let aligned = c
        .numbers(&format!(
            "GetForwardKin,0,{},0,0,0,0,0,0,0,0,0,0,0,0,;",
            q.join(",")
        ))
        .await;
    assert!(close(&aligned[..3], &before[..3], 1e-2), "{aligned:?}");
    assert!(
        (aligned[3].abs() - 180.0).abs() < 1e-2 && aligned[4].abs() < 1e-2,
        "{aligned:?}"
    );
    assert_eq!(c.fsm().await, 26, "turning while held");
    for _ in 0..10 {
        sim.advance(ms(100));
        let _ = c.call("LongMoveEvent,0,;").await;
    }
    assert_eq!(c.fsm().await, 33);
    assert!(close(&joints(&mut c).await, &r[1..], 1e-3));
    let after = pose(&mut c).await;
    assert!(close(&after[..3], &before[..3], 1e-2), "{after:?}");
    assert_eq!(c.values("MoveAlignToZ,0,TCP,Base,;").await[0], "1");
    sim.shutdown().await;
}

#[tokio::test]
async fn error_texts_for_every_code_the_simulator_answers() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    for (code, text) in [
        (20018, "command forbidden in this state"),
        (20006, "command parameters error"),
        (20007, "command format error"),
        (10000, "Short circuit error"),
        (20005, "command not supported"),
        (20042, "path not ready"),
        (100, "unkown error"),
        (39503, "unkown error"),
    ] {
        assert_eq!(
            c.call(&format!("GetErrorCodeStr,{code},;")).await,
            format!("GetErrorCodeStr,OK,{text},;")
        );
    }
    // The document's form without the comma before ';'.
    assert_eq!(
        c.call("GetErrorCodeStr,10000;").await,
        "GetErrorCodeStr,OK,Short circuit error,;"
    );
    sim.shutdown().await;
}

#[tokio::test]
async fn payload_override_and_settings_read_back() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    assert_eq!(c.values("ReadMaxPayload,0,;").await, ["5.000"]);
    assert_eq!(c.values("ReadPayload,0,;").await, ["0.000"; 4]);
    c.ok("SetPayload,0,1.5,12,25,39,;").await;
    assert_eq!(
        c.values("ReadPayload,0,;").await,
        ["1.500", "12.000", "25.000", "39.000"]
    );
    c.ok("SetPayload,0,2,0,0,0,3,;").await; // the mass only
    assert_eq!(
        c.values("ReadPayload,0,;").await,
        ["2.000", "12.000", "25.000", "39.000"]
    );
    assert_eq!(c.fail("SetPayload,0,6,0,0,0,;").await, 20006);
    assert_eq!(c.values("ReadOverride,0,;").await, ["1.000"]);
    c.ok("SetOverride,0,0.6,;").await;
    assert_eq!(c.values("ReadOverride,0,;").await, ["0.600"]);
    c.ok("SetCOConfig,2,10,;").await;
    assert_eq!(c.values("ReadCOConfig,;").await[2], "10");
    c.ok("SetCIConfig,3,11,2,;").await;
    assert_eq!(c.values("ReadCIConfig,3,;").await, ["11", "2"]);
    c.ok("SwitchScript,0,abcd.JSON,;").await;
    assert_eq!(c.values("ReadDefaultScript,0,;").await, ["abcd.JSON"]);
    c.ok("ConfigTCP,0,Pen,0,0,100,0,0,0,;").await;
    assert_eq!(
        c.values("ReadTCPList,0,;").await,
        ["Pen", "TCP", "TCP_1", "Tool"]
    );
    c.ok("SetDftTCP,0,Pen,;").await;
    assert_eq!(c.numbers("ReadCurTCP,0,;").await[2], 100.0);
    // The document's examples.
    assert_eq!(
        c.values("CalTCPOrt,0,0,0,1176.5,0,0,0,185.883,-61.340,1030.321,-10.545,37.583,-117.477,;")
            .await,
        ["-38.351", "6.563", "111.596"]
    );
    let p = c.numbers("ReadPointByName,0,Point_3,;").await;
    assert!(
        close(
            &p[..12],
            &[0.0, 0.0, 45.0, 0.0, 90.0, 0.0, 406.586, 0.0, 787.383, 180.0, 45.0, 180.0],
            1e-3
        ),
        "{p:?}"
    );
    assert_eq!(c.fail("ReadPointByName,0,Nowhere,;").await, 20016);
    assert_eq!(c.values("PackageVersion,;").await, ["6.6.1.20250805"]);
    sim.shutdown().await;
}

#[tokio::test]
async fn payload_identification_takes_time_and_reports_the_payload() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    assert_eq!(c.values("GetLoadIdentifyResult,0,;").await[0], "7");
    c.ok("SetPayload,0,1.5,12,25,39,;").await;
    c.ok("LoadIdentify,0,;").await;
    assert_eq!(c.fsm().await, 41);
    sim.advance(ms(2500));
    assert_eq!(
        c.values("GetLoadIdentifyResult,0,;").await[..2],
        ["4", "50"]
    );
    sim.advance(ms(2500));
    assert_eq!(c.fsm().await, 33);
    assert_eq!(
        c.values("GetLoadIdentifyResult,0,;").await,
        ["0", "100", "1.500", "12.000", "25.000", "39.000"]
    );
    c.ok("LoadIdentify,0,;").await;
    c.ok("GrpStop,0,;").await;
    assert_eq!(
        c.values("GetLoadIdentifyResult,0,;").await[0],
        "5",
        "stopped"
    );
    sim.shutdown().await;
}

#[tokio::test]
async fn the_new_paths_compute_twice_and_run() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    c.ok("InitPath,0,0,ccc,0.5,20,;").await;
    assert_eq!(
        c.values("ReadPathState,0,ccc,;").await,
        ["1", "0", "1", "0"]
    );
    assert_eq!(c.fail("MovePathJ,0,ccc,;").await, 20042, "not computed");
    c.ok("PushPathPoints,0,ccc,10,0,90,0,90,0,20,0,90,0,90,0,;")
        .await;
    c.ok("PushPathPoints,0,ccc,30,0,90,0,90,0,;").await;
    c.ok("EndPushPathPoints,0,ccc,;").await;
    assert_eq!(
        c.values("ReadPathState,0,ccc,;").await,
        ["2", "0", "2", "0"]
    );
    assert_eq!(c.fail("DelPath,0,ccc,;").await, 20018, "computing");
    assert_eq!(
        c.fail("EndPushPathPoints,0,ccc,;").await,
        20018,
        "not teaching"
    );
    sim.advance(ms(300));
    assert_eq!(
        c.values("ReadPathState,0,ccc,;").await,
        ["3", "0", "2", "0"]
    );
    sim.advance(ms(1700));
    assert_eq!(
        c.values("ReadPathState,0,ccc,;").await,
        ["3", "0", "3", "0"]
    );
    assert_eq!(c.values("ReadPath,0,;").await, ["ccc"]);
    let info = c.values("ReadPath,0,ccc,;").await;
    assert_eq!(info.len(), 29, "{info:?}");
    assert_eq!((info[0].as_str(), info[5].as_str()), ("0", "0.500"));
    assert_eq!(info[22], "3", "three raw points");
    assert_eq!(info[23], "10.000", "the first");
    c.ok("MovePathJ,0,ccc,;").await;
    assert_eq!(c.fsm().await, 25);
    sim.advance(ms(10_000));
    assert_eq!(c.fsm().await, 33);
    assert!((joints(&mut c).await[0] - 30.0).abs() < 1e-6);
    // The Cartesian run of a joint path: through the points' poses.
    c.ok("MovePathL,0,ccc,;").await;
    sim.advance(ms(10_000));
    assert!((joints(&mut c).await[0] - 30.0).abs() < 1e-3);
    c.ok("UpdatePathName,0,ccc,ddd,;").await;
    assert_eq!(c.fail("UpdatePathName,0,ccc,eee,;").await, 20006);
    c.ok("DelPath,0,ddd,;").await;
    assert_eq!(c.values("ReadPath,0,;").await, Vec::<String>::new());

    // Cartesian points, one out of reach: both computations fail.
    c.ok("InitPath,0,1,aaa,0.3,20,100,200,300,Base,TCP,;").await;
    c.ok("PushPathPoints,0,aaa,420,0,445,180,0,180,5000,0,445,180,0,180,;")
        .await;
    c.ok("EndPushPathPoints,0,aaa,;").await;
    sim.advance(ms(2000));
    assert_eq!(
        c.values("ReadPathState,0,aaa,;").await,
        ["5", "20046", "5", "20046"]
    );
    // Reachable ones run as a line.
    c.ok("InitPath,0,1,aaa,0.3,20,100,200,300,Base,TCP,;").await;
    c.ok("PushPathPoints,0,aaa,420,0,445,180,0,180,420,50,445,180,0,180,;")
        .await;
    c.ok("EndPushPathPoints,0,aaa,;").await;
    sim.advance(ms(2000));
    c.ok("MovePathL,0,aaa,;").await;
    sim.advance(ms(5000));
    let p = pose(&mut c).await;
    assert!(close(&p[..3], &[420.0, 50.0, 445.0], 1e-3), "{p:?}");
    assert_eq!(c.fail("InitPath,0,0,bad-name,0.5,20,;").await, 20006);
    assert_eq!(
        c.fail("InitPath,0,1,nopose,0.5,20,;").await,
        20006,
        "needs the Cartesian part"
    );
    sim.shutdown().await;
}

#[tokio::test]
async fn an_online_path_reports_its_index_and_sets_outputs_on_the_way() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    // Three points 10° apart on J1; the second sets box DO1 and DO3.
    let point = |j1: i32, set: i32| format!("{j1},0,90,0,90,0,{set},0,0,10,10,0,0,0,1,0,1,0,0");
    let msg = format!(
        "MovePathJOL,0,10,100,0.1,{},{},{},;",
        point(10, 0),
        point(20, 1),
        point(30, 0)
    );
    c.ok(&msg).await;
    assert_eq!(c.values("GetMovePathJOLIndex,0,;").await, ["0", "3"]);
    sim.advance(ms(1500));
    assert_eq!(c.values("GetMovePathJOLIndex,0,;").await, ["1", "3"]);
    assert_eq!(c.values("ReadBoxDO,1,3,;").await, ["0", "0"]);
    sim.advance(ms(1000));
    assert_eq!(c.values("GetMovePathJOLIndex,0,;").await, ["2", "3"]);
    assert_eq!(c.values("ReadBoxDO,1,3,;").await, ["1", "1"]);
    sim.advance(ms(2000));
    assert_eq!(c.values("GetMovePathJOLIndex,0,;").await, ["3", "3"]);
    assert_eq!(c.fsm().await, 33);
    sim.shutdown().await;
}

#[tokio::test]
async fn velocity_control_moves_for_its_run_time() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    // J1 at 10 °/s for 1 s, 100 °/s²: 0.1 s ramps, 10° in all.
    c.ok("SpeedJ,0,10,0,0,0,0,0,100,1,;").await;
    sim.advance(ms(500));
    let v = c.numbers("ReadCmdJointVel,0,;").await;
    assert!((v[0] - 10.0).abs() < 0.1, "{v:?}");
    // Replaced by a stop (velocities 0).
    c.ok("SpeedJ,0,0,0,0,0,0,0,100,1,;").await;
    assert_eq!(c.fsm().await, 33);
    let q = joints(&mut c).await[0];
    assert!((q - 4.5).abs() < 1e-6, "{q}");
    // Along X at 20 mm/s for 0.5 s.
    let p0 = pose(&mut c).await;
    c.ok("SpeedL,0,20,0,0,0,0,0,200,100,0.5,;").await;
    sim.advance(ms(2000));
    let p1 = pose(&mut c).await;
    assert!((p1[0] - p0[0] - 10.0).abs() < 1e-2, "{p0:?} -> {p1:?}");
    sim.shutdown().await;
}

#[tokio::test]
async fn the_fast_port_serves_the_fast_commands() {
    let sim = manual(Config::ready()).await;
    let fast = sim.fast_addr().expect("a fast port at V6");
    let mut c = Client::connect(sim.command_addr()).await;
    assert_eq!(
        c.values("ReadFastCmdPort,;").await,
        [fast.port().to_string()]
    );
    let mut f = Client::connect(fast).await;
    assert_eq!(f.fsm().await, 33);
    assert_eq!(
        f.values("GetErrorCodeStr,20018,;").await,
        ["command forbidden in this state"]
    );
    f.ok("GetForwardKin,0,0,0,90,0,90,0,0,0,0,0,0,0,0,0,0,0,0,0,;")
        .await;
    // Motion and settings are for the command port.
    assert_eq!(
        f.call("WayPoint,0,0,0,0,0,0,0,10,0,90,0,90,0,TCP,Base,50,100,0,0,1,0,0,0,w,;")
            .await,
        "WayPoint,Fail,20005,;"
    );
    assert_eq!(
        f.call("SetOverride,0,0.5,;").await,
        "SetOverride,Fail,20005,;"
    );
    assert_eq!(sim.fsm(), FsmState::StandBy);
    // A move from the command port shows on the fast port.
    c.ok("LongJogJ,0,0,1,1,;").await;
    assert_eq!(f.fsm().await, 26);
    // No fast port when asked for none.
    let none = Sim::start(Config {
        fast_port: None,
        ..Config::ready()
    })
    .await
    .unwrap();
    assert_eq!(none.fast_addr(), None);
    let mut n = Client::connect(none.command_addr()).await;
    assert_eq!(n.fail("ReadFastCmdPort,;").await, 20018);
    none.shutdown().await;
    sim.shutdown().await;
}

#[tokio::test]
async fn x_to_standby_brings_the_robot_up_alone() {
    let sim = manual(Config::default()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    assert_eq!(c.fsm().await, 2);
    c.ok("XToStandby,0,;").await;
    sim.advance(ms(200 + 500 + 300 + 200));
    assert_eq!(c.fsm().await, 33);
    c.ok("EnterSafeGuard,0,1,;").await;
    assert_eq!(c.fsm().await, 12);
    assert_eq!(c.fail("XToStandby,0,;").await, 20018);
    c.ok("EnterSafeGuard,0,0,;").await;
    assert_eq!(c.fsm().await, 33);
    assert_eq!(c.values("ReadBrakeStatus,0,;").await, ["1"; 6]);
    sim.shutdown().await;
}
