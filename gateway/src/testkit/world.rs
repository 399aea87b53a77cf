//! The world: a gateway, a robot controller and PLCs on a simulated network
//! in virtual time, run by a deterministic executor.
//!
//! The gateway is the real one ([`Gateway::run`], the future a board runs):
//! its engine, Modbus sessions, DataSheet reader and storage task run on
//! [`SimNet`] and [`VirtualClock`]. The executor polls that one future
//! whenever it was woken; when nothing is left to do now, time jumps to the
//! next timer of the gateway or the robot. Nothing sleeps, and the same
//! inputs give the same run.

use core::cell::{Cell, RefCell};
use core::convert::Infallible;
use core::future::Future;
use core::net::{Ipv4Addr, SocketAddrV4};
use core::pin::Pin;
use core::task::{Context, Poll, Waker};
use std::boxed::Box;
use std::rc::Rc;
use std::string::String;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::task::Wake;
use std::vec::Vec;

use embassy_time::{Duration, Instant};

use super::broker::{BrokerMode, SimBroker, BROKER};
use super::clock::VirtualClock;
use super::net::SimNet;
use super::plc::{pdu, Answer, Plc};
use super::robot::SimRobot;
use crate::config::{Config, LinkMode};
use crate::gateway::{Gateway, Options};
use crate::state::Model;
use crate::storage::{AuditStore, ConfigStore, Image, Medium, StorageError, IMAGE_LEN};

/// The gateway's address.
pub const GATEWAY_IP: Ipv4Addr = Ipv4Addr::new(10, 0, 0, 1);
/// The robot controller's address.
pub const ROBOT_IP: Ipv4Addr = Ipv4Addr::new(10, 0, 0, 2);
/// The robot's command port.
pub const ROBOT_PORT: u16 = 10003;
/// The gateway's Modbus port.
pub const MODBUS_PORT: u16 = 502;

/// Storage in memory that outlives a gateway (a restart keeps it), and can
/// be made to fail.
#[derive(Default)]
pub struct MemStorage {
    /// The stored image.
    pub data: Rc<RefCell<Vec<u8>>>,
    /// Saves fail while set.
    pub fail: Rc<Cell<bool>>,
    /// The audit records kept, oldest first (no limit).
    pub audit: Rc<RefCell<Vec<Vec<u8>>>>,
    /// A board's flash with the firmware slots (feature `update`): the
    /// gateway installs uploads into it, and [`World::restart`] runs the
    /// bootloader's step on it first. `None`: no slots (as Linux).
    #[cfg(feature = "update")]
    pub flash: Option<super::flash::SimFlash>,
    /// The application's view of the slots (RAM: a restart makes it anew).
    #[cfg(feature = "update")]
    slots: Option<
        crate::update::BootSlots<super::flash::Part, super::flash::Part, super::flash::Part>,
    >,
    copy: Vec<u8>,
}

impl Clone for MemStorage {
    /// Another view of the same media (what a restarted gateway gets).
    fn clone(&self) -> Self {
        MemStorage {
            data: self.data.clone(),
            fail: self.fail.clone(),
            audit: self.audit.clone(),
            #[cfg(feature = "update")]
            flash: self.flash.clone(),
            #[cfg(feature = "update")]
            slots: None,
            copy: Vec::new(),
        }
    }
}

impl ConfigStore for MemStorage {
    fn medium(&self) -> Medium {
        Medium::Flash
    }

    async fn load(&mut self) -> Result<&[u8], StorageError> {
        self.copy = self.data.borrow().clone();
        Ok(&self.copy)
    }

    async fn save(&mut self, image: &dyn Image) -> Result<(), StorageError> {
        if self.fail.get() {
            return Err(StorageError::Io);
        }
        let mut buf = std::vec![0u8; IMAGE_LEN];
        let n = image.write(&mut buf)?;
        buf.truncate(n);
        *self.data.borrow_mut() = buf;
        Ok(())
    }
}

impl AuditStore for MemStorage {
    async fn read(&mut self, each: &mut dyn FnMut(&[u8])) -> Result<(), StorageError> {
        for r in self.audit.borrow().iter() {
            each(r);
        }
        Ok(())
    }

    async fn append(&mut self, record: &[u8]) -> Result<(), StorageError> {
        if self.fail.get() {
            return Err(StorageError::Io);
        }
        self.audit.borrow_mut().push(record.to_vec());
        Ok(())
    }

