//! Board support for the Arm MPS2+ AN386 (Cortex-M4F) as emulated by QEMU's
//! `mps2-an386` machine: the CI board of this project.
//!
//! What the board provides, and nothing more:
//! * clocks: a fixed 25 MHz system clock; SysTick drives `embassy-time`;
//! * the interrupt vector table (the chip has no PAC crate) with the LAN9118
//!   Ethernet interrupt on line 13;
//! * the LAN9118 driver and an `embassy-net` stack on it; the gateway
//!   firmwares start it without an address and the gateway applies its
//!   network settings, whose factory defaults ([`FACTORY_NET`]) are what
//!   QEMU's user-mode network expects (10.0.2.15/24, gateway 10.0.2.2);
//!   the smoke firmware sets that address itself ([`guest_config`]);
//! * no random source of its own: [`seed`] reads the host's
//!   `/dev/urandom` through semihosting (with a predictable fallback, see
//!   there);
//! * logs: `defmt` over semihosting (QEMU writes the frames to its stdout;
//!   decode with `defmt-print -e <elf>`);
//! * exit codes: [`exit`] and the panic handler end QEMU through semihosting,
//!   so a test sees 0 for pass and 1 for fail;
//! * an executor loop that sleeps with WFI ([`executor`]), so QEMU idles
//!   instead of spinning.
#![no_std]
// The gateway is one future of nested futures (engine, sessions, web
// connections, picoserve): computing its layout needs more depth than the
// default 128.
#![recursion_limit = "256"]
#![deny(missing_docs)]

pub mod diag;
pub mod executor;
pub mod firmware;
pub mod irq;
#[cfg(feature = "field-device")]
pub mod slots;

use cortex_m::peripheral::NVIC;
use defmt_semihosting as _;
use embassy_executor::Spawner;
use embassy_net::{Ipv4Address, Ipv4Cidr, Stack, StackResources, StaticConfigV4};
use hans_gateway::config::{HostName, MqttConfig, NetConfig};
use lan9118::Lan9118;
use static_cell::ConstStaticCell;

/// System (and SysTick) clock of the AN386 image, in Hz.
pub const SYSCLK_HZ: u32 = 25_000_000;

/// Base address of the LAN9118 register window.
pub const ETH_BASE: usize = 0x4020_0000;

/// The guest address QEMU's user-mode network (slirp) expects by default.
pub const GUEST_IP: Ipv4Address = Ipv4Address::new(10, 0, 2, 15);

/// Slirp's gateway (and host alias).
pub const GATEWAY_IP: Ipv4Address = Ipv4Address::new(10, 0, 2, 2);

/// The factory network settings of the gateway on this board: the address
/// QEMU's user-mode network expects ([`GUEST_IP`]/24 via [`GATEWAY_IP`]),
/// Modbus on 502 and the web page on 80 (`scripts/qemu-run.sh` forwards
/// both to the host's loopback). The board has no persistent storage, so
/// these are what it runs with, unless changed from the page or the
/// registers for the rest of a run (they take effect at the next start,
/// which, without storage, comes back to these).
pub const FACTORY_NET: NetConfig = NetConfig {
    ip: GUEST_IP,
    mask: Ipv4Address::new(255, 255, 255, 0),
    gateway: GATEWAY_IP,
    ..NetConfig::DEFAULT
};

/// The factory network settings this start: [`FACTORY_NET`], with DHCP
/// when QEMU's command line holds the word `dhcp` (`-append dhcp`; set by
/// `FIRMWARE_ARGS=dhcp scripts/qemu-run.sh`), as `HANS_GW_NET=dhcp` does at
/// build time on the NUCLEO. QEMU's user-mode network has a DHCP server,
/// which hands out 10.0.2.15 first: the forwarded ports still reach the
/// firmware. The firmware reads its command line through semihosting.
pub fn factory_net() -> NetConfig {
    let dhcp = find_arg(|a| (a == "dhcp").then_some(())).is_some();
    NetConfig {
        dhcp,
        ..FACTORY_NET
    }
}

