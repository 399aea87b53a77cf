//! The NUCLEO-F767ZI board (STM32F767ZI, Cortex-M7, on-board LAN8742A
//! Ethernet PHY over RMII): everything but `main`, shared as a module by the
//! two firmwares (`src/main.rs`: the core gateway; `src/bin/field_device.rs`:
//! with the web page, DHCP and the DataSheet reader, feature `field-device`),
//! which call [`run`]. A module of each binary rather than a library crate:
//! the same code linked from a library came out ~5 KiB larger (LTO inlines
//! differently), and the core firmware is held to 128 KiB.
//!
//! Board duties only: clocks, Ethernet pins and PHY, MAC address, the
//! random seed, the recovery button, flash storage; then the gateway
//! library runs the rest (and applies the network settings of the stored
//! configuration to the stack).
//!
//! * Clocks: 8 MHz HSE from the ST-LINK's MCO (bypass), PLL to 216 MHz
//!   SYSCLK, 48 MHz on PLLQ for the RNG.
//! * Ethernet (RMII, solder bridges as shipped): REF_CLK PA1, MDIO PA2,
//!   CRS_DV PA7, MDC PC1, RXD0 PC4, RXD1 PC5, TX_EN PG11, TXD0 PG13,
//!   TXD1 PB13; PHY address found automatically.
//! * MAC address: locally administered, derived from the chip's unique ID.
//! * Network: the stored configuration's (`NET_*`, set from the web page or
//!   the registers); [`FACTORY_NET`] until one is stored: static
//!   192.168.1.50/24 via 192.168.1.1 unless built with `HANS_GW_NET` (see
//!   build.rs), e.g. `HANS_GW_NET=10.20.30.2/24,10.20.30.1` or
//!   `HANS_GW_NET=dhcp` (with the `dhcp` or `field-device` feature).
//! * Recovery: the user button B1 (PC13) held at power-up (or reset)
//!   starts with the factory network and access settings (the stored ones
//!   are kept until the next save); the blue LED LD2 (PB7) is lit while
//!   the board runs so.
//! * Random: the STM32 RNG seeds the network stack (TCP sequence numbers,
//!   ports) and the web page's session tokens and password salts.
//! * The gateway configuration (robot address, network, ...) is kept in the
//!   first four sectors of flash bank 2, power-fail safe, written while the
//!   program runs on (see `flash_store`; needs the flash in dual-bank mode).

mod flash_store;
#[cfg(feature = "field-device")]
mod slots;

use defmt_rtt as _;
use embassy_executor::Spawner;
use embassy_net::StackResources;
use embassy_stm32::eth::{Ethernet, GenericPhy, PacketQueue, Sma};
use embassy_stm32::gpio::{Input, Level, Output, Pull, Speed};
use embassy_stm32::peripherals::{ETH, ETH_SMA, RNG};
use embassy_stm32::rng::Rng;
use embassy_stm32::time::Hertz;
use embassy_stm32::{bind_interrupts, eth, rng};
use embassy_time::Timer;
use static_cell::ConstStaticCell;

use hans_gateway::config::NetConfig;
use hans_gateway::storage::flash::FlashStorage;
use hans_gateway::storage::{AuditStore, ConfigStore, Image, Medium, NoStorage, StorageError};
use hans_gateway::Storage;
use hans_gateway::{Config, Options};

bind_interrupts!(struct Irqs {
    ETH => eth::InterruptHandler;
    RNG => rng::InterruptHandler<RNG>;
});

include!(concat!(env!("OUT_DIR"), "/factory_net.rs"));

/// The Ethernet driver behind the guard that bounds the ARP the stack
/// learns from hosts it does not talk to and the pings it answers (an ARP
/// flood must not evict the PLC's and the robot's neighbor entries; see
/// `arp-guard`), as on the QEMU board.
type Device = arp_guard::Guarded<Ethernet<'static, ETH, GenericPhy<Sma<'static, ETH_SMA>>>>;

/// Sockets: the gateway's (Modbus sessions, robot link, and with
/// `field-device` the DataSheet, the web page and DHCP); the board has none
/// of its own.
const SOCKETS: usize = hans_gateway::board::SOCKETS;

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

