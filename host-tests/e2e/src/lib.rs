//! Shared helpers for the end-to-end tests: a PLC (tokio-modbus client)
//! speaking the gateway's register map, and a rig of simulator + gateway +
//! PLC on 127.0.0.1.
//!
//! Every wait is bounded ([`WAIT`]) and fails the test with a message.

use std::net::{Ipv4Addr, SocketAddr, SocketAddrV4};
use std::time::{Duration, Instant};

use hans_gateway::registers as r;
use hans_gateway_linux::{HostOptions, RunningGateway};
use hans_sim::Sim;
use tokio_modbus::client::{Context, Reader, Writer};

pub mod mqtt;

pub use hans_gateway::error::{ErrorSource, GatewayError};
pub use hans_gateway::job::code;

/// Longest wait for anything in these tests (generous: the machine is
/// shared).
pub const WAIT: Duration = Duration::from_secs(20);

/// The pause between two reads of a register that [`Plc::wait_reg`] waits
/// on (the tests' pace, not the gateway's).
pub const POLL_PAUSE: Duration = Duration::from_millis(5);

/// Error source register value "the robot refused the command".
pub const SRC_ROBOT_FAIL: u16 = ErrorSource::RobotFail as u16;

/// Error source register value "the gateway" (ErrorID is a
/// [`GatewayError`] code).
pub const SRC_GATEWAY: u16 = ErrorSource::Gateway as u16;

/// What the PLC reads for a gateway error: (ErrorID, error source).
pub const fn gateway_error(e: GatewayError) -> (i32, u16) {
    (e.code(), SRC_GATEWAY)
}

/// A Modbus client for the gateway's map (32-bit values high word first,
/// the default word order).
pub struct Plc {
    /// The tokio-modbus context.
    pub ctx: Context,
}

/// An `f32` as two registers, high word first.
pub fn words_of_f32(v: f32) -> [u16; 2] {
    let b = v.to_bits();
    [(b >> 16) as u16, b as u16]
}

/// The reply of a minimal robot that accepts every request: `Name,OK,;`,
/// with plausible values for the reads the gateway polls (StandBy, not
/// moving, at the document's home pose, I/O off). For rigs that stand in for
/// the controller where the simulator is not wanted (a peer embassy-net
/// stack, a latency benchmark that must not measure the simulator).
pub fn canned_reply(msg: &str) -> String {
    let name = msg.split(',').next().unwrap_or("").trim();
    let values = match name {
        "ReadRobotState" => "0,1,0,0,0,1,0,0,0,1,1,1,1,",
        "ReadCurFSM" => "33,",
        "ReadActPos" => "0,0,90,0,90,0,420,0,445,180,0,180,0,0,0,0,0,0,0,0,0,0,0,0,",
        "ReadBoxDI" | "ReadBoxDO" | "ReadBoxCI" | "ReadBoxCO" => "0,0,0,0,0,0,0,0,",
        "ReadEI" | "ReadEO" => "0,0,0,",
        _ => "",
    };
    format!("{name},OK,{values};")
}

/// The reading side of a robot that answers with [`canned_reply`]: give it
/// the bytes as a socket delivers them, get back each complete message (up
/// to and including its `;`) with the reply to send. The socket stays with
/// the caller.
#[derive(Debug, Default)]
pub struct CannedRobot {
    pending: Vec<u8>,
}

impl CannedRobot {
    /// A robot with nothing received yet.
    pub fn new() -> CannedRobot {
        CannedRobot::default()
    }

    /// Takes `bytes`; returns `(message, reply)` for each message they
    /// complete, in order. A partial message waits for the next call.
    pub fn feed(&mut self, bytes: &[u8]) -> Vec<(String, String)> {
        self.pending.extend_from_slice(bytes);
        let mut out = Vec::new();
        while let Some(i) = self.pending.iter().position(|&b| b == b';') {
            let raw: Vec<u8> = self.pending.drain(..=i).collect();
            let msg = String::from_utf8_lossy(&raw).into_owned();
            let reply = canned_reply(&msg);
            out.push((msg, reply));
        }
        out
    }
}

/// Two registers (high word first) as `f32`.
pub fn f32_of(w: &[u16]) -> f32 {
    f32::from_bits((u32::from(w[0]) << 16) | u32::from(w[1]))
}

/// Two registers (high word first) as `i32`.
pub fn i32_of(w: &[u16]) -> i32 {
    ((u32::from(w[0]) << 16) | u32::from(w[1])) as i32
}

