//! The `hans-gateway` binary's command line: help, version, usage errors,
//! host names for `--robot`, what it says when `--robot` overrides a
//! saved robot address, and the TOML configuration file (`--config`): a
//! refused file stops the start, a hand-written one is used, a save writes
//! TOML that reads back, readable by its owner only; the setup code; the
//! exit status when the running gateway fails.
//! Loopback only; every process is killed at the end, also on failure, and
//! every wait is bounded. Each run has a fresh current directory, and each
//! file its own directory (the setup code is written beside the
//! configuration file, or in the current directory).

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{Ipv4Addr, TcpListener, TcpStream};
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStderr, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use hans_gateway::registers::map as reg;
use hans_gateway::registers::MAP_VERSION;
use hans_gateway::state::Text;
use hans_gateway::storage::{image, IMAGE_LEN};
use hans_gateway::{Config, SetupCode};
use hans_gateway_linux::config_file::{self, Format};

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
    let cwd = TempDir::new("cwd");
    let child = Command::new(BIN)
        .args(args)
        .current_dir(&cwd.0)
        .env("RUST_LOG", "info")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run hans-gateway");
    let mut gw = Running(child, cwd);
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
        "TOML",
        "FILE:LINE:COLUMN: reason",
        "salted hash",
        "Exit status",
        "RUST_LOG",
        "--setup-code-file FILE",
        "setup code",
        "mode 0600",
        "101",
        "linux/dist/hans-gateway.service",
        "the web page's accounts",
    ] {
        assert!(text.contains(needle), "help lacks {needle:?}:\n{text}");
    }
    // Issue 27: the help spoke of "the web password" (there are accounts
    // now) and left [mqtt] out of the file's tables. It names every table
    // of the settings this build has.
    assert!(!text.contains("web password"), "{text}");
    for s in hans_gateway::config::SETTINGS {
        let table = format!("[{}]", s.group());
        assert!(
            text.contains(&table),
            "help lacks the table {table}:\n{text}"
        );
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

/// Issue 27: a listener that could not listen said `Address already in use
/// (os error 98)` and nothing of which. Each names its option, the address
/// and what usually helps; status 1, nothing served.
#[test]
fn a_listener_that_cannot_listen_names_its_option_and_address() {
    let taken = TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).expect("bind a port");
    let addr = taken.local_addr().expect("address").to_string();
    for (option, what, args) in [
        (
            "--modbus-listen",
            "the Modbus TCP server",
            vec!["--robot", "127.0.0.1:1", "--modbus-listen", &addr],
        ),
        (
            "--web-listen",
            "the web page",
            vec![
                "--robot",
                "127.0.0.1:1",
                "--modbus-listen",
                "127.0.0.1:0",
                "--web-listen",
                &addr,
            ],
        ),
        (
            "--robot-listen",
            "the robot's connection",
            vec!["--robot-listen", &addr, "--modbus-listen", "127.0.0.1:0"],
        ),
    ] {
        let out = run(&args);
        assert_eq!(out.code, Some(1), "{option}: {out:?}");
        let want = format!(
            "hans-gateway: {option} {addr}: {what} cannot listen there: Address already in use"
        );
        assert!(out.stderr.contains(&want), "{option}: {}", out.stderr);
        assert!(
            out.stderr.contains("another program listens on that port"),
            "{option}: {}",
            out.stderr
        );
        assert!(!out.stderr.contains("modbus server on"), "{}", out.stderr);
    }
    drop(taken);
}

/// Issue 27: the systemd unit starts the gateway with a configuration file
/// and no robot, and nothing said that it would connect to none. It warns,
/// saying where to set one; with a robot given or configured it does not.
#[test]
fn a_gateway_without_a_robot_address_warns_that_it_connects_to_none() {
    let file = TempFile::new("fresh.toml");
    let (gw, log) = start(&["--config", file.arg(), "--modbus-listen", "127.0.0.1:0"]);
    let line = log.wait_for("no robot address configured");
    assert!(line.contains("WARN"), "{line}");
    assert!(line.contains(file.arg()), "{line}");
    for place in [
        "web page",
        "[robot] address",
        "CFG_ROBOT_IP",
        "--robot HOST",
    ] {
        assert!(line.contains(place), "{place}: {line}");
    }
    drop(gw);
    // A robot on the command line, or in the file: no warning (it would
    // come before the setup code's line).
    let named = TempFile::new("named.toml");
    std::fs::write(&named.0, "[robot]\naddress = \"127.0.0.1\"\nport = 1\n").expect("write");
    for args in [
        vec![
            "--config",
            file.arg(),
            "--robot",
            "127.0.0.1:1",
            "--modbus-listen",
            "127.0.0.1:0",
        ],
        vec!["--config", named.arg(), "--modbus-listen", "127.0.0.1:0"],
    ] {
        let (gw, log) = start(&args);
        log.wait_for("setup code for the first administrator");
        let seen = log.seen.borrow();
        assert!(
            !seen.iter().any(|l| l.contains("no robot address")),
            "{args:?}: {seen:#?}"
        );
        drop(seen);
        drop(gw);
    }
}

