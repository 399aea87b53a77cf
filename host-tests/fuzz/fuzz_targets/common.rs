//! Shared by the gateway targets that need a whole gateway: one world per
//! process (thread), built on the first input; what an input changed for
//! good is put back at its end.
//!
//! Building a world runs every part of the gateway once (sockets, tasks,
//! the robot's bring-up): under the sanitizers that costs milliseconds,
//! and every input would cover those same edges again. So a target builds
//! it once, and each input only drives the part it fuzzes; what that input
//! stored (configuration, triggers, accounts, the storage image) is reset
//! at its end by [`reset`]. State that is not stored (channel
//! statuses, web sessions, the robot link) carries on from input to input,
//! as on a gateway that runs: a crash may need what inputs before
//! it left (rerun it alone first; libFuzzer does not record the inputs
//! before it), though the invariants are checked at every input's end.

use std::cell::RefCell;
use std::thread::LocalKey;

use hans_gateway::config::Config;
use hans_gateway::Accounts;
use hans_gateway::state::Triggers;
use hans_gateway::testkit::world::World;

/// Runs `f` on this thread's world in `slot`, built by `make` the first
/// time (the configuration it then runs with is what [`reset`] restores
/// after each input).
pub fn with_world<R>(
    slot: &'static LocalKey<RefCell<Option<(World, Config)>>>,
    make: impl FnOnce() -> World,
    f: impl FnOnce(&mut World) -> R,
) -> R {
    slot.with(|cell| {
        let mut guard = cell.borrow_mut();
        let (w, base) = guard.get_or_insert_with(|| {
            let mut w = make();
            let base = w.model(|m| m.config.active);
            reset(&mut w, &base);
            (w, base)
        });
        let out = f(w);
        // Within the input, so that what it allocated is freed by its end
        // (libFuzzer reruns an input that ends with more allocations than
        // frees, looking for a leak).
        reset(w, base);
        out
    })
}

/// Puts back what an input may have stored: the configuration in use and
/// its edit area, the trigger entries, the web accounts, the stored image
/// (empty, as at the start) and a storage that saves.
pub fn reset(w: &mut World, base: &Config) {
    w.config.storage.data.borrow_mut().clear();
    w.config.storage.fail.set(false);
    w.model(|m| {
        if m.config.active != *base {
            m.config.apply(*base);
        }
        m.config.edit = None;
        m.access.accounts = Accounts::NONE;
        m.triggers.entries = Triggers::default().entries;
    });
    // The robot's request log would grow without end.
    w.robot.log.clear();
    w.settle();
}
