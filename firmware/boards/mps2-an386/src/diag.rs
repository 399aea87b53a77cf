//! Diagnostics port for tests and demos under QEMU (TCP 5021, forwarded to
//! the host's loopback only by `scripts/qemu-run.sh` when `ADMIN_PORT` is
//! set).
//!
//! One command line per connection, answered with one line of `key=value`
//! pairs, then the connection closes:
//! * `report` — stack high-water mark and Ethernet counters;
//! * `exit` — the same report, then the firmware exits with status 0, which
//!   ends QEMU: a test shuts the firmware down cleanly and learns that it was
//!   healthy to the end;
//! * `panic` — panics, to prove that a failure reaches the host: the panic
//!   handler logs it and QEMU exits with status 1.
//!
//! ```text
//! stack_used=9384 stack_size=4182712 rx_frames=120 tx_frames=118 rx_dropped=0 irqs=121
//! ```

use embassy_net::tcp::TcpSocket;
use embassy_net::Stack;
use embassy_time::{with_timeout, Duration};
use heapless::String;

/// The diagnostics port on the guest.
pub const PORT: u16 = 5021;

/// The report line (without newline) as ASCII.
pub fn report_line() -> String<160> {
    let stack = fw_support::stack::usage();
    let eth = lan9118::stats();
    let mut line = String::new();
    let fields: [(&str, u32); 6] = [
        ("stack_used", stack.used as u32),
        ("stack_size", stack.size as u32),
        ("rx_frames", eth.rx_frames),
        ("tx_frames", eth.tx_frames),
        ("rx_dropped", eth.rx_dropped),
        ("irqs", eth.interrupts),
    ];
    for (i, (key, value)) in fields.iter().enumerate() {
        if i > 0 {
            let _ = line.push(' ');
        }
        let _ = line.push_str(key);
        let _ = line.push('=');
        push_decimal(&mut line, *value);
    }
    line
}

/// Appends `value` in decimal (core::fmt would link its whole machinery for
/// this). A full string keeps what fitted.
fn push_decimal<const N: usize>(out: &mut String<N>, mut value: u32) {
    let mut digits = [0u8; 10];
    let mut n = 0;
    loop {
        digits[n] = b'0' + (value % 10) as u8;
        n += 1;
        value /= 10;
        if value == 0 {
            break;
        }
    }
    for d in digits[..n].iter().rev() {
        let _ = out.push(char::from(*d));
    }
}

async fn write_all(socket: &mut TcpSocket<'_>, mut data: &[u8]) -> bool {
    while !data.is_empty() {
        match socket.write(data).await {
            Ok(0) | Err(_) => return false,
            Ok(n) => data = &data[n..],
        }
    }
    socket.flush().await.is_ok()
}

/// Serves the diagnostics port, one connection at a time.
#[embassy_executor::task]
pub async fn task(stack: Stack<'static>) -> ! {
    let mut rx = [0u8; 64];
    let mut tx = [0u8; 192];
    loop {
        let mut socket = TcpSocket::new(stack, &mut rx, &mut tx);
        socket.set_timeout(Some(Duration::from_secs(10)));
        if socket.accept(PORT).await.is_err() {
            continue;
        }
        let mut cmd = [0u8; 16];
        let mut len = 0;
        while len < cmd.len() && !cmd[..len].contains(&b'\n') {
            match socket.read(&mut cmd[len..]).await {
                Ok(0) | Err(_) => break,
                Ok(n) => len += n,
            }
        }
        let cmd = &cmd[..len];
        if cmd.starts_with(b"panic") {
            panic!("diagnostics port asked for a panic");
        }
        let exit = cmd.starts_with(b"exit");
        if exit || cmd.starts_with(b"report") {
            let mut line = report_line();
            let _ = line.push('\n');
            let _ = write_all(&mut socket, line.as_bytes()).await;
            defmt::info!("diag: {=str}", line.as_str());
        }
        socket.close();
        let _ = with_timeout(Duration::from_secs(2), socket.flush()).await;
        socket.abort();
        if exit {
            crate::report();
            defmt::info!("diag: exit requested");
            crate::exit(0);
        }
    }
}
