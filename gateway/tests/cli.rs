//! The `hans-gateway` binary's command line: help, version, usage errors,
//! host names for `--robot`, and what it says when `--robot` overrides a
//! saved robot address.
//! Loopback only; every process is killed at the end, also on failure, and
//! every wait is bounded.

use std::io::{BufRead, BufReader, Read};
use std::net::{Ipv4Addr, TcpListener};
use std::process::{Child, ChildStderr, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use hans_gateway::registers::MAP_VERSION;
use hans_gateway::state::Text;
use hans_gateway::storage::{image, IMAGE_LEN};
use hans_gateway::Config;

const BIN: &str = env!("CARGO_BIN_EXE_hans-gateway");

/// Longest wait for anything here (generous: the machine is shared).
const WAIT: Duration = Duration::from_secs(20);

/// How a run that ends by itself ended.
#[derive(Debug)]
struct Ended {
    code: Option<i32>,
    stdout: String,
    stderr: String,
}

/// Runs the gateway with `args` until it exits by itself; fails the test
/// (killing it) if it is still running after [`WAIT`].
fn run(args: &[&str]) -> Ended {
    let child = Command::new(BIN)
        .args(args)
        .env("RUST_LOG", "info")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run hans-gateway");
    let mut gw = Running(child);
    let start = Instant::now();
    let status = loop {
        if let Some(status) = gw.0.try_wait().expect("wait for hans-gateway") {
            break status;
        }
        assert!(
            start.elapsed() < WAIT,
            "hans-gateway {args:?} still running after {WAIT:?}"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    // What it wrote is in the pipes (far less than a pipe holds).
    let mut stdout = String::new();
    let mut stderr = String::new();
    if let Some(mut o) = gw.0.stdout.take() {
        o.read_to_string(&mut stdout).expect("read stdout");
    }
    if let Some(mut e) = gw.0.stderr.take() {
        e.read_to_string(&mut stderr).expect("read stderr");
    }
    Ended {
        code: status.code(),
        stdout,
        stderr,
    }
}

/// Finding: `--help` printed one usage line to stderr and exited 2.
#[test]
fn help_and_version_print_to_stdout_and_exit_0() {
    let out = run(&["--help"]);
    let text = &out.stdout;
    assert_eq!(out.code, Some(0), "--help: {out:?}");
    for needle in [
        "--modbus-listen",
        "--robot ",
        "--robot-listen",
        "--config FILE",
        "trigger entries",
        "CONFIG_RESULT 3",
        "Exit status",
        "RUST_LOG",
    ] {
        assert!(text.contains(needle), "help lacks {needle:?}:\n{text}");
    }
    assert!(out.stderr.is_empty(), "help on stderr");
    let short = run(&["-h"]);
    assert_eq!(short.code, Some(0));
    assert_eq!(short.stdout, out.stdout, "-h and --help print the same");
    for flag in ["--version", "-V"] {
        let out = run(&[flag]);
        assert_eq!(out.code, Some(0), "{flag}: {out:?}");
        assert!(out.stderr.is_empty(), "{flag} on stderr");
    }
}

/// Item 6 of issue 10: `--version` printed the crate version alone, while the
/// VERSION register holds the register map's. It names both, the map's as
/// `major.minor` of `MAP_VERSION` (major x 256 + minor).
#[test]
fn version_names_the_gateway_and_the_register_map() {
    let want = format!(
        "hans-gateway {} (register map {}.{})\n",
        env!("CARGO_PKG_VERSION"),
        MAP_VERSION >> 8,
        MAP_VERSION & 0xFF
    );
    for flag in ["--version", "-V"] {
        assert_eq!(run(&[flag]).stdout, want, "{flag}");
    }
    // The form, independently of the numbers.
    let line = want.trim_end();
    let (name, rest) = line.split_once(' ').expect("name and version");
    let (crate_version, map) = rest.split_once(" (register map ").expect("map version");
    assert_eq!(name, "hans-gateway");
    assert_eq!(crate_version.split('.').count(), 3, "{line}");
    let (major, minor) = map
        .strip_suffix(')')
        .and_then(|m| m.split_once('.'))
        .expect("major.minor)");
    assert!(
        major.parse::<u8>().is_ok() && minor.parse::<u8>().is_ok(),
        "{line}"
    );
}

/// A bad command line is clap's usage error: exit 2, the reason, the usage
/// and a pointer to `--help`, all on stderr.
#[test]
fn a_bad_command_line_exits_2_with_the_reason() {
    for (args, why) in [
        (&["--bogus"][..], "unexpected argument '--bogus'"),
        (
            &["--robot", "127.0.0.1:1"][..],
            "required arguments were not provided:\n  --modbus-listen",
        ),
        (&["--modbus-listen", "127.0.0.1:0"][..], "no robot given"),
        (&["--robot"][..], "a value is required for '--robot"),
        (
            &[
                "--robot",
                "127.0.0.1:1",
                "--robot-listen",
                "127.0.0.1:0",
                "--modbus-listen",
                "127.0.0.1:0",
            ][..],
            "'--robot <HOST[:PORT]>' cannot be used with '--robot-listen",
        ),
        (
            &[
                "--robot",
                "127.0.0.1:99999",
                "--modbus-listen",
                "127.0.0.1:0",
            ][..],
            "\"99999\" is not a port number",
        ),
        (
            &["--robot", "[::1]:10003", "--modbus-listen", "127.0.0.1:0"][..],
            "IPv6 addresses are not supported",
        ),
        (
            &["--robot", "127.0.0.1", "--modbus-listen", "127.0.0.1"][..],
            "a port is needed",
        ),
    ] {
        let out = run(args);
        let err = &out.stderr;
        assert_eq!(out.code, Some(2), "{args:?}: {out:?}");
        assert!(err.contains(why), "{args:?}: {err}");
        assert!(err.contains("--help"), "{args:?}: {err}");
        assert!(out.stdout.is_empty(), "{args:?}: {out:?}");
    }
}

/// A name that does not resolve is not a bad command line (status 2) but an
/// environment the gateway cannot start in, like a port it cannot bind:
/// status 1, with the option, the name and the resolver's reason. `.invalid`
/// never resolves (RFC 6761).
#[test]
fn an_unresolvable_robot_name_exits_1_with_the_reason() {
    let out = run(&["--robot", "robot.invalid", "--modbus-listen", "127.0.0.1:0"]);
    assert_eq!(out.code, Some(1), "{out:?}");
    let err = &out.stderr;
    assert!(
        err.contains("--robot robot.invalid:10003: cannot resolve the host name \"robot.invalid\""),
        "{err}"
    );
}

/// `--robot localhost:PORT`: the name is resolved at start and the gateway
/// connects to the address it gives.
#[test]
fn a_host_name_is_accepted_for_robot() {
    let robot = TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).expect("bind the robot's port");
    let port = robot.local_addr().expect("robot address").port();
    let target = format!("localhost:{port}");
    let (gw, log) = start(&["--robot", &target, "--modbus-listen", "127.0.0.1:0"]);
    robot.set_nonblocking(true).expect("non-blocking accept");
    let start = Instant::now();
    let peer = loop {
        match robot.accept() {
            Ok((_, peer)) => break peer,
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                assert!(
                    start.elapsed() < WAIT,
                    "the gateway never connected to {target}"
                );
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(e) => panic!("accept: {e}"),
        }
    };
    assert!(peer.ip().is_loopback(), "{peer}");
    let line = log.wait_for("resolves to");
    assert!(
        line.contains(&format!("--robot {target} resolves to 127.0.0.1:{port}")),
        "{line}"
    );
    drop(gw);
}

/// `--robot localhost` without a port means the controller's port 10003.
/// Checked without touching 10003 (another program may use it): the Modbus
/// address is taken, so the gateway resolves the robot's name, says where it
/// would connect, then cannot bind and exits 1 before any connection.
#[test]
fn a_robot_name_without_a_port_means_10003() {
    let taken = TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).expect("bind a port");
    let modbus = taken.local_addr().expect("address").to_string();
    let out = run(&["--robot", "localhost", "--modbus-listen", &modbus]);
    assert_eq!(out.code, Some(1), "{out:?}");
    assert!(
        out.stderr
            .contains("--robot localhost:10003 resolves to 127.0.0.1:10003"),
        "{}",
        out.stderr
    );
    drop(taken);
}

/// Kills the child when dropped (also when an assertion fails).
struct Running(Child);

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Finding M6: `--robot` silently replaced a saved robot address. It
/// still wins (the operator asked for it), and the log says so, naming the
/// saved setting.
#[test]
fn robot_on_the_command_line_overrides_a_saved_one_and_says_so() {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    let path = std::env::temp_dir().join(format!("hans-gw-cli-{}-{nanos}.cfg", std::process::id()));
    let saved = Config {
        robot_ip: Ipv4Addr::new(10, 9, 8, 7),
        robot_port: 4321,
        ..Config::default()
    };
    let mut bytes = [0u8; IMAGE_LEN];
    let stored = image::Stored {
        config: saved,
        password: None,
    };
    image::encode(&stored, &[Text::EMPTY; 16], &mut bytes).expect("room for the image");
    std::fs::write(&path, bytes).expect("write the config file");
    let (gw, log) = start(&[
        "--config",
        path.to_str().expect("utf-8 path"),
        // Nothing listens on port 1 of the loopback: the link stays down.
        "--robot",
        "127.0.0.1:1",
        "--modbus-listen",
        "127.0.0.1:0",
    ]);
    let found = log.wait_for("overrides the saved one");
    drop(gw);
    let _ = std::fs::remove_file(&path);
    assert!(found.contains("WARN"), "{found}");
    assert!(found.contains("10.9.8.7:4321"), "{found}");
}

/// The gateway's log lines (stderr), read by a thread as they come.
struct Log {
    lines: mpsc::Receiver<String>,
}

impl Log {
    fn new(stderr: ChildStderr) -> Log {
        let (tx, lines) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines() {
                let Ok(line) = line else { break };
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        Log { lines }
    }

    /// The first line containing `needle`; fails the test after [`WAIT`].
    fn wait_for(&self, needle: &str) -> String {
        let start = Instant::now();
        let mut seen = Vec::new();
        loop {
            let left = WAIT.saturating_sub(start.elapsed());
            match self.lines.recv_timeout(left) {
                Ok(line) if line.contains(needle) => return line,
                Ok(line) => seen.push(line),
                Err(_) => panic!("no {needle:?} in the log: {seen:#?}"),
            }
        }
    }
}

/// Starts the gateway with `args` (log level info), to run until dropped.
fn start(args: &[&str]) -> (Running, Log) {
    let child = Command::new(BIN)
        .args(args)
        .env("RUST_LOG", "info")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start hans-gateway");
    let mut gw = Running(child);
    let log = Log::new(gw.0.stderr.take().expect("stderr"));
    (gw, log)
}
