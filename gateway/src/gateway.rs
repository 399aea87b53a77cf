//! The gateway as a whole: shared state, the write path that turns register
//! writes into commands, and [`run`], which joins the engine and the Modbus
//! sessions into one future.

use core::cell::RefCell;
use core::convert::Infallible;
use core::net::Ipv4Addr;
use core::pin::pin;

use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::signal::Signal;
use embassy_time::{Duration, Instant};

use crate::config::{self, Config, Storage, IMAGE_LEN};
use crate::engine::commands::{self, Inputs};
use crate::engine::job::{GatewayError, Job, JobQueue, Outcome, Source};
use crate::net::Net;
use crate::registers::{self as r, AccessError, RegisterFile};
use crate::status;

/// Number of Modbus clients served at once ([`run`] starts one session
/// future for each).
pub const MAX_SESSIONS: usize = 4;
/// Socket buffer size of each Modbus session (each direction).
pub const MODBUS_BUF: usize = 512;
/// Socket buffer size of each robot-link socket (each direction).
pub const LINK_BUF: usize = 1024;

/// The gateway version in register `VERSION` (`major × 256 + minor`).
pub const VERSION: u16 = 0x0100;

/// How the gateway is started.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Port of the Modbus server (502 on boards).
    pub modbus_port: u16,
    /// Configuration used when storage holds none (or a damaged one).
    pub defaults: Config,
    /// Robot address that overrides the stored one (host `--robot`).
    pub robot_override: Option<RobotOverride>,
}

/// A robot address given at start (host `--robot` / `--robot-listen`). It
/// replaces the robot setting of a stored configuration for this run (the
/// log says so); the other stored settings are kept. The configuration
/// registers show it, so a save (`CONFIG_COMMAND` 1) stores it.
#[derive(Clone, Copy, Debug)]
pub enum RobotOverride {
    /// Connect to this address and port.
    Connect(Ipv4Addr, u16),
    /// Listen on this port for the controller.
    Listen(u16),
}

impl RobotOverride {
    /// `config` with this robot setting.
    pub fn apply(self, mut config: Config) -> Config {
        match self {
            RobotOverride::Connect(ip, port) => {
                config.robot_ip = ip;
                config.robot_port = port;
                config.link_mode = config::LinkMode::Connect;
            }
            RobotOverride::Listen(port) => {
                config.listen_port = port;
                config.link_mode = config::LinkMode::Listen;
            }
        }
        config
    }
}

impl Default for Options {
    fn default() -> Self {
        Options {
            modbus_port: 502,
            defaults: Config::default(),
            robot_override: None,
        }
    }
}

/// State shared by the engine and the Modbus sessions.
pub(crate) struct Shared<'r> {
    /// The register map (5.5 KiB: a local of [`run`], borrowed so that it
    /// is zeroed where it stays instead of being moved into place).
    pub regs: &'r mut RegisterFile,
    /// The active configuration.
    pub config: Config,
    /// Bumped when the configuration is applied.
    pub config_gen: u32,
    pub queue: JobQueue,
    pub link_up: bool,
    /// When the robot status was last refreshed.
    pub status_time: Option<Instant>,
    /// When the PLC heartbeat last changed.
    pub last_beat: Instant,
    pub sessions: u16,
    /// The controller's address on the current link (listen mode).
    pub robot_peer: Option<Ipv4Addr>,
}

impl Shared<'_> {
    /// One register as the PLC reads it (the status age is computed now).
    pub fn read(&self, addr: u16, now: Instant) -> u16 {
        if addr == r::STATUS_AGE_MS {
            return match self.status_time {
                None => u16::MAX,
                Some(t) => {
                    u16::try_from(now.saturating_duration_since(t).as_millis()).unwrap_or(u16::MAX)
                }
            };
        }
        self.regs.get(addr)
    }

    /// Ends a source's command and logs it.
    pub fn finish(&mut self, source: Source, outcome: Outcome) {
        let order = self.config.word_order;
        source.set_outcome(self.regs, outcome, order);
        match outcome {
            Outcome::Done => info!("{} #{}: done", source.name(), source.index()),
            Outcome::Aborted => info!("{} #{}: aborted", source.name(), source.index()),
            Outcome::Error(s, code) => {
                warn!(
                    "{} #{}: error {} (source {})",
                    source.name(),
                    source.index(),
                    code,
                    s as u8
                )
            }
        }
    }

    pub fn update_queue_reg(&mut self) {
        self.regs.set(r::STATUS_QUEUE_USED, self.queue.len() as u16);
    }

    /// Fails every queued job (link lost or down).
    pub fn fail_queue(&mut self, e: GatewayError) {
        while let Some(source) = self.queue.pop_source() {
            self.finish(source, Outcome::gateway(e));
        }
        self.update_queue_reg();
    }

    /// A stop ended the motions: every motion job still waiting in the
    /// queue ends in CommandAborted and is never sent.
    pub fn abort_queued_motions(&mut self) {
        while let Some(source) = self.queue.take_motion() {
            self.finish(source, Outcome::Aborted);
        }
        self.update_queue_reg();
    }
}