/// Kills the child when dropped (also when an assertion fails), then
/// removes its current directory.
struct Running(Child, TempDir);

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A fresh directory in the temporary directory (removed with what it
/// holds when dropped).
struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> TempDir {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_nanos())
            .unwrap_or(0);
        let dir = format!("hans-gw-cli-{}-{nanos}-{name}", std::process::id());
        let dir = std::env::temp_dir().join(dir);
        std::fs::create_dir(&dir).expect("create a temporary directory");
        TempDir(dir)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A fresh path, alone in its own temporary directory (removed when
/// dropped, with the files written beside it).
struct TempFile(PathBuf, TempDir);

impl TempFile {
    fn new(name: &str) -> TempFile {
        let dir = TempDir::new("dir");
        TempFile(dir.0.join(name), dir)
    }

    fn arg(&self) -> &str {
        self.0.to_str().expect("utf-8 path")
    }
}

/// `path`'s permission bits.
fn mode(path: &Path) -> u32 {
    let meta = std::fs::metadata(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    meta.permissions().mode() & 0o777
}

fn set_mode(path: &Path, mode: u32) {
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode)).expect("chmod");
}

/// The binary image (the format that older versions wrote and the
/// gateway still reads) of the configuration `toml` describes.
fn binary_image(toml: &str) -> Vec<u8> {
    let file = TempFile::new("source.toml");
    std::fs::write(&file.0, toml).expect("write the TOML source");
    let (contents, _) = config_file::read_file(&file.0, &Config::default())
        .expect("a valid file")
        .expect("a file");
    let mut bytes = [0u8; IMAGE_LEN];
    let n = image::encode(&contents.stored, &contents.triggers, &mut bytes)
        .expect("room for the image");
    bytes[..n].to_vec()
}

/// Finding M6: `--robot` silently replaced a saved robot address. It
/// still wins (the operator asked for it), and the log says so, naming the
/// saved setting.
#[test]
fn robot_on_the_command_line_overrides_a_saved_one_and_says_so() {
    let file = TempFile::new("override.toml");
    std::fs::write(&file.0, "[robot]\naddress = \"10.9.8.7\"\nport = 4321\n")
        .expect("write the config file");
    let (gw, log) = start(&[
        "--config",
        file.arg(),
        // Nothing listens on port 1 of the loopback: the link stays down.
        "--robot",
        "127.0.0.1:1",
        "--modbus-listen",
        "127.0.0.1:0",
    ]);
    let found = log.wait_for("overrides the saved one");
    drop(gw);
    assert!(found.contains("WARN"), "{found}");
    assert!(found.contains("10.9.8.7:4321"), "{found}");
}

/// A malformed or invalid file is refused before anything starts: status
/// 2, one `hans-gateway: FILE:LINE:COLUMN: reason` line per problem, and
/// no Modbus server (the process ends by itself, never saying it serves).
#[test]
fn a_refused_config_file_stops_the_start_with_its_line_and_status_2() {
    let file = TempFile::new("bad.toml");
    let path = file.arg();
    let mut damaged = binary_image("");
    damaged[50] ^= 1;
    for (contents, want) in [
        (
            &b"# my gateway\n[link]\npoll_ms = 5\n[robot]\nadress = \"10.0.0.1\"\n"[..],
            vec![
                format!("hans-gateway: {path}:3:11: link.poll_ms = 5: out of range, CFG_POLL_MS takes 10-100 ms"),
                format!("hans-gateway: {path}:5:1: unknown key \"adress\" in [robot]"),
            ],
        ),
        (
            &b"[robot]\naddress = \"10.0.0.1\n"[..],
            vec![format!("hans-gateway: {path}:2:")],
        ),
        (
            &b"[access]\npassword = \"secret123\"\n"[..],
            vec![format!("hans-gateway: {path}:2:12: access.password: not a salted hash")],
        ),
        (
            &damaged[..],
            vec![format!("hans-gateway: {path}: a binary configuration image of an older version, refused: CRC mismatch")],
        ),
    ] {
        std::fs::write(&file.0, contents).expect("write the config file");
        let out = run(&[
            "--config",
            path,
            "--robot",
            "127.0.0.1:1",
            "--modbus-listen",
            "127.0.0.1:0",
        ]);
        assert_eq!(out.code, Some(2), "{out:?}");
        let errors: Vec<&str> = out
            .stderr
            .lines()
            .filter(|l| l.starts_with("hans-gateway: "))
            .collect();
        assert_eq!(errors.len(), want.len(), "{}", out.stderr);
        for (line, want) in errors.iter().zip(&want) {
            assert!(line.starts_with(want.as_str()), "{line}\nwanted {want}");
        }
        assert!(!out.stderr.contains("modbus server on"), "{}", out.stderr);
        assert!(out.stdout.is_empty(), "{out:?}");
    }
    // The file is left as it was.
    assert_eq!(std::fs::read(&file.0).expect("read"), damaged);
}

/// A file written by hand, without `--robot`: the gateway connects to the
/// robot it names and shows its settings in the registers.
#[test]
fn a_hand_written_config_file_is_used() {
    let robot = TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).expect("bind the robot's port");
    let port = robot.local_addr().expect("robot address").port();
    let file = TempFile::new("hand.toml");
    std::fs::write(
        &file.0,
        format!(
            "# The gateway of cell 3.\n\n[robot]\naddress = \"127.0.0.1\"  # the controller\nport = {port}\n\n[link]\npoll_ms = 40\n\n[access]\nmodbus_allow = [\"127.0.0.0/8\"]\n\n[triggers]\n2 = \"GrpStop,0,;\"\n"
        ),
    )
    .expect("write the config file");
    let (gw, log) = start(&["--config", file.arg(), "--modbus-listen", "127.0.0.1:0"]);
    let modbus = modbus_addr(&log);
    accept_within(&robot, WAIT);
    assert_eq!(read_registers(&modbus, reg::CONFIG_POLL_MS, 1), [40]);
    assert_eq!(read_registers(&modbus, reg::CONFIG_ROBOT_PORT, 1), [port]);
    let allow = read_registers(&modbus, reg::MODBUS_ALLOW, 3);
    assert_eq!(allow, [0x7F00, 0, 8]);
    let text = read_registers(&modbus, reg::TRIG_TEXT_BASE + 2 * reg::TRIG_TEXT_STRIDE, 6);
    let bytes: Vec<u8> = text.iter().flat_map(|w| w.to_be_bytes()).collect();
    assert_eq!(&bytes[..11], b"GrpStop,0,;");
    drop(gw);
}

