//! The status mirror's second source: the controller's DataSheet port
//! (chapter 5, JSON packets at 20/10/5 Hz on 10004/10005/10006), read with
//! the codec's deframer and JSON reader. It spares the command port: with
//! `CFG_STATUS_SOURCE = 1` the engine stops its polling rounds (motion
//! completion still polls `ReadRobotState`, which is exact).
//!
//! The DataSheet connection goes to the robot's address (connect mode) or
//! to the address of the controller the link accepted (listen mode: never
//! another host's, see `crate::link::admits`; and with `robot.address` set,
//! only that address), on `CFG_DATASHEET_PORT`, and follows that address:
//! a new robot address, or in listen mode a new controller link after the
//! old one was lost, moves it.
//! When it fails it is retried every [`RETRY_DELAY`]; [`SILENCE_TIMEOUT`]
//! without data ends it. A packet that cannot be read (a bad header, more
//! than [`PAYLOAD_MAX`] bytes, JSON the codec rejects) is dropped; the first
//! one on each connection is logged, and the count when it ends. The status
//! age register shows how fresh the data is.

use core::convert::Infallible;
use core::net::{Ipv4Addr, SocketAddrV4};

use embassy_time::Duration;
use hans_codec::datasheet::{DataSheet, Deframer};

use crate::clock::{with_timeout, Clock};
use crate::config::{LinkMode, StatusSource};
use crate::hub::Hub;
use crate::link::CONNECT_TIMEOUT;
use crate::net::Socket;
use crate::state::Model;

/// Largest DataSheet payload accepted (a controller's is ~3 KiB). A larger
/// packet is dropped.
pub(crate) const PAYLOAD_MAX: usize = 6144;

/// Silence that ends the connection: the slowest port (10006) sends every
/// 200 ms, so a controller quiet this long is gone or stuck.
pub(crate) const SILENCE_TIMEOUT: Duration = Duration::from_secs(2);

/// Pause after a failed connection attempt (connect refused, or no answer
/// within [`CONNECT_TIMEOUT`]).
pub(crate) const RETRY_DELAY: Duration = Duration::from_secs(1);

/// Pause after a connection ended, and between looks at the configuration
/// while the DataSheet is not the status source (or has no address yet).
pub(crate) const IDLE_DELAY: Duration = Duration::from_millis(200);

/// Counts a dropped packet; true for the first of the connection (the one
/// logged, so that a controller sending bad data cannot flood the log).
fn first_drop(dropped: &mut u32) -> bool {
    *dropped = dropped.saturating_add(1);
    *dropped == 1
}

/// Where to read the DataSheet now, if configured.
fn target(m: &Model) -> Option<SocketAddrV4> {
    let c = &m.config.active;
    if c.status_source != StatusSource::DataSheet {
        return None;
    }
    let ip = match c.link_mode {
        LinkMode::Connect => c.robot_ip,
        // The accepted controller; with an address configured never another
        // (the link refuses it; checked again here all the same).
        LinkMode::Listen => m
            .link
            .peer
            .filter(|p| c.robot_ip.is_unspecified() || *p == c.robot_ip)
            .unwrap_or(Ipv4Addr::UNSPECIFIED),
    };
    (!ip.is_unspecified()).then(|| SocketAddrV4::new(ip, c.datasheet_port))
}

