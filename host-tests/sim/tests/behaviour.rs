//! Controller behaviour over TCP on the manual clock: stop, pause and
//! continue, safety, errors and reset, seek, kinematics and pose commands,
//! I/O read-back, scripts, free drive, paths, servo, and the DataSheet
//! packets decoded by the codec.

mod support;

use hans_codec::datasheet::{DataSheet, Deframer, MAGIC};
use hans_codec::RawMessage;
use hans_sim::{Config, FsmState, ProtocolLevel, RobotError, Sim};
use support::{close, manual, ms, Client, WAIT};
use tokio::io::AsyncReadExt;
use tokio::net::TcpStream;

/// J1 0 -> 90 at 50 °/s, 100 °/s²: 2.3 s.
const MOVE: &str = "WayPoint,0,0,0,0,0,0,0,90,0,90,0,90,0,TCP,Base,50,100,0,0,1,0,0,0,m1,;";

#[tokio::test]
async fn stop_pause_and_continue() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    c.ok(MOVE).await;
    sim.advance(ms(1000));
    c.ok("GrpInterrupt,0,;").await;
    assert_eq!(c.fsm().await, 32);
    assert_eq!(c.state().await[6], 1, "paused flag");
    assert_eq!(c.fail("GrpContinue,0,;").await, 40014, "still braking");
    sim.advance(ms(600));
    let held = c.numbers("ReadCmdPos,0,;").await[0];
    sim.advance(ms(1000));
    assert_eq!(c.numbers("ReadCmdPos,0,;").await[0], held, "holds still");
    assert_eq!(c.state().await[0], 0, "not moving while held");
    assert_eq!(c.fail(MOVE).await, 20018, "no new motion while paused");
    c.ok("GrpContinue,0,;").await;
    assert_eq!(c.fsm().await, 25);
    sim.advance(ms(5000));
    assert_eq!(c.fsm().await, 33);
    assert!(
        (c.numbers("ReadCmdPos,0,;").await[0] - 90.0).abs() < 1e-9,
        "finished the path"
    );

    c.ok("WayPoint,0,0,0,0,0,0,0,0,0,90,0,90,0,TCP,Base,50,100,0,0,1,0,0,0,m2,;")
        .await;
    c.ok("WayPoint,0,0,0,0,0,0,0,45,0,90,0,90,0,TCP,Base,50,100,0,0,1,0,0,0,m3,;")
        .await;
    sim.advance(ms(1000));
    c.ok("GrpStop,0,;").await;
    assert_eq!(c.fsm().await, 27, "stopping");
    sim.advance(ms(600));
    assert_eq!(c.fsm().await, 33);
    let q = c.numbers("ReadCmdPos,0,;").await[0];
    assert!(q > 0.0 && q < 90.0, "stopped on the way: {q}");
    sim.advance(ms(5000));
    assert_eq!(
        c.numbers("ReadCmdPos,0,;").await[0],
        q,
        "the queued move was dropped"
    );
    assert_eq!(c.values("ReadCurWayPointID,0,;").await, ["m2"]);
    sim.shutdown().await;
}

#[tokio::test]
async fn safety_errors_and_reset() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    c.ok(MOVE).await;
    sim.advance(ms(500));
    sim.set_safety_guard(true);
    assert_eq!(c.fsm().await, 12);
    assert_eq!(
        c.values("ReadEmergencyInfo,0,;").await,
        ["0", "0", "0", "1"]
    );
    assert_eq!(c.fail(MOVE).await, 20018);
    sim.advance(ms(1000));
    sim.set_safety_guard(false);
    assert_eq!(c.fsm().await, 33);

    sim.set_error(Some(RobotError {
        code: 10000,
        axis: 2,
    }));
    assert_eq!(c.fsm().await, 22);
    let s = c.state().await;
    assert_eq!((s[2], s[3], s[4]), (1, 10000, 2));
    assert_eq!(
        c.values("ReadAxisErrorCode,0,;").await,
        ["10000", "0", "0", "10000", "0", "0", "0"]
    );
    assert_eq!(c.fail(MOVE).await, 20018);
    c.ok("GrpReset,0,;").await;
    assert_eq!(c.fsm().await, 19);
    sim.advance(ms(100));
    assert_eq!(c.fsm().await, 33);
    assert_eq!(c.state().await[2], 0);

    c.ok(MOVE).await;
    sim.advance(ms(300));
    sim.set_emergency_stop(true);
    assert_eq!(c.fsm().await, 5);
    let s = c.state().await;
    assert_eq!((s[1], s[7], s[9]), (0, 1, 0), "disabled, e-stop, unpowered");
    assert_eq!(c.fail("GrpEnable,0,;").await, 20018);
    sim.set_emergency_stop(false);
    assert_eq!(c.fsm().await, 7);
    c.ok("Electrify,;").await;
    c.ok("GrpEnable,0,;").await;
    sim.advance(ms(1000));
    assert_eq!(c.fsm().await, 33);
    sim.shutdown().await;
}