/// A save over Modbus (CONFIG_COMMAND 1) writes TOML, also over the binary
/// image an older version wrote, and a new start reads it back.
#[test]
fn a_save_over_modbus_writes_toml_that_reads_back() {
    let file = TempFile::new("saved.toml");
    let mut triggers = [Text::EMPTY; 16];
    triggers[4].set(b"GrpStop,0,;");
    let old = binary_image("[link]\npoll_ms = 30\n\n[triggers]\n4 = \"GrpStop,0,;\"\n");
    std::fs::write(&file.0, old).expect("write the old image");
    // Written as every user may read it, as `std::fs::write` makes files.
    set_mode(&file.0, 0o644);

    let args = [
        "--config",
        file.arg(),
        "--robot",
        "127.0.0.1:1",
        "--modbus-listen",
        "127.0.0.1:0",
    ];
    let (gw, log) = start(&args);
    log.wait_for("binary image of an older version");
    let modbus = modbus_addr(&log);
    assert_eq!(read_registers(&modbus, reg::CONFIG_POLL_MS, 1), [30]);
    write_register(&modbus, reg::CONFIG_POLL_MS, 60);
    write_register(&modbus, reg::CONTROL_CONFIG_COMMAND, 1);
    assert_eq!(read_registers(&modbus, reg::CONTROL_CONFIG_RESULT, 1), [0]);
    drop(gw);

    let text = std::fs::read_to_string(&file.0).expect("the file is text now");
    // It holds password hashes: readable by its owner only ("secure by
    // default": it was written with the umask's 0644 and kept it).
    assert_eq!(mode(&file.0), 0o600, "the saved file's permissions");
    for needle in [
        "# hans-gateway configuration (TOML)",
        "\npoll_ms = 60\n",
        "\n4 = \"GrpStop,0,;\"\n",
        // The robot given at start is what a save stores.
        "\naddress = \"127.0.0.1\"\n",
        "\nport = 1\n",
    ] {
        assert!(text.contains(needle), "{needle:?} not in\n{text}");
    }
    let (read, format) = config_file::read_file(&file.0, &Config::default())
        .expect("valid")
        .expect("exists");
    assert_eq!(format, Format::Toml);
    assert_eq!(read.stored.config.poll_ms, 60);
    assert_eq!(read.triggers, triggers);

    let (gw, log) = start(
        &args[..2]
            .iter()
            .chain(&args[4..])
            .copied()
            .collect::<Vec<_>>(),
    );
    let modbus = modbus_addr(&log);
    assert_eq!(read_registers(&modbus, reg::CONFIG_POLL_MS, 1), [60]);
    drop(gw);
}

