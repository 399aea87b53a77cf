//! `hansctl`: decode Hans protocol messages and drive a robot (or
//! `hans-sim`) from the command line.
//!
//! Exit status: 0 success, 1 the robot refused (`Fail`) or a move failed,
//! 2 bad input, 3 connection error or timeout.

mod client;
mod decode;
mod fleet;
mod jog;
mod json;
mod sparkplug;

use std::io::{BufRead, Read, Write};
use std::net::TcpStream;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::{Parser, Subcommand};
use hans_codec::datasheet::{DataSheet, Deframer};
use hans_codec::{
    request as rq, response as rs, Command, Decimal, FsmState, ProtocolLevel, RobotId,
};

use client::{check, resolve, response, Client, ClientError};
use json::{Json, Obj};

#[derive(Parser, Debug)]
#[command(
    name = "hansctl",
    version,
    about = "Decode Hans robot protocol messages and drive a robot"
)]
struct Cli {
    /// The robot (or simulator): HOST or HOST:PORT (default port 10003).
    #[arg(long, global = true, default_value = "127.0.0.1")]
    robot: String,
    /// Timeout for connecting and for each reply, in milliseconds.
    #[arg(long, global = true, default_value_t = 5000)]
    timeout: u64,
    /// Machine-readable output: one JSON object per line.
    #[arg(long, global = true)]
    json: bool,
    /// The controller's protocol level: v5 (HR-TCP V1.0.0.3), v6 (HR6.6.1)
    /// or its version (HR6.4.8). A command that level does not have is
    /// refused before it is sent (exit status 2). Without it, nothing is
    /// checked.
    #[arg(long, global = true, value_parser = parse_level)]
    protocol: Option<ProtocolLevel>,
    #[command(subcommand)]
    cmd: Cmd,
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

#[derive(Subcommand, Debug)]
enum Cmd {
    /// Read messages (requests or replies), one per line on stdin, and
    /// print one JSON object per line.
    ///
    /// Each line is one message as it appears on the wire. Blank lines are
    /// skipped; every other line gives one object, and decoding goes on to
    /// the end of the input (exit status 0 unless stdin or stdout fail).
    ///
    /// Keys: name, kind (request, ok, fail, errorcmd, invalid), known (the
    /// name is in the command table), then
    ///   fields          typed values by parameter name, in wire order
    ///   code, code_name, detail   for a Fail reply
    ///   error           why the line is not a valid message
    ///   range_error     a request outside the document's ranges
    ///   warnings        numbers with more digits than the codec keeps
    ///   against_request the reply was read against the request before it
    ///
    /// Numbers are written exactly as the codec holds them (hans-codec's
    /// Decimal), never through a 64-bit float: -0.000 stays -0.000, 1.500000
    /// stays 1.500000, 0.123456789012345678 keeps every digit. Exponent
    /// forms are written as the same value in plain decimals (1e-05 ->
    /// 0.00001). The codec keeps 19 significant digits and 18 decimals
    /// (hans-codec's Decimal); digits beyond that are dropped, and a
    /// warning quotes the text as written.
    /// Parse the output with a JSON reader that keeps decimals (Python:
    /// json.loads(line, parse_float=decimal.Decimal)) to keep them exact.
    ///
    /// Lines are bytes: a line that is not UTF-8 gets an error naming the
    /// first bad byte and its offset. A line not ending in ';' (spaces or
    /// tabs after it are ignored) is an incomplete message on the wire: it
    /// gets an error, and its body is still decoded into fields. Lines
    /// longer than 1 MiB are skipped with an error.
    ///
    /// A reply (OK or Fail) on the line right after a valid request of the
    /// same command is read against that request, e.g. a ReadBoxDI reply
    /// must have one value per bit asked for; it gets
    /// "against_request": true. Any other reply is read by its name alone
    /// (a list of any valid length).
    #[command(
        verbatim_doc_comment,
        about = "Read messages (requests or replies), one per line on stdin, print one JSON object per line"
    )]
    Decode,
    /// Send one message and print the typed reply.
    Send {
        /// The message, e.g. 'ReadCurFSM,0,;' (a missing ',;' is added).
        message: String,
        /// Send even if the message does not read as its command.
        #[arg(long)]
        force: bool,
    },
    /// FSM state, flags, error, positions.
    State,
    /// Bring-up: ConnectToBox, Electrify, StartMaster, GrpEnable, each
    /// waited for, up to StandBy.
    PowerOn,
    /// Joint move to J1..J6 (degrees).
    MoveJoint {
        /// Six joint angles.
        #[arg(num_args = 6, allow_negative_numbers = true, required = true)]
        joints: Vec<f64>,
        /// Velocity, °/s.
        #[arg(long, default_value_t = 30.0)]
        vel: f64,
        /// Acceleration, °/s².
        #[arg(long, default_value_t = 100.0)]
        acc: f64,
        /// Wait for the end of the move (chapter 6), showing progress.
        #[arg(long)]
        wait: bool,
    },
    /// Linear move to X Y Z (mm) Rx Ry Rz (°).
    MoveLine {
        /// Six pose values.
        #[arg(num_args = 6, allow_negative_numbers = true, required = true)]
        pose: Vec<f64>,
        /// Velocity, mm/s.
        #[arg(long, default_value_t = 100.0)]
        vel: f64,
        /// Acceleration, mm/s².
        #[arg(long, default_value_t = 500.0)]
        acc: f64,
        /// Tool frame name.
        #[arg(long, default_value = "TCP")]
        tcp: String,
        /// User frame name.
        #[arg(long, default_value = "Base")]
        ucs: String,
        /// Wait for the end of the move (chapter 6), showing progress.
        #[arg(long)]
        wait: bool,
    },
    /// Stop the motion (GrpStop).
    Stop,
    /// Clear errors (GrpReset).
    Reset,
    /// Read all box and end I/O, or set one output:
    /// `io set do|co|end-do BIT 0|1`, `io set ao CHANNEL VALUE [--mode 1|2]`.
    Io {
        #[command(subcommand)]
        action: Option<IoCmd>,
    },
    /// Jog one joint or Cartesian axis (V6 commands: LongJogJ/L and
    /// LongMoveEvent, ShortJogJ/L).
    ///
    /// AXIS is j1..j6, or x, y, z, rx, ry, rz (user frame, or tool frame
    /// after SetToolMotion), followed by + or -: `hansctl jog j2+`.
    ///
    /// From a terminal, hold any key: the jog starts with the first key
    /// press and runs while the keyboard repeats it; it stops when the
    /// repeats stop (release), or on q, Esc or Ctrl-C. With --for it runs for
    /// that long; with --short it is one step (2° or 2 mm). While it runs,
    /// LongMoveEvent goes out every 100 ms (the document asks for at least
    /// every 200 ms); if hansctl stops sending, the controller stops the jog.
    #[command(verbatim_doc_comment)]
    Jog {
        /// j1..j6 or x, y, z, rx, ry, rz, then + or -.
        axis: String,
        /// Jog for this long (e.g. 1.5s, 800ms, 2) instead of while a key
        /// is held.
        #[arg(long = "for", value_name = "DURATION", value_parser = parse_duration)]
        duration: Option<Duration>,
        /// One short step (ShortJogJ/L) instead of a long jog.
        #[arg(long, conflicts_with = "duration")]
        short: bool,
    },
    /// The controller's text for an error code (GetErrorCodeStr), or the
    /// codec's when the controller has none to give (a V5 controller,
    /// --protocol v5, no connection).
    Error {
        /// The error code, e.g. 20018.
        #[arg(allow_negative_numbers = true)]
        code: i32,
    },
    /// Live view of the DataSheet stream.
    Watch {
        /// DataSheet port (10004 = 20 Hz, 10005 = 10 Hz, 10006 = 5 Hz).
        #[arg(long, default_value_t = 10004)]
        port: u16,
        /// Stop after this many packets (0 = until interrupted).
        #[arg(long, default_value_t = 0)]
        count: u64,
    },
    /// Live table of the Sparkplug B edge nodes (gateways) on an MQTT
    /// broker: alive or DEAD, robot link, FSM state, robot error, last
    /// command and its result, time since each node's last message.
    ///
    /// Subscribes to spBv1.0/GROUP/# (every group without --group). A
    /// node is ALIVE from its NBIRTH and DEAD from the NDEATH of the same
    /// bdSeq (an NDEATH of another bdSeq is a late Will of an earlier
    /// session: ignored). On a terminal the table is redrawn in place (at
    /// most 4 times a second); otherwise it is printed as a block at most
    /// once a second when something changed, and once at the end. With
    /// --json: one object per message (type, group, node, device, seq,
    /// timestamp, metrics by name, commands, stale, error).
    ///
    /// Runs until Ctrl-C or --for; exit status 3 if the broker cannot be
    /// reached and subscribed to within --timeout.
    #[command(verbatim_doc_comment)]
    Fleet {
        /// The MQTT broker: HOST:PORT (HOST alone: port 1883).
        #[arg(long)]
        broker: String,
        /// Only this Sparkplug group (default: every group).
        #[arg(long)]
        group: Option<String>,
        /// End after this long (e.g. 10, 2.5s, 800ms); default: until Ctrl-C.
        #[arg(long = "for", value_name = "SECONDS", value_parser = parse_duration)]
        duration: Option<Duration>,
        /// MQTT client id (default: hansctl-fleet-PID).
        #[arg(long)]
        client_id: Option<String>,
        /// Never publish: by default a node seen without its birth (born
        /// before the view started) is asked once for a rebirth (an NCMD
        /// Node Control/Rebirth, the one command a gateway obeys).
        #[arg(long)]
        no_rebirth: bool,
    },
}