    fn persistent(&self) -> bool {
        true
    }
}

#[cfg(feature = "update")]
impl MemStorage {
    /// The slots over the simulated flash, `Unsupported` without one.
    fn slots(
        &mut self,
    ) -> Result<
        &mut crate::update::BootSlots<super::flash::Part, super::flash::Part, super::flash::Part>,
        crate::update::SlotError,
    > {
        let flash = self
            .flash
            .as_ref()
            .ok_or(crate::update::SlotError::Unsupported)?;
        Ok(self.slots.get_or_insert_with(|| flash.slots()))
    }
}

#[cfg(feature = "update")]
impl crate::update::SlotStore for MemStorage {
    async fn state(&mut self) -> Result<crate::update::BootState, crate::update::SlotError> {
        self.slots()?.state().await
    }
    async fn read(
        &mut self,
        slot: crate::update::Slot,
        offset: u32,
        buf: &mut [u8],
    ) -> Result<(), crate::update::SlotError> {
        self.slots()?.read(slot, offset, buf).await
    }
    async fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), crate::update::SlotError> {
        self.slots()?.write(offset, data).await
    }
    async fn mark_updated(&mut self) -> Result<(), crate::update::SlotError> {
        self.slots()?.mark_updated().await
    }
    async fn confirm(&mut self) -> Result<(), crate::update::SlotError> {
        self.slots()?.confirm().await
    }
}

std::thread_local! {
    /// Set when the gateway asked the platform to restart (its
    /// `Options::restart`), read by [`World::restart_asked`].
    static RESTART_ASKED: Cell<bool> = const { Cell::new(false) };
    /// A stop asked by [`World::stop`], not yet seen by the gateway.
    static STOP_ASKED: Cell<Option<&'static str>> = const { Cell::new(None) };
    /// How the gateway's run ended after [`World::stop`].
    static STOPPED: Cell<Option<crate::gateway::Stopped>> = const { Cell::new(None) };
}

fn ask_restart() {
    RESTART_ASKED.with(|r| r.set(true));
}

/// How to build a world.
#[derive(Clone)]
pub struct WorldConfig {
    /// Seed of the robot's random faults.
    pub seed: u64,
    /// The robot connects to the gateway (listen mode) instead.
    pub listen_mode: bool,
    /// The gateway's start configuration (the robot address is set here).
    pub config: Config,
    /// Number of PLC connections.
    pub plcs: usize,
    /// The storage (it survives [`World::restart`]).
    pub storage: MemStorage,
    /// Serve the web page on [`WEB_PORT`] (feature `web`).
    pub web: bool,
    /// Start (and restart) as a board held in recovery (its button held at
    /// power-up: factory network and access settings).
    pub recovery: bool,
    /// The setup code the platform hands in (default [`SETUP_CODE`]).
    pub setup_code: Option<crate::SetupCode>,
    /// An MQTT broker at [`BROKER`] doing this, and the gateway's
    /// telemetry on to it (needs the feature `mqtt`); `None`: telemetry
    /// off (the factory state).
    pub broker: Option<BrokerMode>,
    /// The firmware's self-check fails (an image that never confirms
    /// itself; with slots in the storage).
    pub self_check_fails: bool,
}

/// The world's setup code (as the platform would print it).
pub const SETUP_CODE: &str = "ABCD-EFGH-JKMN";

/// The gateway's web port in the world (when [`WorldConfig::web`]).
pub const WEB_PORT: u16 = 80;

impl Default for WorldConfig {
    fn default() -> Self {
        WorldConfig {
            seed: 1,
            listen_mode: false,
            config: Config::default(),
            plcs: 1,
            storage: MemStorage::default(),
            web: false,
            recovery: false,
            setup_code: crate::SetupCode::parse(SETUP_CODE.as_bytes()),
            broker: None,
            self_check_fails: false,
        }
    }
}

/// Polls `fut` while the flag of its waker is up (it was woken), until it
/// waits; returns the polls made. Panics (a test harness) after `limit`
/// polls in a row: the future never waits, at `at`.
pub(crate) fn poll_until_waiting(
    flag: &Flag,
    waker: &Waker,
    fut: &mut Pin<Box<dyn Future<Output = Infallible>>>,
    limit: u64,
    at: Instant,
) -> u64 {
    let mut n = 0u64;
    while flag.0.swap(false, Ordering::Relaxed) {
        let mut cx = Context::from_waker(waker);
        if let Poll::Ready(never) = fut.as_mut().poll(&mut cx) {
            match never {}
        }
        n += 1;
        assert!(n < limit, "the future never waits at {at:?}");
    }
    n
}

