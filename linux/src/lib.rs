//! # hans-gateway-linux
//!
//! The gateway (`hans-gateway`, a `no_std` crate) on Linux: the platform
//! it runs on here, as the boards' crates (`firmware/`) are the platform
//! on a microcontroller, and the `hans-gateway` binary.
//!
//! | module | what |
//! |---|---|
//! | [`net`] | the socket interface over tokio (listeners bound ahead, TLS connections) |
//! | `tls` | the TLS servers (the page over HTTPS, Modbus/TCP Security and its role extension) and the broker's TLS client |
//! | [`config_file`] | the configuration as a TOML file people edit (read, checked with line and column, written) |
//! | [`audit_file`] | the audit log's file beside it, with rotation |
//! | this page | [`FileStorage`], and [`RunningGateway`]: a gateway on its own thread (the binary, the tests, the benchmarks) |
//!
//! The no_std logic runs on a tokio current-thread runtime: tokio supplies
//! the sockets ([`net::TokioNet`]) and embassy-time's std driver the
//! timers (with a generic timer queue, so embassy timers work under tokio).
//! One thread, one future: the same shape as one embassy task on a board.

// The gateway is one future of nested futures: computing its layout needs
// more depth than the default 128.
#![recursion_limit = "256"]

pub mod audit_file;
pub mod config_file;
pub mod mqtt;
pub mod net;
mod tls;
mod waker;

use core::fmt;
use core::net::{Ipv4Addr, SocketAddrV4};
use std::io;
use std::path::PathBuf;
use std::string::{String, ToString};
use std::sync::{mpsc, Arc, Mutex};
use std::thread;

use hans_gateway::config::HostName;
use hans_gateway::state::inputs::{Text, TRIGGERS};
use hans_gateway::storage::image::{self, Entries};
use hans_gateway::storage::{Image, IMAGE_LEN};
use hans_gateway::{
    AuditStore, Config, ConfigStore, Medium, MqttOverride, NoSlots, NoStorage, Options,
    RobotOverride, SetupCode, Stopped, StorageError, SystemClock, WithAudit, WithSlots,
};

use crate::net::TokioNet;
use config_file::{Contents, Format};

/// Storage in a TOML file that people may edit ([`config_file`]): read at
/// start, replaced atomically on save: the text is written to `FILE.tmp`
/// and fsynced, renamed over `FILE`, and the directory fsynced, so that a
/// power cut leaves the old file or the new one. The file work runs on
/// tokio's blocking pool: the gateway's thread goes on serving while the
/// disk syncs.
///
/// To the gateway it is a storage of binary images like the others: a
/// load turns the file into the image that [`image::decode`] reads (one
/// start-up path on every target), a save turns the image back into TOML.
/// A file that does not exist holds nothing (the defaults are used); the
/// binary image an older version wrote is read, and replaced by TOML at
/// the next save. A file that is refused makes the load fail (and the
/// gateway start with its defaults, saying so in the log): check it first
/// with [`config_file::read_file`], as [`RunningGateway::start`] and the
/// binary do, to refuse to start on it.
pub struct FileStorage {
    path: PathBuf,
    defaults: Config,
    data: std::vec::Vec<u8>,
}

impl FileStorage {
    /// Storage at `path` (created on the first save); settings the file
    /// leaves out take their factory defaults.
    pub fn new(path: impl Into<PathBuf>) -> Self {
        FileStorage::with_defaults(path, Config::DEFAULT)
    }

    /// Storage at `path`; settings the file leaves out take their value
    /// in `defaults`.
    pub fn with_defaults(path: impl Into<PathBuf>, defaults: Config) -> Self {
        FileStorage {
            path: path.into(),
            defaults,
            data: std::vec::Vec::new(),
        }
    }

    /// Writes `bytes` to the file, durably (see the type's documentation),
    /// readable and writable by its owner only (mode 0600): the file may
    /// hold password hashes. The temporary file is created anew with that
    /// mode (one left over by a crash is removed first), and the rename
    /// puts it in place of the old file, so an existing file with looser
    /// permissions has 0600 after the write.
    pub fn write_durably(path: &std::path::Path, bytes: &[u8]) -> io::Result<()> {
        use std::io::Write;
        let mut tmp = std::ffi::OsString::from(path.as_os_str());
        tmp.push(".tmp");
        let tmp = PathBuf::from(tmp);
        match std::fs::remove_file(&tmp) {
            Err(e) if e.kind() != io::ErrorKind::NotFound => return Err(e),
            _ => {}
        }
        let mut f = create_private(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        drop(f);
        std::fs::rename(&tmp, path)?;
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => std::path::Path::new("."),
        };
        std::fs::File::open(dir)?.sync_all()
    }
}

