//! The gateway on an ST NUCLEO-F767ZI (STM32F767ZI, Cortex-M7, on-board
//! LAN8742A Ethernet PHY over RMII).
//!
//! Board duties only: clocks, Ethernet pins and PHY, MAC address, IP setting,
//! flash storage; then the gateway library runs the rest.
//!
//! * Clocks: 8 MHz HSE from the ST-LINK's MCO (bypass), PLL to 216 MHz
//!   SYSCLK, 48 MHz on PLLQ for the RNG.
//! * Ethernet (RMII, solder bridges as shipped): REF_CLK PA1, MDIO PA2,
//!   CRS_DV PA7, MDC PC1, RXD0 PC4, RXD1 PC5, TX_EN PG11, TXD0 PG13,
//!   TXD1 PB13; PHY address found automatically.
//! * MAC address: locally administered, derived from the chip's unique ID.
//! * IP: static 192.168.1.50/24 via 192.168.1.1 unless built with
//!   `HANS_GW_NET` (see build.rs), e.g. `HANS_GW_NET=10.20.30.2/24,10.20.30.1`
//!   or `HANS_GW_NET=dhcp` with `--features dhcp`.
//! * The gateway configuration (robot address, ...) is set by the PLC
//!   through the configuration registers and kept in the first four
//!   sectors of flash bank 2, power-fail safe, written while the program
//!   runs on (see `flash_store`; needs the flash in dual-bank mode).
#![no_std]
#![no_main]

mod flash_store;

use defmt_rtt as _;
use embassy_executor::Spawner;
use embassy_net::{Ipv4Address, Ipv4Cidr, StackResources, StaticConfigV4};
use embassy_stm32::eth::{Ethernet, GenericPhy, PacketQueue, Sma};
use embassy_stm32::peripherals::{ETH, ETH_SMA, RNG};
use embassy_stm32::rng::Rng;
use embassy_stm32::time::Hertz;
use embassy_stm32::{bind_interrupts, eth, rng};
use static_cell::ConstStaticCell;

use hans_gateway::storage::flash::FlashStorage;
use hans_gateway::storage::{Image, NoStorage, Storage, StorageError};

bind_interrupts!(struct Irqs {
    ETH => eth::InterruptHandler;
    RNG => rng::InterruptHandler<RNG>;
});

/// How the board gets its IP address.
#[allow(dead_code)] // one variant is chosen at build time
enum NetSetting {
    /// DHCPv4.
    Dhcp,
    /// A fixed address.
    Static {
        address: Ipv4Address,
        prefix: u8,
        gateway: Option<Ipv4Address>,
    },
}

include!(concat!(env!("OUT_DIR"), "/net_setting.rs"));

type Device = Ethernet<'static, ETH, GenericPhy<Sma<'static, ETH_SMA>>>;

/// Sockets: the gateway's Modbus sessions and robot link, plus DHCP.
const SOCKETS: usize = hans_gateway::board::SOCKETS + 1;

fn clocks() -> embassy_stm32::Config {
    use embassy_stm32::rcc::*;
    let mut config = embassy_stm32::Config::default();
    config.rcc.hse = Some(Hse {
        freq: Hertz(8_000_000),
        mode: HseMode::Bypass,
    });
    config.rcc.pll_src = PllSource::HSE;
    config.rcc.pll = Some(Pll {
        prediv: PllPreDiv::DIV4,   // 2 MHz
        mul: PllMul::MUL216,       // 432 MHz VCO
        divp: Some(PllPDiv::DIV2), // 216 MHz SYSCLK
        divq: Some(PllQDiv::DIV9), // 48 MHz for the RNG
        divr: None,
    });
    config.rcc.ahb_pre = AHBPrescaler::DIV1;
    config.rcc.apb1_pre = APBPrescaler::DIV4; // 54 MHz
    config.rcc.apb2_pre = APBPrescaler::DIV2; // 108 MHz
    config.rcc.sys = Sysclk::PLL1_P;
    config
}

