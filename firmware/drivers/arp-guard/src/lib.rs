//! An [`embassy-net-driver`] wrapper that bounds the ARP the network stack
//! takes from hosts it does not talk to, and the ICMP echo requests it
//! answers. Both boards wrap their Ethernet driver in it.
//!
//! smoltcp learns the sender of every ARP request for its address into a
//! neighbor cache of a few entries, evicting the entry that expires first.
//! A flood of ARP requests from many (forged) senders therefore evicts the
//! PLC's and the robot's entries within milliseconds; the stack must ask
//! for them again, and asks for at most one address a second: the PLC's
//! answers and the robot link stall for seconds at a time (found by the
//! robustness rig, `host-tests/robustness`, case `arp-request-flood`).
//!
//! [`Guarded`] wraps the board's driver and looks at each received ARP
//! frame before the stack does:
//! * ARP for another address passes (the stack ignores it);
//! * ARP from a *peer* passes: a host this device sent an IPv4 packet or an
//!   ARP request to recently (the last [`PEERS`] such addresses), so the
//!   PLC re-validating the device's address and the answers to the device's
//!   own requests always get through;
//! * any other ARP for this device takes a token from a bucket of
//!   [`BURST`] tokens refilled one every [`REFILL_MS`] ms; without a token
//!   it is dropped (counted in [`Stats::arp_dropped`]). So at most 10 new
//!   neighbors a second enter the cache, slower than a PLC or the robot
//!   refresh theirs.
//!
//! ICMP echo requests (ping) are answered by the stack (smoltcp's
//! `auto-icmp-echo-reply`, which the boards turn on), at a bounded rate:
//! each takes a token from a second bucket of [`ECHO_BURST`] tokens
//! refilled one every [`ECHO_REFILL_MS`] ms, and without a token it is
//! dropped (counted in [`Stats::echo_dropped`]). A technician's ping (one a
//! second) is always answered; a ping flood gets at most 10 answers a
//! second, so it cannot make the device spend its CPU and its link on
//! replies (an amplifier) instead of the PLC and the robot
//! (`host-tests/robustness`, case `icmp-ping-flood`).
//!
//! The device's address and its peers are learned from the frames it
//! transmits, so the wrapper needs no configuration and follows a DHCP
//! change. A dropped frame is handed to the stack empty, which drops it as
//! malformed: the driver interface has no way to take a received token
//! back.
//!
//! ```ignore
//! let eth = arp_guard::Guarded::new(lan9118::Lan9118::new(..)?);
//! let (stack, runner) = embassy_net::new(eth, config, resources, seed);
//! ```
//!
//! [`embassy-net-driver`]: embassy_net_driver
#![no_std]
#![deny(missing_docs)]

use core::cell::Cell;
use core::sync::atomic::{AtomicU32, Ordering};
use core::task::Context;

use embassy_net_driver::{Capabilities, Driver, HardwareAddress, LinkState};

/// Peers remembered (the destinations of the device's last transmissions).
pub const PEERS: usize = 8;
/// ARP frames from non-peers passed at once after a quiet time.
pub const BURST: u32 = 4;
/// One more such frame may pass every this many milliseconds.
pub const REFILL_MS: u64 = 100;
/// ICMP echo requests answered at once after a quiet time.
pub const ECHO_BURST: u32 = 5;
/// One more echo request may be answered every this many milliseconds.
pub const ECHO_REFILL_MS: u64 = 100;

const ETHERTYPE_IPV4: [u8; 2] = [0x08, 0x00];
const ETHERTYPE_ARP: [u8; 2] = [0x08, 0x06];

static ARP_DROPPED: AtomicU32 = AtomicU32::new(0);
static ECHO_DROPPED: AtomicU32 = AtomicU32::new(0);

/// What the guard counted since power-on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Stats {
    /// ARP frames for this device from non-peers, dropped over the rate.
    pub arp_dropped: u32,
    /// ICMP echo requests dropped over the rate (not answered).
    pub echo_dropped: u32,
}

/// Reads the guard's counters.
pub fn stats() -> Stats {
    Stats {
        arp_dropped: ARP_DROPPED.load(Ordering::Relaxed),
        echo_dropped: ECHO_DROPPED.load(Ordering::Relaxed),
    }
}