#[tokio::test]
async fn seek_stops_a_way_point_when_the_input_matches() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    c.ok("WayPoint,0,0,0,0,0,0,0,90,0,90,0,90,0,TCP,Base,50,100,0,0,1,1,3,1,s1,;")
        .await;
    sim.advance(ms(1000));
    sim.set_io(|io| io.di[3] = true);
    assert_eq!(c.fsm().await, 27);
    sim.advance(ms(1000));
    assert_eq!(c.fsm().await, 33);
    let q = c.numbers("ReadCmdPos,0,;").await[0];
    assert!(q < 60.0, "stopped early at {q}");
    sim.shutdown().await;
}

#[tokio::test]
async fn a_linear_move_keeps_the_tcp_on_the_line() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    // From 420,0,445 to 420,100,445 at 100 mm/s, 1000 mm/s².
    c.ok("WayPoint,0,420,100,445,180,0,180,0,0,90,0,90,0,TCP,Base,100,1000,0,1,0,0,0,0,l1,;")
        .await;
    sim.advance(ms(550)); // 0.1 s accelerating (5 mm) + 0.45 s cruising
    let p = c.numbers("ReadCmdPos,0,;").await;
    assert!(close(&p[6..9], &[420.0, 50.0, 445.0], 1e-2), "{p:?}");
    sim.advance(ms(1000));
    let p = c.numbers("ReadActPos,0,;").await;
    assert!(close(&p[6..9], &[420.0, 100.0, 445.0], 1e-3), "{p:?}");
    sim.shutdown().await;
}