/// Waits for the gateway to connect to `robot`; fails the test after `wait`.
fn accept_within(robot: &TcpListener, wait: Duration) {
    robot.set_nonblocking(true).expect("non-blocking accept");
    let start = Instant::now();
    loop {
        match robot.accept() {
            Ok(_) => return,
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                assert!(start.elapsed() < wait, "the gateway never connected");
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(e) => panic!("accept: {e}"),
        }
    }
}

/// The Modbus server's address, from the log.
fn modbus_addr(log: &Log) -> String {
    let line = log.wait_for("modbus server on ");
    let (_, addr) = line.split_once("modbus server on ").expect("address");
    addr.trim().to_string()
}

/// The web page's address, from the log.
fn web_addr(log: &Log) -> String {
    let line = log.wait_for("web page on http://");
    let (_, url) = line.split_once("web page on http://").expect("address");
    url.trim().trim_end_matches('/').to_string()
}

/// The whole answer (head and body) to `GET path`.
fn http_get(addr: &str, path: &str) -> Vec<u8> {
    let mut s = TcpStream::connect(addr).expect("connect to the web page");
    s.set_read_timeout(Some(WAIT)).expect("timeout");
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
    )
    .expect("send");
    let mut answer = Vec::new();
    let _ = s.read_to_end(&mut answer);
    answer
}

/// One Modbus TCP request (unit 1) and its answer's PDU; an exception
/// fails the test.
fn modbus_request(addr: &str, pdu: &[u8]) -> Vec<u8> {
    let mut s = TcpStream::connect(addr).expect("connect to the Modbus server");
    s.set_read_timeout(Some(WAIT)).expect("timeout");
    let len = u16::try_from(pdu.len() + 1).expect("short PDU");
    let mut adu = vec![0, 1, 0, 0];
    adu.extend_from_slice(&len.to_be_bytes());
    adu.push(1);
    adu.extend_from_slice(pdu);
    s.write_all(&adu).expect("send the request");
    let mut head = [0u8; 7];
    s.read_exact(&mut head).expect("the answer's header");
    let n = usize::from(u16::from_be_bytes([head[4], head[5]])) - 1;
    let mut answer = vec![0u8; n];
    s.read_exact(&mut answer).expect("the answer");
    assert_eq!(answer[0], pdu[0], "exception: {answer:?}");
    answer
}

fn read_registers(addr: &str, start: u16, count: u16) -> Vec<u16> {
    let [a, b] = start.to_be_bytes();
    let [c, d] = count.to_be_bytes();
    let answer = modbus_request(addr, &[3, a, b, c, d]);
    answer[2..]
        .chunks(2)
        .map(|w| u16::from_be_bytes([w[0], w[1]]))
        .collect()
}

fn write_register(addr: &str, at: u16, value: u16) {
    let [a, b] = at.to_be_bytes();
    let [c, d] = value.to_be_bytes();
    modbus_request(addr, &[6, a, b, c, d]);
}

/// The gateway's log lines (stderr), read by a thread as they come.
struct Log {
    lines: mpsc::Receiver<String>,
    /// Lines read and not yet matched (the gateway's threads log in no
    /// fixed order).
    seen: std::cell::RefCell<Vec<String>>,
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
        Log {
            lines,
            seen: Default::default(),
        }
    }

    /// Every line not matched yet, up to the end of the output (or for
    /// [`WAIT`]).
    fn rest(&self) -> Vec<String> {
        let mut lines = std::mem::take(&mut *self.seen.borrow_mut());
        let start = Instant::now();
        while let Ok(line) = self
            .lines
            .recv_timeout(WAIT.saturating_sub(start.elapsed()))
        {
            lines.push(line);
        }
        lines
    }

    /// The first line containing `needle`, among those seen before or
    /// coming; fails the test after [`WAIT`].
    fn wait_for(&self, needle: &str) -> String {
        let mut seen = self.seen.borrow_mut();
        if let Some(i) = seen.iter().position(|l| l.contains(needle)) {
            return seen.remove(i);
        }
        let start = Instant::now();
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
    start_env(args, &[])
}

/// [`start`] with more variables in the environment.
fn start_env(args: &[&str], env: &[(&str, &str)]) -> (Running, Log) {
    let cwd = TempDir::new("cwd");
    let child = Command::new(BIN)
        .args(args)
        .current_dir(&cwd.0)
        .env("RUST_LOG", "info")
        .envs(env.iter().copied())
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start hans-gateway");
    let mut gw = Running(child, cwd);
    let log = Log::new(gw.0.stderr.take().expect("stderr"));
    (gw, log)
}