/// An IPv4 address as its four bytes (0.0.0.0: none).
type Ip = [u8; 4];

/// The bytes `range` of `frame` as an address, if the frame has them.
fn ip_at(frame: &[u8], at: usize) -> Option<Ip> {
    frame.get(at..at + 4)?.try_into().ok()
}

fn ethertype(frame: &[u8]) -> Option<[u8; 2]> {
    frame.get(12..14)?.try_into().ok()
}

/// A token bucket: `burst` tokens, one more every `refill_ms`.
struct Bucket {
    burst: u32,
    refill_ms: u64,
    tokens: Cell<u32>,
    refilled_ms: Cell<u64>,
}

impl Bucket {
    const fn new(burst: u32, refill_ms: u64) -> Self {
        Bucket {
            burst,
            refill_ms,
            tokens: Cell::new(burst),
            refilled_ms: Cell::new(0),
        }
    }

    /// Refills for the time passed, then takes a token: `false` when none
    /// is left.
    fn take(&self, now_ms: u64) -> bool {
        let last = self.refilled_ms.get();
        let new = now_ms.saturating_sub(last) / self.refill_ms.max(1);
        if new > 0 {
            let tokens = self
                .tokens
                .get()
                .saturating_add(new.min(u64::from(self.burst)) as u32);
            self.tokens.set(tokens.min(self.burst));
            self.refilled_ms.set(last + new * self.refill_ms);
        }
        match self.tokens.get() {
            0 => false,
            n => {
                self.tokens.set(n - 1);
                true
            }
        }
    }
}

/// What the guard knows: the device's address, its peers, the buckets.
struct Gate {
    own: Cell<Ip>,
    peers: Cell<[Ip; PEERS]>,
    next_peer: Cell<usize>,
    arp: Bucket,
    echo: Bucket,
}

impl Gate {
    const fn new() -> Self {
        Gate {
            own: Cell::new([0; 4]),
            peers: Cell::new([[0; 4]; PEERS]),
            next_peer: Cell::new(0),
            arp: Bucket::new(BURST, REFILL_MS),
            echo: Bucket::new(ECHO_BURST, ECHO_REFILL_MS),
        }
    }

    fn is_peer(&self, ip: Ip) -> bool {
        ip != [0; 4] && self.peers.get().contains(&ip)
    }

    fn add_peer(&self, ip: Ip) {
        let unicast = ip != [0; 4] && ip[0] < 224 && ip != [255; 4];
        if !unicast || self.is_peer(ip) {
            return;
        }
        let mut peers = self.peers.get();
        let i = self.next_peer.get() % PEERS;
        if let Some(slot) = peers.get_mut(i) {
            *slot = ip;
        }
        self.peers.set(peers);
        self.next_peer.set((i + 1) % PEERS);
    }

    /// Learns the device's address and its peers from a transmitted frame.
    fn learn(&self, frame: &[u8]) {
        match ethertype(frame) {
            Some(ETHERTYPE_IPV4) => {
                if let (Some(src), Some(dst)) = (ip_at(frame, 26), ip_at(frame, 30)) {
                    if src != [0; 4] {
                        self.own.set(src);
                    }
                    self.add_peer(dst);
                }
            }
            Some(ETHERTYPE_ARP) => {
                if let Some(sender) = ip_at(frame, 28) {
                    if sender != [0; 4] {
                        self.own.set(sender);
                    }
                }
                // A request the device sends: the answer must get through.
                if frame.get(20..22) == Some(&[0, 1]) {
                    if let Some(target) = ip_at(frame, 38) {
                        self.add_peer(target);
                    }
                }
            }
            _ => {}
        }
    }

    /// Whether a received frame goes to the stack.
    fn admit(&self, frame: &[u8], now_ms: u64) -> bool {
        match ethertype(frame) {
            Some(ETHERTYPE_ARP) => self.admit_arp(frame, now_ms),
            Some(ETHERTYPE_IPV4) if is_echo_request(frame) => {
                let ok = self.echo.take(now_ms);
                if !ok {
                    ECHO_DROPPED.fetch_add(1, Ordering::Relaxed);
                }
                ok
            }
            _ => true,
        }
    }

