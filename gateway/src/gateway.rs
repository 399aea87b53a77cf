//! The gateway as a whole: how it is started ([`Options`]), loading the
//! stored configuration, and [`Gateway::run`], which joins the engine, the
//! Modbus sessions, the DataSheet reader and the storage task into one
//! future.

use core::convert::Infallible;
use core::net::Ipv4Addr;
use core::pin::pin;

use embassy_futures::join::{join, join4, join5};

use crate::access::setup::SetupCode;
use crate::clock::Clock;
use crate::config::{self, Config, HostName};
use crate::hub::Hub;
use crate::net::Net;
use crate::plc::PlcPort;
use crate::state::Model;
use crate::storage::{image, ConfigStore, Image, Medium, SaveOutcome, StorageError, Stored};

use crate::limits::{LINK_BUF, MAX_SESSIONS, MODBUS_BUF};

/// How the gateway is started.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// Port of the Modbus server (502 on boards).
    pub modbus_port: u16,
    /// Configuration used when storage holds none (or a damaged one).
    pub defaults: Config,
    /// Robot address that overrides the stored one (host `--robot`).
    pub robot_override: Option<RobotOverride>,
    /// Start with the factory network and access settings (`defaults`'
    /// network, write protection and allow-lists) instead of the stored
    /// ones: the way back when the address is lost (a board's button held
    /// at power-up). The stored configuration is not changed until the
    /// next save.
    pub recovery: bool,
    /// The network settings of the configuration are applied by this
    /// platform (boards). On Linux the operating system and the command
    /// line decide them: `false`.
    pub network_managed: bool,
    /// Seed of the random generator behind web session tokens and
    /// password salts: from the board's random source (on Linux, the
    /// operating system's).
    pub seed: [u8; 32],
    /// Port of the web page where the platform does not manage the
    /// network (Linux `--web-listen`); 0 = no web page. Boards take
    /// `NET_WEB_PORT` from the configuration instead.
    pub web_port: u16,
    /// How the web page restarts the device (boards); `None`: it cannot.
    pub restart: Option<fn()>,
    /// The one-time code that proves presence when the first
    /// administrator is created (see `access::setup`): the platform makes
    /// it from its random source and shows it where only someone at the
    /// device reads it. `None`: no administrator can be created (until a
    /// restart with a code).
    pub setup_code: Option<SetupCode>,
    /// The wall clock, Unix seconds now (`None`: not set), where the
    /// platform has one (Linux: the host's clock). The audit log's records
    /// carry it; without it they have only the uptime until a time server
    /// answers.
    pub wall_clock: Option<fn() -> Option<u64>>,
    /// The device's own name: the Sparkplug edge node id (and MQTT client
    /// id) when `mqtt.edge_id` is empty. Boards: `hans-` and the MAC
    /// address; Linux: the host name.
    pub node_name: HostName,
    /// The MQTT broker given at start (host `--mqtt`): for this run the
    /// telemetry is on, to this broker, whatever the stored `mqtt.*` say
    /// (the configuration views show it; a save stores it).
    pub mqtt_override: Option<MqttOverride>,
    /// The broker's user name and password, where the platform has them
    /// (Linux: `--mqtt-user`, `--mqtt-password-file`); `None`: anonymous.
    #[cfg(feature = "mqtt")]
    pub mqtt_login: Option<crate::mqtt::Login>,
    /// The public key (ed25519) whose signature an uploaded firmware image
    /// must carry: the one compiled into the bootloader (boards); `None`:
    /// this platform installs no image.
    #[cfg(feature = "update")]
    pub update_key: Option<[u8; 32]>,
    /// The board id an image must name (`hans_fw_image::layout`).
    #[cfg(feature = "update")]
    pub board: &'static str,
    /// A test's failure of the trial image's self-check (the QEMU board's
    /// `selfcheck=fail` word): an image on trial does not confirm itself,
    /// and restarts so that the bootloader rolls it back.
    #[cfg(feature = "update")]
    pub self_check_fails: bool,
    /// The software's version as this platform names it, where no firmware
    /// image names one: Linux gives its program's (`hans-gateway`'s, which
    /// is its package's version). Default: this crate's. A field device
    /// with updates reports its running image's version instead (read from
    /// its slots). The Sparkplug `Gateway/Version` metric shows it.
    pub version: &'static str,
    /// The EtherNet/IP adapter's ports and identity (feature `enip`);
    /// `None`: not served whatever `enip.enabled` says (Linux without
    /// `--enip-listen`). Served only while `enip.enabled` is on.
    #[cfg(feature = "enip")]
    pub enip: Option<crate::enip::EnipOptions>,
}

