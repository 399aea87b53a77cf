//! Benchmark (not a test), three figures in one run, default configuration:
//!
//! 1. latency from the PLC's Modbus write of Execute to the command's bytes
//!    arriving at the robot (goal: p99 <= 1 ms);
//! 2. the sustained rate of non-motion commands through the full PLCopen
//!    handshake (goal: >= 2,000 commands/s);
//! 3. latency from the robot first reporting a motion finished (the first
//!    `ReadRobotState` reply with moving 0 after the motion) to Done read by
//!    the PLC (goal: p99 <= 15 ms).
//!
//! `cargo bench -p hans-e2e --bench gateway_latency` (release build).
//!
//! The robot is a minimal peer in this process that timestamps each
//! message the moment its bytes are read (hans-sim records what it received
//! but not when) and answers every request at once with a canned reply; a
//! `MoveRelJ` makes it move for [`MOTION`], and it timestamps the first
//! reply that reports the motion over. The PLC polls the status without
//! pausing between reads (each read's round trip is the pace), so the
//! figures are the gateway's, not a test helper's sleep. Every wait is
//! bounded by [`hans_e2e::WAIT`].

use std::net::{Ipv4Addr, SocketAddr, SocketAddrV4};
use std::time::{Duration, Instant};

use hans_e2e::{code, CannedRobot, Plc, WAIT};
use hans_gateway::registers as r;
use hans_gateway_linux::{HostOptions, RunningGateway};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpListener;
use tokio::sync::mpsc;

const SAMPLES: usize = 2000;
const WARMUP: usize = 200;
const RATE_TIME: Duration = Duration::from_secs(3);
/// Motions measured, and how long they move: 30 ms plus 0-9.5 ms, so that
/// their ends fall anywhere between two motion polls.
const MOTIONS: usize = 300;
const MOTION: Duration = Duration::from_millis(30);

/// The robot: answers everything, reports when each `SetBoxDO` arrived and
/// when it first replied that a motion was over.
async fn robot(
    listener: TcpListener,
    arrivals: mpsc::UnboundedSender<Instant>,
    ends: mpsc::UnboundedSender<(Instant, Instant)>,
) {
    while let Ok((mut s, _)) = listener.accept().await {
        let _ = s.set_nodelay(true);
        let tx = arrivals.clone();
        let ends = ends.clone();
        tokio::spawn(async move {
            let mut buf = vec![0u8; 4096];
            let mut canned = CannedRobot::new();
            // A motion moves until then; `Some` until its end was reported.
            let mut moving_until: Option<Instant> = None;
            let mut motions = 0u32;
            loop {
                let n = match s.read(&mut buf).await {
                    Ok(0) | Err(_) => return,
                    Ok(n) => n,
                };
                let now = Instant::now();
                for (msg, mut reply) in canned.feed(&buf[..n]) {
                    if msg.starts_with("SetBoxDO") {
                        let _ = tx.send(now);
                    }
                    if msg.starts_with("MoveRelJ") {
                        motions += 1;
                        let extra = Duration::from_micros(u64::from(motions * 3700 % 10_000));
                        moving_until = Some(now + MOTION + extra);
                    }
                    let moving = moving_until.is_some_and(|t| now < t);
                    if msg.starts_with("ReadRobotState") && moving {
                        reply = "ReadRobotState,OK,1,1,0,0,0,1,0,0,0,1,1,0,0,;".into();
                    } else if msg.starts_with("ReadRobotState") {
                        if let Some(ended) = moving_until.take() {
                            // The first reply that reports the motion over,
                            // and when it really ended.
                            let _ = ends.send((ended, Instant::now()));
                        }
                    }
                    if msg.starts_with("ReadCurFSM") && moving {
                        reply = "ReadCurFSM,OK,25,;".into();
                    }
                    if s.write_all(reply.as_bytes()).await.is_err() {
                        return;
                    }
                }
            }
        });
    }
}

/// A relative joint move (its inputs written once before): Execute high,
/// Done read, Execute low; returns the time from the robot's first reply
/// reporting the motion over to the read that showed Done, and from the
/// motion's real end (the poll period of 10 ms comes in there).
async fn motion(
    plc: &mut Plc,
    ends: &mut mpsc::UnboundedReceiver<(Instant, Instant)>,
) -> (Duration, Duration) {
    let status = Plc::ch_status(1);
    plc.write(r::channel_base(1) + r::CH_CONTROL, &[1]).await;
    let end = plc.wait_end_every(status, Duration::ZERO).await;
    let done_at = Instant::now();
    assert!(end.done(), "{end:?}");
    let (ended, reported) = match tokio::time::timeout(WAIT, ends.recv()).await {
        Ok(Some(t)) => t,
        _ => panic!("the robot never reported the motion over"),
    };
    plc.write(r::channel_base(1) + r::CH_CONTROL, &[0]).await;
    (
        done_at.saturating_duration_since(reported),
        done_at.saturating_duration_since(ended),
    )
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
        let (end_tx, mut ends) = mpsc::unbounded_channel();
        tokio::spawn(robot(listener, tx, end_tx));
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
            "  p50 {:?}  p90 {:?}  p99 {:?}  max {:?}   (goal: p99 <= 1 ms)",
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
            "  {rate:.0} commands/s over {:?}   (goal: >= 2000/s)",
            RATE_TIME
        );

        // Motions on channel 1: MoveRelJ axis 0 by 1°.
        plc.command(1, code::MOVE_REL_J, &[0.0, 1.0], 1).await;
        let end = plc.wait_end(Plc::ch_status(1)).await;
        assert!(end.done(), "first MoveRelJ: {end:?}");
        plc.write(r::channel_base(1) + r::CH_CONTROL, &[0]).await;
        while ends.try_recv().is_ok() {}
        let mut done: Vec<Duration> = Vec::with_capacity(MOTIONS);
        let mut from_end: Vec<Duration> = Vec::with_capacity(MOTIONS);
        for _ in 0..MOTIONS {
            let (d, e) = motion(&mut plc, &mut ends).await;
            done.push(d);
            from_end.push(e);
        }
        done.sort();
        from_end.sort();
        println!("robot first reports a motion ({MOTION:?} + 0-10 ms) over -> Done read by the PLC, {MOTIONS} motions:");
        println!(
            "  p50 {:?}  p90 {:?}  p99 {:?}  max {:?}   (goal: p99 <= 15 ms)",
            pct(&done, 0.50),
            pct(&done, 0.90),
            pct(&done, 0.99),
            done[done.len() - 1]
        );
        println!("  from the motion's real end on the robot (the 10 ms motion poll comes in):");
        println!(
            "  p50 {:?}  p90 {:?}  p99 {:?}  max {:?}",
            pct(&from_end, 0.50),
            pct(&from_end, 0.90),
            pct(&from_end, 0.99),
            from_end[from_end.len() - 1]
        );
        drop(plc);
        gw.stop();
    });
}