/// The longest command line read: QEMU's semihosting gives the kernel's
/// path (as `scripts/qemu-run.sh` was given it; the bootloader's for the
/// field device) followed by the words of `-append` (`flash=PATH` among
/// them), and refuses the whole line to a buffer too short for it.
const CMDLINE_MAX: usize = 512;

/// The first word of QEMU's command line (`-append`, read through
/// semihosting) for which `f` gives a value. A line that cannot be read
/// (longer than [`CMDLINE_MAX`]) is logged and counts as empty.
fn find_arg<T>(mut f: impl FnMut(&str) -> Option<T>) -> Option<T> {
    match semihosting::experimental::env::args::<CMDLINE_MAX>() {
        Ok(args) => (&args).find_map(|a| a.ok().and_then(&mut f)),
        Err(_) => {
            defmt::warn!(
                "command line: not readable (longer than {=usize} bytes?): ignored",
                CMDLINE_MAX
            );
            None
        }
    }
}

/// Whether QEMU's command line holds the word `recovery`: the NUCLEO's
/// button held at power-up, on this board (`FIRMWARE_ARGS=recovery`): a
/// start with the factory network and access settings instead of the
/// stored ones (the stored configuration is kept until the next save).
pub fn recovery() -> bool {
    find_arg(|a| (a == "recovery").then_some(())).is_some()
}

/// Whether QEMU's command line holds the word `selfcheck=fail`: a test's
/// way to make an image on trial fail its self-check (it then does not
/// confirm itself and restarts, and the bootloader rolls it back).
pub fn self_check_fails() -> bool {
    find_arg(|a| (a == "selfcheck=fail").then_some(())).is_some()
}

/// The factory MQTT settings this start: `defaults` (off), or, when
/// QEMU's command line holds the word `mqtt=A.B.C.D:PORT` (set by
/// `MQTT_PORT=... scripts/qemu-run.sh`, which forwards 10.0.2.100:1883 to
/// a broker on the host's loopback), the Sparkplug edge node on and
/// publishing to that broker. The host hands it in as it hands in the
/// setup code; a malformed word is logged and leaves MQTT off.
pub fn factory_mqtt(defaults: MqttConfig) -> MqttConfig {
    match find_arg(|a| a.strip_prefix("mqtt=").map(broker_of)) {
        None => defaults,
        Some(None) => {
            defmt::warn!("mqtt: the command line's mqtt= is not A.B.C.D:PORT: MQTT stays off");
            defaults
        }
        Some(Some((broker, port))) => {
            defmt::info!(
                "mqtt: broker {=str}:{=u16}, handed in by the host",
                broker.as_str(),
                port
            );
            MqttConfig {
                enabled: true,
                broker,
                port,
                ..defaults
            }
        }
    }
}

/// `A.B.C.D:PORT` (an IPv4 address, a port 1-65535) as the `mqtt.broker`
/// and `mqtt.port` settings.
fn broker_of(word: &str) -> Option<(HostName, u16)> {
    let (ip, port) = word.rsplit_once(':')?;
    ip.parse::<core::net::Ipv4Addr>().ok()?;
    let port = port.parse::<u16>().ok().filter(|&p| p != 0)?;
    Some((HostName::new(ip)?, port))
}

/// The one-time setup code of the first administrator (the web page's;
/// `hans_gateway::SetupCode`): the host hands it in on QEMU's command line
/// as the word `setup=CODE` (`SETUP_CODE=... scripts/qemu-run.sh`), as it
/// hands in the random seed; without it the firmware makes one from the
/// seed's random source and prints it in its log, which only the host
/// reads (as the NUCLEO prints its own in the probe's log). It is never
/// served on any port.
pub fn setup_code() -> Option<hans_gateway::SetupCode> {
    let given = find_arg(|a| {
        a.strip_prefix("setup=")
            .and_then(|c| hans_gateway::SetupCode::parse(c.as_bytes()))
    });
    if given.is_some() {
        defmt::info!("setup code: handed in by the host");
        return given;
    }
    let mut random = [0u8; hans_gateway::SETUP_CODE_LEN];
    if semihosting::experimental::random::fill_bytes(&mut random).is_err() {
        defmt::warn!("setup code: no random source; no administrator can be created");
        return None;
    }
    let code = hans_gateway::SetupCode::from_random(random);
    defmt::info!(
        "setup code for the first administrator: {=str}",
        code.to_text().as_str()
    );
    Some(code)
}

