//! [`embassy-time`] driver on the Cortex-M SysTick timer.
//!
//! SysTick is the one timer every Cortex-M has, which makes it the time base
//! for boards whose vendor timers have no embassy driver (the MPS2 under QEMU).
//! It is a 24-bit down-counter, too short to run tickless for long, so this
//! driver takes a periodic interrupt at [`TICK_HZ`] (1 kHz) and extends the
//! count to 64 bits in software. Each tick compares the count with the
//! earliest deadline of the timer queue and wakes expired timers; between
//! deadlines a tick is an increment and a compare.
//!
//! The timer queue is embassy's integrated queue (timers live in the tasks),
//! behind a critical section, so any number of timers cost no static memory
//! here.
//!
//! Call [`init`] once, before the executor starts. This crate defines the
//! `SysTick` exception handler itself.
//!
//! [`embassy-time`]: https://docs.rs/embassy-time
#![no_std]
#![deny(missing_docs)]

use core::cell::{Cell, RefCell};
use core::task::Waker;

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use cortex_m_rt::exception;
use critical_section::{CriticalSection, Mutex};
use embassy_time_driver::Driver;
use embassy_time_queue_utils::Queue;

/// Tick rate of the time base, as configured for `embassy-time`.
pub const TICK_HZ: u32 = embassy_time_driver::TICK_HZ as u32;

/// Why [`init`] refused the clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InitError {
    /// The core clock divided by [`TICK_HZ`] does not fit SysTick's 24-bit
    /// reload register (or is zero).
    ClockOutOfRange(u32),
}

struct SysTickDriver {
    /// Ticks since `init`.
    ticks: Mutex<Cell<u64>>,
    /// Earliest deadline in the queue (`u64::MAX`: none).
    alarm: Mutex<Cell<u64>>,
    queue: Mutex<RefCell<Queue>>,
}

embassy_time_driver::time_driver_impl!(static DRIVER: SysTickDriver = SysTickDriver {
    ticks: Mutex::new(Cell::new(0)),
    alarm: Mutex::new(Cell::new(u64::MAX)),
    queue: Mutex::new(RefCell::new(Queue::new())),
});

impl SysTickDriver {
    /// Dequeues expired timers and records the next deadline.
    fn service(&self, cs: CriticalSection<'_>) {
        let now = self.ticks.borrow(cs).get();
        let next = self.queue.borrow(cs).borrow_mut().next_expiration(now);
        self.alarm.borrow(cs).set(next);
    }

    fn tick(&self) {
        critical_section::with(|cs| {
            let ticks = self.ticks.borrow(cs);
            let now = ticks.get() + 1;
            ticks.set(now);
            if now >= self.alarm.borrow(cs).get() {
                self.service(cs);
            }
        });
    }
}

impl Driver for SysTickDriver {
    fn now(&self) -> u64 {
        critical_section::with(|cs| self.ticks.borrow(cs).get())
    }

    fn schedule_wake(&self, at: u64, waker: &Waker) {
        critical_section::with(|cs| {
            let changed = self.queue.borrow(cs).borrow_mut().schedule_wake(at, waker);
            if changed {
                // Deadlines already due are woken here rather than on the next
                // tick; the next one is recorded for the tick handler.
                self.service(cs);
            }
        });
    }
}

/// Starts SysTick from the processor clock `core_hz` with an interrupt at
/// [`TICK_HZ`].
///
/// Until this is called, time stands still at zero (embassy-time's contract:
/// `now` must never fail).
pub fn init(mut syst: SYST, core_hz: u32) -> Result<(), InitError> {
    let reload = core_hz / TICK_HZ;
    if reload == 0 || reload > 0x0100_0000 {
        return Err(InitError::ClockOutOfRange(core_hz));
    }
    syst.disable_counter();
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(reload - 1);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
    Ok(())
}

#[exception]
fn SysTick() {
    DRIVER.tick();
}
