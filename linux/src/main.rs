//! `hans-gateway`: the gateway on Linux.
//!
//! ```text
//! hans-gateway --robot HOST[:PORT] --modbus-listen HOST:PORT [--config FILE] [--web-listen HOST:PORT]
//! hans-gateway --robot-listen HOST:PORT --modbus-listen HOST:PORT [--config FILE] [--web-listen HOST:PORT]
//! hans-gateway --config FILE --modbus-listen HOST:PORT
//!     [--web-listen HOST:PORT --web-tls CERT KEY]
//!     [--modbus-tls-listen HOST:PORT --modbus-tls CERT KEY --modbus-tls-ca CA]
//! hans-gateway --help | --version
//! ```
//!
//! The command line is read by clap; `--help` prints the options, the
//! configuration file, the setup code and the exit status ([`AFTER_HELP`]).
//! The process runs until SIGTERM or SIGINT stops it in order (status 0:
//! the audit log's last records kept first, [`StopSignals`]), or until the
//! gateway fails (status 101, for a supervisor to restart it).

use std::fmt;
use std::io::Write;
use std::net::{Ipv4Addr, Ipv6Addr, SocketAddr, SocketAddrV4, ToSocketAddrs};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::error::ErrorKind;
use clap::{ArgAction, CommandFactory, FromArgMatches, Parser};
use hans_gateway::config::HostName;
use hans_gateway::registers::MAP_VERSION;
use hans_gateway::{MqttOverride, SetupCode, Stopped, SETUP_CODE_LEN};
use hans_gateway_linux::config_file::{self, Error as FileProblem};
use hans_gateway_linux::{os_random, FileStorage, HostOptions, RunningGateway, Stopper};

/// The robot controller's command port, used when `--robot` names none.
const ROBOT_PORT: u16 = 10003;

/// The setup code's file name, beside the configuration file (or in the
/// current directory) unless `--setup-code-file` names another.
const SETUP_CODE_FILE: &str = "setup-code";

/// The exit status when the running gateway fails (a panic: Rust's own
/// status for one).
const FAILED_RUNNING: u8 = 101;

/// The forms of the command line, in `--help` and after every usage error
/// (lines after the first are indented under clap's `Usage: `).
const USAGE: &str = "\
hans-gateway --robot HOST[:PORT] --modbus-listen HOST:PORT [--config FILE] [--web-listen HOST:PORT]
       hans-gateway --robot-listen HOST:PORT --modbus-listen HOST:PORT [--config FILE] [--web-listen HOST:PORT]
       hans-gateway --config FILE --modbus-listen HOST:PORT
           [--web-listen HOST:PORT --web-tls CERT KEY]
           [--modbus-tls-listen HOST:PORT --modbus-tls CERT KEY --modbus-tls-ca CA]
       hans-gateway --help | --version";

/// What `--help` says after the options: [`TABLES`] is replaced by the
/// settings' tables ([`after_help`]).
const AFTER_HELP: &str = "\
The configuration file (--config FILE) is TOML that you may edit and keep in version
control: the settings in the tables
  TABLES
(their keys are those of the web page's Configuration, which names each; REGISTERS.md
names their Modbus registers), the sixteen trigger entries in [triggers], and in [access]
the web page's accounts (name, role, and the password as a salted hash, never in clear).
An example: linux/examples/gateway.toml. A key left out takes its factory default; a file
that does not exist yet means the defaults (the first save creates it).
The file is checked before anything starts: a malformed file, an unknown key or a value
out of range is refused, one line per problem on stderr
  hans-gateway: FILE:LINE:COLUMN: reason
and the gateway exits with status 2 (it never runs on silent defaults). A save
(CONFIG_COMMAND 1) rewrites the whole file atomically; comments added by hand are not
kept. The file is written readable by its owner only (mode 0600), also over a file that
was not. A binary image written by an older version is still read, and written as TOML at
the next save. --robot or --robot-listen override the robot setting saved in the file
for this run (a warning in the log says so); the other saved settings are kept. One of
--robot, --robot-listen or --config FILE is needed; with a file whose robot.address is
0.0.0.0 (the factory state) the gateway warns that it connects to no robot until one is
set (on the web page, in the file, or over Modbus).
Without --config nothing is kept across a restart (the page says so at its top).

