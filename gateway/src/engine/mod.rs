//! The command engine: the only user of the robot link.
//!
//! Its rules live in the submodules, each testable alone:
//! `crate::plc` (what the PLC's writes do), [`motion`] (when a motion is Done),
//! [`watchdog`], [`bringup`] (Power on, Enable), [`poll`] (the status
//! reads). This module runs them in time: one step at a time, chosen by
//! `Engine::choose` in a fixed priority order:
//!
//! 1. the link is down: bring it up (connect, listen, or wait out the
//!    backoff of [`MIN_BACKOFF`] doubling to [`MAX_BACKOFF`]);
//! 2. the watchdog expired during a motion (or the heartbeat a jog needs
//!    stopped): act;
//! 3. the controller's protocol level is to be detected (once per
//!    connection, `CFG_PROTOCOL` 0): ask it (`PackageVersion`);
//! 4. a held jog was released: stop it; its keep-alive is due: send it
//!    ([`jog`]);
//! 5. a job may go: send it (urgent jobs first; while a motion runs a
//!    motion at the head of the queue waits; while a bring-up step waits
//!    for its state only urgent jobs go);
//! 6. the motion poll is due ([`motion::MOTION_POLL`]);
//! 7. the bring-up poll is due ([`bringup::STATE_POLL`]);
//! 8. a robot error code wants its text (`GetErrorCodeStr`, V6);
//! 9. the status round has a read left (one round per `CFG_POLL_MS`);
//! 10. else wait for the earliest deadline, a wake from the PLC side, or a
//!     link event (lost, or a new connection in listen mode: the
//!     controller's replaces the link, another host's is refused; see
//!     [`crate::link::admits`]).
//!
//! One request is in flight at a time. A reply timeout ends the command in
//! Error and resets the link; when the link drops, every queued and running
//! command ends in Error (link lost) and nothing is re-sent.

pub(crate) mod bringup;
pub(crate) mod jog;
pub(crate) mod motion;
pub(crate) mod poll;
#[cfg(test)]
mod tests;
pub(crate) mod watchdog;

use core::convert::Infallible;

use embassy_futures::select::{select, select3, Either, Either3};
use embassy_time::{Duration, Instant};
use hans_codec::{
    response, CommandId, ErrorCode, FsmState, ParseError, ProtocolLevel, Reply, Response,
};

pub(crate) use crate::error::{ErrorSource, GatewayError, Outcome};

use crate::clock::{millis, Clock};
use crate::config::{Config, LinkMode, ProtocolSetting, StatusSource, WatchdogAction};
use crate::hub::{ConfigReceiver, Hub};
use crate::job::{Gate, Job, JobKind, Message, Source, Urgent};
use crate::link::{Accepted, IdleEvent, Link, LinkError, Target};
use crate::net::Socket;
use crate::state::history::LogEvent;
use crate::state::{LinkState, TextSource};
use bringup::{StepWait, Verdict};
use motion::{Judgement, Motion, MOTION_POLL};
use poll::{PollStep, UNTYPED};

/// First reconnect delay.
pub(crate) const MIN_BACKOFF: Duration = Duration::from_millis(200);
/// Longest reconnect delay.
pub(crate) const MAX_BACKOFF: Duration = Duration::from_secs(5);
/// Room for one request: a RAW text and the longest typed command.
const MSG_BUF: usize = 320;

/// A job between two messages, or after its last one, waiting for the
/// state its last bring-up step leads to.
struct Pending {
    job: Job,
    /// The next message to send.
    next: u8,
    wait: StepWait,
    deadline: Instant,
}

/// What the engine does next (see the module documentation for the order).
enum Step {
    BringUp,
    Watchdog,
    Detect,
    #[cfg(feature = "v6")]
    JogStop,
    #[cfg(feature = "v6")]
    JogKeepAlive,
    Job(Gate),
    MotionPoll,
    BringUpPoll,
    Explain(i32),
    StatusPoll(PollStep),
    Wait(Instant),
}

/// The link was lost (already handled: every command ended, backoff set).
struct Lost;

/// What a status read gave the engine.
enum Polled {
    /// Nothing it needs (the status may have been updated).
    Nothing,
    /// The robot refused the read (`Fail`, `errorcmd`): it lacks it.
    Refused,
    /// The reply could not be read (the link stays).
    Unreadable,
    /// `ReadRobotState`.
    State(response::ReadRobotState),
    /// `ReadCurFSM`.
    Fsm(FsmState),
}

fn target_of(c: &Config) -> Target {
    match c.link_mode {
        LinkMode::Listen => Target::Listen {
            port: c.listen_port,
            controller: c.robot_ip,
        },
        LinkMode::Connect if c.robot_ip.is_unspecified() => Target::None,
        LinkMode::Connect => Target::Connect(c.robot()),
    }
}

/// `true` if reply name `a` answers request name `b`: the same name, or
/// two names (aliases) of one known command.
fn same_command(a: &str, b: &str) -> bool {
    a == b || CommandId::from_name(a).is_some_and(|id| CommandId::from_name(b) == Some(id))
}

/// Runs the engine forever on a link over sockets `a` and `b` (built here,
/// in place: the link holds kilobytes of buffers).
pub(crate) async fn run<S: Socket, C: Clock>(hub: &Hub, clock: &C, a: S, b: S) -> Infallible {
    let mut link = Link::new(a, b);
    let mut e = Engine::new(hub, clock);
    loop {
        e.step(&mut link).await;
    }
}

/// Waits for a queued job (`None`) or an applied configuration.
async fn woken(hub: &Hub, config_rx: &mut Option<ConfigReceiver<'_>>) -> Option<Config> {
    let applied = async {
        match config_rx {
            Some(r) => r.changed().await,
            None => core::future::pending().await,
        }
    };
    match select(hub.job_queued.wait(), applied).await {
        Either::First(()) => None,
        Either::Second(c) => Some(c),
    }
}

