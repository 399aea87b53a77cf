//! `hans-sim`: runs the simulated controller until Ctrl-C.
//!
//! ```text
//! hans-sim [--host 127.0.0.1] [--command-port 10003]
//!          [--datasheet-ports 10004,10005,10006] [--ready] [--speed 1.0]
//!          [--protocol v6] [--fast-port 10001]
//!          [--connect HOST:PORT] [--fault SPEC]... [--model 5KG]
//! ```
//! Prints one line per listener when ready, e.g.
//! `hans-sim: command port listening on 127.0.0.1:10003`.

use std::net::{IpAddr, SocketAddr};
use std::process::ExitCode;
use std::time::Duration;

use clap::Parser;
use hans_sim::{ClockMode, Config, FaultRule, Initial, ProtocolLevel, Sim, Timing};

/// Prints one status line. A closed stdout (its reader stopped reading) is
/// no reason to stop serving, so a failed write is ignored where `println!`
/// would panic.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let mut out = std::io::stdout().lock();
        let _ = writeln!(out, $($arg)*);
        let _ = out.flush();
    }};
}

#[derive(Parser, Debug)]
#[command(
    name = "hans-sim",
    version,
    about = "Simulated Hans / Huayan (Elfin) robot controller"
)]
struct Args {
    /// Address to listen on.
    #[arg(long, default_value = "127.0.0.1")]
    host: IpAddr,
    /// Command port (0 = pick a free one).
    #[arg(long, default_value_t = 10003)]
    command_port: u16,
    /// JSON DataSheet ports, comma separated (20, 10, 5 Hz; 0 = free ones;
    /// empty = none).
    #[arg(long, default_value = "10004,10005,10006", value_delimiter = ',')]
    datasheet_ports: Vec<String>,
    /// Start brought up and enabled (FSM 33 StandBy) instead of powered off.
    #[arg(long)]
    ready: bool,
    /// Simulated-time speed factor (2 = twice as fast as real time).
    #[arg(long, default_value_t = 1.0)]
    speed: f64,
    /// Every slow operation completes at once and no flag lags.
    #[arg(long)]
    instant: bool,
    /// Client mode: connect to this address and serve commands over it
    /// (retried every second until it succeeds; gives up after an hour).
    #[arg(long)]
    connect: Option<SocketAddr>,
    /// Fault rule KIND[=ARG][@COMMAND][*TIMES], repeatable: delay=MS,
    /// split=BYTES, noreply, drop, garbage[=TEXT], garbage-before[=TEXT],
    /// fail=CODE[:DETAIL], errorcmd.
    #[arg(long = "fault")]
    faults: Vec<String>,
    /// Refuse command connections for this many milliseconds after start.
    #[arg(long, default_value_t = 0)]
    refuse_ms: u64,
    /// Robot model returned by ReadRobotModel.
    #[arg(long, default_value = "5KG")]
    model: String,
    /// Protocol level: v5 (HR-TCP V1.0.0.3: the V6 document's commands are
    /// refused with Fail 20005), v6 (HR6.6.1: MoveJ, MoveL and the other
    /// removed commands are refused), or a controller version (HR6.4.8).
    #[arg(long, default_value = "v6", value_parser = parse_level)]
    protocol: ProtocolLevel,
    /// Fast command port (0 = pick a free one). Served at levels from
    /// HR6.5.1 only.
    #[arg(long, default_value_t = 10001)]
    fast_port: u16,
    /// Do not serve the fast command port.
    #[arg(long)]
    no_fast_port: bool,
    /// Script functions RunFunc accepts, comma separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "Func_main,Func_1,Func_2,Func_3"
    )]
    script_funcs: Vec<String>,
}

/// `v5`, `v6` or a controller version such as `HR6.4.8`.
fn parse_level(s: &str) -> Result<ProtocolLevel, String> {
    match s.to_ascii_lowercase().as_str() {
        "v5" => Ok(ProtocolLevel::V5),
        "v6" => Ok(ProtocolLevel::V6),
        _ => ProtocolLevel::parse(s)
            .ok_or_else(|| format!("{s:?}: expected v5, v6 or a version such as HR6.4.8")),
    }
}

