//! Running the gateway on Linux (feature `std`): file storage, and a
//! gateway on its own thread (used by the binary, the tests and the
//! benchmark).
//!
//! The no_std logic runs on a tokio current-thread runtime: tokio supplies
//! the sockets (the [`TokioNet`] adapter) and embassy-time's std driver the
//! timers (with a generic timer queue, so embassy timers work under tokio).
//! One thread, one future: the same shape as one embassy task on a board.

extern crate std;

pub mod config_file;

use core::net::{Ipv4Addr, SocketAddrV4};
use std::io;
use std::path::PathBuf;
use std::string::String;
use std::sync::mpsc;
use std::thread;

use crate::clock::SystemClock;
use crate::gateway::{Options, RobotOverride};
use crate::net::tokio::TokioNet;
use crate::storage::{Image, NoStorage, Storage, StorageError, IMAGE_LEN};

/// Storage in a file, replaced atomically on save: the image is written to
/// `FILE.tmp` and fsynced, renamed over `FILE`, and the directory fsynced,
/// so that a power cut leaves the old file or the new one. The file work
/// runs on tokio's blocking pool: the gateway's thread goes on serving
/// while the disk syncs.
pub struct FileStorage {
    path: PathBuf,
    data: std::vec::Vec<u8>,
}

impl FileStorage {
    /// Storage at `path` (created on the first save).
    pub fn new(path: impl Into<PathBuf>) -> Self {
        FileStorage {
            path: path.into(),
            data: std::vec::Vec::new(),
        }
    }

    /// Writes `image` to the file, durably (see the type's documentation).
    pub fn write_durably(path: &std::path::Path, image: &[u8]) -> io::Result<()> {
        use std::io::Write;
        let mut tmp = std::ffi::OsString::from(path.as_os_str());
        tmp.push(".tmp");
        let tmp = PathBuf::from(tmp);
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(image)?;
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

impl Storage for FileStorage {
    async fn load(&mut self) -> Result<&[u8], StorageError> {
        self.data = match std::fs::read(&self.path) {
            Ok(data) => data,
            Err(e) if e.kind() == io::ErrorKind::NotFound => std::vec::Vec::new(),
            Err(_) => return Err(StorageError::Io),
        };
        Ok(&self.data)
    }

    async fn save(&mut self, image: &dyn Image) -> Result<(), StorageError> {
        let path = self.path.clone();
        let mut buf = std::vec![0u8; IMAGE_LEN];
        let n = image.write(&mut buf)?;
        buf.truncate(n);
        let image = buf;
        let done = tokio::task::spawn_blocking(move || FileStorage::write_durably(&path, &image));
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
    /// Storage file; `None` keeps the configuration in RAM.
    pub config_file: Option<PathBuf>,
    /// Configuration used when storage holds none.
    pub defaults: crate::Config,
}

impl HostOptions {
    /// Modbus on `modbus_listen`, robot at `robot`, configuration in RAM.
    pub fn new(modbus_listen: SocketAddrV4, robot: SocketAddrV4) -> Self {
        HostOptions {
            modbus_listen,
            robot: Some(robot),
            robot_listen: None,
            config_file: None,
            defaults: crate::Config::default(),
        }
    }
}

/// A gateway running on its own thread. Dropping it stops it (sockets
/// closed, thread joined).
pub struct RunningGateway {
    modbus: SocketAddrV4,
    robot_listen: Option<SocketAddrV4>,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<thread::JoinHandle<()>>,
}

impl RunningGateway {
    /// Starts a gateway; returns once its ports are bound.
    pub fn start(opts: HostOptions) -> io::Result<RunningGateway> {
        let (ready_tx, ready_rx) =
            mpsc::channel::<io::Result<(SocketAddrV4, Option<SocketAddrV4>)>>();
        let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
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
                        return;
                    }
                };
                rt.block_on(serve(opts, ready_tx, stop_rx));
            })?;
        match ready_rx.recv() {
            Ok(Ok((modbus, robot_listen))) => Ok(RunningGateway {
                modbus,
                robot_listen,
                stop: Some(stop_tx),
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
        self.modbus
    }

    /// Where the gateway listens for the robot (listen mode).
    pub fn robot_listen_addr(&self) -> Option<SocketAddrV4> {
        self.robot_listen
    }

    /// Stops the gateway and waits for its thread.
    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        if let Some(tx) = self.stop.take() {
            let _ = tx.send(());
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for RunningGateway {
    fn drop(&mut self) {
        self.shutdown();
    }
}

type Ready = mpsc::Sender<io::Result<(SocketAddrV4, Option<SocketAddrV4>)>>;

async fn serve(opts: HostOptions, ready: Ready, stop: tokio::sync::oneshot::Receiver<()>) {
    let bind_ip = opts
        .robot_listen
        .map(|a| *a.ip())
        .unwrap_or(Ipv4Addr::LOCALHOST);
    let net = TokioNet::new(bind_ip);
    let bound = async {
        let mport = net.listen(opts.modbus_listen).await?;
        let robot = match opts.robot_listen {
            Some(a) => Some(SocketAddrV4::new(*a.ip(), net.listen(a).await?)),
            None => None,
        };
        io::Result::Ok((SocketAddrV4::new(*opts.modbus_listen.ip(), mport), robot))
    }
    .await;
    let (modbus, robot) = match bound {
        Ok(b) => b,
        Err(e) => {
            let _ = ready.send(Err(e));
            return;
        }
    };
    let options = Options {
        modbus_port: modbus.port(),
        defaults: opts.defaults,
        robot_override: match (robot, opts.robot) {
            (Some(l), _) => Some(RobotOverride::Listen(l.port())),
            (None, Some(a)) => Some(RobotOverride::Connect(*a.ip(), a.port())),
            (None, None) => None,
        },
        recovery: false,
        network_managed: false,
        seed: os_seed(),
    };
    let _ = ready.send(Ok((modbus, robot)));
    let clock = SystemClock;
    match &opts.config_file {
        Some(p) => {
            let storage = FileStorage::new(p.clone());
            tokio::select! {
                _ = crate::gateway::run(&net, &clock, storage, options) => {}
                _ = stop => {}
            }
        }
        None => {
            let storage = NoStorage;
            tokio::select! {
                _ = crate::gateway::run(&net, &clock, storage, options) => {}
                _ = stop => {}
            }
        }
    }
}

/// 32 bytes from the operating system's random source (`/dev/urandom`),
/// the seed of web session tokens and password salts. Should it be
/// unreadable, the time and the process id are used, with a warning:
/// tokens are then guessable by someone who knows when the gateway started.
pub fn os_seed() -> [u8; 32] {
    use std::io::Read;
    let mut seed = [0u8; 32];
    let read = std::fs::File::open("/dev/urandom").and_then(|mut f| f.read_exact(&mut seed));
    if read.is_err() {
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