/// Creates `path`, which must not exist (a symbolic link there is not
/// followed), for writing, readable and writable by its owner only: the
/// mode is set at creation, so the contents are never readable by others.
fn create_private(path: &std::path::Path) -> io::Result<std::fs::File> {
    let mut options = std::fs::OpenOptions::new();
    options.write(true).create_new(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o600);
    options.open(path)
}

impl ConfigStore for FileStorage {
    fn medium(&self) -> Medium {
        Medium::File
    }

    async fn load(&mut self) -> Result<&[u8], StorageError> {
        let (contents, format) = match config_file::read_file(&self.path, &self.defaults) {
            Ok(Some(read)) => read,
            Ok(None) => {
                self.data.clear();
                return Ok(&self.data);
            }
            Err(e) => {
                for line in e.to_string().lines() {
                    log::error!("config: {line}");
                }
                return Err(StorageError::Io);
            }
        };
        if format == Format::BinaryImage {
            log::info!(
                "config: {} holds the binary image of an older version; the next save writes it as TOML",
                self.path.display()
            );
        }
        self.data.resize(IMAGE_LEN, 0);
        let n = image::encode(&contents.stored, &contents.triggers, &mut self.data)?;
        self.data.truncate(n);
        Ok(&self.data)
    }

    async fn save(&mut self, image: &dyn Image) -> Result<(), StorageError> {
        let path = self.path.clone();
        let mut buf = std::vec![0u8; IMAGE_LEN];
        let n = image.write(&mut buf)?;
        let mut triggers: Entries = [Text::EMPTY; TRIGGERS];
        let bytes = buf.get(..n).unwrap_or(&[]);
        let stored = image::decode(bytes, &self.defaults, &mut triggers).map_err(|e| {
            log::error!("config: the image to save is refused: {}", e.as_str());
            StorageError::Io
        })?;
        let text = config_file::render(&Contents { stored, triggers });
        let done =
            tokio::task::spawn_blocking(move || FileStorage::write_durably(&path, text.as_bytes()));
        match done.await {
            Ok(Ok(())) => Ok(()),
            Ok(Err(e)) => {
                log::warn!("config: cannot write {}: {e}", self.path.display());
                Err(StorageError::Io)
            }
            Err(_) => Err(StorageError::Io),
        }
    }
}

/// How to start a host gateway.
#[derive(Clone, Debug)]
pub struct HostOptions {
    /// Modbus listen address (port 0 = any free port).
    pub modbus_listen: SocketAddrV4,
    /// Connect to the robot here (overrides the stored configuration).
    pub robot: Option<SocketAddrV4>,
    /// Listen for the robot here instead (port 0 = any free port).
    pub robot_listen: Option<SocketAddrV4>,
    /// Configuration file ([`FileStorage`], checked at start); `None`
    /// keeps the configuration in RAM.
    pub config_file: Option<PathBuf>,
    /// Configuration used when storage holds none.
    pub defaults: hans_gateway::Config,
    /// Serve the web page here (port 0 = any free port); `None`: no page.
    pub web_listen: Option<SocketAddrV4>,
    /// The one-time code for creating the first administrator
    /// ([`Options::setup_code`]); the caller shows it where only someone
    /// at the machine reads it (`hans-gateway` makes a new one at each
    /// start, from [`os_random`]). `None`: no administrator can be created.
    pub setup_code: Option<SetupCode>,
    /// The MQTT broker given at start (`--mqtt`): [`Options::mqtt_override`].
    pub mqtt: Option<MqttOverride>,
    /// The machine's name ([`Options::node_name`]).
    pub node_name: HostName,
    /// The CAs (PEM file) a TLS broker must be signed by; `None`: the
    /// system's bundle.
    pub mqtt_ca: Option<PathBuf>,
    /// The broker's user name and password ([`Options::mqtt_login`]).
    pub mqtt_login: Option<hans_gateway::mqtt::Login>,
    /// Serve the web page over HTTPS with this certificate and key
    /// (`--web-tls`); `None`: plain HTTP.
    pub web_tls: Option<TlsIdentity>,
    /// Serve Modbus/TCP Security too (`--modbus-tls-listen`); `None`:
    /// plain Modbus TCP only.
    pub modbus_tls: Option<ModbusTls>,
    /// Where the EtherNet/IP adapter listens (`--enip-listen`), served
    /// while `enip.enabled` is on; `None`: not served.
    pub enip: Option<EnipListen>,
}

