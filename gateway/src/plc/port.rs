//! The PLC's port: the register map the Modbus sessions serve, bound to the
//! hub. A read encodes the registers from the state (`registers::view`); a
//! write is decoded into typed events and acted on at once (the rules of
//! this module's parent), so that the answer to the write comes after Busy
//! is visible; a configuration command written with it is run before the
//! write is answered. The port also counts the sessions and refusals the
//! status shows and closes the sessions a new allow-list refuses.

use core::convert::Infallible;
use core::net::SocketAddrV4;

use crate::admission::Guard;
#[cfg(feature = "audit")]
use crate::audit::{Interface, Who};
use crate::clock::Clock;
use crate::hub::Hub;
use crate::modbus::{Pending, Registers, Slots};
use crate::registers::{view, AccessError, WriteError};
use crate::storage::SaveOutcome;

use super::ConfigStep;

/// The register map the Modbus sessions serve: the hub's state, read and
/// written at the clock's time, and the sessions' table.
pub(crate) struct PlcPort<'a, C: Clock> {
    /// The state.
    pub hub: &'a Hub,
    /// The time.
    pub clock: &'a C,
    /// The Modbus sessions' table.
    pub slots: &'a Slots,
}

impl<C: Clock> PlcPort<'_, C> {
    /// Writes registers for the PLC at `peer`: stores the values (all or
    /// nothing) and acts on the edges and the heartbeat at once. A
    /// configuration command written with them is returned: the caller
    /// runs it ([`Self::config_command`]) before answering.
    fn write_registers(
        &self,
        start: u16,
        values: &[u16],
        peer: Option<SocketAddrV4>,
    ) -> Result<Option<u16>, WriteError> {
        let now = self.clock.now();
        #[cfg(not(feature = "audit"))]
        let _ = peer;
        let (queued, command) = self.hub.with(|m| {
            if !super::modbus_may_write(m, start, values.len()) {
                m.access.writes_refused = m.access.writes_refused.wrapping_add(1);
                warn!(
                    "modbus: write to {} refused: an EtherNet/IP PLC owns the command inputs",
                    start
                );
                return Err(WriteError::Protected);
            }
            let ev = view::write(m, start, values)?;
            // A trigger text written: in use at once, so recorded at once.
            #[cfg(feature = "audit")]
            if ev.triggers_changed {
                self.hub.audit.modbus_triggers_changed(
                    &m.triggers.entries,
                    &Who::modbus(peer.map(|p| *p.ip())),
                );
            }
            let by = crate::state::owner::Commander::Modbus;
            Ok::<_, WriteError>((super::apply(m, &ev, now, by), ev.config_command))
        })?;
        if queued {
            self.hub.job_queued.signal(());
        }
        Ok(command)
    }

    /// `CONFIG_COMMAND` `cmd` (1-3) of the client at `peer`: apply (and
    /// save, waiting for the storage task), discard, or defaults. One
    /// change at a time. What it changes, or the protected setting it was
    /// refused, goes into the audit log with the client's address.
    async fn config_command(&self, cmd: u16, peer: Option<SocketAddrV4>) -> Result<(), WriteError> {
        let hub = self.hub;
        let _one_at_a_time = hub.one_change().await;
        #[cfg(not(feature = "audit"))]
        let _ = peer;
        let step = hub.with(|m| {
            #[cfg(feature = "audit")]
            let before = m.config.active;
            let step = super::config_command(m, cmd);
            #[cfg(feature = "audit")]
            {
                let who = Who::modbus(peer.map(|p| *p.ip()));
                match step {
                    ConfigStep::Save => hub.audit.modbus_config_changed(
                        &before,
                        &m.config.active,
                        &m.triggers.entries,
                        &who,
                    ),
                    ConfigStep::Locked(s) => hub.audit.config_refused(s, &who),
                    _ => {}
                }
            }
            step
        });
        match step {
            ConfigStep::Done => Ok(()),
            ConfigStep::Invalid(_) => Err(WriteError::Value),
            ConfigStep::Locked(_) => {
                hub.with(|m| {
                    m.access.writes_refused = m.access.writes_refused.wrapping_add(1);
                });
                Err(WriteError::Protected)
            }
            ConfigStep::Save => {
                // The engine follows the new configuration at once.
                hub.announce_config();
                match hub.save().await {
                    SaveOutcome::Failed(_) => Err(WriteError::Device),
                    _ => Ok(()),
                }
            }
        }
    }
}

impl<C: Clock> Registers for PlcPort<'_, C> {
    fn read(&self, start: u16, out: &mut [u16]) -> Result<(), AccessError> {
        let now = self.clock.now();
        self.hub.with(|m| view::read_into(m, start, out, now))
    }

    fn write(
        &self,
        start: u16,
        values: &[u16],
        peer: Option<SocketAddrV4>,
    ) -> Result<Option<Pending>, WriteError> {
        self.write_registers(start, values, peer)
            .map(|c| c.map(Pending))
    }

    async fn settle(&self, p: Pending, peer: Option<SocketAddrV4>) -> Result<(), WriteError> {
        self.config_command(p.0, peer).await
    }

    /// Admitted if `MODBUS_ALLOW` permits the client, and then counted; a
    /// refusal is counted in `MODBUS_REFUSED` (and the audit log).
    fn admit(&self, peer: Option<SocketAddrV4>) -> Option<u16> {
        self.hub.with(|m| {
            if !m.config.active.modbus_allow.admits(peer) {
                m.access.modbus_refused = m.access.modbus_refused.wrapping_add(1);
                #[cfg(feature = "audit")]
                self.hub
                    .audit
                    .refused(Interface::Modbus, peer.map(|p| *p.ip()));
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

    fn leave(&self, peer: Option<SocketAddrV4>) -> u16 {
        self.hub.with(|m| {
            m.sessions = m.sessions.saturating_sub(1);
            if let Some(i) = m.modbus_peers.iter().position(|p| Some(*p) == peer) {
                m.modbus_peers.swap_remove(i);
            }
            m.sessions
        })
    }

    fn permits(&self, peer: Option<SocketAddrV4>) -> bool {
        self.hub.peek(|m| m.config.active.modbus_allow.admits(peer))
    }

    fn slots(&self) -> &Slots {
        self.slots
    }

    /// The PLC (its configured address, or the allow-list's entries)
    /// holds a reserved slot.
    fn guard(&self, peer: Option<SocketAddrV4>) -> Guard {
        self.hub.peek(|m| {
            let c = &m.config.active;
            Guard {
                reserving: c.reserves_plc_slot(),
                protected: c.is_plc(peer),
            }
        })
    }

    fn write_refused(&self, _peer: Option<SocketAddrV4>) {
        self.hub.with(|m| {
            m.access.writes_refused = m.access.writes_refused.wrapping_add(1);
        });
    }
}

/// Follows each configuration applied: closes the Modbus sessions its
/// allow-list no longer permits (each session also checks the list before
/// every request, so none is served another one in between), and tells
/// the sessions' table who the PLC is now (its reserved slot).
pub(crate) async fn warden<C: Clock>(port: &PlcPort<'_, C>) -> Infallible {
    let Some(mut applied) = port.hub.config_applied.receiver() else {
        // The watch has a receiver for each of its followers: cannot happen.
        return core::future::pending().await;
    };
    let mut config = port.hub.peek(|m| m.config.active);
    loop {
        port.slots
            .protect(config.reserves_plc_slot(), |peer| config.is_plc(peer));
        config = applied.changed().await;
        let list = config.modbus_allow;
        port.slots.close_unless(|peer| list.admits(peer));
    }
}