/// The address `scripts/qemu-run.sh` forwards (`guestfwd`) to the robot
/// simulator on the host's loopback.
pub const SIM_IP: Ipv4Address = Ipv4Address::new(10, 0, 2, 100);

/// The port of [`SIM_IP`] that reaches the simulator's command port.
pub const SIM_PORT: u16 = 10003;

/// Number of sockets the network stack is sized for: the gateway's, plus two
/// for the board's own services (the diagnostics port; the smoke firmware's
/// server and client). Each costs a few hundred bytes of bookkeeping; their
/// buffers belong to the tasks using them.
pub const SOCKETS: usize = hans_gateway::board::SOCKETS + 2;

/// Why the board could not start.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum BoardError {
    /// The core peripherals were already taken.
    CorePeripherals,
    /// SysTick rejected the clock.
    Time,
    /// The Ethernet controller did not come up.
    Ethernet(lan9118::InitError),
    /// A task could not be spawned (its pool is exhausted).
    Spawn,
    /// The flash file (field device: the firmware slots) cannot be used:
    /// why.
    Flash(&'static str),
}

/// Ends the program: QEMU exits with `code` (0 pass, anything else fail).
pub fn exit(code: i32) -> ! {
    semihosting::process::exit(code)
}

/// Logs a board error and exits with status 1.
pub fn fail(error: BoardError) -> ! {
    defmt::error!("board: {}", error);
    exit(1)
}

/// The static setting of QEMU's user-mode network for firmwares that set
/// their address themselves (the smoke firmware): [`GUEST_IP`]/24 via
/// [`GATEWAY_IP`].
pub fn guest_config() -> embassy_net::Config {
    embassy_net::Config::ipv4_static(StaticConfigV4 {
        address: Ipv4Cidr::new(GUEST_IP, 24),
        gateway: Some(GATEWAY_IP),
        dns_servers: heapless::Vec::new(),
    })
}

/// Starts time, the Ethernet controller and the network stack with
/// `config` (`embassy_net::Config::default()`: no address yet, the gateway
/// sets it), and spawns the stack's task. Returns the stack.
pub fn init(spawner: Spawner, config: embassy_net::Config) -> Result<Stack<'static>, BoardError> {
    let core = cortex_m::Peripherals::take().ok_or(BoardError::CorePeripherals)?;
    systick_time::init(core.SYST, SYSCLK_HZ).map_err(|_| BoardError::Time)?;

    // SAFETY: ETH_BASE is the LAN9118's window on this machine and nothing
    // else touches it; the interrupt handler only uses the same window.
    // Const-initialised statics: built in place, never copied through the
    // stack (StackResources alone is ~12 KiB).
    static BUFFERS: ConstStaticCell<lan9118::Buffers> =
        ConstStaticCell::new(lan9118::Buffers::new());
    let buffers = BUFFERS.take();
    let eth = unsafe { Lan9118::new(ETH_BASE, buffers) }.map_err(BoardError::Ethernet)?;
    let mac = eth.mac_address();
    // ARP from hosts the device does not talk to, at a bounded rate: an
    // ARP flood must not evict the PLC's and the robot's neighbor entries.
    let eth = arp_guard::Guarded::new(eth);
    defmt::info!("lan9118: up, MAC {=[u8]:02x}", mac);
    // SAFETY: the handler it enables (`irq::ETHERNET`) only touches
    // lock-free wakers and the controller, so unmasking it breaks no
    // critical section.
    unsafe { NVIC::unmask(irq::Interrupt::Ethernet) };

    static RESOURCES: ConstStaticCell<StackResources<SOCKETS>> =
        ConstStaticCell::new(StackResources::new());
    // TCP initial sequence numbers and local ports: from the host's
    // /dev/urandom through semihosting (see `seed`), else from the MAC
    // (unique per -nic).
    let mut random = [0u8; 8];
    let seed = match semihosting::experimental::random::fill_bytes(&mut random) {
        Ok(()) => u64::from_le_bytes(random),
        Err(_) => u64::from_le_bytes([mac[0], mac[1], mac[2], mac[3], mac[4], mac[5], 0x48, 0x53]),
    };
    let (stack, runner) = embassy_net::new(eth, config, RESOURCES.take(), seed);
    spawner.spawn(net_task(runner).map_err(|_| BoardError::Spawn)?);
    Ok(stack)
}

