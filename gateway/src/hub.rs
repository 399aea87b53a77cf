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
//! | a session (`CONFIG_COMMAND` 1), the page | engine, web server | `config_applied` (a `Watch<Config>`): the configuration now in use |
//! | a session (`CONFIG_COMMAND` 1) | storage task | `save_request`, answered by `save_done` ([`SaveOutcome`]) |
//! | anyone (feature `audit`) | storage task | `audit`: records for the audit log ([`Hub::audit`]; changes, refusals are recorded here) |
//!
//! Views: [`Hub::read_registers`] (Modbus) encodes registers from the
//! model; other views call [`Hub::with`] and read the typed values.

use core::cell::RefCell;
use core::net::SocketAddrV4;

use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::signal::Signal;
use embassy_sync::watch::{Receiver, Watch};
use embassy_time::Instant;

#[cfg(feature = "audit")]
use crate::audit::{Event, Interface, Log, Who};
use crate::clock::Clock;
use crate::config::{Config, ConfigResult};
use crate::modbus::{Pending, Registers, Slots};
use crate::plc::{self, ConfigStep};
use crate::registers::{view, AccessError, WriteError};
use crate::state::Model;
use crate::storage::SaveOutcome;

/// The engine's end of [`Hub::config_applied`].
pub(crate) type ConfigReceiver<'a> = Receiver<'a, NoopRawMutex, Config, 2>;

/// Shared state and signals (see the module documentation).
pub struct Hub {
    model: Mutex<NoopRawMutex, RefCell<Model>>,
    /// Wakes the engine: a job was queued.
    pub(crate) job_queued: Signal<NoopRawMutex, ()>,
    /// The configuration in use, each time one is applied (the engine
    /// follows it, the web server closes the connections its allow-list
    /// no longer permits; the model keeps it too, for the views).
    pub(crate) config_applied: Watch<NoopRawMutex, Config, 2>,
    /// Asks the storage task to save the configuration and trigger table.
    pub(crate) save_request: Signal<NoopRawMutex, ()>,
    /// The storage task's answer to `save_request`.
    pub(crate) save_done: Signal<NoopRawMutex, SaveOutcome>,
    /// One configuration command at a time (they wait for their save).
    config_lock: embassy_sync::mutex::Mutex<NoopRawMutex, ()>,
    /// The Modbus sessions: applying a configuration closes those its
    /// allow-list no longer permits.
    pub(crate) modbus_slots: Slots,
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
            modbus_slots: Slots::new(crate::modbus::NAME, &crate::modbus::LIMITS),
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

    /// Reads registers for a PLC (exception 02 if any is unmapped).
    pub fn read_registers(
        &self,
        start: u16,
        out: &mut [u16],
        now: Instant,
    ) -> Result<(), AccessError> {
        self.with(|m| view::read_into(m, start, out, now))
    }

    /// Writes registers for a PLC: stores the values (all or nothing) and
    /// acts on the edges and the heartbeat at once, so that the answer to
    /// the write comes after Busy is visible. A configuration command
    /// written with them is returned: the caller runs it
    /// ([`Self::config_command`]) before answering.
    pub fn write_registers(
        &self,
        start: u16,
        values: &[u16],
        now: Instant,
    ) -> Result<Option<u16>, WriteError> {
        let (queued, command) = self.with(|m| {
            let ev = view::write(m, start, values)?;
            // A trigger text written: in use at once, so recorded at once.
            #[cfg(feature = "audit")]
            if usize::from(start) + values.len()
                > usize::from(crate::registers::map::TRIG_TEXT_BASE)
            {
                self.audit
                    .triggers_changed(&m.triggers.entries, &Who::modbus(None));
            }
            Ok::<_, WriteError>((plc::apply(m, &ev, now), ev.config_command))
        })?;
        if queued {
            self.job_queued.signal(());
        }
        Ok(command)
    }

    /// `CONFIG_COMMAND` `cmd` (1-3): apply (and save, waiting for the
    /// storage task), discard, or defaults.
    pub async fn config_command(&self, cmd: u16) -> Result<(), WriteError> {
        let _one_at_a_time = self.config_lock.lock().await;
        let step = self.with(|m| {
            #[cfg(feature = "audit")]
            let before = m.config.active;
            let step = plc::config_command(m, cmd);
            // The client's address is not known here (the session's):
            // recorded without one.
            #[cfg(feature = "audit")]
            if step == ConfigStep::Save {
                let who = Who::modbus(None);
                self.audit.config_changed(&before, &m.config.active, &who);
                self.audit.triggers_changed(&m.triggers.entries, &who);
            }
            step
        });
        match step {
            ConfigStep::Done => Ok(()),
            ConfigStep::Invalid(_) => Err(WriteError::Value),
            ConfigStep::Locked => Err(WriteError::Protected),
            ConfigStep::Save => {
                // The engine follows the new configuration at once.
                self.announce_config();
                match self.save_locked().await {
                    SaveOutcome::Failed(_) => Err(WriteError::Device),
                    _ => Ok(()),
                }
            }
        }
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
            let _one_at_a_time = self.config_lock.lock().await;
            if self.with(f)? {
                self.announce_config();
            }
            Ok(self.save_locked().await)
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
        let _one_at_a_time = self.config_lock.lock().await;
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
        Ok(self.save_locked().await)
    }

