//! # hans-sim: a simulated Hans / Huayan (Elfin) robot controller
//!
//! It listens where a controller listens — the command port (10003), the
//! JSON DataSheet ports (10004-10006, 20/10/5 Hz) and the fast command port
//! (10001) — answers the 139 commands of HR-TCP V1.0.0.3 and the 74 of the
//! V6 document with the codec (`hans-codec`) on both sides, at the protocol
//! level it is given ([`Config::protocol`]), and behaves like a controller
//! where a client can tell: the FSM of the bring-up, motion that takes time
//! with the document's flags, jogging kept alive by `LongMoveEvent`,
//! kinematics consistent with the documents' examples, I/O that reads back,
//! one message at a time. Faults can be injected for tests.
//!
//! ## Library use (tokio)
//! ```no_run
//! # async fn demo() -> std::io::Result<()> {
//! use std::time::Duration;
//! use hans_sim::{ClockMode, Config, Fault, Sim};
//!
//! // 127.0.0.1, ephemeral ports, robot powered off (FSM 2).
//! let sim = Sim::start(Config::default()).await?;
//! let addr = sim.command_addr();          // connect your client here
//! let sheets = sim.datasheet_addrs();     // 3 DataSheet ports
//!
//! sim.faults().once(Fault::Delay(Duration::from_millis(300)));
//! sim.set_emergency_stop(true);           // FSM 5 at once
//! assert_eq!(sim.fsm(), hans_sim::FsmState::EmergencyStop);
//! sim.set_emergency_stop(false);
//! let log: Vec<String> = sim.received(); // every message received, in order
//! sim.drop_connections();                 // close all command connections
//! sim.refuse_connections(Duration::from_secs(1));
//! sim.connect_out("127.0.0.1:9000".parse().unwrap()).await?; // client mode
//! sim.shutdown().await;
//! # Ok(()) }
//! ```
//!
//! Deterministic tests use the simulator's own clock:
//! `Config { clock: ClockMode::Manual, ..Config::default() }` freezes time
//! and [`Sim::advance`] moves it; `ClockMode::Scaled(10.0)` runs ten times
//! faster than real time. Start from StandBy with [`Config::ready`].
//!
//! ## Timing of a move (simulated time)
//! | time | what a client sees |
//! |---|---|
//! | `t0` | the move is accepted (`OK`); FSM 25 Moving at once; `nBlendingDone` 0, `nInPos` 0; `ReadCurWayPointID` = its `strCmdID` |
//! | `t0` + 50 ms | `nMovingState` 1 ([`Timing::moving_flag_lag`]) |
//! | `t0` + D | the command position reaches the target; FSM 33 StandBy; `nBlendingDone` 1 |
//! | `t0` + D + 20 ms | the actual position is there: `nInPos` 1 ([`Timing::actual_lag`]) |
//! | `t0` + D + 50 ms | `nMovingState` 0 |
//!
//! D follows a trapezoidal velocity profile: the command's velocity and
//! acceleration, both multiplied by the override (`SetOverride`), the
//! velocity capped by the joint (joint moves) or linear (Cartesian moves)
//! maximum. Joint moves are synchronised (all joints start and stop
//! together); `s` is the travel of the joint that moves most. Moves sent
//! while one runs are queued ([`MAX_QUEUE`]) and run back to back
//! (blending radii are accepted but paths are not rounded).
//! `GrpStop` decelerates to a stop (FSM 27, then 33) and drops the queue;
//! `GrpInterrupt` decelerates and holds (FSM 32, `nPause` 1);
//! `GrpContinue` resumes the rest of the path.
//!
//! ## Modules
//! | module | job |
//! |---|---|
//! | [`server`] | command port, fast port, client mode, one message at a time, faults applied |
//! | [`datasheet`] | DataSheet ports |
//! | `robot` | state machine ([`Timing`], FSM table), motion, the commands (one file per document section) |
//! | [`robot::io`] | box and tool-end I/O, tool Modbus registers |
//! | [`kinematics`] | forward / inverse kinematics, pose arithmetic |
//! | [`faults`] | fault injection |
//! | [`clock`] | the simulated clock |

#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod clock;
pub mod datasheet;
pub mod faults;
pub mod kinematics;
pub mod robot;
pub mod server;

