//! The executor's idle loop for this board: sleep with WFI.
//!
//! embassy's Cortex-M executor sleeps with WFE and wakes itself with SEV.
//! QEMU implements WFE as a no-op on a single core, so under QEMU that loop
//! spins and burns a host CPU at 100 %. WFI does halt QEMU's CPU until an
//! interrupt, so this board polls the raw executor itself:
//!
//! * a task woken from thread mode sets [`PENDED`] (embassy calls
//!   `__pender`), and the loop polls again without sleeping;
//! * otherwise the loop checks [`PENDED`] and executes WFI with interrupts
//!   masked (PRIMASK), so an interrupt that arrives between the check and the
//!   WFI still ends the WFI; its handler runs as soon as the mask is lifted.
//!
//! Every wake-up here comes from an interrupt (SysTick, Ethernet) or from a
//! task, so nothing is missed; on hardware this costs the same as WFE.

use core::sync::atomic::{AtomicBool, Ordering};

use embassy_executor::{raw, SpawnError, SpawnToken, Spawner};
use static_cell::StaticCell;

use crate::{fail, BoardError};

/// Set when a task was woken since the last check.
static PENDED: AtomicBool = AtomicBool::new(false);

/// Called by embassy whenever a task of this executor is woken, from thread
/// or interrupt context.
#[export_name = "__pender"]
fn pender(_context: *mut ()) {
    PENDED.store(true, Ordering::Release);
}

/// Starts the executor with its first task and never returns. `start` is
/// that task's function (`#[embassy_executor::task] async fn start(spawner:
/// Spawner)`), which spawns the others; if its pool is exhausted the board
/// [`fail`]s with [`BoardError::Spawn`].
pub fn run<S>(start: impl FnOnce(Spawner) -> Result<SpawnToken<S>, SpawnError>) -> ! {
    static EXECUTOR: StaticCell<raw::Executor> = StaticCell::new();
    let executor: &'static raw::Executor = EXECUTOR.init(raw::Executor::new(core::ptr::null_mut()));
    let spawner = executor.spawner();
    match start(spawner) {
        Ok(task) => spawner.spawn(task),
        Err(_) => fail(BoardError::Spawn),
    }
    loop {
        // SAFETY: `poll` is only ever called from this loop, in thread mode,
        // never re-entrantly.
        unsafe { executor.poll() };
        cortex_m::interrupt::free(|_| {
            if !PENDED.swap(false, Ordering::AcqRel) {
                cortex_m::asm::wfi();
            }
        });
    }
}