/// Where the EtherNet/IP adapter listens: the encapsulation protocol on
/// TCP and UDP `listen` (44818 is the standard; port 0 picks a free one,
/// the same for both), class 1 I/O on UDP `io_port` of the same address
/// (2222 is the standard, and what a Logix scanner sends to; 0 picks one).
#[derive(Clone, Copy, Debug)]
pub struct EnipListen {
    /// The encapsulation address (TCP and UDP).
    pub listen: SocketAddrV4,
    /// The class 1 I/O port (UDP).
    pub io_port: u16,
}

/// A TLS server's certificate (chain) and private key, PEM files.
#[derive(Clone, Debug)]
pub struct TlsIdentity {
    /// The certificate, then the CAs up to the root's child (PEM).
    pub cert: PathBuf,
    /// Its private key (PEM: PKCS#8, SEC1 or PKCS#1).
    pub key: PathBuf,
}

/// Modbus/TCP Security (TLS with client certificates, the client's role
/// from its certificate's role extension; see the README): served beside
/// the plain Modbus server, sharing its sessions and allow-list.
#[derive(Clone, Debug)]
pub struct ModbusTls {
    /// Where to listen (port 0 = any free port; the standard is 802).
    pub listen: SocketAddrV4,
    /// The server's certificate and key.
    pub identity: TlsIdentity,
    /// The CAs (PEM) a client's certificate must be signed by.
    pub client_ca: PathBuf,
}

impl HostOptions {
    /// Modbus on `modbus_listen`, robot at `robot`, configuration in RAM.
    pub fn new(modbus_listen: SocketAddrV4, robot: SocketAddrV4) -> Self {
        HostOptions {
            modbus_listen,
            robot: Some(robot),
            robot_listen: None,
            config_file: None,
            defaults: hans_gateway::Config::default(),
            web_listen: None,
            setup_code: None,
            mqtt: None,
            node_name: Options::default().node_name,
            mqtt_ca: None,
            mqtt_login: None,
            web_tls: None,
            modbus_tls: None,
            enip: None,
        }
    }
}

/// The addresses a started gateway listens on.
#[derive(Clone, Copy, Debug)]
struct Bound {
    modbus: SocketAddrV4,
    robot_listen: Option<SocketAddrV4>,
    web: Option<SocketAddrV4>,
    /// Modbus/TCP Security's listener.
    modbus_tls: Option<SocketAddrV4>,
    /// The EtherNet/IP adapter's encapsulation address and I/O port.
    enip: Option<(SocketAddrV4, u16)>,
}

/// A gateway running on its own thread. Dropping it stops it, in order
/// (as [`Stopper::stop`]; its sockets closed, its thread joined).
pub struct RunningGateway {
    bound: Bound,
    stop: Stopper,
    thread: Option<thread::JoinHandle<Option<Stopped>>>,
}