/// A waker that raises a flag: a deterministic executor polls its future
/// again only when it is up (also the engine's wake-count tests').
pub(crate) struct Flag(pub(crate) AtomicBool);

impl Wake for Flag {
    fn wake(self: Arc<Self>) {
        self.0.store(true, Ordering::Relaxed);
    }
    fn wake_by_ref(self: &Arc<Self>) {
        self.0.store(true, Ordering::Relaxed);
    }
}

/// A gateway, a robot and PLCs in virtual time.
pub struct World {
    /// Virtual time.
    pub clock: Rc<VirtualClock>,
    /// The network.
    pub net: SimNet,
    /// The gateway (its state: `gateway.hub()`).
    pub gateway: Rc<Gateway>,
    fut: Pin<Box<dyn Future<Output = Infallible>>>,
    flag: Arc<Flag>,
    waker: Waker,
    /// The robot controller.
    pub robot: SimRobot,
    /// The PLCs (`plcs[i]` connected from 10.0.0.(10 + i)).
    pub plcs: Vec<Plc>,
    /// How it was built.
    pub config: WorldConfig,
    /// Gateway polls so far (a measure of work).
    pub polls: u64,
    /// The MQTT broker ([`WorldConfig::broker`]).
    pub broker: Option<SimBroker>,
    /// A fingerprint of everything the PLCs were answered, and when
    /// ([`World::request`]): two runs that gave the PLCs the same answers
    /// at the same instants have the same one.
    pub plc_trace: u64,
}

/// The longest a PLC waits for an answer before the test fails.
pub const ANSWER_LIMIT: Duration = Duration::from_secs(30);

impl World {
    /// A world: the gateway started, the robot listening (or connecting),
    /// the PLCs connected. Nothing has run yet.
    pub fn new(config: WorldConfig) -> Self {
        let clock = Rc::new(VirtualClock::new());
        let net = SimNet::new(GATEWAY_IP);
        let robot_addr = SocketAddrV4::new(ROBOT_IP, ROBOT_PORT);
        let mut robot = SimRobot::new(&net, robot_addr, config.seed);
        let mut defaults = config.config;
        if config.listen_mode {
            defaults.link_mode = LinkMode::Listen;
            robot.connect_to_gateway(defaults.listen_port);
        } else if defaults.robot_ip.is_unspecified() {
            defaults.robot_ip = ROBOT_IP;
            defaults.robot_port = ROBOT_PORT;
        }
        let broker = config.broker.map(|mode| {
            if !cfg!(feature = "mqtt") {
                panic!("a broker needs the feature `mqtt`");
            }
            defaults.mqtt.enabled = true;
            defaults.mqtt.broker = crate::config::HostName::new("10.0.0.50").unwrap();
            assert_eq!(BROKER.ip().octets(), [10, 0, 0, 50]);
            defaults.mqtt.port = BROKER.port();
            SimBroker::new(&net, mode)
        });
        let opts = Options {
            modbus_port: MODBUS_PORT,
            defaults,
            robot_override: None,
            web_port: if config.web { WEB_PORT } else { 0 },
            seed: [config.seed as u8; 32],
            recovery: config.recovery,
            setup_code: config.setup_code,
            ..Default::default()
        };
        let opts = Self::with_updates(opts, &config);
        let flag = Arc::new(Flag(AtomicBool::new(true)));
        let waker = Waker::from(flag.clone());
        let gateway = Rc::new(Gateway::new(opts));
        let fut = Self::spawn(&clock, &net, &gateway, config.storage.clone());
        let mut w = World {
            clock,
            net,
            gateway,
            fut,
            flag,
            waker,
            robot,
            plcs: Vec::new(),
            config,
            polls: 0,
            broker,
            plc_trace: 0xcbf2_9ce4_8422_2325,
        };
        w.settle();
        for i in 0..w.config.plcs {
            let from = SocketAddrV4::new(Ipv4Addr::new(10, 0, 0, 10 + i as u8), 50000 + i as u16);
            if let Some(s) = w.net.connect(from, MODBUS_PORT) {
                w.plcs.push(Plc::new(s));
            }
        }
        w.settle();
        w
    }

