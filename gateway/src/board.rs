//! The entry point for boards (feature `embassy-net`).
//!
//! A board does three things: build its `embassy_net::Stack` (and spawn the
//! stack's runner), pick a [`Storage`] (flash, or [`crate::NoStorage`] where there
//! is none), and run [`run`] from one task:
//!
//! ```text
//! #[embassy_executor::task]
//! async fn gateway(stack: embassy_net::Stack<'static>) -> ! {
//!     let storage = hans_gateway::NoStorage;
//!     let options = hans_gateway::Options {
//!         network_managed: true, // apply NET_* to the stack
//!         seed,                  // from the board's random source
//!         restart: Some(restart),
//!         ..Default::default()
//!     };
//!     match hans_gateway::board::run(stack, storage, options).await {}
//! }
//! // in main: spawner.spawn(gateway(stack).unwrap());
//! ```
//!
//! [`run`] loads the stored configuration first ([`Gateway::load`]), then,
//! when the options say the board manages the network
//! (`network_managed`), applies its network settings
//! ([`Gateway::network`]) to the stack: the static address, mask and
//! gateway, or DHCP when `NET_DHCP` is 1 and the build has the `dhcp`
//! feature (without it a stored DHCP setting falls back to the static
//! address, with a warning, and `NET_DHCP` then reads as not running:
//! `ACCESS` bit 2). So the stack is created without an address
//! (`embassy_net::Config::default()`), and one binary serves every plant:
//! the board's build-time address is only the factory default
//! ([`Options::defaults`](crate::Options)), changed at run time through the
//! `NET_*` registers or the web page and applied at the next start. Then
//! the gateway is served ([`Gateway::serve`]), and with the feature `sntp`
//! the audit log's wall time is asked of the time server
//! (`network.ntp_server`, see `crate::sntp`) beside it.
//!
//! Everything the gateway needs (sockets, buffers, queue, register map)
//! lives inside the future of [`run`] (the storage too: it is moved in), so
//! the task's static storage holds it:
//! no other statics, no allocator. Its size is printed by
//! `core::mem::size_of_val` of the future if you need it; see the crate
//! docs for the RAM budget.
//!
//! The robot address and all other settings come from storage (written by
//! the PLC through the configuration registers) or from
//! [`Options::defaults`](crate::Options) when storage is empty. The stack
//! needs [`SOCKETS`] sockets for the gateway (`StackResources<N>` with
//! `N` ≥ [`SOCKETS`] plus what the board uses itself): a stack that runs
//! out of sockets panics when one more is created.

use core::convert::Infallible;
use core::net::Ipv4Addr;

#[cfg(any(feature = "dhcp", feature = "sntp"))]
use embassy_futures::join::join3;
use embassy_net::{ConfigV4, Ipv4Cidr, Stack, StaticConfigV4};

use crate::clock::SystemClock;
#[cfg(feature = "mqtt")]
use crate::config::HostName;
use crate::config::NetConfig;
use crate::gateway::Storage;
use crate::gateway::{Gateway, Options};
use crate::limits::MAX_SESSIONS;
use crate::net::embassy::EmbassyNet;

/// Sockets of the DataSheet reader (feature `datasheet`).
const DATASHEET_SOCKETS: usize = if cfg!(feature = "datasheet") { 1 } else { 0 };

/// Sockets of the web page (feature `web`).
#[cfg(feature = "web")]
const WEB_SOCKETS: usize = crate::web::WEB_CONNECTIONS;
#[cfg(not(feature = "web"))]
const WEB_SOCKETS: usize = 0;

/// The DHCP client's socket (feature `dhcp`; embassy-net adds it when
/// DHCP is switched on).
const DHCP_SOCKETS: usize = if cfg!(feature = "dhcp") { 1 } else { 0 };

/// The SNTP client's UDP socket (feature `sntp`).
const SNTP_SOCKETS: usize = if cfg!(feature = "sntp") { 1 } else { 0 };

/// The MQTT client's socket (feature `mqtt`).
const MQTT_SOCKETS: usize = if cfg!(feature = "mqtt") { 1 } else { 0 };