The setup code: at each start the gateway makes a new one-time code from the operating
system's random source and writes it to the --setup-code-file FILE only (readable by its
owner only, replaced at each start); stderr (the journal) says where, never the code:
  hans-gateway: setup code for the first administrator: in FILE (readable by its owner only) Creating the first administrator account asks for it: it proves that whoever
creates it can read the machine's log or files. It is never served on the network.

TLS (PEM files): --web-tls serves the page over HTTPS only (TLS 1.2 and 1.3). Modbus/TCP
Security (--modbus-tls-listen, the standard port is 802) serves beside the plain Modbus server
and shares its sessions and MODBUS_ALLOW: TLS 1.2 or 1.3, a client certificate signed by a CA
of --modbus-tls-ca is required, and its role extension (OID 1.3.6.1.4.1.50316.802.1, a
UTF8String) decides: admin or operator read and write; viewer, any other role or none
read only (a write gets exception 01 and counts in WRITES_REFUSED). A handshake must end
within 2 s of the connection's first read, else the connection is closed.

HOST is an IPv4 address or a host name. A name is resolved once, at start, to its first
IPv4 address (the gateway speaks IPv4 only); the log shows the address used.

The register map for PLC programmers is REGISTERS.md beside the crate's Cargo.toml.
Logs go to stderr (RUST_LOG=debug for more). SIGINT or SIGTERM stops the gateway in order:
its audit log records the stop and keeps what it had counted (at most 5 s); a second
signal ends it at once.

Exit status:
  0    --help or --version, or stopped in order by SIGTERM or SIGINT
  1    the gateway could not start (a host name does not resolve to an IPv4 address,
       an address cannot be bound, the configuration file cannot be read), or at a stop
       the audit log's last records could not be kept
  130, 143  a second SIGINT or SIGTERM ended a stop at once
  2    bad command line, or a configuration file that is refused (FILE:LINE:COLUMN: reason)
  101  the gateway failed while running (the line before says why): nothing is served any
       more, start it again (systemd: Restart=on-failure, linux/dist/hans-gateway.service)";