/// A broker given at start (see [`Options::mqtt_override`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MqttOverride {
    /// Its name or address.
    pub broker: HostName,
    /// Its port.
    pub port: u16,
    /// TLS to it (`mqtts://`).
    pub tls: bool,
}

impl MqttOverride {
    /// `config` with the telemetry on, to this broker.
    pub fn apply(self, mut config: Config) -> Config {
        config.mqtt.enabled = true;
        config.mqtt.broker = self.broker;
        config.mqtt.port = self.port;
        config.mqtt.tls = self.tls;
        config
    }
}

/// A robot address given at start (host `--robot` / `--robot-listen`). It
/// replaces the robot setting of a stored configuration for this run (the
/// log says so); the other stored settings are kept. The configuration
/// registers show it, so a save (`CONFIG_COMMAND` 1) stores it; factory
/// defaults (`CONFIG_COMMAND` 3) keep it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
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
            recovery: false,
            network_managed: false,
            seed: [0; 32],
            web_port: 0,
            restart: None,
            setup_code: None,
            wall_clock: None,
            node_name: HostName::from_static("hans-gateway"),
            mqtt_override: None,
            #[cfg(feature = "mqtt")]
            mqtt_login: None,
            #[cfg(feature = "update")]
            update_key: None,
            #[cfg(feature = "update")]
            board: "",
            #[cfg(feature = "update")]
            self_check_fails: false,
            version: env!("CARGO_PKG_VERSION"),
            #[cfg(feature = "enip")]
            enip: Some(crate::enip::EnipOptions::default()),
        }
    }
}

impl Options {
    /// What `CONFIG_COMMAND` 3 loads: the defaults, with the robot address
    /// given at start.
    pub fn factory(&self) -> Config {
        let config = match self.robot_override {
            Some(o) => o.apply(self.defaults),
            None => self.defaults,
        };
        match self.mqtt_override {
            Some(o) => o.apply(config),
            None => config,
        }
    }
}

/// What the gateway keeps its things in: a [`ConfigStore`] always, an
/// [`AuditStore`](crate::storage::AuditStore) with the feature `audit`,
/// firmware slots ([`SlotStore`](crate::update::SlotStore)) with `update`.
/// A platform implements the traits its build needs on one value (joining
/// media with [`WithAudit`](crate::storage::WithAudit) and
/// [`WithSlots`](crate::update::WithSlots)); this trait is implemented for
/// every such value.
pub trait Storage: ConfigStore + needs::Audit + needs::Slots {}

impl<T: ConfigStore + needs::Audit + needs::Slots> Storage for T {}

/// The stores a feature adds to [`Storage`]: one bound per feature, empty
/// without it.
pub mod needs {
    /// With `audit`: [`AuditStore`](crate::storage::AuditStore).
    #[cfg(feature = "audit")]
    pub use crate::storage::AuditStore as Audit;
    /// Without `audit`: nothing.
    #[cfg(not(feature = "audit"))]
    pub trait Audit {}
    #[cfg(not(feature = "audit"))]
    impl<T> Audit for T {}
    /// With `update`: [`SlotStore`](crate::update::SlotStore).
    #[cfg(feature = "update")]
    pub use crate::update::SlotStore as Slots;
    /// Without `update`: nothing.
    #[cfg(not(feature = "update"))]
    pub trait Slots {}
    #[cfg(not(feature = "update"))]
    impl<T> Slots for T {}
}

/// A gateway: its state, and how it was started.
pub struct Gateway {
    hub: Hub,
    opts: Options,
}

impl Gateway {
    /// A gateway with the start configuration of `opts`, not yet running.
    pub fn new(opts: Options) -> Self {
        let factory = opts.factory();
        Gateway {
            hub: Hub::new(Model::new(factory, factory)),
            opts,
        }
    }

