//! The command engine: the only user of the robot link.
//!
//! * Jobs leave the FIFO queue one at a time; one request is in flight.
//! * A motion command is Done when the robot has finished it (chapter 6):
//!   `ReadRobotState` is polled every [`MOTION_POLL`] until moving ends
//!   (plus blending done / in position if configured), then the FSM must
//!   agree ([`fsm::motion_under_way`]) and `ReadActPos` refreshes the
//!   position registers, so that they are final at Done; Error when the
//!   robot refuses it or reports an error, emergency stop or safety guard.
//! * Urgent commands (stop, pause, continue, reset, disable: see
//!   [`job::is_urgent`]) go out before every ordinary command waiting.
//! * While a motion runs, other commands still go out in queue order, but a
//!   motion at the head of the queue waits for the running one to finish
//!   (the robot takes one motion at a time). A successful `GrpStop` (or the
//!   watchdog's stop or pause) ends the running motion's command and every
//!   motion still waiting in the queue in CommandAborted (MC_Stop).
//! * After the `OK` of a bring-up step (`ConnectToBox`, `Electrify`,
//!   `StartMaster`, `GrpEnable`) the job is parked until `ReadCurFSM` shows
//!   the step's state ([`fsm::StepWait`]), then goes on with its next
//!   message or is Done; meanwhile only urgent commands are sent.
//! * Between commands the engine polls the status (see [`crate::status`]).
//! * The PLC watchdog: while a motion runs, the heartbeat register must
//!   change at least every configured period, else the configured action
//!   is sent and reported.
//! * A reply timeout ends the command in Error and resets the link; when
//!   the link drops, every queued and running command ends in Error (link
//!   lost) and nothing is re-sent. Reconnects back off from
//!   [`MIN_BACKOFF`] to [`MAX_BACKOFF`].

pub mod commands;
pub mod fsm;
pub mod job;

use core::convert::Infallible;

use embassy_futures::select::{select3, Either3};
use embassy_time::{Duration, Instant, Timer};
use hans_codec::{
    request, response, Command, CommandId, FsmState, ParseError, Reply, ReplyExpect, Request,
    Response, RobotId,
};

pub use job::{ErrorSource, GatewayError, Outcome, Source};

use crate::config::{Config, LinkMode, WatchdogAction, WordOrder};
use crate::gateway::{millis, Ctx};
use crate::link::{IdleEvent, Link, LinkError, Target};
use crate::net::Socket;
use crate::registers as r;
use crate::status::{self, LinkState, PollStep};
use fsm::{StepWait, Verdict};
use job::{Gate, Job, Results};

/// Poll period of `ReadRobotState` while a motion runs.
pub const MOTION_POLL: Duration = Duration::from_millis(10);
/// First reconnect delay.
pub const MIN_BACKOFF: Duration = Duration::from_millis(200);
/// Longest reconnect delay.
pub const MAX_BACKOFF: Duration = Duration::from_secs(5);

/// A reply read without a type: any name, the values as sent.
const UNTYPED: ReplyExpect = ReplyExpect {
    command: None,
    count: None,
};

struct Active {
    source: Source,
    since: Instant,
    /// Start of the grace period: acceptance, or the last `GrpContinue`.
    grace_from: Instant,
    seen_moving: bool,
    /// The watchdog already acted on this motion.
    watchdog_fired: bool,
}

/// A command the gateway sends of its own accord, to the configured robot.
#[derive(Clone, Copy)]
enum Internal {
    /// `GrpStop` (the watchdog's stop).
    Stop,
    /// `GrpInterrupt` (the watchdog's pause).
    Pause,
    /// `GrpReset` (the automatic reset after a motion error).
    Reset,
}

/// What a polled reply gave the engine.
enum Polled {
    /// Nothing it needs (the registers may have been updated).
    Nothing,
    /// `ReadRobotState`.
    State(response::ReadRobotState),
    /// `ReadCurFSM`.
    Fsm(FsmState),
    /// The code of a reply to the gateway's own command (0 = OK).
    Code(i32),
}

/// A job between two messages, or after its last one, waiting for the
/// state its last bring-up step leads to.
struct Pending {
    job: Job,
    /// Byte offset in `job.text` of the next message to send.
    next: usize,
    wait: StepWait,
    deadline: Instant,
}