/// The engine's own state (the shared state is the hub's model).
pub(crate) struct Engine<'a, C: Clock> {
    hub: &'a Hub,
    clock: &'a C,
    config: Config,
    /// Configurations applied since the last step (`None`: a second
    /// engine on one hub, which has no receiver; it keeps its start
    /// configuration).
    config_rx: Option<ConfigReceiver<'a>>,
    /// A configuration taken from `config_rx` while waiting, for the next
    /// `follow_config`.
    applied: Option<Config>,
    target: Target,
    motion: Option<Motion>,
    pending: Option<Pending>,
    /// The next read of the status round, while a round is under way.
    round: Option<usize>,
    next_tick: Instant,
    next_motion_poll: Instant,
    next_state_poll: Instant,
    retry_at: Instant,
    backoff: Duration,
    buf: [u8; MSG_BUF],
    /// The protocol level is to be asked on this connection.
    detect: bool,
    /// A robot error code whose text is wanted (set where commands end).
    explain: core::cell::Cell<Option<i32>>,
    /// The robot error code (`ROBOT_ERROR_CODE`) last explained.
    explained: i32,
}

impl<'a, C: Clock> Engine<'a, C> {
    /// An engine on `hub`'s active configuration, its link down, every
    /// deadline now.
    pub(crate) fn new(hub: &'a Hub, clock: &'a C) -> Self {
        let config = hub.with(|m| m.config.active);
        let config_rx = hub.config_applied.receiver();
        if config_rx.is_none() {
            warn!("engine: a second engine on one hub does not follow the configuration");
        }
        let now = clock.now();
        Engine {
            hub,
            clock,
            config,
            config_rx,
            applied: None,
            target: target_of(&config),
            motion: None,
            pending: None,
            round: None,
            next_tick: now,
            next_motion_poll: now,
            next_state_poll: now,
            retry_at: now,
            backoff: MIN_BACKOFF,
            buf: [0; MSG_BUF],
            detect: false,
            explain: core::cell::Cell::new(None),
            explained: 0,
        }
    }

    async fn step<S: Socket>(&mut self, link: &mut Link<S>) {
        self.follow_config(link).await;
        let now = self.clock.now();
        self.tick(link.is_up(), now);
        match self.choose(link.is_up(), now) {
            Step::BringUp => self.bring_up(link).await,
            Step::Watchdog => self.watchdog(link).await,
            Step::Detect => self.detect_level(link).await,
            #[cfg(feature = "v6")]
            Step::JogStop => self.jog_stop(link).await,
            #[cfg(feature = "v6")]
            Step::JogKeepAlive => self.jog_keep_alive(link).await,
            Step::Explain(code) => self.explain_error(link, code).await,
            Step::Job(gate) => {
                let job = self.hub.with(|m| {
                    let job = m.queue.take(gate)?;
                    m.set_running(job.source);
                    Some(job)
                });
                if let Some(job) = job {
                    self.run_job(link, job, 0).await;
                }
            }
            Step::MotionPoll => self.poll_motion(link).await,
            Step::BringUpPoll => self.poll_bringup(link).await,
            Step::StatusPoll(step) => self.poll_status(link, step).await,
            Step::Wait(until) => self.wait(link, until).await,
        }
    }

    /// The gateway's heartbeat, and the start of a status round, every
    /// poll period.
    fn tick(&mut self, link_up: bool, now: Instant) {
        if now < self.next_tick {
            return;
        }
        self.next_tick = now + millis(self.config.poll_ms);
        self.hub.with(|m| m.ticks = m.ticks.wrapping_add(1));
        if link_up && self.round.is_none() && self.config.status_source == StatusSource::Polling {
            self.round = Some(0);
        }
    }

    /// The next step, in the priority order of the module documentation.
    fn choose(&mut self, link_up: bool, now: Instant) -> Step {
        if !link_up {
            return Step::BringUp;
        }
        let period = self.watch_period();
        let motion = self.motion.is_some();
        let last_beat = self.hub.with(|m| {
            // A lost heartbeat is for the motion that ran when it was lost.
            m.plc.lost &= motion;
            watchdog::Beat {
                last: m.plc.last_beat,
                lost: m.plc.lost,
            }
        });
        if let Some(mo) = &self.motion {
            if watchdog::expired(mo, last_beat, period, now) {
                return Step::Watchdog;
            }
        }
        if self.detect {
            return Step::Detect;
        }
        #[cfg(feature = "v6")]
        if let Some(mo) = &self.motion {
            if let Some(j) = mo.jog.filter(|j| !j.stopping) {
                if self.jog_released(mo.source) {
                    return Step::JogStop;
                }
                if now >= j.next_event {
                    return Step::JogKeepAlive;
                }
            }
        }
        let gate = if self.pending.is_some() {
            Gate::UrgentOnly
        } else if self.motion.is_some() {
            Gate::MotionRunning
        } else {
            Gate::Open
        };
        if self.hub.with(|m| m.queue.can_take(gate)) {
            return Step::Job(gate);
        }
        if self.motion.is_some() && now >= self.next_motion_poll {
            return Step::MotionPoll;
        }
        if self.pending.is_some() && now >= self.next_state_poll {
            return Step::BringUpPoll;
        }
        if let Some(code) = self.error_to_explain() {
            return Step::Explain(code);
        }
        if let Some(step) = self.round.and_then(|i| PollStep::ROUND.get(i)) {
            return Step::StatusPoll(*step);
        }
        let mut due = self.next_tick;
        if self.motion.is_some() {
            due = due.min(self.next_motion_poll);
        }
        if self.pending.is_some() {
            due = due.min(self.next_state_poll);
        }
        #[cfg(feature = "v6")]
        if let Some(j) = self.motion.and_then(|mo| mo.jog).filter(|j| !j.stopping) {
            due = due.min(j.next_event);
        }
        if let Some(w) = self
            .motion
            .as_ref()
            .and_then(|mo| watchdog::deadline(mo, last_beat, period))
        {
            due = due.min(w);
        }
        Step::Wait(due)
    }

