//! `hans-gateway`: the gateway on Linux.
//!
//! ```text
//! hans-gateway --robot HOST:PORT --modbus-listen HOST:PORT [--config FILE]
//! hans-gateway --robot-listen HOST:PORT --modbus-listen HOST:PORT [--config FILE]
//! hans-gateway --help | --version
//! ```
//!
//! See [`HELP`] (printed by `--help`) for the options, the configuration
//! file and the exit status.

use std::net::{SocketAddr, SocketAddrV4, ToSocketAddrs};
use std::path::PathBuf;
use std::process::ExitCode;

use hans_gateway::host::{HostOptions, RunningGateway};

const USAGE: &str = "usage: hans-gateway (--robot HOST:PORT | --robot-listen HOST:PORT) \
--modbus-listen HOST:PORT [--config FILE]
       hans-gateway --help | --version";

/// The text of `--help`.
const HELP: &str = "\
hans-gateway: Modbus TCP (PLC) to Hans / Huayan Elfin robot controller gateway

Usage:
  hans-gateway --robot HOST:PORT --modbus-listen HOST:PORT [--config FILE]
  hans-gateway --robot-listen HOST:PORT --modbus-listen HOST:PORT [--config FILE]
  hans-gateway --config FILE --modbus-listen HOST:PORT
  hans-gateway --help | --version

Options:
  --modbus-listen HOST:PORT  Address of the Modbus TCP server for the PLC (required;
                             port 0 picks a free one; 502 needs privileges).
  --robot HOST:PORT          Connect to the controller's command port (usually 10003).
  --robot-listen HOST:PORT   Wait for the controller to connect instead (its client mode).
  --config FILE              Keep the configuration and the trigger table in FILE: read at
                             start, written when the PLC writes 1 to CONFIG_COMMAND.
                             Without it they live in RAM: the PLC's CONFIG_COMMAND 1
                             applies them but reports CONFIG_RESULT 3 (not saved).
  -h, --help                 Print this help and exit.
  -V, --version              Print the version and exit.

The configuration file holds the CFG_* registers (robot address and port, link mode,
listen port, poll period, reply timeout, word order, watchdog, motion policy, start grace,
auto reset, status source, DataSheet port, robot id) and the sixteen trigger entries, in a
checked binary image (magic HGW1, CRC-32); a damaged file is ignored (defaults are used and
the log says so). --robot or --robot-listen override the robot setting saved in the file
for this run (a warning in the log says so); the other saved settings are kept. One of
--robot, --robot-listen or --config is needed.

The register map for PLC programmers is REGISTERS.md beside the crate's Cargo.toml.
Logs go to stderr (RUST_LOG=debug for more). SIGINT or SIGTERM stops the gateway.

Exit status:
  0  --help or --version
  1  the gateway could not start (an address cannot be bound)
  2  bad command line
";

fn resolve(s: &str) -> Result<SocketAddrV4, String> {
    let addrs = s.to_socket_addrs().map_err(|e| format!("{s}: {e}"))?;
    addrs
        .filter_map(|a| match a {
            SocketAddr::V4(a) => Some(a),
            SocketAddr::V6(_) => None,
        })
        .next()
        .ok_or_else(|| format!("{s}: no IPv4 address"))
}

/// What the command line asks for.
enum Action {
    Run(HostOptions),
    Help,
    Version,
}

fn parse(args: &[String]) -> Result<Action, String> {
    let mut robot = None;
    let mut robot_listen = None;
    let mut modbus = None;
    let mut config = None;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || it.next().ok_or_else(|| format!("{a} needs a value"));
        match a.as_str() {
            "--robot" => robot = Some(resolve(value()?)?),
            "--robot-listen" => robot_listen = Some(resolve(value()?)?),
            "--modbus-listen" => modbus = Some(resolve(value()?)?),
            "--config" => config = Some(PathBuf::from(value()?)),
            "-h" | "--help" => return Ok(Action::Help),
            "-V" | "--version" => return Ok(Action::Version),
            other => return Err(format!("unknown argument {other}")),
        }
    }
    if robot.is_some() && robot_listen.is_some() {
        return Err("--robot and --robot-listen exclude each other".into());
    }
    let modbus = modbus.ok_or("--modbus-listen is required")?;
    if robot.is_none() && robot_listen.is_none() && config.is_none() {
        return Err("no robot given (--robot, --robot-listen or a --config that has one)".into());
    }
    Ok(Action::Run(HostOptions {
        modbus_listen: modbus,
        robot,
        robot_listen,
        config_file: config,
        defaults: hans_gateway::Config::default(),
    }))
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let opts = match parse(&args) {
        Ok(Action::Run(o)) => o,
        Ok(Action::Help) => {
            print!("{HELP}");
            return ExitCode::SUCCESS;
        }
        Ok(Action::Version) => {
            println!("hans-gateway {}", env!("CARGO_PKG_VERSION"));
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            eprintln!("hans-gateway: {e}");
            eprintln!("{USAGE}");
            eprintln!("Try 'hans-gateway --help' for more.");
            return ExitCode::from(2);
        }
    };
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("info"))
        .format_timestamp_millis()
        .init();
    let gw = match RunningGateway::start(opts) {
        Ok(g) => g,
        Err(e) => {
            eprintln!("hans-gateway: {e}");
            return ExitCode::FAILURE;
        }
    };
    log::info!("modbus server on {}", gw.modbus_addr());
    if let Some(a) = gw.robot_listen_addr() {
        log::info!("waiting for the robot controller on {a}");
    }
    // Runs until the process is stopped (SIGINT/SIGTERM end it; sockets
    // are closed by the OS).
    loop {
        std::thread::park();
    }
}