    /// `opts` of a board with firmware slots, if the storage has them:
    /// the test key trusted, the QEMU board's id, a restart the world
    /// notes ([`Self::restart_asked`]).
    fn with_updates(opts: Options, config: &WorldConfig) -> Options {
        #[cfg(feature = "update")]
        if config.storage.flash.is_some() {
            return Options {
                update_key: Some(super::flash::test_key()),
                board: hans_fw_image::layout::MPS2_AN386.board,
                self_check_fails: config.self_check_fails,
                restart: Some(ask_restart),
                ..opts
            };
        }
        let _ = config;
        opts
    }

    /// The gateway asked the platform to restart (the web page's restart,
    /// a trial image's failed self-check) since the last [`Self::restart`].
    pub fn restart_asked(&self) -> bool {
        RESTART_ASKED.with(|r| r.get())
    }

    fn spawn(
        clock: &Rc<VirtualClock>,
        net: &SimNet,
        gateway: &Rc<Gateway>,
        storage: MemStorage,
    ) -> Pin<Box<dyn Future<Output = Infallible>>> {
        let (c, n, g) = (clock.clone(), net.clone(), gateway.clone());
        STOP_ASKED.with(|s| s.set(None));
        STOPPED.with(|s| s.set(None));
        // Until a stop is asked (World::stop raises the waker's flag).
        let stop = core::future::poll_fn(|_| match STOP_ASKED.with(|s| s.take()) {
            Some(why) => Poll::Ready(why),
            None => Poll::Pending,
        });
        Box::pin(async move {
            let stopped = g.run_until(&n, &*c, storage, stop).await;
            STOPPED.with(|s| s.set(Some(stopped)));
            core::future::pending().await
        })
    }

    /// The platform stops the gateway in order for `why` (a Linux host's
    /// SIGTERM): [`Gateway::run_until`]'s stop. Runs until the gateway's
    /// run has ended (at most 10 s of virtual time); how it ended, `None`
    /// if it did not. [`Self::restart`] starts it again on the same
    /// storage.
    pub fn stop(&mut self, why: &'static str) -> Option<crate::gateway::Stopped> {
        STOP_ASKED.with(|s| s.set(Some(why)));
        self.flag.0.store(true, Ordering::Relaxed);
        self.run_until_cond(Duration::from_secs(10), |_| {
            STOPPED.with(|s| s.get()).is_some()
        });
        STOPPED.with(|s| s.get())
    }

    /// Gives the gateway an administrator account (`admin`), as a
    /// commissioned device has (configuration over Modbus stays off: see
    /// [`Self::allow_modbus_config`]). In memory only (not saved).
    pub fn add_admin(&mut self) {
        let hash = crate::PasswordHash {
            iterations: 1,
            salt: [0; 16],
            hash: [0; 32],
        };
        let added = self.gateway.hub().with(|m| {
            m.access
                .accounts
                .add(crate::Account {
                    name: crate::UserName::new(b"admin")?,
                    role: crate::Role::Admin,
                    hash,
                })
                .ok()
        });
        assert!(added.is_some(), "an administrator added");
    }

    /// Configuration over Modbus allowed (`access.modbus_config`, as an
    /// administrator allows it on the page): the protected settings (the
    /// robot endpoint, the link mode, the network and access settings) may
    /// then change over Modbus. In memory only (not saved).
    pub fn allow_modbus_config(&mut self) {
        self.gateway
            .hub()
            .with(|m| m.config.active.modbus_config = true);
    }