#[tokio::test]
async fn kinematics_and_pose_commands_match_the_document() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    assert_eq!(
        c.call("GetForwardKin,0,0,0,90,0,90,0,0,0,0,0,0,0,0,0,0,0,0,0,;")
            .await,
        "GetForwardKin,OK,420.000,0.000,445.000,180.000,0.000,180.000,;"
    );
    assert_eq!(
        c.call("GetInverseKin,0,420,0,445,180,0,180,0,0,90,0,90,0,0,0,0,0,0,0,0,0,0,0,0,0,;")
            .await,
        "GetInverseKin,OK,0.000,0.000,90.000,0.000,90.000,0.000,;"
    );
    assert_eq!(
        c.call("PCS2ACS,0,420,0,445,180,0,180,0,0,90,0,90,0,0,0,0,0,0,0,0,0,0,0,0,0,;")
            .await,
        "PCS2ACS,OK,0.000,0.000,90.000,0.000,90.000,0.000,;"
    );
    let ex = [
        (
            "PoseAdd,0,420,100,445,180,0,180,420,100,445,180,0,180,;",
            "PoseAdd,OK,840.000,200.000,890.000,0.000,0.000,0.000,;",
        ),
        (
            "PoseSub,0,420,0,445,180,0,180,420,100,445,180,0,180,;",
            "PoseSub,OK,0.000,-100.000,0.000,0.000,0.000,0.000,;",
        ),
        (
            "PoseTrans,0,420,0,445,180,0,180,420,100,445,180,0,180,;",
            "PoseTrans,OK,0.000,100.000,0.000,0.000,0.000,0.000,;",
        ),
        (
            "PoseInverse,0,420,0,445,180,0,180,;",
            "PoseInverse,OK,420.000,0.000,445.000,180.000,0.000,180.000,;",
        ),
        (
            "PoseDist,0,420,0,445,180,0,180,420,100,445,180,0,180,;",
            "PoseDist,OK,100.000,0.000,;",
        ),
        (
            "PoseInterpolate,0,420,0,445,0,0,180,420,100,445,180,0,180,0.5,;",
            "PoseInterpolate,OK,420.000,50.000,445.000,90.000,0.000,180.000,;",
        ),
        (
            "PoseDefdFrame,0,420,0,445,420,50,445,470,50,445,420,0,445,420,0,495,420,50,495,;",
            "PoseDefdFrame,OK,420.000,-445.000,25.000,0.000,-90.000,-90.000,;",
        ),
        (
            "Base2UcsTcp,0,420,0,445,180,0,180,0,0,0,0,0,0,420,100,445,180,0,180,;",
            "Base2UcsTcp,OK,0.000,-100.000,0.000,0.000,0.000,0.000,;",
        ),
        (
            "UcsTcp2Base,0,0,-100,0,0,0,0,0,0,0,0,0,0,420,100,445,180,0,180,;",
            "UcsTcp2Base,OK,420.000,0.000,445.000,180.000,0.000,180.000,;",
        ),
        (
            "RPY2Quaternion,0,180,0,180,;",
            "RPY2Quaternion,OK,0.000,0.000,1.000,0.000,;",
        ),
        (
            "Quaternion2RPY,0,0,0,1,0,;",
            "Quaternion2RPY,OK,180.000,0.000,180.000,;",
        ),
        (
            "ReadTCPByName,0,TCP_1,;",
            "ReadTCPByName,OK,60.000,80.000,120.000,50.000,0.000,0.000,;",
        ),
        (
            "ReadUCSByName,0,Point_1,;",
            "ReadUCSByName,OK,420.000,0.000,445.000,180.000,0.000,180.000,;",
        ),
    ];
    for (req, want) in ex {
        // Numerically equal, angles modulo 360 (the document itself prints
        // `-0.000` and both `180` and `-180`).
        let got = c.call(req).await;
        // The name and the values after `OK`, read by the codec.
        let parts = |t: &str| -> (String, Vec<f64>) {
            let raw = RawMessage::parse(t).unwrap_or_else(|e| panic!("{t}: {e}"));
            let values = raw.fields().skip(1);
            let nums = values.filter_map(|f| f.trim().parse().ok()).collect();
            (raw.name().to_string(), nums)
        };
        let ((got_name, g), (want_name, w)) = (parts(&got), parts(want));
        assert_eq!(got_name, want_name, "{req}");
        assert_eq!(g.len(), w.len(), "{req} -> {got}");
        for (a, b) in g.iter().zip(&w) {
            let d = (a - b).abs();
            assert!(
                d < 1e-3 || (d - 360.0).abs() < 1e-3,
                "{req} -> {got}, want {want}"
            );
        }
    }
    assert_eq!(
        c.fail("GetInverseKin,0,5000,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,;")
            .await,
        20006
    );
    assert_eq!(c.fail("SetTCPByName,0,NoSuchTool,;").await, 20029);
    assert_eq!(c.fail("SetUCSByName,0,NoSuchFrame,;").await, 20030);
    // ReadActPos agrees with GetForwardKin in the current frames.
    c.ok("SetCurTCP,0,0,0,100,0,0,0,;").await;
    let p = c.numbers("ReadActPos,0,;").await;
    assert!(
        close(&p[6..12], &[420.0, 0.0, 345.0, 180.0, 0.0, 180.0], 1e-3),
        "{p:?}"
    );
    assert!(close(&p[12..18], &[0.0, 0.0, 100.0, 0.0, 0.0, 0.0], 1e-9));
    sim.shutdown().await;
}

#[tokio::test]
async fn io_reads_back_and_tool_registers() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    c.ok("SetBoxDO,5,1,;").await;
    c.ok("SetBoxCO,2,1,;").await;
    c.ok("SetEndDO,0,1,1,;").await;
    c.ok("SetBoxAO,1,8.8,2,;").await;
    assert_eq!(
        c.fail("SetBoxAO,0,12,1,;").await,
        20006,
        "over 10 V in voltage mode"
    );
    assert_eq!(c.values("ReadBoxDO,5,6,;").await, ["1", "0"]);
    assert_eq!(c.values("ReadBoxCO,2,;").await, ["1"]);
    assert_eq!(c.values("ReadEO,0,1,2,;").await, ["1", "0"]);
    // The V6 document's form: mode and value per channel.
    assert_eq!(
        c.values("ReadBoxAO,0,1,;").await,
        ["1", "0.000", "2", "8.800"]
    );
    sim.set_io(|io| {
        io.di[0] = true;
        io.ci[7] = true;
        io.ai = [5.5, 3.8];
        io.end_di[2] = true;
        io.end_ai[1] = 12.0;
    });
    assert_eq!(c.values("ReadBoxDI,0,1,;").await, ["1", "0"]);
    assert_eq!(c.values("ReadBoxCI,7,;").await, ["1"]);
    assert_eq!(c.values("ReadBoxAI,0,1,;").await, ["5.500", "3.800"]);
    assert_eq!(c.values("ReadEI,0,2,;").await, ["1"]);
    assert_eq!(c.values("ReadEAI,0,1,;").await, ["12.000"]);
    c.ok("WriteHoldingRegisters,0,1,16,5000,5,88,89,90,91,92,;")
        .await;
    assert_eq!(
        c.values("ReadHoldingRegisters,0,1,3,5000,5,;").await,
        ["88", "89", "90", "91", "92"]
    );
    assert_eq!(
        c.fail("WriteHoldingRegisters,0,1,3,5000,1,88,;").await,
        20006,
        "3 reads"
    );
    sim.set_end_io_ethercat(false);
    assert_eq!(c.fail("ReadHoldingRegisters,0,1,3,5000,1,;").await, 40058);
    sim.shutdown().await;
}

