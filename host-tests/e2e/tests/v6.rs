//! The gateway against hans-sim speaking V6 (and V5): the protocol level
//! detected, jogging from the PLC with its stop conditions (release,
//! heartbeat loss, link loss), the refusal at V5, and the robot error's
//! text from the controller. Real sockets on 127.0.0.1, real time; every
//! wait is on a condition, bounded by [`WAIT`].
//!
//! The jogs' timing (a `LongMoveEvent` every 100 ms, the controller's
//! 200 ms, the 1000 ms heartbeat a jog needs) is tested exactly in virtual
//! time (`gateway/tests/v6.rs`). Here the simulated controller waits
//! [`JOG_WINDOW`] for a keep-alive instead of the document's 200 ms: a
//! loaded machine that stalls the gateway's or the simulator's thread for
//! 100 ms would make it stop the jog itself and refuse the next
//! `LongMoveEvent` (`Fail,20018`), which the gateway rightly reports as the
//! command's error; only the gateway's own stop (or, the link lost, the
//! window's lapse) may end a jog in these tests.

use std::time::{Duration, Instant};

use hans_codec::{FsmState, ProtocolLevel};
use hans_e2e::{f32_of, words_text, Plc, Rig, WAIT};
use hans_gateway::job::code;
use hans_gateway::registers as r;
use hans_sim::Sim;

const CH0: usize = 0;

/// How long the simulated controller keeps a long jog going after its
/// start or its last `LongMoveEvent` (see the module documentation).
const JOG_WINDOW: Duration = Duration::from_secs(3);

/// The heartbeat period a jog needs when the watchdog is off (the
/// gateway's `engine::jog::HEARTBEAT`, REGISTERS.md).
const JOG_HEARTBEAT: Duration = Duration::from_millis(1000);