/// What the tasks share.
pub(crate) struct Ctx<'a> {
    pub shared: Mutex<NoopRawMutex, RefCell<Shared<'a>>>,
    /// Wakes the engine (a job was queued, the configuration changed).
    pub wake: Signal<NoopRawMutex, ()>,
    pub storage: RefCell<&'a mut dyn Storage>,
}

/// Why a write was refused (maps to a Modbus exception).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum WriteError {
    /// Exception 02.
    Address,
    /// Exception 03.
    Value,
    /// Exception 04.
    Device,
}

impl From<AccessError> for WriteError {
    fn from(_: AccessError) -> Self {
        WriteError::Address
    }
}

/// The control registers whose changes start something.
#[derive(Clone, Copy)]
struct Controls {
    channels: [u16; r::CHANNELS],
    raw: u16,
    triggers: u16,
    heartbeat: u16,
}

impl Controls {
    fn of(regs: &RegisterFile) -> Self {
        let mut channels = [0; r::CHANNELS];
        for (i, c) in channels.iter_mut().enumerate() {
            *c = regs.get(r::channel_base(i) + r::CH_CONTROL);
        }
        Controls {
            channels,
            raw: regs.get(r::RAW_CONTROL),
            triggers: regs.get(r::TRIG_BITS),
            heartbeat: regs.get(r::CONTROL_HEARTBEAT),
        }
    }
}

impl<'a> Ctx<'a> {
    /// A context with every register 0 and the default configuration;
    /// [`Ctx::load`] fills it. Built in place: nothing large passes
    /// through the stack.
    pub fn new(storage: &'a mut dyn Storage, regs: &'a mut RegisterFile) -> Self {
        Ctx {
            shared: Mutex::new(RefCell::new(Shared {
                regs,
                config: Config::DEFAULT,
                config_gen: 0,
                queue: JobQueue::new(),
                link_up: false,
                status_time: None,
                last_beat: Instant::from_ticks(0),
                sessions: 0,
                robot_peer: None,
            })),
            wake: Signal::new(),
            storage: RefCell::new(storage),
        }
    }

    /// Loads the stored configuration and trigger table (or `opts`'
    /// defaults), applies the robot override and sets the start values
    /// of the registers. Once, at start. Not inlined, so that its 3 KiB
    /// image buffer is off the stack once it returns.
    #[inline(never)]
    pub fn load(&self, opts: &Options) {
        let mut image = [0u8; IMAGE_LEN];
        let stored = self.storage.borrow_mut().load(&mut image);
        self.with(|s| {
            let regs = &mut *s.regs;
            let loaded = match stored {
                Ok(0) => {
                    info!("config: nothing stored, using defaults");
                    None
                }
                Ok(n) => match config::decode_image(image.get(..n).unwrap_or(&[]), regs) {
                    Ok(c) => {
                        info!("config: loaded from storage");
                        Some(c)
                    }
                    Err(_) => {
                        warn!("config: stored image invalid, using defaults");
                        None
                    }
                },
                Err(_) => {
                    warn!("config: storage read failed, using defaults");
                    None
                }
            };
            let mut config = loaded.unwrap_or(opts.defaults);
            if let Some(o) = opts.robot_override {
                config = o.apply(config);
                if let Some(saved) = loaded.filter(|c| o.apply(*c) != *c) {
                    // The command line wins (the operator asked for it), but
                    // never silently: the other saved settings are kept.
                    let [a, b, c, d] = saved.robot_ip.octets();
                    warn!(
                        "config: the robot setting given at start overrides the saved one (saved: link mode {}, robot {}.{}.{}.{}:{}, listen port {}) for this run; CONFIG_COMMAND 1 would save the new one",
                        saved.link_mode as u16,
                        a,
                        b,
                        c,
                        d,
                        saved.robot_port,
                        saved.listen_port
                    );
                }
            }
            config.store(regs);
            regs.set(r::STATUS_VERSION, VERSION);
            status::invalidate(regs, config.word_order);
            regs.set(r::STATUS_SOURCE, config.status_source as u16);
            s.config = config;
            s.last_beat = Instant::now();
        });
    }