#[embassy_executor::main]
async fn main(spawner: Spawner) {
    let p = embassy_stm32::init(clocks());
    defmt::info!("nucleo-f767zi: clocks up");

    let mut rng = Rng::new(p.RNG, Irqs);
    let mut seed = [0u8; 8];
    rng.fill_bytes(&mut seed);
    let seed = u64::from_le_bytes(seed);

    // Locally administered unicast address from the 96-bit unique ID.
    let uid = embassy_stm32::uid::uid();
    let mac = [
        0x02,
        uid[0] ^ uid[6],
        uid[1] ^ uid[7],
        uid[2] ^ uid[8],
        uid[3] ^ uid[9],
        uid[4] ^ uid[10] ^ uid[5] ^ uid[11],
    ];

    // Const-initialised statics: built in place, never copied through the
    // stack (the packet queue is 12 KiB, StackResources about as much).
    static PACKETS: ConstStaticCell<PacketQueue<4, 4>> = ConstStaticCell::new(PacketQueue::new());
    let device: Device = Ethernet::new(
        PACKETS.take(),
        p.ETH,
        Irqs,
        p.PA1,
        p.PA7,
        p.PC4,
        p.PC5,
        p.PG13,
        p.PB13,
        p.PG11,
        mac,
        p.ETH_SMA,
        p.PA2,
        p.PC1,
    );

    let net_config = match NET {
        #[cfg(feature = "dhcp")]
        NetSetting::Dhcp => embassy_net::Config::dhcpv4(Default::default()),
        #[cfg(not(feature = "dhcp"))]
        NetSetting::Dhcp => defmt::unreachable!("build.rs requires the dhcp feature for DHCP"),
        NetSetting::Static {
            address,
            prefix,
            gateway,
        } => embassy_net::Config::ipv4_static(StaticConfigV4 {
            address: Ipv4Cidr::new(address, prefix),
            gateway,
            dns_servers: heapless::Vec::new(),
        }),
    };
    static RESOURCES: ConstStaticCell<StackResources<SOCKETS>> =
        ConstStaticCell::new(StackResources::new());
    let (stack, runner) = embassy_net::new(device, net_config, RESOURCES.take(), seed);
    match net_task(runner) {
        Ok(token) => spawner.spawn(token),
        Err(_) => defmt::panic!("net task already spawned"),
    }

    let mut storage = if flash_store::is_dual_bank() {
        let range = 0..flash_store::SECTORS * flash_store::SECTOR_SIZE;
        match FlashStorage::new(flash_store::Bank2::new(p.FLASH), range) {
            Ok(f) => BoardStorage::Flash(f),
            Err(_) => defmt::panic!("the configuration range is not whole sectors"),
        }
    } else {
        defmt::error!(
            "flash in single-bank mode: the configuration is NOT saved (CONFIG_RESULT 3); set nDBANK = 0 (firmware/README.md)"
        );
        BoardStorage::Ram(NoStorage)
    };
    stack.wait_config_up().await;
    if let Some(config) = stack.config_v4() {
        defmt::info!("network up: {}", config.address);
    }
    run_gateway(stack, &mut storage).await
}

#[embassy_executor::task]
async fn net_task(mut runner: embassy_net::Runner<'static, Device>) -> ! {
    runner.run().await
}

async fn run_gateway(stack: embassy_net::Stack<'static>, storage: &mut BoardStorage) -> ! {
    // By reference: the storage (3 KiB of buffer) stays where main built it,
    // instead of a copy in every future it is passed through.
    // The robot address and the other settings come from flash (written by
    // the PLC through the configuration registers); until then the link
    // stays down (robot address 0.0.0.0).
    let options = hans_gateway::Options::default();
    match hans_gateway::board::run(stack, storage, options).await {}
}

/// The configuration's storage: bank 2 of the flash, or none when the flash
/// is in single-bank mode (erasing would stall the board for seconds).
// One value of this lives in a static for the program's life, so the empty
// variant's unused bytes cost nothing that boxing (no heap here) would save.
#[allow(clippy::large_enum_variant)]
enum BoardStorage {
    Flash(FlashStorage<flash_store::Bank2>),
    Ram(NoStorage),
}

impl Storage for BoardStorage {
    async fn load(&mut self) -> Result<&[u8], StorageError> {
        match self {
            BoardStorage::Flash(f) => f.load().await,
            BoardStorage::Ram(r) => r.load().await,
        }
    }

    async fn save(&mut self, image: &dyn Image) -> Result<(), StorageError> {
        match self {
            BoardStorage::Flash(f) => f.save(image).await,
            BoardStorage::Ram(r) => r.save(image).await,
        }
    }

    fn is_persistent(&self) -> bool {
        matches!(self, BoardStorage::Flash(_))
    }
}

/// A panic (a bug: the gateway's library code has none on any input) logs
/// where it happened and resets the board, so that a field device comes
/// back on its own. The message's arguments are not formatted: that would
/// link core's formatting machinery (some KiB) for a path that should
/// never run.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    match info.location() {
        Some(loc) => defmt::error!(
            "panic at {=str}:{=u32}: {=str}",
            loc.file(),
            loc.line(),
            info.message().as_str().unwrap_or("(formatted message)")
        ),
        None => defmt::error!("panic"),
    }
    cortex_m::peripheral::SCB::sys_reset()
}