/// Asks a [`RunningGateway`] to stop, from any thread (`hans-gateway`'s
/// signal thread). Cloned, each clone asks the same gateway; the first
/// request counts.
#[derive(Clone)]
pub struct Stopper(Arc<Mutex<Option<tokio::sync::oneshot::Sender<&'static str>>>>);

impl Stopper {
    /// Asks the gateway to stop for `why` (the audit log's `stop` record
    /// says it): it records the stop, keeps what its audit log's counting
    /// periods counted, and ends (see `hans_gateway::Gateway::run_until`).
    /// Returns at once; [`RunningGateway::wait`] returns when it is done.
    pub fn stop(&self, why: &'static str) {
        let tx = match self.0.lock() {
            Ok(mut g) => g.take(),
            Err(poisoned) => poisoned.into_inner().take(),
        };
        if let Some(tx) = tx {
            let _ = tx.send(why);
        }
    }
}

impl RunningGateway {
    /// Starts a gateway; returns once its ports are bound. A configuration
    /// file that is refused ([`config_file::read_file`]) is an error of
    /// kind `InvalidData` (its text: one `FILE:LINE:COLUMN: reason` per
    /// line), and nothing is started.
    pub fn start(opts: HostOptions) -> io::Result<RunningGateway> {
        if let Some(path) = &opts.config_file {
            config_file::read_file(path, &opts.defaults)
                .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e.to_string()))?;
        }
        let (ready_tx, ready_rx) = mpsc::channel::<io::Result<Bound>>();
        let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<&'static str>();
        let thread = thread::Builder::new()
            .name(String::from("hans-gateway"))
            .stack_size(8 << 20)
            .spawn(move || {
                let rt = match tokio::runtime::Builder::new_current_thread()
                    .enable_all()
                    .build()
                {
                    Ok(rt) => rt,
                    Err(e) => {
                        let _ = ready_tx.send(Err(e));
                        return None;
                    }
                };
                rt.block_on(serve(opts, ready_tx, stop_rx))
            })?;
        match ready_rx.recv() {
            Ok(Ok(bound)) => Ok(RunningGateway {
                bound,
                stop: Stopper(Arc::new(Mutex::new(Some(stop_tx)))),
                thread: Some(thread),
            }),
            Ok(Err(e)) => {
                let _ = thread.join();
                Err(e)
            }
            Err(_) => {
                let _ = thread.join();
                Err(io::Error::other("gateway thread ended before starting"))
            }
        }
    }

    /// Where the Modbus server listens.
    pub fn modbus_addr(&self) -> SocketAddrV4 {
        self.bound.modbus
    }

    /// Where the gateway listens for the robot (listen mode).
    pub fn robot_listen_addr(&self) -> Option<SocketAddrV4> {
        self.bound.robot_listen
    }

    /// Where the web page is served.
    pub fn web_addr(&self) -> Option<SocketAddrV4> {
        self.bound.web
    }

    /// Where Modbus/TCP Security is served.
    pub fn modbus_tls_addr(&self) -> Option<SocketAddrV4> {
        self.bound.modbus_tls
    }

    /// Where the EtherNet/IP adapter listens (TCP and UDP), and its class 1
    /// I/O port (UDP, same address), if `--enip-listen` was given (it
    /// answers only while `enip.enabled` is on).
    pub fn enip_addr(&self) -> Option<(SocketAddrV4, u16)> {
        self.bound.enip
    }

    /// Blocks until the gateway ends: `Ok` when it stopped on request
    /// ([`Self::stopper`]), else it failed: its thread panicked (a bug, or
    /// the system refused it something it cannot do without, such as a
    /// thread for the file work of a save). The error says why. Its sockets are closed then and nothing is
    /// served any more: a process that runs the gateway should exit with a
    /// failure status, so that a supervisor restarts it (`hans-gateway`
    /// exits with status 101).
    pub fn wait(mut self) -> io::Result<Stopped> {
        // `self.stop` stays alive while joining: dropping it would stop
        // the gateway.
        let why = match self.thread.take().map(|t| t.join()) {
            Some(Ok(Some(stopped))) => return Ok(stopped),
            None | Some(Ok(None)) => String::from("the gateway's thread ended"),
            Some(Err(panic)) => {
                let message = panic
                    .downcast_ref::<&str>()
                    .copied()
                    .or_else(|| panic.downcast_ref::<String>().map(String::as_str))
                    .unwrap_or("(no message)");
                std::format!("the gateway's thread panicked: {message}")
            }
        };
        Err(io::Error::other(why))
    }

    /// What asks this gateway to stop, from another thread.
    pub fn stopper(&self) -> Stopper {
        self.stop.clone()
    }

    /// Stops the gateway in order and waits for its thread: how it ended
    /// (`None`: it had failed before).
    pub fn stop(mut self) -> Option<Stopped> {
        self.shutdown()
    }

    fn shutdown(&mut self) -> Option<Stopped> {
        self.stop.stop("stopped by its program");
        self.thread.take().and_then(|t| t.join().ok().flatten())
    }
}

impl Drop for RunningGateway {
    fn drop(&mut self) {
        let _ = self.shutdown();
    }
}

type Ready = mpsc::Sender<io::Result<Bound>>;