/// The command line.
#[derive(Parser, Debug)]
#[command(
    name = "hans-gateway",
    about = "hans-gateway: Modbus TCP (PLC) to Hans / Huayan Elfin robot controller gateway",
    override_usage = USAGE,
    disable_help_flag = true,
    disable_version_flag = true
)]
struct Cli {
    /// Address of the Modbus TCP server for the PLC (required;
    /// port 0 picks a free one; 502 needs privileges).
    #[arg(long, value_name = "HOST:PORT", value_parser = listen_endpoint)]
    #[arg(required = true, verbatim_doc_comment)]
    modbus_listen: Endpoint,
    /// Connect to the controller's command port
    /// (PORT defaults to 10003).
    #[arg(long, value_name = "HOST[:PORT]", value_parser = robot_endpoint)]
    #[arg(conflicts_with = "robot_listen", verbatim_doc_comment)]
    robot: Option<Endpoint>,
    /// Wait for the controller to connect instead (its client mode).
    #[arg(long, value_name = "HOST:PORT", value_parser = listen_endpoint)]
    #[arg(verbatim_doc_comment)]
    robot_listen: Option<Endpoint>,
    /// Serve the web page (status, configuration, trigger table,
    /// command log; gateway/WEB.md) here. Off unless given.
    #[arg(long, value_name = "HOST:PORT", value_parser = listen_endpoint)]
    #[arg(verbatim_doc_comment)]
    web_listen: Option<Endpoint>,
    /// Serve the web page over HTTPS with the certificate (chain)
    /// CERT and its private key KEY (PEM files).
    #[arg(long, num_args = 2, value_names = ["CERT", "KEY"])]
    #[arg(requires = "web_listen", verbatim_doc_comment)]
    web_tls: Option<Vec<PathBuf>>,
    /// Serve Modbus/TCP Security here too (TLS with client
    /// certificates; the standard port is 802): needs --modbus-tls
    /// and --modbus-tls-ca.
    #[arg(long, value_name = "HOST:PORT", value_parser = listen_endpoint)]
    #[arg(requires_all = ["modbus_tls", "modbus_tls_ca"], verbatim_doc_comment)]
    modbus_tls_listen: Option<Endpoint>,
    /// The Modbus/TCP Security server's certificate (chain) and
    /// private key (PEM files).
    #[arg(long, num_args = 2, value_names = ["CERT", "KEY"])]
    #[arg(requires = "modbus_tls_listen", verbatim_doc_comment)]
    modbus_tls: Option<Vec<PathBuf>>,
    /// The CAs (PEM) a Modbus/TCP Security client's certificate must
    /// be signed by.
    #[arg(long, value_name = "CA", requires = "modbus_tls_listen")]
    #[arg(verbatim_doc_comment)]
    modbus_tls_ca: Option<PathBuf>,
    /// Serve the EtherNet/IP adapter (gateway/ENIP.md) here: the
    /// encapsulation protocol on TCP and UDP (the standard port is
    /// 44818), while enip.enabled is on (off in the factory state).
    /// Off unless given.
    #[arg(long, value_name = "HOST:PORT", value_parser = listen_endpoint)]
    #[arg(verbatim_doc_comment)]
    enip_listen: Option<Endpoint>,
    /// The EtherNet/IP class 1 I/O port (UDP, on the --enip-listen
    /// address): 2222 is what Logix scanners send to.
    #[arg(long, value_name = "PORT", default_value_t = 2222)]
    #[arg(requires = "enip_listen", verbatim_doc_comment)]
    enip_io_port: u16,
    /// Publish the cell's state as a Sparkplug B edge node to the MQTT
    /// broker at HOST:PORT (gateway/SPARKPLUG.md), for this run: turns
    /// mqtt.enabled on and overrides mqtt.broker, mqtt.port and mqtt.tls.
    /// mqtts://HOST:PORT: over TLS (the broker's certificate must name
    /// HOST and be signed by a CA of --mqtt-ca). A name is resolved at
    /// each connect. MQTT sees the robot, never moves it.
    #[arg(long, value_name = "[mqtts://]HOST:PORT", value_parser = mqtt_endpoint)]
    #[arg(verbatim_doc_comment)]
    mqtt: Option<(bool, Endpoint)>,
    /// The user name for the MQTT broker (with --mqtt-password-file);
    /// without it the gateway connects anonymously.
    #[arg(
        long,
        value_name = "NAME",
        requires = "mqtt_password_file",
        verbatim_doc_comment
    )]
    mqtt_user: Option<String>,
    /// A file whose first line is the broker's password (readable by
    /// its owner only, as the setup code: never on the command line,
    /// where every user of the machine reads it).
    #[arg(
        long,
        value_name = "FILE",
        requires = "mqtt_user",
        verbatim_doc_comment
    )]
    mqtt_password_file: Option<PathBuf>,
    /// The CAs (PEM) a TLS broker's certificate must be signed by
    /// (mqtt.tls); default: the system's, /etc/ssl/certs/ca-certificates.crt.
    #[arg(long, value_name = "FILE", verbatim_doc_comment)]
    mqtt_ca: Option<PathBuf>,
    /// Keep the configuration, the trigger table and the web page's
    /// accounts in FILE (TOML), and the audit log beside it
    /// (FILE.audit): checked and read at start, written at each save
    /// (the page's, or the PLC's CONFIG_COMMAND 1).
    /// Without it they live in RAM and are lost at each restart: the
    /// PLC's CONFIG_COMMAND 1 applies them but reports CONFIG_RESULT 3
    /// (not saved), and the page says so at its top.
    #[arg(long, value_name = "FILE", verbatim_doc_comment)]
    config: Option<PathBuf>,
    /// Write the one-time setup code (for creating the first
    /// administrator; a new one at each start) to FILE, readable by
    /// its owner only. Default: setup-code beside the --config FILE,
    /// or in the current directory without --config.
    #[arg(long, value_name = "FILE", verbatim_doc_comment)]
    setup_code_file: Option<PathBuf>,
    /// Print this help and exit.
    #[arg(short, long, action = ArgAction::HelpLong, verbatim_doc_comment)]
    help: Option<bool>,
    /// Print the version (and the register map's) and exit.
    #[arg(short = 'V', long, action = ArgAction::Version, verbatim_doc_comment)]
    version: Option<bool>,
}

/// `HOST:PORT` as given: checked for form by clap, resolved at start.
#[derive(Clone, Debug)]
struct Endpoint {
    host: String,
    port: u16,
}

impl fmt::Display for Endpoint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.host, self.port)
    }
}