struct Engine<'c, 'a> {
    ctx: &'c Ctx<'a>,
    config: Config,
    config_gen: u32,
    target: Target,
    active: Option<Active>,
    pending: Option<Pending>,
    next_state_poll: Instant,
    backoff: Duration,
    retry_at: Instant,
    next_tick: Instant,
    round: Option<usize>,
    next_motion_poll: Instant,
    buf: [u8; 160],
}

fn target_of(c: &Config) -> Target {
    match c.link_mode {
        LinkMode::Listen => Target::Listen(c.listen_port),
        LinkMode::Connect if c.robot_ip.is_unspecified() => Target::None,
        LinkMode::Connect => Target::Connect(c.robot()),
    }
}

/// Runs the engine forever on a link over sockets `a` and `b` (built here,
/// in place: the link holds kilobytes of buffers).
pub(crate) async fn run<S: Socket>(ctx: &Ctx<'_>, a: S, b: S) -> Infallible {
    let mut link = Link::new(a, b);
    let (config, config_gen) = ctx.with(|s| (s.config, s.config_gen));
    let now = Instant::now();
    let mut e = Engine {
        ctx,
        config,
        config_gen,
        target: target_of(&config),
        active: None,
        pending: None,
        next_state_poll: now,
        backoff: MIN_BACKOFF,
        retry_at: now,
        next_tick: now,
        round: None,
        next_motion_poll: now,
        buf: [0; 160],
    };
    loop {
        e.step(&mut link).await;
    }
}

impl<'c, 'a> Engine<'c, 'a> {
    fn set_link_state(&self, st: LinkState) {
        self.ctx
            .with(|s| s.regs.set(r::STATUS_LINK_STATE, st as u16));
    }

    async fn step<S: Socket>(&mut self, link: &mut Link<S>) {
        self.follow_config(link).await;
        let now = Instant::now();
        if now >= self.next_tick {
            self.next_tick = now + millis(self.config.poll_ms);
            self.ctx.with(|s| {
                let hb = s.regs.get(r::STATUS_HEARTBEAT).wrapping_add(1);
                s.regs.set(r::STATUS_HEARTBEAT, hb);
            });
            if link.is_up()
                && self.round.is_none()
                && self.config.status_source == crate::config::StatusSource::Polling
            {
                self.round = Some(0);
            }
        }
        if !link.is_up() {
            self.bring_up(link).await;
            return;
        }
        if self.check_watchdog(link, now).await {
            return;
        }
        if let Some(job) = self.take_job() {
            self.run_job(link, job).await;
            return;
        }
        if self.active.is_some() && now >= self.next_motion_poll {
            self.poll_motion(link).await;
            return;
        }
        if self.pending.is_some() && now >= self.next_state_poll {
            self.poll_pending(link).await;
            return;
        }
        if let Some(i) = self.round {
            self.poll_status(link, i).await;
            return;
        }
        let mut due = self.next_tick;
        if self.active.is_some() {
            due = due.min(self.next_motion_poll);
        }
        if self.pending.is_some() {
            due = due.min(self.next_state_poll);
        }
        if let Some(w) = self.watchdog_due() {
            due = due.min(w);
        }
        let listen = match self.target {
            Target::Listen(p) => Some(p),
            _ => None,
        };
        match select3(link.idle(listen), self.ctx.wake.wait(), Timer::at(due)).await {
            Either3::First(IdleEvent::Lost(e)) => {
                warn!("robot link: {}", e.as_str());
                self.link_lost(link, GatewayError::LinkLost).await;
            }
            Either3::First(IdleEvent::Replaced) => {
                info!(
                    "robot link: the controller connected again; new connection replaces the old"
                );
                let peer = link.peer().map(|p| *p.ip());
                self.ctx.with(|s| {
                    // Maybe from another address: the DataSheet follows.
                    s.robot_peer = peer;
                    let n = s.regs.get(r::STATUS_LINK_CONNECTS).wrapping_add(1);
                    s.regs.set(r::STATUS_LINK_CONNECTS, n);
                });
            }
            _ => {}
        }
    }