    /// The gateway powered off and on again: a new gateway on the same
    /// storage (a power cut). PLCs connect again.
    pub fn restart(&mut self) {
        let opts = Options {
            modbus_port: MODBUS_PORT,
            defaults: self.gateway.hub().with(|m| m.config.factory),
            robot_override: None,
            web_port: if self.config.web { WEB_PORT } else { 0 },
            seed: [self.config.seed as u8 ^ 0x5a; 32],
            recovery: self.config.recovery,
            setup_code: self.config.setup_code,
            ..Default::default()
        };
        let opts = Self::with_updates(opts, &self.config);
        // The bootloader's step at power-up (a board with slots); the
        // power is back first. A cut during it (scheduled with
        // `SimFlash::cut_after` before this restart) is one more power
        // cycle: the next power-up runs it again, as a board does.
        #[cfg(feature = "update")]
        if let Some(flash) = &self.config.storage.flash {
            if flash.is_off() {
                flash.power_on();
            }
            for _ in 0..2 {
                if flash.try_boot().is_ok() {
                    break;
                }
                flash.power_on();
            }
            assert!(!flash.is_off(), "the bootloader ran to its end");
        }
        RESTART_ASKED.with(|r| r.set(false));
        self.robot.drop_connections();
        for p in self.plcs.iter_mut() {
            p.close();
        }
        self.gateway = Rc::new(Gateway::new(opts));
        self.fut = Self::spawn(
            &self.clock,
            &self.net,
            &self.gateway,
            self.config.storage.clone(),
        );
        self.flag.0.store(true, Ordering::Relaxed);
        self.settle();
        let n = self.plcs.len();
        self.plcs.clear();
        for i in 0..n {
            let from = SocketAddrV4::new(Ipv4Addr::new(10, 0, 0, 10 + i as u8), 51000 + i as u16);
            if let Some(s) = self.net.connect(from, MODBUS_PORT) {
                self.plcs.push(Plc::new(s));
            }
        }
        self.settle();
    }

    /// The current instant.
    pub fn now(&self) -> Instant {
        use crate::clock::Clock;
        self.clock.now()
    }

    /// Runs `f` on the gateway's state.
    pub fn model<R>(&self, f: impl FnOnce(&mut Model) -> R) -> R {
        self.gateway.hub().with(f)
    }

    /// Polls the gateway until it has nothing left to do now.
    pub fn settle(&mut self) {
        let at = self.now();
        self.polls += poll_until_waiting(&self.flag, &self.waker, &mut self.fut, 100_000, at);
    }

    /// Everything due now: the gateway and the robot take turns until
    /// neither has anything left to do at this instant.
    pub fn catch_up(&mut self) {
        loop {
            self.settle();
            let now = self.now();
            let broker = self.broker.as_mut().is_some_and(|b| b.step(now));
            if !self.robot.step(now) && !broker {
                return;
            }
        }
    }

    /// One turn: everything due now ([`Self::catch_up`]), then time moves
    /// to the next event of the gateway or the robot not after `limit`.
    /// `false` when nothing happens until `limit` (time is then at `limit`,
    /// and what was due then is done).
    pub fn turn(&mut self, limit: Instant) -> bool {
        self.catch_up();
        let now = self.now();
        let next = [
            self.clock.next_deadline(),
            self.robot.next_wakeup(),
            self.broker.as_ref().and_then(SimBroker::next_wakeup),
        ]
        .into_iter()
        .flatten()
        .filter(|t| *t > now)
        .min();
        match next {
            Some(t) if t <= limit => {
                self.clock.advance_to(t);
                true
            }
            _ => {
                if limit > now {
                    self.clock.advance_to(limit);
                }
                self.catch_up();
                false
            }
        }
    }

    /// Runs until `t`.
    pub fn run_until(&mut self, t: Instant) {
        while self.turn(t) {}
    }

    /// Runs for `d`.
    pub fn run_for(&mut self, d: Duration) {
        let t = self.now() + d;
        self.run_until(t);
    }

    /// Runs until `cond` holds (checked after every turn), at most `limit`
    /// long; `true` if it held.
    pub fn run_until_cond(
        &mut self,
        limit: Duration,
        mut cond: impl FnMut(&mut World) -> bool,
    ) -> bool {
        let end = self.now() + limit;
        loop {
            if cond(self) {
                return true;
            }
            if self.now() >= end {
                return false;
            }
            self.turn(end);
        }
    }

    /// A web client from `ip` sends `request` (raw bytes: request line,
    /// headers, body) on a new connection and reads until the gateway
    /// closes it, the answer is complete (by its `Content-Length` or its
    /// last chunk) or `limit` passes. Returns what came back (empty: the
    /// connection was refused or closed at once).
    pub fn http(&mut self, ip: Ipv4Addr, request: &[u8], limit: Duration) -> Vec<u8> {
        let Some(mut s) = self.web_connect(ip) else {
            return Vec::new();
        };
        s.write(request);
        let end = self.now() + limit;
        let mut got = Vec::new();
        loop {
            self.catch_up();
            got.extend(s.read());
            if http_complete(&got) || !s.is_open() {
                got.extend(s.read());
                break;
            }
            if !self.turn(end) {
                break;
            }
        }
        s.close();
        self.settle();
        got
    }