impl Endpoint {
    /// `HOST:PORT`, or `HOST` alone when there is a `default_port`. Only the
    /// form is checked here: a name that does not resolve is not a bad
    /// command line (see [`Endpoint::resolve`]).
    fn parse(s: &str, default_port: Option<u16>) -> Result<Endpoint, String> {
        const IPV6: &str = "IPv6 addresses are not supported (the gateway speaks IPv4)";
        if let Ok(addr) = s.parse::<SocketAddr>() {
            return match addr {
                SocketAddr::V4(a) => Ok(Endpoint {
                    host: a.ip().to_string(),
                    port: a.port(),
                }),
                SocketAddr::V6(_) => Err(IPV6.into()),
            };
        }
        if s.starts_with('[') || s.parse::<Ipv6Addr>().is_ok() {
            return Err(IPV6.into());
        }
        let (host, port) = match (s.rsplit_once(':'), default_port) {
            (Some((host, port)), _) => {
                let port = port
                    .parse()
                    .map_err(|_| format!("{port:?} is not a port number (0 to 65535)"))?;
                (host, port)
            }
            (None, Some(port)) => (s, port),
            (None, None) => return Err("a port is needed: HOST:PORT".into()),
        };
        if host.is_empty() || host.contains(':') || host.contains(char::is_whitespace) {
            return Err(format!("{host:?} is not a host name or an IPv4 address"));
        }
        Ok(Endpoint {
            host: host.to_string(),
            port,
        })
    }

    /// The IPv4 address to use: the host itself if it is one, else the first
    /// IPv4 address the system's resolver gives for the name.
    fn resolve(&self) -> Result<SocketAddrV4, String> {
        if let Ok(ip) = self.host.parse::<Ipv4Addr>() {
            return Ok(SocketAddrV4::new(ip, self.port));
        }
        let addrs = (self.host.as_str(), self.port)
            .to_socket_addrs()
            .map_err(|e| format!("cannot resolve the host name {:?}: {e}", self.host))?;
        addrs
            .filter_map(|a| match a {
                SocketAddr::V4(a) => Some(a),
                SocketAddr::V6(_) => None,
            })
            .next()
            .ok_or_else(|| format!("the host name {:?} has no IPv4 address", self.host))
    }
}

fn robot_endpoint(s: &str) -> Result<Endpoint, String> {
    Endpoint::parse(s, Some(ROBOT_PORT))
}

fn listen_endpoint(s: &str) -> Result<Endpoint, String> {
    Endpoint::parse(s, None)
}

/// `[mqtt://|mqtts://]HOST:PORT`: whether TLS, and where.
fn mqtt_endpoint(s: &str) -> Result<(bool, Endpoint), String> {
    match s.split_once("://") {
        Some(("mqtts", rest)) => Ok((true, Endpoint::parse(rest, Some(8883))?)),
        Some(("mqtt", rest)) => Ok((false, Endpoint::parse(rest, Some(1883))?)),
        Some((scheme, _)) => Err(format!("{scheme}:// is not mqtt:// or mqtts://")),
        None => Ok((false, Endpoint::parse(s, Some(1883))?)),
    }
}

/// `0.1.0 (register map 1.4)`: the gateway's version, and the register
/// map's that the VERSION register holds (major × 256 + minor).
fn version() -> String {
    format!(
        "{} (register map {}.{})",
        env!("CARGO_PKG_VERSION"),
        MAP_VERSION >> 8,
        MAP_VERSION & 0xFF
    )
}

/// The placeholder of [`AFTER_HELP`] for the settings' tables.
const TABLES: &str = "TABLES";

/// [`AFTER_HELP`] with the settings' tables of this build (`[robot]`,
/// `[link]`, ..., in the schema's order): the help names every table the
/// file may have, also those added later.
fn after_help() -> String {
    let mut groups: Vec<&str> = Vec::new();
    for s in hans_gateway::config::SETTINGS {
        if !groups.contains(&s.group()) {
            groups.push(s.group());
        }
    }
    let tables: Vec<String> = groups.iter().map(|g| format!("[{g}]")).collect();
    let list = match tables.split_last() {
        Some((last, [])) => last.clone(),
        Some((last, rest)) => format!("{} and {last}", rest.join(", ")),
        None => String::new(),
    };
    AFTER_HELP.replacen(TABLES, &list, 1)
}