#[tokio::test]
async fn scripts_free_drive_and_force_control() {
    let sim = manual(Config::ready()).await;
    let mut c = Client::connect(sim.command_addr()).await;
    assert_eq!(c.call("RunFunc,Func_1,55,;").await, "RunFunc,OK,Func_1,;");
    assert_eq!(c.fsm().await, 34);
    assert_eq!(c.fail(MOVE).await, 20018);
    c.ok("PauseScript,;").await;
    sim.advance(ms(100));
    assert_eq!(c.fsm().await, 36);
    c.ok("ContinueScript,;").await;
    assert_eq!(c.fsm().await, 34);
    c.ok("StopScript,;").await;
    sim.advance(ms(100));
    assert_eq!(c.fsm().await, 33);
    assert_eq!(c.fail("ContinueScript,;").await, 20018);
    assert_eq!(c.fail("RunFunc,Nope,;").await, 20601);

    c.ok("GrpOpenFreeDriver,0,;").await;
    sim.advance(ms(100));
    assert_eq!(c.fsm().await, 31);
    c.ok("GrpCloseFreeDriver,0,;").await;
    sim.advance(ms(100));
    assert_eq!(c.fsm().await, 33);

    assert_eq!(c.fail("GrpFCInterrupt,0,;").await, 40020);
    c.ok("SetForceControlState,0,1,;").await;
    assert_eq!(c.fsm().await, 25, "force control counts as motion");
    assert_eq!(c.values("ReadFTControlState,0,;").await, ["1"]);
    sim.advance(ms(500));
    assert_eq!(c.values("ReadFTControlState,0,;").await, ["2"]);
    c.ok("GrpFCInterrupt,0,;").await;
    c.ok("SetForceControlState,0,0,;").await;
    sim.advance(ms(100));
    assert_eq!(c.fsm().await, 33);
    sim.set_force_data([1.0, 2.0, 3.0, 0.0, 0.0, 0.5]);
    assert_eq!(c.values("ReadFTCabData,0,;").await[5], "0.500");
    sim.shutdown().await;
}