    /// Its state (for views, and for tests).
    pub fn hub(&self) -> &Hub {
        &self.hub
    }

    /// Loads the stored configuration and trigger table (or keeps the
    /// defaults, with a log line saying why), applies the robot override,
    /// then runs the engine (robot link, queue, status, watchdog),
    /// [`MAX_SESSIONS`] Modbus sessions on `opts.modbus_port`, the
    /// DataSheet reader and the storage task until the future is dropped.
    ///
    /// Everything lives in this one future (sockets and buffers included),
    /// so a board runs it from one task and the host from one thread.
    pub async fn run<N: Net, C: Clock, S: Storage>(
        &self,
        net: &N,
        clock: &C,
        mut storage: S,
    ) -> Infallible {
        self.load(&mut storage, clock).await;
        // Borrowed, not moved: see `board::run`.
        self.serve(net, clock, &mut storage).await
    }

    /// Runs the gateway as [`Self::run`] does until `stop` gives a reason
    /// (a platform's stop request, e.g. `"SIGTERM"`), then stops in order
    /// while the gateway goes on serving: with the audit log (feature
    /// `audit`) a `stop` record with the reason, the log's counting periods
    /// ended with a record of what they counted, and both kept by the
    /// storage task before this returns (at most 5 s). A gateway stopped
    /// by dropping its future loses what the running periods counted.
    pub async fn run_until<N: Net, C: Clock, S: Storage>(
        &self,
        net: &N,
        clock: &C,
        storage: S,
        stop: impl core::future::Future<Output = &'static str>,
    ) -> Stopped {
        use embassy_futures::select::{select, Either};
        let run = pin!(self.run(net, clock, storage));
        let stopping = pin!(async {
            let why = stop.await;
            info!("stopping ({})", why);
            #[cfg(feature = "audit")]
            let kept = crate::audit::keep::closing(&self.hub.audit, clock, Some(why)).await;
            #[cfg(not(feature = "audit"))]
            let kept = true;
            Stopped { kept }
        });
        match select(run, stopping).await {
            Either::First(never) => match never {},
            Either::Second(stopped) => stopped,
        }
    }

    /// The network settings to run with, once [`Self::load`] has run:
    /// the configuration's on boards (the caller applies address, mask,
    /// gateway and DHCP to its stack), and in any case the ports.
    pub fn network(&self) -> crate::config::NetConfig {
        self.hub.with(|m| m.access.running)
    }

    /// The Modbus and web ports to serve: the configuration's where the
    /// platform manages the network, else the options'.
    fn ports(&self) -> (u16, u16) {
        if self.opts.network_managed {
            let n = self.network();
            (n.modbus_port, n.web_port)
        } else {
            (self.opts.modbus_port, self.opts.web_port)
        }
    }