fn main() -> ExitCode {
    let args = Args::parse();
    let rt = match tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
    {
        Ok(rt) => rt,
        Err(e) => {
            eprintln!("hans-sim: cannot start the runtime: {e}");
            return ExitCode::FAILURE;
        }
    };
    rt.block_on(run(args))
}

async fn run(args: Args) -> ExitCode {
    let mut datasheet_ports = Vec::new();
    for p in args.datasheet_ports.iter().filter(|p| !p.trim().is_empty()) {
        match p.trim().parse::<u16>() {
            Ok(v) => datasheet_ports.push(v),
            Err(_) => {
                eprintln!("hans-sim: bad DataSheet port {p:?}");
                return ExitCode::FAILURE;
            }
        }
    }
    let mut faults = Vec::new();
    for spec in &args.faults {
        match FaultRule::parse(spec) {
            Ok(r) => faults.push(r),
            Err(e) => {
                eprintln!("hans-sim: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    if !(args.speed.is_finite() && args.speed > 0.0) {
        eprintln!("hans-sim: --speed must be above 0");
        return ExitCode::FAILURE;
    }
    let config = Config {
        host: args.host,
        command_port: args.command_port,
        datasheet_ports,
        clock: ClockMode::Scaled(args.speed),
        initial: if args.ready {
            Initial::StandBy
        } else {
            Initial::PoweredOff
        },
        timing: if args.instant {
            Timing::instant()
        } else {
            Timing::default()
        },
        model: args.model,
        script_functions: args.script_funcs,
        faults,
        protocol: args.protocol,
        fast_port: (!args.no_fast_port).then_some(args.fast_port),
        ..Config::default()
    };
    let sim = match Sim::start(config.clone()).await {
        Ok(s) => s,
        // The fast port is an extra: without it the controller still works.
        Err(e) if matches!(config.fast_port, Some(p) if p != 0) => {
            eprintln!("hans-sim: {e}; trying without the fast command port");
            match Sim::start(Config {
                fast_port: None,
                ..config
            })
            .await
            {
                Ok(s) => s,
                Err(e) => {
                    eprintln!("hans-sim: cannot listen: {e}");
                    return ExitCode::FAILURE;
                }
            }
        }
        Err(e) => {
            eprintln!("hans-sim: cannot listen: {e}");
            return ExitCode::FAILURE;
        }
    };
    say!("hans-sim: command port listening on {}", sim.command_addr());
    for (i, a) in sim.datasheet_addrs().iter().enumerate() {
        let hz = [20, 10, 5].get(i).copied().unwrap_or(5);
        say!("hans-sim: datasheet port ({hz} Hz) listening on {a}");
    }
    if let Some(a) = sim.fast_addr() {
        say!("hans-sim: fast command port listening on {a}");
    }
    say!("hans-sim: protocol level {}", sim.protocol());
    say!(
        "hans-sim: robot FSM {} ({})",
        sim.fsm().code(),
        sim.fsm().name().unwrap_or("?")
    );
    if args.refuse_ms > 0 {
        sim.refuse_connections(Duration::from_millis(args.refuse_ms));
    }
    if let Some(addr) = args.connect {
        let mut connected = false;
        for _ in 0..3600 {
            match sim.connect_out(addr).await {
                Ok(()) => {
                    say!("hans-sim: client mode: connected to {addr}");
                    connected = true;
                    break;
                }
                Err(e) => {
                    eprintln!("hans-sim: client mode: cannot connect to {addr}: {e}; retrying");
                    tokio::select! {
                        _ = tokio::signal::ctrl_c() => break,
                        _ = tokio::time::sleep(Duration::from_secs(1)) => {}
                    }
                }
            }
        }
        if !connected {
            sim.shutdown().await;
            return ExitCode::FAILURE;
        }
    }
    let _ = tokio::signal::ctrl_c().await;
    say!("hans-sim: stopping");
    sim.shutdown().await;
    ExitCode::SUCCESS
}
