//! `hansctl` run as a program: `decode` on a fixture, and the client
//! subcommands against an in-process `hans-sim`.

use std::io::Write;
use std::process::{Command, Output, Stdio};
use std::time::Duration;

use hans_sim::{ClockMode, Config, Fault, FsmState, ProtocolLevel, Sim};
use serde_json::Value;

const BIN: &str = env!("CARGO_BIN_EXE_hansctl");

/// Runs hansctl with `args` (blocking, on a worker thread so the
/// simulator keeps running). Every call is bounded by `--timeout`.
async fn hansctl(args: Vec<String>) -> Output {
    tokio::task::spawn_blocking(move || {
        Command::new(BIN)
            .args(&args)
            .stdin(Stdio::null())
            .output()
            .expect("run hansctl")
    })
    .await
    .unwrap()
}

fn args(robot: &str, rest: &[&str]) -> Vec<String> {
    let mut v = vec![
        "--robot".to_string(),
        robot.to_string(),
        "--timeout".into(),
        "3000".into(),
    ];
    v.extend(rest.iter().map(|s| s.to_string()));
    v
}

fn json_lines(out: &Output) -> Vec<Value> {
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{l:?}: {e}")))
        .collect()
}

#[test]
fn decode_reads_a_fixture_and_keeps_going_after_bad_lines() {
    let fixture = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fixtures/decode.txt"
    ))
    .unwrap();
    let (code, _, v) = decode(&fixture);
    assert_eq!(code, Some(0), "exits with success");
    assert_eq!(v.len(), 11, "one object per non-empty line");
    assert_eq!(
        (v[0]["name"].as_str(), v[0]["kind"].as_str()),
        (Some("ReadBoxDI"), Some("request"))
    );
    assert_eq!(v[0]["fields"]["bits"], serde_json::json!([5, 6]));
    assert_eq!(v[1]["kind"], "ok");
    assert_eq!(v[1]["fields"]["values"], serde_json::json!([0, 1]));
    assert_eq!(v[2]["fields"]["tcp_name"], "TCP");
    assert_eq!(v[2]["fields"]["pose"][0], serde_json::json!(420));
    assert_eq!(v[3]["kind"], "fail");
    assert_eq!(
        (v[3]["code"].as_i64(), v[3]["code_name"].as_str()),
        (Some(20018), Some("StateRefused"))
    );
    assert_eq!(v[4]["detail"], "the output does not exist");
    assert_eq!(
        (v[5]["known"].as_bool(), v[5]["kind"].as_str()),
        (Some(false), Some("request"))
    );
    assert!(
        v[6]["error"].as_str().unwrap().contains("WayPoint"),
        "{}",
        v[6]
    );
    assert_eq!(v[7]["kind"], "errorcmd");
    assert_eq!(
        (v[8]["name"].as_str(), v[8]["known"].as_bool()),
        (Some("GrpPowerOn"), Some(true))
    );
    assert!(v[9]["error"].is_string(), "{}", v[9]);
    assert_eq!(v[10]["fields"]["state"], serde_json::json!(33));
}

/// Runs `hansctl decode` on `input`; returns the exit status, the output
/// lines as text and parsed.
fn decode(input: &[u8]) -> (Option<i32>, Vec<String>, Vec<Value>) {
    let mut child = Command::new(BIN)
        .arg("decode")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let input = input.to_vec();
    // Written from another thread: the output pipe must be drained while
    // a large input is still being written.
    let writer = std::thread::spawn(move || stdin.write_all(&input));
    let out = child.wait_with_output().unwrap();
    writer.join().unwrap().unwrap();
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text: Vec<String> = String::from_utf8(out.stdout.clone())
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect();
    (out.status.code(), text, json_lines(&out))
}

#[test]
fn decode_keeps_going_after_bytes_that_are_not_utf8() {
    let (code, _, v) = decode(b"ReadCurFSM,0,;\n\xff\xfe\x00\x01;\nReadCurFSM,OK,33,;\n");
    assert_eq!(code, Some(0));
    assert_eq!(v.len(), 3, "{v:?}");
    assert_eq!(v[0]["fields"]["rbt_id"], 0);
    assert_eq!(v[1]["kind"], "invalid");
    assert_eq!(
        v[1]["error"],
        "not UTF-8: byte 0xff at offset 0 of the line"
    );
    assert_eq!(v[2]["fields"]["state"], 33);
}