    /// Runs the gateway with the configuration [`Self::load`] loaded
    /// (see [`Self::run`]). Pass the storage by reference (`&mut S` is a
    /// [`Storage`]), as `board::run` does: a storage moved in is carried
    /// by this future, and a future that copies its arguments in can be
    /// built on the caller's stack before it moves into place.
    pub async fn serve<N: Net, C: Clock, S: Storage>(
        &self,
        net: &N,
        clock: &C,
        mut storage: S,
    ) -> Infallible {
        // Every part is built where it stays (a local of this future):
        // buffers of kilobytes are never moved through the stack.
        let (port, web_port) = self.ports();
        let hub = &self.hub;
        #[cfg(feature = "update")]
        if let Some(key) = self.opts.update_key {
            hub.updates.trust_images(key, self.opts.board);
        }
        let mut link_bufs = [[0u8; LINK_BUF]; 4];
        let [l0, l1, l2, l3] = link_bufs.each_mut();
        let engine = crate::engine::run(hub, clock, net.socket(l0, l1), net.socket(l2, l3));
        let modbus_slots = crate::modbus::Slots::new(crate::modbus::NAME, &crate::modbus::LIMITS);
        let plc = PlcPort {
            hub,
            clock,
            slots: &modbus_slots,
        };
        let warden = crate::plc::warden(&plc);
        let mut bufs = [[[0u8; MODBUS_BUF]; 2]; MAX_SESSIONS];
        // The sessions one by one, each pinned where it stays: built as an
        // array (`map`) and moved into `join_array`, the array (4.4 KiB)
        // went through a temporary in the frame of the board task's poll.
        // (The pattern does not compile if MAX_SESSIONS changes: then add
        // or remove a session here.)
        let [k0, k1, k2, k3, k4] = bufs.each_mut().map(|b| {
            let [rx, tx] = b.each_mut();
            net.socket(rx, tx)
        });
        let session = |sock, i| crate::modbus::session(&plc, clock, sock, port, i);
        let (s0, s1, s2) = (
            pin!(session(k0, 0)),
            pin!(session(k1, 1)),
            pin!(session(k2, 2)),
        );
        let (s3, s4) = (pin!(session(k3, 3)), pin!(session(k4, 4)));
        let sessions = join5(s0, s1, s2, s3, s4);
        #[cfg(feature = "datasheet")]
        let (mut ds_rx, mut ds_tx) = ([0u8; LINK_BUF], [0u8; 64]);
        #[cfg(feature = "datasheet")]
        let datasheet = crate::datasheet::run(hub, clock, net.socket(&mut ds_rx, &mut ds_tx));
        #[cfg(not(feature = "datasheet"))]
        let datasheet = core::future::pending::<Infallible>();
        let saver = storage_task(hub, clock, &mut storage);
        #[cfg(feature = "web")]
        let web = crate::web::Web::new(self.opts.seed, self.opts.setup_code, self.opts.restart);
        #[cfg(feature = "web")]
        let page = async {
            if web_port == 0 {
                return core::future::pending().await;
            }
            hub.with(|m| m.access.web_on = true);
            info!("web: page on port {}", web_port);
            crate::web::run(hub, clock, &web, net, web_port).await
        };
        #[cfg(not(feature = "web"))]
        let page = {
            let _ = web_port;
            core::future::pending::<Infallible>()
        };
        #[cfg(feature = "mqtt")]
        let utc = self.opts.wall_clock.and_then(|f| f()).map(|secs| {
            secs.saturating_mul(1000)
                .saturating_sub(clock.now().as_millis())
        });
        #[cfg(feature = "mqtt")]
        let telemetry = crate::mqtt::serve(
            hub,
            clock,
            net,
            self.opts.node_name.as_str(),
            self.opts.version,
            utc,
            self.opts.mqtt_login,
        );
        #[cfg(not(feature = "mqtt"))]
        let telemetry = core::future::pending::<Infallible>();
        #[cfg(feature = "update")]
        let trial = trial(hub, clock, &self.opts, web_port);
        #[cfg(not(feature = "update"))]
        let trial = core::future::pending::<Infallible>();
        #[cfg(feature = "enip")]
        let enip = async {
            let [s0, s1, s2, s3, ..] = self.opts.seed;
            match &self.opts.enip {
                Some(o) => {
                    let name = self.opts.node_name.as_str();
                    let seed = u32::from_le_bytes([s0, s1, s2, s3]);
                    crate::enip::serve(hub, clock, net, o, name, seed).await
                }
                None => core::future::pending().await,
            }
        };
        #[cfg(not(feature = "enip"))]
        let enip = core::future::pending::<Infallible>();
        // Joined through pinned references: each part stays where it was
        // built, instead of being moved into the join (through the stack).
        let (engine, sessions) = (pin!(engine), pin!(sessions));
        let (datasheet, saver, page) = (pin!(datasheet), pin!(saver), pin!(page));
        let (telemetry, trial, warden) = (pin!(telemetry), pin!(trial), pin!(warden));
        let enip = pin!(enip);
        let _ = join(
            join5(engine, sessions, datasheet, saver, page),
            join4(telemetry, trial, warden, enip),
        )
        .await;
        // The engine, the sessions, the reader and the saver loop forever.
        core::future::pending().await
    }

