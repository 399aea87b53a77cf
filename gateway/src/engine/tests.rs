//! The engine alone: a hub, a link over the simulated network and a
//! simulated controller in virtual time; no Modbus sessions, no storage
//! task, no DataSheet reader.

use core::convert::Infallible;
use core::future::Future;
use core::net::{Ipv4Addr, SocketAddrV4};
use core::pin::Pin;
use core::task::Waker;
use std::boxed::Box;
use std::rc::Rc;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use embassy_time::{Duration, Instant};

use hans_codec::{ErrorCode, ProtocolLevel};

use super::poll::PollStep;
use super::{run, Engine, Step, MAX_BACKOFF, MIN_BACKOFF};
use crate::clock::Clock;
use crate::config::{Config, StatusSource};
use crate::hub::Hub;
use crate::net::Net;
use crate::state::{LinkState, Model, TextSource};
use crate::testkit::clock::VirtualClock;
use crate::testkit::net::SimNet;
use crate::testkit::robot::SimRobot;
use crate::testkit::world::{poll_until_waiting, Flag};

const GATEWAY_IP: Ipv4Addr = Ipv4Addr::new(10, 0, 0, 1);
const ROBOT: SocketAddrV4 = SocketAddrV4::new(Ipv4Addr::new(10, 0, 0, 2), 10003);
/// Polls at one instant after which the engine counts as spinning.
const SPIN: u64 = 10_000;

/// The engine's future, run by a deterministic executor that counts its
/// polls (its wakes).
struct Rig {
    clock: Rc<VirtualClock>,
    net: SimNet,
    robot: SimRobot,
    hub: Rc<Hub>,
    fut: Pin<Box<dyn Future<Output = Infallible>>>,
    flag: Arc<Flag>,
    waker: Waker,
    /// Polls of the engine so far.
    polls: u64,
}

impl Rig {
    /// An engine on `config` (its robot address is set to the simulated
    /// controller's unless it is unspecified on purpose: `robot`).
    fn new(mut config: Config, robot: bool) -> Rig {
        if robot {
            config.robot_ip = *ROBOT.ip();
            config.robot_port = ROBOT.port();
        } else {
            config.robot_ip = Ipv4Addr::UNSPECIFIED;
        }
        let clock = Rc::new(VirtualClock::new());
        let net = SimNet::new(GATEWAY_IP);
        let robot = SimRobot::new(&net, ROBOT, 1);
        let hub = Rc::new(Hub::new(Model::new(config, config)));
        let (c, n, h) = (clock.clone(), net.clone(), hub.clone());
        let fut = Box::pin(async move {
            let (mut ra, mut ta, mut rb, mut tb) = ([0u8; 0], [0u8; 0], [0u8; 0], [0u8; 0]);
            let a = n.socket(&mut ra, &mut ta);
            let b = n.socket(&mut rb, &mut tb);
            run(&h, &*c, a, b).await
        });
        let flag = Arc::new(Flag(AtomicBool::new(true)));
        let waker = Waker::from(flag.clone());
        Rig {
            clock,
            net,
            robot,
            hub,
            fut,
            flag,
            waker,
            polls: 0,
        }
    }

    fn now(&self) -> Instant {
        self.clock.now()
    }

    /// Polls the engine until it waits (fails if it never does).
    fn settle(&mut self) {
        let at = self.now();
        self.polls += poll_until_waiting(&self.flag, &self.waker, &mut self.fut, SPIN, at);
    }

    /// Everything due now, the engine and the robot in turn.
    fn catch_up(&mut self) {
        loop {
            self.settle();
            let now = self.now();
            if !self.robot.step(now) {
                return;
            }
        }
    }

