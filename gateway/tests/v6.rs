//! What controllers that speak V6 add, in virtual time (as
//! `tests/behaviour.rs`): the protocol level (detected or configured),
//! jogging with MC_Jog's hold semantics and its stop conditions, and the
//! error text registers. The simulated robot (`testkit::robot`) keeps long
//! jogs going only while `LongMoveEvent` comes, as the V6 document says.

use embassy_time::Duration;
use hans_gateway::job::code;
use hans_gateway::registers as r;
use hans_gateway::testkit::robot::{Fault, JOG_TIMEOUT};
use hans_gateway::testkit::world::{World, WorldConfig};

const CH0: u16 = r::CHANNEL_BASE;
const CH1: u16 = r::CHANNEL_BASE + r::CHANNEL_STRIDE;

fn ms(v: u64) -> Duration {
    Duration::from_millis(v)
}

fn world() -> World {
    let mut w = World::new(WorldConfig::default());
    w.run_for(ms(300));
    w
}

/// A world whose controller speaks V5 (no `PackageVersion`, no jogs).
fn v5_world() -> World {
    let mut w = World::new(WorldConfig::default());
    w.robot.model.version = None;
    w.run_for(ms(300));
    w
}

fn fire(w: &mut World, ch: u16, c: u16, seq: u16) {
    w.set(ch, &[0, c, seq, 0]);
    w.set(ch, &[1]);
}

fn status(w: &mut World, ch: u16) -> u16 {
    w.reg(ch + r::CH_STATUS)
}

fn error_id(w: &mut World, ch: u16) -> (u32, u16) {
    let v = w.read(ch + r::CH_ERROR_ID, 3).expect("read");
    ((u32::from(v[0]) << 16) | u32::from(v[1]), v[2])
}

/// Holds the jog for `d`, the PLC beating every 100 ms.
fn hold(w: &mut World, d: Duration) {
    let end = w.now() + d;
    let mut beat = w.reg(r::CONTROL_HEARTBEAT);
    while w.now() < end {
        beat = beat.wrapping_add(1);
        w.set(r::CONTROL_HEARTBEAT, &[beat]);
        w.run_for(ms(100));
    }
}

fn text(w: &mut World, addr: u16, regs: u16) -> String {
    let words = w.read(addr, regs).expect("read");
    let bytes: Vec<u8> = words
        .iter()
        .flat_map(|x| x.to_be_bytes())
        .take_while(|&b| b != 0)
        .collect();
    String::from_utf8_lossy(&bytes).to_string()
}

fn sent(w: &World, prefix: &str) -> Vec<String> {
    w.robot
        .log
        .iter()
        .filter(|m| m.text.starts_with(prefix))
        .map(|m| m.text.clone())
        .collect()
}

#[test]
fn the_protocol_level_is_detected_at_each_connection_or_configured() {
    let mut w = world();
    assert_eq!(
        w.reg(r::STATUS_PROTOCOL),
        603,
        "PackageVersion 6.3.6.20240305"
    );
    assert_eq!(sent(&w, "PackageVersion").len(), 1);
    let mut w = v5_world();
    assert_eq!(w.reg(r::STATUS_PROTOCOL), 500, "refused: V5");
    // Configured: not asked.
    w.set(r::CONFIG_PROTOCOL, &[2]);
    w.set(r::CONTROL_CONFIG_COMMAND, &[1]);
    w.run_for(ms(10));
    assert_eq!(w.reg(r::STATUS_PROTOCOL), 606);
    let asked = sent(&w, "PackageVersion").len();
    w.robot.drop_connections();
    w.run_for(ms(2000));
    assert_eq!(w.reg(r::STATUS_LINK_STATE), 3);
    assert_eq!(sent(&w, "PackageVersion").len(), asked, "not asked again");
    assert_eq!(w.reg(r::STATUS_PROTOCOL), 606);
}

#[test]
fn a_jog_runs_while_execute_is_held_and_stops_when_it_falls() {
    let mut w = world();
    fire(&mut w, CH0, code::JOG_J + 3, 7); // J2+ (axis 1, positive)
    hold(&mut w, ms(1500));
    assert_eq!(status(&mut w, CH0), r::ST_BUSY | r::ST_ACTIVE);
    let jog = w.robot.model.jog.expect("the robot jogs");
    assert_eq!((jog.cartesian, jog.axis, jog.direction), (false, 1, 1));
    assert!(
        w.robot.model.max_event_gap < JOG_TIMEOUT,
        "keep-alives every {:?}",
        w.robot.model.max_event_gap
    );
    assert!(sent(&w, "LongMoveEvent,0,;").len() >= 12);
    // Release: the stop goes out at once, Done once it stands still.
    w.set(CH0, &[0]);
    let released = w.now();
    w.run_for(ms(20));
    let stop = w
        .robot
        .log
        .iter()
        .find(|m| m.text == "LongJogJ,0,1,1,0,;")
        .map(|m| m.at)
        .expect("stop sent");
    assert!(stop.saturating_duration_since(released) <= ms(20));
    assert!(w.robot.model.jog.is_none());
    let done = w.run_until_cond(ms(1000), |w| w.reg(CH0 + r::CH_STATUS) == r::ST_DONE);
    assert!(done, "Done after the release");
    assert_eq!(w.robot.model.jog_timeouts, 0, "never left to time out");
    // A Cartesian jog: LongJogL.
    fire(&mut w, CH1, code::JOG_L + 2 * 2, 8); // Z-
    hold(&mut w, ms(300));
    assert!(sent(&w, "LongJogL,0,2,0,1,;").len() == 1);
    w.set(CH1, &[0]);
    w.run_for(ms(300));
    assert_eq!(status(&mut w, CH1), r::ST_DONE);
}