    /// Loads the stored configuration and trigger table (and the web
    /// password); the first half of [`Self::run`], for platforms that
    /// apply the network settings before serving. Not inlined, so that
    /// its locals are off the stack once it returns.
    #[inline(never)]
    pub async fn load<C: Clock, S: Storage>(&self, storage: &mut S, clock: &C) {
        // The audit log first: the boot counter follows its newest record.
        #[cfg(feature = "audit")]
        let boot = crate::audit::keep::restore(&self.hub.audit, storage).await;
        let medium = storage.medium();
        let keeps = crate::state::Keeps {
            config: medium != Medium::None,
            #[cfg(feature = "audit")]
            audit: <S as crate::storage::AuditStore>::persistent(storage),
            #[cfg(not(feature = "audit"))]
            audit: false,
        };
        let stored = storage.load().await;
        let opts = &self.opts;
        let now = clock.now();
        #[cfg(feature = "audit")]
        let mut how = crate::audit::keep::Loaded::Nothing;
        self.hub.with(|m| {
            let loaded = match stored {
                Ok([]) => {
                    info!("config: nothing stored, using defaults");
                    None
                }
                Ok(image) => match image::decode(
                    image,
                    &opts.defaults,
                    &mut m.triggers.entries,
                ) {
                    Ok(stored) => {
                        info!("config: loaded from storage");
                        #[cfg(feature = "audit")]
                        {
                            how = crate::audit::keep::Loaded::Image(crate::crc::crc32(image));
                        }
                        m.access.accounts = stored.accounts;
                        Some(stored.config)
                    }
                    Err(e) => {
                        warn!("config: stored image refused ({}), using defaults", e.as_str());
                        #[cfg(feature = "audit")]
                        {
                            how = crate::audit::keep::Loaded::Refused(e.as_str());
                        }
                        None
                    }
                },
                Err(_) => {
                    warn!("config: storage read failed, using defaults");
                    #[cfg(feature = "audit")]
                    {
                        how = crate::audit::keep::Loaded::Unreadable;
                    }
                    None
                }
            };
            let mut config = loaded.unwrap_or(opts.defaults);
            #[cfg(feature = "audit")]
            let before_recovery = config;
            if opts.recovery {
                warn!("config: recovery start: factory network and access settings for this run");
                config = config.with_network_of(&opts.defaults);
            }
            m.keeps = keeps;
            m.access.recovery = opts.recovery;
            m.access.network_managed = opts.network_managed;
            m.access.running = config.net;
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
            if let Some(o) = opts.mqtt_override {
                config = o.apply(config);
            }
            m.config.active = config;
            m.config.edit = None;
            m.plc.last_beat = now;
            #[cfg(feature = "audit")]
            crate::audit::keep::started(
                &self.hub.audit,
                &crate::audit::keep::Start {
                    boot,
                    loaded: how,
                    recovery: opts.recovery.then_some((&before_recovery, &config)),
                    triggers: &m.triggers.entries,
                    medium,
                    wall_clock: opts.wall_clock,
                },
                now,
            );
        });
    }
}

/// How a gateway's run ended when it was asked to stop
/// ([`Gateway::run_until`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stopped {
    /// Every audit record, the stop's included, was kept on the medium
    /// (or nothing is kept on this platform); `false`: the medium did not
    /// keep them within the stop's wait.
    pub kept: bool,
}

/// Runs a gateway with `opts` on `net` until `stop` gives a reason, then
/// stops in order (see [`Gateway::run_until`]).
pub async fn run_until<N: Net, C: Clock, S: Storage>(
    net: &N,
    clock: &C,
    storage: S,
    opts: Options,
    stop: impl core::future::Future<Output = &'static str>,
) -> Stopped {
    Gateway::new(opts)
        .run_until(net, clock, storage, stop)
        .await
}

/// Runs a gateway with `opts` on `net` until the future is dropped (see
/// [`Gateway::run`]).
pub async fn run<N: Net, C: Clock, S: Storage>(
    net: &N,
    clock: &C,
    storage: S,
    opts: Options,
) -> Infallible {
    Gateway::new(opts).run(net, clock, storage).await
}

/// The image of the hub's configuration and trigger table as they are.
struct Current<'a>(&'a Hub);

impl Image for Current<'_> {
    fn write(&self, out: &mut [u8]) -> Result<usize, StorageError> {
        self.0.with(|m| {
            let stored = Stored {
                config: m.config.active,
                accounts: m.access.accounts,
            };
            image::encode(&stored, &m.triggers.entries, out)
        })
    }
}