    /// The heartbeat period the watchdog holds the running motion to:
    /// `CFG_WATCHDOG_MS`, and for a jog [`jog::HEARTBEAT`] when that is off.
    fn watch_period(&self) -> u16 {
        match self.motion {
            Some(mo) if mo.jog.is_some() && self.config.watchdog_ms == 0 => jog::HEARTBEAT,
            _ => self.config.watchdog_ms,
        }
    }

    /// A robot error code that wants its text: one a command ended with,
    /// or a new `ROBOT_ERROR_CODE`. Codes the controller cannot explain
    /// (V5, or a build without the V6 commands) are explained from the
    /// gateway's table at once, without a request.
    fn error_to_explain(&mut self) -> Option<i32> {
        let code = match self.explain.take() {
            Some(c) => c,
            None => {
                let now_code = self.hub.with(|m| m.robot.error_code);
                if now_code == self.explained {
                    return None;
                }
                self.explained = now_code;
                if now_code == 0 {
                    return None;
                }
                now_code
            }
        };
        if self.controller_explains() {
            return Some(code);
        }
        self.explain_from_table(code);
        None
    }

    /// The gateway's text for robot error `code` into the error text
    /// registers (or "unknown error code").
    fn explain_from_table(&self, code: i32) {
        let (source, text) = match ErrorCode::from(code).text() {
            Some(t) => (TextSource::Table, t),
            None => (TextSource::Unknown, "unknown error code"),
        };
        self.hub
            .with(|m| m.error_text.set(code, source, text.as_bytes()));
    }

    /// The PLC let go of the jog of `source` (Execute fell, or the
    /// handshake says released).
    #[cfg(feature = "v6")]
    fn jog_released(&self, source: Source) -> bool {
        self.hub
            .with(|m| !m.execute_held(source) || m.handshake(source).is_some_and(|h| h.released))
    }

    /// The controller has `GetErrorCodeStr` (and this build can ask it).
    fn controller_explains(&self) -> bool {
        #[cfg(feature = "v6")]
        {
            let level = self.hub.with(|m| m.link.level);
            level.is_some_and(|l| l >= CommandId::GetErrorCodeStr.since())
        }
        #[cfg(not(feature = "v6"))]
        false
    }

    fn set_link_state(&self, st: LinkState) {
        self.hub.with(|m| m.link.state = st);
    }

    fn end(&self, source: Source, outcome: Outcome) {
        if let Outcome::Error(ErrorSource::RobotFail | ErrorSource::RobotMotion, code) = outcome {
            self.explain.set(Some(code));
        }
        let now = self.clock.now();
        self.hub.with(|m| m.finish(source, outcome, now));
    }

    fn deadline(&self) -> Instant {
        self.clock.now() + millis(self.config.reply_timeout_ms)
    }

    /// Returns at `until`, or earlier when a job was queued or a
    /// configuration applied (the next step picks that up).
    async fn woken_or_until(&mut self, until: Instant) {
        let (hub, clock) = (self.hub, self.clock);
        let woken = woken(hub, &mut self.config_rx);
        if let Either::First(Some(c)) = select(woken, clock.sleep_until(until)).await {
            self.applied = Some(c);
        }
    }

    /// Nothing to do until `until`, a wake, or a link event.
    async fn wait<S: Socket>(&mut self, link: &mut Link<S>, until: Instant) {
        let idle = link.idle(self.target, self.clock);
        let (hub, clock) = (self.hub, self.clock);
        let woken = woken(hub, &mut self.config_rx);
        match select3(idle, woken, clock.sleep_until(until)).await {
            Either3::Second(Some(c)) => self.applied = Some(c),
            Either3::First(IdleEvent::Lost(e)) => {
                warn!("robot link: {}", e.as_str());
                self.link_lost(link, GatewayError::LinkLost).await;
            }
            Either3::First(IdleEvent::Replaced(p)) => {
                let [a, b, c, d] = p.ip().octets();
                warn!(
                    "robot link: the controller connected again from {}.{}.{}.{}:{}; the new connection replaces the old",
                    a,
                    b,
                    c,
                    d,
                    p.port()
                );
                let peer = Some(*p.ip());
                let now = self.clock.now();
                self.hub.with(|m| {
                    // The same address (`link::admits`): the DataSheet stays.
                    m.link.peer = peer;
                    m.link.connects = m.link.connects.wrapping_add(1);
                    m.log.link(LogEvent::LinkUp(peer), now);
                });
            }
            Either3::First(IdleEvent::Refused(p)) => self.refused(p),
            _ => {}
        }
    }

    /// Picks up a changed configuration; a changed robot address drops the
    /// link.
    async fn follow_config<S: Socket>(&mut self, link: &mut Link<S>) {
        let stashed = self.applied.take();
        let latest = self.config_rx.as_mut().and_then(|r| r.try_changed());
        let Some(config) = latest.or(stashed) else {
            return;
        };
        let protocol_changed = config.protocol != self.config.protocol;
        self.config = config;
        if protocol_changed && link.is_up() {
            self.detect = config.protocol == ProtocolSetting::Detect;
            let level = match config.protocol {
                ProtocolSetting::Detect => None,
                ProtocolSetting::V5 => Some(ProtocolLevel::V5),
                ProtocolSetting::V6 => Some(ProtocolLevel::V6),
            };
            self.hub.with(|m| m.link.level = level);
        }
        let target = target_of(&config);
        // Listen mode, the same port, another `robot.address`: a live link
        // from the address now configured (or any, with 0.0.0.0) stays.
        let keeps = match (self.target, target) {
            (Target::Listen { port: old, .. }, Target::Listen { port, controller }) => {
                old == port
                    && link.is_up()
                    && link
                        .live()
                        .is_some_and(|l| crate::link::admits(controller, None, l))
            }
            _ => false,
        };
        if keeps {
            self.target = target;
        } else if target != self.target {
            info!("robot link: target changed");
            if link.is_up() {
                self.link_lost(link, GatewayError::LinkLost).await;
            }
            link.close_all().await;
            self.target = target;
            self.backoff = MIN_BACKOFF;
            self.retry_at = self.clock.now();
        }
    }