/// Text as registers, two characters per register, NUL padded to `regs`.
pub fn text_words(t: &str, regs: usize) -> Vec<u16> {
    let b = t.as_bytes();
    (0..regs)
        .map(|i| {
            let at = |k: usize| u16::from(b.get(k).copied().unwrap_or(0));
            (at(2 * i) << 8) | at(2 * i + 1)
        })
        .collect()
}

/// Registers as text up to the first NUL.
pub fn words_text(w: &[u16]) -> String {
    let mut s = String::new();
    for v in w {
        for b in [(v >> 8) as u8, *v as u8] {
            if b == 0 {
                return s;
            }
            s.push(char::from(b));
        }
    }
    s
}

/// What a command ended as.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Ended {
    /// Status bits (`ST_*`).
    pub status: u16,
    /// ErrorID.
    pub error_id: i32,
    /// Error source.
    pub error_source: u16,
    /// Sequence echo.
    pub seq: u16,
}

impl Ended {
    /// Done?
    pub fn done(&self) -> bool {
        self.status & r::ST_DONE != 0
    }
}

impl Plc {
    /// Connects to the gateway.
    pub async fn connect(addr: SocketAddrV4) -> Plc {
        let ctx = tokio_modbus::client::tcp::connect(SocketAddr::V4(addr))
            .await
            .expect("connect to the gateway's Modbus server");
        Plc { ctx }
    }

    /// Reads registers (FC 3), panicking on any error.
    pub async fn read(&mut self, addr: u16, n: u16) -> Vec<u16> {
        self.ctx
            .read_holding_registers(addr, n)
            .await
            .expect("transport")
            .unwrap_or_else(|e| panic!("exception {e:?} reading {addr}+{n}"))
    }

    /// Writes registers (FC 16), panicking on any error.
    pub async fn write(&mut self, addr: u16, values: &[u16]) {
        self.ctx
            .write_multiple_registers(addr, values)
            .await
            .expect("transport")
            .unwrap_or_else(|e| panic!("exception {e:?} writing {addr}"));
    }

    /// Writes registers (FC 16): `Err` with the exception if the device
    /// refused them (a transport error still panics).
    pub async fn try_write(
        &mut self,
        addr: u16,
        values: &[u16],
    ) -> Result<(), tokio_modbus::ExceptionCode> {
        self.ctx
            .write_multiple_registers(addr, values)
            .await
            .expect("transport")
    }

    /// One register.
    pub async fn read1(&mut self, addr: u16) -> u16 {
        self.read(addr, 1).await[0]
    }

    /// Waits until `cond` holds for register `addr`, reading it every
    /// [`POLL_PAUSE`]; returns its value. Fails after [`WAIT`].
    pub async fn wait_reg(&mut self, addr: u16, what: &str, cond: impl Fn(u16) -> bool) -> u16 {
        self.wait_reg_every(addr, what, POLL_PAUSE, cond).await
    }

    /// Like [`Plc::wait_reg`] with `pause` between two reads. With
    /// `Duration::ZERO` it reads again as soon as an answer arrives (the
    /// Modbus round trip is the pace), for measurements that must not
    /// include the test's own sleep.
    pub async fn wait_reg_every(
        &mut self,
        addr: u16,
        what: &str,
        pause: Duration,
        cond: impl Fn(u16) -> bool,
    ) -> u16 {
        let start = Instant::now();
        loop {
            let v = self.read1(addr).await;
            if cond(v) {
                return v;
            }
            assert!(
                start.elapsed() < WAIT,
                "timed out waiting for {what} (register {addr} = {v:#x})"
            );
            if !pause.is_zero() {
                tokio::time::sleep(pause).await;
            }
        }
    }

    /// Waits for the robot link to be up.
    pub async fn wait_link(&mut self) {
        self.wait_reg(r::STATUS_LINK_STATE, "link up", |v| v == 3)
            .await;
    }

    /// Fires a typed command on channel `ch`: parameters, code, sequence,
    /// then Execute (one write). Execute must be low before.
    pub async fn command(&mut self, ch: usize, code: u16, params: &[f32], seq: u16) {
        self.command_text(ch, code, params, "", "", seq).await;
    }