async fn serve(
    opts: HostOptions,
    ready: Ready,
    stop: tokio::sync::oneshot::Receiver<&'static str>,
) -> Option<Stopped> {
    let bind_ip = opts
        .robot_listen
        .map(|a| *a.ip())
        .unwrap_or(Ipv4Addr::LOCALHOST);
    let net = TokioNet::new(bind_ip);
    let net = match &opts.mqtt_ca {
        Some(ca) => net.with_tls_ca(ca.clone()),
        None => net,
    };
    let bound = async {
        let at = |listener: Listener, addr: SocketAddrV4| {
            move |error: io::Error| ListenError::io(listener, addr, error)
        };
        let mport = net
            .listen(opts.modbus_listen)
            .await
            .map_err(at(Listener::Modbus, opts.modbus_listen))?;
        let robot = match opts.robot_listen {
            Some(a) => Some(SocketAddrV4::new(
                *a.ip(),
                net.listen(a).await.map_err(at(Listener::Robot, a))?,
            )),
            None => None,
        };
        let web = match opts.web_listen {
            Some(a) => Some(SocketAddrV4::new(
                *a.ip(),
                listen_web(&net, a, &opts).await?,
            )),
            None => None,
        };
        let modbus_tls = match &opts.modbus_tls {
            Some(m) => {
                let server =
                    crate::tls::TlsServer::modbus(&m.identity.cert, &m.identity.key, &m.client_ca)?;
                let port = net
                    .listen_tls_beside(mport, m.listen, server)
                    .await
                    .map_err(at(Listener::ModbusTls, m.listen))?;
                Some(SocketAddrV4::new(*m.listen.ip(), port))
            }
            None => None,
        };
        let enip = match opts.enip {
            Some(e) => {
                // TCP first (port 0 picks one), then UDP on the same port.
                let port = net.listen(e.listen).await?;
                let at = SocketAddrV4::new(*e.listen.ip(), port);
                net.listen_udp(at)?;
                let io = net.listen_udp(SocketAddrV4::new(*e.listen.ip(), e.io_port))?;
                Some((at, io))
            }
            None => None,
        };
        io::Result::Ok(Bound {
            modbus: SocketAddrV4::new(*opts.modbus_listen.ip(), mport),
            robot_listen: robot,
            web,
            modbus_tls,
            enip,
        })
    }
    .await;
    let bound = match bound {
        Ok(b) => b,
        Err(e) => {
            let _ = ready.send(Err(e));
            return None;
        }
    };
    let options = Options {
        modbus_port: bound.modbus.port(),
        defaults: opts.defaults,
        robot_override: match (bound.robot_listen, opts.robot) {
            (Some(l), _) => Some(RobotOverride::Listen(l.port())),
            (None, Some(a)) => Some(RobotOverride::Connect(*a.ip(), a.port())),
            (None, None) => None,
        },
        recovery: false,
        network_managed: false,
        seed: os_seed(),
        web_port: bound.web.map_or(0, |w| w.port()),
        restart: None,
        setup_code: opts.setup_code,
        wall_clock: Some(audit_file::unix_now),
        node_name: opts.node_name,
        mqtt_override: opts.mqtt,
        mqtt_login: opts.mqtt_login,
        // Linux installs no firmware image: its package does.
        update_key: None,
        board: "linux",
        self_check_fails: false,
        // This program's version (its Debian package's): what Sparkplug's
        // Gateway/Version shows.
        version: env!("CARGO_PKG_VERSION"),
        enip: bound
            .enip
            .map(|(at, io_port)| hans_gateway::enip::EnipOptions {
                port: at.port(),
                io_port,
                serial: machine_serial(),
                ip: *at.ip(),
                ..hans_gateway::enip::EnipOptions::default()
            }),
    };
    let _ = ready.send(Ok(bound));
    let clock = SystemClock;
    // The configuration file and the audit file beside it, or nothing;
    // Linux has no firmware slots (its package updates it).
    let storage = match &opts.config_file {
        Some(p) => Files::Kept(Box::new(WithAudit {
            config: FileStorage::with_defaults(p.clone(), opts.defaults),
            audit: audit_file::AuditFile::beside(p),
        })),
        None => Files::None(NoStorage),
    };
    let storage = WithSlots {
        storage,
        slots: NoSlots,
    };
    // A stop request (or its sender dropped with the RunningGateway) ends
    // the run in order: the audit log's last records are kept first.
    let stop = async { stop.await.unwrap_or("stopped by its program") };
    let run = hans_gateway::run_until(&net, &clock, storage, options, stop);
    Some(waker::steady_waker(run).await)
}

