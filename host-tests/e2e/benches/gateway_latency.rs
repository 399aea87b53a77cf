//! Benchmark (not a test): latency from the PLC's Modbus write of Execute to
//! the command's bytes arriving at the robot, and the sustained rate of
//! non-motion commands through the full PLCopen handshake.
//!
//! `cargo bench -p hans-e2e --bench gateway_latency` (release build).
//!
//! The robot is a minimal peer in this process that timestamps each
//! message the moment its bytes are read (hans-sim records what it received
//! but not when) and answers every request at once with a canned reply.
//! The PLC polls the status without pausing between reads (each read's
//! round trip is the pace), so the rate measures the gateway, not a test
//! helper's sleep. Every wait is bounded by [`hans_e2e::WAIT`].
//! Goals: p99 under 2 ms, 500 commands per second or more.

use std::net::{Ipv4Addr, SocketAddr, SocketAddrV4};
use std::time::{Duration, Instant};

use hans_e2e::{code, CannedRobot, Plc, WAIT};
use hans_gateway::host::{HostOptions, RunningGateway};
use hans_gateway::registers as r;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpListener;
use tokio::sync::mpsc;

const SAMPLES: usize = 2000;
const WARMUP: usize = 200;
const RATE_TIME: Duration = Duration::from_secs(3);

/// The robot: answers everything, reports when each `SetBoxDO` arrived.
async fn robot(listener: TcpListener, arrivals: mpsc::UnboundedSender<Instant>) {
    while let Ok((mut s, _)) = listener.accept().await {
        let _ = s.set_nodelay(true);
        let tx = arrivals.clone();
        tokio::spawn(async move {
            let mut buf = vec![0u8; 4096];
            let mut canned = CannedRobot::new();
            loop {
                let n = match s.read(&mut buf).await {
                    Ok(0) | Err(_) => return,
                    Ok(n) => n,
                };
                let now = Instant::now();
                for (msg, reply) in canned.feed(&buf[..n]) {
                    if msg.starts_with("SetBoxDO") {
                        let _ = tx.send(now);
                    }
                    if s.write_all(reply.as_bytes()).await.is_err() {
                        return;
                    }
                }
            }
        });
    }
}

/// Execute high, the command's bytes at the robot, Done, Execute low;
/// returns the time from the Execute write to the bytes' arrival.
async fn handshake(plc: &mut Plc, arrivals: &mut mpsc::UnboundedReceiver<Instant>) -> Duration {
    let status = Plc::ch_status(0);
    let t0 = Instant::now();
    plc.write(r::channel_base(0) + r::CH_CONTROL, &[1]).await;
    let t1 = match tokio::time::timeout(WAIT, arrivals.recv()).await {
        Ok(Some(t)) => t,
        Ok(None) => panic!("the robot task ended"),
        Err(_) => {
            let now = plc.outputs(status).await;
            panic!("no SetBoxDO reached the robot within {WAIT:?}; channel 0 shows {now:?}")
        }
    };
    let end = plc.wait_end_every(status, Duration::ZERO).await;
    assert!(end.done(), "{end:?}");
    plc.write(r::channel_base(0) + r::CH_CONTROL, &[0]).await;
    t1.saturating_duration_since(t0)
}

fn pct(sorted: &[Duration], p: f64) -> Duration {
    let i = ((sorted.len() as f64 - 1.0) * p).round() as usize;
    sorted[i.min(sorted.len() - 1)]
}

fn main() {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .expect("runtime");
    rt.block_on(async {
        let listener = TcpListener::bind("127.0.0.1:0").await.expect("bind");
        let robot_addr = match listener.local_addr().expect("addr") {
            SocketAddr::V4(a) => a,
            SocketAddr::V6(_) => unreachable!(),
        };
        let (tx, mut arrivals) = mpsc::unbounded_channel();
        tokio::spawn(robot(listener, tx));
        let gw = RunningGateway::start(HostOptions::new(
            SocketAddrV4::new(Ipv4Addr::LOCALHOST, 0),
            robot_addr,
        ))
        .expect("gateway");
        let mut plc = Plc::connect(gw.modbus_addr()).await;
        plc.wait_link().await;
        // Inputs once: SetBoxDO bit 1 = 1; then only Execute is toggled.
        plc.command(0, code::SET_BOX_DO, &[1.0, 1.0], 1).await;
        let end = plc.wait_end(Plc::ch_status(0)).await;
        assert!(end.done(), "first SetBoxDO: {end:?}");
        plc.write(r::channel_base(0) + r::CH_CONTROL, &[0]).await;
        while arrivals.try_recv().is_ok() {}

        for _ in 0..WARMUP {
            handshake(&mut plc, &mut arrivals).await;
        }
        let mut lat: Vec<Duration> = Vec::with_capacity(SAMPLES);
        for _ in 0..SAMPLES {
            lat.push(handshake(&mut plc, &mut arrivals).await);
        }
        lat.sort();
        println!("Execute write -> bytes at the robot, {SAMPLES} samples:");
        println!(
            "  p50 {:?}  p90 {:?}  p99 {:?}  max {:?}   (goal: p99 < 2 ms)",
            pct(&lat, 0.50),
            pct(&lat, 0.90),
            pct(&lat, 0.99),
            lat[lat.len() - 1]
        );

        let start = Instant::now();
        let mut n = 0u32;
        while start.elapsed() < RATE_TIME {
            handshake(&mut plc, &mut arrivals).await;
            n += 1;
        }
        let rate = f64::from(n) / start.elapsed().as_secs_f64();
        println!("sustained non-motion commands, full handshake (Execute, Done, Execute low):");
        println!(
            "  {rate:.0} commands/s over {:?}   (goal: >= 500/s)",
            RATE_TIME
        );
        drop(plc);
        gw.stop();
    });
}