/// The command line's definition with its version and its after-help,
/// which are built at run time (the map version, the settings' tables) and
/// so go on here rather than in the derive attribute (clap takes a
/// `&'static str`: the strings are leaked, once per run).
fn command() -> clap::Command {
    let version: &'static str = version().leak();
    let after: &'static str = after_help().leak();
    Cli::command().version(version).after_help(after)
}

/// Reads the command line. `--help` and `--version` print to stdout and
/// exit 0; a bad command line prints the reason and the usage to stderr and
/// exits 2 (clap's conventions, kept for the rule clap cannot express).
fn command_line() -> Cli {
    let mut cmd = command();
    let matches = cmd.get_matches_mut();
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.format(&mut cmd).exit());
    if cli.robot.is_none() && cli.robot_listen.is_none() && cli.config.is_none() {
        cmd.error(
            ErrorKind::MissingRequiredArgument,
            "no robot given: one of --robot, --robot-listen or --config (a file that has one) is needed",
        )
        .exit();
    }
    cli
}

/// Where the setup code is written: `--setup-code-file`, else
/// [`SETUP_CODE_FILE`] beside the configuration file, else in the current
/// directory.
fn setup_code_path(cli: &Cli) -> PathBuf {
    if let Some(path) = &cli.setup_code_file {
        return path.clone();
    }
    match cli.config.as_deref().and_then(Path::parent) {
        Some(dir) => dir.join(SETUP_CODE_FILE),
        None => PathBuf::from(SETUP_CODE_FILE),
    }
}

/// A new setup code from the operating system's random source; `None`
/// (no administrator can be created, said in the log) if it cannot be
/// read: a code from the clock could be guessed.
fn new_setup_code() -> Option<SetupCode> {
    let mut random = [0u8; SETUP_CODE_LEN];
    match os_random(&mut random) {
        Ok(()) => Some(SetupCode::from_random(random)),
        Err(e) => {
            log::error!(
                "no setup code (the random source /dev/urandom: {e}): no administrator can be created in this run"
            );
            None
        }
    }
}

/// Writes `code` to `path` (readable by its owner only, replacing the code
/// of the run before) and says on stderr, whatever the log level, where
/// it is: the code itself never goes to stderr (the journal, which more
/// than root may read), only to its file. A file that cannot be written is
/// said in the same line: no administrator can be created in this run.
fn publish_setup_code(code: &SetupCode, path: &Path) {
    let line = match FileStorage::write_durably(path, format!("{code}\n").as_bytes()) {
        Ok(()) => format!(
            "setup code for the first administrator: in {} (readable by its owner only)",
            path.display()
        ),
        Err(e) => format!(
            "no setup code in this run: {} could not be written ({e}); no administrator can be created until it can",
            path.display()
        ),
    };
    say(&line);
}

/// A line on stderr, `hans-gateway: ` first; a failure to write it is
/// ignored (there is nowhere else to say it).
/// SIGTERM (systemd's stop) and SIGINT (Ctrl-C), taken from the process's
/// default (which ended it at once: what the audit log's counting periods
/// had counted was lost, and no `stop` record said the end was ordered).
/// The first stops the gateway in order ([`Stopper::stop`]: the gateway
/// records the stop and keeps its last records, at most 5 s); a second
/// one while it stops ends the process at once (status 130 or 143).
/// tokio's signal handling, on a thread of its own.
struct StopSignals {
    rt: tokio::runtime::Runtime,
    term: tokio::signal::unix::Signal,
    int: tokio::signal::unix::Signal,
}

impl StopSignals {
    /// Takes the signals now: one that arrives before [`Self::stop`]
    /// waits for it.
    fn take() -> std::io::Result<StopSignals> {
        use tokio::signal::unix::{signal, SignalKind};
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_io()
            .build()?;
        let (term, int) = {
            let _in = rt.enter();
            (
                signal(SignalKind::terminate())?,
                signal(SignalKind::interrupt())?,
            )
        };
        Ok(StopSignals { rt, term, int })
    }