#[embassy_executor::task]
async fn net_task(
    mut runner: embassy_net::Runner<'static, arp_guard::Guarded<Lan9118<'static>>>,
) -> ! {
    runner.run().await
}

/// The seed of the web page's session tokens and password salts.
///
/// QEMU's `mps2-an386` has no random source of its own (no TRNG, and the
/// emulated cycle counter does not run). Under QEMU the board reads the
/// host's `/dev/urandom` through semihosting (QEMU runs with
/// `-semihosting-config target=native`, and the firmware already logs and
/// exits through it): unpredictable, but a debugger's facility, which an
/// MPS2 board without a debugger attached would not have. If that read
/// fails, the seed is derived from what varies a little from run to run:
/// the SysTick counter and the uptime at the moment of the call (both
/// follow the host's clock), mixed with the MAC address. That fallback is
/// **predictable** (session tokens and salts could be guessed by anyone who
/// knows the firmware), and logged as a warning. A real board takes the
/// seed from its hardware random generator (the NUCLEO: the STM32 RNG).
pub fn seed(stack: Stack<'_>) -> [u8; 32] {
    let mut seed = [0u8; 32];
    if semihosting::experimental::random::fill_bytes(&mut seed).is_ok() {
        return seed;
    }
    defmt::warn!(
        "seed: the host's /dev/urandom is not readable through semihosting: web session tokens are predictable"
    );
    let mut mac = [0u8; 8];
    for (m, b) in mac.iter_mut().zip(stack.hardware_address().as_bytes()) {
        *m = *b;
    }
    let systick = u64::from(cortex_m::peripheral::SYST::get_current());
    let uptime = embassy_time::Instant::now().as_ticks();
    let mut state = u64::from_le_bytes(mac) ^ systick.rotate_left(40) ^ uptime;
    for chunk in seed.chunks_mut(8) {
        // splitmix64: spreads the few varying bits over every byte.
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        chunk.copy_from_slice(&z.to_le_bytes());
    }
    seed
}

/// Restarts the board (the web page's restart): a system reset. Under QEMU
/// the machine resets and the firmware starts again, with the factory
/// settings (this board keeps nothing).
pub fn restart() {
    cortex_m::peripheral::SCB::sys_reset()
}

/// Logs the stack high-water mark and the Ethernet counters.
pub fn report() {
    let stack = fw_support::stack::usage();
    defmt::info!(
        "stack: {=usize} of {=usize} bytes used (high-water mark)",
        stack.used,
        stack.size
    );
    defmt::info!("lan9118: {}", lan9118::stats());
    defmt::info!("arp-guard: {}", arp_guard::stats());
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    // Location and static message only: formatting arbitrary panic arguments
    // would link core::fmt's float and padding machinery for a path that
    // should never run.
    match info.location() {
        Some(loc) => defmt::error!(
            "panic at {=str}:{=u32}: {=str}",
            loc.file(),
            loc.line(),
            info.message().as_str().unwrap_or("(formatted message)")
        ),
        None => defmt::error!("panic"),
    }
    exit(1)
}