/// Beats the PLC heartbeat every 100 ms until `cond` holds for the
/// simulator (at most [`WAIT`]); returns the instant the last beat was
/// sent (the gateway saw it no earlier than that).
async fn beat_until(plc: &mut Plc, sim: &Sim, what: &str, cond: impl Fn(&Sim) -> bool) -> Instant {
    let start = Instant::now();
    let mut beat = plc.read1(r::CONTROL_HEARTBEAT).await;
    loop {
        beat = beat.wrapping_add(1);
        let sent = Instant::now();
        plc.write(r::CONTROL_HEARTBEAT, &[beat]).await;
        if cond(sim) {
            return sent;
        }
        assert!(start.elapsed() < WAIT, "{what} within {WAIT:?}");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// The messages named `name` the simulator received.
fn received(sim: &Sim, name: &str) -> usize {
    let prefix = format!("{name},");
    sim.received()
        .iter()
        .filter(|m| m.starts_with(&prefix))
        .count()
}

async fn joint(plc: &mut Plc, i: u16) -> f32 {
    let w = plc.read(r::STATUS_JOINTS + 2 * i, 2).await;
    f32_of(&w)
}

async fn v6_rig() -> Rig {
    let mut config = hans_sim::Config::ready();
    config.timing.long_move_keepalive = JOG_WINDOW;
    let mut rig = Rig::start(config).await;
    rig.plc
        .wait_reg(r::STATUS_PROTOCOL, "protocol level detected", |v| v == 606)
        .await;
    rig
}

#[tokio::test(flavor = "current_thread")]
async fn a_jog_moves_the_robot_while_execute_is_held_and_stops_at_release() {
    let mut rig = v6_rig().await;
    rig.plc.wait_status().await;
    let before = joint(&mut rig.plc, 0).await;
    rig.plc.command(CH0, code::JOG_J + 1, &[], 1).await; // J1+
                                                         // Held until the gateway has kept the jog alive eight times (each
                                                         // keep-alive at least 100 ms after the one before: J1 has turned
                                                         // some 7° at 10°/s by then).
    beat_until(&mut rig.plc, &rig.sim, "eight keep-alives", |sim| {
        received(sim, "LongMoveEvent") >= 8
    })
    .await;
    let st = rig.plc.read1(Plc::ch_status(CH0)).await;
    assert_eq!(st, r::ST_BUSY | r::ST_ACTIVE, "Busy and Active while held");
    assert_eq!(rig.sim.fsm(), FsmState::LongJogMoving);
    rig.plc.wait_status().await;
    let during = joint(&mut rig.plc, 0).await;
    assert!(during > before + 3.0, "J1 moved: {before} -> {during}");
    // Release: Done once it stands still; it no longer moves.
    rig.plc.write(r::channel_base(CH0), &[0]).await;
    let e = rig.plc.wait_end(Plc::ch_status(CH0)).await;
    assert!(e.done(), "{e:?}");
    assert_eq!(
        rig.received("LongJogJ"),
        ["LongJogJ,0,0,1,1,;", "LongJogJ,0,0,1,0,;"]
    );
    let stopped = joint(&mut rig.plc, 0).await;
    // Three more position reads of the gateway's status rounds, one round
    // per 100 ms: at least 200 ms in which J1 would have turned 2° more.
    let reads = received(&rig.sim, "ReadActPos");
    let start = Instant::now();
    while received(&rig.sim, "ReadActPos") < reads + 3 {
        assert!(start.elapsed() < WAIT, "no status round within {WAIT:?}");
        tokio::time::sleep(hans_e2e::POLL_PAUSE).await;
    }
    let later = joint(&mut rig.plc, 0).await;
    assert!(
        (later - stopped).abs() < 0.5,
        "still moving: {stopped} -> {later}"
    );
    assert_ne!(rig.sim.fsm(), FsmState::LongJogMoving);
    rig.stop().await;
}

#[tokio::test(flavor = "current_thread")]
async fn a_jog_stops_when_the_plc_heartbeat_stops() {
    let mut rig = v6_rig().await;
    rig.plc.command(CH0, code::JOG_L + 4, &[], 1).await; // Z-
    let last_beat = beat_until(&mut rig.plc, &rig.sim, "the jog kept alive", |sim| {
        sim.fsm() == FsmState::LongJogMoving && received(sim, "LongMoveEvent") >= 3
    })
    .await;
    // Execute stays high; the heartbeat stops. The watchdog is off, so the
    // jog's own period applies, counted from the last beat the gateway
    // saw, which it saw after it was sent.
    let e = rig.plc.wait_end(Plc::ch_status(CH0)).await;
    let after = last_beat.elapsed();
    assert_eq!((e.error_id, e.error_source), (39602, 3), "{e:?}");
    assert!(
        after >= JOG_HEARTBEAT,
        "stopped {after:?} after the last beat"
    );
    assert_eq!(
        rig.received("LongJogL").last().map(String::as_str),
        Some("LongJogL,0,2,0,0,;")
    );
    assert_ne!(rig.sim.fsm(), FsmState::LongJogMoving);
    rig.stop().await;
}

#[tokio::test(flavor = "current_thread")]
async fn a_jog_stops_when_the_link_drops() {
    let mut rig = v6_rig().await;
    rig.plc.command(CH0, code::JOG_J + 5, &[], 1).await; // J3+
    beat_until(&mut rig.plc, &rig.sim, "the jog kept alive", |sim| {
        sim.fsm() == FsmState::LongJogMoving && received(sim, "LongMoveEvent") >= 3
    })
    .await;
    rig.sim.drop_connections();
    let e = rig.plc.wait_end(Plc::ch_status(CH0)).await;
    assert_eq!((e.error_id, e.error_source), (39601, 3), "{e:?}");
    // The controller stops by itself once the keep-alives stop (after its
    // window).
    let start = Instant::now();
    while rig.sim.fsm() == FsmState::LongJogMoving {
        assert!(start.elapsed() < WAIT, "the robot still jogs");
        tokio::time::sleep(hans_e2e::POLL_PAUSE).await;
    }
    rig.stop().await;
}

#[tokio::test(flavor = "current_thread")]
async fn a_v5_controller_gets_no_jog_and_errors_are_explained_from_the_table() {
    let mut rig = Rig::start(hans_sim::Config {
        protocol: ProtocolLevel::V5,
        ..hans_sim::Config::ready()
    })
    .await;
    rig.plc
        .wait_reg(r::STATUS_PROTOCOL, "protocol level detected", |v| v == 500)
        .await;
    let e = rig.plc.run(CH0, code::JOG_J, &[], 1).await;
    assert_eq!((e.error_id, e.error_source), (39608, 3), "{e:?}");
    assert!(rig.received("LongJogJ").is_empty());
    // A robot refusal: its text from the gateway's table (source 2).
    let (e, _) = rig.plc.raw("SetBoxDO,9,1,;", 2).await;
    assert_eq!(e.error_source, 1, "{e:?}");
    let code = rig
        .plc
        .wait_reg(r::ERROR_TEXT_COUNT, "an error text", |v| v >= 1)
        .await;
    assert!(code >= 1);
    let w = rig.plc.read(r::ERROR_TEXT_CODE, 4).await;
    assert_eq!(hans_e2e::i32_of(&w[..2]), e.error_id);
    assert_eq!(w[2], 2, "from the table");
    assert!(rig.received("GetErrorCodeStr").is_empty());
    rig.stop().await;
}

#[tokio::test(flavor = "current_thread")]
async fn at_v6_the_controller_explains_its_error_codes() {
    let mut rig = v6_rig().await;
    let (e, _) = rig.plc.raw("SetBoxDO,9,1,;", 1).await;
    assert_eq!(e.error_source, 1, "{e:?}");
    rig.plc
        .wait_reg(r::ERROR_TEXT_COUNT, "an error text", |v| v >= 1)
        .await;
    let w = rig
        .plc
        .read(r::ERROR_TEXT_CODE, 4 + r::ERROR_TEXT_REGS)
        .await;
    assert_eq!(hans_e2e::i32_of(&w[..2]), e.error_id);
    assert_eq!(w[2], 1, "the controller's own text");
    let text = words_text(&w[4..]);
    assert!(!text.is_empty());
    assert_eq!(
        rig.received("GetErrorCodeStr"),
        [format!("GetErrorCodeStr,{},;", e.error_id)]
    );
    rig.stop().await;
}