    /// Picks up a changed configuration; a changed robot address drops the
    /// link.
    async fn follow_config<S: Socket>(&mut self, link: &mut Link<S>) {
        let (config, gen) = self.ctx.with(|s| (s.config, s.config_gen));
        if gen == self.config_gen {
            return;
        }
        self.config_gen = gen;
        self.config = config;
        let target = target_of(&config);
        if target != self.target {
            info!("robot link: target changed");
            if link.is_up() {
                self.link_lost(link, GatewayError::LinkLost).await;
            }
            link.close_all().await;
            self.target = target;
            self.backoff = MIN_BACKOFF;
            self.retry_at = Instant::now();
        }
    }

    async fn bring_up<S: Socket>(&mut self, link: &mut Link<S>) {
        self.ctx.with(|s| s.fail_queue(GatewayError::NotConnected));
        let now = Instant::now();
        match self.target {
            Target::None => {
                self.set_link_state(LinkState::Down);
                let _ = embassy_futures::select::select(
                    self.ctx.wake.wait(),
                    Timer::at(self.next_tick),
                )
                .await;
            }
            Target::Connect(addr) => {
                if now < self.retry_at {
                    self.set_link_state(LinkState::Down);
                    let due = self.retry_at.min(self.next_tick);
                    let _ =
                        embassy_futures::select::select(self.ctx.wake.wait(), Timer::at(due)).await;
                    return;
                }
                self.set_link_state(LinkState::Connecting);
                // Bounded by CONNECT_TIMEOUT; awaited whole so that slow
                // connects are not cut by the poll tick.
                match link.establish(Target::Connect(addr)).await {
                    Ok(()) => self.on_connected(link),
                    Err(e) => {
                        debug!("robot link: connect failed: {}", e.as_str());
                        self.backoff_after(GatewayError::ConnectFailed);
                    }
                }
            }
            Target::Listen(port) => {
                self.set_link_state(LinkState::Listening);
                match select3(
                    link.establish(Target::Listen(port)),
                    self.ctx.wake.wait(),
                    Timer::at(self.next_tick),
                )
                .await
                {
                    Either3::First(Ok(())) => self.on_connected(link),
                    Either3::First(Err(e)) => {
                        warn!("robot link: listen failed: {}", e.as_str());
                        self.backoff_after(GatewayError::ConnectFailed);
                        Timer::at(self.retry_at).await;
                    }
                    _ => {}
                }
            }
        }
    }

    fn backoff_after(&mut self, e: GatewayError) {
        self.retry_at = Instant::now() + self.backoff;
        self.backoff = (self.backoff * 2).min(MAX_BACKOFF);
        self.ctx.with(|s| {
            s.regs.set(r::STATUS_LINK_STATE, LinkState::Down as u16);
            s.regs.set(r::STATUS_LINK_LAST_ERROR, e.code() as u16);
        });
    }

    fn on_connected<S: Socket>(&mut self, link: &Link<S>) {
        self.backoff = MIN_BACKOFF;
        if let Some(p) = link.peer() {
            let [a, b, c, d] = p.ip().octets();
            info!("robot link: up, peer {}.{}.{}.{}:{}", a, b, c, d, p.port());
        } else {
            info!("robot link: up");
        }
        let peer = link.peer().map(|p| *p.ip());
        self.ctx.with(|s| {
            s.link_up = true;
            s.robot_peer = peer;
            s.regs
                .set(r::STATUS_LINK_STATE, LinkState::Connected as u16);
            let n = s.regs.get(r::STATUS_LINK_CONNECTS).wrapping_add(1);
            s.regs.set(r::STATUS_LINK_CONNECTS, n);
        });
        if self.config.status_source == crate::config::StatusSource::Polling {
            self.round = Some(0);
        }
    }

