//! End to end: tokio-modbus PLC -> hans-gateway (host, tokio adapter) ->
//! hans-sim, all on 127.0.0.1.

use std::net::{Ipv4Addr, SocketAddr, SocketAddrV4};
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use hans_e2e::{
    code, f32_of, gateway_error, i32_of, text_words, GatewayError, Plc, Rig, SRC_ROBOT_FAIL, WAIT,
};
use hans_gateway::registers as r;
use hans_gateway_linux::{HostOptions, RunningGateway};
use hans_sim::{Config, Fault, FaultRule, Sim};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio_modbus::client::{Reader, Writer};
use tokio_modbus::ExceptionCode;

/// VERSION (register 0) as it reads: the register map's version.
const VERSION: [u8; 2] = hans_gateway::registers::MAP_VERSION.to_be_bytes();
#[tokio::test]
async fn bring_up_from_power_off() {
    let mut rig = Rig::start(Config::default()).await;
    let plc = &mut rig.plc;
    assert_eq!(
        plc.read1(r::STATUS_VERSION).await,
        hans_gateway::registers::MAP_VERSION
    );
    let e = plc.run(0, code::POWER_ON, &[], 1).await;
    assert!(e.done(), "power on: {e:?}");
    let e = plc.run(0, code::ENABLE, &[], 2).await;
    assert!(e.done(), "enable: {e:?}");
    assert_eq!(e.seq, 2);
    plc.wait_reg(r::STATUS_FSM, "FSM StandBy", |v| v == 33)
        .await;
    let flags = plc
        .wait_reg(r::STATUS_FLAGS, "enabled", |v| v & r::FLAG_ENABLED != 0)
        .await;
    assert!(flags & r::FLAG_POWERED != 0 && flags & r::FLAG_VALID != 0);
    let sent: Vec<String> = rig
        .sim
        .received()
        .into_iter()
        // Status reads, and the protocol level asked at the connection.
        .filter(|m| !m.starts_with("Read") && !m.starts_with("PackageVersion"))
        .collect();
    assert_eq!(
        sent,
        [
            "ConnectToBox,;",
            "Electrify,;",
            "StartMaster,;",
            "GrpEnable,0,;"
        ]
    );
    // The heartbeat runs and the status is fresh.
    let hb = plc.read1(r::STATUS_HEARTBEAT).await;
    plc.wait_reg(r::STATUS_HEARTBEAT, "heartbeat", |v| v != hb)
        .await;
    assert!(plc.read1(r::STATUS_AGE_MS).await < 1000);
    rig.stop().await;
}

#[tokio::test]
async fn a_move_is_done_when_the_robot_has_finished_it() {
    let mut rig = Rig::start(Config::ready()).await;
    let target = rig.plc.start_move(0, 10.0, 40.0, 100.0, 7).await;
    let st = Plc::ch_status(0);
    let busy = rig.plc.read1(st).await;
    assert!(
        busy & r::ST_BUSY != 0,
        "busy right after Execute: {busy:#x}"
    );
    rig.plc
        .wait_reg(st, "active", |v| v & (r::ST_ACTIVE | r::ST_DONE) != 0)
        .await;
    let e = rig.plc.wait_end(st).await;
    assert!(e.done(), "{e:?}");
    assert_eq!(e.seq, 7);
    // Done means finished: the robot is no longer moving and is there.
    let s = rig.sim.state();
    assert!(!s.flags.moving, "robot still moving at Done");
    assert!(
        (s.act_joints[0] - f64::from(target[0])).abs() < 0.01,
        "{:?}",
        s.act_joints
    );
    assert_eq!(rig.received("WayPoint").len(), 1);
    assert!(rig.received("ReadRobotState").len() >= 2);
    // Outputs stay while Execute is high, clear when it falls.
    assert_eq!(rig.plc.read1(st).await & r::ST_DONE, r::ST_DONE);
    rig.plc.write(r::channel_base(0), &[0]).await;
    assert_eq!(rig.plc.read1(st).await, 0);
    rig.stop().await;
}

