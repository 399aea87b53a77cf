//! Running the gateway on Linux (feature `std`): file storage, and a
//! gateway on its own thread (used by the binary, the tests and the
//! benchmark).
//!
//! The no_std logic runs on a tokio current-thread runtime: tokio supplies
//! the sockets (the [`TokioNet`] adapter) and embassy-time's std driver the
//! timers (with a generic timer queue, so embassy timers work under tokio).
//! One thread, one future: the same shape as one embassy task on a board.

extern crate std;

use core::net::{Ipv4Addr, SocketAddrV4};
use std::io;
use std::path::PathBuf;
use std::string::String;
use std::sync::mpsc;
use std::thread;

use crate::config::{RamStorage, Storage, StorageError};
use crate::gateway::{Options, RobotOverride};
use crate::net::tokio::TokioNet;

/// Storage in a file, replaced atomically on save (write, then rename).
pub struct FileStorage {
    path: PathBuf,
}

impl FileStorage {
    /// Storage at `path` (created on the first save).
    pub fn new(path: impl Into<PathBuf>) -> Self {
        FileStorage { path: path.into() }
    }
}

impl Storage for FileStorage {
    fn load(&mut self, buf: &mut [u8]) -> Result<usize, StorageError> {
        match std::fs::read(&self.path) {
            Ok(data) => {
                let dst = buf.get_mut(..data.len()).ok_or(StorageError::TooLarge)?;
                dst.copy_from_slice(&data);
                Ok(data.len())
            }
            Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(0),
            Err(_) => Err(StorageError::Io),
        }
    }

    fn save(&mut self, image: &[u8]) -> Result<(), StorageError> {
        let mut tmp = self.path.clone().into_os_string();
        tmp.push(".tmp");
        std::fs::write(&tmp, image).map_err(|_| StorageError::Io)?;
        std::fs::rename(&tmp, &self.path).map_err(|_| StorageError::Io)
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
    };
    let mut file;
    let mut ram;
    let storage: &mut dyn Storage = match &opts.config_file {
        Some(p) => {
            file = FileStorage::new(p.clone());
            &mut file
        }
        None => {
            ram = RamStorage::new();
            &mut ram
        }
    };
    let _ = ready.send(Ok((modbus, robot)));
    tokio::select! {
        _ = crate::gateway::run(&net, storage, options) => {}
        _ = stop => {}
    }
}