    /// The link is gone: every queued and running command ends in Error.
    async fn link_lost<S: Socket>(&mut self, link: &mut Link<S>, e: GatewayError) {
        let active = self.active.take();
        let pending = self.pending.take().map(|p| p.job.source);
        self.round = None;
        self.ctx.with(|s| {
            if let Some(a) = &active {
                s.finish(a.source, Outcome::gateway(GatewayError::LinkLost));
                s.regs.set(r::STATUS_ACTIVE_MOTION, 0);
            }
            if let Some(source) = pending {
                s.finish(source, Outcome::gateway(GatewayError::LinkLost));
            }
            s.fail_queue(GatewayError::LinkLost);
            s.link_up = false;
            // No controller is connected now (listen mode: the DataSheet
            // follows the next one, from wherever it connects).
            s.robot_peer = None;
            let order = s.config.word_order;
            status::invalidate(s.regs, order);
            s.status_time = None;
            s.regs.set_bits(r::STATUS_WATCHDOG, 1, false);
        });
        link.close().await;
        warn!("robot link: lost ({}), reconnecting", e.as_str());
        self.backoff_after(e);
    }

    /// Takes the next job that may go now.
    fn take_job(&mut self) -> Option<Job> {
        let gate = if self.pending.is_some() {
            Gate::UrgentOnly
        } else if self.active.is_some() {
            Gate::MotionRunning
        } else {
            Gate::Open
        };
        self.ctx.with(|s| {
            let job = s.queue.take(gate)?;
            job.source.set_dequeued(s.regs);
            s.update_queue_reg();
            Some(job)
        })
    }

    fn deadline(&self) -> Instant {
        Instant::now() + millis(self.config.reply_timeout_ms)
    }

    /// Sends a job's messages in turn and ends it (or starts its motion).
    async fn run_job<S: Socket>(&mut self, link: &mut Link<S>, job: Job) {
        self.run_job_from(link, job, 0).await;
    }