    /// Stops the gateway of `stopper` at the first signal (on a thread of
    /// its own).
    fn stop(self, stopper: Stopper) -> std::io::Result<()> {
        let StopSignals {
            rt,
            mut term,
            mut int,
        } = self;
        std::thread::Builder::new()
            .name(String::from("signals"))
            .spawn(move || {
                rt.block_on(async move {
                    let why = tokio::select! {
                        _ = term.recv() => "SIGTERM",
                        _ = int.recv() => "SIGINT",
                    };
                    log::info!("{why}: stopping (a second signal ends the process at once)");
                    stopper.stop(why);
                    let status = tokio::select! {
                        _ = term.recv() => 128 + 15,
                        _ = int.recv() => 128 + 2,
                    };
                    say("a second stop signal: ending at once");
                    std::process::exit(status);
                })
            })?;
        Ok(())
    }
}

fn say(line: &str) {
    let _ = writeln!(std::io::stderr(), "hans-gateway: {line}");
}

/// Resolves the addresses of the command line (host names too).
fn host_options(cli: Cli) -> Result<HostOptions, String> {
    let resolve = |option: &str, e: &Endpoint| -> Result<SocketAddrV4, String> {
        let addr = e
            .resolve()
            .map_err(|why| format!("--{option} {e}: {why}"))?;
        if e.host.parse::<Ipv4Addr>().is_err() {
            log::info!("--{option} {e} resolves to {addr}");
        }
        Ok(addr)
    };
    Ok(HostOptions {
        modbus_listen: resolve("modbus-listen", &cli.modbus_listen)?,
        robot: cli
            .robot
            .as_ref()
            .map(|e| resolve("robot", e))
            .transpose()?,
        robot_listen: cli
            .robot_listen
            .as_ref()
            .map(|e| resolve("robot-listen", e))
            .transpose()?,
        web_listen: cli
            .web_listen
            .as_ref()
            .map(|e| resolve("web-listen", e))
            .transpose()?,
        config_file: cli.config,
        defaults: hans_gateway::Config::default(),
        setup_code: None,
        mqtt: match &cli.mqtt {
            Some((tls, e)) => Some(MqttOverride {
                broker: HostName::new(&e.host)
                    .ok_or_else(|| format!("--mqtt {e}: not a host name or an IPv4 address"))?,
                port: e.port,
                tls: *tls,
            }),
            None => None,
        },
        mqtt_ca: cli.mqtt_ca.clone(),
        mqtt_login: match (&cli.mqtt_user, &cli.mqtt_password_file) {
            (Some(user), Some(file)) => Some(mqtt_login(user, file)?),
            _ => None,
        },
        node_name: host_name(),
        web_tls: cli.web_tls.as_deref().and_then(identity),
        modbus_tls: match (
            &cli.modbus_tls_listen,
            cli.modbus_tls.as_deref(),
            &cli.modbus_tls_ca,
        ) {
            (Some(e), Some(files), Some(ca)) => Some(hans_gateway_linux::ModbusTls {
                listen: resolve("modbus-tls-listen", e)?,
                identity: identity(files).ok_or("--modbus-tls: CERT and KEY are needed")?,
                client_ca: ca.clone(),
            }),
            _ => None,
        },
        enip: match &cli.enip_listen {
            Some(e) => Some(hans_gateway_linux::EnipListen {
                listen: resolve("enip-listen", e)?,
                io_port: cli.enip_io_port,
            }),
            None => None,
        },
    })
}

/// `--web-tls` / `--modbus-tls` CERT KEY (clap takes exactly two).
fn identity(files: &[PathBuf]) -> Option<hans_gateway_linux::TlsIdentity> {
    match files {
        [cert, key] => Some(hans_gateway_linux::TlsIdentity {
            cert: cert.clone(),
            key: key.clone(),
        }),
        _ => None,
    }
}

/// The broker's login: `user`, and the first line of `file` as the
/// password. A file others may read is refused (the password would be
/// theirs too).
fn mqtt_login(user: &str, file: &Path) -> Result<hans_gateway::mqtt::Login, String> {
    use std::os::unix::fs::MetadataExt;
    let name = HostName::new(user).ok_or_else(|| {
        format!("--mqtt-user {user:?}: letters, digits, '.', '-', '_', ':' only, up to 63")
    })?;
    let meta = std::fs::metadata(file)
        .map_err(|e| format!("--mqtt-password-file {}: {e}", file.display()))?;
    if meta.mode() & 0o077 != 0 {
        return Err(format!(
            "--mqtt-password-file {}: readable by others (mode {:o}): chmod 600 it",
            file.display(),
            meta.mode() & 0o777
        ));
    }
    let text = std::fs::read_to_string(file)
        .map_err(|e| format!("--mqtt-password-file {}: {e}", file.display()))?;
    let password = text.lines().next().unwrap_or("");
    hans_gateway::mqtt::Login::new(name, password.as_bytes()).ok_or_else(|| {
        format!(
            "--mqtt-password-file {}: the first line must be 1 to {} printable ASCII characters",
            file.display(),
            hans_gateway::mqtt::Login::PASSWORD_MAX
        )
    })
}