#[derive(Subcommand, Debug)]
enum IoCmd {
    /// Set an output.
    Set {
        /// do, co, end-do or ao.
        kind: String,
        /// Bit or channel.
        index: i32,
        /// 0/1, or the analog value.
        value: f64,
        /// Analog mode: 1 voltage, 2 current.
        #[arg(long, default_value_t = 1)]
        mode: i32,
    },
}

/// An error with its exit status.
struct Exit(u8, String);

impl From<ClientError> for Exit {
    fn from(e: ClientError) -> Self {
        let code = match e {
            ClientError::Fail(..) | ClientError::ErrorCmd(_) => 1,
            ClientError::Level(_) => 2,
            _ => 3,
        };
        Exit(code, e.to_string())
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(Exit(code, msg)) => {
            if cli.json {
                println!("{}", obj! { "error" => msg });
            } else {
                eprintln!("hansctl: {msg}");
            }
            ExitCode::from(code)
        }
    }
}

fn run(cli: &Cli) -> Result<(), Exit> {
    let timeout = Duration::from_millis(cli.timeout.max(1));
    let connect = || -> Result<Client, Exit> {
        let addr = resolve(&cli.robot, 10003)?;
        Ok(Client::connect(addr, timeout, cli.protocol)?)
    };
    match &cli.cmd {
        Cmd::Decode => decode_stdin(),
        Cmd::Send { message, force } => send(cli, connect()?, message, *force),
        Cmd::State => state(cli, &mut connect()?),
        Cmd::PowerOn => power_on(cli, &mut connect()?, timeout),
        Cmd::MoveJoint {
            joints,
            vel,
            acc,
            wait,
        } => {
            let mut c = connect()?;
            let q = arr6(joints)?;
            let pose = c
                .call(&rq::GetForwardKin {
                    joints: q,
                    ..Default::default()
                })
                .ok()
                .and_then(|r| {
                    match response(
                        &r,
                        hans_codec::ReplyExpect::of(hans_codec::CommandId::GetForwardKin),
                    ) {
                        Some(hans_codec::Response::GetForwardKin(p)) => Some(p.pose),
                        _ => None,
                    }
                })
                .unwrap_or_default();
            let cmd = rq::WayPoint {
                rbt_id: RobotId(0),
                pose,
                joints: q,
                tcp_name: "TCP",
                ucs_name: "Base",
                velocity: d(*vel),
                acc: d(*acc),
                radius: Decimal::ZERO,
                move_type: 0,
                use_joint: 1,
                cmd_id: "hansctl",
                ..Default::default()
            };
            start_move(cli, &mut c, &cmd, *wait)
        }
        Cmd::MoveLine {
            pose,
            vel,
            acc,
            tcp,
            ucs,
            wait,
        } => {
            let mut c = connect()?;
            let reference = read_act_pos(&mut c)?.joints;
            let cmd = rq::WayPoint {
                rbt_id: RobotId(0),
                pose: arr6(pose)?,
                joints: reference,
                tcp_name: tcp,
                ucs_name: ucs,
                velocity: d(*vel),
                acc: d(*acc),
                radius: Decimal::ZERO,
                move_type: 1,
                use_joint: 0,
                cmd_id: "hansctl",
                ..Default::default()
            };
            start_move(cli, &mut c, &cmd, *wait)
        }
        Cmd::Stop => simple(cli, &mut connect()?, &rq::GrpStop::default()),
        Cmd::Reset => simple(cli, &mut connect()?, &rq::GrpReset::default()),
        Cmd::Io { action: None } => io_read(cli, &mut connect()?),
        Cmd::Io {
            action:
                Some(IoCmd::Set {
                    kind,
                    index,
                    value,
                    mode,
                }),
        } => io_set(cli, &mut connect()?, kind, *index, *value, *mode),
        Cmd::Jog {
            axis,
            duration,
            short,
        } => {
            let axis = jog::Axis::parse(axis).map_err(|e| Exit(2, e))?;
            // Refused before connecting when the level has no jogging.
            jog::check_level(cli.protocol, &axis, *short).map_err(Exit::from)?;
            let mode = match (short, duration) {
                (true, _) => jog::Mode::Short,
                (false, Some(d)) => jog::Mode::For(*d),
                (false, None) => jog::Mode::Held,
            };
            jog::run(cli.json, &mut connect()?, &axis, mode)
        }
        Cmd::Error { code } => error_text(cli, *code, connect),
        Cmd::Watch { port, count } => watch(cli, *port, *count, timeout),
        Cmd::Fleet {
            broker,
            group,
            duration,
            client_id,
            no_rebirth,
        } => fleet::run(&fleet::Options {
            broker: broker.clone(),
            group: group.clone(),
            json: cli.json,
            duration: *duration,
            client_id: client_id.clone(),
            timeout,
            rebirth: !*no_rebirth,
        }),
    }
}

