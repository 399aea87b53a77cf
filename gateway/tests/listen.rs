//! Listen mode (the controller connects to the gateway) against a second
//! host on the network: who may be the controller, in virtual time
//! (`hans_gateway::testkit`). The robot controller is 10.0.0.2; the
//! intruder is 10.0.0.66, a host of the same segment that connects to the
//! listen port.
//!
//! The rules (REGISTERS.md, "Robot link"): with `robot.address` set only
//! that address is accepted; with 0.0.0.0 the first controller is; a new
//! connection replaces a live link only when it comes from the live
//! controller's address (a controller reconnecting after a restart); every
//! other one is closed at once, logged and counted (`link.refused`).

use core::net::{Ipv4Addr, SocketAddrV4};

use embassy_time::Duration;
use hans_gateway::config::{Config, StatusSource};
use hans_gateway::job::code;
use hans_gateway::registers as r;
use hans_gateway::state::LinkState;
use hans_gateway::testkit::net::SimStream;
use hans_gateway::testkit::world::{World, WorldConfig, ROBOT_IP};

const CH0: u16 = r::CHANNEL_BASE;
const INTRUDER: Ipv4Addr = Ipv4Addr::new(10, 0, 0, 66);

fn ms(v: u64) -> Duration {
    Duration::from_millis(v)
}

/// A listen-mode world, `robot.address` = `controller`; nothing has run yet.
fn listen_world(controller: Ipv4Addr, config: Config) -> World {
    World::new(WorldConfig {
        listen_mode: true,
        config: Config {
            robot_ip: controller,
            ..config
        },
        ..WorldConfig::default()
    })
}

fn listen_port(w: &World) -> u16 {
    w.model(|m| m.config.active.listen_port)
}

/// The intruder connects to the listen port (the world runs a little).
fn intrude(w: &mut World, port: u16) -> SimStream {
    let lp = listen_port(w);
    let s = w
        .net
        .connect(SocketAddrV4::new(INTRUDER, port), lp)
        .expect("the gateway listens");
    w.run_for(ms(50));
    s
}

/// Fires `SetBoxDO 1,1` on channel 0 and waits for its end; its status.
fn fire_and_wait(w: &mut World, seq: u16) -> u16 {
    w.set(CH0, &[0, code::SET_BOX_DO, seq, 0]);
    // Parameters 1.0, 1.0 (f32, big-endian words).
    let one = 1.0f32.to_bits();
    let p = [(one >> 16) as u16, one as u16];
    w.set(CH0 + 4, &[p[0], p[1], p[0], p[1]]);
    w.set(CH0, &[1]);
    let ended = w.run_until_cond(ms(1000), |w| {
        let s = w.reg(CH0 + r::CH_STATUS);
        s != 0 && s & r::ST_BUSY == 0
    });
    assert!(ended, "the command is still busy");
    w.reg(CH0 + r::CH_STATUS)
}

fn sent_to_robot(w: &World, name: &str) -> usize {
    w.robot
        .log
        .iter()
        .filter(|m| m.text.starts_with(name))
        .count()
}

fn peer(w: &World) -> Option<Ipv4Addr> {
    w.model(|m| m.link.peer)
}

/// An intruder that played the controller: it answers every request with
/// a forged `OK` (what made a command Done for the PLC before).
fn forge_ok(s: &mut SimStream) -> Vec<u8> {
    let got = s.read();
    if !got.is_empty() {
        s.write(b"SetBoxDO,OK,;");
    }
    got
}

