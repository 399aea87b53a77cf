//! `hans-gateway`: the gateway on Linux.
//!
//! ```text
//! hans-gateway --robot HOST:PORT --modbus-listen HOST:PORT [--config FILE]
//! hans-gateway --robot-listen HOST:PORT --modbus-listen HOST:PORT [--config FILE]
//! ```
//!
//! `--robot` connects to the controller's command port; `--robot-listen`
//! waits for the controller to connect (its client mode). Either overrides
//! the stored configuration's robot settings. `--config FILE` keeps the
//! configuration and trigger table in FILE (saved when the PLC writes 1 to
//! `CONFIG_COMMAND`); without it they live in RAM. Logs go to stderr
//! (`RUST_LOG=debug` for more). Stops on SIGINT/SIGTERM or when killed.

use std::net::{SocketAddr, SocketAddrV4, ToSocketAddrs};
use std::path::PathBuf;
use std::process::ExitCode;

use hans_gateway::host::{HostOptions, RunningGateway};

const USAGE: &str = "usage: hans-gateway (--robot HOST:PORT | --robot-listen HOST:PORT) \
--modbus-listen HOST:PORT [--config FILE]";

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

fn parse(args: &[String]) -> Result<HostOptions, String> {
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
            "-h" | "--help" => return Err(String::new()),
            other => return Err(format!("unknown argument {other}")),
        }
    }
    if robot.is_some() && robot_listen.is_some() {
        return Err("--robot and --robot-listen exclude each other".into());
    }
    let modbus = modbus.ok_or("--modbus-listen is required")?;
    Ok(HostOptions {
        modbus_listen: modbus,
        robot,
        robot_listen,
        config_file: config,
        defaults: hans_gateway::Config::default(),
    })
}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("info"))
        .format_timestamp_millis()
        .init();
    let args: Vec<String> = std::env::args().skip(1).collect();
    let opts = match parse(&args) {
        Ok(o) => o,
        Err(e) => {
            if !e.is_empty() {
                eprintln!("hans-gateway: {e}");
            }
            eprintln!("{USAGE}");
            return ExitCode::from(2);
        }
    };
    if opts.robot.is_none() && opts.robot_listen.is_none() && opts.config_file.is_none() {
        eprintln!(
            "hans-gateway: no robot given (--robot, --robot-listen or a --config that has one)"
        );
        eprintln!("{USAGE}");
        return ExitCode::from(2);
    }
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