    /// Runs for `d` of virtual time.
    fn run_for(&mut self, d: Duration) {
        let end = self.now() + d;
        loop {
            self.catch_up();
            let now = self.now();
            let next = [self.clock.next_deadline(), self.robot.next_wakeup()]
                .into_iter()
                .flatten()
                .filter(|t| *t > now)
                .min();
            match next {
                Some(t) if t <= end => self.clock.advance_to(t),
                _ => {
                    self.clock.advance_to(end);
                    self.catch_up();
                    return;
                }
            }
        }
    }

    /// Engine polls and clock sleeps over `d` (after the start).
    fn wakes_over(&mut self, d: Duration) -> (u64, u64) {
        let (polls, sleeps) = (self.polls, self.clock.sleeps());
        self.run_for(d);
        (self.polls - polls, self.clock.sleeps() - sleeps)
    }

    fn link_state(&self) -> LinkState {
        self.hub.with(|m| m.link.state)
    }
}

/// A configuration whose status comes from the DataSheet: with the link
/// up and nothing to do the engine only keeps the heartbeat.
fn datasheet() -> Config {
    Config {
        status_source: StatusSource::DataSheet,
        ..Config::default()
    }
}

/// Poll periods in `d`.
fn periods(d: Duration, c: &Config) -> u64 {
    d.as_millis() / u64::from(c.poll_ms)
}

const IDLE: Duration = Duration::from_secs(10);

#[test]
fn idle_without_a_robot_wakes_once_per_poll_period() {
    let c = Config::default();
    let mut rig = Rig::new(c, false);
    rig.run_for(Duration::from_secs(1));
    let ticks = rig.hub.with(|m| m.ticks);
    let (polls, sleeps) = rig.wakes_over(IDLE);
    let n = periods(IDLE, &c);
    assert!(polls <= n + 2, "{polls} wakes in {n} poll periods");
    assert!(sleeps <= n + 2, "{sleeps} sleeps in {n} poll periods");
    // The heartbeat still goes on.
    let beats = u64::from(rig.hub.with(|m| m.ticks).wrapping_sub(ticks));
    assert!(beats + 1 >= n, "{beats} heartbeats in {n} poll periods");
}

#[test]
fn an_idle_link_wakes_once_per_poll_period() {
    let c = datasheet();
    let mut rig = Rig::new(c, true);
    rig.run_for(Duration::from_secs(1));
    assert_eq!(rig.link_state(), LinkState::Connected);
    let (polls, sleeps) = rig.wakes_over(IDLE);
    let n = periods(IDLE, &c);
    assert!(polls <= n + 2, "{polls} wakes in {n} poll periods");
    assert!(sleeps <= n + 2, "{sleeps} sleeps in {n} poll periods");
    assert_eq!(rig.link_state(), LinkState::Connected);
}

#[test]
fn an_unreachable_robot_wakes_about_once_per_poll_period() {
    let c = Config::default();
    let mut rig = Rig::new(c, true);
    rig.robot.set_offline(true);
    rig.run_for(Duration::from_secs(1));
    let (polls, sleeps) = rig.wakes_over(IDLE);
    let n = periods(IDLE, &c);
    // A connect attempt every MAX_BACKOFF at most.
    let attempts = IDLE.as_secs() / MAX_BACKOFF.as_secs() + 1;
    assert!(polls <= n + attempts + 2, "{polls} wakes in {n} periods");
    assert!(sleeps <= n + attempts + 2, "{sleeps} sleeps in {n} periods");
    assert_ne!(rig.link_state(), LinkState::Connected);
}

#[test]
fn status_polling_wakes_once_per_read() {
    let c = Config::default();
    let mut rig = Rig::new(c, true);
    rig.run_for(Duration::from_secs(1));
    assert_eq!(rig.link_state(), LinkState::Connected);
    let (polls, _) = rig.wakes_over(IDLE);
    let n = periods(IDLE, &c);
    // Each read: one wake for its reply; then one to wait for the tick.
    let per_period = PollStep::ROUND.len() as u64 + 1;
    assert!(polls <= n * per_period + 2, "{polls} wakes in {n} periods");
    assert!(rig.robot.log.len() as u64 >= n * (per_period - 1));
}