#[tokio::test]
async fn a_refusal_surfaces_as_error_with_its_code() {
    let mut rig = Rig::start(Config::ready()).await;
    rig.sim.faults().add(
        FaultRule::new(Fault::Fail {
            code: 20018,
            detail: String::new(),
        })
        .only("WayPoint")
        .times(1),
    );
    rig.plc.start_move(0, 5.0, 40.0, 100.0, 3).await;
    let e = rig.plc.wait_end(Plc::ch_status(0)).await;
    assert_eq!(
        e.status & (r::ST_ERROR | r::ST_DONE | r::ST_BUSY),
        r::ST_ERROR
    );
    assert_eq!(
        (e.error_id, e.error_source, e.seq),
        (20018, SRC_ROBOT_FAIL, 3)
    );
    // A new edge clears it and runs again.
    rig.plc.write(r::channel_base(0), &[0]).await;
    let e = rig.plc.run(0, code::RESET, &[], 4).await;
    assert!(e.done());
    rig.stop().await;
}

#[tokio::test]
async fn robot_dropping_mid_motion_fails_the_command_and_nothing_is_resent() {
    let mut rig = Rig::start(Config::ready()).await;
    rig.plc.start_move(0, 90.0, 10.0, 100.0, 1).await;
    let st = Plc::ch_status(0);
    rig.plc
        .wait_reg(st, "active", |v| v & r::ST_ACTIVE != 0)
        .await;
    assert_eq!(rig.plc.read1(r::STATUS_ACTIVE_MOTION).await, 1);
    rig.sim.drop_connections();
    let e = rig.plc.wait_end(st).await;
    assert_eq!(
        (e.error_id, e.error_source),
        gateway_error(GatewayError::LinkLost),
        "{e:?}"
    );
    // It reconnects by itself and says so.
    rig.plc
        .wait_reg(r::STATUS_LINK_CONNECTS, "reconnect", |v| v >= 2)
        .await;
    rig.plc.wait_link().await;
    assert_eq!(
        rig.plc.read1(r::STATUS_LINK_LAST_ERROR).await as i32,
        GatewayError::LinkLost.code()
    );
    // New commands work on the new connection. Jobs go in order: had the
    // move been queued again at the reconnection, it would have gone
    // before this one.
    let e = rig.plc.run(1, code::SET_BOX_DO, &[2.0, 1.0], 3).await;
    assert!(e.done(), "{e:?}");
    assert_eq!(
        rig.received("WayPoint").len(),
        1,
        "the move was not sent again"
    );
    rig.plc.write(r::channel_base(0), &[0]).await;
    assert!(rig.plc.run(0, code::STOP, &[], 2).await.done());
    rig.stop().await;
}

#[tokio::test]
async fn a_reply_timeout_fails_the_command_and_resets_the_link() {
    let mut rig = Rig::start(Config::ready()).await;
    rig.plc
        .configure(&[(r::CONFIG_REPLY_TIMEOUT_MS, 200)])
        .await;
    rig.sim
        .faults()
        .add(FaultRule::new(Fault::NoReply).only("SetOverride").times(1));
    let t0 = Instant::now();
    let e = rig.plc.run(1, code::SET_OVERRIDE, &[0.5], 9).await;
    assert_eq!(
        (e.error_id, e.error_source),
        gateway_error(GatewayError::ReplyTimeout),
        "{e:?}"
    );
    assert!(t0.elapsed() >= Duration::from_millis(200));
    rig.plc
        .wait_reg(r::STATUS_LINK_CONNECTS, "reconnect", |v| v >= 2)
        .await;
    rig.plc.wait_link().await;
    let e = rig.plc.run(1, code::SET_OVERRIDE, &[0.5], 10).await;
    assert!(e.done(), "{e:?}");
    let ov = rig.plc.read(r::STATUS_OVERRIDE, 2).await;
    assert_eq!(f32_of(&ov), 0.5);
    rig.stop().await;
}