/// `1.5s`, `800ms`, `2` (seconds).
fn parse_duration(s: &str) -> Result<Duration, String> {
    let t = s.trim();
    let (num, scale) = if let Some(v) = t.strip_suffix("ms") {
        (v, 0.001)
    } else if let Some(v) = t.strip_suffix('s') {
        (v, 1.0)
    } else {
        (t, 1.0)
    };
    match num.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 && v * scale <= 86_400.0 => {
            Ok(Duration::from_secs_f64(v * scale))
        }
        _ => Err(format!("{s:?}: expected a duration such as 1.5s or 800ms")),
    }
}

/// `error CODE`: the controller's text, else the codec's.
fn error_text(
    cli: &Cli,
    code: i32,
    connect: impl FnOnce() -> Result<Client, Exit>,
) -> Result<(), Exit> {
    let ec = hans_codec::ErrorCode::from(code);
    let req = rq::GetErrorCodeStr { code: ec };
    let asked = match cli.protocol.map(|l| req.check_level(l)) {
        // The level has no GetErrorCodeStr: do not ask.
        Some(Err(e)) => Err(format!("{e}")),
        _ => connect()
            .map_err(|Exit(_, m)| m)
            .and_then(|mut c| c.call(&req).map_err(|e| e.to_string())),
    };
    let answer = asked
        .as_ref()
        .ok()
        .and_then(|r| match response(r, req.expect()) {
            Some(hans_codec::Response::GetErrorCodeStr(t)) => Some(t.text.as_str().to_string()),
            _ => None,
        });
    // A controller answers every code: one it does not know with the text
    // it prints for that (`unkown error`, sic), which is not a text for it.
    let (controller, unknown_to_it) = match answer {
        Some(t) if controller_knows_none(&t) => (None, Some(t)),
        other => (other, None),
    };
    let (text, source) = match (controller, ec.text()) {
        (Some(t), _) => (Some(t), "controller"),
        (None, Some(t)) => (Some(t.to_string()), "codec"),
        (None, None) => (None, "none"),
    };
    if !cli.json {
        if let Err(why) = &asked {
            eprintln!(
                "hansctl: the controller's text is not available ({why}); the codec's table:"
            );
        } else if let Some(t) = &unknown_to_it {
            eprintln!("hansctl: the controller knows no text for {code} (it answers {t:?})");
        }
    }
    let name = ec.name();
    if cli.json {
        println!(
            "{}",
            obj! {
                "code" => code, "name" => name, "text" => text.as_deref(),
                "source" => source,
            }
        );
    } else {
        println!(
            "{code} {}: {}",
            name.unwrap_or("(no name)"),
            text.as_deref().unwrap_or("(no text known)")
        );
    }
    match text {
        Some(_) => Ok(()),
        None => Err(Exit(1, format!("no text known for {code}"))),
    }
}