/// The storage task (here, where the hub and the storage meet, so that
/// neither imports the other): waits for save requests, has the medium write the
/// image of the configuration and trigger table as they are now, and
/// reports the result. One save at a time (the hub serializes requests).
/// With the audit log (feature `audit`) it also keeps the log's records on
/// the medium, between saves, and stamps new records with their time; with
/// updates (feature `update`) it surveys the firmware slots at start and
/// does what an upload or the trial check asks of them.
async fn storage_task<S: Storage, C: Clock>(hub: &Hub, clock: &C, storage: &mut S) -> Infallible {
    #[cfg(feature = "update")]
    survey(hub, storage).await;
    #[cfg(feature = "audit")]
    {
        use embassy_futures::select::{select, Either};
        // The stamper apart: a slow flash operation of the work does not
        // delay a record's time.
        let stamper = crate::audit::keep::stamper(&hub.audit, clock);
        match select(stamper, storage_work(hub, clock, storage)).await {
            Either::First(never) | Either::Second(never) => never,
        }
    }
    #[cfg(not(feature = "audit"))]
    storage_work(hub, clock, storage).await
}

/// What the storage task is woken for.
enum Work {
    Save,
    #[cfg(feature = "audit")]
    Keep(Option<(u32, crate::audit::page::Query)>),
    #[cfg(feature = "update")]
    Firmware(crate::update::Op),
}

/// The storage task's work: a save when asked, the log's records kept
/// between saves, the firmware slots' operations.
async fn storage_work<S: Storage, C: Clock>(hub: &Hub, clock: &C, storage: &mut S) -> Infallible {
    use embassy_futures::select::{select3, Either3};
    let _ = clock;
    loop {
        let asked = async {
            hub.save_request.wait().await;
            Work::Save
        };
        #[cfg(feature = "audit")]
        let keep = async { Work::Keep(crate::audit::keep::wait_work(&hub.audit, clock).await) };
        #[cfg(not(feature = "audit"))]
        let keep = core::future::pending::<Work>();
        #[cfg(feature = "update")]
        let slots = async { Work::Firmware(hub.updates.next().await) };
        #[cfg(not(feature = "update"))]
        let slots = core::future::pending::<Work>();
        let work = match select3(asked, keep, slots).await {
            Either3::First(w) | Either3::Second(w) | Either3::Third(w) => w,
        };
        #[cfg(feature = "audit")]
        let mut page = None;
        match work {
            Work::Save => save(hub, storage).await,
            #[cfg(feature = "audit")]
            Work::Keep(asked) => page = asked,
            #[cfg(feature = "update")]
            Work::Firmware(op) => {
                let result = firmware(hub, storage, op).await;
                hub.updates.answer(result);
            }
        }
        #[cfg(feature = "audit")]
        {
            crate::audit::keep::keep(&hub.audit, clock, storage).await;
            // After what waited was kept: the page shows it.
            if let Some((id, query)) = page {
                crate::audit::keep::page(&hub.audit, storage, id, query).await;
            }
        }
    }
}

/// How long an image on trial runs before its self-check decides: long
/// enough for the network, the engine, the Modbus sessions and the web
/// server to have started (a firmware that fails on start resets before
/// this and is rolled back by the bootloader).
#[cfg(feature = "update")]
pub const TRIAL_CHECK: embassy_time::Duration = embassy_time::Duration::from_secs(8);