#[test]
fn unconfigured_an_intruder_cannot_replace_the_live_controller() {
    // 0.0.0.0: the first controller is accepted, and keeps the link.
    let mut w = listen_world(Ipv4Addr::UNSPECIFIED, Config::default());
    w.run_for(ms(300));
    assert_eq!(w.reg(r::STATUS_LINK_STATE), 3);
    assert_eq!(peer(&w), Some(ROBOT_IP));
    let connects = w.reg(r::STATUS_LINK_CONNECTS);
    // The controller keeps its link but would not connect again on its own
    // (so that a take-over would last).
    w.robot.set_offline(true);

    let mut intruder = intrude(&mut w, 40666);
    assert!(!intruder.is_open(), "the intruder's connection is closed");
    assert_eq!(peer(&w), Some(ROBOT_IP));
    assert_eq!(w.reg(r::STATUS_LINK_CONNECTS), connects);
    assert_eq!(w.model(|m| m.link.refused), 1);
    assert_eq!(w.robot.open_connections(), 1, "the controller's link stays");

    // The PLC's command goes to the real controller, not to the intruder
    // (which would answer it with a forged OK).
    let before = sent_to_robot(&w, "SetBoxDO");
    w.set(CH0, &[0, code::SET_BOX_DO, 1, 0, 0x3f80, 0, 0x3f80, 0]);
    w.set(CH0, &[1]);
    let mut forged = Vec::new();
    let ended = w.run_until_cond(ms(1000), |w| {
        forged.extend(forge_ok(&mut intruder));
        let s = w.reg(CH0 + r::CH_STATUS);
        s != 0 && s & r::ST_BUSY == 0
    });
    assert!(ended);
    assert!(forged.is_empty(), "the intruder got {forged:?}");
    assert_eq!(sent_to_robot(&w, "SetBoxDO"), before + 1);
    assert_eq!(w.reg(CH0 + r::CH_STATUS), r::ST_DONE);
}

#[test]
fn configured_an_intruder_is_refused_while_the_link_is_up() {
    let mut w = listen_world(ROBOT_IP, Config::default());
    w.run_for(ms(300));
    assert_eq!(peer(&w), Some(ROBOT_IP));
    let mut intruder = intrude(&mut w, 40666);
    assert!(!intruder.is_open());
    assert_eq!(peer(&w), Some(ROBOT_IP));
    let before = sent_to_robot(&w, "SetBoxDO");
    assert_eq!(fire_and_wait(&mut w, 1), r::ST_DONE);
    assert_eq!(sent_to_robot(&w, "SetBoxDO"), before + 1);
    assert!(forge_ok(&mut intruder).is_empty());
    assert_eq!(w.model(|m| m.link.refused), 1);
}

#[test]
fn configured_an_intruder_is_refused_while_the_controller_is_away() {
    // The controller is off: the intruder is the only one connecting.
    let mut w = listen_world(ROBOT_IP, Config::default());
    w.robot.set_offline(true);
    let mut intruder = intrude(&mut w, 40666);
    w.run_for(ms(300));
    assert!(!intruder.is_open(), "refused, although no link is up");
    assert_eq!(w.model(|m| m.link.state), LinkState::Listening);
    assert_eq!(peer(&w), None);
    assert_eq!(w.reg(r::STATUS_LINK_CONNECTS), 0);
    assert_eq!(w.model(|m| m.link.refused), 1);
    // A command is not sent anywhere: it ends in Error, never Done.
    assert_eq!(fire_and_wait(&mut w, 1) & r::ST_DONE, 0);
    assert!(forge_ok(&mut intruder).is_empty());

    // Again and again: each one refused, the gateway keeps listening.
    for i in 0..3 {
        let s = intrude(&mut w, 40700 + i);
        assert!(!s.is_open());
    }
    assert_eq!(w.model(|m| m.link.refused), 4);

    // The controller comes back: accepted.
    w.robot.set_offline(false);
    let now = w.now();
    w.robot.reconnect_now(now);
    w.run_for(ms(300));
    assert_eq!(w.reg(r::STATUS_LINK_STATE), 3);
    assert_eq!(peer(&w), Some(ROBOT_IP));
    assert_eq!(fire_and_wait(&mut w, 2), r::ST_DONE);
}