use std::collections::VecDeque;
use std::io;
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::sync::atomic::AtomicUsize;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use hans_codec::CommandId;
use tokio::sync::{mpsc, watch};
use tokio::task::JoinHandle;

pub use clock::{Clock, ClockMode};
pub use faults::{Fault, FaultRule, Faults};
pub use hans_codec::{FsmState, ProtocolLevel};
pub use robot::io::Io;
pub use robot::{Flags, Initial, RobotError, Snapshot, Timing, MAX_QUEUE};

use server::Shared;

/// How to start a simulator.
#[derive(Clone, Debug)]
pub struct Config {
    /// Address to listen on (127.0.0.1 by default).
    pub host: IpAddr,
    /// Command port; 0 picks a free one (the default here; the binary's
    /// default is 10003).
    pub command_port: u16,
    /// JSON DataSheet ports; 0 picks free ones. The first three push at 20,
    /// 10 and 5 Hz, any further ones at 5 Hz. Default: three free ports.
    pub datasheet_ports: Vec<u16>,
    /// How simulated time passes.
    pub clock: ClockMode,
    /// Where the robot starts.
    pub initial: Initial,
    /// Durations of the slow operations and flag lags.
    pub timing: Timing,
    /// `ReadRobotModel`'s answer.
    pub model: String,
    /// Script functions `RunFunc` knows (others: `Fail,20601`).
    pub script_functions: Vec<String>,
    /// Quiet period after which bytes without `;` are answered as an
    /// incomplete message (`errorcmd,20007,;`).
    pub incomplete_timeout: Duration,
    /// How many received messages [`Sim::received`] keeps (oldest dropped).
    pub received_capacity: usize,
    /// `OSCmd,2` (reboot): how long the command port refuses connections.
    pub reboot_time: Duration,
    /// Client mode: connect to this address at start (see
    /// [`Sim::connect_out`]).
    pub connect_out: Option<SocketAddr>,
    /// Fault rules in force from the start.
    pub faults: Vec<FaultRule>,
    /// The protocol level the simulated controller speaks: which commands
    /// it knows (the codec's level data) and the form of a few replies. At
    /// [`ProtocolLevel::V5`] (HR-TCP V1.0.0.3) it answers the V6 document's
    /// commands `Fail,20005`, as an old controller does; at
    /// [`ProtocolLevel::V6`] (`HR6.6.1`, the default) the commands the V6
    /// document removed (`MoveJ`, `MoveL`, `MoveE`, HR-TCP's path commands).
    /// Any controller version between works too (`ProtocolLevel::parse`).
    pub protocol: ProtocolLevel,
    /// The fast command port (V6 document 3.2: 10001 on a controller),
    /// which serves the commands the document marks as fast (state reads,
    /// kinematics); 0 picks a free one (the default here). It listens only
    /// at levels that have `ReadFastCmdPort` (from `HR6.5.1`); `None`: never.
    pub fast_port: Option<u16>,
}

impl Default for Config {
    /// 127.0.0.1, ephemeral ports, real-time clock, powered off.
    fn default() -> Self {
        Config {
            host: IpAddr::V4(Ipv4Addr::LOCALHOST),
            command_port: 0,
            datasheet_ports: vec![0, 0, 0],
            clock: ClockMode::default(),
            initial: Initial::PoweredOff,
            timing: Timing::default(),
            model: "5KG".into(),
            script_functions: ["Func_main", "Func_1", "Func_2", "Func_3"]
                .iter()
                .map(|s| s.to_string())
                .collect(),
            incomplete_timeout: Duration::from_millis(200),
            received_capacity: 100_000,
            reboot_time: Duration::from_secs(2),
            connect_out: None,
            faults: Vec::new(),
            protocol: ProtocolLevel::V6,
            fast_port: Some(0),
        }
    }
}

impl Config {
    /// The default configuration, starting in StandBy (brought up and
    /// enabled).
    pub fn ready() -> Self {
        Config {
            initial: Initial::StandBy,
            ..Config::default()
        }
    }

    /// The controller's well-known ports (10003, 10004-10006).
    pub fn standard_ports(mut self) -> Self {
        self.command_port = 10003;
        self.datasheet_ports = vec![10004, 10005, 10006];
        self
    }
}