/// `--web-listen` serves the page and the API; the log names its address.
#[test]
fn web_listen_serves_the_page_and_the_api() {
    let (gw, log) = start(&[
        "--robot",
        "127.0.0.1:1",
        "--modbus-listen",
        "127.0.0.1:0",
        "--web-listen",
        "127.0.0.1:0",
    ]);
    let addr = web_addr(&log);
    let get = |path: &str| String::from_utf8_lossy(&http_get(&addr, path)).to_string();
    let page = get("/");
    assert!(page.starts_with("HTTP/1.1 200"), "{page}");
    assert!(
        page.to_ascii_lowercase().contains("content-encoding: gzip"),
        "{page}"
    );
    let status = get("/api/status");
    assert!(status.starts_with("HTTP/1.1 200"), "{status}");
    assert!(status.contains("\"map\":\"1.5\""), "{status}");
    // Plain HTTP: no HSTS (only over TLS, tls.rs).
    assert!(
        !status
            .to_ascii_lowercase()
            .contains("strict-transport-security"),
        "{status}"
    );
    // Without --config nothing is kept across a restart, and the status
    // says so (the page shows it); Linux runs no firmware image.
    assert!(
        status.contains("\"keeps\":{\"config\":false,\"audit\":false}"),
        "{status}"
    );
    assert!(status.contains("\"image\":null"), "{status}");
    // The access bit "web page on" shows over Modbus too.
    let regs = read_registers(&modbus_addr(&log), 50, 1);
    assert_eq!(regs[0] & (1 << 4), 1 << 4);
    drop(gw);
}

/// What follows `setup code for the first administrator: ` in its line
/// (where the code is), and the code read from `file`. The line never
/// holds the code itself (issue 25: the journal is read by more than
/// root).
fn shown_setup_code(line: &str, file: &std::path::Path) -> (String, String) {
    let (_, rest) = line
        .split_once("setup code for the first administrator: ")
        .expect("the setup code line");
    let code = std::fs::read_to_string(file).expect("the setup code file");
    let code = code.trim().to_string();
    for form in [code.clone(), code.replace('-', "")] {
        assert!(!line.contains(&form), "the code is on stderr: {line}");
    }
    (code, rest.to_string())
}

/// "Secure by default": the first administrator is created with a one-time
/// setup code that only someone at the machine can read. Each start makes a
/// new one and writes it to `--setup-code-file` only (stderr says where:
/// issue 25, the journal is read by more than root),
/// readable by its owner only (replacing the file, also one that everyone
/// could read); the web page and its API never show it.
#[test]
fn each_start_writes_a_new_setup_code_for_its_owner_only_and_never_serves_it() {
    let file = TempFile::new("setup-code");
    std::fs::write(&file.0, "2222-2222-2222\n").expect("an old code");
    set_mode(&file.0, 0o644);
    let mut codes = Vec::new();
    for _ in 0..2 {
        let (gw, log) = start(&[
            "--robot",
            "127.0.0.1:1",
            "--modbus-listen",
            "127.0.0.1:0",
            "--web-listen",
            "127.0.0.1:0",
            "--setup-code-file",
            file.arg(),
        ]);
        let (shown, rest) = shown_setup_code(&log.wait_for("setup code for the first"), &file.0);
        assert_eq!(
            rest,
            format!("in {} (readable by its owner only)", file.arg())
        );
        let code = SetupCode::parse(shown.as_bytes()).expect("the code shown parses");
        assert_eq!(mode(&file.0), 0o600, "the setup code file's permissions");
        let written = std::fs::read_to_string(&file.0).expect("read the setup code file");
        assert_eq!(written, format!("{shown}\n"));
        assert_eq!(SetupCode::parse(written.trim().as_bytes()), Some(code));
        let addr = web_addr(&log);
        for path in ["/", "/api/status", "/api/session"] {
            let answer = http_get(&addr, path);
            assert!(answer.starts_with(b"HTTP/1.1 "), "{path}: no answer");
            // (The page itself is compressed: it is a static file, built
            // with the binary, so it cannot hold a code made at start.)
            for form in [shown.clone(), shown.replace('-', "")] {
                assert!(
                    !answer.windows(form.len()).any(|w| w == form.as_bytes()),
                    "{path} shows the setup code"
                );
            }
        }
        codes.push(shown);
        drop(gw);
    }
    assert_ne!(codes[0], codes[1], "a new code at each start");
}