#[test]
fn configured_an_intruder_connecting_first_does_not_get_the_link() {
    // The intruder's connection waits in the backlog before the
    // controller's first one.
    let mut w = listen_world(ROBOT_IP, Config::default());
    let lp = listen_port(&w);
    let mut intruder = w
        .net
        .connect(SocketAddrV4::new(INTRUDER, 40666), lp)
        .expect("the gateway listens");
    w.run_for(ms(300));
    assert!(!intruder.is_open());
    assert_eq!(w.reg(r::STATUS_LINK_STATE), 3);
    assert_eq!(peer(&w), Some(ROBOT_IP));
    assert_eq!(w.reg(r::STATUS_LINK_CONNECTS), 1);
    assert_eq!(fire_and_wait(&mut w, 1), r::ST_DONE);
    assert!(forge_ok(&mut intruder).is_empty());
}

#[test]
fn the_same_controller_reconnecting_replaces_its_old_link() {
    for controller in [ROBOT_IP, Ipv4Addr::UNSPECIFIED] {
        let mut w = listen_world(controller, Config::default());
        w.run_for(ms(300));
        assert_eq!(w.reg(r::STATUS_LINK_CONNECTS), 1);
        // An intruder first (refused), then the controller after a restart.
        let _intruder = intrude(&mut w, 40666);
        let now = w.now();
        w.robot.reconnect_now(now);
        w.run_for(ms(200));
        assert_eq!(w.reg(r::STATUS_LINK_CONNECTS), 2, "{controller}");
        assert_eq!(w.robot.open_connections(), 1, "the old link is closed");
        assert_eq!(peer(&w), Some(ROBOT_IP));
        assert_eq!(w.model(|m| m.link.refused), 1);
        assert_eq!(fire_and_wait(&mut w, 1), r::ST_DONE);
    }
}

#[test]
fn a_configured_address_applied_while_its_controller_is_connected_keeps_the_link() {
    let mut w = listen_world(Ipv4Addr::UNSPECIFIED, Config::default());
    w.run_for(ms(300));
    // The robot endpoint is protected: configuration over Modbus allowed.
    w.allow_modbus_config();
    // CFG_ROBOT_IP = 10.0.0.2, applied (CONFIG_COMMAND 1).
    let [a, b, c, d] = ROBOT_IP.octets();
    w.set(
        r::CONFIG_ROBOT_IP,
        &[
            u16::from(a) << 8 | u16::from(b),
            u16::from(c) << 8 | u16::from(d),
        ],
    );
    w.set(r::CONTROL_CONFIG_COMMAND, &[1]);
    w.run_for(ms(100));
    assert_eq!(w.model(|m| m.config.active.robot_ip), ROBOT_IP);
    assert_eq!(w.reg(r::STATUS_LINK_CONNECTS), 1, "the link was kept");
    assert_eq!(w.reg(r::STATUS_LINK_STATE), 3);
    // Another address applied: the live controller is no longer it.
    w.set(r::CONFIG_ROBOT_IP, &[0x0a00, 0x0063]);
    w.set(r::CONTROL_CONFIG_COMMAND, &[1]);
    w.run_for(ms(500));
    assert_eq!(
        w.model(|m| m.config.active.robot_ip),
        Ipv4Addr::new(10, 0, 0, 99)
    );
    assert_ne!(w.reg(r::STATUS_LINK_STATE), 3, "10.0.0.2 is refused now");
    assert_eq!(peer(&w), None);
    assert!(w.model(|m| m.link.refused) >= 1);
}

#[test]
fn the_datasheet_is_read_only_from_the_accepted_controller() {
    let config = Config {
        status_source: StatusSource::DataSheet,
        ..Config::default()
    };
    let mut w = listen_world(Ipv4Addr::UNSPECIFIED, config);
    let port = config.datasheet_port;
    let intruder_sheet = SocketAddrV4::new(INTRUDER, port);
    w.net.listen(intruder_sheet);
    w.run_for(ms(300));
    assert_eq!(peer(&w), Some(ROBOT_IP));
    // As above: the controller would not take a stolen link back.
    w.robot.set_offline(true);
    let _intruder = intrude(&mut w, 40666);
    w.run_for(ms(3000));
    assert_eq!(peer(&w), Some(ROBOT_IP));
    assert_eq!(w.net.attempts(intruder_sheet), 0, "never to the intruder");
    assert!(w.net.attempts(SocketAddrV4::new(ROBOT_IP, port)) > 0);
}
