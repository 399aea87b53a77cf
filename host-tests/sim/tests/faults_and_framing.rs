//! One message at a time, incomplete and unparseable input, every fault
//! injection, connection control and client mode, over TCP.

mod support;

use std::time::{Duration, Instant};

use hans_sim::{Config, Fault, FaultRule, FsmState, Sim};
use support::{Client, WAIT};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};

async fn sim() -> Sim {
    Sim::start(Config {
        datasheet_ports: vec![],
        ..Config::ready()
    })
    .await
    .unwrap()
}

#[tokio::test]
async fn several_messages_in_one_read_answer_only_the_first() {
    let sim = sim().await;
    let mut c = Client::connect(sim.command_addr()).await;
    c.send_raw(b"ReadCurFSM,0,;SetBoxDO,1,1,;ReadRobotModel,;")
        .await;
    assert_eq!(c.read().await, "ReadCurFSM,OK,33,;");
    assert_eq!(
        c.read_within(Duration::from_millis(400)).await,
        None,
        "the rest is discarded"
    );
    assert!(!sim.io().do_[1], "the discarded SetBoxDO did not run");
    // The connection still works.
    assert_eq!(c.call("ReadRobotModel,;").await, "ReadRobotModel,OK,5KG,;");
    sim.shutdown().await;
}

/// A simulator that waits 10 s before it answers an incomplete message
/// (200 ms by default): the pause a test makes between the parts of a
/// split message cannot end it, however loaded the machine.
async fn patient_sim() -> Sim {
    Sim::start(Config {
        datasheet_ports: vec![],
        incomplete_timeout: Duration::from_secs(10),
        ..Config::ready()
    })
    .await
    .unwrap()
}

#[tokio::test]
async fn a_split_request_is_one_message_and_an_incomplete_one_is_answered() {
    // The parts sent 20 ms apart: two reads of the simulator (unless the
    // machine is slow; then one, and the answers are the same).
    let patient = patient_sim().await;
    let mut c = Client::connect(patient.command_addr()).await;
    c.send_raw(b"ReadCur").await;
    tokio::time::sleep(Duration::from_millis(20)).await;
    c.send_raw(b"FSM,0,;").await;
    assert_eq!(c.read().await, "ReadCurFSM,OK,33,;");
    // A `;` ending a message split across reads is that message's end.
    c.send_raw(b"ReadCurFSM,0,").await;
    tokio::time::sleep(Duration::from_millis(20)).await;
    c.send_raw(b";").await;
    assert_eq!(c.read().await, "ReadCurFSM,OK,33,;");
    patient.shutdown().await;
    // No ';' and then silence: the invalid-command answer, after the quiet
    // period (200 ms).
    let sim = sim().await;
    let mut c = Client::connect(sim.command_addr()).await;
    let t = Instant::now();
    c.send_raw(b"ReadCurFSM,0,").await;
    assert_eq!(c.read().await, "errorcmd,20007,;");
    assert!(
        t.elapsed() >= Duration::from_millis(200),
        "after the quiet period"
    );
    assert_eq!(c.call("ReadCurFSM,0,;").await, "ReadCurFSM,OK,33,;");
    sim.shutdown().await;
}

#[tokio::test]
async fn an_empty_message_gets_the_invalid_command_answer() {
    let sim = sim().await;
    let mut c = Client::connect(sim.command_addr()).await;
    // A lone `;` is a message with nothing in it: answered at once, like
    // any message that cannot be read, instead of leaving the client to
    // its timeout.
    c.send_raw(b";").await;
    assert_eq!(c.read().await, "errorcmd,20007,;");
    // Whitespace before it does not make it a message.
    c.send_raw(b" \r\n;").await;
    assert_eq!(c.read().await, "errorcmd,20007,;");
    // It is the first message of its read: what follows is discarded.
    c.send_raw(b";ReadCurFSM,0,;").await;
    assert_eq!(c.read().await, "errorcmd,20007,;");
    assert_eq!(
        c.read_within(Duration::from_millis(400)).await,
        None,
        "one answer per read"
    );
    // Whitespace alone (a line end sent after the message) is no message.
    assert_eq!(c.call("ReadCurFSM,0,;").await, "ReadCurFSM,OK,33,;");
    c.send_raw(b"\r\n").await;
    assert_eq!(c.read_within(Duration::from_millis(400)).await, None);
    // A doubled `;` after a message in the same read stays discarded.
    assert_eq!(c.call("ReadCurFSM,0,;;").await, "ReadCurFSM,OK,33,;");
    assert_eq!(c.read_within(Duration::from_millis(400)).await, None);
    assert!(
        sim.received().iter().all(|m| !m.trim().is_empty()),
        "empty messages are not recorded as received"
    );
    sim.shutdown().await;
}