/// This machine's host name (the Sparkplug edge node id when the
/// configuration names none), from the kernel; `hans-gateway` if it has
/// none a Sparkplug id may hold.
fn host_name() -> HostName {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .and_then(|n| HostName::new(n.trim()).filter(|h| (1..=32).contains(&h.as_str().len())))
        .unwrap_or_else(|| HostName::new("hans-gateway").unwrap_or(HostName::EMPTY))
}

/// The warning for a gateway that will connect to no robot: neither
/// `--robot` nor `--robot-listen`, and a configuration in connect mode
/// whose robot address is 0.0.0.0 (the factory state, and the systemd
/// unit's start). It serves the PLC and the page meanwhile, and connects
/// once an address is set.
fn no_robot(cli: &Cli, config: &hans_gateway::Config) -> Option<String> {
    let connect = config.link_mode == hans_gateway::config::LinkMode::Connect;
    if cli.robot.is_some() || cli.robot_listen.is_some() || !connect {
        return None;
    }
    if !config.robot_ip.is_unspecified() {
        return None;
    }
    let file = cli
        .config
        .as_deref()
        .map_or(String::new(), |p| format!(" in {}", p.display()));
    Some(format!(
        "no robot address configured (robot.address is 0.0.0.0{file}): the gateway serves \
         the PLC and the page but connects to no robot until one is set: on the web page \
         (Configuration: Robot address), in the file ([robot] address = \"HOST\"), over Modbus \
         (CFG_ROBOT_IP, then CONFIG_COMMAND 1), or with --robot HOST[:PORT]"
    ))
}

/// Checks the configuration file before anything starts: a file that is
/// refused prints one `hans-gateway: FILE:LINE:COLUMN: reason` line per
/// problem and gives status 2 (like a bad command line: the operator must
/// fix it), one that cannot be read status 1 (the environment). Returns
/// the configuration the gateway starts from (the file's, or the defaults).
fn check_config_file(cli: &Cli) -> Result<hans_gateway::Config, ExitCode> {
    let defaults = hans_gateway::Config::default();
    let Some(path) = &cli.config else {
        return Ok(defaults);
    };
    match config_file::read_file(path, &defaults) {
        Ok(Some((contents, _))) => Ok(contents.stored.config),
        Ok(None) => {
            log::info!(
                "config: {} does not exist yet: defaults; the first save creates it",
                path.display()
            );
            Ok(defaults)
        }
        Err(e) => {
            for line in e.to_string().lines() {
                eprintln!("hans-gateway: {line}");
            }
            Err(match e.error {
                FileProblem::Io(_) => ExitCode::FAILURE,
                FileProblem::Toml(_) | FileProblem::Image(_) => ExitCode::from(2),
            })
        }
    }
}