#[tokio::test]
async fn a_full_queue_refuses_at_once() {
    let mut rig = Rig::start(Config::ready()).await;
    let plc = &mut rig.plc;
    for i in 0..r::TRIGGERS {
        let text = format!("SetBoxDO,{},1,;", i % 8);
        plc.write(r::trigger_text(i), &text_words(&text, 16)).await;
    }
    // Slow replies keep the first jobs in the queue.
    rig.sim.faults().add(
        FaultRule::new(Fault::Delay(Duration::from_millis(20)))
            .only("SetBoxDO")
            .times(16),
    );
    // All sixteen fire in one write: eight fit, eight are refused.
    plc.write(r::TRIG_BITS, &[0xFFFF]).await;
    let errors = plc.read1(r::TRIG_ERROR).await;
    assert_eq!(errors, 0xFF00, "refused at once");
    let ids = plc.read(r::TRIG_ERROR_ID, 32).await;
    for i in 8..16 {
        assert_eq!(i32_of(&ids[2 * i..]), GatewayError::QueueFull.code());
    }
    plc.wait_reg(r::TRIG_BUSY, "queue drained", |v| v == 0)
        .await;
    assert_eq!(plc.read1(r::TRIG_DONE).await, 0x00FF);
    assert_eq!(rig.received("SetBoxDO").len(), 8);
    // Dropping the bits clears the outputs.
    rig.plc.write(r::TRIG_BITS, &[0]).await;
    assert_eq!(rig.plc.read(r::TRIG_BUSY, 4).await, [0, 0, 0, 0]);
    rig.stop().await;
}

#[tokio::test]
async fn two_modbus_clients_at_once() {
    let mut rig = Rig::start(Config::ready()).await;
    let mut hmi = Plc::connect(rig.gw.modbus_addr()).await;
    hmi.wait_reg(r::STATUS_SESSIONS, "two sessions", |v| v == 2)
        .await;
    // The HMI reads without pause until the PLC is done; the PLC waits,
    // after each of its commands, for the HMI to have been served again.
    let reads = Arc::new(AtomicU32::new(0));
    let done = Arc::new(AtomicBool::new(false));
    let (hmi_reads, plc_done) = (reads.clone(), done.clone());
    let hmi_task = tokio::spawn(async move {
        while !plc_done.load(Ordering::Relaxed) {
            let w = hmi.read(r::STATUS_VERSION, 50).await;
            assert_eq!(w[0], hans_gateway::registers::MAP_VERSION);
            hmi_reads.fetch_add(1, Ordering::Relaxed);
        }
    });
    for seq in 0..10 {
        let before = reads.load(Ordering::Relaxed);
        let e = rig
            .plc
            .run(0, code::SET_BOX_DO, &[1.0, f32::from(seq % 2)], seq)
            .await;
        assert!(e.done() && e.seq == seq, "{e:?}");
        let start = Instant::now();
        while reads.load(Ordering::Relaxed) == before {
            assert!(start.elapsed() < WAIT, "the HMI was not served");
            tokio::time::sleep(hans_e2e::POLL_PAUSE).await;
        }
    }
    done.store(true, Ordering::Relaxed);
    hmi_task.await.expect("hmi");
    let reads = reads.load(Ordering::Relaxed);
    assert!(reads >= 10, "the HMI was served ({reads} reads)");
    rig.stop().await;
}