/// The controller's answer to `GetErrorCodeStr` for a code it does not know:
/// the V6 document's controller prints `unkown error` (sic); a corrected
/// spelling is taken too.
fn controller_knows_none(text: &str) -> bool {
    let t = text.trim();
    t.eq_ignore_ascii_case("unkown error") || t.eq_ignore_ascii_case("unknown error")
}

fn d(v: f64) -> Decimal {
    Decimal::from_f64(v, 3).unwrap_or(Decimal::ZERO)
}

fn arr6(v: &[f64]) -> Result<[Decimal; 6], Exit> {
    let a: [f64; 6] = v
        .try_into()
        .map_err(|_| Exit(2, "six values are needed".into()))?;
    if a.iter().any(|x| !x.is_finite()) {
        return Err(Exit(2, "values must be finite numbers".into()));
    }
    Ok(a.map(d))
}

fn fmt6(v: &[Decimal; 6]) -> String {
    v.iter()
        .map(|x| x.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

fn decode_stdin() -> Result<(), Exit> {
    let mut input = std::io::stdin().lock();
    let mut out = std::io::stdout().lock();
    let mut decoder = decode::Decoder::new();
    let mut line = Vec::new();
    loop {
        let len = read_line(&mut input, &mut line, decode::MAX_LINE)
            .map_err(|e| Exit(2, format!("reading stdin: {e}")))?;
        let v = match len {
            None => return Ok(()),
            Some(len) if line.len() < len => Some(decoder.too_long(len)),
            Some(_) => decoder.line(&line),
        };
        if let Some(v) = v {
            writeln!(out, "{v}").map_err(|e| Exit(3, e.to_string()))?;
        }
    }
}

/// Reads one line (through its `\n`, if any) into `line`, keeping at most
/// `max` bytes of it (line end excluded) and skipping the rest. Returns the
/// line's full length without its `\n` (more than `line.len()` when bytes
/// were skipped), or `None` at the end of the input.
fn read_line(
    input: &mut impl BufRead,
    line: &mut Vec<u8>,
    max: usize,
) -> std::io::Result<Option<usize>> {
    line.clear();
    let mut len = 0usize;
    let mut any = false;
    loop {
        let chunk = match input.fill_buf() {
            Ok(c) => c,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        if chunk.is_empty() {
            return Ok(any.then_some(len));
        }
        any = true;
        let (body, used, done) = match chunk.iter().position(|&b| b == b'\n') {
            Some(i) => (chunk.get(..i).unwrap_or(&[]), i + 1, true),
            None => (chunk, chunk.len(), false),
        };
        let room = max.saturating_sub(line.len());
        line.extend_from_slice(body.get(..room.min(body.len())).unwrap_or(&[]));
        len = len.saturating_add(body.len());
        input.consume(used);
        if done {
            return Ok(Some(len));
        }
    }
}

fn send(cli: &Cli, mut c: Client, message: &str, force: bool) -> Result<(), Exit> {
    let mut msg = message.trim().to_string();
    if !msg.ends_with(';') {
        if !msg.ends_with(',') {
            msg.push(',');
        }
        msg.push(';');
    }
    // The level: a command the controller does not have is not sent
    // (unless forced), whether or not its fields read.
    if let Some(level) = cli.protocol {
        let id = hans_codec::CommandId::from_name(msg.split(',').next().unwrap_or("").trim());
        if let Some(Err(e)) = id.map(|id| id.check_level(level)) {
            if !force {
                return Err(Exit(
                    2,
                    format!("{e}: not sent (use --force to send it anyway)"),
                ));
            }
            eprintln!("hansctl: warning: {e} (sent anyway)");
        }
    }
    let expect = match client::typed(&msg) {
        Ok(req) => {
            if let Err(e) = req.validate() {
                eprintln!("hansctl: warning: {e} (sent anyway)");
            }
            req.expect()
        }
        Err(e) if force => {
            eprintln!("hansctl: warning: {e} (sent anyway)");
            hans_codec::ReplyExpect::from_name(msg.split(',').next().unwrap_or(""))
        }
        Err(e) => return Err(Exit(2, format!("{e} (use --force to send it anyway)"))),
    };
    let reply = c.call_raw(&msg)?;
    let v = decode::reply(&reply, expect);
    if cli.json {
        println!("{v}");
    } else {
        println!("{reply}");
        if let Json::Obj(o) = &v {
            print_human(o);
        }
    }
    check(&reply, expect).map_err(Exit::from)
}

fn print_human(v: &Obj) {
    let text = |key| match v.get(key) {
        Some(Json::Str(s)) => Some(s.as_str()),
        _ => None,
    };
    if let Some(e) = text("error") {
        println!("  unreadable reply: {e}");
        return;
    }
    match text("kind") {
        Some("ok") => {
            if let Some(Json::Obj(f)) = v.get("fields") {
                for (k, val) in f.iter() {
                    println!("  {k} = {val}");
                }
            }
        }
        Some("fail") => {
            let name = text("code_name").unwrap_or("unknown code");
            let code = v.get("code").unwrap_or(&Json::Null);
            let detail = v.get("detail").unwrap_or(&Json::Null);
            println!("  failed: {code} ({name}) {detail}");
        }
        _ => {}
    }
}

fn simple<'a, C: Command<'a>>(cli: &Cli, c: &mut Client, cmd: &C) -> Result<(), Exit> {
    let r = c.call(cmd)?;
    if cli.json {
        println!("{}", decode::reply(&r, cmd.expect()));
    } else {
        println!("{r}");
    }
    Ok(())
}

fn read_fsm(c: &mut Client) -> Result<FsmState, Exit> {
    let cmd = rq::ReadCurFSM::default();
    let r = c.call(&cmd)?;
    match response(&r, cmd.expect()) {
        Some(hans_codec::Response::ReadCurFSM(s)) => Ok(s.state),
        _ => Err(Exit(3, format!("unexpected reply {r}"))),
    }
}

fn read_state(c: &mut Client) -> Result<rs::ReadRobotState, Exit> {
    let cmd = rq::ReadRobotState::default();
    let r = c.call(&cmd)?;
    match response(&r, cmd.expect()) {
        Some(hans_codec::Response::ReadRobotState(s)) => Ok(s),
        _ => Err(Exit(3, format!("unexpected reply {r}"))),
    }
}

fn read_act_pos(c: &mut Client) -> Result<rs::ReadActPos, Exit> {
    let cmd = rq::ReadActPos::default();
    let r = c.call(&cmd)?;
    match response(&r, cmd.expect()) {
        Some(hans_codec::Response::ReadActPos(s)) => Ok(s),
        _ => Err(Exit(3, format!("unexpected reply {r}"))),
    }
}

fn fsm_name(s: FsmState) -> String {
    format!("{} {}", s.code(), s.name().unwrap_or("(unknown)"))
}

fn state(cli: &Cli, c: &mut Client) -> Result<(), Exit> {
    let fsm = read_fsm(c)?;
    let s = read_state(c)?;
    let p = read_act_pos(c)?;
    if cli.json {
        println!(
            "{}",
            obj! {
                "fsm" => fsm.code(), "fsm_name" => fsm.name(),
                "moving" => s.moving, "enabled" => s.enabled, "error" => s.error,
                "error_code" => s.error_code, "error_axis" => s.error_axis,
                "brake_released" => s.brake_released, "paused" => s.paused,
                "emergency_stop" => s.emergency_stop, "safety_guard" => s.safety_guard,
                "powered" => s.powered, "box_connected" => s.box_connected,
                "blending_done" => s.blending_done, "in_position" => s.in_position,
                "joints" => &p.joints, "pose" => &p.pose,
            }
        );
    } else {
        println!("FSM      {}", fsm_name(fsm));
        println!(
            "flags    moving={} enabled={} paused={} powered={} box={} blending_done={} in_pos={}",
            s.moving,
            s.enabled,
            s.paused,
            s.powered,
            s.box_connected,
            s.blending_done,
            s.in_position
        );
        println!(
            "safety   emergency_stop={} safety_guard={}",
            s.emergency_stop, s.safety_guard
        );
        if s.error != 0 {
            let code = hans_codec::ErrorCode::from(s.error_code);
            println!("error    {code} on axis {}", s.error_axis);
        } else {
            println!("error    none");
        }
        println!("joints   {}", fmt6(&p.joints));
        println!("pose     {}", fmt6(&p.pose));
    }
    Ok(())
}

/// Polls `ReadCurFSM` until `done(state)`; fails on a state in `bad`.
fn wait_fsm(
    c: &mut Client,
    limit: Duration,
    done: impl Fn(FsmState) -> bool,
) -> Result<FsmState, Exit> {
    let start = Instant::now();
    loop {
        let s = read_fsm(c)?;
        if done(s) {
            return Ok(s);
        }
        if start.elapsed() > limit {
            return Err(Exit(
                3,
                format!("still in FSM {} after {limit:?}", fsm_name(s)),
            ));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn power_on(cli: &Cli, c: &mut Client, timeout: Duration) -> Result<(), Exit> {
    use FsmState as F;
    let limit = timeout.max(Duration::from_secs(10));
    let report = |step: &str, s: FsmState| {
        if cli.json {
            println!(
                "{}",
                obj! { "step" => step, "fsm" => s.code(), "fsm_name" => s.name() }
            );
        } else {
            println!("{step:<13} ok   FSM {}", fsm_name(s));
        }
    };
    let s = read_fsm(c)?;
    if s == F::EmergencyStop {
        return Err(Exit(1, "emergency stop is pressed".into()));
    }
    if matches!(s, F::ElectricBoxDisconnect | F::ElectricBoxConnecting) {
        c.call(&rq::ConnectToBox {})?;
        let s = wait_fsm(c, limit, |s| {
            !matches!(s, F::ElectricBoxDisconnect | F::ElectricBoxConnecting)
        })?;
        report("ConnectToBox", s);
    }
    let s = read_fsm(c)?;
    if matches!(s, F::Blackout48V | F::Electrifying48V | F::Blackouting48V) {
        c.call(&rq::Electrify {})?;
        let s = wait_fsm(c, limit, |s| {
            !matches!(s, F::Blackout48V | F::Electrifying48V | F::Blackouting48V)
        })?;
        report("Electrify", s);
    }
    let s = read_fsm(c)?;
    if matches!(
        s,
        F::ControllerDisconnect | F::ControllerConnecting | F::ControllerChecking
    ) {
        c.call(&rq::StartMaster {})?;
        let s = wait_fsm(c, limit, |s| {
            !matches!(
                s,
                F::ControllerDisconnect | F::ControllerConnecting | F::ControllerChecking
            )
        })?;
        report("StartMaster", s);
    }
    let s = read_fsm(c)?;
    if s == F::Error {
        c.call(&rq::GrpReset::default())?;
        let s = wait_fsm(c, limit, |s| !matches!(s, F::Error | F::Reseting))?;
        report("GrpReset", s);
    }
    let s = read_fsm(c)?;
    if matches!(s, F::Disable | F::Enabling) {
        c.call(&rq::GrpEnable::default())?;
        let s = wait_fsm(c, limit, |s| !matches!(s, F::Disable | F::Enabling))?;
        report("GrpEnable", s);
    }
    let s = read_fsm(c)?;
    if s == F::StandBy {
        if !cli.json {
            println!("ready        FSM {}", fsm_name(s));
        }
        Ok(())
    } else {
        Err(Exit(1, format!("bring-up ended in FSM {}", fsm_name(s))))
    }
}

fn start_move<'a, C: Command<'a>>(
    cli: &Cli,
    c: &mut Client,
    cmd: &C,
    wait: bool,
) -> Result<(), Exit> {
    c.call(cmd)?;
    if !cli.json {
        println!("move accepted");
    }
    if !wait {
        return Ok(());
    }
    // Chapter 6: poll ReadRobotState until the move ends or fails. The
    // moving flag lags the motion (~50 ms), so the move counts as running
    // until the way point is done (nBlendingDone) and the flag is clear.
    let start = Instant::now();
    let mut last_print = Instant::now() - Duration::from_secs(1);
    loop {
        let s = read_state(c)?;
        if s.error != 0 {
            let code = hans_codec::ErrorCode::from(s.error_code);
            return Err(Exit(
                1,
                format!(
                    "move failed: error {code} on axis {} (send GrpReset)",
                    s.error_axis
                ),
            ));
        }
        let fsm = read_fsm(c)?;
        let done = s.moving == 0 && s.blending_done == 1 && fsm != FsmState::Moving;
        if done || last_print.elapsed() >= Duration::from_millis(500) {
            let p = read_act_pos(c)?;
            if cli.json {
                println!(
                    "{}",
                    obj! {
                        "t" => Decimal::from_f64(start.elapsed().as_secs_f64(), 3),
                        "fsm" => fsm.code(), "moving" => s.moving, "done" => done,
                        "joints" => &p.joints, "pose" => &p.pose,
                    }
                );
            } else {
                println!(
                    "{:6.2}s  FSM {:<16} joints [{}]",
                    start.elapsed().as_secs_f64(),
                    fsm_name(fsm),
                    fmt6(&p.joints)
                );
            }
            last_print = Instant::now();
        }
        if done {
            if fsm == FsmState::StandBy {
                return Ok(());
            }
            return Err(Exit(1, format!("move ended in FSM {}", fsm_name(fsm))));
        }
        if start.elapsed() > Duration::from_secs(600) {
            return Err(Exit(3, "move still running after 600 s".into()));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn io_read(cli: &Cli, c: &mut Client) -> Result<(), Exit> {
    let all8 = || hv::<8>(&[0, 1, 2, 3, 4, 5, 6, 7]);
    let mut out = Obj::new();
    let mut text = Vec::new();
    macro_rules! read_list {
        ($label:literal, $cmd:expr, $Resp:ident) => {{
            let cmd = $cmd;
            let r = c.call(&cmd)?;
            if let Some(hans_codec::Response::$Resp(v)) = response(&r, cmd.expect()) {
                let vals = Json::from(v.values.as_slice());
                text.push(format!(
                    "{:<7}{}",
                    $label,
                    v.values
                        .iter()
                        .map(|x| x.to_string())
                        .collect::<Vec<_>>()
                        .join(" ")
                ));
                out.insert($label, vals);
            }
        }};
    }
    read_list!("CI", rq::ReadBoxCI { bits: all8() }, ReadBoxCI);
    read_list!("CO", rq::ReadBoxCO { bits: all8() }, ReadBoxCO);
    read_list!("DI", rq::ReadBoxDI { bits: all8() }, ReadBoxDI);
    read_list!("DO", rq::ReadBoxDO { bits: all8() }, ReadBoxDO);
    let two = hv::<2>(&[0, 1]);
    {
        let cmd = rq::ReadBoxAI {
            channels: two.clone(),
        };
        let r = c.call(&cmd)?;
        if let Some(hans_codec::Response::ReadBoxAI(v)) = response(&r, cmd.expect()) {
            let vals = Json::from(v.values.as_slice());
            text.push(format!(
                "AI     {}",
                v.values
                    .iter()
                    .map(|x| x.to_string())
                    .collect::<Vec<_>>()
                    .join(" ")
            ));
            out.insert("AI", vals);
        }
        let cmd = rq::ReadBoxAO { channels: two };
        let r = c.call(&cmd)?;
        if let Some(hans_codec::Response::ReadBoxAO(v)) = response(&r, cmd.expect()) {
            let vals = Json::from(v.values.as_slice());
            text.push(format!(
                "AO     {}",
                v.values
                    .iter()
                    .map(|x| x.to_string())
                    .collect::<Vec<_>>()
                    .join(" ")
            ));
            out.insert("AO", vals);
        }
    }
    let three = hv::<3>(&[0, 1, 2]);
    // The tool end needs the arm powered: report, do not fail.
    match c.call(&rq::ReadEI {
        rbt_id: RobotId(0),
        bits: three.clone(),
    }) {
        Ok(r) => {
            if let Some(hans_codec::Response::ReadEI(v)) = response(
                &r,
                hans_codec::ReplyExpect::of(hans_codec::CommandId::ReadEI),
            ) {
                text.push(format!(
                    "EndDI  {}",
                    v.values
                        .iter()
                        .map(|x| x.to_string())
                        .collect::<Vec<_>>()
                        .join(" ")
                ));
                out.insert("EndDI", v.values.as_slice());
            }
            let cmd = rq::ReadEO {
                rbt_id: RobotId(0),
                bits: three,
            };
            let r = c.call(&cmd)?;
            if let Some(hans_codec::Response::ReadEO(v)) = response(&r, cmd.expect()) {
                text.push(format!(
                    "EndDO  {}",
                    v.values
                        .iter()
                        .map(|x| x.to_string())
                        .collect::<Vec<_>>()
                        .join(" ")
                ));
                out.insert("EndDO", v.values.as_slice());
            }
        }
        Err(e) => text.push(format!("end I/O unavailable: {e}")),
    }
    if cli.json {
        println!("{}", Json::Obj(out));
    } else {
        for l in text {
            println!("{l}");
        }
    }
    Ok(())
}

fn hv<const N: usize>(v: &[i32]) -> heapless::Vec<i32, N> {
    heapless::Vec::from_slice(v).unwrap_or_default()
}

fn io_set(
    cli: &Cli,
    c: &mut Client,
    kind: &str,
    index: i32,
    value: f64,
    mode: i32,
) -> Result<(), Exit> {
    let bit = if value == 0.0 { 0 } else { 1 };
    match kind.to_ascii_lowercase().as_str() {
        "do" => simple(
            cli,
            c,
            &rq::SetBoxDO {
                bit: index,
                value: bit,
            },
        ),
        "co" => simple(
            cli,
            c,
            &rq::SetBoxCO {
                bit: index,
                value: bit,
            },
        ),
        "end-do" | "enddo" | "eo" => simple(
            cli,
            c,
            &rq::SetEndDO {
                rbt_id: RobotId(0),
                bit: index,
                value: bit,
            },
        ),
        "ao" => simple(
            cli,
            c,
            &rq::SetBoxAO {
                channel: index,
                value: d(value),
                mode,
            },
        ),
        other => Err(Exit(
            2,
            format!("unknown output {other:?}: use do, co, end-do or ao"),
        )),
    }
}

fn watch(cli: &Cli, port: u16, count: u64, timeout: Duration) -> Result<(), Exit> {
    let addr = resolve(&cli.robot, port)?;
    let host_has_port = cli.robot.contains(':') && !cli.robot.starts_with('[');
    let addr = if host_has_port {
        std::net::SocketAddr::new(addr.ip(), port)
    } else {
        addr
    };
    let mut s = TcpStream::connect_timeout(&addr, timeout)
        .map_err(|e| Exit(3, format!("cannot connect to {addr}: {e}")))?;
    s.set_read_timeout(Some(timeout))
        .map_err(|e| Exit(3, e.to_string()))?;
    let mut deframer: Box<Deframer<65536>> = Box::default();
    let mut buf = vec![0u8; 16384];
    let mut seen = 0u64;
    loop {
        let n = match s.read(&mut buf) {
            Ok(0) => return Err(Exit(3, "the DataSheet stream closed".into())),
            Ok(n) => n,
            Err(_) => return Err(Exit(3, format!("no DataSheet packet within {timeout:?}"))),
        };
        let mut lines = Vec::new();
        deframer.feed(buf.get(..n).unwrap_or(&[]), |item| {
            lines.push(match item {
                Ok(payload) => match DataSheet::parse(payload) {
                    Ok(sheet) => Ok(sheet),
                    Err(e) => Err(format!("bad payload: {e}")),
                },
                Err(e) => Err(format!("bad header: {e}")),
            })
        });
        for item in lines {
            match item {
                Ok(sheet) => println!("{}", sheet_line(cli.json, &sheet)),
                Err(e) => eprintln!("hansctl: {e}"),
            }
            seen += 1;
            if count > 0 && seen >= count {
                return Ok(());
            }
        }
        let _ = std::io::stdout().flush();
    }
}

fn sheet_line(as_json: bool, s: &DataSheet) -> String {
    let fsm = s.state.robot_state;
    let pos = s.pos_and_vel.position;
    let bits = |v: &[i32]| {
        v.iter()
            .map(|b| if *b != 0 { '1' } else { '0' })
            .collect::<String>()
    };
    if as_json {
        return obj! {
            "fsm" => fsm.map(|f| f.code()), "fsm_name" => fsm.and_then(|f| f.name()),
            "moving" => s.state.moving, "enabled" => s.state.enabled, "paused" => s.state.paused,
            "blending_done" => s.state.blending_done, "in_pos" => s.state.in_pos,
            "error_code" => s.state.error_code,
            "joints" => pos.map(|p| p.joints).as_ref(), "tcp" => s.pos_and_vel.pcs_tcp.as_ref(),
            "box_di" => s.box_io.box_di.as_slice(), "box_do" => s.box_io.box_do.as_slice(),
            "end_di" => s.end_io.end_di.as_slice(), "end_do" => s.end_io.end_do.as_slice(),
        }
        .to_string();
    }
    let flag = |b: Option<bool>| match b {
        Some(true) => "1",
        Some(false) => "0",
        None => "-",
    };
    format!(
        "FSM {:<18} mov={} en={} pause={} done={} inpos={} err={} | J [{}] | TCP [{}] | DI {} DO {} EI {} EO {}",
        fsm.map_or("-".to_string(), fsm_name),
        flag(s.state.moving),
        flag(s.state.enabled),
        flag(s.state.paused),
        flag(s.state.blending_done),
        flag(s.state.in_pos),
        s.state.error_code.unwrap_or(0),
        pos.map_or(String::new(), |p| fmt6(&p.joints)),
        s.pos_and_vel.pcs_tcp.map_or(String::new(), |p| fmt6(&p)),
        bits(&s.box_io.box_di),
        bits(&s.box_io.box_do),
        bits(&s.end_io.end_di),
        bits(&s.end_io.end_do),
    )
}