/// Without `--setup-code-file` the code goes to `setup-code` beside the
/// `--config` file, or in the current directory without `--config`.
#[test]
fn the_setup_code_file_is_beside_the_config_file_or_in_the_current_directory() {
    let config = TempFile::new("gateway.toml");
    let beside = config.1 .0.join("setup-code");
    let (gw, log) = start(&[
        "--config",
        config.arg(),
        "--robot",
        "127.0.0.1:1",
        "--modbus-listen",
        "127.0.0.1:0",
    ]);
    let (shown, rest) = shown_setup_code(&log.wait_for("setup code for the first"), &beside);
    assert_eq!(
        rest,
        format!("in {} (readable by its owner only)", beside.display())
    );
    assert_eq!(
        std::fs::read_to_string(&beside).expect("setup-code beside the configuration file"),
        format!("{shown}\n")
    );
    assert_eq!(mode(&beside), 0o600);
    drop(gw);

    let (gw, log) = start(&["--robot", "127.0.0.1:1", "--modbus-listen", "127.0.0.1:0"]);
    let here = gw.1 .0.join("setup-code");
    let (shown, rest) = shown_setup_code(&log.wait_for("setup code for the first"), &here);
    assert_eq!(rest, "in setup-code (readable by its owner only)");
    assert_eq!(
        std::fs::read_to_string(&here).expect("setup-code in the current directory"),
        format!("{shown}\n")
    );
    assert_eq!(mode(&here), 0o600);
    drop(gw);
}