/// DataSheet push period of the `i`-th DataSheet port.
fn datasheet_period(i: usize) -> Duration {
    match i {
        0 => Duration::from_millis(50),
        1 => Duration::from_millis(100),
        _ => Duration::from_millis(200),
    }
}

/// A running simulator. Dropping it without [`Sim::shutdown`] leaves its
/// tasks running until the tokio runtime ends.
pub struct Sim {
    shared: Arc<Shared>,
    command_addr: SocketAddr,
    fast_addr: Option<SocketAddr>,
    datasheet_addrs: Vec<SocketAddr>,
    tasks: Vec<JoinHandle<()>>,
}

impl Sim {
    /// Binds every port and starts serving. Fails if a port cannot be bound
    /// (or, in client mode, the first connection cannot be made).
    pub async fn start(config: Config) -> io::Result<Sim> {
        let command = server::bind(SocketAddr::new(config.host, config.command_port))?;
        let command_addr = command.local_addr()?;
        let mut ds = Vec::new();
        for &p in &config.datasheet_ports {
            let l = server::bind(SocketAddr::new(config.host, p))?;
            ds.push((l.local_addr()?, l));
        }
        // The fast port, where the level has it.
        let fast = match config.fast_port {
            Some(p) if CommandId::ReadFastCmdPort.available_at(config.protocol) => {
                let l = server::bind(SocketAddr::new(config.host, p))?;
                Some((l.local_addr()?, l))
            }
            _ => None,
        };
        let mut robot = robot::Robot::new(config.timing, config.initial, config.protocol);
        robot.model = config.model.clone();
        robot.script_functions = config.script_functions.clone();
        robot.fast_port = fast.as_ref().map(|(a, _)| a.port());
        let (refuse_tx, refuse_rx) = mpsc::channel(8);
        let faults = Faults::default();
        for r in &config.faults {
            faults.add(r.clone());
        }
        let shared = Arc::new(Shared {
            robot: Mutex::new(robot),
            clock: Clock::new(config.clock),
            faults,
            received: Mutex::new(VecDeque::new()),
            received_capacity: config.received_capacity,
            incomplete_timeout: config.incomplete_timeout,
            reboot_time: config.reboot_time,
            drop_gen: watch::channel(0).0,
            shutdown: watch::channel(false).0,
            refuse: refuse_tx,
            connections: AtomicUsize::new(0),
            outgoing: Mutex::new(None),
        });
        let mut tasks = vec![tokio::spawn(server::accept_loop(
            shared.clone(),
            command,
            refuse_rx,
        ))];
        let fast_addr = match fast {
            Some((addr, l)) => {
                tasks.push(tokio::spawn(server::fast_accept_loop(shared.clone(), l)));
                Some(addr)
            }
            None => None,
        };
        let mut datasheet_addrs = Vec::new();
        for (i, (addr, l)) in ds.into_iter().enumerate() {
            datasheet_addrs.push(addr);
            tasks.push(tokio::spawn(datasheet::accept_loop(
                shared.clone(),
                l,
                datasheet_period(i),
            )));
        }
        let sim = Sim {
            shared,
            command_addr,
            fast_addr,
            datasheet_addrs,
            tasks,
        };
        if let Some(a) = config.connect_out {
            if let Err(e) = sim.connect_out(a).await {
                sim.shutdown().await;
                return Err(e);
            }
        }
        Ok(sim)
    }

    /// The command port's address.
    pub fn command_addr(&self) -> SocketAddr {
        self.command_addr
    }

    /// The fast command port's address, when it listens (see
    /// [`Config::fast_port`]).
    pub fn fast_addr(&self) -> Option<SocketAddr> {
        self.fast_addr
    }

    /// The protocol level the simulator speaks.
    pub fn protocol(&self) -> ProtocolLevel {
        self.with_robot(|r, _| r.level)
    }

    /// The DataSheet ports' addresses (20, 10, 5 Hz).
    pub fn datasheet_addrs(&self) -> Vec<SocketAddr> {
        self.datasheet_addrs.clone()
    }

    /// Every message received on command connections, in order, as text
    /// (`;` included). Bytes that were not a message are not listed. Only
    /// the last [`Config::received_capacity`] are kept.
    pub fn received(&self) -> Vec<String> {
        self.shared
            .received
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .iter()
            .cloned()
            .collect()
    }

    /// Forgets the received messages.
    pub fn clear_received(&self) {
        self.shared
            .received
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clear();
    }

