//! The gateway firmware under QEMU, end to end: a Modbus client on the host
//! drives it like a PLC, the robot simulator (in this process, on 127.0.0.1)
//! plays the controller and says what it received.
//!
//! Register addresses are the gateway's (`gateway/REGISTERS.md`); they are
//! repeated here on purpose: a test that imported them could not notice the
//! map moving under the PLCs.

use std::net::TcpStream;
use std::os::fd::AsRawFd;
use std::time::Duration;

use qemu_tests::{connect_retry, f32_from_words, f32_to_words, must, request_line, Plc};
use tokio_modbus::ExceptionCode;

// Status block.
const STATUS_LINK_STATE: u16 = 3;
const STATUS_LINK_CONNECTS: u16 = 4;
const STATUS_FSM: u16 = 6;
const STATUS_FLAGS: u16 = 7;
const STATUS_JOINTS: u16 = 14;
const STATUS_SESSIONS: u16 = 46;
const STATUS_LEN: u16 = 50;
const LINK_CONNECTED: u16 = 3;
const FLAG_MOVING: u16 = 1 << 0;
const FLAG_ENABLED: u16 = 1 << 1;
const FLAG_POWERED: u16 = 1 << 6;
const FLAG_VALID: u16 = 1 << 15;
const FSM_STANDBY: u16 = 33;

// Command channel 0.
const CH0: u16 = 200;
const CH_CONTROL: u16 = 0;
const CH_COMMAND: u16 = 1;
const CH_SEQUENCE: u16 = 2;
const CH_PARAMS: u16 = 4;
const CH_STATUS: u16 = 60;
const CH_SEQ_ECHO: u16 = 61;
const ST_DONE: u16 = 1 << 1;
const ST_ERROR: u16 = 1 << 2;
// `execute` writes command + sequence and reads status + echo as pairs.
const _: () = assert!(CH_SEQUENCE == CH_COMMAND + 1 && CH_SEQ_ECHO == CH_STATUS + 1);
const CMD_POWER_ON: u16 = 1;
const CMD_ENABLE: u16 = 3;
const CMD_MOVE_J_JOINTS: u16 = 10;

/// Sessions one client address may hold (hans_gateway's modbus
/// `PER_ADDRESS`). Under QEMU's user-mode network every client comes from
/// 10.0.2.2, so this is what a test can take.
const PER_ADDRESS: usize = 3;

mod common;
use common::{start_sim, wait_for, STEP};

/// The gateway firmware's rig.
type Rig = common::Rig;

impl Rig {
    fn gateway(name: &'static str) -> Rig {
        Rig::start("gateway", name, "")
    }

    /// Ends the firmware through the diagnostics port, prints its log, stops
    /// the simulator and checks how QEMU ended: `Exit` after the stack
    /// report with status 0, `Panic` with status 1 and the panic in the log.
    fn finish(mut self, end: End) {
        let report = match end {
            End::Exit => Some(
                request_line(self.qemu.ports.admin, "exit\n", Duration::from_secs(30))
                    .expect("diagnostics report"),
            ),
            // No answer comes: the firmware panics instead.
            End::Panic => {
                let mut admin =
                    connect_retry(self.qemu.ports.admin, STEP).expect("diagnostics port");
                std::io::Write::write_all(&mut admin, b"panic\n").expect("send the command");
                None
            }
        };
        if let Some(report) = &report {
            println!("{}: {}", self.name, report.trim());
        }
        let (status, log) = self.wait_end();
        match end {
            End::Exit => {
                let report = report.as_deref().unwrap_or_default();
                assert!(report.starts_with("stack_used="), "report: {report}");
            }
            End::Panic => {
                if !log.starts_with("(raw defmt") {
                    assert!(log.contains("panic at"), "panic message in the log");
                }
            }
        }
        assert_eq!(
            status.and_then(|s| s.code()),
            Some(end.status()),
            "firmware exit status (semihosting) after {end:?}"
        );
        if let Some(report) = &report {
            self.check_stack(report);
        }
    }
}

/// How a test ends the firmware (the diagnostics port's commands).
#[derive(Clone, Copy, Debug)]
enum End {
    /// `exit`: the stack report, then semihosting exit 0.
    Exit,
    /// `panic`: the panic handler logs it and exits with 1, the status a
    /// failing firmware must show.
    Panic,
}