#[tokio::test]
async fn bad_input_gets_typed_refusals() {
    let sim = sim().await;
    let mut c = Client::connect(sim.command_addr()).await;
    assert_eq!(c.call("WayPoint,0,1,2,;").await, "WayPoint,Fail,20007,;");
    assert_eq!(
        c.call("SetOverride,0,1.5,;").await,
        "SetOverride,Fail,20006,;"
    );
    assert_eq!(c.call("SetBoxDO,9,1,;").await, "SetBoxDO,Fail,20006,;");
    assert_eq!(c.call("ReadVersion,;").await, "ReadVersion,Fail,20005,;");
    assert_eq!(c.call("Pose Trans,0,;").await, "errorcmd,20007,;");
    assert_eq!(c.call("Gr\u{7f}pStop,0,;").await, "errorcmd,20007,;");
    c.send_raw(b"\xff\x00;").await;
    assert_eq!(c.read().await, "errorcmd,20007,;");
    assert_eq!(c.call("GrpStop,OK,;").await, "GrpStop,Fail,20007,;");
    // Every form the document and NOTES allow.
    assert_eq!(c.call("OSCmd,1;").await, "OSCmd,OK,;");
    // 48 V off; the V6 level's reply has the 12 V output too (HR6.3.3).
    assert_eq!(
        c.call("ReadBoxInfo,;").await,
        "ReadBoxInfo,OK,1,0,0.000,0.000,0,0,12.000,0.500,;"
    );
    assert_eq!(c.call("ConnectToBox,0,;").await, "ConnectToBox,OK,;");
    assert_eq!(
        c.call("ReadBoxCO,0,1,2,3,4,5,6,7,;;").await,
        "ReadBoxCO,OK,0,0,0,0,0,0,0,0,;"
    );
    assert_eq!(c.call(" SetBoxDO , 5, 1 ,;").await, "SetBoxDO,OK,;");
    assert_eq!(c.call("ReadBoxDO,5,;").await, "ReadBoxDO,OK,1,;");
    sim.shutdown().await;
}

#[tokio::test]
async fn delay_split_garbage_fail_and_errorcmd_faults() {
    let sim = sim().await;
    let mut c = Client::connect(sim.command_addr()).await;
    sim.faults().once(Fault::Delay(Duration::from_millis(300)));
    let t = Instant::now();
    assert_eq!(c.call("ReadCurFSM,0,;").await, "ReadCurFSM,OK,33,;");
    assert!(t.elapsed() >= Duration::from_millis(300));

    // Two chunks, 1 s apart: the test reads the first alone unless it
    // stalls for a second.
    sim.faults().once(Fault::Split {
        chunk: 12,
        pause: Duration::from_secs(1),
    });
    c.send_raw(b"ReadRobotModel,;").await;
    let mut first = [0u8; 64];
    let n = tokio::time::timeout(WAIT, c.stream.read(&mut first))
        .await
        .unwrap()
        .unwrap();
    assert_eq!(
        &first[..n],
        b"ReadRobotMod",
        "the first segment is one chunk"
    );
    let mut rest = Vec::new();
    while rest.len() < "el,OK,5KG,;".len() {
        let mut b = [0u8; 64];
        let n = tokio::time::timeout(WAIT, c.stream.read(&mut b))
            .await
            .unwrap()
            .unwrap();
        assert!(n > 0);
        rest.extend_from_slice(&b[..n]);
    }
    assert_eq!(rest, b"el,OK,5KG,;");

    // Garbage ending in ';' is one bad frame; the reply follows intact.
    sim.faults()
        .once(Fault::GarbageBefore(b"\xff\x00junk;".to_vec()));
    c.send_raw(b"ReadCurFSM,0,;").await;
    let g = c.read().await;
    assert!(g.starts_with("<frame error"), "{g}");
    assert_eq!(c.read().await, "ReadCurFSM,OK,33,;");

    sim.faults().once(Fault::Garbage(b"#?!;".to_vec()));
    c.send_raw(b"SetBoxDO,2,1,;").await;
    assert_eq!(c.read().await, "#?!;");
    assert!(!sim.io().do_[2], "garbage instead of a reply: not executed");

    sim.faults().add(
        FaultRule::new(Fault::Fail {
            code: 20018,
            detail: "robot busy, try later".into(),
        })
        .only("SetBoxDO")
        .times(1),
    );
    assert_eq!(
        c.call("ReadCurFSM,0,;").await,
        "ReadCurFSM,OK,33,;",
        "other commands unaffected"
    );
    assert_eq!(
        c.call("SetBoxDO,2,1,;").await,
        "SetBoxDO,Fail,20018,robot busy, try later,;"
    );
    assert!(!sim.io().do_[2]);
    assert_eq!(c.call("SetBoxDO,2,1,;").await, "SetBoxDO,OK,;");

    sim.faults().once(Fault::ErrorCmd);
    assert_eq!(c.call("ReadCurFSM,0,;").await, "errorcmd,20007,;");
    sim.shutdown().await;
}