#[tokio::test]
async fn joint_and_cartesian_paths_and_servo() {
    // HR-TCP's path commands: gone from the V6 level (HR6.5.0).
    let sim = manual(Config {
        protocol: ProtocolLevel::V5,
        ..Config::ready()
    })
    .await;
    let mut c = Client::connect(sim.command_addr()).await;
    assert_eq!(c.fail("MovePath,0,P1,;").await, 20042);
    c.ok("StartPushMovePath,0,P1,0.5,2,;").await;
    for j in ["10", "20", "30", "40"] {
        c.ok(&format!("PushMovePathJ,0,P1,{j},0,90,0,90,0,;")).await;
    }
    assert_eq!(c.values("ReadMovePathState,0,P1,;").await, ["1"]);
    c.ok("EndPushMovePath,0,P1,;").await;
    assert_eq!(c.values("ReadMovePathState,0,P1,;").await, ["2"]);
    sim.advance(ms(300));
    assert_eq!(c.values("ReadMovePathState,0,P1,;").await, ["3"]);
    // HR-TCP's name (with the V6 commands, `MovePathJ` is the V6
    // document's own command, from HR6.3.3: not an alias at this level).
    assert_eq!(c.fail("MovePathJ,0,P1,;").await, 20005);
    c.ok("MovePath,0,P1,;").await;
    assert_eq!(c.fsm().await, 25);
    sim.advance(ms(10_000));
    assert!((c.numbers("ReadCmdPos,0,;").await[0] - 40.0).abs() < 1e-6);

    c.ok("InitMovePathL,0,L1,100,2500,1000000,Base,TCP,;").await;
    c.ok("PushMovePaths,0,L1,1,3,420,0,445,180,0,180,420,20,445,180,0,180,420,40,445,180,0,180,;")
        .await;
    c.ok("EndPushMovePath,0,L1,;").await;
    assert_eq!(c.values("ReadMovePathState,0,L1,;").await, ["4"]);
    c.ok("MovePathL,0,L1,;").await;
    assert_eq!(c.fsm().await, 25, "computing counts as busy");
    assert_eq!(
        c.values("ReadSoftMotionProgress,0,;").await,
        ["0.000000", "0"]
    );
    sim.advance(ms(20_000));
    assert_eq!(c.fsm().await, 33);
    assert_eq!(
        c.values("ReadSoftMotionProgress,0,;").await,
        ["1.000000", "3"]
    );
    let p = c.numbers("ReadActPos,0,;").await;
    assert!(close(&p[6..9], &[420.0, 40.0, 445.0], 1e-3), "{p:?}");
    c.ok("DelMovePath,0,L1,;").await;
    assert_eq!(c.values("ReadMovePathState,0,L1,;").await, ["0"]);

    assert_eq!(c.fail("PushServoJ,0,0,0,90,0,90,0,;").await, 20018);
    c.ok("StartServo,0,0.2,0.02,;").await;
    let j1 = c.numbers("ReadCmdPos,0,;").await[0];
    c.ok("PushServoJ,0,10,0,90,0,90,0,;").await;
    sim.advance(ms(100));
    let mid = c.numbers("ReadCmdPos,0,;").await[0];
    assert!(
        (mid - (j1 + 10.0) / 2.0).abs() < 1e-6,
        "half way after half the servo time: {mid}"
    );
    sim.advance(ms(100));
    assert!((c.numbers("ReadCmdPos,0,;").await[0] - 10.0).abs() < 1e-6);
    sim.shutdown().await;
}

#[tokio::test]
async fn datasheet_packets_decode_with_the_codec() {
    let sim = Sim::start(Config::ready()).await.unwrap();
    assert_eq!(sim.datasheet_addrs().len(), 3);
    sim.set_io(|io| io.di[2] = true);
    let mut s = TcpStream::connect(sim.datasheet_addrs()[0]).await.unwrap();
    let mut deframer: Box<Deframer<65536>> = Box::default();
    let mut sheets = Vec::new();
    // The stream starts on a packet boundary: its first bytes are the magic.
    let mut magic = [0u8; 4];
    tokio::time::timeout(WAIT, s.read_exact(&mut magic))
        .await
        .unwrap()
        .unwrap();
    assert_eq!(magic, MAGIC);
    deframer.feed(&magic, |_| panic!("4 bytes cannot hold a packet"));
    let mut buf = vec![0u8; 16384];
    while sheets.len() < 3 {
        let n = tokio::time::timeout(WAIT, s.read(&mut buf))
            .await
            .unwrap()
            .unwrap();
        assert!(n > 0, "stream closed");
        deframer.feed(&buf[..n], |item| {
            sheets.push(DataSheet::parse(item.expect("valid header")).expect("valid JSON"));
        });
    }
    let sh = &sheets[0];
    assert_eq!(sh.state.robot_state, Some(FsmState::StandBy));
    assert_eq!(sh.state.enabled, Some(true));
    assert_eq!(sh.box_io.box_di.as_slice(), [0, 0, 1, 0, 0, 0, 0, 0]);
    let j = sh.pos_and_vel.position.unwrap().joints;
    assert_eq!(j.map(|d| d.to_f64()), [0.0, 0.0, 90.0, 0.0, 90.0, 0.0]);
    let tcp = sh.pos_and_vel.pcs_tcp.unwrap().map(|d| d.to_f64());
    assert!(close(&tcp[..3], &[420.0, 0.0, 445.0], 1e-3), "{tcp:?}");
    // The stream follows the robot: the e-stop shows in the next packets.
    sim.set_emergency_stop(true);
    let deadline = tokio::time::Instant::now() + WAIT;
    let mut seen = false;
    while !seen {
        let n = tokio::time::timeout_at(deadline, s.read(&mut buf))
            .await
            .unwrap()
            .unwrap();
        assert!(n > 0);
        deframer.feed(&buf[..n], |item| {
            let sh = DataSheet::parse(item.unwrap()).unwrap();
            seen |= sh.state.robot_state == Some(FsmState::EmergencyStop);
        });
    }
    sim.shutdown().await;
}