fn main() -> ExitCode {
    let cli = command_line();
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("info"))
        .format_timestamp_millis()
        .init();
    let config = match check_config_file(&cli) {
        Ok(c) => c,
        Err(code) => return code,
    };
    let no_robot = no_robot(&cli, &config);
    let code_file = setup_code_path(&cli);
    let web_tls = cli.web_tls.is_some();
    // A name that does not resolve is an environment the gateway cannot
    // start in (DNS not up yet, a missing hosts entry), like a port that
    // cannot be bound: status 1, which a supervisor may retry; the command
    // line itself was well formed.
    let mut opts = match host_options(cli) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("hans-gateway: {e}");
            return ExitCode::FAILURE;
        }
    };
    opts.setup_code = new_setup_code();
    if let Some(a) = opts.robot {
        log::info!("robot controller at {a}");
    }
    let setup_code = opts.setup_code;
    // From here a SIGTERM or SIGINT waits for the gateway to be up, and
    // then stops it in order.
    let signals = match StopSignals::take() {
        Ok(s) => s,
        Err(e) => {
            eprintln!("hans-gateway: the stop signals (SIGTERM, SIGINT) cannot be handled: {e}");
            return ExitCode::FAILURE;
        }
    };
    let gw = match RunningGateway::start(opts) {
        Ok(g) => g,
        Err(e) => {
            eprintln!("hans-gateway: {e}");
            return ExitCode::FAILURE;
        }
    };
    if let Err(e) = signals.stop(gw.stopper()) {
        eprintln!("hans-gateway: the stop signals (SIGTERM, SIGINT) cannot be handled: {e}");
        return ExitCode::FAILURE;
    }
    log::info!("modbus server on {}", gw.modbus_addr());
    if let Some(a) = gw.robot_listen_addr() {
        log::info!("waiting for the robot controller on {a}");
    }
    if let Some(a) = gw.web_addr() {
        let scheme = if web_tls { "https" } else { "http" };
        log::info!("web page on {scheme}://{a}/");
    }
    if let Some(a) = gw.modbus_tls_addr() {
        log::info!("modbus/tcp security (TLS, client certificates) on {a}");
    }
    if let Some(warning) = no_robot {
        log::warn!("{warning}");
    }
    // Shown once the gateway runs: a start that fails shows no code.
    if let Some(code) = &setup_code {
        publish_setup_code(code, &code_file);
    }
    // Runs until the process is stopped (SIGINT/SIGTERM end it; sockets
    // are closed by the OS), or until the gateway fails: then the process
    // must end too, with a failure status for a supervisor to restart it,
    // rather than live on serving nothing.
    match gw.wait() {
        Ok(Stopped { kept: true }) => {
            log::info!("stopped; the audit log's last records are kept");
            ExitCode::SUCCESS
        }
        Ok(Stopped { kept: false }) => {
            say("stopped, but the audit log's last records could not be kept in time");
            ExitCode::FAILURE
        }
        Err(e) => {
            say(&format!(
                "{e}: exiting with status {FAILED_RUNNING} (nothing is served any more)"
            ));
            ExitCode::from(FAILED_RUNNING)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn robot(s: &str) -> Result<(String, u16), String> {
        robot_endpoint(s).map(|e| (e.host, e.port))
    }

    #[test]
    fn robot_takes_a_name_or_an_ipv4_address_with_or_without_a_port() {
        let ok = |h: &str, p| Ok((h.to_string(), p));
        assert_eq!(robot("robot.local"), ok("robot.local", 10003));
        assert_eq!(robot("robot.local:4000"), ok("robot.local", 4000));
        assert_eq!(robot("localhost:0"), ok("localhost", 0));
        assert_eq!(robot("192.168.0.10"), ok("192.168.0.10", 10003));
        assert_eq!(robot("192.168.0.10:10003"), ok("192.168.0.10", 10003));
    }

    #[test]
    fn malformed_addresses_are_refused_with_the_reason() {
        for (s, why) in [
            ("robot.local:", "not a port number"),
            ("robot.local:65536", "not a port number"),
            (":10003", "not a host name"),
            ("two words:10003", "not a host name"),
            ("[::1]:10003", "IPv6"),
            ("::1", "IPv6"),
            ("[::1]", "IPv6"),
        ] {
            let err = robot(s).expect_err(s);
            assert!(err.contains(why), "{s}: {err}");
        }
        let err = listen_endpoint("0.0.0.0").expect_err("no port");
        assert!(err.contains("a port is needed"), "{err}");
    }

    #[test]
    fn an_ipv4_address_needs_no_resolver_and_localhost_resolves_to_ipv4() {
        let e = robot_endpoint("10.1.2.3").expect("form");
        assert_eq!(
            e.resolve(),
            Ok(SocketAddrV4::new(Ipv4Addr::new(10, 1, 2, 3), 10003))
        );
        let e = robot_endpoint("localhost").expect("form");
        let addr = e.resolve().expect("localhost resolves");
        assert!(addr.ip().is_loopback(), "{addr}");
        assert_eq!(addr.port(), 10003);
    }

    /// clap's own consistency checks of the definition (names, groups,
    /// conflicts), which it otherwise runs only in debug builds at parse time.
    #[test]
    fn the_command_definition_is_consistent() {
        command().debug_assert();
    }
}