/// Waits until the process `pid` has settled: the same number of threads
/// and the same virtual memory size (/proc/PID/status) for 500 ms.
fn settle(pid: u32) {
    let sample = || {
        let status =
            std::fs::read_to_string(format!("/proc/{pid}/status")).expect("the process's status");
        status
            .lines()
            .filter(|l| l.starts_with("Threads:") || l.starts_with("VmSize:"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let start = Instant::now();
    let mut last = sample();
    let mut since = Instant::now();
    while since.elapsed() < Duration::from_millis(500) {
        assert!(start.elapsed() < WAIT, "not settled after {WAIT:?}: {last}");
        std::thread::sleep(Duration::from_millis(20));
        let now = sample();
        if now != last {
            last = now;
            since = Instant::now();
        }
    }
}

/// "Secure by default": a gateway that fails while running ended its thread
/// and left a live process serving nothing, which a supervisor (systemd's
/// `Restart=on-failure`) never restarts. It exits with status 101, saying why.
///
/// The failure is a real one: the operating system refuses the gateway a
/// thread. A save (CONFIG_COMMAND 1) writes the file on tokio's blocking
/// pool, whose first thread is started then; with the process's address
/// space limited (`prlimit --as`, the soft limit) to 1 MiB, far below what
/// it already uses, the kernel keeps the memory it has and refuses any new
/// mapping, such as that thread's stack, and tokio panics in the gateway's
/// thread.
#[test]
fn a_gateway_that_fails_while_running_exits_101() {
    let file = TempFile::new("gateway.toml");
    let (mut gw, log) = start_env(
        &[
            "--config",
            file.arg(),
            "--robot",
            "127.0.0.1:1",
            "--modbus-listen",
            "127.0.0.1:0",
        ],
        // The panic message alone: a backtrace would need memory the
        // limit leaves no room for.
        &[("RUST_BACKTRACE", "0")],
    );
    let modbus = modbus_addr(&log);
    // The last thing the process does at start.
    log.wait_for("setup code for the first");
    // Every thread started and with its memory: a thread that allocated
    // its first bytes under the limit would end the process (SIGABRT).
    read_registers(&modbus, reg::CONFIG_POLL_MS, 1);
    settle(gw.0.id());
    let limited = Command::new("prlimit")
        .arg(format!("--pid={}", gw.0.id()))
        .arg(format!("--as={}:", 1 << 20))
        .status()
        .expect("run prlimit (util-linux)");
    assert!(limited.success(), "prlimit: {limited}");
    // The save: no answer to wait for, the gateway may fail first.
    let mut s = TcpStream::connect(&modbus).expect("connect to the Modbus server");
    let [a, b] = reg::CONTROL_CONFIG_COMMAND.to_be_bytes();
    s.write_all(&[0, 1, 0, 0, 0, 6, 1, 6, a, b, 0, 1])
        .expect("send the save");
    let start = Instant::now();
    let status = loop {
        if let Some(status) = gw.0.try_wait().expect("wait for hans-gateway") {
            break status;
        }
        assert!(
            start.elapsed() < WAIT,
            "hans-gateway still running {WAIT:?} after its gateway failed"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    assert_eq!(status.code(), Some(101), "{status}: {:#?}", log.rest());
    let line = log.wait_for("exiting with status 101");
    assert!(
        line.starts_with(
            "hans-gateway: the gateway's thread panicked: OS can't spawn worker thread"
        ),
        "{line}"
    );
    assert!(!file.0.exists(), "nothing saved");
}

/// Sends `request` (a whole HTTP/1.1 request) to `addr` and returns the
/// answer as soon as it is whole (its head and its `Content-Length`
/// body), without waiting for the connection to close.
fn http_exchange(addr: &str, request: &str) -> String {
    let mut s = TcpStream::connect(addr).expect("connect to the web page");
    s.set_read_timeout(Some(WAIT)).expect("timeout");
    s.write_all(request.as_bytes()).expect("send");
    let mut got = Vec::new();
    let mut buf = [0u8; 4096];
    loop {
        if let Some(end) = got.windows(4).position(|w| w == b"\r\n\r\n") {
            let head = String::from_utf8_lossy(&got[..end]).to_ascii_lowercase();
            let len = head
                .lines()
                .find_map(|l| l.strip_prefix("content-length:"))
                .and_then(|v| v.trim().parse::<usize>().ok())
                .unwrap_or(0);
            if got.len() >= end + 4 + len {
                return String::from_utf8_lossy(&got).to_string();
            }
        }
        let n = s.read(&mut buf).expect("read the answer");
        assert!(n > 0, "closed before the answer was whole: {got:?}");
        got.extend_from_slice(&buf[..n]);
    }
}

/// A gateway keeping its configuration (and audit files) in `config`,
/// with its web page, the robot absent, every port the kernel's choice.
fn kept_web_args(config: &TempFile) -> [&str; 8] {
    [
        "--config",
        config.arg(),
        "--robot",
        "127.0.0.1:1",
        "--modbus-listen",
        "127.0.0.1:0",
        "--web-listen",
        "127.0.0.1:0",
    ]
}

/// The records kept in the audit files beside `config`, oldest first:
/// (kind, detail).
fn kept_records(config: &Path) -> Vec<(String, String)> {
    use hans_gateway::audit::Record;
    use hans_gateway::storage::AuditStore;
    let mut f = hans_gateway_linux::audit_file::AuditFile::beside(config);
    let mut got = Vec::new();
    let rt = tokio::runtime::Builder::new_current_thread()
        .build()
        .expect("a runtime");
    rt.block_on(f.read(&mut |b| {
        if let Ok((r, _)) = Record::parse(b) {
            got.push((r.kind.as_str().to_string(), r.detail.as_str().to_string()));
        }
    }))
    .expect("read the audit files");
    got
}

/// Issue 25, finding 4: the audit file was written by its writer thread
/// after the answer, so a gateway killed right after answering a change
/// lost its record (a SIGKILL right after a flood lost the latest). Now
/// the answer to a request that made records goes once they are synced.
///
/// The writer is kept busy (a change of nine settings from one session:
/// nine records, each synced in turn); while it writes them, a second
/// session logs out, and the gateway is SIGKILLed the moment that answer
/// is whole. After a restart the logout and the nine changes are in the
/// file. (Before, the logout was answered at once and its record, queued
/// behind the nine syncs, was lost.)
#[test]
fn a_change_answered_is_on_disk_even_if_the_gateway_is_killed_at_once() {
    let config = TempFile::new("gateway.toml");
    let args = kept_web_args(&config);
    let (mut gw, log) = start(&args);
    let code_file = config.1 .0.join("setup-code");
    let (code, _) = shown_setup_code(&log.wait_for("setup code for the first"), &code_file);
    let addr = web_addr(&log);
    let post = |path: &str, cookie: &str, body: &str| {
        format!(
            "POST {path} HTTP/1.1\r\nHost: {addr}\r\nOrigin: http://{addr}\r\n{cookie}Content-Type: application/json\r\nContent-Length: {}\r\n\r\n{body}",
            body.len()
        )
    };
    let cookie_of = |answer: &str| {
        let c = answer
            .lines()
            .find_map(|l| {
                l.strip_prefix("Set-Cookie: ")
                    .or(l.strip_prefix("set-cookie: "))
            })
            .and_then(|c| c.split(';').next())
            .unwrap_or_else(|| panic!("a session cookie: {answer}"));
        format!("Cookie: {c}\r\n")
    };
    let body = format!(r#"{{"code":"{code}","name":"admin","password":"correct horse"}}"#);
    let answer = http_exchange(&addr, &post("/api/setup", "", &body));
    assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
    let first = cookie_of(&answer);
    let body = r#"{"name":"admin","password":"correct horse"}"#;
    let answer = http_exchange(&addr, &post("/api/login", "", body));
    assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
    let second = cookie_of(&answer);
    // Every record so far written (the file's size stops at the login).
    let security = config.1 .0.join("gateway.toml.audit");
    let start_wait = Instant::now();
    while kept_records(&config.0).last().map(|(k, _)| k.as_str()) != Some("login") {
        assert!(
            start_wait.elapsed() < WAIT,
            "{:#?}",
            kept_records(&config.0)
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    let before = std::fs::metadata(&security).expect("the audit file").len();
    let settings = [
        ("link.poll_ms", "50"),
        ("link.reply_timeout_ms", "900"),
        ("watchdog.period_ms", "700"),
        ("mqtt.keep_alive_s", "45"),
        ("mqtt.period_ms", "300"),
        ("mqtt.group_id", "plant9"),
        ("mqtt.edge_id", "gw9"),
        ("mqtt.primary_host", "scada9"),
        ("motion.start_grace_ms", "400"),
    ];
    let body = format!(
        r#"{{"settings":{{{}}}}}"#,
        settings
            .iter()
            .map(|(k, v)| format!(r#""{k}":"{v}""#))
            .collect::<Vec<_>>()
            .join(",")
    );
    // The change, its answer not awaited; its first record on disk.
    let mut change = TcpStream::connect(&addr).expect("connect to the web page");
    change
        .write_all(post("/api/config", &first, &body).as_bytes())
        .expect("send the change");
    while std::fs::metadata(&security).map_or(0, |m| m.len()) == before {
        assert!(start_wait.elapsed() < WAIT, "the change was never written");
        std::thread::sleep(Duration::from_millis(1));
    }
    let answer = http_exchange(&addr, &post("/api/logout", &second, "{}"));
    // At once: no time for a writer that runs after the answer.
    gw.0.kill().expect("SIGKILL the gateway");
    assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
    let _ = gw.0.wait();
    drop((gw, change));
    // A restart reads the files (and cuts a torn record off).
    let (gw, log) = start(&args);
    web_addr(&log);
    drop(gw);
    let kept = kept_records(&config.0);
    assert!(
        kept.iter().any(|(k, _)| k == "logout"),
        "the logout answered is not kept: {kept:#?}"
    );
    for (key, value) in settings {
        assert!(
            kept.iter().any(|(k, d)| k == "config"
                && d.starts_with(&format!("{key}: "))
                && d.ends_with(value)),
            "no record of {key} -> {value}: {kept:#?}"
        );
    }
}

/// A stop in order: SIGTERM (systemd's stop) and SIGINT keep what the
/// audit log had counted and record the stop, then exit 0. Before, the
/// signal ended the process at once: the failed logins counted in the
/// running period were lost (an attacker's guesses of up to an hour gone
/// from the evidence at every stop or package upgrade), nothing told an
/// ordered stop from a crash, and the status was that of a killed process.
#[test]
fn sigterm_and_sigint_keep_the_counted_failures_and_record_the_stop() {
    for (signal, name) in [("TERM", "SIGTERM"), ("INT", "SIGINT")] {
        let config = TempFile::new("gateway.toml");
        let args = kept_web_args(&config);
        let (mut gw, log) = start(&args);
        let addr = web_addr(&log);
        // Wrong setup codes (failed logins of a device without accounts):
        // the first is recorded as it comes, the next two are counted.
        for code in ["AAAA-AAAA-AAAA", "BBBB-BBBB-BBBB", "CCCC-CCCC-CCCC"] {
            let body = format!(r#"{{"code":"{code}","name":"admin","password":"correct horse"}}"#);
            let answer = http_exchange(
                &addr,
                &format!(
                    "POST /api/setup HTTP/1.1\r\nHost: {addr}\r\nOrigin: http://{addr}\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n{body}",
                    body.len()
                ),
            );
            assert!(answer.starts_with("HTTP/1.1 403"), "{answer}");
        }
        let start_wait = Instant::now();
        while !kept_records(&config.0)
            .iter()
            .any(|(k, _)| k == "login-failed")
        {
            assert!(
                start_wait.elapsed() < WAIT,
                "{:#?}",
                kept_records(&config.0)
            );
            std::thread::sleep(Duration::from_millis(5));
        }
        let status = Command::new("kill")
            .arg(format!("-{signal}"))
            .arg(gw.0.id().to_string())
            .status()
            .expect("kill");
        assert!(status.success());
        let stopped = Instant::now();
        let exit = loop {
            if let Some(s) = gw.0.try_wait().expect("wait") {
                break s;
            }
            assert!(
                stopped.elapsed() < WAIT,
                "still running {WAIT:?} after SIG{signal}"
            );
            std::thread::sleep(Duration::from_millis(5));
        };
        assert_eq!(
            exit.code(),
            Some(0),
            "SIG{signal}: {exit:?}: {:#?}",
            log.rest()
        );
        let kept = kept_records(&config.0);
        let failed: Vec<_> = kept
            .iter()
            .filter(|(k, _)| k == "login-failed")
            .map(|(_, d)| d.as_str())
            .collect();
        assert_eq!(failed.len(), 2, "{kept:#?}");
        assert!(
            failed[1].starts_with("2 more failed logins in "),
            "the counted ones kept: {kept:#?}"
        );
        assert_eq!(
            kept.last(),
            Some(&("stop".to_string(), name.to_string())),
            "{kept:#?}"
        );
        drop(gw);
    }
}