    /// Whether a received ARP frame goes to the stack.
    fn admit_arp(&self, frame: &[u8], now_ms: u64) -> bool {
        let (Some(sender), Some(target)) = (ip_at(frame, 28), ip_at(frame, 38)) else {
            return true; // too short: the stack drops it
        };
        let own = self.own.get();
        if (own != [0; 4] && target != own) || self.is_peer(sender) {
            return true;
        }
        let ok = self.arp.take(now_ms);
        if !ok {
            ARP_DROPPED.fetch_add(1, Ordering::Relaxed);
        }
        ok
    }
}

/// Whether an IPv4 frame is an ICMP echo request (its first fragment: the
/// one with the ICMP header; later fragments carry none).
fn is_echo_request(frame: &[u8]) -> bool {
    let frag: Option<[u8; 2]> = frame.get(20..22).and_then(|f| f.try_into().ok());
    let (Some(&vihl), Some(frag), Some(&proto)) = (frame.get(14), frag, frame.get(23)) else {
        return false;
    };
    let first_fragment = (u16::from_be_bytes(frag) & 0x1FFF) == 0;
    let icmp_at = 14 + usize::from(vihl & 0x0F) * 4;
    proto == 1 && first_fragment && frame.get(icmp_at) == Some(&8)
}

fn now_ms() -> u64 {
    embassy_time::Instant::now().as_millis()
}

/// A driver whose received ARP is bounded as the crate docs say.
pub struct Guarded<D> {
    inner: D,
    gate: Gate,
}

impl<D: Driver> Guarded<D> {
    /// Wraps `inner`.
    pub const fn new(inner: D) -> Self {
        Guarded {
            inner,
            gate: Gate::new(),
        }
    }

    /// The wrapped driver.
    pub fn inner(&self) -> &D {
        &self.inner
    }
}

/// A received frame: handed to the stack if the guard admits it.
pub struct RxToken<'a, T> {
    inner: T,
    gate: &'a Gate,
}

impl<T: embassy_net_driver::RxToken> embassy_net_driver::RxToken for RxToken<'_, T> {
    fn consume<R, F>(self, f: F) -> R
    where
        F: FnOnce(&mut [u8]) -> R,
    {
        let gate = self.gate;
        self.inner.consume(|frame| {
            if gate.admit(frame, now_ms()) {
                f(frame)
            } else {
                f(&mut [])
            }
        })
    }
}

/// Room for a frame to transmit; the guard learns from what is sent.
pub struct TxToken<'a, T> {
    inner: T,
    gate: &'a Gate,
}

impl<T: embassy_net_driver::TxToken> embassy_net_driver::TxToken for TxToken<'_, T> {
    fn consume<R, F>(self, len: usize, f: F) -> R
    where
        F: FnOnce(&mut [u8]) -> R,
    {
        let gate = self.gate;
        self.inner.consume(len, |frame| {
            let r = f(frame);
            gate.learn(frame);
            r
        })
    }
}

impl<D: Driver> Driver for Guarded<D> {
    type RxToken<'a>
        = RxToken<'a, D::RxToken<'a>>
    where
        Self: 'a;
    type TxToken<'a>
        = TxToken<'a, D::TxToken<'a>>
    where
        Self: 'a;

    fn receive(&mut self, cx: &mut Context) -> Option<(Self::RxToken<'_>, Self::TxToken<'_>)> {
        let gate = &self.gate;
        let (rx, tx) = self.inner.receive(cx)?;
        Some((RxToken { inner: rx, gate }, TxToken { inner: tx, gate }))
    }

    fn transmit(&mut self, cx: &mut Context) -> Option<Self::TxToken<'_>> {
        let gate = &self.gate;
        let tx = self.inner.transmit(cx)?;
        Some(TxToken { inner: tx, gate })
    }

    fn link_state(&mut self, cx: &mut Context) -> LinkState {
        self.inner.link_state(cx)
    }

    fn capabilities(&self) -> Capabilities {
        self.inner.capabilities()
    }

    fn hardware_address(&self) -> HardwareAddress {
        self.inner.hardware_address()
    }
}