#[test]
fn decode_writes_numbers_exactly_as_read() {
    let (code, text, v) = decode(
        b"ReadActPos,OK,10.759,-0.000,37.828,0.000,37.828,0.000,400.581,76.115,970.143,0.000,\
          75.655,10.759,0,0,0,0,0,0,0,0,0,0,0,1.500000,;\n\
          SetOverride,0,0.123456789012345678,;\n\
          SetOverride,0,0.1234567890123456789,;\n",
    );
    assert_eq!(code, Some(0));
    assert!(
        text[0].contains(r#""joints":[10.759,-0.000,37.828,0.000,37.828,0.000]"#),
        "{}",
        text[0]
    );
    assert!(text[0].contains(r#",1.500000]"#), "{}", text[0]);
    assert!(
        text[1].contains(r#""ratio":0.123456789012345678}"#),
        "{}",
        text[1]
    );
    // The brief's example: written exactly, or (beyond the codec's
    // precision) with a warning that quotes the text.
    let exact = text[2].contains(r#""ratio":0.1234567890123456789}"#);
    let warned = v[2]["warnings"][0]
        .as_str()
        .is_some_and(|w| w.contains(r#""0.1234567890123456789""#));
    assert!(exact != warned, "{}", text[2]);
    assert!(!text[2].contains("0.12345678901234568"), "{}", text[2]);
    let help = Command::new(BIN)
        .args(["decode", "--help"])
        .output()
        .unwrap();
    let help = String::from_utf8_lossy(&help.stdout);
    assert!(help.contains("-0.000"), "{help}");
}

#[test]
fn decode_reports_a_line_without_terminator() {
    let (code, _, v) = decode(b"garbage\nReadCurFSM,0,\nReadCurFSM,0,;\n");
    assert_eq!(code, Some(0));
    assert!(
        v[0]["error"].as_str().unwrap().starts_with("no ';'"),
        "{}",
        v[0]
    );
    assert!(
        v[1]["error"].as_str().unwrap().starts_with("no ';'"),
        "{}",
        v[1]
    );
    assert_eq!(v[1]["fields"]["rbt_id"], 0, "the body is still decoded");
    assert!(v[2].get("error").is_none(), "{}", v[2]);
}

#[test]
fn decode_reads_a_reply_against_the_request_before_it() {
    let (code, _, v) = decode(
        b"ReadBoxDI,5,6,;\nReadBoxDI,OK,0,1,1,1,1,1,1,1,;\n\
          ReadBoxDI,5,6,;\nReadBoxDI,OK,0,1,;\n\
          ReadBoxDI,OK,0,1,1,1,1,1,1,1,;\n",
    );
    assert_eq!(code, Some(0));
    assert!(v[1]["error"].is_string(), "8 values for 2 bits: {}", v[1]);
    assert_eq!(v[1]["against_request"], true);
    assert_eq!(v[3]["fields"]["values"], serde_json::json!([0, 1]));
    // Not after its request: read by name, any valid length.
    assert!(v[4].get("error").is_none(), "{}", v[4]);
    assert!(v[4].get("against_request").is_none(), "{}", v[4]);
}

#[test]
fn decode_skips_a_line_over_the_bound_and_goes_on() {
    let mut input = b"ReadCurFSM,0,".to_vec();
    input.resize(1024 * 1024 + 100, b'0');
    input.extend_from_slice(b",;\nReadCurFSM,OK,33,;\n");
    let (code, _, v) = decode(&input);
    assert_eq!(code, Some(0));
    assert_eq!(v.len(), 2, "{v:?}");
    assert_eq!(v[0]["kind"], "invalid");
    assert!(
        v[0]["error"].as_str().unwrap().contains("1048678 bytes"),
        "{}",
        v[0]
    );
    assert_eq!(v[1]["fields"]["state"], 33);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn send_prints_typed_replies_with_exit_codes() {
    let sim = Sim::start(Config::default()).await.unwrap();
    let robot = sim.command_addr().to_string();
    let out = hansctl(args(&robot, &["--json", "send", "ReadCurFSM,0,;"])).await;
    assert!(out.status.success(), "{out:?}");
    assert_eq!(json_lines(&out)[0]["fields"]["state"], serde_json::json!(2));
    // Refused in this state: exit 1, code and name shown.
    let out = hansctl(args(&robot, &["send", "GrpEnable,0"])).await;
    assert_eq!(out.status.code(), Some(1));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("20018") && text.contains("StateRefused"),
        "{text}"
    );
    // Malformed known command: not sent, exit 2.
    let before = sim.received().len();
    let out = hansctl(args(&robot, &["send", "WayPoint,0,1,;"])).await;
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(sim.received().len(), before);
    // Unknown names pass through.
    let out = hansctl(args(&robot, &["send", "ReadVersion,;"])).await;
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stdout).contains("20005"));
    sim.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn timeouts_and_connection_errors_are_one_line_and_nonzero() {
    let sim = Sim::start(Config::default()).await.unwrap();
    sim.faults().set(Fault::NoReply);
    let robot = sim.command_addr().to_string();
    let mut a = args(&robot, &["send", "ReadCurFSM,0,;"]);
    a[3] = "300".into();
    let out = hansctl(a).await;
    assert_eq!(out.status.code(), Some(3));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("no reply"), "{err}");
    sim.shutdown().await;
    // Nothing listens there any more.
    let out = hansctl(args(&robot, &["state"])).await;
    assert_eq!(out.status.code(), Some(3));
    assert!(String::from_utf8_lossy(&out.stderr).contains("cannot connect"));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn power_on_move_io_state_and_watch() {
    let sim = Sim::start(Config {
        clock: ClockMode::Scaled(20.0),
        ..Config::default()
    })
    .await
    .unwrap();
    let robot = sim.command_addr().to_string();
    let out = hansctl(args(&robot, &["power-on"])).await;
    assert!(out.status.success(), "{out:?}");
    let text = String::from_utf8_lossy(&out.stdout);
    for step in ["ConnectToBox", "Electrify", "StartMaster", "GrpEnable"] {
        assert!(text.contains(step), "{text}");
    }
    assert_eq!(sim.fsm(), FsmState::StandBy);

    let out = hansctl(args(
        &robot,
        &[
            "move-joint",
            "10",
            "0",
            "90",
            "0",
            "90",
            "-20",
            "--vel",
            "50",
            "--wait",
        ],
    ))
    .await;
    assert!(out.status.success(), "{out:?}");
    let q = sim.state().act_joints;
    assert!(
        (q[0] - 10.0).abs() < 1e-6 && (q[5] + 20.0).abs() < 1e-6,
        "{q:?}"
    );

    let out = hansctl(args(
        &robot,
        &[
            "--json",
            "move-line",
            "400",
            "50",
            "400",
            "180",
            "0",
            "180",
            "--vel",
            "200",
            "--wait",
        ],
    ))
    .await;
    assert!(out.status.success(), "{out:?}");
    let last = json_lines(&out).pop().unwrap();
    assert_eq!(last["done"], serde_json::json!(true));
    let p = sim.state().act_pose;
    assert!(
        (p[0] - 400.0).abs() < 1e-3 && (p[1] - 50.0).abs() < 1e-3 && (p[2] - 400.0).abs() < 1e-3,
        "{p:?}"
    );

    let out = hansctl(args(&robot, &["io", "set", "do", "3", "1"])).await;
    assert!(out.status.success(), "{out:?}");
    assert!(sim.io().do_[3]);
    sim.set_io(|io| io.di[6] = true);
    let out = hansctl(args(&robot, &["--json", "io"])).await;
    assert!(out.status.success(), "{out:?}");
    let v = &json_lines(&out)[0];
    assert_eq!(v["DO"][3], serde_json::json!(1));
    assert_eq!(v["DI"][6], serde_json::json!(1));

    let out = hansctl(args(&robot, &["--json", "state"])).await;
    let v = &json_lines(&out)[0];
    assert_eq!(
        (v["fsm"].as_i64(), v["enabled"].as_i64()),
        (Some(33), Some(1))
    );

    let ds = sim.datasheet_addrs()[0];
    let out = hansctl(args(
        &ds.ip().to_string(),
        &[
            "--json",
            "watch",
            "--port",
            &ds.port().to_string(),
            "--count",
            "3",
        ],
    ))
    .await;
    assert!(out.status.success(), "{out:?}");
    let v = json_lines(&out);
    assert_eq!(v.len(), 3);
    assert_eq!(v[0]["fsm"], serde_json::json!(33));
    assert_eq!(v[0]["box_do"][3], serde_json::json!(1));
    for key in ["joints", "tcp"] {
        let six = v[0][key]
            .as_array()
            .map(|a| a.len() == 6 && a.iter().all(|x| x.is_number()));
        assert_eq!(six, Some(true), "{key}: six numbers in {}", v[0]);
    }

    // A refused move surfaces as exit 1.
    sim.set_safety_guard(true);
    let out = hansctl(args(
        &robot,
        &["move-joint", "0", "0", "90", "0", "90", "0"],
    ))
    .await;
    assert_eq!(out.status.code(), Some(1));
    sim.set_safety_guard(false);
    let out = hansctl(args(&robot, &["stop"])).await;
    assert!(out.status.success());
    let out = hansctl(args(&robot, &["reset"])).await;
    assert!(out.status.success());
    tokio::time::sleep(Duration::from_millis(10)).await;
    sim.shutdown().await;
}

/// The messages of `received` named `name`.
fn named<'a>(received: &'a [String], name: &str) -> Vec<&'a String> {
    received
        .iter()
        .filter(|m| m.split(',').next() == Some(name))
        .collect()
}

/// Longest wait for anything in the terminal tests (generous: a loaded
/// machine; never a figure hansctl is held to).
const WAIT: Duration = Duration::from_secs(20);

/// `line` run on a pseudo-terminal made by util-linux's `script`
/// (Debian's essential package bsdutils): the keys typed into it, what it
/// printed so far. Killed when dropped.
struct Terminal {
    child: std::process::Child,
    keys: std::process::ChildStdin,
    printed: std::sync::mpsc::Receiver<Vec<u8>>,
    output: String,
}

impl Terminal {
    fn start(line: &str) -> Terminal {
        let mut child = Command::new("script")
            .args(["--quiet", "--return", "--command", line, "/dev/null"])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("run hansctl under script(1) (util-linux)");
        let keys = child.stdin.take().expect("script's stdin");
        let mut out = child.stdout.take().expect("script's stdout");
        let (tx, printed) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while let Ok(n @ 1..) = std::io::Read::read(&mut out, &mut buf) {
                if tx.send(buf[..n].to_vec()).is_err() {
                    return;
                }
            }
        });
        Terminal {
            child,
            keys,
            printed,
            output: String::new(),
        }
    }

    /// Takes in what was printed so far.
    fn read_output(&mut self) {
        while let Ok(bytes) = self.printed.try_recv() {
            self.output.push_str(&String::from_utf8_lossy(&bytes));
        }
    }

    /// Waits (at most [`WAIT`]) until hansctl printed `text`.
    async fn wait_printed(&mut self, text: &str) -> Result<(), String> {
        let start = std::time::Instant::now();
        loop {
            self.read_output();
            if self.output.contains(text) {
                return Ok(());
            }
            if start.elapsed() > WAIT {
                return Err(format!(
                    "not printed within {WAIT:?}: {text:?}; printed {:?}",
                    self.output
                ));
            }
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
    }

    /// Types `key`.
    fn key(&mut self, key: u8) -> Result<(), String> {
        let typed = self.keys.write_all(&[key]).and_then(|()| self.keys.flush());
        typed.map_err(|e| {
            self.read_output();
            format!(
                "typing {:?}: {e} (hansctl ended?); printed {:?}",
                key as char, self.output
            )
        })
    }

    /// Waits (at most [`WAIT`]) for hansctl to end; its exit status.
    async fn ended(&mut self) -> Result<std::process::ExitStatus, String> {
        let start = std::time::Instant::now();
        loop {
            if let Some(status) = self.child.try_wait().map_err(|e| e.to_string())? {
                return Ok(status);
            }
            if start.elapsed() > WAIT {
                self.read_output();
                return Err(format!(
                    "still running after {WAIT:?}; printed {:?}",
                    self.output
                ));
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    }
}

impl Drop for Terminal {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A simulator whose long jogs keep going 3 s after their last
/// `LongMoveEvent` (the document's 200 ms in hans-sim's default): a loaded
/// machine that delays an event must not stop the jog (and make hansctl
/// end with `Fail,20018`); only hansctl's release (or its death) may.
async fn patient_sim() -> Sim {
    Sim::start(Config {
        timing: hans_sim::Timing {
            long_move_keepalive: Duration::from_secs(3),
            ..hans_sim::Timing::default()
        },
        ..Config::ready()
    })
    .await
    .unwrap()
}

/// How one attempt at holding a key went.
enum Held {
    /// The jog ran while the key was held and stopped after its release:
    /// how long after.
    Stopped(Duration),
    /// The test could not type as a held key repeats (a gap of this long
    /// between two repeats: a loaded machine), and hansctl took it for a
    /// release. Not a result.
    NotHeld(Duration),
}

/// Plays a key held on the terminal of `hansctl jog j3-` (one byte, then
/// repeats every 30 ms, as a keyboard sends them) until the simulator jogs
/// and has had a keep-alive, then releases it.
async fn hold_a_key(sim: &Sim) -> Result<Held, String> {
    let robot = sim.command_addr().to_string();
    let mut term = Terminal::start(&format!("{BIN} --robot {robot} --timeout 3000 jog j3-"));
    // Up, its terminal set to hand over keys at once, waiting for a key.
    term.wait_printed("hold any key to jog J3-").await?;
    if !named(&sim.received(), "LongJogJ").is_empty() {
        return Err("jogged before any key".to_string());
    }
    let mut last = std::time::Instant::now();
    let mut gap = Duration::ZERO;
    let start = last;
    let stop = "LongJogJ,0,2,0,0,;";
    loop {
        let typed = term.key(b'a');
        let now = std::time::Instant::now();
        if now > start {
            gap = gap.max(now - last);
        }
        last = now;
        let r = sim.received();
        let stopped = named(&r, "LongJogJ").iter().any(|m| m.as_str() == stop);
        if typed.is_err() || stopped {
            // Released while the test was typing: by a gap of its own?
            if gap > Duration::from_millis(100) {
                return Ok(Held::NotHeld(gap));
            }
            return Err(format!("stopped while the key was held: {typed:?}, {r:?}"));
        }
        if sim.fsm() == FsmState::LongJogMoving && !named(&r, "LongMoveEvent").is_empty() {
            break;
        }
        if start.elapsed() > WAIT {
            return Err(format!("no jog within {WAIT:?} of the first key: {r:?}"));
        }
        tokio::time::sleep(Duration::from_millis(30)).await;
    }
    // Released: no more repeats. hansctl stops the jog, then ends by itself.
    let released = std::time::Instant::now();
    let stopped = loop {
        let r = sim.received();
        if named(&r, "LongJogJ").last().map(|s| s.as_str()) == Some(stop) {
            break released.elapsed();
        }
        if released.elapsed() > WAIT {
            return Err(format!("no stop within {WAIT:?} of the release: {r:?}"));
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    };
    let status = term.ended().await?;
    if !status.success() {
        term.read_output();
        return Err(format!("hansctl ended with {status}: {:?}", term.output));
    }
    Ok(Held::Stopped(stopped))
}

/// Hold-to-jog from a terminal: hansctl runs on a pseudo-terminal, the
/// test plays a held key, then releases it. The jog runs while the key is
/// held and stops after the release (the release rule itself, 150 ms
/// without a repeat, is unit-tested with time the test owns: src/jog.rs).
/// If the test itself could not type as a held key repeats (its own
/// thread stalled over 100 ms), hansctl rightly took that for a release:
/// the attempt is played again, at most three times.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn jog_while_a_key_is_held_on_a_terminal() {
    for attempt in 1..=3 {
        let sim = patient_sim().await;
        let held = hold_a_key(&sim).await.unwrap_or_else(|e| panic!("{e}"));
        let received = sim.received();
        sim.shutdown().await;
        let stopped = match held {
            Held::Stopped(after) => after,
            Held::NotHeld(gap) => {
                println!("attempt {attempt}: the test typed a repeat {gap:?} late; again");
                continue;
            }
        };
        println!("release -> stop at the robot: {stopped:?}");
        let jogs = named(&received, "LongJogJ");
        assert_eq!(jogs, ["LongJogJ,0,2,0,1,;", "LongJogJ,0,2,0,0,;"]);
        assert!(!named(&received, "LongMoveEvent").is_empty(), "keep-alives");
        return;
    }
    panic!("three attempts, each with the test's own typing too late to hold a key");
}

/// `q` before any key: hansctl ends at once, without jogging.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn q_on_the_terminal_quits_without_jogging() {
    let sim = Sim::start(Config::ready()).await.unwrap();
    let robot = sim.command_addr().to_string();
    let mut term = Terminal::start(&format!("{BIN} --robot {robot} --timeout 3000 jog j3-"));
    let quit = async {
        term.wait_printed("hold any key to jog J3-").await?;
        term.key(b'q')?;
        term.ended().await
    };
    let status = quit.await.unwrap_or_else(|e| panic!("{e}"));
    assert!(status.success(), "hansctl quits on q: {status}");
    assert!(named(&sim.received(), "LongJogJ").is_empty());
    sim.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn jog_for_a_duration_keeps_the_jog_alive_then_releases_it() {
    let sim = patient_sim().await;
    let robot = sim.command_addr().to_string();
    let before = sim.state().cmd_joints[1];
    let t0 = std::time::Instant::now();
    // 2 s: hansctl's first event goes 100 ms after the robot took the
    // start, so only a stall of most of 2 s could leave none.
    let run = tokio::spawn(hansctl(args(&robot, &["jog", "j2+", "--for", "2s"])));
    // Seen jogging while it runs.
    let mut seen = false;
    while !run.is_finished() && t0.elapsed() < Duration::from_secs(20) {
        seen |= sim.fsm() == FsmState::LongJogMoving;
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let out = run.await.unwrap();
    assert!(out.status.success(), "{out:?}");
    assert!(seen, "FSM 26 while jogging");
    let received = sim.received();
    assert_eq!(named(&received, "LongJogJ")[0], "LongJogJ,0,1,1,1,;");
    assert_eq!(
        named(&received, "LongJogJ").last().unwrap().as_str(),
        "LongJogJ,0,1,1,0,;",
        "released"
    );
    // Their period (100 ms) is unit-tested with time the test owns
    // (src/jog.rs): here at least one, and no more than 2 s holds.
    let events = named(&received, "LongMoveEvent").len();
    println!("{events} events in 2 s");
    assert!((1..=20).contains(&events), "{events} events in 2 s");
    // Released: standing still when hansctl ended (it waits for the robot
    // to stand still; the stop, not the simulator's 3 s, ended the jog).
    assert_eq!(sim.fsm(), FsmState::StandBy);
    // The robot took the start before hansctl began its events, and the
    // stop after the last: it jogged at least one event period per event,
    // at 10°/s after a 0.2 s ramp (50°/s²).
    let jogged = 0.1 * events as f64;
    let least = if jogged <= 0.2 {
        25.0 * jogged * jogged
    } else {
        1.0 + 10.0 * (jogged - 0.2)
    };
    let moved = sim.state().cmd_joints[1] - before;
    println!("J2 moved {moved:.2}° in 2 s");
    assert!(
        moved >= least - 1e-6,
        "J2 moved {moved}°, at least {least}°"
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("J2+"), "{text}");

    // A short step: 2°.
    let before = sim.state().cmd_joints[1];
    let out = hansctl(args(&robot, &["jog", "j2-", "--short", "--json"])).await;
    assert!(out.status.success(), "{out:?}");
    let v = json_lines(&out);
    assert_eq!(v.last().unwrap()["done"], true);
    assert!((sim.state().cmd_joints[1] - (before - 2.0)).abs() < 1e-6);

    // Holding a key needs a terminal (stdin is not one here).
    let out = hansctl(args(&robot, &["jog", "x+"])).await;
    assert_eq!(out.status.code(), Some(2), "{out:?}");
    assert!(String::from_utf8_lossy(&out.stderr).contains("--for"));
    let out = hansctl(args(&robot, &["jog", "j7+", "--for", "1s"])).await;
    assert_eq!(out.status.code(), Some(2));
    sim.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn protocol_refuses_what_the_level_has_not_before_sending() {
    let sim = Sim::start(Config::ready()).await.unwrap();
    let robot = sim.command_addr().to_string();
    sim.clear_received();
    let out = hansctl(args(
        &robot,
        &["--protocol", "v5", "jog", "j1+", "--for", "1s"],
    ))
    .await;
    assert_eq!(out.status.code(), Some(2), "{out:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("LongJogJ needs HR6.2.17 (level V5)"), "{err}");
    let out = hansctl(args(
        &robot,
        &[
            "--protocol",
            "v6",
            "send",
            "MoveJ,0,0,0,0,0,0,0,10,0,90,0,90,0,TCP,Base,50,100,0,1,0,0,0,mj,;",
        ],
    ))
    .await;
    assert_eq!(out.status.code(), Some(2), "{out:?}");
    assert!(String::from_utf8_lossy(&out.stderr).contains("MoveJ was removed at HR5.50.3"));
    assert!(sim.received().is_empty(), "{:?}", sim.received());
    // Forced, it goes out, and the V6 controller refuses it as unknown.
    let out = hansctl(args(
        &robot,
        &[
            "--protocol",
            "v6",
            "send",
            "--force",
            "MoveJ,0,0,0,0,0,0,0,10,0,90,0,90,0,TCP,Base,50,100,0,1,0,0,0,mj,;",
        ],
    ))
    .await;
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stdout).contains("MoveJ,Fail,20005"));
    // Commands the level has go out as before.
    let out = hansctl(args(&robot, &["--protocol", "HR6.4.8", "state"])).await;
    assert!(out.status.success(), "{out:?}");
    let out = hansctl(args(&robot, &["--protocol", "v7", "state"])).await;
    assert_eq!(out.status.code(), Some(2));
    sim.shutdown().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn error_prints_the_controllers_text_or_the_codecs() {
    let sim = Sim::start(Config::ready()).await.unwrap();
    let robot = sim.command_addr().to_string();
    let out = hansctl(args(&robot, &["error", "20018"])).await;
    assert!(out.status.success(), "{out:?}");
    assert_eq!(
        String::from_utf8_lossy(&out.stdout).trim(),
        "20018 StateRefused: command forbidden in this state"
    );
    let out = hansctl(args(&robot, &["--json", "error", "20042"])).await;
    let v = json_lines(&out);
    assert_eq!(
        (v[0]["text"].as_str(), v[0]["source"].as_str()),
        (Some("path not ready"), Some("controller")),
        "the simulator's own text (the codec has none)"
    );
    assert!(named(&sim.received(), "GetErrorCodeStr").len() == 2);
    // A V5 controller has no GetErrorCodeStr: the codec's table.
    let old = Sim::start(Config {
        protocol: ProtocolLevel::V5,
        ..Config::ready()
    })
    .await
    .unwrap();
    let old_robot = old.command_addr().to_string();
    let out = hansctl(args(&old_robot, &["--json", "error", "20018"])).await;
    assert!(out.status.success(), "{out:?}");
    let v = json_lines(&out);
    assert_eq!(
        (v[0]["text"].as_str(), v[0]["source"].as_str()),
        (Some("command forbidden in this state"), Some("codec"))
    );
    // With --protocol v5 it is not even asked.
    old.clear_received();
    let out = hansctl(args(&old_robot, &["--protocol", "v5", "error", "10000"])).await;
    assert!(out.status.success(), "{out:?}");
    assert!(String::from_utf8_lossy(&out.stdout).contains("Short circuit error"));
    assert!(old.received().is_empty());
    // No text anywhere: exit 1.
    let out = hansctl(args(&old_robot, &["--protocol", "v5", "error", "12345"])).await;
    assert_eq!(out.status.code(), Some(1));
    // A V6 controller answers every code, one it does not know with
    // `unkown error` (sic): no text either, exit 1, as the README says.
    let out = hansctl(args(&robot, &["error", "12345"])).await;
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    assert_eq!(
        String::from_utf8_lossy(&out.stdout).trim(),
        "12345 (no name): (no text known)"
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("the controller knows no text for 12345"));
    let out = hansctl(args(&robot, &["--json", "error", "12345"])).await;
    assert_eq!(out.status.code(), Some(1));
    let v = json_lines(&out);
    assert_eq!(
        (v[0]["text"].is_null(), v[0]["source"].as_str()),
        (true, Some("none"))
    );
    old.shutdown().await;
    sim.shutdown().await;
}