impl End {
    /// QEMU's exit status.
    fn status(self) -> i32 {
        match self {
            End::Exit => 0,
            End::Panic => 1,
        }
    }
}

/// Waits until the firmware is connected to the robot and has polled its
/// status at least once.
fn wait_for_robot(plc: &mut Plc) {
    wait_for("the robot link and a first status", STEP, || {
        let s = status(plc);
        let up = s[usize::from(STATUS_LINK_STATE)] == LINK_CONNECTED
            && s[usize::from(STATUS_FLAGS)] & FLAG_VALID != 0;
        up.then_some(())
    });
}

fn status(client: &mut Plc) -> Vec<u16> {
    must(
        client.read_input_registers(0, STATUS_LEN),
        "read the status block",
    )
}

/// Runs one command on channel 0 the PLCopen way: parameters, command,
/// sequence, Execute rising edge, wait for Done or Error with our sequence,
/// Execute low. Returns the channel status bits.
fn execute(client: &mut Plc, code: u16, seq: u16, params: &[f32]) -> u16 {
    let mut words = Vec::new();
    for p in params {
        words.extend_from_slice(&f32_to_words(*p));
    }
    if !words.is_empty() {
        must(
            client.write_multiple_registers(CH0 + CH_PARAMS, &words),
            "write parameters",
        );
    }
    must(
        client.write_single_register(CH0 + CH_CONTROL, 0),
        "Execute low",
    );
    must(
        client.write_multiple_registers(CH0 + CH_COMMAND, &[code, seq]),
        "command and sequence",
    );
    must(client.write_single_register(CH0 + CH_CONTROL, 1), "Execute");
    let st = wait_for(&format!("command {code} to finish"), STEP, || {
        let r = must(
            client.read_holding_registers(CH0 + CH_STATUS, 2),
            "read channel status",
        );
        (r[1] == seq && r[0] & (ST_DONE | ST_ERROR) != 0).then_some(r[0])
    });
    must(
        client.write_single_register(CH0 + CH_CONTROL, 0),
        "Execute low",
    );
    st
}

#[test]
fn plc_powers_on_moves_and_reads_status_through_the_firmware() {
    let rig = Rig::gateway("gateway-motion");
    let mut plc = rig.modbus();

    wait_for_robot(&mut plc);

    let st = execute(&mut plc, CMD_POWER_ON, 1, &[]);
    assert_eq!(
        st & (ST_DONE | ST_ERROR),
        ST_DONE,
        "power on: status {st:#06x}"
    );
    let st = execute(&mut plc, CMD_ENABLE, 2, &[]);
    assert_eq!(
        st & (ST_DONE | ST_ERROR),
        ST_DONE,
        "enable: status {st:#06x}"
    );

    let target = [10.0f32, -20.0, 30.0, 0.0, 45.0, 5.0];
    let mut params = target.to_vec();
    params.extend_from_slice(&[50.0, 100.0, 0.0]); // velocity, acceleration, radius
    let st = execute(&mut plc, CMD_MOVE_J_JOINTS, 3, &params);
    assert_eq!(st & (ST_DONE | ST_ERROR), ST_DONE, "move: status {st:#06x}");

    // The status block mirrors the robot once the move is done.
    let block = wait_for("the status block to show the target", STEP, || {
        let s = status(&mut plc);
        let joints: Vec<f32> = (0..6)
            .map(|i| {
                let a = usize::from(STATUS_JOINTS) + 2 * i;
                f32_from_words(s[a], s[a + 1])
            })
            .collect();
        let arrived = joints
            .iter()
            .zip(target.iter())
            .all(|(a, b)| (a - b).abs() < 0.01);
        // The fields come from different poll commands (ReadRobotState,
        // ReadCurFSM, ReadActPos), so they settle within one poll round of
        // each other: wait for all of them.
        let settled = s[usize::from(STATUS_FLAGS)] & FLAG_MOVING == 0
            && s[usize::from(STATUS_FSM)] == FSM_STANDBY;
        (arrived && settled).then_some(s)
    });
    let flags = block[usize::from(STATUS_FLAGS)];
    assert_eq!(block[usize::from(STATUS_LINK_STATE)], LINK_CONNECTED);
    assert_eq!(block[usize::from(STATUS_FSM)], FSM_STANDBY, "FSM StandBy");
    assert_eq!(
        flags & (FLAG_VALID | FLAG_POWERED | FLAG_ENABLED),
        FLAG_VALID | FLAG_POWERED | FLAG_ENABLED,
        "flags {flags:#06x}"
    );

    // The simulator confirms what the firmware sent.
    let received = rig.sim().received();
    for name in [
        "ConnectToBox,",
        "Electrify,",
        "StartMaster,",
        "GrpEnable,0,",
    ] {
        assert!(
            received.iter().any(|m| m.starts_with(name)),
            "simulator never received {name}: {received:?}"
        );
    }
    let waypoint = received
        .iter()
        .find(|m| m.starts_with("WayPoint,"))
        .unwrap_or_else(|| panic!("no WayPoint received: {received:?}"));
    let fields: Vec<&str> = waypoint.split(',').collect();
    // WayPoint,rbt,X,Y,Z,Rx,Ry,Rz,J1..J6,...
    let joints: Vec<f64> = fields[8..14]
        .iter()
        .map(|f| f.trim().parse().expect("numeric joint"))
        .collect();
    for (got, want) in joints.iter().zip(target.iter()) {
        assert!((got - f64::from(*want)).abs() < 1e-3, "{waypoint}");
    }
    let state = rig.sim().state();
    for (got, want) in state.act_joints.iter().zip(target.iter()) {
        assert!(
            (got - f64::from(*want)).abs() < 1e-3,
            "sim joints {:?}",
            state.act_joints
        );
    }

    drop(plc);
    rig.finish(End::Exit);
}