    /// Tells the engine the configuration in use changed, and closes the
    /// Modbus sessions its allow-list no longer permits (before they are
    /// served another request).
    fn announce_config(&self) {
        let config = self.with(|m| m.config.active);
        self.config_applied.sender().send(config);
        let list = config.modbus_allow;
        self.modbus_slots.close_unless(|peer| match peer {
            Some(p) => list.permits(*p.ip()),
            None => list.is_empty(),
        });
    }

    /// Has the storage task save, waits for it and reports the outcome in
    /// `CONFIG_RESULT` and `CONFIG_SAVES`. The caller holds `config_lock`.
    async fn save_locked(&self) -> SaveOutcome {
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

    /// A Modbus client at `peer` connected: admitted if `MODBUS_ALLOW`
    /// permits it (an unknown address only when the list is empty), and
    /// then counted; a refusal is counted in `MODBUS_REFUSED`. Returns the
    /// clients connected now, `None` if refused.
    pub fn admit_modbus(&self, peer: Option<SocketAddrV4>) -> Option<u16> {
        self.with(|m| {
            let list = &m.config.active.modbus_allow;
            let ok = match peer {
                Some(p) => list.permits(*p.ip()),
                None => list.is_empty(),
            };
            if !ok {
                m.access.modbus_refused = m.access.modbus_refused.wrapping_add(1);
                #[cfg(feature = "audit")]
                self.audit.refused(Interface::Modbus, peer.map(|p| *p.ip()));
                return None;
            }
            m.sessions = m.sessions.saturating_add(1);
            if let Some(p) = peer {
                // One slot per session: always room.
                let _ = m.modbus_peers.push(p);
            }
            Some(m.sessions)
        })
    }

    /// `MODBUS_ALLOW` in use permits a client at `peer` (an unknown
    /// address only when the list is empty); nothing is counted.
    pub fn permits_modbus(&self, peer: Option<SocketAddrV4>) -> bool {
        self.with(|m| {
            let list = &m.config.active.modbus_allow;
            match peer {
                Some(p) => list.permits(*p.ip()),
                None => list.is_empty(),
            }
        })
    }

    /// The admitted Modbus client at `peer` left; returns how many are
    /// connected.
    pub fn leave_modbus(&self, peer: Option<SocketAddrV4>) -> u16 {
        self.with(|m| {
            m.sessions = m.sessions.saturating_sub(1);
            if let Some(i) = m.modbus_peers.iter().position(|p| Some(*p) == peer) {
                m.modbus_peers.swap_remove(i);
            }
            m.sessions
        })
    }

    /// A web client at `peer` connected: `true` if `WEB_ALLOW` permits it
    /// (an unknown address only when the list is empty); a refusal is
    /// counted in `WEB_REFUSED`.
    pub fn admit_web(&self, peer: Option<SocketAddrV4>) -> bool {
        self.with(|m| {
            let list = &m.config.active.web_allow;
            let ok = match peer {
                Some(p) => list.permits(*p.ip()),
                None => list.is_empty(),
            };
            if !ok {
                m.access.web_refused = m.access.web_refused.wrapping_add(1);
                #[cfg(feature = "audit")]
                self.audit.refused(Interface::Web, peer.map(|p| *p.ip()));
            }
            ok
        })
    }
}

/// The register map the Modbus sessions serve: the hub's model, read and
/// written at the clock's time.
pub(crate) struct PlcPort<'a, C: Clock> {
    /// The state.
    pub hub: &'a Hub,
    /// The time.
    pub clock: &'a C,
}

impl<C: Clock> Registers for PlcPort<'_, C> {
    fn read(&self, start: u16, out: &mut [u16]) -> Result<(), AccessError> {
        self.hub.read_registers(start, out, self.clock.now())
    }

    fn write(&self, start: u16, values: &[u16]) -> Result<Option<Pending>, WriteError> {
        self.hub
            .write_registers(start, values, self.clock.now())
            .map(|c| c.map(Pending))
    }

    async fn settle(&self, p: Pending) -> Result<(), WriteError> {
        self.hub.config_command(p.0).await
    }

    fn admit(&self, peer: Option<SocketAddrV4>) -> Option<u16> {
        self.hub.admit_modbus(peer)
    }

    fn leave(&self, peer: Option<SocketAddrV4>) -> u16 {
        self.hub.leave_modbus(peer)
    }

    fn permits(&self, peer: Option<SocketAddrV4>) -> bool {
        self.hub.permits_modbus(peer)
    }

    fn slots(&self) -> &Slots {
        &self.hub.modbus_slots
    }

    fn write_refused(&self, _peer: Option<SocketAddrV4>) {
        self.hub.with(|m| {
            m.access.writes_refused = m.access.writes_refused.wrapping_add(1);
        });
    }
}
