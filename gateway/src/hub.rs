//! The hub: the typed state every task reads, and the signals they send
//! each other.
//!
//! The gateway is a handful of futures on one executor (one embassy task on
//! a board, one thread on Linux): the engine (owner of the robot link), the
//! Modbus sessions, the DataSheet reader and the storage task. They share
//! the [`Model`] behind a blocking mutex that is never held across an
//! await, and talk through typed signals:
//!
//! | from | to | what |
//! |---|---|---|
//! | a session (a PLC write) | engine | `job_queued`: a job was queued |
//! | a session (`CONFIG_COMMAND` 1), the page | engine, web server, Modbus server | `config_applied` (a `Watch<Config>`): the configuration now in use |
//! | a session (`CONFIG_COMMAND` 1), the page | storage task | `save_request`, answered by `save_done` ([`SaveOutcome`]) |
//! | anyone (feature `audit`) | storage task | `audit`: records for the audit log (`Hub::audit`; changes, refusals are recorded here) |
//!
//! The hub is plumbing: it knows no register, no PLC rule and no listener.
//! The views and the rules that change the state live with their owners
//! (`plc` for a PLC's writes, `web` for the page's) and call [`Hub::with`].

use core::cell::RefCell;

use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::mutex::MutexGuard;
use embassy_sync::signal::Signal;
use embassy_sync::watch::{Receiver, Watch};

#[cfg(feature = "audit")]
use crate::audit::{Event, Interface, Log, Who};
use crate::config::{Config, ConfigResult};
use crate::state::Model;
use crate::storage::SaveOutcome;

/// The engine's end of [`Hub::config_applied`].
pub(crate) type ConfigReceiver<'a> = Receiver<'a, NoopRawMutex, Config, FOLLOWERS>;

/// Who follows [`Hub::config_applied`]: the engine, the web server's, the
/// Modbus server's and the EtherNet/IP adapter's allow-list wardens.
const FOLLOWERS: usize = 4;

/// Shared state and signals (see the module documentation).
pub struct Hub {
    model: Mutex<NoopRawMutex, RefCell<Model>>,
    /// Wakes the engine: a job was queued.
    pub(crate) job_queued: Signal<NoopRawMutex, ()>,
    /// The configuration in use, each time one is applied (the engine
    /// follows it, the web server closes the connections its allow-list
    /// no longer permits; the model keeps it too, for the views).
    pub(crate) config_applied: Watch<NoopRawMutex, Config, FOLLOWERS>,
    /// Asks the storage task to save the configuration and trigger table.
    pub(crate) save_request: Signal<NoopRawMutex, ()>,
    /// The storage task's answer to `save_request`.
    pub(crate) save_done: Signal<NoopRawMutex, SaveOutcome>,
    /// One configuration command at a time (they wait for their save).
    config_lock: embassy_sync::mutex::Mutex<NoopRawMutex, ()>,
    /// The audit log (the storage task keeps its records).
    #[cfg(feature = "audit")]
    pub(crate) audit: Log,
    /// The MQTT client's connection and counters (the status page shows
    /// them).
    #[cfg(feature = "mqtt")]
    pub mqtt: crate::state::telemetry::Status,
    /// Raised by every [`Hub::with`] (the state may have changed): wakes
    /// the MQTT client, which publishes by exception, so that a change goes
    /// out at once instead of at its next look (it reads with
    /// [`Hub::peek`], which raises nothing).
    #[cfg(feature = "mqtt")]
    pub(crate) changed: Signal<NoopRawMutex, ()>,
    /// The firmware's status, and the mailbox through which an upload
    /// reaches the storage task (feature `update`).
    #[cfg(feature = "update")]
    pub updates: crate::update::Updates,
}

impl Hub {
    /// A hub around `model`.
    pub fn new(model: Model) -> Self {
        Hub {
            model: Mutex::new(RefCell::new(model)),
            job_queued: Signal::new(),
            config_applied: Watch::new(),
            save_request: Signal::new(),
            save_done: Signal::new(),
            config_lock: embassy_sync::mutex::Mutex::new(()),
            #[cfg(feature = "audit")]
            audit: Log::new(),
            #[cfg(feature = "mqtt")]
            mqtt: crate::state::telemetry::Status::new(),
            #[cfg(feature = "mqtt")]
            changed: Signal::new(),
            #[cfg(feature = "update")]
            updates: crate::update::Updates::new(),
        }
    }