#[test]
fn firmware_reconnects_after_the_simulator_restarts() {
    let mut rig = Rig::gateway("gateway-sim-restart");
    let mut plc = rig.modbus();
    wait_for_robot(&mut plc);
    let connects_before = status(&mut plc)[usize::from(STATUS_LINK_CONNECTS)];

    // Stop the simulator under the running firmware: the firmware must see
    // the link go (state leaves Connected; the flags stop claiming valid
    // robot data).
    let sim = rig.sim.take().expect("simulator");
    let port = sim.command_addr().port();
    rig.rt.block_on(sim.shutdown());
    let mut seen = Vec::new();
    wait_for("the link to be reported down", STEP, || {
        let s = status(&mut plc);
        let view = (
            s[usize::from(STATUS_LINK_STATE)],
            s[usize::from(STATUS_FLAGS)] & FLAG_VALID != 0,
            s[usize::from(STATUS_LINK_CONNECTS)],
        );
        if seen.last() != Some(&view) {
            seen.push(view);
        }
        (view.0 != LINK_CONNECTED && !view.1).then_some(())
    });

    // Start it again on the same port: the firmware reconnects by itself.
    let sim = rig.rt.block_on(start_sim(port));
    rig.sim = Some(sim);
    let s = wait_for("the link to come back", STEP, || {
        let s = status(&mut plc);
        let view = (
            s[usize::from(STATUS_LINK_STATE)],
            s[usize::from(STATUS_FLAGS)] & FLAG_VALID != 0,
            s[usize::from(STATUS_LINK_CONNECTS)],
        );
        if seen.last() != Some(&view) {
            seen.push(view);
        }
        let up = view.0 == LINK_CONNECTED && view.1 && !rig.sim().received().is_empty();
        up.then_some(s)
    });
    println!("link (state, valid, connects) seen: {seen:?}");
    let connects_after = s[usize::from(STATUS_LINK_CONNECTS)];
    assert!(
        connects_after.wrapping_sub(connects_before) >= 1,
        "link connects {connects_before} -> {connects_after}; seen {seen:?}"
    );
    // The new simulator is being polled by the firmware.
    assert!(
        rig.sim()
            .received()
            .iter()
            .any(|m| m.starts_with("ReadRobotState,") || m.starts_with("ReadCurFSM,")),
        "restarted simulator got no status poll: {:?}",
        rig.sim().received()
    );

    drop(plc);
    rig.finish(End::Exit);
}

extern "C" {
    fn setsockopt(fd: i32, level: i32, name: i32, value: *const core::ffi::c_void, len: u32)
        -> i32;
}