    /// Like [`Plc::command`] with the two text parameters.
    pub async fn command_text(
        &mut self,
        ch: usize,
        code: u16,
        params: &[f32],
        t1: &str,
        t2: &str,
        seq: u16,
    ) {
        let b = r::channel_base(ch);
        let mut block = vec![0u16; usize::from(r::CH_STATUS)];
        block[usize::from(r::CH_COMMAND)] = code;
        block[usize::from(r::CH_SEQUENCE)] = seq;
        for (i, p) in params.iter().enumerate() {
            let w = words_of_f32(*p);
            block[usize::from(r::CH_PARAMS) + 2 * i] = w[0];
            block[usize::from(r::CH_PARAMS) + 2 * i + 1] = w[1];
        }
        let o = usize::from(r::CH_TEXT1);
        block[o..o + 16].copy_from_slice(&text_words(t1, 16));
        let o = usize::from(r::CH_TEXT2);
        block[o..o + 16].copy_from_slice(&text_words(t2, 16));
        // Inputs first, Execute last (the gateway acts on the whole write).
        self.write(b + 1, &block[1..]).await;
        self.write(b + r::CH_CONTROL, &[1]).await;
    }

    /// Waits for the end of the command whose status register is
    /// `status_reg` (Done, Error or Aborted) and returns it; Execute stays
    /// high.
    pub async fn wait_end(&mut self, status_reg: u16) -> Ended {
        self.wait_end_every(status_reg, POLL_PAUSE).await
    }

    /// Like [`Plc::wait_end`] with `pause` between two reads (see
    /// [`Plc::wait_reg_every`]).
    pub async fn wait_end_every(&mut self, status_reg: u16, pause: Duration) -> Ended {
        self.wait_reg_every(status_reg, "command end", pause, |v| {
            v & (r::ST_DONE | r::ST_ERROR | r::ST_ABORTED) != 0
        })
        .await;
        self.outputs(status_reg).await
    }

    /// The outputs of a command (status, sequence echo, ErrorID, error
    /// source) as they are now, without waiting.
    pub async fn outputs(&mut self, status_reg: u16) -> Ended {
        let w = self.read(status_reg, 5).await;
        Ended {
            status: w[0],
            seq: w[1],
            error_id: i32_of(&w[2..4]),
            error_source: w[4],
        }
    }

    /// Channel `ch`'s status register.
    pub fn ch_status(ch: usize) -> u16 {
        r::channel_base(ch) + r::CH_STATUS
    }

    /// Runs a typed command to its end and drops Execute.
    pub async fn run(&mut self, ch: usize, code: u16, params: &[f32], seq: u16) -> Ended {
        self.command(ch, code, params, seq).await;
        let e = self.wait_end(Self::ch_status(ch)).await;
        self.write(r::channel_base(ch) + r::CH_CONTROL, &[0]).await;
        e
    }

    /// Sends a RAW message; returns the end and the reply text.
    pub async fn raw(&mut self, text: &str, seq: u16) -> (Ended, String) {
        let mut block = vec![seq];
        block.extend(text_words(text, usize::from(r::RAW_REQUEST_REGS)));
        // At most 123 registers per write.
        for (i, chunk) in block.chunks(100).enumerate() {
            self.write(r::RAW_SEQUENCE + 100 * i as u16, chunk).await;
        }
        self.write(r::RAW_CONTROL, &[1]).await;
        let e = self.wait_end(r::RAW_STATUS).await;
        let len = self.read1(r::RAW_REPLY_LEN).await;
        let mut reply = Vec::new();
        let mut at = r::RAW_REPLY;
        let mut left = len.div_ceil(2).min(r::RAW_REPLY_REGS);
        while left > 0 {
            let n = left.min(120);
            reply.extend(self.read(at, n).await);
            at += n;
            left -= n;
        }
        self.write(r::RAW_CONTROL, &[0]).await;
        (e, words_text(&reply))
    }

    /// Six `f32`s from twelve registers at `addr`.
    async fn f32x6(&mut self, addr: u16) -> [f32; 6] {
        let w = self.read(addr, 12).await;
        let mut v = [0.0; 6];
        for (i, x) in v.iter_mut().enumerate() {
            *x = f32_of(&w[2 * i..]);
        }
        v
    }

    /// The actual joints J1-J6 of the status mirror.
    pub async fn joints(&mut self) -> [f32; 6] {
        self.f32x6(r::STATUS_JOINTS).await
    }

    /// The actual TCP pose of the status mirror.
    pub async fn pose(&mut self) -> [f32; 6] {
        self.f32x6(r::STATUS_POSE).await
    }