    /// The link is down: connect, listen, or wait out the backoff.
    async fn bring_up<S: Socket>(&mut self, link: &mut Link<S>) {
        let now = self.clock.now();
        self.hub
            .with(|m| m.fail_queue(GatewayError::NotConnected, now));
        match self.target {
            Target::None => {
                self.set_link_state(LinkState::Down);
                self.woken_or_until(self.next_tick).await;
            }
            Target::Connect(addr) => {
                if now < self.retry_at {
                    self.set_link_state(LinkState::Down);
                    let due = self.retry_at.min(self.next_tick);
                    self.woken_or_until(due).await;
                    return;
                }
                self.set_link_state(LinkState::Connecting);
                // Bounded by CONNECT_TIMEOUT; awaited whole so that slow
                // connects are not cut by the poll tick.
                match link.establish(Target::Connect(addr), self.clock).await {
                    Ok(Accepted::Up) => self.on_connected(link),
                    Ok(Accepted::Refused(p)) => self.refused(p),
                    Err(e) => {
                        debug!("robot link: connect failed: {}", e.as_str());
                        self.backoff_after(GatewayError::ConnectFailed);
                    }
                }
            }
            Target::Listen { .. } => {
                self.set_link_state(LinkState::Listening);
                let accept = link.establish(self.target, self.clock);
                let woken = woken(self.hub, &mut self.config_rx);
                match select3(accept, woken, self.clock.sleep_until(self.next_tick)).await {
                    Either3::Second(Some(c)) => self.applied = Some(c),
                    Either3::First(Ok(Accepted::Up)) => self.on_connected(link),
                    // Not the controller: closed; keep listening, no backoff.
                    Either3::First(Ok(Accepted::Refused(p))) => self.refused(p),
                    Either3::First(Err(e)) => {
                        warn!("robot link: listen failed: {}", e.as_str());
                        self.backoff_after(GatewayError::ConnectFailed);
                        self.clock.sleep_until(self.retry_at).await;
                    }
                    _ => {}
                }
            }
        }
    }

    fn backoff_after(&mut self, e: GatewayError) {
        self.retry_at = self.clock.now() + self.backoff;
        self.backoff = (self.backoff * 2).min(MAX_BACKOFF);
        self.hub.with(|m| {
            m.link.state = LinkState::Down;
            m.link.last_error = Some(e);
        });
    }

    /// Listen mode: a host that is not the controller connected (its
    /// connection is closed already): logged and counted.
    fn refused(&mut self, peer: Option<core::net::SocketAddrV4>) {
        match peer {
            Some(p) => {
                let [a, b, c, d] = p.ip().octets();
                warn!(
                    "robot link: refused a connection from {}.{}.{}.{}:{}: not the controller",
                    a,
                    b,
                    c,
                    d,
                    p.port()
                );
            }
            None => warn!("robot link: refused a connection from an unknown address"),
        }
        self.hub
            .with(|m| m.link.refused = m.link.refused.wrapping_add(1));
        #[cfg(feature = "audit")]
        self.hub.audit_refused_robot(peer.map(|p| *p.ip()));
    }

    fn on_connected<S: Socket>(&mut self, link: &Link<S>) {
        self.backoff = MIN_BACKOFF;
        if let Some(p) = link.peer() {
            let [a, b, c, d] = p.ip().octets();
            info!("robot link: up, peer {}.{}.{}.{}:{}", a, b, c, d, p.port());
        } else {
            info!("robot link: up");
        }
        if let Target::Listen { controller, .. } = self.target {
            if controller.is_unspecified() {
                warn!("robot link: robot.address is not set: the first controller to connect was accepted; set it so that only the controller may");
            }
        }
        let peer = link.peer().map(|p| *p.ip());
        let now = self.clock.now();
        let level = match self.config.protocol {
            ProtocolSetting::Detect => None,
            ProtocolSetting::V5 => Some(ProtocolLevel::V5),
            ProtocolSetting::V6 => Some(ProtocolLevel::V6),
        };
        self.detect = level.is_none();
        self.hub.with(|m| {
            m.link.state = LinkState::Connected;
            m.link.peer = peer;
            m.link.connects = m.link.connects.wrapping_add(1);
            m.link.level = level;
            m.log.link(LogEvent::LinkUp(peer), now);
        });
        if self.config.status_source == StatusSource::Polling {
            self.round = Some(0);
        }
    }

    /// The link is gone: every queued and running command ends in Error
    /// 39601, the status becomes unknown, the link backs off (`cause` shows
    /// in `LINK_LAST_ERROR`).
    async fn link_lost<S: Socket>(&mut self, link: &mut Link<S>, cause: GatewayError) {
        let motion = self.motion.take();
        let pending = self.pending.take();
        self.round = None;
        let now = self.clock.now();
        self.hub.with(|m| {
            let lost = Outcome::gateway(GatewayError::LinkLost);
            if let Some(mo) = motion {
                m.finish(mo.source, lost, now);
            }
            if let Some(p) = pending {
                m.finish(p.job.source, lost, now);
            }
            m.fail_queue(GatewayError::LinkLost, now);
            m.log.link(LogEvent::LinkDown(cause), now);
            // No controller is connected now (listen mode: the DataSheet
            // follows the next one, from wherever it connects).
            m.link.peer = None;
            m.link.level = None;
            m.link.losses = m.link.losses.wrapping_add(1);
            m.robot.invalidate();
        });
        link.close().await;
        warn!("robot link: lost ({}), reconnecting", cause.as_str());
        self.backoff_after(cause);
    }