/// Reads the DataSheet whenever it is the configured status source.
pub(crate) async fn run<S: Socket, C: Clock>(hub: &Hub, clock: &C, mut sock: S) -> Infallible {
    let mut deframer = Deframer::<PAYLOAD_MAX>::new();
    let mut buf = [0u8; 512];
    loop {
        let Some(addr) = hub.with(|m| target(m)) else {
            clock.sleep(IDLE_DELAY).await;
            continue;
        };
        match with_timeout(clock, CONNECT_TIMEOUT, sock.connect(addr)).await {
            Ok(Ok(())) => info!("datasheet: connected to port {}", addr.port()),
            _ => {
                sock.close().await;
                clock.sleep(RETRY_DELAY).await;
                continue;
            }
        }
        deframer.reset();
        let discarded = deframer.discarded();
        let mut dropped = 0u32;
        // Another address (a new robot address or port, or a controller
        // reconnected from elsewhere), or another status source, ends it.
        while hub.with(|m| target(m)) == Some(addr) {
            let n = match with_timeout(clock, SILENCE_TIMEOUT, sock.read(&mut buf)).await {
                Ok(Ok(n)) if n > 0 => n,
                _ => break,
            };
            // Each sheet is applied where it is parsed: a DataSheet is ~2 KiB,
            // one on the stack is enough.
            deframer.feed(buf.get(..n).unwrap_or(&[]), |item| {
                match item.map(DataSheet::parse) {
                    Ok(Ok(sheet)) => {
                        let now = clock.now();
                        hub.with(|m| m.robot.apply_sheet(&sheet, now));
                    }
                    Ok(Err(e)) => {
                        if first_drop(&mut dropped) {
                            warn!("datasheet: payload dropped: {}", e);
                        }
                    }
                    Err(e) => {
                        if first_drop(&mut dropped) {
                            warn!("datasheet: packet dropped: {}", e);
                        }
                    }
                }
            });
        }
        let garbage = deframer.discarded().saturating_sub(discarded);
        info!(
            "datasheet: connection ended ({} packets dropped, {} bytes skipped)",
            dropped, garbage
        );
        sock.close().await;
        clock.sleep(IDLE_DELAY).await;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;

    #[test]
    fn the_connection_follows_the_address_not_every_configuration_change() {
        let mut m = Model::new(Config::default(), Config::default());
        let peer = |ip: [u8; 4]| Ipv4Addr::from(ip);
        m.config.active.status_source = StatusSource::DataSheet;
        m.config.active.link_mode = LinkMode::Listen;
        m.config.active.datasheet_port = 10004;
        // Listen mode, no controller yet: nowhere to go.
        assert_eq!(target(&m), None);
        m.link.peer = Some(peer([127, 0, 0, 2]));
        let first = Some(SocketAddrV4::new(peer([127, 0, 0, 2]), 10004));
        assert_eq!(target(&m), first);
        // Another applied setting (the poll period) keeps the connection.
        m.config.active.poll_ms = m.config.active.poll_ms.wrapping_add(10);
        m.config.generation = m.config.generation.wrapping_add(1);
        assert_eq!(target(&m), first);
        // A new controller link from elsewhere (the old one was lost) moves it.
        m.link.peer = Some(peer([127, 0, 0, 3]));
        assert_eq!(
            target(&m),
            Some(SocketAddrV4::new(peer([127, 0, 0, 3]), 10004))
        );
        // So does another port, and polling as the source ends it.
        m.config.active.datasheet_port = 10005;
        assert_eq!(
            target(&m),
            Some(SocketAddrV4::new(peer([127, 0, 0, 3]), 10005))
        );
        m.config.active.status_source = StatusSource::Polling;
        assert_eq!(target(&m), None);
    }

    #[test]
    fn listen_mode_with_a_controller_address_reads_only_from_it() {
        let mut m = Model::new(Config::default(), Config::default());
        m.config.active.status_source = StatusSource::DataSheet;
        m.config.active.link_mode = LinkMode::Listen;
        m.config.active.datasheet_port = 10004;
        m.config.active.robot_ip = Ipv4Addr::new(10, 0, 0, 2);
        m.link.peer = Some(Ipv4Addr::new(10, 0, 0, 66));
        assert_eq!(target(&m), None);
        m.link.peer = Some(Ipv4Addr::new(10, 0, 0, 2));
        assert_eq!(
            target(&m),
            Some(SocketAddrV4::new(Ipv4Addr::new(10, 0, 0, 2), 10004))
        );
    }
}