    /// Sends a job's messages from byte offset `from` in turn and ends it
    /// (or starts its motion). After a bring-up step's `OK` the job is
    /// parked until the FSM shows the step's state ([`Self::poll_pending`]).
    async fn run_job_from<S: Socket>(&mut self, link: &mut Link<S>, job: Job, from: usize) {
        let mut last = None;
        let mut next = from;
        let mut park = None;
        for msg in job.text.get(from..).unwrap_or("").split_inclusive(';') {
            next += msg.len();
            info!(
                "{} #{}: send {}",
                job.source.name(),
                job.source.index(),
                msg
            );
            let req = Request::parse(msg).ok();
            let expect = req.as_ref().map(|q| q.expect()).unwrap_or(UNTYPED);
            last = req.as_ref().and_then(|q| q.command());
            let req_name = req.as_ref().map(|q| q.name()).unwrap_or("");
            let deadline = self.deadline();
            let outcome = match link.transact(msg.as_bytes(), deadline).await {
                Err(LinkError::Timeout) => {
                    self.end(job.source, Outcome::gateway(GatewayError::ReplyTimeout));
                    self.link_lost(link, GatewayError::ReplyTimeout).await;
                    return;
                }
                Err(LinkError::Lost(_)) => {
                    self.end(job.source, Outcome::gateway(GatewayError::LinkLost));
                    self.link_lost(link, GatewayError::LinkLost).await;
                    return;
                }
                Err(LinkError::BadFrame(_)) => Some(Outcome::gateway(GatewayError::BadReply)),
                Ok(text) => {
                    let order = self.config.word_order;
                    let parsed = match Reply::parse(text, expect) {
                        // An OK the codec cannot type (extra values, as
                        // newer firmware may send): the robot accepted the
                        // command. Success where the gateway does not use
                        // the values; typed checks stay where it does. The
                        // name is the request's: any error but NameMismatch
                        // comes after the codec matched it (aliases too).
                        Err(e)
                            if job.results == Results::None
                                && !matches!(e, ParseError::NameMismatch { .. }) =>
                        {
                            match Reply::parse(text, UNTYPED) {
                                Ok(Reply::Ok(Response::Unknown(raw))) => {
                                    warn!(
                                        "{} #{}: reply values not as documented, accepted: {}",
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
                    self.ctx.with(|s| {
                        if job.source == Source::Raw {
                            let b = text.as_bytes();
                            s.regs.set_text(r::RAW_REPLY, r::RAW_REPLY_REGS, b);
                            s.regs.set(r::RAW_REPLY_LEN, b.len() as u16);
                            let cut = b.len() > 2 * r::RAW_REPLY_REGS as usize;
                            s.regs.set(r::RAW_REPLY_TRUNCATED, u16::from(cut));
                        }
                        match &parsed {
                            Ok(Reply::Ok(Response::Unknown(raw)))
                                if !same_command(raw.name(), req_name) =>
                            {
                                Some(Outcome::gateway(GatewayError::ReplyMismatch))
                            }
                            Ok(Reply::Ok(resp)) => {
                                status::apply_response(resp, s.regs, order);
                                if let (
                                    Results::ActPos,
                                    Response::ReadActPos(p),
                                    Source::Channel(i),
                                ) = (job.results, resp, job.source)
                                {
                                    let b = r::channel_base(usize::from(i)) + r::CH_RESULTS;
                                    let all =
                                        p.joints.iter().chain(&p.pose).chain(&p.tcp).chain(&p.ucs);
                                    for (k, v) in all.enumerate() {
                                        s.regs.set_f32(b + 2 * k as u16, v.to_f32(), order);
                                    }
                                }
                                if let Some(Request::SetOverride(o)) = &req {
                                    s.regs.set_f32(r::STATUS_OVERRIDE, o.ratio.to_f32(), order);
                                }
                                None
                            }
                            Ok(Reply::Fail(f)) => {
                                Some(Outcome::Error(ErrorSource::RobotFail, f.code.code()))
                            }
                            Ok(Reply::ErrorCmd(_)) => {
                                Some(Outcome::gateway(GatewayError::BadReply))
                            }
                            Err(ParseError::NameMismatch { .. }) => {
                                Some(Outcome::gateway(GatewayError::ReplyMismatch))
                            }
                            Err(_) => Some(Outcome::gateway(GatewayError::BadReply)),
                        }
                    })
                }
            };
            if let Some(outcome) = outcome {
                self.end(job.source, outcome);
                if outcome == Outcome::gateway(GatewayError::ReplyMismatch) {
                    // Replies no longer match requests: start afresh.
                    self.link_lost(link, GatewayError::ReplyMismatch).await;
                }
                return;
            }
            if let Some(wait) = last.and_then(StepWait::after) {
                park = Some(wait);
                break;
            }
        }
        let now = Instant::now();
        if let Some(wait) = park {
            debug!(
                "{} #{}: waiting for {}",
                job.source.name(),
                job.source.index(),
                wait.as_str()
            );
            self.pending = Some(Pending {
                job,
                next,
                wait,
                deadline: now + fsm::STATE_TIMEOUT,
            });
            self.next_state_poll = now + fsm::STATE_POLL;
            return;
        }
        if job.motion {
            self.ctx.with(|s| {
                job.source.set_active(s.regs, true);
                s.regs.set(r::STATUS_ACTIVE_MOTION, job.source.code());
            });
            self.active = Some(Active {
                source: job.source,
                since: now,
                grace_from: now,
                seen_moving: false,
                watchdog_fired: false,
            });
            self.next_motion_poll = now + MOTION_POLL;
            return;
        }
        if last == Some(CommandId::GrpContinue) {
            // The motion starts again: its moving flag lags as at the
            // start, so the grace period starts again too.
            if let Some(a) = self.active.as_mut() {
                a.grace_from = now;
                a.seen_moving = false;
            }
        }
        if last == Some(CommandId::GrpStop) {
            // MC_Stop: the running motion and every motion still waiting
            // end in CommandAborted; waiting non-motion commands go on.
            if let Some(a) = self.active.take() {
                self.end_motion(a.source, Outcome::Aborted);
            }
            self.ctx.with(|s| s.abort_queued_motions());
        }
        self.end(job.source, Outcome::Done);
    }

    fn end(&self, source: Source, outcome: Outcome) {
        self.ctx.with(|s| s.finish(source, outcome));
    }

    fn end_motion(&self, source: Source, outcome: Outcome) {
        self.ctx.with(|s| {
            s.finish(source, outcome);
            s.regs.set(r::STATUS_ACTIVE_MOTION, 0);
            s.regs.set_bits(r::STATUS_WATCHDOG, 1, false);
        });
    }

    /// Sends the request in `self.buf[..len]` and hands its reply to `f`.
    /// `Err(())` when the link was lost (already handled), `Ok(None)` when
    /// the reply could not be read. One instance for every caller (`f` is
    /// a trait object): this runs on small boards.
    async fn poll<S: Socket>(
        &mut self,
        link: &mut Link<S>,
        len: usize,
        expect: ReplyExpect,
        what: &str,
        f: &mut dyn FnMut(&Reply<'_>, &mut crate::gateway::Shared<'_>, WordOrder) -> Polled,
    ) -> Result<Option<Polled>, ()> {
        let deadline = self.deadline();
        let order = self.config.word_order;
        let ctx = self.ctx;
        let msg = self.buf.get(..len).unwrap_or(&[]);
        let err = match link.transact(msg, deadline).await {
            Err(LinkError::Timeout) => GatewayError::ReplyTimeout,
            Err(LinkError::Lost(_)) => GatewayError::LinkLost,
            Err(LinkError::BadFrame(_)) => return Ok(None),
            Ok(text) => {
                return match Reply::parse(text, expect) {
                    Ok(reply) => Ok(Some(ctx.with(|s| f(&reply, s, order)))),
                    Err(_) => {
                        debug!("{}: unreadable reply", what);
                        Ok(None)
                    }
                }
            }
        };
        warn!("{}: {}", what, err.as_str());
        self.link_lost(link, err).await;
        Err(())
    }

    /// Sends the request of `step` and copies its reply into the registers
    /// ([`PollStep::apply`]). As [`Self::poll`]; the reply comes back as
    /// [`Polled::State`] or [`Polled::Fsm`] where the engine needs it.
    /// `Ok(None)` also if the request could not be written (it fits
    /// `buf`, so that does not happen).
    async fn poll_step<S: Socket>(
        &mut self,
        link: &mut Link<S>,
        step: PollStep,
        what: &str,
    ) -> Result<Option<Polled>, ()> {
        let Some((len, expect)) = step.request(self.config.robot_id, &mut self.buf) else {
            return Ok(None);
        };
        self.poll(link, len, expect, what, &mut |reply, s, order| {
            step.apply(reply, s.regs, order);
            match reply {
                Reply::Ok(Response::ReadRobotState(rs)) => Polled::State(rs.clone()),
                Reply::Ok(Response::ReadCurFSM(f)) => Polled::Fsm(f.state),
                _ => Polled::Nothing,
            }
        })
        .await
    }

    /// One request of the status round.
    async fn poll_status<S: Socket>(&mut self, link: &mut Link<S>, i: usize) {
        let Some(step) = PollStep::ROUND.get(i).copied() else {
            self.round = None;
            return;
        };
        if self.poll_step(link, step, "status").await.is_err() {
            return;
        }
        if i + 1 >= PollStep::ROUND.len() {
            self.round = None;
            self.ctx.with(|s| s.status_time = Some(Instant::now()));
        } else {
            self.round = Some(i + 1);
        }
    }

    /// `ReadRobotState` while a motion runs: decides Done or Error.
    async fn poll_motion<S: Socket>(&mut self, link: &mut Link<S>) {
        self.next_motion_poll = Instant::now() + MOTION_POLL;
        let state = self.poll_step(link, PollStep::RobotState, "motion").await;
        let Ok(Some(Polled::State(rs))) = state else {
            return;
        };
        let Some(a) = self.active.as_mut() else {
            return;
        };
        let now = Instant::now();
        let outcome = if rs.error != 0 {
            Some(match rs.error_code {
                0 => Outcome::gateway(GatewayError::RobotErrorNoCode),
                c => Outcome::Error(ErrorSource::RobotMotion, c),
            })
        } else if rs.emergency_stop != 0 {
            Some(Outcome::gateway(GatewayError::EmergencyStop))
        } else if rs.safety_guard != 0 {
            Some(Outcome::gateway(GatewayError::SafetyGuard))
        } else if rs.moving != 0 {
            a.seen_moving = true;
            None
        } else if rs.paused != 0 {
            None
        } else if a.seen_moving
            || now.saturating_duration_since(a.grace_from) >= millis(self.config.start_grace_ms)
        {
            let blend_ok = !self.config.wait_blending_done || rs.blending_done != 0;
            let pos_ok = !self.config.wait_in_position || rs.in_position != 0;
            (blend_ok && pos_ok).then_some(Outcome::Done)
        } else {
            None
        };
        let Some(outcome) = outcome else {
            return;
        };
        if outcome == Outcome::Done {
            match self.confirm_done(link).await {
                Ok(true) => {}
                Ok(false) | Err(()) => return,
            }
        }
        let Some(a) = self.active.take() else {
            return;
        };
        self.end_motion(a.source, outcome);
        if matches!(outcome, Outcome::Error(..)) && self.config.auto_reset {
            info!("auto-reset: GrpReset after the motion error");
            self.send_internal(link, Internal::Reset).await;
        }
    }

    /// The flags say the motion has ended. Done only if the FSM agrees (it
    /// changes at once, the moving flag ~50 ms late, e.g. after
    /// `GrpContinue`), and once the position registers show where the
    /// robot stopped (`ReadActPos`), so that Done means they are final.
    /// `Ok(false)`: not yet (polled again), also when an urgent command
    /// waits (it goes first); `Err(())`: the link was lost.
    async fn confirm_done<S: Socket>(&mut self, link: &mut Link<S>) -> Result<bool, ()> {
        if self.ctx.with(|s| s.queue.has_urgent()) {
            return Ok(false);
        }
        if let Some(state) = self.read_fsm(link).await? {
            if fsm::motion_under_way(state) {
                if let Some(a) = self.active.as_mut() {
                    a.seen_moving = true;
                }
                return Ok(false);
            }
        }
        if self.ctx.with(|s| s.queue.has_urgent()) {
            return Ok(false);
        }
        // A refused or unreadable reply leaves the registers as they are;
        // the motion is Done all the same (the robot said so twice).
        self.poll_step(link, PollStep::ActPos, "position").await?;
        Ok(true)
    }

    /// `ReadCurFSM` for a job parked after a bring-up step: goes on with
    /// the job once the step's state is reached, ends it in Error at a
    /// fault state or after [`fsm::STATE_TIMEOUT`].
    async fn poll_pending<S: Socket>(&mut self, link: &mut Link<S>) {
        self.next_state_poll = Instant::now() + fsm::STATE_POLL;
        let Ok(state) = self.read_fsm(link).await else {
            return;
        };
        let Some(p) = self.pending.as_ref() else {
            return;
        };
        let verdict = state.map_or(Verdict::Wait, |s| p.wait.verdict(s));
        let verdict = match verdict {
            Verdict::Wait if Instant::now() >= p.deadline => {
                Verdict::Failed(GatewayError::StateNotReached)
            }
            v => v,
        };
        match verdict {
            Verdict::Wait => {}
            Verdict::Reached => {
                // FSM_STATE shows the new state; make ROBOT_FLAGS agree
                // before the job goes on (or is Done).
                if self
                    .poll_step(link, PollStep::RobotState, "state")
                    .await
                    .is_err()
                {
                    return;
                }
                if let Some(p) = self.pending.take() {
                    self.run_job_from(link, p.job, p.next).await;
                }
            }
            Verdict::Failed(e) => {
                if let Some(p) = self.pending.take() {
                    warn!(
                        "{} #{}: {} not reached",
                        p.job.source.name(),
                        p.job.source.index(),
                        p.wait.as_str()
                    );
                    self.end(p.job.source, Outcome::gateway(e));
                }
            }
        }
    }

    /// `ReadCurFSM` (also copied into `FSM_STATE`); `Ok(None)` when the
    /// robot refused it or the reply could not be read.
    async fn read_fsm<S: Socket>(&mut self, link: &mut Link<S>) -> Result<Option<FsmState>, ()> {
        let r = self.poll_step(link, PollStep::Fsm, "fsm").await?;
        Ok(match r {
            Some(Polled::Fsm(state)) => Some(state),
            _ => None,
        })
    }

    /// Sends a command of the gateway's own (watchdog action, auto reset)
    /// to the configured robot and reads its reply as that command's.
    async fn send_internal<S: Socket>(&mut self, link: &mut Link<S>, cmd: Internal) {
        /// Each command's own encoder, which the typed channels link anyway
        /// (`Request::encode` would add every command's writer: ~4 KiB).
        fn enc<'c, C: Command<'c>>(
            c: C,
            buf: &mut [u8],
        ) -> (&'static str, Option<(usize, ReplyExpect)>) {
            (C::ID.name(), c.encode(buf).ok().map(|n| (n, c.expect())))
        }
        let rbt_id = RobotId(i32::from(self.config.robot_id));
        let buf = &mut self.buf;
        let (name, encoded) = match cmd {
            Internal::Stop => enc(request::GrpStop { rbt_id }, buf),
            Internal::Pause => enc(request::GrpInterrupt { rbt_id }, buf),
            Internal::Reset => enc(request::GrpReset { rbt_id }, buf),
        };
        let Some((len, expect)) = encoded else {
            return;
        };
        let r = self
            .poll(link, len, expect, name, &mut |reply, _, _| {
                Polled::Code(match reply {
                    Reply::Ok(_) => 0,
                    Reply::Fail(f) => f.code.code(),
                    Reply::ErrorCmd(_) => GatewayError::BadReply.code(),
                })
            })
            .await;
        match r {
            Ok(Some(Polled::Code(0))) => info!("{}: sent, ok", name),
            Ok(Some(Polled::Code(code))) => warn!("{}: refused, code {}", name, code),
            Ok(_) => warn!("{}: unreadable reply", name),
            Err(()) => {}
        }
    }

    /// Checks the PLC heartbeat while a motion runs. `true` if it acted.
    async fn check_watchdog<S: Socket>(&mut self, link: &mut Link<S>, now: Instant) -> bool {
        let Some(a) = &self.active else {
            return false;
        };
        if self.config.watchdog_ms == 0 || a.watchdog_fired {
            return false;
        }
        let period = millis(self.config.watchdog_ms);
        let since = a.since;
        let source = a.source;
        let expired = self.ctx.with(|s| {
            s.regs.set_bits(r::STATUS_WATCHDOG, 1, true);
            let last = s.last_beat.max(since);
            now.saturating_duration_since(last) > period
        });
        if !expired {
            return false;
        }
        let action = self.config.watchdog_action;
        warn!(
            "watchdog: PLC heartbeat unchanged for {} ms during a motion",
            self.config.watchdog_ms
        );
        self.ctx.with(|s| {
            s.regs.set_bits(r::STATUS_WATCHDOG, 2, true);
            let n = s.regs.get(r::STATUS_WATCHDOG_TRIPS).wrapping_add(1);
            s.regs.set(r::STATUS_WATCHDOG_TRIPS, n);
        });
        match action {
            WatchdogAction::ReportOnly => {
                if let Some(a) = self.active.as_mut() {
                    a.watchdog_fired = true;
                }
                return false;
            }
            WatchdogAction::Stop => {
                self.active = None;
                self.end_motion(source, Outcome::gateway(GatewayError::Watchdog));
                // As a Stop: the motions waiting behind it are not sent.
                self.ctx.with(|s| s.abort_queued_motions());
                self.send_internal(link, Internal::Stop).await;
            }
            WatchdogAction::Pause => {
                self.active = None;
                self.end_motion(source, Outcome::gateway(GatewayError::Watchdog));
                // The robot holds the motion: nothing may start behind it.
                self.ctx.with(|s| s.abort_queued_motions());
                self.send_internal(link, Internal::Pause).await;
            }
        }
        true
    }

    /// The next instant the watchdog could expire.
    fn watchdog_due(&self) -> Option<Instant> {
        let a = self.active.as_ref()?;
        if self.config.watchdog_ms == 0 || a.watchdog_fired {
            return None;
        }
        let last = self.ctx.with(|s| s.last_beat).max(a.since);
        Some(last + millis(self.config.watchdog_ms) + Duration::from_millis(1))
    }
}

/// `true` if reply name `a` answers request name `b`: the same name, or
/// two names (aliases) of one known command.
fn same_command(a: &str, b: &str) -> bool {
    a == b || CommandId::from_name(a).is_some_and(|id| CommandId::from_name(b) == Some(id))
}