#[tokio::test]
async fn no_reply_and_dropped_connection_still_execute() {
    let sim = sim().await;
    let mut c = Client::connect(sim.command_addr()).await;
    sim.faults().once(Fault::NoReply);
    c.send_raw(b"SetBoxDO,4,1,;").await;
    assert_eq!(c.read_within(Duration::from_millis(300)).await, None);
    assert!(sim.io().do_[4], "executed, reply lost");
    sim.faults().add(
        FaultRule::new(Fault::DropConnection)
            .only("WayPoint")
            .times(1),
    );
    c.send_raw(b"WayPoint,0,0,0,0,0,0,0,90,0,90,0,90,0,TCP,Base,50,100,0,0,1,0,0,0,1,;")
        .await;
    assert_eq!(c.read_within(WAIT).await, None, "closed without a reply");
    assert_eq!(
        sim.fsm(),
        FsmState::Moving,
        "the move runs on without a client"
    );
    let mut c = Client::connect(sim.command_addr()).await;
    assert_eq!(c.fsm().await, 25);
    sim.shutdown().await;
}

#[tokio::test]
async fn drop_and_refuse_connections() {
    let sim = sim().await;
    let addr = sim.command_addr();
    let mut a = Client::connect(addr).await;
    let mut b = Client::connect(addr).await;
    assert_eq!(a.fsm().await, 33);
    assert_eq!(b.fsm().await, 33);
    sim.drop_connections();
    assert_eq!(a.read_within(WAIT).await, None);
    assert_eq!(b.read_within(WAIT).await, None);
    // 2 s: the test tries while the period lasts unless it stalls that
    // long.
    sim.refuse_connections(Duration::from_secs(2));
    // Refused while the period lasts (the listener is closed at once).
    let mut refused = false;
    for _ in 0..50 {
        match TcpStream::connect(addr).await {
            Err(e) if e.kind() == std::io::ErrorKind::ConnectionRefused => {
                refused = true;
                break;
            }
            _ => tokio::time::sleep(Duration::from_millis(5)).await,
        }
    }
    assert!(refused, "connections were not refused");
    // ...and accepted again afterwards, on the same port.
    let deadline = Instant::now() + WAIT;
    loop {
        if let Ok(s) = TcpStream::connect(addr).await {
            drop(s);
            break;
        }
        assert!(Instant::now() < deadline, "never listened again");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let mut c = Client::connect(addr).await;
    assert_eq!(c.fsm().await, 33);
    sim.shutdown().await;
}

#[tokio::test]
async fn several_clients_are_served_at_once() {
    let sim = sim().await;
    let mut tasks = Vec::new();
    for i in 0..8 {
        let addr = sim.command_addr();
        tasks.push(tokio::spawn(async move {
            let mut c = Client::connect(addr).await;
            for _ in 0..50 {
                assert_eq!(c.call("ReadCurFSM,0,;").await, "ReadCurFSM,OK,33,;");
            }
            c.ok(&format!("SetBoxDO,{i},1,;")).await;
        }));
    }
    for t in tasks {
        tokio::time::timeout(WAIT, t).await.unwrap().unwrap();
    }
    assert_eq!(sim.io().do_, [true; 8]);
    assert_eq!(sim.received().len(), 8 * 51);
    sim.shutdown().await;
}

#[tokio::test]
async fn client_mode_connects_out_and_reconnecting_replaces_the_connection() {
    let host = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let sim = sim().await;
    sim.connect_out(host.local_addr().unwrap()).await.unwrap();
    let (mut first, _) = tokio::time::timeout(WAIT, host.accept())
        .await
        .unwrap()
        .unwrap();
    first.write_all(b"ReadCurFSM,0,;").await.unwrap();
    let mut buf = [0u8; 64];
    let n = tokio::time::timeout(WAIT, first.read(&mut buf))
        .await
        .unwrap()
        .unwrap();
    assert_eq!(&buf[..n], b"ReadCurFSM,OK,33,;");
    // The connect signal again: the old connection closes, a new one opens.
    sim.connect_out(host.local_addr().unwrap()).await.unwrap();
    let (mut second, _) = tokio::time::timeout(WAIT, host.accept())
        .await
        .unwrap()
        .unwrap();
    let n = tokio::time::timeout(WAIT, first.read(&mut buf))
        .await
        .unwrap()
        .unwrap_or(0);
    assert_eq!(n, 0, "the old connection is closed");
    second.write_all(b"ReadRobotModel,;").await.unwrap();
    let n = tokio::time::timeout(WAIT, second.read(&mut buf))
        .await
        .unwrap()
        .unwrap();
    assert_eq!(&buf[..n], b"ReadRobotModel,OK,5KG,;");
    sim.shutdown().await;
}

#[tokio::test]
async fn reboot_drops_connections_refuses_then_comes_back_powered_off() {
    let sim = Sim::start(Config {
        datasheet_ports: vec![],
        reboot_time: Duration::from_millis(300),
        ..Config::ready()
    })
    .await
    .unwrap();
    let mut c = Client::connect(sim.command_addr()).await;
    assert_eq!(c.call("OSCmd,2,;").await, "OSCmd,OK,;");
    assert_eq!(c.read_within(WAIT).await, None, "connection dropped");
    let deadline = Instant::now() + WAIT;
    let mut c = loop {
        if let Ok(s) = TcpStream::connect(sim.command_addr()).await {
            drop(s);
            break Client::connect(sim.command_addr()).await;
        }
        assert!(Instant::now() < deadline);
        tokio::time::sleep(Duration::from_millis(50)).await;
    };
    assert_eq!(c.fsm().await, 2);
    sim.shutdown().await;
}