/// Where a Linux gateway keeps its things: the files of `--config`, or
/// nothing.
enum Files {
    Kept(Box<WithAudit<FileStorage, audit_file::AuditFile>>),
    None(NoStorage),
}

impl ConfigStore for Files {
    async fn load(&mut self) -> Result<&[u8], StorageError> {
        match self {
            Files::Kept(f) => f.load().await,
            Files::None(n) => n.load().await,
        }
    }
    async fn save(&mut self, image: &dyn Image) -> Result<(), StorageError> {
        match self {
            Files::Kept(f) => f.save(image).await,
            Files::None(n) => n.save(image).await,
        }
    }
    fn medium(&self) -> Medium {
        match self {
            Files::Kept(f) => f.medium(),
            Files::None(n) => n.medium(),
        }
    }
}

impl AuditStore for Files {
    async fn read(&mut self, each: &mut dyn FnMut(&[u8])) -> Result<(), StorageError> {
        match self {
            Files::Kept(f) => f.read(each).await,
            Files::None(n) => n.read(each).await,
        }
    }
    async fn append(&mut self, record: &[u8]) -> Result<(), StorageError> {
        match self {
            Files::Kept(f) => f.append(record).await,
            Files::None(n) => n.append(record).await,
        }
    }
    fn persistent(&self) -> bool {
        match self {
            Files::Kept(f) => f.persistent(),
            Files::None(n) => n.persistent(),
        }
    }
}

/// Binds the web page's `addr`: for HTTPS with `--web-tls`.
async fn listen_web(net: &TokioNet, addr: SocketAddrV4, opts: &HostOptions) -> io::Result<u16> {
    let at = |error| ListenError::io(Listener::Web, addr, error);
    if let Some(id) = &opts.web_tls {
        let server = crate::tls::TlsServer::web(&id.cert, &id.key)?;
        return net.listen_tls(addr, server).await.map_err(at);
    }
    net.listen(addr).await.map_err(at)
}

/// A listener of the gateway (for the error that says which one could not
/// listen).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Listener {
    /// The Modbus TCP server (`--modbus-listen`).
    Modbus,
    /// The robot's listener in listen mode (`--robot-listen`).
    Robot,
    /// The web page (`--web-listen`).
    Web,
    /// Modbus/TCP Security (`--modbus-tls-listen`).
    ModbusTls,
}

impl Listener {
    /// The command-line option that gives its address.
    pub fn option(self) -> &'static str {
        match self {
            Listener::Modbus => "--modbus-listen",
            Listener::Robot => "--robot-listen",
            Listener::Web => "--web-listen",
            Listener::ModbusTls => "--modbus-tls-listen",
        }
    }

    /// What it serves, in words.
    pub fn what(self) -> &'static str {
        match self {
            Listener::Modbus => "the Modbus TCP server",
            Listener::Robot => "the robot's connection",
            Listener::Web => "the web page",
            Listener::ModbusTls => "Modbus/TCP Security",
        }
    }
}

/// A listener could not listen on its address (the start's error, as an
/// [`io::Error`] of the same kind whose text says which listener, where,
/// why, and what usually helps):
/// `--modbus-listen 127.0.0.1:502: the Modbus TCP server cannot listen
/// there: Address already in use (os error 98): another program listens on
/// that port (or this gateway runs already): stop it or choose another`.
#[derive(Debug)]
pub struct ListenError {
    /// Which listener.
    pub listener: Listener,
    /// The address it was to listen on.
    pub addr: SocketAddrV4,
    /// The operating system's error.
    pub error: io::Error,
}

impl ListenError {
    /// `error` of `listener` on `addr`, as an [`io::Error`] of its kind.
    fn io(listener: Listener, addr: SocketAddrV4, error: io::Error) -> io::Error {
        io::Error::new(
            error.kind(),
            ListenError {
                listener,
                addr,
                error,
            },
        )
    }
}

impl fmt::Display for ListenError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let hint = match self.error.kind() {
            io::ErrorKind::AddrInUse => {
                ": another program listens on that port (or this gateway runs already): \
                 stop it or choose another port"
            }
            io::ErrorKind::PermissionDenied => {
                ": ports below 1024 need root or the capability CAP_NET_BIND_SERVICE \
                 (the systemd unit gives it)"
            }
            io::ErrorKind::AddrNotAvailable => {
                ": this machine has no such address (0.0.0.0 listens on all of them)"
            }
            _ => "",
        };
        write!(
            f,
            "{} {}: {} cannot listen there: {}{hint}",
            self.listener.option(),
            self.addr,
            self.listener.what(),
            self.error
        )
    }
}

