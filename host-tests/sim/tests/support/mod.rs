//! A minimal test client for the command port: one request in flight,
//! replies framed by the codec, every wait bounded.
#![allow(dead_code)]

use std::net::SocketAddr;
use std::time::Duration;

use hans_codec::{Framer, Reply, ReplyExpect, Request};
use hans_sim::{ClockMode, Config, Sim};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

/// Generous bound for any single wait in the tests.
pub const WAIT: Duration = Duration::from_secs(10);

/// `v` milliseconds.
pub fn ms(v: u64) -> Duration {
    Duration::from_millis(v)
}

/// A simulator started from `config` on the manual clock (time moves only
/// by `Sim::advance`), so every test is deterministic.
pub async fn manual(config: Config) -> Sim {
    Sim::start(Config {
        clock: ClockMode::Manual,
        ..config
    })
    .await
    .unwrap()
}

pub struct Client {
    pub stream: TcpStream,
    framer: Framer<65536>,
    pending: Vec<String>,
}

impl Client {
    pub async fn connect(addr: SocketAddr) -> Client {
        let stream = tokio::time::timeout(WAIT, TcpStream::connect(addr))
            .await
            .expect("connect timed out")
            .expect("connect failed");
        stream.set_nodelay(true).unwrap();
        Client {
            stream,
            framer: Framer::new(),
            pending: Vec::new(),
        }
    }

    pub async fn send_raw(&mut self, bytes: &[u8]) {
        self.stream.write_all(bytes).await.expect("write failed");
    }

    /// The next message from the simulator, or `None` if none comes within
    /// `limit` (or the connection closed).
    pub async fn read_within(&mut self, limit: Duration) -> Option<String> {
        let deadline = tokio::time::Instant::now() + limit;
        loop {
            if !self.pending.is_empty() {
                return Some(self.pending.remove(0));
            }
            let mut buf = [0u8; 4096];
            let n = match tokio::time::timeout_at(deadline, self.stream.read(&mut buf)).await {
                Err(_) => return None,
                Ok(Err(_)) | Ok(Ok(0)) => return None,
                Ok(Ok(n)) => n,
            };
            let pending = &mut self.pending;
            self.framer.feed(&buf[..n], |m| {
                pending.push(match m {
                    Ok(s) => s.to_string(),
                    Err(e) => format!("<frame error {e}>"),
                })
            });
        }
    }

    pub async fn read(&mut self) -> String {
        self.read_within(WAIT)
            .await
            .expect("no reply within the bound")
    }

    /// Sends one message and returns the reply text.
    pub async fn call(&mut self, msg: &str) -> String {
        self.send_raw(msg.as_bytes()).await;
        self.read().await
    }

    /// Sends a message and checks that the reply is `Name,OK,...`.
    pub async fn ok(&mut self, msg: &str) -> String {
        let r = self.call(msg).await;
        let req = Request::parse(msg).expect("test request must parse");
        match Reply::parse(&r, req.expect()) {
            Ok(Reply::Ok(_)) => r,
            other => panic!("{msg} -> {r} ({other:?})"),
        }
    }

    /// Sends a message and returns the failure code of its reply.
    pub async fn fail(&mut self, msg: &str) -> i32 {
        let r = self.call(msg).await;
        match Reply::parse(&r, ReplyExpect::from_name("")) {
            Ok(Reply::Fail(f)) => f.code.code(),
            other => panic!("{msg} -> {r}: expected a failure, got {other:?}"),
        }
    }

    /// The values of an OK reply, as text fields.
    pub async fn values(&mut self, msg: &str) -> Vec<String> {
        let r = self.ok(msg).await;
        let raw = hans_codec::RawMessage::parse(&r).unwrap();
        raw.fields().skip(1).map(str::to_string).collect()
    }

    pub async fn fsm(&mut self) -> i32 {
        self.values("ReadCurFSM,0,;").await[0].parse().unwrap()
    }

    /// `ReadRobotState` as 13 integers.
    pub async fn state(&mut self) -> Vec<i32> {
        self.values("ReadRobotState,0,;")
            .await
            .iter()
            .map(|v| v.parse().unwrap())
            .collect()
    }

    pub async fn numbers(&mut self, msg: &str) -> Vec<f64> {
        self.values(msg)
            .await
            .iter()
            .map(|v| v.parse().unwrap())
            .collect()
    }
}

pub fn close(a: &[f64], b: &[f64], tol: f64) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
}
