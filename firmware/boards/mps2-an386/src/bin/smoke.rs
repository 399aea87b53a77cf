//! Smoke firmware: proves the LAN9118 driver, the time driver and the network
//! stack under QEMU in both directions, then exits through semihosting.
//!
//! * Server: accepts a connection on port 502 and echoes one line back.
//! * Client: connects to the simulator address (10.0.2.100:10003, forwarded
//!   by QEMU to the host), sends `hello from mps2-an386\n` and expects a line
//!   starting with `ack` back.
//!
//! Exit 0 once both have happened, 1 on any failure or after 60 s.
#![no_std]
#![no_main]

use board_mps2_an386 as board;
use embassy_executor::Spawner;
use embassy_net::tcp::TcpSocket;
use embassy_net::Stack;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::signal::Signal;
use embassy_time::{with_timeout, Duration, Timer};

static SERVED: Signal<CriticalSectionRawMutex, ()> = Signal::new();
static CLIENT_DONE: Signal<CriticalSectionRawMutex, ()> = Signal::new();

const TIMEOUT: Duration = Duration::from_secs(60);

#[cortex_m_rt::entry]
fn main() -> ! {
    board::executor::run(start)
}

#[embassy_executor::task]
async fn start(spawner: Spawner) {
    let stack = match board::init(spawner, board::guest_config()) {
        Ok(stack) => stack,
        Err(e) => board::fail(e),
    };
    defmt::info!("smoke: network up");
    let tasks = echo_server(stack).and_then(|server| {
        spawner.spawn(server);
        client(stack)
    });
    match tasks {
        Ok(client) => spawner.spawn(client),
        Err(_) => board::fail(board::BoardError::Spawn),
    }
    let both = async {
        SERVED.wait().await;
        CLIENT_DONE.wait().await;
    };
    match with_timeout(TIMEOUT, both).await {
        Ok(()) => {
            defmt::info!("smoke: pass");
            board::report();
            board::exit(0)
        }
        Err(_) => {
            defmt::error!("smoke: timed out");
            board::report();
            board::exit(1)
        }
    }
}

/// Reads until a newline or the buffer is full; returns the bytes read.
async fn read_line(socket: &mut TcpSocket<'_>, buf: &mut [u8]) -> Option<usize> {
    let mut len = 0;
    while len < buf.len() {
        match socket.read(&mut buf[len..]).await {
            Ok(0) | Err(_) => return None,
            Ok(n) => {
                len += n;
                if buf[..len].contains(&b'\n') {
                    return Some(len);
                }
            }
        }
    }
    Some(len)
}

#[embassy_executor::task]
async fn echo_server(stack: Stack<'static>) {
    let mut rx = [0u8; 512];
    let mut tx = [0u8; 512];
    loop {
        let mut socket = TcpSocket::new(stack, &mut rx, &mut tx);
        socket.set_timeout(Some(Duration::from_secs(10)));
        if let Err(e) = socket.accept(502).await {
            defmt::warn!("smoke: accept failed: {}", e);
            continue;
        }
        defmt::info!("smoke: client connected from {}", socket.remote_endpoint());
        let mut line = [0u8; 128];
        if let Some(n) = read_line(&mut socket, &mut line).await {
            if socket.write(&line[..n]).await.is_ok() && socket.flush().await.is_ok() {
                defmt::info!("smoke: echoed {=usize} bytes", n);
                SERVED.signal(());
            }
        }
        socket.close();
        let _ = with_timeout(Duration::from_secs(2), socket.flush()).await;
        socket.abort();
    }
}

#[embassy_executor::task]
async fn client(stack: Stack<'static>) {
    let mut rx = [0u8; 256];
    let mut tx = [0u8; 256];
    for attempt in 1..=30u32 {
        let mut socket = TcpSocket::new(stack, &mut rx, &mut tx);
        socket.set_timeout(Some(Duration::from_secs(5)));
        let remote = (board::SIM_IP, board::SIM_PORT);
        if let Err(e) = socket.connect(remote).await {
            defmt::warn!("smoke: connect attempt {=u32} failed: {}", attempt, e);
            Timer::after(Duration::from_millis(500)).await;
            continue;
        }
        if socket.write(b"hello from mps2-an386\n").await.is_err() {
            continue;
        }
        let mut line = [0u8; 64];
        match read_line(&mut socket, &mut line).await {
            Some(n) if line[..n].starts_with(b"ack") => {
                defmt::info!("smoke: simulator side answered");
                socket.close();
                CLIENT_DONE.signal(());
                return;
            }
            _ => defmt::warn!("smoke: bad or no answer from the host"),
        }
        socket.abort();
        Timer::after(Duration::from_millis(500)).await;
    }
    defmt::error!("smoke: could not reach the host side");
    board::exit(1)
}
