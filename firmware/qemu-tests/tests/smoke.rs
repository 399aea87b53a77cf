//! The smoke firmware under QEMU: TCP in both directions through the LAN9118
//! driver, then a semihosting exit code.

use std::io::{BufRead, BufReader, Write};
use std::net::TcpListener;
use std::thread;
use std::time::Duration;

use qemu_tests::{connect_retry, firmware_elf, Ports, Qemu, LOOPBACK};

#[test]
fn smoke_firmware_talks_both_ways_and_exits_zero() {
    let ports = Ports::pick();
    // The "simulator" side: answers the firmware's greeting with `ack ...`.
    let listener = TcpListener::bind((LOOPBACK, ports.sim)).expect("bind sim port");
    listener.set_nonblocking(false).expect("blocking");
    let sim = thread::spawn(move || -> Option<String> {
        // Bounded: the firmware gives up after 60 s and QEMU then exits,
        // which the accept below cannot see, so time out on our own.
        let (stream, _) = accept_with_timeout(&listener, Duration::from_secs(90))?;
        stream
            .set_read_timeout(Some(Duration::from_secs(10)))
            .ok()?;
        let mut line = String::new();
        BufReader::new(&stream).read_line(&mut line).ok()?;
        (&stream).write_all(format!("ack {line}").as_bytes()).ok()?;
        Some(line)
    });

    let mut qemu = Qemu::start(
        "smoke",
        &firmware_elf("smoke"),
        ports,
        Duration::from_secs(120),
    )
    .expect("start QEMU");

    // The host as a client of the firmware's echo server on 502.
    let echoed = (|| {
        for _ in 0..30 {
            let mut stream = connect_retry(qemu.ports.modbus, Duration::from_secs(30)).ok()?;
            stream
                .set_read_timeout(Some(Duration::from_secs(10)))
                .ok()?;
            stream.write_all(b"ping from host\n").ok()?;
            let mut line = String::new();
            if BufReader::new(&stream).read_line(&mut line).is_ok() && !line.is_empty() {
                return Some(line);
            }
            thread::sleep(Duration::from_millis(300));
        }
        None
    })();

    let status = qemu.process().wait(Duration::from_secs(90));
    let greeting = sim.join().expect("sim thread");
    let log = qemu.log_text();
    println!("--- firmware log ---\n{log}");
    // "stack: N of M bytes used" (decoded only when defmt-print is installed).
    if let Some(line) = log.lines().find(|l| l.contains("INFO  stack: ")) {
        let nums: Vec<&str> = line
            .split_whitespace()
            .filter(|w| w.chars().all(|c| c.is_ascii_digit()))
            .collect();
        if let [used, size] = nums[..] {
            println!("smoke: stack_used={used} stack_size={size}");
        }
    }

    assert_eq!(
        echoed.as_deref(),
        Some("ping from host\n"),
        "echo over :502"
    );
    assert_eq!(
        greeting.as_deref(),
        Some("hello from mps2-an386\n"),
        "greeting received on the simulator port"
    );
    let status = status.expect("firmware exits by itself");
    assert_eq!(status.code(), Some(0), "semihosting exit code");
}

fn accept_with_timeout(
    listener: &TcpListener,
    limit: Duration,
) -> Option<(std::net::TcpStream, std::net::SocketAddr)> {
    listener.set_nonblocking(true).ok()?;
    let start = std::time::Instant::now();
    while start.elapsed() < limit {
        match listener.accept() {
            Ok((stream, addr)) => {
                stream.set_nonblocking(false).ok()?;
                return Some((stream, addr));
            }
            Err(_) => thread::sleep(Duration::from_millis(50)),
        }
    }
    None
}

/// A forwarded port another program took between the pick and QEMU's bind
/// (QEMU then exits at once: "Could not set up host forwarding rule"): the
/// harness starts QEMU again on other ports, and it listens there.
#[test]
fn a_forward_taken_before_qemu_binds_it_moves_to_another_port() {
    let taken = TcpListener::bind((LOOPBACK, 0)).expect("bind a port to take");
    let taken_port = taken.local_addr().expect("local addr").port();
    let ports = Ports {
        modbus: taken_port,
        ..Ports::pick()
    };
    let mut qemu = Qemu::start(
        "smoke-port-taken",
        &firmware_elf("smoke"),
        ports,
        Duration::from_secs(60),
    )
    .expect("start QEMU");
    assert_ne!(qemu.ports.modbus, taken_port, "moved off the taken port");
    assert!(
        qemu.process().running(),
        "QEMU runs: {}",
        qemu.stderr_text()
    );
    assert_eq!(
        qemu_tests::listening(&[qemu.ports.modbus]),
        Some(true),
        "QEMU listens on its new Modbus forward"
    );
    assert_eq!(qemu.ports.sim, ports.sim, "the simulator's port stays");
    drop(taken);
}