/// The trial of a firmware just swapped in: after [`TRIAL_CHECK`], with
/// every part of the gateway running (this future is joined with them: a
/// part that panicked would have reset the board) and the web server
/// listening where it has a port, the image confirms itself; if its check
/// fails ([`Options::self_check_fails`]) it restarts, and the bootloader
/// rolls it back. An image not on trial does nothing here.
#[cfg(feature = "update")]
async fn trial<C: Clock>(hub: &Hub, clock: &C, opts: &Options, web_port: u16) -> Infallible {
    use crate::update::{BootState, Op};
    clock.sleep(TRIAL_CHECK).await;
    if hub.with(|m| m.firmware.boot) != Some(BootState::Trial) {
        return core::future::pending().await;
    }
    let web_up = web_port == 0 || hub.with(|m| m.access.web_on);
    if opts.self_check_fails || !web_up {
        warn!("update: the new firmware's self-check failed: restarting into the previous one");
        clock.sleep(embassy_time::Duration::from_secs(1)).await;
        #[cfg(feature = "audit")]
        crate::audit::keep::closing(&hub.audit, clock, None).await;
        match opts.restart {
            Some(restart) => restart(),
            None => warn!(
                "update: this platform cannot restart itself: the next power cycle rolls back"
            ),
        }
        return core::future::pending().await;
    }
    {
        // The mailbox for the confirmation only: released before this
        // future waits for ever (an upload needs it next).
        let _mailbox = hub.updates.take().await;
        match hub.updates.ask(Op::Confirm).await {
            Ok(()) => {
                hub.with(|m| m.firmware.boot = Some(BootState::Confirmed));
                info!("update: the new firmware passed its self-check and is confirmed");
            }
            Err(e) => warn!("update: the confirmation failed: {}", e.as_str()),
        }
    }
    core::future::pending().await
}

/// Reads the boot state and the two slots' headers into the firmware's
/// status (at start).
#[cfg(feature = "update")]
async fn survey<S: crate::update::SlotStore>(hub: &Hub, slots: &mut S) {
    use crate::update::{BootState, Slot, SlotError};
    use hans_fw_image::{Header, HEADER_LEN};
    let boot = match slots.state().await {
        Ok(boot) => boot,
        Err(SlotError::Unsupported) => return,
        Err(e) => {
            warn!("update: the boot state cannot be read: {}", e.as_str());
            return;
        }
    };
    let mut versions = [None, None];
    // The other image: after a swap the one it replaced (one page into the
    // download slot); after a rollback the one rolled back (at its start).
    let other = match boot {
        BootState::RolledBack => Slot::Dfu,
        _ => Slot::Previous,
    };
    for (slot, v) in [Slot::Active, other].into_iter().zip(versions.iter_mut()) {
        let mut head = [0u8; HEADER_LEN];
        let read = slots.read(slot, 0, &mut head).await;
        *v = read
            .ok()
            .and_then(|()| Header::parse(&head).ok())
            .map(|h| h.version);
    }
    hub.with(|m| {
        let s = &mut m.firmware;
        s.supported = true;
        s.boot = Some(boot);
        s.running = versions[0];
        s.previous = versions[1];
    });
    if let Some(v) = versions[0] {
        info!(
            "update: running firmware {}.{}.{} ({})",
            v.major,
            v.minor,
            v.patch,
            boot.as_str()
        );
    }
}

/// Does `op` on the slots.
#[cfg(feature = "update")]
#[allow(clippy::await_holding_refcell_ref)] // the piece's borrow: see `Op::Write`
async fn firmware<S: crate::update::SlotStore>(
    hub: &Hub,
    slots: &mut S,
    op: crate::update::Op,
) -> Result<(), crate::update::SlotError> {
    use crate::update::Op;
    match op {
        // The uploader waits for the answer while this holds the piece
        // (the mailbox's protocol), so the borrow is never contended; a
        // contended one would fail the write, not panic.
        Op::Write { offset, len } => {
            let Ok(piece) = hub.updates.piece.try_borrow() else {
                return Err(crate::update::SlotError::Flash);
            };
            let data = piece.get(..len).unwrap_or(&[]);
            slots.write(offset, data).await
        }
        Op::BootState => {
            let boot = slots.state().await?;
            hub.with(|m| m.firmware.boot = Some(boot));
            Ok(())
        }
        Op::MarkUpdated => slots.mark_updated().await,
        Op::Confirm => slots.confirm().await,
    }
}

/// Saves the configuration and trigger table as they are, and answers the
/// request.
async fn save<S: ConfigStore>(hub: &Hub, storage: &mut S) {
    let result = storage.save(&Current(hub)).await;
    let result = match (result, storage.medium()) {
        (Ok(()), Medium::None) => SaveOutcome::NotPersistent,
        (Ok(()), Medium::Flash | Medium::File) => SaveOutcome::Saved,
        (Err(e), _) => SaveOutcome::Failed(e),
    };
    hub.save_done.signal(result);
}