    /// Runs `f` on the shared state.
    pub fn with<R>(&self, f: impl FnOnce(&mut Shared<'a>) -> R) -> R {
        self.shared.lock(|c| f(&mut c.borrow_mut()))
    }

    /// Reads registers for the PLC.
    pub fn read(&self, start: u16, out: &mut [u16]) -> Result<(), AccessError> {
        RegisterFile::check(start, out.len() as u16, false)?;
        let now = Instant::now();
        self.with(|s| {
            for (i, o) in out.iter_mut().enumerate() {
                *o = s.read(start + i as u16, now);
            }
        });
        Ok(())
    }

    /// Writes registers for the PLC: all or nothing, then acts on edges of
    /// the control registers and on configuration commands.
    pub fn write(&self, start: u16, values: &[u16]) -> Result<(), WriteError> {
        RegisterFile::check(start, values.len() as u16, true)?;
        let now = Instant::now();
        let in_range = |a: u16| a >= start && u32::from(a) < u32::from(start) + values.len() as u32;
        let config_cmd = in_range(r::CONTROL_CONFIG_COMMAND)
            .then(|| {
                values
                    .get(usize::from(r::CONTROL_CONFIG_COMMAND - start))
                    .copied()
            })
            .flatten();
        if let Some(cmd) = config_cmd {
            if cmd > 3 {
                return Err(WriteError::Value);
            }
        }
        let fired = self.with(|s| {
            let old = Controls::of(s.regs);
            for (i, v) in values.iter().enumerate() {
                s.regs.set(start + i as u16, *v);
            }
            s.regs.set(r::CONTROL_CONFIG_COMMAND, 0);
            let new = Controls::of(s.regs);
            if new.heartbeat != old.heartbeat {
                s.last_beat = now;
                s.regs.set_bits(r::STATUS_WATCHDOG, 1 << 1, false);
            }
            let mut fired = false;
            for i in 0..r::CHANNELS {
                fired |= edge(
                    s,
                    Source::Channel(i as u8),
                    old.channels[i] & 1,
                    new.channels[i] & 1,
                );
            }
            fired |= edge(s, Source::Raw, old.raw & 1, new.raw & 1);
            for i in 0..r::TRIGGERS {
                let m = 1 << i;
                fired |= edge(
                    s,
                    Source::Trigger(i as u8),
                    old.triggers & m,
                    new.triggers & m,
                );
            }
            fired
        });
        if fired {
            self.wake.signal(());
        }
        match config_cmd {
            Some(1) => self.apply_config(),
            Some(2) => {
                self.with(|s| {
                    let c = s.config;
                    c.store(s.regs);
                    s.regs
                        .set(r::CONTROL_CONFIG_RESULT, ConfigResult::Ok as u16);
                });
                Ok(())
            }
            Some(3) => {
                self.with(|s| {
                    Config::default().store(s.regs);
                    s.regs
                        .set(r::CONTROL_CONFIG_RESULT, ConfigResult::Ok as u16);
                });
                Ok(())
            }
            _ => Ok(()),
        }
    }

    /// Checks, applies and saves the configuration registers (and the
    /// trigger table).
    fn apply_config(&self) -> Result<(), WriteError> {
        let mut image = [0u8; IMAGE_LEN];
        let checked = self.with(|s| {
            match Config::from_words(&Config::words_of(s.regs)) {
                Err(bad) => {
                    s.regs
                        .set(r::CONTROL_CONFIG_RESULT, ConfigResult::Invalid as u16);
                    s.regs.set(r::CONTROL_CONFIG_BAD_ADDR, bad.addr);
                    Err(bad)
                }
                Ok(c) => {
                    let order_changed = c.word_order != s.config.word_order;
                    s.config = c;
                    s.config_gen = s.config_gen.wrapping_add(1);
                    s.regs.set(r::STATUS_SOURCE, c.status_source as u16);
                    if order_changed {
                        // Re-encode the 32-bit status values in the new order.
                        let ov = s.regs.get_f32(r::STATUS_OVERRIDE, flip(c.word_order));
                        s.regs.set_f32(r::STATUS_OVERRIDE, ov, c.word_order);
                        for k in 0..12 {
                            let a = r::STATUS_JOINTS + 2 * k;
                            let v = s.regs.get_u32(a, flip(c.word_order));
                            s.regs.set_u32(a, v, c.word_order);
                        }
                        let e = s.regs.get_u32(r::STATUS_ERROR_CODE, flip(c.word_order));
                        s.regs.set_u32(r::STATUS_ERROR_CODE, e, c.word_order);
                    }
                    config::encode_image(&c, s.regs, &mut image);
                    Ok(())
                }
            }
        });
        self.wake.signal(());
        if let Err(bad) = checked {
            warn!("config: register {} invalid, not applied", bad.addr);
            return Err(WriteError::Value);
        }
        let (saved, persistent) = {
            let mut storage = self.storage.borrow_mut();
            (storage.save(&image), storage.is_persistent())
        };
        let (result, answer) = match (saved, persistent) {
            (Ok(()), true) => {
                info!("config: applied and saved");
                (ConfigResult::Ok, Ok(()))
            }
            (Ok(()), false) => {
                warn!("config: applied, not saved: no persistent storage (lost at restart)");
                (ConfigResult::NotSaved, Ok(()))
            }
            (Err(_), _) => {
                warn!("config: applied, but saving failed");
                (ConfigResult::SaveFailed, Err(WriteError::Device))
            }
        };
        self.with(|s| {
            s.regs.set(r::CONTROL_CONFIG_RESULT, result as u16);
            if result == ConfigResult::Ok {
                let n = s.regs.get(r::CONTROL_SAVES).wrapping_add(1);
                s.regs.set(r::CONTROL_SAVES, n);
            }
        });
        answer
    }
}

/// Values of `CONFIG_RESULT`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum ConfigResult {
    /// Done: for CONFIG_COMMAND 1 applied and saved, for 2 and 3 the CFG_*
    /// registers rewritten.
    Ok = 0,
    /// A value was out of range: nothing applied (exception 03).
    Invalid = 1,
    /// Applied, but the storage failed (exception 04).
    SaveFailed = 2,
    /// Applied, not saved: the gateway has no persistent storage.
    NotSaved = 3,
}