/// Closes `stream` with a reset instead of an orderly shutdown (SO_LINGER 0),
/// like a PLC that loses power or a cable pulled mid-request.
fn abort(stream: TcpStream) {
    #[repr(C)]
    struct Linger {
        onoff: i32,
        seconds: i32,
    }
    const SOL_SOCKET: i32 = 1;
    const SO_LINGER: i32 = 13;
    let linger = Linger {
        onoff: 1,
        seconds: 0,
    };
    // SAFETY: setsockopt(2) on a socket we own, with a correctly sized value.
    let rc = unsafe {
        setsockopt(
            stream.as_raw_fd(),
            SOL_SOCKET,
            SO_LINGER,
            (&linger as *const Linger).cast(),
            std::mem::size_of::<Linger>() as u32,
        )
    };
    assert_eq!(rc, 0, "setsockopt(SO_LINGER)");
    drop(stream);
}

#[test]
fn a_client_that_vanishes_mid_request_frees_its_session() {
    let rig = Rig::gateway("gateway-abrupt-client");

    // Take every session one address may have.
    let mut clients: Vec<Plc> = (0..PER_ADDRESS).map(|_| rig.modbus()).collect();
    let sessions = wait_for("the sessions to be counted", STEP, || {
        let s = status(&mut clients[0])[usize::from(STATUS_SESSIONS)];
        (usize::from(s) == PER_ADDRESS).then_some(s)
    });
    assert_eq!(usize::from(sessions), PER_ADDRESS);

    // One of them sends half a request and is reset.
    let victim = clients.pop().expect("a client");
    let stream = victim.into_socket().expect("the victim's socket");
    use std::io::Write;
    (&stream)
        .write_all(&[0x00, 0x07, 0x00, 0x00, 0x00])
        .expect("half a header");
    std::thread::sleep(Duration::from_millis(200));
    abort(stream);
    // Its session is freed (the reset closes it; the frame deadline would
    // within a second).
    wait_for("the vanished client's session to end", STEP, || {
        let s = status(&mut clients[0])[usize::from(STATUS_SESSIONS)];
        (usize::from(s) == PER_ADDRESS - 1).then_some(())
    });

    // A new client from the same address gets the freed session and is
    // served.
    let mut newcomer = rig.modbus();
    let block = status(&mut newcomer);
    assert_eq!(
        usize::from(block[usize::from(STATUS_SESSIONS)]),
        PER_ADDRESS
    );
    // The others were not disturbed.
    for c in clients.iter_mut() {
        must(
            c.read_holding_registers(0, 2),
            "surviving session still served",
        );
    }
    // And the firmware refuses nothing it should not: an exception for an
    // unmapped address is a Modbus answer, not a dropped connection.
    match newcomer.read_holding_registers(9000, 1) {
        Ok(Err(ExceptionCode::IllegalDataAddress)) => {}
        other => panic!("expected exception 2 for an unmapped address, got {other:?}"),
    }

    drop(clients);
    drop(newcomer);
    rig.finish(End::Exit);
}

#[test]
fn without_a_dhcp_client_a_dhcp_setting_falls_back_to_the_static_address() {
    // DHCP as the factory setting, on the core firmware, which has no DHCP
    // client: it runs on the static address (so this session reaches it),
    // keeps NET_DHCP = 1, and ACCESS bit 2 says the setting is not what runs.
    const NET_DHCP: u16 = 166;
    const ACCESS: u16 = 50;
    const ACCESS_NOT_RUNNING: u16 = 1 << 2;
    let rig = Rig::start("gateway", "gateway-dhcp-fallback", "dhcp");
    let mut plc = rig.modbus();
    assert_eq!(
        must(plc.read_holding_registers(NET_DHCP, 1), "NET_DHCP")[0],
        1
    );
    let access = must(plc.read_input_registers(ACCESS, 1), "ACCESS")[0];
    assert_eq!(
        access & ACCESS_NOT_RUNNING,
        ACCESS_NOT_RUNNING,
        "ACCESS {access:#06x}"
    );
    drop(plc);
    rig.finish(End::Exit);
}

#[test]
fn a_panic_in_the_firmware_ends_qemu_with_status_1() {
    let rig = Rig::gateway("gateway-panic");
    // Up and serving; then the firmware panics instead of answering.
    let _ = rig.modbus();
    rig.finish(End::Panic);
}