    /// Waits for a valid, fresh status (the actual joints are known).
    pub async fn wait_status(&mut self) {
        self.wait_reg(r::STATUS_FLAGS, "valid status", |v| v & r::FLAG_VALID != 0)
            .await;
        self.wait_reg(r::STATUS_AGE_MS, "status refreshed", |v| v < 1000)
            .await;
    }

    /// Starts a joint move of `delta` degrees on J1 at `vel` °/s and
    /// `acc` °/s² on channel `ch` (code 10, from the actual joints); returns
    /// the target.
    pub async fn start_move(
        &mut self,
        ch: usize,
        delta: f32,
        vel: f32,
        acc: f32,
        seq: u16,
    ) -> [f32; 6] {
        self.wait_status().await;
        let mut t = self.joints().await;
        t[0] += delta;
        let p = [t[0], t[1], t[2], t[3], t[4], t[5], vel, acc, 0.0];
        self.command(ch, code::MOVE_J_JOINTS, &p, seq).await;
        t
    }

    /// Fires trigger entries: writes their texts, then raises their bits
    /// (one write); returns the bits.
    pub async fn fire_triggers(&mut self, entries: &[(usize, &str)]) -> u16 {
        let mut bits = 0;
        for (i, text) in entries {
            self.write(
                r::trigger_text(*i),
                &text_words(text, usize::from(r::TRIG_TEXT_REGS)),
            )
            .await;
            bits |= 1 << i;
        }
        self.write(r::TRIG_BITS, &[bits]).await;
        bits
    }

    /// Sets configuration registers and applies them (command 1); panics
    /// if refused. Returns `CONFIG_RESULT`: 0 applied and saved, 3 applied
    /// but not saved (no persistent storage, as in [`Rig`]).
    pub async fn configure(&mut self, settings: &[(u16, u16)]) -> u16 {
        for (a, v) in settings {
            self.write(*a, &[*v]).await;
        }
        self.write(r::CONTROL_CONFIG_COMMAND, &[1]).await;
        let result = self.read1(r::CONTROL_CONFIG_RESULT).await;
        assert!(
            result == 0 || result == 3,
            "configuration refused: CONFIG_RESULT {result}"
        );
        result
    }
}

/// Simulator + gateway (connect mode) + one PLC.
pub struct Rig {
    /// The simulated robot.
    pub sim: Sim,
    /// The gateway (stops when dropped).
    pub gw: RunningGateway,
    /// The PLC.
    pub plc: Plc,
}

impl Rig {
    /// Starts all three with the simulator in `config`; waits for the link.
    pub async fn start(config: hans_sim::Config) -> Rig {
        let sim = Sim::start(config).await.expect("start the simulator");
        let robot = match sim.command_addr() {
            SocketAddr::V4(a) => a,
            SocketAddr::V6(_) => panic!("simulator not on IPv4"),
        };
        let gw = RunningGateway::start(HostOptions::new(
            SocketAddrV4::new(Ipv4Addr::LOCALHOST, 0),
            robot,
        ))
        .expect("start the gateway");
        let mut plc = Plc::connect(gw.modbus_addr()).await;
        plc.wait_link().await;
        Rig { sim, gw, plc }
    }

    /// Messages the simulator received other than the gateway's status
    /// reads (`Read...`) and its question for the protocol level
    /// (`PackageVersion`), in order.
    pub fn commands_received(&self) -> Vec<String> {
        self.sim
            .received()
            .into_iter()
            .filter(|m| !m.starts_with("Read") && !m.starts_with("PackageVersion"))
            .collect()
    }

    /// Messages the simulator received whose name is `name`.
    pub fn received(&self, name: &str) -> Vec<String> {
        let prefix = format!("{name},");
        self.sim
            .received()
            .into_iter()
            .filter(|m| m.starts_with(&prefix))
            .collect()
    }

    /// Stops everything.
    pub async fn stop(self) {
        drop(self.plc);
        self.gw.stop();
        self.sim.shutdown().await;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_canned_robot_answers_messages_split_across_reads() {
        let mut robot = CannedRobot::new();
        assert!(robot.feed(b"ReadCur").is_empty());
        let got = robot.feed(b"FSM,0,;SetBoxDO,2,1,;Read");
        assert_eq!(
            got,
            [
                (
                    "ReadCurFSM,0,;".to_string(),
                    "ReadCurFSM,OK,33,;".to_string()
                ),
                ("SetBoxDO,2,1,;".to_string(), "SetBoxDO,OK,;".to_string()),
            ]
        );
        assert_eq!(robot.feed(b"EI,0,;").len(), 1);
    }
}