/// The EtherNet/IP adapter's sockets (feature `enip`): its TCP sessions'
/// (`enip::SOCKETS`) and two UDP ones, discovery (44818) and class 1 I/O
/// (2222). Made only while `enip.enabled` is on, but counted always: the
/// setting changes at run time, the stack's size does not.
#[cfg(feature = "enip")]
const ENIP_SOCKETS: usize = crate::enip::SOCKETS + 2;
#[cfg(not(feature = "enip"))]
const ENIP_SOCKETS: usize = 0;

/// Sockets the gateway uses on the board's stack: the Modbus sessions
/// ([`MAX_SESSIONS`]), two for the robot link, one for the DataSheet
/// (feature `datasheet`), the web page's connections (feature `web`:
/// `web::WEB_CONNECTIONS`), the DHCP client's (feature `dhcp`), the
/// SNTP client's (feature `sntp`), the MQTT client's (feature `mqtt`) and
/// the EtherNet/IP adapter's (feature `enip`: its sessions and two UDP).
/// A board sizes its `StackResources` with
/// this plus its own.
pub const SOCKETS: usize = MAX_SESSIONS
    + 2
    + DATASHEET_SOCKETS
    + WEB_SOCKETS
    + DHCP_SOCKETS
    + SNTP_SOCKETS
    + MQTT_SOCKETS
    + ENIP_SOCKETS;

/// Runs the gateway on the board's network stack until the future is
/// dropped (it never returns): loads the stored configuration, applies
/// its network settings to `stack` if `options.network_managed`, and
/// serves (see the module docs).
pub async fn run<S: Storage>(
    stack: embassy_net::Stack<'_>,
    mut storage: S,
    options: Options,
) -> Infallible {
    let clock = SystemClock;
    #[cfg(feature = "mqtt")]
    let options = match mac_name(stack.hardware_address().as_bytes()) {
        Some(node_name) => Options {
            node_name,
            ..options
        },
        None => options,
    };
    #[cfg(feature = "enip")]
    let options = Options {
        enip: options
            .enip
            .map(|o| enip_identity(o, stack.hardware_address().as_bytes())),
        ..options
    };
    // The gateway's state (25 KiB on the field device, 10 KiB in the core)
    // is built in `place`'s frame, which is gone once it returns: built
    // here, it was a temporary in the frame of the board task's poll (this
    // future's), which the stack carries for as long as the gateway runs.
    let mut gateway = None;
    let gateway: &Gateway = place(&mut gateway, || Gateway::new(options));
    gateway.load(&mut storage, &clock).await;
    if options.network_managed {
        apply_network(stack, gateway);
    }
    let net = EmbassyNet::new(stack);
    // `serve` borrows the storage (`&mut S` is a `Storage`), as it borrows
    // `net` and `clock`: given the storage itself (the field device's
    // firmware slots, 96 bytes), its future (110 KiB with its join) was
    // built on the stack, in the frame of the board task's poll, and then
    // moved into the task: 138 KiB of stack for as long as the gateway runs.
    // With DHCP the address comes (and may go) while the gateway runs: a
    // second future logs it. Without, apply_network has logged it.
    // With SNTP a third asks the time server (`crate::sntp`).
    #[cfg(any(feature = "dhcp", feature = "sntp"))]
    {
        #[cfg(feature = "dhcp")]
        let announce = announce(stack);
        #[cfg(not(feature = "dhcp"))]
        let announce = core::future::pending::<Infallible>();
        #[cfg(feature = "sntp")]
        let sntp = crate::sntp::on_stack(stack, gateway.hub(), &clock, options.seed);
        #[cfg(not(feature = "sntp"))]
        let sntp = core::future::pending::<Infallible>();
        let (never, _, _) = join3(gateway.serve(&net, &clock, &mut storage), announce, sntp).await;
        never
    }
    #[cfg(not(any(feature = "dhcp", feature = "sntp")))]
    gateway.serve(&net, &clock, &mut storage).await
}