    /// Records `event` in the audit log (the accounts' and the page's
    /// events; see `crate::audit`): at once, never blocking.
    #[cfg(feature = "audit")]
    pub(crate) fn audit(&self, event: Event<'_>) {
        self.audit.record(event)
    }

    /// A connection to the robot link's listen port from another address
    /// than the controller's was refused (counted per period in the audit
    /// log, as the allow-lists' refusals are).
    #[cfg(feature = "audit")]
    pub(crate) fn audit_refused_robot(&self, peer: Option<core::net::Ipv4Addr>) {
        self.audit.refused(Interface::Robot, peer);
    }

    /// Runs `f` on the state. Never call it from inside `f`.
    pub fn with<R>(&self, f: impl FnOnce(&mut Model) -> R) -> R {
        let r = self.model.lock(|m| f(&mut m.borrow_mut()));
        #[cfg(feature = "mqtt")]
        self.changed.signal(());
        r
    }

    /// Reads the state without telling anyone it may have changed (the
    /// MQTT client's own reads). Never call it from inside `f`.
    pub fn peek<R>(&self, f: impl FnOnce(&Model) -> R) -> R {
        self.model.lock(|m| f(&m.borrow()))
    }

    /// Waits for the turn of one change of the stored state (a
    /// configuration command, a change from the page): held until its
    /// save is answered.
    pub(crate) async fn one_change(&self) -> MutexGuard<'_, NoopRawMutex, ()> {
        self.config_lock.lock().await
    }

    /// Changes the stored state with `f` (the web page: settings, trigger
    /// entries, the password) and saves it as `CONFIG_COMMAND` 1 does,
    /// one change or configuration command at a time. `f` returns whether
    /// the configuration in use changed (the engine is woken), or why
    /// nothing was changed (then nothing is saved).
    pub async fn change<E>(
        &self,
        f: impl FnOnce(&mut Model) -> Result<bool, E>,
    ) -> Result<SaveOutcome, E> {
        #[cfg(feature = "audit")]
        return self.change_by(Who::web(b"", None), f).await;
        #[cfg(not(feature = "audit"))]
        {
            let _one_at_a_time = self.one_change().await;
            if self.with(f)? {
                self.announce_config();
            }
            Ok(self.save().await)
        }
    }

    /// [`Self::change`] by `who` (the page's account and client): each
    /// setting and trigger entry it changes is recorded in the audit log.
    #[cfg(feature = "audit")]
    pub(crate) async fn change_by<E>(
        &self,
        who: Who<'_>,
        f: impl FnOnce(&mut Model) -> Result<bool, E>,
    ) -> Result<SaveOutcome, E> {
        let _one_at_a_time = self.one_change().await;
        let changed = self.with(|m| {
            let before = m.config.active;
            let changed = f(m)?;
            self.audit.config_changed(&before, &m.config.active, &who);
            self.audit.triggers_changed(&m.triggers.entries, &who);
            Ok(changed)
        })?;
        if changed {
            self.announce_config();
        }
        Ok(self.save().await)
    }

    /// Tells its followers the configuration in use changed (the engine
    /// follows it, the servers close the connections its allow-lists no
    /// longer permit).
    pub(crate) fn announce_config(&self) {
        let config = self.with(|m| m.config.active);
        self.config_applied.sender().send(config);
    }

    /// Has the storage task save, waits for it and reports the outcome in
    /// `CONFIG_RESULT` and `CONFIG_SAVES`. The caller holds its turn
    /// ([`Self::one_change`]).
    pub(crate) async fn save(&self) -> SaveOutcome {
        self.save_done.reset();
        self.save_request.signal(());
        let outcome = self.save_done.wait().await;
        self.with(|m| {
            let c = &mut m.config;
            c.result = match outcome {
                SaveOutcome::Saved => {
                    c.saves = c.saves.wrapping_add(1);
                    info!("config: saved");
                    ConfigResult::Ok
                }
                SaveOutcome::NotPersistent => {
                    warn!("config: applied, not saved: no persistent storage (lost at restart)");
                    ConfigResult::NotSaved
                }
                SaveOutcome::Failed(_) => {
                    warn!("config: applied, but saving failed");
                    ConfigResult::SaveFailed
                }
            };
        });
        outcome
    }
}