#[test]
fn a_jog_stops_when_the_plc_heartbeat_stops() {
    let mut w = world();
    fire(&mut w, CH0, code::JOG_J, 1); // J1-
    hold(&mut w, ms(500));
    assert_eq!(status(&mut w, CH0), r::ST_BUSY | r::ST_ACTIVE);
    // The PLC hangs with Execute high: no more beats. The watchdog is
    // off, so the jog's own 1000 ms apply.
    let last = w.now();
    let ended = w.run_until_cond(ms(2000), |w| w.reg(CH0 + r::CH_STATUS) == r::ST_ERROR);
    assert!(ended);
    assert_eq!(error_id(&mut w, CH0), (39602, 3));
    assert!(w.robot.model.jog.is_none());
    let stop = w
        .robot
        .log
        .iter()
        .find(|m| m.text == "LongJogJ,0,0,0,0,;")
        .map(|m| m.at)
        .expect("stop sent");
    let after = stop.saturating_duration_since(last);
    assert!(
        after >= ms(900) && after <= ms(1200),
        "stopped {after:?} after the last beat"
    );
    assert_ne!(w.reg(r::STATUS_WATCHDOG) & 2, 0, "tripped");
}

#[test]
fn a_jog_stops_on_the_robot_side_when_the_link_drops() {
    let mut w = world();
    fire(&mut w, CH0, code::JOG_L + 1, 1); // X+
    hold(&mut w, ms(400));
    w.robot.set_offline(true);
    w.robot.drop_connections();
    w.run_for(ms(300));
    assert_eq!(status(&mut w, CH0), r::ST_ERROR);
    assert_eq!(error_id(&mut w, CH0), (39601, 3));
    assert!(w.robot.model.jog.is_none(), "stopped by the controller");
    assert_eq!(w.robot.model.jog_timeouts, 1);
}

#[test]
fn a_stop_aborts_a_jog_and_a_v5_controller_has_none() {
    let mut w = world();
    fire(&mut w, CH0, code::JOG_J + 11, 1); // J6+
    hold(&mut w, ms(300));
    fire(&mut w, CH1, code::STOP, 2);
    w.run_for(ms(100));
    assert_eq!(status(&mut w, CH0), r::ST_ABORTED);
    assert!(w.robot.model.jog.is_none());
    let mut w = v5_world();
    fire(&mut w, CH0, code::JOG_J + 11, 1);
    w.run_for(ms(100));
    assert_eq!(status(&mut w, CH0), r::ST_ERROR);
    assert_eq!(error_id(&mut w, CH0), (39608, 3));
    assert!(sent(&w, "LongJog").is_empty());
}

#[test]
fn a_robot_error_gets_its_text_from_the_controller_at_v6_and_the_table_at_v5() {
    for (mut w, source) in [(world(), 1), (v5_world(), 2)] {
        assert_eq!(w.reg(r::ERROR_TEXT_SOURCE), 0);
        w.robot.script.push_back(Fault::Fail(20018));
        fire(&mut w, CH0, code::SET_BOX_DO, 1);
        w.run_for(ms(200));
        assert_eq!(status(&mut w, CH0), r::ST_ERROR);
        assert_eq!(w.read(r::ERROR_TEXT_CODE, 2).unwrap(), [0, 20018]);
        assert_eq!(w.reg(r::ERROR_TEXT_SOURCE), source);
        assert_eq!(w.reg(r::ERROR_TEXT_COUNT), 1);
        assert_eq!(
            text(&mut w, r::ERROR_TEXT, r::ERROR_TEXT_REGS),
            "command forbidden in this state"
        );
        assert_eq!(
            sent(&w, "GetErrorCodeStr,20018,;").len(),
            usize::from(source == 1)
        );
        // A new ROBOT_ERROR_CODE is explained too.
        w.robot.model.error = Some(20006);
        w.run_for(ms(500));
        assert_eq!(w.read(r::ERROR_TEXT_CODE, 2).unwrap(), [0, 20006]);
        assert_eq!(w.reg(r::ERROR_TEXT_COUNT), 2);
        assert_eq!(
            text(&mut w, r::ERROR_TEXT, r::ERROR_TEXT_REGS),
            "command parameters error"
        );
    }
}