/// An engine's decisions without running it: a hub on the default
/// configuration, virtual time at 0.
fn decide(f: impl FnOnce(&Hub, &VirtualClock, &mut Engine<'_, VirtualClock>)) {
    let hub = Hub::new(Model::new(Config::default(), Config::default()));
    let clock = VirtualClock::new();
    let mut e = Engine::new(&hub, &clock);
    f(&hub, &clock, &mut e);
}

#[test]
fn choose_brings_a_down_link_up_before_anything() {
    decide(|_, clock, e| {
        e.detect = true;
        e.round = Some(0);
        assert!(matches!(e.choose(false, clock.now()), Step::BringUp));
    });
}

#[test]
fn choose_asks_the_level_then_reads_the_round_then_waits_for_the_tick() {
    decide(|_, clock, e| {
        let now = clock.now();
        e.next_tick = now + Duration::from_millis(100);
        e.detect = true;
        e.round = Some(0);
        assert!(matches!(e.choose(true, now), Step::Detect));
        e.detect = false;
        assert!(matches!(
            e.choose(true, now),
            Step::StatusPoll(PollStep::RobotState)
        ));
        e.round = Some(PollStep::ROUND.len());
        let Step::Wait(until) = e.choose(true, now) else {
            panic!("not a wait");
        };
        assert_eq!(until, e.next_tick);
    });
}

#[test]
fn the_tick_starts_a_status_round_once_per_period() {
    decide(|hub, clock, e| {
        let now = clock.now();
        e.tick(true, now);
        assert_eq!(e.round, Some(0));
        assert_eq!(e.next_tick, now + Duration::from_millis(100));
        e.round = None;
        e.tick(true, now + Duration::from_millis(99));
        assert_eq!(e.round, None, "not before the period");
        assert_eq!(hub.with(|m| m.ticks), 1);
    });
}

#[test]
fn an_error_code_is_explained_from_the_table_unless_the_controller_can() {
    let code = 20005;
    decide(|hub, _, e| {
        // No level known (V5): the gateway's table, at once.
        hub.with(|m| m.robot.error_code = code);
        assert_eq!(e.error_to_explain(), None);
        let (got, source) = hub.with(|m| (m.error_text.code, m.error_text.source));
        assert_eq!(got, code);
        let table = if ErrorCode::from(code).text().is_some() {
            TextSource::Table
        } else {
            TextSource::Unknown
        };
        assert_eq!(source, table);
        // Explained once.
        assert_eq!(e.error_to_explain(), None);
        // A V6 controller explains a code a command ended with.
        hub.with(|m| m.link.level = Some(ProtocolLevel::V6));
        e.explain.set(Some(code));
        assert_eq!(e.error_to_explain(), Some(code));
    });
}

#[test]
fn a_refused_connect_backs_off_doubling_to_the_longest_delay() {
    let mut rig = Rig::new(Config::default(), true);
    rig.robot.set_offline(true);
    let mut at = std::vec::Vec::new();
    let mut seen = 0;
    while rig.now() < Instant::from_secs(20) {
        rig.run_for(Duration::from_millis(10));
        let n = rig.net.attempts(ROBOT);
        if n > seen {
            seen = n;
            at.push(rig.now().as_millis());
        }
    }
    let gaps: std::vec::Vec<u64> = at.windows(2).map(|w| w[1] - w[0]).collect();
    let mut want = MIN_BACKOFF.as_millis();
    for g in &gaps {
        // Each retry waits its delay (seen in 10 ms steps here).
        assert!(g + 10 >= want && *g <= want + 10, "gaps {gaps:?}");
        want = (want * 2).min(MAX_BACKOFF.as_millis());
    }
    assert!(gaps.len() >= 5, "gaps {gaps:?}");
    assert_eq!(rig.link_state(), LinkState::Down);
}

#[test]
fn a_jog_starts_only_while_held_and_at_a_level_that_has_jogging() {
    use crate::error::GatewayError;
    use crate::job::command::Jog;
    use crate::job::{Command, Job, JobKind, Source};

    use super::Outcome;

    let jog = |source| Job {
        source,
        seq: 0,
        robot: 0,
        kind: JobKind::Command(Command::Jog(Jog {
            cartesian: false,
            axis: 0,
            positive: true,
        })),
    };
    decide(|hub, _, e| {
        let held = Source::Trigger(0);
        // Released before it could start: a jog of no length.
        assert_eq!(e.jog_gate(&jog(held)), Some(Outcome::Done));
        hub.with(|m| m.triggers.bits = 1);
        // Held, but no level known (V5): no jogging.
        assert_eq!(
            e.jog_gate(&jog(held)),
            Some(Outcome::gateway(GatewayError::NotSupported))
        );
        hub.with(|m| m.link.level = Some(ProtocolLevel::V6));
        assert_eq!(e.jog_gate(&jog(held)), None);
        assert!(!e.jog_released(held));
        // Let go.
        hub.with(|m| m.triggers.bits = 0);
        assert!(e.jog_released(held));
        // Not a jog: no gate.
        let stop = Job {
            kind: JobKind::Command(Command::ReadActPos),
            ..jog(held)
        };
        assert_eq!(e.jog_gate(&stop), None);
    });
}

/// What a reply does to a job: typed values applied, a Fail and an
/// errorcmd named, a reply to another command refused, the RAW reply kept.
#[test]
fn on_reply_judges_a_reply_against_its_request() {
    use crate::error::{ErrorSource, GatewayError, Outcome};
    use crate::job::{Job, Source};
    decide(|hub, _, e| {
        let job = |text: &[u8], source| {
            let (kind, _) = crate::job::text::build(text).unwrap();
            Job {
                source,
                seq: 1,
                robot: 0,
                kind,
            }
        };
        let mut buf = [0u8; 256];
        let mut judge = |e: &mut Engine<'_, VirtualClock>, j: &Job, reply: &str| {
            let msg = j.encode(0, &mut buf).unwrap();
            e.on_reply(j, &msg, reply)
        };
        // An accepted override is applied to the status.
        let ovr = job(b"SetOverride,0,0.5,;", Source::Channel(0));
        assert_eq!(judge(e, &ovr, "SetOverride,OK,;"), None);
        assert_eq!(hub.with(|m| m.robot.override_ratio), Some(0.5));
        // A Fail is the robot's error, with its code.
        assert_eq!(
            judge(e, &ovr, "SetOverride,Fail,20018,;"),
            Some(Outcome::Error(ErrorSource::RobotFail, 20018))
        );
        // An errorcmd, and a reply to another command.
        assert_eq!(
            judge(e, &ovr, "errorcmd,;"),
            Some(Outcome::gateway(GatewayError::BadReply))
        );
        assert_eq!(
            judge(e, &ovr, "GrpStop,OK,;"),
            Some(Outcome::gateway(GatewayError::ReplyMismatch))
        );
        // RAW keeps the reply as it came, whatever it says.
        let raw = job(b"ReadOverride,0,;", Source::Raw);
        assert_eq!(judge(e, &raw, "ReadOverride,OK,0.25,;"), None);
        assert_eq!(
            hub.with(|m| m.raw.reply.bytes().to_vec()),
            b"ReadOverride,OK,0.25,;".to_vec()
        );
        assert_eq!(
            judge(e, &raw, "ReadOverride,Fail,20005,;"),
            Some(Outcome::Error(ErrorSource::RobotFail, 20005))
        );
        assert_eq!(
            hub.with(|m| m.raw.reply.bytes().to_vec()),
            b"ReadOverride,Fail,20005,;".to_vec()
        );
    });
}