impl std::error::Error for ListenError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        Some(&self.error)
    }
}

/// Fills `buf` from the operating system's random source (`/dev/urandom`).
pub fn os_random(buf: &mut [u8]) -> io::Result<()> {
    use std::io::Read;
    std::fs::File::open("/dev/urandom").and_then(|mut f| f.read_exact(buf))
}

/// The EtherNet/IP Identity's serial number on Linux: stable for the
/// machine (FNV-1a of `/etc/machine-id`), 1 where there is none.
fn machine_serial() -> u32 {
    match std::fs::read("/etc/machine-id") {
        Ok(id) => id.iter().fold(0x811c_9dc5u32, |h, &b| {
            (h ^ u32::from(b)).wrapping_mul(0x0100_0193)
        }),
        Err(_) => 1,
    }
}

/// 32 bytes from the operating system's random source ([`os_random`]),
/// the seed of web session tokens and password salts. Should it be
/// unreadable, the time and the process id are used, with a warning:
/// tokens are then guessable by someone who knows when the gateway started.
pub fn os_seed() -> [u8; 32] {
    let mut seed = [0u8; 32];
    if os_random(&mut seed).is_err() {
        log::warn!("no /dev/urandom: web session tokens are seeded from the clock");
        let t = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_nanos())
            .unwrap_or(0);
        seed[..16].copy_from_slice(&t.to_le_bytes());
        seed[16..20].copy_from_slice(&std::process::id().to_le_bytes());
    }
    seed
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;
    use std::path::Path;
    use std::vec::Vec;

    /// An image given as bytes.
    struct Bytes(Vec<u8>);

    impl Image for Bytes {
        fn write(&self, out: &mut [u8]) -> Result<usize, StorageError> {
            let n = self.0.len();
            out.get_mut(..n)
                .ok_or(StorageError::TooLarge)?
                .copy_from_slice(&self.0);
            Ok(n)
        }
    }

    fn mode(path: &Path) -> u32 {
        std::fs::metadata(path)
            .expect("the file")
            .permissions()
            .mode()
            & 0o777
    }

    fn set_mode(path: &Path, mode: u32) {
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode)).expect("chmod");
    }

    /// A fresh directory in the temporary directory, removed when dropped.
    struct TempDir(PathBuf);

    impl TempDir {
        fn new(name: &str) -> TempDir {
            let nanos = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.as_nanos())
                .unwrap_or(0);
            let dir = std::env::temp_dir().join(std::format!(
                "hans-gw-host-{}-{nanos}-{name}",
                std::process::id()
            ));
            std::fs::create_dir(&dir).expect("a temporary directory");
            TempDir(dir)
        }
    }

    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    /// The "secure by default" issue: the configuration file holds password
    /// hashes, and was created with the process's umask (0644: readable by
    /// every local user), and a rewrite kept it so. A save creates it 0600,
    /// and leaves an existing 0644 file 0600, also over a leftover
    /// temporary file that was 0644.
    #[test]
    fn a_saved_configuration_file_is_readable_by_its_owner_only() {
        let dir = TempDir::new("mode");
        let old = dir.0.join("old.toml");
        std::fs::write(&old, "[link]\npoll_ms = 40\n").expect("write the file");
        set_mode(&old, 0o644);
        let leftover = dir.0.join("old.toml.tmp");
        std::fs::write(&leftover, "left by a crash").expect("write the leftover");
        set_mode(&leftover, 0o644);
        let new = dir.0.join("new.toml");
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .expect("runtime");
        rt.block_on(async {
            let mut storage = FileStorage::new(&old);
            let image = Bytes(storage.load().await.expect("load").to_vec());
            storage.save(&image).await.expect("save over the old file");
            FileStorage::new(&new)
                .save(&image)
                .await
                .expect("save a new file");
        });
        for path in [&old, &new] {
            assert_eq!(mode(path), 0o600, "{}", path.display());
            let text = std::fs::read_to_string(path).expect("read back");
            assert!(text.contains("\npoll_ms = 40\n"), "{text}");
        }
        assert!(!leftover.exists(), "renamed into place");
    }
}