/// Puts what `make` builds into `slot` and returns it there. Not inlined:
/// a large value is built in this function's frame (for the moment of the
/// call), not in its caller's, a future's poll, whose frame stays on the
/// stack under every other one while the future runs.
#[inline(never)]
fn place<T>(slot: &mut Option<T>, make: impl FnOnce() -> T) -> &mut T {
    slot.insert(make())
}

/// The board's own name, `hans-` and its MAC address in hex (the
/// Sparkplug edge node id when `mqtt.edge_id` is empty): unique on the
/// plant's network, and what its label shows. `None` without a 6-byte MAC.
#[cfg(feature = "mqtt")]
fn mac_name(mac: &[u8]) -> Option<HostName> {
    let mac: &[u8; 6] = mac.try_into().ok()?;
    let mut out = [0u8; 17];
    let (prefix, digits) = out.split_at_mut(5);
    prefix.copy_from_slice(b"hans-");
    crate::hex::encode(mac, digits)?;
    HostName::from_bytes(&out)
}

/// The EtherNet/IP adapter's identity on a board: the Ethernet Link
/// object's MAC address is the board's, and the Identity's serial number
/// its last four bytes (unique per device, as the MAC is). Unchanged
/// without a 6-byte MAC.
#[cfg(feature = "enip")]
fn enip_identity(o: crate::enip::EnipOptions, mac: &[u8]) -> crate::enip::EnipOptions {
    let Ok(mac) = <[u8; 6]>::try_from(mac) else {
        return o;
    };
    let [_, _, a, b, c, d] = mac;
    crate::enip::EnipOptions {
        mac,
        serial: u32::from_be_bytes([a, b, c, d]),
        ..o
    }
}

/// Applies the loaded network settings to the stack (see the module docs).
/// Not inlined: its locals are off the stack once it returns.
#[inline(never)]
fn apply_network(stack: Stack<'_>, gateway: &Gateway) {
    let net = gateway.network();
    #[cfg(feature = "dhcp")]
    if net.dhcp {
        info!("network: DHCP (the address is logged once a server gives one)");
        stack.set_config_v4(ConfigV4::Dhcp(embassy_net::DhcpConfig::default()));
        return;
    }
    #[cfg(not(feature = "dhcp"))]
    if net.dhcp {
        let [a, b, c, d] = net.ip.octets();
        warn!(
            "network: NET_DHCP is 1 but this firmware has no DHCP client (build feature `dhcp`): using the static address {}.{}.{}.{}",
            a, b, c, d
        );
        // What runs is the static address: the status says so (ACCESS
        // bit 2: the configuration differs from what runs).
        gateway.hub().with(|m| m.access.running.dhcp = false);
    }
    let config = static_config(&net);
    #[cfg(not(feature = "dhcp"))]
    log_address(&config);
    stack.set_config_v4(ConfigV4::Static(config));
}

/// The static IPv4 setting of `net` (address, mask, gateway; `0.0.0.0` as
/// gateway: none).
fn static_config(net: &NetConfig) -> StaticConfigV4 {
    StaticConfigV4 {
        address: Ipv4Cidr::new(net.ip, net.prefix_len()),
        gateway: (net.gateway != Ipv4Addr::UNSPECIFIED).then_some(net.gateway),
        dns_servers: heapless::Vec::new(),
    }
}

/// Logs an IPv4 setting.
fn log_address(c: &StaticConfigV4) {
    let [a, b, cc, d] = c.address.address().octets();
    let [g0, g1, g2, g3] = c.gateway.unwrap_or(Ipv4Addr::UNSPECIFIED).octets();
    info!(
        "network: address {}.{}.{}.{}/{}, gateway {}.{}.{}.{}",
        a,
        b,
        cc,
        d,
        c.address.prefix_len(),
        g0,
        g1,
        g2,
        g3
    );
}

/// Logs the address each time the stack gets one (at once for a static
/// address; when the lease comes with DHCP) and when it loses it.
#[cfg(feature = "dhcp")]
async fn announce(stack: Stack<'_>) -> Infallible {
    loop {
        stack.wait_config_up().await;
        if let Some(c) = stack.config_v4() {
            log_address(&c);
        }
        stack.wait_config_down().await;
        warn!("network: address lost (DHCP lease ended); waiting for a new one");
    }
}
