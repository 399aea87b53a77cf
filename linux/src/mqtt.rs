//! The Sparkplug B edge node's MQTT client on Linux, on its own: the
//! gateway runs it itself when `mqtt.enabled` is on; this runs one beside a
//! hub the caller owns (the tests' broker runs, the fleet benchmark).

use core::convert::Infallible;

use embassy_time::Instant;
use hans_gateway::hub::Hub;
use hans_gateway::mqtt::{run, Settings, Status};
use hans_gateway::SystemClock;

use crate::net::TokioNet;

/// [`run`] over tokio's sockets and the system clock (on a current-thread
/// runtime: the future is not `Send`); the timestamps from the host's wall
/// clock unless `settings` has one.
pub async fn run_host(hub: &Hub, settings: &Settings, status: &Status) -> Infallible {
    let mut settings = settings.clone();
    if settings.utc_at_zero.is_none() {
        let utc = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| u64::try_from(d.as_millis()).unwrap_or(u64::MAX))
            .unwrap_or(0);
        settings.utc_at_zero = Some(utc.saturating_sub(Instant::now().as_millis()));
    }
    let net = TokioNet::new(core::net::Ipv4Addr::UNSPECIFIED);
    crate::waker::steady_waker(run(hub, &SystemClock, &net, &settings, status)).await
}