    fn with_robot<T>(&self, f: impl FnOnce(&mut robot::Robot, f64) -> T) -> T {
        let now = self.shared.now();
        let mut r = self.shared.robot();
        r.update(now);
        f(&mut r, now)
    }

    /// The FSM state now.
    pub fn fsm(&self) -> FsmState {
        self.with_robot(|r, now| r.fsm(now))
    }

    /// Everything observable now: FSM, flags, positions, I/O.
    pub fn state(&self) -> Snapshot {
        self.with_robot(|r, now| r.snapshot(now))
    }

    /// Presses (`true`) or releases the emergency stop. Pressing stops any
    /// motion at once, disables and cuts 48 V (FSM 5); after release the
    /// robot is in FSM 7 (Blackout48V) and needs `Electrify`, `GrpEnable`.
    pub fn set_emergency_stop(&self, on: bool) {
        self.with_robot(|r, now| r.set_estop(on, now));
    }

    /// Opens (`true`) or closes the safety guard. Opening decelerates any
    /// motion to a stop and refuses motion (`Fail,20018`) while open (FSM
    /// 12); power stays on and the robot returns to its state on closing.
    pub fn set_safety_guard(&self, on: bool) {
        self.with_robot(|r, now| r.set_guard(on, now));
    }

    /// Raises a robot error (FSM 22, `nErrorState` 1 with this code and
    /// axis; motion stops at once) or clears it (`None`; clients clear it
    /// with `GrpReset`).
    pub fn set_error(&self, error: Option<RobotError>) {
        self.with_robot(|r, now| r.set_error(error, now));
    }

    /// Changes the I/O as a wiring change would (inputs, analog values,
    /// buttons, registers). A way point with `nIsSeek` reacts at once.
    pub fn set_io(&self, f: impl FnOnce(&mut Io)) {
        self.with_robot(|r, now| {
            f(&mut r.io);
            r.update(now);
        });
    }

    /// Sets the calibrated force-sensor data (`ReadFTCabData`).
    pub fn set_force_data(&self, data: [f64; 6]) {
        self.with_robot(|r, _| r.ft_data = data);
    }

    /// Chooses whether the tool-end I/O is the EtherCAT version; when not,
    /// the tool Modbus commands fail with 40058.
    pub fn set_end_io_ethercat(&self, on: bool) {
        self.with_robot(|r, _| r.end_io_ethercat = on);
    }

    /// The I/O now.
    pub fn io(&self) -> Io {
        self.with_robot(|r, _| r.io.clone())
    }

    /// The fault rules (see [`faults`]).
    pub fn faults(&self) -> &Faults {
        &self.shared.faults
    }

    /// The simulated clock.
    pub fn clock(&self) -> &Clock {
        &self.shared.clock
    }

    /// Moves simulated time forward (see [`ClockMode::Manual`]).
    pub fn advance(&self, d: Duration) {
        self.shared.clock.advance(d);
    }

    /// Simulated time since start.
    pub fn now(&self) -> Duration {
        self.shared.clock.now()
    }

    /// Closes every command connection now (listening and client mode);
    /// the robot carries on (a move in progress completes).
    pub fn drop_connections(&self) {
        self.shared.drop_connections();
    }

    /// Stops listening on the command port for `d` (connections are
    /// refused), then listens again on the same port. Open connections are
    /// not affected; call [`Sim::drop_connections`] too for a controller
    /// that went away.
    pub fn refuse_connections(&self, d: Duration) {
        let _ = self.shared.refuse.try_send(d);
    }

    /// Client mode (section 3.1.1): closes the previous outgoing connection,
    /// connects to `addr` and serves the command protocol over it, as the
    /// controller does when its connect I/O signal fires.
    pub async fn connect_out(&self, addr: SocketAddr) -> io::Result<()> {
        server::connect_out(&self.shared, addr).await
    }

    /// Number of command connections being served.
    pub fn connection_count(&self) -> usize {
        self.shared
            .connections
            .load(std::sync::atomic::Ordering::SeqCst)
    }

    /// Stops every task and closes every socket it opened.
    pub async fn shutdown(self) {
        self.shared.drop_connections();
        let _ = self.shared.shutdown.send(true);
        for t in self.tasks {
            let _ = t.await;
        }
    }
}