    /// A web client from `ip` connects (the world runs until the gateway
    /// took the connection or refused it).
    pub fn web_connect(&mut self, ip: Ipv4Addr) -> Option<crate::testkit::net::SimStream> {
        let from = SocketAddrV4::new(ip, 40000 + (self.polls % 20000) as u16);
        let s = self.net.connect(from, WEB_PORT)?;
        self.settle();
        Some(s)
    }

    /// A new Modbus client from `ip` connects; returns its index (for
    /// [`Self::request`]). Whether the gateway admits it shows in
    /// [`Self::plc_open`] once the world has run.
    pub fn connect_plc(&mut self, ip: Ipv4Addr) -> usize {
        let port = 50000 + self.plcs.len() as u16;
        if let Some(s) = self.net.connect(SocketAddrV4::new(ip, port), MODBUS_PORT) {
            self.plcs.push(Plc::new(s));
        }
        self.settle();
        self.plcs.len() - 1
    }

    /// PLC `i`'s connection is open.
    pub fn plc_open(&self, i: usize) -> bool {
        self.plcs.get(i).is_some_and(Plc::is_open)
    }

    /// PLC `i` sends `pdu` and waits for the answer (the world runs
    /// meanwhile). Panics if none comes within [`ANSWER_LIMIT`].
    pub fn request(&mut self, i: usize, pdu: &[u8]) -> Answer {
        // What is due now happens before the request arrives.
        self.catch_up();
        let tid = self.plcs[i].send(pdu);
        let end = self.now() + ANSWER_LIMIT;
        loop {
            self.catch_up();
            if let Some(a) = self.plcs[i].answer(tid) {
                let at = self.now().as_ticks().to_le_bytes();
                let answer = std::format!("{i} {pdu:?} {a:?}");
                for b in at.iter().chain(answer.as_bytes()) {
                    self.plc_trace = (self.plc_trace ^ u64::from(*b)).wrapping_mul(0x100_0000_01b3);
                }
                return a;
            }
            assert!(
                self.turn(end),
                "PLC {i}: no answer to {pdu:?} within {ANSWER_LIMIT:?}"
            );
        }
    }

    /// Reads `n` registers from `addr` (PLC 0).
    pub fn read(&mut self, addr: u16, n: u16) -> Result<Vec<u16>, u8> {
        match self.request(0, &pdu::read(addr, n)) {
            Answer::Pdu(p) => Ok(pdu::registers(&p)),
            Answer::Exception(e) => Err(e),
        }
    }

    /// Reads one register (PLC 0); panics on an exception.
    pub fn reg(&mut self, addr: u16) -> u16 {
        match self.read(addr, 1) {
            Ok(v) => v[0],
            Err(e) => panic!("reading {addr}: exception {e}"),
        }
    }

    /// Writes registers from `addr` (PLC 0).
    pub fn write(&mut self, addr: u16, values: &[u16]) -> Result<(), u8> {
        match self.request(0, &pdu::write(addr, values)) {
            Answer::Pdu(_) => Ok(()),
            Answer::Exception(e) => Err(e),
        }
    }

    /// Writes registers and panics on an exception.
    pub fn set(&mut self, addr: u16, values: &[u16]) {
        if let Err(e) = self.write(addr, values) {
            panic!("writing {addr}: exception {e}");
        }
    }
}

/// An HTTP answer in `b` is complete: its head and as many body bytes as
/// `Content-Length` says, or the last chunk of a chunked one.
pub fn http_complete(b: &[u8]) -> bool {
    let Some(head_end) = b.windows(4).position(|w| w == b"\r\n\r\n") else {
        return false;
    };
    let head = String::from_utf8_lossy(&b[..head_end]).to_ascii_lowercase();
    let body = &b[head_end + 4..];
    if head.contains("transfer-encoding: chunked") {
        return body.ends_with(b"0\r\n\r\n");
    }
    let len = head
        .lines()
        .find_map(|l| l.strip_prefix("content-length:"))
        .and_then(|v| v.trim().parse::<usize>().ok())
        .unwrap_or(0);
    body.len() >= len
}