fn flip(o: config::WordOrder) -> config::WordOrder {
    match o {
        config::WordOrder::HighFirst => config::WordOrder::LowFirst,
        config::WordOrder::LowFirst => config::WordOrder::HighFirst,
    }
}

/// Acts on one control bit: a rising edge fires the command, a falling edge
/// clears the outputs of a finished command. Returns `true` if a job was
/// queued.
fn edge(s: &mut Shared<'_>, source: Source, old: u16, new: u16) -> bool {
    if old == new {
        return false;
    }
    let busy = source.is_busy(s.regs);
    if new == 0 {
        if !busy {
            source.clear_outputs(s.regs);
        }
        return false;
    }
    if busy {
        // PLCopen: a new edge while Busy is ignored.
        return false;
    }
    let (seq, code, job) = build_job(s, source);
    source.set_started(s.regs, seq, code);
    let job = match job {
        Ok(j) => j,
        Err(e) => {
            s.finish(source, Outcome::gateway(e));
            return false;
        }
    };
    if !s.link_up {
        s.finish(source, Outcome::gateway(GatewayError::NotConnected));
        return false;
    }
    info!(
        "{} #{}: queued {}",
        source.name(),
        source.index(),
        job.text.as_str()
    );
    if let Err(source) = s.queue.push(job) {
        s.finish(source, Outcome::gateway(GatewayError::QueueFull));
        return false;
    }
    s.update_queue_reg();
    true
}

