//! The `hans-gateway` binary's command line: help, version, usage errors,
//! and what it says when `--robot` overrides a saved robot address.
//! Loopback only; every process is killed at the end, also on failure.

use std::io::{BufRead, BufReader};
use std::net::Ipv4Addr;
use std::process::{Child, Command, Output, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use hans_gateway::state::Text;
use hans_gateway::storage::{image, IMAGE_LEN};
use hans_gateway::Config;

const BIN: &str = env!("CARGO_BIN_EXE_hans-gateway");

fn run(args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .output()
        .expect("run hans-gateway")
}

/// Finding: `--help` printed one usage line to stderr and exited 2.
#[test]
fn help_and_version_print_to_stdout_and_exit_0() {
    let out = run(&["--help"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "--help: {out:?}");
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
    let out = run(&["-h"]);
    assert_eq!(out.status.code(), Some(0));
    let out = run(&["--version"]);
    assert_eq!(out.status.code(), Some(0));
    assert_eq!(
        String::from_utf8_lossy(&out.stdout),
        format!("hans-gateway {}\n", env!("CARGO_PKG_VERSION"))
    );
}

#[test]
fn a_bad_command_line_exits_2_with_the_reason() {
    for (args, why) in [
        (&["--bogus"][..], "unknown argument --bogus"),
        (
            &["--robot", "127.0.0.1:1"][..],
            "--modbus-listen is required",
        ),
        (&["--modbus-listen", "127.0.0.1:0"][..], "no robot given"),
        (&["--robot"][..], "--robot needs a value"),
    ] {
        let out = run(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {out:?}");
        assert!(err.contains(why), "{args:?}: {err}");
        assert!(err.contains("--help"), "{args:?}: {err}");
    }
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
    image::encode(&saved, &[Text::EMPTY; 16], &mut bytes).expect("room for the image");
    std::fs::write(&path, bytes).expect("write the config file");
    let child = Command::new(BIN)
        .args([
            "--config",
            path.to_str().expect("utf-8 path"),
            // Nothing listens on port 1 of the loopback: the link stays down.
            "--robot",
            "127.0.0.1:1",
            "--modbus-listen",
            "127.0.0.1:0",
        ])
        .env("RUST_LOG", "info")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start hans-gateway");
    let mut gw = Running(child);
    let stderr = gw.0.stderr.take().expect("stderr");
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let start = Instant::now();
    let mut seen = Vec::new();
    let found = loop {
        let left = Duration::from_secs(20).saturating_sub(start.elapsed());
        match rx.recv_timeout(left) {
            Ok(line) if line.contains("overrides the saved one") => break line,
            Ok(line) => seen.push(line),
            Err(_) => panic!("no override warning in the log: {seen:#?}"),
        }
    };
    drop(gw);
    let _ = std::fs::remove_file(&path);
    assert!(found.contains("WARN"), "{found}");
    assert!(found.contains("10.9.8.7:4321"), "{found}");
}