    /// Sends `self.buf[..len]` and waits for its reply: the reply text, or
    /// why there is none: [`GatewayError::BadReply`] for a frame that
    /// cannot be read (the link stays), [`GatewayError::ReplyTimeout`] or
    /// [`GatewayError::LinkLost`] (the caller resets the link).
    async fn transact<'l, S: Socket>(
        &mut self,
        link: &'l mut Link<S>,
        len: usize,
    ) -> Result<&'l str, GatewayError> {
        let deadline = self.deadline();
        let msg = self.buf.get(..len).unwrap_or(&[]);
        link.transact(msg, deadline, self.clock)
            .await
            .map_err(|e| match e {
                LinkError::BadFrame(_) => GatewayError::BadReply,
                LinkError::Timeout => GatewayError::ReplyTimeout,
                LinkError::Lost(_) => GatewayError::LinkLost,
            })
    }

    /// Sends `self.buf[..len]` and hands its reply text to `read` (`None`
    /// for a reply that cannot be read: the link stays). A reply timeout or
    /// a lost connection is logged as `what`, and the link is reset
    /// ([`Self::link_lost`]): `Err(Lost)`. The one place a request's
    /// failure is handled, but for a job's ([`Self::run_job`]: it ends the
    /// job first).
    async fn exchange<S: Socket, R>(
        &mut self,
        link: &mut Link<S>,
        len: usize,
        what: &str,
        read: impl FnOnce(Option<&str>) -> R,
    ) -> Result<R, Lost> {
        match self.transact(link, len).await {
            Ok(text) => Ok(read(Some(text))),
            Err(GatewayError::BadReply) => Ok(read(None)),
            Err(cause) => {
                warn!("{}: {}", what, cause.as_str());
                self.link_lost(link, cause).await;
                Err(Lost)
            }
        }
    }

    /// Sends a job's messages from `from` in turn and ends it (or starts its
    /// motion). After a bring-up step's `OK` the job waits until the FSM
    /// shows the step's state ([`Self::poll_bringup`]).
    async fn run_job<S: Socket>(&mut self, link: &mut Link<S>, job: Job, from: u8) {
        let source = job.source;
        #[cfg(feature = "v6")]
        if let Some(outcome) = self.jog_gate(&job) {
            self.end(source, outcome);
            return;
        }
        let mut last = None;
        for step in from..job.steps() {
            let Some(msg) = job.encode(step, &mut self.buf) else {
                self.end(source, Outcome::gateway(GatewayError::BadParameter));
                return;
            };
            info!(
                "{} {}: send {}",
                source.name(),
                source.index(),
                core::str::from_utf8(self.buf.get(..msg.len).unwrap_or(&[])).unwrap_or("?")
            );
            last = msg.id;
            let sent = self.buf.get(..msg.len).unwrap_or(&[]);
            self.hub.with(|m| m.note_send(source, sent));
            let outcome = match self.transact(link, msg.len).await {
                Ok(text) => {
                    self.hub.with(|m| m.note_reply(source, text.as_bytes()));
                    self.on_reply(&job, &msg, text)
                }
                Err(GatewayError::BadReply) => Some(Outcome::gateway(GatewayError::BadReply)),
                Err(cause) => {
                    let own = match cause {
                        GatewayError::ReplyTimeout => cause,
                        _ => GatewayError::LinkLost,
                    };
                    warn!("{} {}: {}", source.name(), source.index(), own.as_str());
                    self.end(source, Outcome::gateway(own));
                    self.link_lost(link, cause).await;
                    return;
                }
            };
            if let Some(outcome) = outcome {
                self.end(source, outcome);
                if outcome == Outcome::gateway(GatewayError::ReplyMismatch) {
                    // Replies no longer match requests: start afresh.
                    self.link_lost(link, GatewayError::ReplyMismatch).await;
                }
                return;
            }
            if let Some(wait) = last.and_then(StepWait::after) {
                debug!(
                    "{} {}: waiting for {}",
                    source.name(),
                    source.index(),
                    wait.as_str()
                );
                let now = self.clock.now();
                self.pending = Some(Pending {
                    job,
                    next: step + 1,
                    wait,
                    deadline: now + bringup::STATE_TIMEOUT,
                });
                self.next_state_poll = now + bringup::STATE_POLL;
                return;
            }
        }
        self.all_sent(&job, last);
    }

    /// How a jog job ends before it is sent, if it may not start: released
    /// already (Done: a jog of no length), or the controller's protocol
    /// level has no jogging (Error `NotSupported`). `None` for any other
    /// job.
    #[cfg(feature = "v6")]
    fn jog_gate(&self, job: &Job) -> Option<Outcome> {
        job.jog()?;
        let source = job.source;
        if self.jog_released(source) {
            info!(
                "{} {}: jog released before it started",
                source.name(),
                source.index()
            );
            return Some(Outcome::Done);
        }
        let level = self.hub.with(|m| m.link.level).unwrap_or(ProtocolLevel::V5);
        if level < crate::job::command::Jog::since() {
            warn!(
                "{} {}: no jogging at this protocol level",
                source.name(),
                source.index()
            );
            return Some(Outcome::gateway(GatewayError::NotSupported));
        }
        None
    }

    /// Every message of `job` was accepted (`last` the id of the last
    /// one): it starts its motion, or ends Done (a `GrpContinue` restarts
    /// the motion's clock, a `GrpStop` aborts the motions).
    fn all_sent(&mut self, job: &Job, last: Option<CommandId>) {
        let source = job.source;
        let now = self.clock.now();
        if job.is_motion() {
            self.hub.with(|m| m.set_moving(source));
            let mut mo = Motion::new(source, now);
            mo.jog = job.jog().map(|j| jog::JogRun::new(j, job.robot, now));
            self.motion = Some(mo);
            self.next_motion_poll = now + MOTION_POLL;
            return;
        }
        if last == Some(CommandId::GrpContinue) {
            if let Some(mo) = self.motion.as_mut() {
                mo.restarted(now);
            }
        }
        if last == Some(CommandId::GrpStop) {
            // MC_Stop: the running motion and every motion still waiting
            // end in CommandAborted; waiting non-motion commands go on.
            let stopped = self.motion.take();
            let now = self.clock.now();
            self.hub.with(|m| {
                if let Some(mo) = stopped {
                    m.finish(mo.source, Outcome::Aborted, now);
                }
                m.abort_queued_motions(now);
            });
        }
        self.end(source, Outcome::Done);
    }

    /// Reads the reply `text` to message `msg` of `job`: `None` when the
    /// robot accepted it (the job goes on), else how the job ends.
    fn on_reply(&self, job: &Job, msg: &Message, text: &str) -> Option<Outcome> {
        let parsed = match Reply::parse(text, msg.expect) {
            // An OK the codec cannot type (extra values, as newer firmware
            // may send): the robot accepted the command. Success where the
            // gateway does not use the values; typed checks stay where it
            // does. Any error but NameMismatch comes after the codec matched
            // the name (aliases too).
            Err(e) if !job.fills_results() && !matches!(e, ParseError::NameMismatch { .. }) => {
                match Reply::parse(text, UNTYPED) {
                    Ok(Reply::Ok(Response::Unknown(raw))) => {
                        warn!(
                            "{} {}: reply values not as documented, accepted: {}",
                            job.source.name(),
                            job.source.index(),
                            text
                        );
                        Ok(Reply::Ok(Response::Unknown(raw)))
                    }
                    _ => Err(e),
                }
            }
            p => p,
        };
        let req_name = match &job.kind {
            JobKind::Text(t) => t.name(),
            _ => msg.id.map_or("", CommandId::name),
        };
        self.hub.with(|m| {
            if job.source == Source::Raw {
                m.raw.set_reply(text.as_bytes());
            }
            match &parsed {
                Ok(Reply::Ok(Response::Unknown(raw))) if !same_command(raw.name(), req_name) => {
                    Some(Outcome::gateway(GatewayError::ReplyMismatch))
                }
                Ok(Reply::Ok(resp)) => {
                    m.robot.apply_response(resp);
                    if let (true, Response::ReadActPos(p), Source::Channel(i)) =
                        (job.fills_results(), resp, job.source)
                    {
                        if let Some(ch) = m.channels.get_mut(usize::from(i)) {
                            let mut r = [0f32; crate::state::inputs::RESULTS];
                            let all = p.joints.iter().chain(&p.pose).chain(&p.tcp).chain(&p.ucs);
                            for (slot, v) in r.iter_mut().zip(all) {
                                *slot = v.to_f32();
                            }
                            ch.results = Some(r);
                        }
                    }
                    let ratio = match &job.kind {
                        JobKind::Command(crate::job::Command::SetOverride(r)) => Some(*r),
                        JobKind::Text(t) => t.override_ratio,
                        _ => None,
                    };
                    if let Some(r) = ratio {
                        m.robot.override_ratio = Some(r.to_f32());
                    }
                    None
                }
                Ok(Reply::Fail(f)) => Some(Outcome::Error(ErrorSource::RobotFail, f.code.code())),
                Ok(Reply::ErrorCmd(_)) => Some(Outcome::gateway(GatewayError::BadReply)),
                Err(ParseError::NameMismatch { .. }) => {
                    Some(Outcome::gateway(GatewayError::ReplyMismatch))
                }
                Err(_) => Some(Outcome::gateway(GatewayError::BadReply)),
            }
        })
    }

    /// Sends the request of `step` and copies its reply into the status.
    async fn poll_step<S: Socket>(
        &mut self,
        link: &mut Link<S>,
        step: PollStep,
    ) -> Result<Polled, Lost> {
        let Some(msg) = step.request(self.config.robot_id, &mut self.buf) else {
            return Ok(Polled::Nothing);
        };
        let hub = self.hub;
        self.exchange(link, msg.len, "status", |text| {
            let Some(text) = text else {
                return Polled::Unreadable;
            };
            let Ok(reply) = Reply::parse(text, msg.expect) else {
                debug!("status: unreadable reply");
                return Polled::Unreadable;
            };
            hub.with(|m| step.apply(&reply, &mut m.robot));
            match reply {
                Reply::Ok(Response::ReadRobotState(rs)) => Polled::State(rs),
                Reply::Ok(Response::ReadCurFSM(f)) => Polled::Fsm(f.state),
                Reply::Ok(_) => Polled::Nothing,
                Reply::Fail(_) | Reply::ErrorCmd(_) => Polled::Refused,
            }
        })
        .await
    }

    /// One read of the status round.
    async fn poll_status<S: Socket>(&mut self, link: &mut Link<S>, step: PollStep) {
        if self.poll_step(link, step).await.is_err() {
            return;
        }
        let i = self.round.unwrap_or(0) + 1;
        if i >= PollStep::ROUND.len() {
            self.round = None;
            let now = self.clock.now();
            self.hub.with(|m| m.robot.updated = Some(now));
        } else {
            self.round = Some(i);
        }
    }

    /// `ReadRobotState` while a motion runs: decides Done or Error.
    async fn poll_motion<S: Socket>(&mut self, link: &mut Link<S>) {
        self.next_motion_poll = self.clock.now() + MOTION_POLL;
        let Ok(Polled::State(rs)) = self.poll_step(link, PollStep::RobotState).await else {
            return;
        };
        let now = self.clock.now();
        let Some(mo) = self.motion.as_mut() else {
            return;
        };
        let outcome = match mo.judge(&rs, &self.config, now) {
            Judgement::Running => return,
            Judgement::Failed(o) => o,
            Judgement::FlagsEnded => match self.confirm_done(link).await {
                Ok(true) => Outcome::Done,
                Ok(false) | Err(Lost) => return,
            },
        };
        let Some(mo) = self.motion.take() else {
            return;
        };
        self.end(mo.source, outcome);
        #[cfg(feature = "v6")]
        if let Some(j) = mo.jog.filter(|j| !j.stopping) {
            // A jog that failed while held: make sure it does not resume.
            self.send_jog_stop(link, j).await;
        }
        if matches!(outcome, Outcome::Error(..)) && self.config.auto_reset {
            info!("auto-reset: GrpReset after the motion error");
            self.send_internal(link, Urgent::Reset).await;
        }
    }

    /// The flags say the motion has ended. Done only if the FSM agrees (it
    /// changes at once, the moving flag ~50 ms late, e.g. after
    /// `GrpContinue`), and once the position is read (`ReadActPos`), so
    /// that Done means ACT_JOINTS and ACT_POSE are final. `Ok(false)`: not
    /// yet (polled again), also when an urgent command waits (it goes
    /// first), when the FSM's reply could not be read (read again at the
    /// next poll), and when the FSM shows a fault (the next
    /// `ReadRobotState` ends the motion in Error). A controller that refuses `ReadCurFSM` lacks it: the
    /// flags alone decide.
    async fn confirm_done<S: Socket>(&mut self, link: &mut Link<S>) -> Result<bool, Lost> {
        if self.hub.with(|m| m.queue.has_urgent()) {
            return Ok(false);
        }
        match self.poll_step(link, PollStep::Fsm).await? {
            Polled::Fsm(state) if bringup::motion_under_way(state) => {
                if let Some(mo) = self.motion.as_mut() {
                    mo.still_under_way();
                }
                return Ok(false);
            }
            // A fault stopped it between the two reads: not finished; the
            // next ReadRobotState says how it failed.
            Polled::Fsm(state) if bringup::fault_state(state) => return Ok(false),
            Polled::Unreadable => return Ok(false),
            _ => {}
        }
        if self.hub.with(|m| m.queue.has_urgent()) {
            return Ok(false);
        }
        // A refused or unreadable reply leaves the position as it is; the
        // motion is Done all the same (the robot said so twice).
        self.poll_step(link, PollStep::ActPos).await?;
        Ok(true)
    }

    /// `ReadCurFSM` for a job waiting after a bring-up step: goes on with
    /// the job once the step's state is reached, ends it in Error at a
    /// fault state or after [`bringup::STATE_TIMEOUT`].
    async fn poll_bringup<S: Socket>(&mut self, link: &mut Link<S>) {
        self.next_state_poll = self.clock.now() + bringup::STATE_POLL;
        let Ok(polled) = self.poll_step(link, PollStep::Fsm).await else {
            return;
        };
        let Some(p) = self.pending.as_ref() else {
            return;
        };
        let verdict = match polled {
            Polled::Fsm(s) => p.wait.verdict(s),
            _ => Verdict::Wait,
        };
        let verdict = match verdict {
            Verdict::Wait if self.clock.now() >= p.deadline => {
                Verdict::Failed(GatewayError::StateNotReached)
            }
            v => v,
        };
        match verdict {
            Verdict::Wait => {}
            Verdict::Reached => {
                // FSM_STATE shows the new state; make ROBOT_FLAGS agree
                // before the job goes on (or is Done).
                if self.poll_step(link, PollStep::RobotState).await.is_err() {
                    return;
                }
                if let Some(p) = self.pending.take() {
                    self.run_job(link, p.job, p.next).await;
                }
            }
            Verdict::Failed(e) => {
                if let Some(p) = self.pending.take() {
                    warn!(
                        "{} {}: {} not reached",
                        p.job.source.name(),
                        p.job.source.index(),
                        p.wait.as_str()
                    );
                    self.end(p.job.source, Outcome::gateway(e));
                }
            }
        }
    }

    /// Sends a command of the gateway's own (the watchdog's action, the
    /// automatic reset) to the configured robot; its reply is only logged.
    async fn send_internal<S: Socket>(&mut self, link: &mut Link<S>, cmd: Urgent) {
        let Some(msg) = cmd.encode(self.config.robot_id, &mut self.buf) else {
            return;
        };
        let name = cmd.id().name();
        let _ = self
            .exchange(link, msg.len, name, |text| {
                match text.map(|t| Reply::parse(t, msg.expect)) {
                    Some(Ok(Reply::Ok(_))) => info!("{}: sent, ok", name),
                    Some(Ok(Reply::Fail(f))) => warn!("{}: refused, code {}", name, f.code.code()),
                    _ => warn!("{}: unreadable reply", name),
                }
            })
            .await;
    }

    /// The watchdog expired during the running motion: trip, then act.
    async fn watchdog<S: Socket>(&mut self, link: &mut Link<S>) {
        let Some(mo) = self.motion.as_mut() else {
            return;
        };
        warn!(
            "watchdog: PLC heartbeat unchanged for {} ms during a motion",
            self.config.watchdog_ms
        );
        self.hub.with(|m| {
            m.plc.watchdog_tripped = true;
            m.plc.lost = false;
            m.plc.watchdog_trips = m.plc.watchdog_trips.wrapping_add(1);
        });
        watchdog::audit_trip(self.hub, &self.config, mo.jog.is_some());
        #[cfg(feature = "v6")]
        if let Some(j) = mo.jog {
            // A jog stops whatever the action says: it runs only while the
            // PLC is there to hold it.
            let source = mo.source;
            self.motion = None;
            let now = self.clock.now();
            self.hub.with(|m| {
                m.finish(source, Outcome::gateway(GatewayError::Watchdog), now);
                m.abort_queued_motions(now);
            });
            if !j.stopping {
                self.send_jog_stop(link, j).await;
            }
            return;
        }
        let urgent = match self.config.watchdog_action {
            WatchdogAction::ReportOnly => {
                mo.watchdog_fired = true;
                return;
            }
            WatchdogAction::Stop => Urgent::Stop,
            WatchdogAction::Pause => Urgent::Pause,
        };
        let source = mo.source;
        self.motion = None;
        let now = self.clock.now();
        self.hub.with(|m| {
            m.finish(source, Outcome::gateway(GatewayError::Watchdog), now);
            // As a Stop: the motions waiting behind it are not sent (and
            // nothing may start behind a held motion).
            m.abort_queued_motions(now);
        });
        self.send_internal(link, urgent).await;
    }

    /// Asks the controller its version (`PackageVersion`, HR6.2.17 and
    /// later); a controller without it (a `Fail`, `errorcmd`, an
    /// unreadable answer) speaks V5.
    async fn detect_level<S: Socket>(&mut self, link: &mut Link<S>) {
        self.detect = false;
        const ASK: &[u8] = b"PackageVersion,;";
        let Some(dst) = self.buf.get_mut(..ASK.len()) else {
            return;
        };
        dst.copy_from_slice(ASK);
        let asked = self.exchange(link, ASK.len(), "protocol level", |text| {
            match text.map(|t| Reply::parse(t, UNTYPED)) {
                Some(Ok(Reply::Ok(Response::Unknown(raw)))) => {
                    raw.fields().next().and_then(ProtocolLevel::parse)
                }
                _ => None,
            }
        });
        let Ok(level) = asked.await else {
            return;
        };
        let level = level.unwrap_or(ProtocolLevel::V5);
        let (major, minor, patch) = level.parts();
        info!("robot link: protocol level {}.{}.{}", major, minor, patch);
        self.hub.with(|m| m.link.level = Some(level));
    }

    /// Sends the stop of `j` (`LongJogJ/L,…,0`); its reply is only logged.
    #[cfg(feature = "v6")]
    async fn send_jog_stop<S: Socket>(&mut self, link: &mut Link<S>, j: jog::JogRun) {
        let Some(msg) = j.jog.request(j.robot, false, &mut self.buf) else {
            return;
        };
        let _ = self
            .exchange(link, msg.len, "jog: stop", |text| {
                match text.map(|t| Reply::parse(t, msg.expect)) {
                    Some(Ok(Reply::Ok(_))) => info!("jog: stopped"),
                    Some(Ok(Reply::Fail(f))) => {
                        warn!("jog: stop refused, code {}", f.code.code())
                    }
                    _ => warn!("jog: unreadable reply to the stop"),
                }
            })
            .await;
    }

    /// Execute fell while the jog ran: stop it; Done once the robot stands
    /// still (the motion poll decides).
    #[cfg(feature = "v6")]
    async fn jog_stop<S: Socket>(&mut self, link: &mut Link<S>) {
        let Some(j) = self.motion.as_mut().and_then(|mo| mo.jog.as_mut()) else {
            return;
        };
        j.stopping = true;
        let j = *j;
        self.send_jog_stop(link, j).await;
        self.next_motion_poll = self.clock.now();
    }

    /// The jog's keep-alive (`LongMoveEvent`). A refusal ends the jog in
    /// Error (the robot's code) and stops it.
    #[cfg(feature = "v6")]
    async fn jog_keep_alive<S: Socket>(&mut self, link: &mut Link<S>) {
        let now = self.clock.now();
        let Some(j) = self.motion.as_mut().and_then(|mo| mo.jog.as_mut()) else {
            return;
        };
        j.next_event = now + jog::KEEP_ALIVE;
        let Some(msg) = crate::job::command::Jog::keep_alive(j.robot, &mut self.buf) else {
            return;
        };
        let sent = self.exchange(link, msg.len, "jog: keep-alive", |text| {
            match text.map(|t| Reply::parse(t, msg.expect)) {
                Some(Ok(Reply::Fail(f))) => Some(f.code.code()),
                _ => None,
            }
        });
        let Ok(failed) = sent.await else {
            return;
        };
        if let Some(code) = failed {
            warn!("jog: keep-alive refused, code {}", code);
            if let Some(mo) = self.motion.take() {
                self.end(mo.source, Outcome::Error(ErrorSource::RobotFail, code));
                if let Some(j) = mo.jog {
                    self.send_jog_stop(link, j).await;
                }
            }
        }
    }

    /// The controller's text for robot error `code` (`GetErrorCodeStr`),
    /// into the error text registers; the gateway's table if the answer is
    /// not a text.
    async fn explain_error<S: Socket>(&mut self, link: &mut Link<S>, code: i32) {
        #[cfg(feature = "v6")]
        {
            let req = hans_codec::request::GetErrorCodeStr {
                code: ErrorCode::from(code),
            };
            let Some(msg) = crate::job::Wire::wire(&req, &mut self.buf) else {
                return;
            };
            let hub = self.hub;
            let asked = self.exchange(link, msg.len, "error text", |text| {
                match text.map(|t| Reply::parse(t, msg.expect)) {
                    Some(Ok(Reply::Ok(Response::GetErrorCodeStr(r)))) => {
                        let t = r.text.as_str().as_bytes();
                        hub.with(|m| m.error_text.set(code, TextSource::Controller, t));
                        true
                    }
                    _ => false,
                }
            });
            match asked.await {
                Ok(false) => {}
                // Explained, or the link was lost.
                Ok(true) | Err(Lost) => return,
            }
        }
        #[cfg(not(feature = "v6"))]
        let _ = link;
        self.explain_from_table(code);
    }
}