#[tokio::test]
async fn the_watchdog_stops_a_move_without_heartbeat() {
    let mut rig = Rig::start(Config::ready()).await;
    // With a heartbeat, a move runs to Done: a move of 3 s, a period of
    // 2 s (the PLC beats every 50 ms; only a stall of the test of 2 s
    // could trip it). The exact periods are tested in virtual time
    // (gateway/tests/behaviour.rs).
    rig.plc.configure(&[(r::CONFIG_WATCHDOG_MS, 2000)]).await;
    rig.plc.start_move(0, 30.0, 10.0, 100.0, 1).await;
    let st = Plc::ch_status(0);
    let start = Instant::now();
    let mut beat = 0u16;
    let e = loop {
        beat = beat.wrapping_add(1);
        rig.plc.write(r::CONTROL_HEARTBEAT, &[beat]).await;
        let s = rig.plc.read1(st).await;
        if s & (r::ST_DONE | r::ST_ERROR) != 0 {
            break s;
        }
        assert!(start.elapsed() < WAIT);
        tokio::time::sleep(Duration::from_millis(50)).await;
    };
    assert_eq!(e & r::ST_DONE, r::ST_DONE, "with heartbeat: {e:#x}");
    rig.plc.write(r::channel_base(0), &[0]).await;
    // Without one, the watchdog (300 ms now) stops a move of 9 s.
    rig.plc.configure(&[(r::CONFIG_WATCHDOG_MS, 300)]).await;
    rig.plc.start_move(0, 90.0, 10.0, 100.0, 2).await;
    let e = rig.plc.wait_end(st).await;
    assert_eq!(
        (e.error_id, e.error_source),
        gateway_error(GatewayError::Watchdog),
        "{e:?}"
    );
    assert_eq!(rig.plc.read1(r::STATUS_WATCHDOG_TRIPS).await, 1);
    assert_eq!(
        rig.plc.read1(r::STATUS_WATCHDOG).await & 2,
        2,
        "tripped latched"
    );
    let start = Instant::now();
    while rig.received("GrpStop").is_empty() {
        assert!(start.elapsed() < WAIT, "no GrpStop sent");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    rig.plc.write(r::CONTROL_HEARTBEAT, &[0xBEEF]).await;
    assert_eq!(
        rig.plc.read1(r::STATUS_WATCHDOG).await & 2,
        0,
        "latch cleared by heartbeat"
    );
    rig.stop().await;
}

#[tokio::test]
async fn stop_aborts_a_running_move_from_the_other_channel() {
    let mut rig = Rig::start(Config::ready()).await;
    rig.plc.start_move(0, 90.0, 10.0, 100.0, 5).await;
    let st = Plc::ch_status(0);
    rig.plc
        .wait_reg(st, "active", |v| v & r::ST_ACTIVE != 0)
        .await;
    let e = rig.plc.run(1, code::STOP, &[], 6).await;
    assert!(e.done(), "{e:?}");
    let e = rig.plc.wait_end(st).await;
    assert_eq!(
        e.status & (r::ST_ABORTED | r::ST_ERROR | r::ST_DONE),
        r::ST_ABORTED
    );
    rig.stop().await;
}

async fn raw_frame(s: &mut TcpStream, frame: &[u8]) -> Vec<u8> {
    s.write_all(frame).await.expect("write");
    let mut hdr = [0u8; 7];
    tokio::time::timeout(WAIT, s.read_exact(&mut hdr))
        .await
        .expect("reply in time")
        .expect("read");
    let len = usize::from(u16::from_be_bytes([hdr[4], hdr[5]])) - 1;
    let mut pdu = vec![0u8; len];
    s.read_exact(&mut pdu).await.expect("read pdu");
    pdu
}

#[tokio::test]
async fn malformed_frames_get_exceptions_and_harm_no_other_client() {
    let mut rig = Rig::start(Config::ready()).await;
    let addr = SocketAddr::V4(rig.gw.modbus_addr());
    let mut s = TcpStream::connect(addr).await.expect("connect");
    // Unknown function code -> 01.
    assert_eq!(
        raw_frame(&mut s, &[0, 1, 0, 0, 0, 2, 1, 0x2B]).await,
        [0xAB, 1]
    );
    // Function code with the exception bit set -> 01.
    assert_eq!(
        raw_frame(&mut s, &[0, 1, 0, 0, 0, 2, 1, 0x90]).await,
        [0x90, 1]
    );
    // Too many registers -> 03.
    assert_eq!(
        raw_frame(&mut s, &[0, 2, 0, 0, 0, 6, 1, 3, 0, 0, 0, 200]).await,
        [0x83, 3]
    );
    // Unmapped address -> 02; read-only register written -> 02.
    assert_eq!(
        raw_frame(&mut s, &[0, 3, 0, 0, 0, 6, 1, 3, 0, 64, 0, 1]).await,
        [0x83, 2]
    );
    assert_eq!(
        raw_frame(&mut s, &[0, 4, 0, 0, 0, 6, 1, 6, 0, 0, 0, 1]).await,
        [0x86, 2]
    );
    // Byte count that does not match the quantity -> 03.
    assert_eq!(
        raw_frame(
            &mut s,
            &[0, 5, 0, 0, 0, 10, 1, 0x10, 0, 140, 0, 1, 3, 0, 1, 2]
        )
        .await,
        [0x90, 3]
    );
    // FC 16 too short to hold its byte count -> 03.
    assert_eq!(
        raw_frame(&mut s, &[0, 6, 0, 0, 0, 5, 1, 0x10, 0, 140, 0]).await,
        [0x90, 3]
    );
    // Coil value other than 0x0000/0xFF00 -> 03.
    assert_eq!(
        raw_frame(&mut s, &[0, 7, 0, 0, 0, 6, 1, 5, 0, 0, 0x12, 0x34]).await,
        [0x85, 3]
    );
    // A frame split across segments is answered once whole.
    s.write_all(&[0, 8, 0, 0, 0, 6]).await.expect("write");
    tokio::time::sleep(Duration::from_millis(50)).await;
    assert_eq!(
        raw_frame(&mut s, &[1, 3, 0, 0, 0, 1]).await,
        [3, 2, VERSION[0], VERSION[1]]
    );
    // FC 5 echoes the request.
    let coil = 16 * r::CONTROL_HEARTBEAT;
    let c = coil.to_be_bytes();
    assert_eq!(
        raw_frame(&mut s, &[0, 9, 0, 0, 0, 6, 1, 5, c[0], c[1], 0xFF, 0]).await,
        [5, c[0], c[1], 0xFF, 0]
    );
    // Not Modbus (protocol id 0x1234): that connection is closed ...
    let mut bad = TcpStream::connect(addr).await.expect("connect");
    bad.write_all(&[0, 1, 0x12, 0x34, 0, 6, 1, 3, 0, 0, 0, 1])
        .await
        .expect("write");
    let mut buf = [0u8; 16];
    let n = tokio::time::timeout(WAIT, bad.read(&mut buf))
        .await
        .expect("closed in time");
    assert!(matches!(n, Ok(0) | Err(_)), "connection not closed: {n:?}");
    // ... and the others go on.
    assert_eq!(
        raw_frame(&mut s, &[0, 10, 0, 0, 0, 6, 1, 4, 0, 0, 0, 1]).await,
        [4, 2, VERSION[0], VERSION[1]]
    );
    assert_eq!(
        rig.plc.read1(r::STATUS_VERSION).await,
        hans_gateway::registers::MAP_VERSION
    );
    // tokio-modbus sees the same exceptions.
    let e = rig
        .plc
        .ctx
        .read_holding_registers(64, 1)
        .await
        .expect("transport");
    assert_eq!(e, Err(ExceptionCode::IllegalDataAddress));
    let e = rig
        .plc
        .ctx
        .write_single_register(r::CONFIG_POLL_MS, 500)
        .await
        .expect("transport");
    assert_eq!(e, Ok(()));
    let e = rig
        .plc
        .ctx
        .write_single_register(r::CONTROL_CONFIG_COMMAND, 1)
        .await
        .expect("transport");
    assert_eq!(
        e,
        Err(ExceptionCode::IllegalDataValue),
        "invalid poll period refused"
    );
    assert_eq!(
        rig.plc.read1(r::CONTROL_CONFIG_BAD_ADDR).await,
        r::CONFIG_POLL_MS
    );
    let coils = rig
        .plc
        .ctx
        .read_coils(16 * r::STATUS_VERSION, 16)
        .await
        .expect("transport")
        .expect("coils");
    assert!(coils[8], "version 1.0: bit 8 of register 0");
    rig.stop().await;
}

/// Finding: a 124-register FC 16 write (MBAP length 255) closed the
/// connection. The Modbus specification answers a quantity out of range
/// with exception 03; the connection stays usable.
#[tokio::test]
async fn an_oversized_write_gets_exception_03_and_the_connection_stays() {
    let rig = Rig::start(Config::ready()).await;
    let mut s = TcpStream::connect(SocketAddr::V4(rig.gw.modbus_addr()))
        .await
        .expect("connect");
    for (tid, regs) in [(1u8, 124u16), (2, 300)] {
        let bytes = 2 * regs;
        let length = 7 + bytes;
        let mut frame = vec![0, tid, 0, 0];
        frame.extend(length.to_be_bytes());
        frame.extend([1, 0x10, 0, 140]);
        frame.extend(regs.to_be_bytes());
        frame.push(bytes as u8); // wraps for 300: the quantity is checked first
        frame.extend(std::iter::repeat_n(0u8, usize::from(bytes)));
        assert_eq!(
            raw_frame(&mut s, &frame).await,
            [0x90, 3],
            "{regs} registers"
        );
    }
    // The same connection goes on.
    assert_eq!(
        raw_frame(&mut s, &[0, 3, 0, 0, 0, 6, 1, 3, 0, 0, 0, 1]).await,
        [3, 2, VERSION[0], VERSION[1]]
    );
    rig.stop().await;
}

#[tokio::test]
async fn raw_commands_reach_every_protocol_command() {
    let mut rig = Rig::start(Config::ready()).await;
    let (e, reply) = rig.plc.raw("ReadActPos,0,;", 11).await;
    assert!(e.done(), "{e:?}");
    assert_eq!(e.seq, 11);
    assert!(
        reply.starts_with("ReadActPos,OK,") && reply.ends_with(";"),
        "{reply}"
    );
    // A command the typed channel does not have, no terminator given.
    let (e, reply) = rig.plc.raw("ReadRobotModel", 12).await;
    assert!(e.done(), "{e:?}");
    assert_eq!(reply, "ReadRobotModel,OK,5KG,;");
    // A refused one: the reply text and the code.
    rig.sim.faults().add(
        FaultRule::new(Fault::Fail {
            code: 20018,
            detail: "busy".into(),
        })
        .only("GrpReset")
        .times(1),
    );
    let (e, reply) = rig.plc.raw("GrpReset,0,;", 13).await;
    assert_eq!((e.error_id, e.error_source), (20018, SRC_ROBOT_FAIL));
    assert_eq!(reply, "GrpReset,Fail,20018,busy,;");
    // Text the grammar cannot read is refused by the gateway.
    let (e, _) = rig.plc.raw(",,;", 14).await;
    assert_eq!(
        (e.error_id, e.error_source),
        gateway_error(GatewayError::BadParameter)
    );
    assert!(rig.received("ReadRobotModel").len() == 1);
    rig.stop().await;
}

/// Finding: `SetBoxDO,OK,1,;` (an OK with a value the document does not
/// list, as newer firmware might send) ended in 39502. The robot accepted
/// the command: where the gateway does not use the values it is Done;
/// where it does (code 40's results) the reply is still checked.
#[tokio::test]
async fn an_ok_reply_with_extra_values_is_success_where_values_are_unused() {
    let mut rig = Rig::start(Config::ready()).await;
    let odd = |name: &str, reply: &str| {
        FaultRule::new(Fault::Garbage(reply.as_bytes().to_vec()))
            .only(name)
            .times(1)
    };
    rig.sim.faults().add(odd("SetBoxDO", "SetBoxDO,OK,1,;"));
    let e = rig.plc.run(0, code::SET_BOX_DO, &[1.0, 1.0], 1).await;
    assert!(e.done(), "{e:?}");
    rig.sim
        .faults()
        .add(odd("SetOverride", "SetOverride,OK,0.5,extra,;"));
    let e = rig.plc.run(0, code::SET_OVERRIDE, &[0.5], 2).await;
    assert!(e.done(), "{e:?}");
    assert_eq!(f32_of(&rig.plc.read(r::STATUS_OVERRIDE, 2).await), 0.5);
    // The values matter here: a short ReadActPos is still a bad reply (for
    // every ReadActPos meanwhile: the status polls read it too).
    rig.sim
        .faults()
        .add(FaultRule::new(Fault::Garbage(b"ReadActPos,OK,1,2,;".to_vec())).only("ReadActPos"));
    let e = rig.plc.run(0, code::READ_ACT_POS, &[], 3).await;
    assert_eq!(
        (e.error_id, e.error_source),
        gateway_error(GatewayError::BadReply),
        "{e:?}"
    );
    rig.sim.faults().clear();
    // And a reply naming another command is still a mismatch.
    rig.sim.faults().add(odd("SetBoxCO", "SetBoxDO,OK,;"));
    let e = rig.plc.run(0, code::SET_BOX_CO, &[1.0, 1.0], 4).await;
    assert_eq!(
        (e.error_id, e.error_source),
        gateway_error(GatewayError::ReplyMismatch),
        "{e:?}"
    );
    rig.stop().await;
}

/// Finding (doc): REGISTERS.md said only that STATUS reads 0 when Execute
/// falls. It now says exactly what clears (outcome bits, ERROR_ID,
/// ERROR_SOURCE) and what stays until the next rising edge (echoes,
/// results); this pins that behaviour.
#[tokio::test]
async fn when_execute_falls_the_outcome_clears_and_the_echoes_stay() {
    let mut rig = Rig::start(Config::ready()).await;
    let b = r::channel_base(0);
    let e = rig.plc.run(0, 999, &[], 41).await;
    assert_eq!(
        (e.error_id, e.error_source),
        gateway_error(GatewayError::BadParameter)
    );
    let w = rig.plc.read(b + r::CH_STATUS, 6).await;
    assert_eq!(
        w,
        [0, 41, 0, 0, 0, 999],
        "status, seq, error id, source, command"
    );
    let e = rig.plc.run(0, code::READ_ACT_POS, &[], 42).await;
    assert!(e.done(), "{e:?}");
    let results = rig.plc.read(b + r::CH_RESULTS, 48).await;
    let j = rig.plc.read(r::STATUS_JOINTS, 12).await;
    assert_eq!(
        &results[..12],
        &j[..],
        "R0-R5 are the joints, kept after Execute fell"
    );
    assert_eq!(rig.plc.read(b + r::CH_STATUS, 2).await, [0, 42]);
    rig.stop().await;
}

#[tokio::test]
async fn a_trigger_entry_fires_on_its_bit() {
    let mut rig = Rig::start(Config::ready()).await;
    rig.plc
        .write(r::trigger_text(2), &text_words("SetBoxDO,3,1,;", 16))
        .await;
    let coil = 16 * r::TRIG_BITS + 2;
    rig.plc
        .ctx
        .write_single_coil(coil, true)
        .await
        .expect("transport")
        .expect("coil");
    rig.plc
        .wait_reg(r::TRIG_DONE, "trigger done", |v| v == 1 << 2)
        .await;
    assert!(rig.sim.io().do_[3], "box DO3 set");
    rig.plc
        .wait_reg(r::STATUS_BOX_DO, "status mirror shows DO3", |v| {
            v & (1 << 3) != 0
        })
        .await;
    // An empty entry ends in Error 39603.
    rig.plc
        .ctx
        .write_single_coil(16 * r::TRIG_BITS + 5, true)
        .await
        .expect("transport")
        .expect("coil");
    let ids = rig.plc.read(r::TRIG_ERROR_ID + 10, 2).await;
    assert_eq!(i32_of(&ids), GatewayError::TriggerEmpty.code());
    assert_eq!(rig.plc.read1(r::TRIG_ERROR).await, 1 << 5);
    rig.stop().await;
}

#[tokio::test]
async fn listen_mode_the_controller_connects_and_a_reconnect_replaces() {
    let sim = Sim::start(Config::ready()).await.expect("sim");
    let mut opts = HostOptions::new(
        SocketAddrV4::new(Ipv4Addr::LOCALHOST, 0),
        SocketAddrV4::new(Ipv4Addr::LOCALHOST, 1),
    );
    opts.robot = None;
    opts.robot_listen = Some(SocketAddrV4::new(Ipv4Addr::LOCALHOST, 0));
    let gw = RunningGateway::start(opts).expect("gateway");
    let mut plc = Plc::connect(gw.modbus_addr()).await;
    assert_eq!(plc.read1(r::STATUS_LINK_STATE).await, 2, "listening");
    let listen = SocketAddr::V4(gw.robot_listen_addr().expect("listen addr"));
    sim.connect_out(listen).await.expect("connect out");
    plc.wait_link().await;
    assert!(plc.run(0, code::SET_BOX_DO, &[2.0, 1.0], 1).await.done());
    // The controller's connect signal again: the new connection replaces
    // the old one.
    sim.connect_out(listen).await.expect("connect out again");
    plc.wait_reg(r::STATUS_LINK_CONNECTS, "replaced", |v| v >= 2)
        .await;
    assert!(plc.run(0, code::SET_BOX_DO, &[2.0, 0.0], 2).await.done());
    assert!(!sim.io().do_[2]);
    drop(plc);
    gw.stop();
    sim.shutdown().await;
}

fn temp_path(name: &str) -> std::path::PathBuf {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    std::env::temp_dir().join(format!("hans-gw-{}-{nanos}-{name}", std::process::id()))
}

#[tokio::test]
async fn configuration_and_triggers_persist_and_a_failed_save_is_exception_04() {
    let sim = Sim::start(Config::ready()).await.expect("sim");
    let robot = match sim.command_addr() {
        SocketAddr::V4(a) => a,
        SocketAddr::V6(_) => unreachable!(),
    };
    let path = temp_path("config");
    let mut opts = HostOptions::new(SocketAddrV4::new(Ipv4Addr::LOCALHOST, 0), robot);
    opts.config_file = Some(path.clone());
    let gw = RunningGateway::start(opts.clone()).expect("gateway");
    let mut plc = Plc::connect(gw.modbus_addr()).await;
    plc.write(r::trigger_text(7), &text_words("GrpStop,0,;", 16))
        .await;
    let result = plc
        .configure(&[(r::CONFIG_POLL_MS, 50), (r::CONFIG_WATCHDOG_MS, 1000)])
        .await;
    assert_eq!(result, 0, "applied and saved to the file");
    assert_eq!(plc.read1(r::CONTROL_SAVES).await, 1);
    drop(plc);
    gw.stop();
    let gw = RunningGateway::start(opts).expect("gateway again");
    let mut plc = Plc::connect(gw.modbus_addr()).await;
    assert_eq!(plc.read1(r::CONFIG_POLL_MS).await, 50);
    assert_eq!(plc.read1(r::CONFIG_WATCHDOG_MS).await, 1000);
    let t = plc.read(r::trigger_text(7), 16).await;
    assert_eq!(hans_e2e::words_text(&t), "GrpStop,0,;");
    drop(plc);
    gw.stop();
    let _ = std::fs::remove_file(&path);
    // Storage that cannot be written.
    let mut opts = HostOptions::new(SocketAddrV4::new(Ipv4Addr::LOCALHOST, 0), robot);
    opts.config_file = Some(temp_path("missing-dir").join("config"));
    let gw = RunningGateway::start(opts).expect("gateway");
    let mut plc = Plc::connect(gw.modbus_addr()).await;
    let e = plc
        .ctx
        .write_single_register(r::CONTROL_CONFIG_COMMAND, 1)
        .await
        .expect("transport");
    assert_eq!(e, Err(ExceptionCode::ServerDeviceFailure));
    assert_eq!(plc.read1(r::CONTROL_CONFIG_RESULT).await, 2);
    drop(plc);
    gw.stop();
    sim.shutdown().await;
}

#[tokio::test]
async fn the_datasheet_port_can_replace_status_polling() {
    let mut rig = Rig::start(Config::ready()).await;
    let port = rig.sim.datasheet_addrs()[0].port();
    rig.plc
        .configure(&[
            (r::CONFIG_STATUS_SOURCE, 1),
            (r::CONFIG_DATASHEET_PORT, port),
        ])
        .await;
    assert_eq!(rig.plc.read1(r::STATUS_SOURCE).await, 1);
    rig.sim.clear_received();
    let ticks = rig.plc.read1(r::STATUS_HEARTBEAT).await;
    // An input changes: only the DataSheet can bring it now.
    rig.sim.set_io(|io| io.di[2] = true);
    rig.plc
        .wait_reg(r::STATUS_BOX_DI, "the input from the DataSheet", |v| {
            v & 4 != 0
        })
        .await;
    // Five poll periods by the gateway's own clock (its heartbeat counts
    // them), in which polling would have made four rounds at least.
    rig.plc
        .wait_reg(r::STATUS_HEARTBEAT, "five poll periods", |v| {
            v.wrapping_sub(ticks) >= 5
        })
        .await;
    assert_eq!(rig.plc.read1(r::STATUS_FSM).await, 33);
    // At most the rest of the round under way when the source changed.
    let round = [
        "ReadRobotState",
        "ReadCurFSM",
        "ReadActPos",
        "ReadBoxDI",
        "ReadBoxDO",
        "ReadBoxCI",
        "ReadBoxCO",
        "ReadEI",
        "ReadEO",
    ];
    let received = rig.sim.received();
    let reads: Vec<&str> = received
        .iter()
        .filter_map(|m| m.split(',').next())
        .filter(|name| name.starts_with("Read"))
        .collect();
    assert!(
        round.ends_with(&reads),
        "still polling: {:?}",
        rig.sim.received()
    );
    // A move still completes (its end is polled on the command port).
    rig.plc.start_move(0, 3.0, 30.0, 100.0, 4).await;
    let e = rig.plc.wait_end(Plc::ch_status(0)).await;
    assert!(e.done(), "{e:?}");
    let j = rig.plc.joints().await;
    let s = rig.sim.state();
    assert!(
        (f64::from(j[0]) - s.act_joints[0]).abs() < 0.5,
        "{j:?} vs {:?}",
        s.act_joints
    );
    rig.stop().await;
}