/// Reads what a source's registers say and builds its job.
fn build_job(s: &Shared<'_>, source: Source) -> (u16, u16, Result<Job, GatewayError>) {
    let order = s.config.word_order;
    let regs = &s.regs;
    match source {
        Source::Channel(i) => {
            let b = r::channel_base(usize::from(i));
            let seq = regs.get(b + r::CH_SEQUENCE);
            let code = regs.get(b + r::CH_COMMAND);
            let mut params = [0f32; r::CH_PARAM_COUNT];
            for (k, p) in params.iter_mut().enumerate() {
                *p = regs.get_f32(b + r::CH_PARAMS + 2 * k as u16, order);
            }
            let mut t1 = [0u8; 32];
            let mut t2 = [0u8; 32];
            let n1 = regs.get_text(b + r::CH_TEXT1, r::CH_TEXT_REGS, &mut t1);
            let n2 = regs.get_text(b + r::CH_TEXT2, r::CH_TEXT_REGS, &mut t2);
            let (Some(text1), Some(text2)) = (
                t1.get(..n1).and_then(|t| core::str::from_utf8(t).ok()),
                t2.get(..n2).and_then(|t| core::str::from_utf8(t).ok()),
            ) else {
                return (seq, code, Err(GatewayError::BadParameter));
            };
            let inputs = Inputs {
                code,
                params,
                text1: text1.trim(),
                text2: text2.trim(),
                robot_id: s.config.robot_id,
                joints: status::joints(regs, order),
            };
            (seq, code, commands::build(source, seq, &inputs))
        }
        Source::Raw => {
            let seq = regs.get(r::RAW_SEQUENCE);
            let mut t = [0u8; 2 * r::RAW_REQUEST_REGS as usize];
            let n = regs.get_text(r::RAW_REQUEST, r::RAW_REQUEST_REGS, &mut t);
            (seq, 0, text_job(source, seq, t.get(..n)))
        }
        Source::Trigger(i) => {
            let mut t = [0u8; 2 * r::TRIG_TEXT_REGS as usize];
            let n = regs.get_text(r::trigger_text(usize::from(i)), r::TRIG_TEXT_REGS, &mut t);
            if n == 0 {
                return (0, 0, Err(GatewayError::TriggerEmpty));
            }
            (0, 0, text_job(source, 0, t.get(..n)))
        }
        Source::Watchdog | Source::AutoReset => (0, 0, Err(GatewayError::BadParameter)),
    }
}

fn text_job(source: Source, seq: u16, text: Option<&[u8]>) -> Result<Job, GatewayError> {
    let t = text.ok_or(GatewayError::BadParameter)?;
    if !t.iter().all(|b| (0x20..0x7f).contains(b)) {
        return Err(GatewayError::BadParameter);
    }
    let t = core::str::from_utf8(t).map_err(|_| GatewayError::BadParameter)?;
    Job::from_text(source, seq, t)
}

/// Runs the gateway on `net` until the future is dropped: the engine (robot
/// link, command queue, status mirror, watchdog) and [`MAX_SESSIONS`]
/// Modbus sessions on `opts.modbus_port`, and the DataSheet reader when it
/// is the configured status source.
///
/// Everything lives in this one future (sockets and buffers included), so
/// a board runs it from one task and the host from one thread.
pub async fn run<N: Net>(net: &N, storage: &mut dyn Storage, opts: Options) -> Infallible {
    // Every part is built where it stays (a pinned local of this future):
    // futures and buffers of kilobytes are never moved through the stack.
    let mut regs = RegisterFile::new();
    let ctx = Ctx::new(storage, &mut regs);
    ctx.load(&opts);
    let mut link_bufs = [[0u8; LINK_BUF]; 4];
    let [l0, l1, l2, l3] = link_bufs.each_mut();
    let engine = pin!(crate::engine::run(
        &ctx,
        net.socket(l0, l1),
        net.socket(l2, l3)
    ));
    let mut bufs = [[[0u8; MODBUS_BUF]; 2]; MAX_SESSIONS];
    let [[r0, t0], [r1, t1], [r2, t2], [r3, t3]] = bufs.each_mut().map(|b| b.each_mut());
    let port = opts.modbus_port;
    let s0 = pin!(crate::modbus::session(&ctx, net.socket(r0, t0), port));
    let s1 = pin!(crate::modbus::session(&ctx, net.socket(r1, t1), port));
    let s2 = pin!(crate::modbus::session(&ctx, net.socket(r2, t2), port));
    let s3 = pin!(crate::modbus::session(&ctx, net.socket(r3, t3), port));
    let (mut ds_rx, mut ds_tx) = ([0u8; LINK_BUF], [0u8; 64]);
    let datasheet = pin!(crate::datasheet::run(
        &ctx,
        net.socket(&mut ds_rx, &mut ds_tx)
    ));
    let _ = embassy_futures::join::join3(
        engine,
        embassy_futures::join::join_array([s0, s1, s2, s3]),
        datasheet,
    )
    .await;
    // The engine, the sessions and the DataSheet reader loop forever.
    core::future::pending().await
}

/// The engine's view of time between status rounds.
pub(crate) fn millis(ms: u16) -> Duration {
    Duration::from_millis(u64::from(ms))
}