/// Starts the board and runs the gateway; never returns. `main` of both
/// firmwares.
pub async fn run(spawner: Spawner) -> ! {
    let p = embassy_stm32::init(clocks());
    defmt::info!("nucleo-f767zi: clocks up");

    // B1 connects PC13 to 3.3 V when pressed (pulled down otherwise).
    let button = Input::new(p.PC13, Pull::Down);
    Timer::after_millis(10).await;
    let recovery = button.is_high();
    drop(button);
    // Lit for the whole run (the binding lives as long as this future).
    let _recovery_led = recovery.then(|| Output::new(p.PB7, Level::High, Speed::Low));
    if recovery {
        defmt::warn!("B1 held at power-up: recovery start (factory network and access settings)");
    }

    let mut rng = Rng::new(p.RNG, Irqs);
    let mut seed = [0u8; 32];
    rng.fill_bytes(&mut seed);
    let mut net_seed = [0u8; 8];
    rng.fill_bytes(&mut net_seed);
    let net_seed = u64::from_le_bytes(net_seed);
    // The web page's first administrator is created with a one-time code
    // printed in the probe's log (RTT): only someone with a debug probe on
    // the board reads it. A new one each start; the core has no page.
    let mut code = [0u8; hans_gateway::SETUP_CODE_LEN];
    rng.fill_bytes(&mut code);
    let setup_code = cfg!(feature = "field-device").then(|| {
        let c = hans_gateway::SetupCode::from_random(code);
        defmt::info!(
            "setup code for the first administrator: {=str}",
            c.to_text().as_str()
        );
        c
    });

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
    let device = Ethernet::new(
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
    let device: Device = arp_guard::Guarded::new(device);

    // No address yet: the gateway applies the stored (or factory) network
    // settings once it has loaded the configuration.
    static RESOURCES: ConstStaticCell<StackResources<SOCKETS>> =
        ConstStaticCell::new(StackResources::new());
    let (stack, runner) = embassy_net::new(
        device,
        embassy_net::Config::default(),
        RESOURCES.take(),
        net_seed,
    );
    match net_task(runner) {
        Ok(token) => spawner.spawn(token),
        Err(_) => defmt::panic!("net task already spawned"),
    }

    let dual_bank = flash_store::is_dual_bank();
    let (config_flash, _state_flash, _dfu_flash) = flash_store::split(p.FLASH);
    let storage = if dual_bank {
        let range = 0..flash_store::SECTORS * flash_store::SECTOR_SIZE;
        match FlashStorage::new(config_flash, range) {
            Ok(f) => BoardStorage::Flash(f),
            Err(_) => defmt::panic!("the configuration range is not whole sectors"),
        }
    } else {
        defmt::error!(
            "flash in single-bank mode: the configuration is NOT saved (CONFIG_RESULT 3); set nDBANK = 0 (firmware/README.md)"
        );
        BoardStorage::Ram(NoStorage)
    };
    // The field device updates itself (signed A/B updates): the slots of
    // the layout, where the bootloader finds them. In single-bank mode the
    // bootloader starts the firmware but swaps nothing: no updates then.
    #[cfg(feature = "field-device")]
    let mut storage = hans_gateway::WithSlots {
        storage,
        slots: slots::BoardSlots(dual_bank.then(|| {
            hans_gateway::update::BootSlots::new(flash_store::ActiveSlot, _dfu_flash, _state_flash)
        })),
    };
    #[cfg(not(feature = "field-device"))]
    let mut storage = storage;
    let options = Options {
        // The robot address and the other settings come from flash
        // (written from the page or the configuration registers); until
        // then the link stays down (robot address 0.0.0.0).
        defaults: Config {
            net: FACTORY_NET,
            ..Config::DEFAULT
        },
        recovery,
        network_managed: true,
        seed,
        restart: Some(restart),
        setup_code,
        // Images signed with the key the bootloader trusts, for this board.
        #[cfg(feature = "field-device")]
        update_key: Some(fw_keys::TRUSTED),
        #[cfg(feature = "field-device")]
        board: hans_gateway::update::layout::NUCLEO_F767ZI.board,
        ..Options::default()
    };
    run_gateway(stack, &mut storage, options).await
}

#[embassy_executor::task]
async fn net_task(mut runner: embassy_net::Runner<'static, Device>) -> ! {
    runner.run().await
}

async fn run_gateway<S: Storage>(
    stack: embassy_net::Stack<'static>,
    storage: &mut S,
    options: Options,
) -> ! {
    // By reference: the storage (3 KiB of buffer) stays where `run` built
    // it, instead of a copy in every future it is passed through.
    match hans_gateway::board::run(stack, storage, options).await {}
}

/// The web page's restart (and nothing else): a system reset.
fn restart() {
    cortex_m::peripheral::SCB::sys_reset()
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

impl ConfigStore for BoardStorage {
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

    fn medium(&self) -> Medium {
        match self {
            BoardStorage::Flash(f) => f.medium(),
            BoardStorage::Ram(r) => r.medium(),
        }
    }
}

/// The audit records: the flash storage has no ring of its own on this
/// board (no sector is planned for it), so they stay in the log's RAM.
impl AuditStore for BoardStorage {
    async fn read(&mut self, each: &mut dyn FnMut(&[u8])) -> Result<(), StorageError> {
        match self {
            BoardStorage::Flash(f) => f.read(each).await,
            BoardStorage::Ram(r) => r.read(each).await,
        }
    }

    async fn append(&mut self, record: &[u8]) -> Result<(), StorageError> {
        match self {
            BoardStorage::Flash(f) => f.append(record).await,
            BoardStorage::Ram(r) => r.append(record).await,
        }
    }

    fn persistent(&self) -> bool {
        match self {
            BoardStorage::Flash(f) => f.persistent(),
            BoardStorage::Ram(r) => r.persistent(),
        }
    }
}

/// A panic (a bug: the gateway's library code has none on any input) is
/// logged and resets the board, so that a field device comes back on its own.
///
/// Where it happened is logged only with the `panic-location` feature: a
/// handler that reads its `PanicInfo` at all keeps every panic site's
/// location and message arguments (and with them core's number formatting)
/// in the image, 19 KiB of flash measured on the core firmware, which is
/// more than its budget has left. Build with the feature when chasing a
/// panic with a probe attached.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    #[cfg(feature = "panic-location")]
    match info.location() {
        Some(loc) => defmt::error!(
            "panic at {=str}:{=u32}: {=str}",
            loc.file(),
            loc.line(),
            info.message().as_str().unwrap_or("(formatted message)")
        ),
        None => defmt::error!("panic"),
    }
    #[cfg(not(feature = "panic-location"))]
    {
        let _ = info;
        defmt::error!("panic: resetting (build with the `panic-location` feature to see where)");
    }
    cortex_m::peripheral::SCB::sys_reset()
}
