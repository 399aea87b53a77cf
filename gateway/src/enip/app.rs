//! The gateway as the adapter's application: the identity and interface
//! values, the assemblies as a view of the state, and what the
//! connections' events mean for the PLC rules (who owns the command
//! inputs, a lost heartbeat).

use core::net::Ipv4Addr;

use hans_enip::wire::cip::GeneralStatus;
use hans_enip::wire::conn_mgr::ExtendedStatus;
use hans_enip::{
    Application, CloseReason, ConnectionKind, EthernetLinkInfo, Event, Identity, Revision,
    TcpIpInfo, WriteOrigin,
};

use super::assembly::{self, INPUT, OUTPUT};
use super::EnipOptions;
use crate::clock::Clock;
use crate::hub::Hub;
use crate::state::owner::{Commander, EnipOwner};

/// The vendor id in the Identity object and the EDS: 0xFFFE, a value ODVA
/// has not assigned to any maker (this open project has no vendor id of
/// its own). Studio 5000 shows it as an unknown vendor; with exact keying
/// the module's key must say the same (the EDS does).
pub const VENDOR_ID: u16 = 0xFFFE;
/// The device type: 0x0C, communications adapter (a gateway to another
/// network: the robot's).
pub const DEVICE_TYPE: u16 = 0x0C;
/// The product code: 1, this gateway (the only product under the vendor
/// id above).
pub const PRODUCT_CODE: u16 = 1;
/// The revision: the major number is the assemblies' layout (a new major
/// number when a PLC program written for the old layout would break), the
/// minor number grows with compatible changes. Exact keying in Studio 5000
/// needs both to match the EDS; "compatible module" needs the same major
/// number and a minor number at least the EDS's.
pub const REVISION: Revision = Revision { major: 1, minor: 1 };
/// The product name (Identity attribute 7, at most 32 characters).
pub const PRODUCT_NAME: &str = "hans-gateway";

/// The gateway's identity, with `serial` (unique per device).
pub fn identity(serial: u32) -> Identity<'static> {
    Identity {
        vendor_id: VENDOR_ID,
        device_type: DEVICE_TYPE,
        product_code: PRODUCT_CODE,
        revision: REVISION,
        status: 0,
        serial,
        product_name: PRODUCT_NAME,
    }
}

/// Connections one originator may hold at once (an exclusive owner and a
/// class 3 connection of its MSG instructions, say): one address cannot
/// take every connection (a flood of half-open Forward_Opens from one host
/// holds at most this many, each until its first-packet timeout).
pub const PER_ORIGINATOR: usize = 2;

/// The application: the hub's state at the clock's time.
pub(crate) struct App<'a, C: Clock> {
    pub(crate) hub: &'a Hub,
    pub(crate) clock: &'a C,
    pub(crate) opts: &'a EnipOptions,
    pub(crate) host_name: &'a str,
}

impl<C: Clock> Application for App<'_, C> {
    fn identity(&self) -> Identity<'_> {
        identity(self.opts.serial)
    }

    fn tcp_ip(&self) -> TcpIpInfo<'_> {
        let (net, managed) = self
            .hub
            .peek(|m| (m.access.running, m.access.network_managed));
        let ip = if managed { net.ip } else { self.opts.ip };
        TcpIpInfo {
            status: 1,
            // Nothing settable over EtherNet/IP (the page and the registers
            // set the network); bit 2: a DHCP client where the board has one.
            config_capability: if managed && cfg!(feature = "dhcp") {
                0x04
            } else {
                0
            },
            config_control: if managed && net.dhcp { 2 } else { 0 },
            ip,
            netmask: if managed {
                net.mask
            } else {
                Ipv4Addr::UNSPECIFIED
            },
            gateway: if managed {
                net.gateway
            } else {
                Ipv4Addr::UNSPECIFIED
            },
            dns1: Ipv4Addr::UNSPECIFIED,
            dns2: Ipv4Addr::UNSPECIFIED,
            domain: "",
            host_name: self.host_name,
        }
    }

    fn ethernet_link(&self) -> EthernetLinkInfo {
        // Nominal: the boards' PHYs are 100 Mbit/s full duplex; the link
        // is up while the gateway answers at all.
        EthernetLinkInfo {
            speed_mbps: 100,
            flags: 0x03,
            mac: self.opts.mac,
        }
    }

    fn read_assembly(&mut self, instance: u16, buf: &mut [u8]) {
        let now = self.clock.now();
        match instance {
            INPUT => self.hub.peek(|m| assembly::encode_input(m, now, buf)),
            OUTPUT => self.hub.peek(|m| assembly::encode_output(m, buf)),
            _ => buf.fill(0),
        }
    }

    fn write_assembly(
        &mut self,
        instance: u16,
        data: &[u8],
        origin: WriteOrigin,
    ) -> Result<(), GeneralStatus> {
        if instance != OUTPUT {
            return Err(GeneralStatus::AttributeNotSettable);
        }
        let now = self.clock.now();
        let queued = self.hub.with(|m| {
            let (ev, by) = match origin {
                WriteOrigin::Io { connection, run } => {
                    let Some(owner) = m
                        .owner
                        .enip_owner
                        .as_mut()
                        .filter(|o| o.connection == connection.0)
                    else {
                        return Err(GeneralStatus::DeviceStateConflict);
                    };
                    owner.run = run;
                    if !run {
                        // Idle (program mode): the data is not applied,
                        // and it is no heartbeat.
                        return Ok(false);
                    }
                    let ip = owner.ip;
                    let ev = if core::mem::replace(&mut owner.fresh, false) {
                        assembly::baseline_output(m, data)
                    } else {
                        assembly::write_output(m, data)
                    };
                    (ev, Commander::Enip(ip))
                }
                WriteOrigin::Explicit => {
                    if m.owner.enip_owns() {
                        return Err(GeneralStatus::DeviceStateConflict);
                    }
                    (assembly::write_output(m, data), Commander::Modbus)
                }
            };
            Ok(crate::plc::apply(m, &ev, now, by))
        })?;
        if queued {
            self.hub.job_queued.signal(());
        }
        Ok(())
    }

    fn event(&mut self, event: Event) {
        match event {
            Event::Opened {
                connection,
                kind,
                originator,
                ..
            } => {
                let [a, b, c, d] = originator.octets();
                info!(
                    "enip: connection {} opened by {}.{}.{}.{} ({})",
                    connection.0,
                    a,
                    b,
                    c,
                    d,
                    kind_name(kind)
                );
                self.hub.with(|m| {
                    m.owner.enip_connections = m.owner.enip_connections.saturating_add(1);
                    if kind == ConnectionKind::ExclusiveOwner {
                        m.owner.enip_owner = Some(EnipOwner {
                            connection: connection.0,
                            ip: originator,
                            run: false,
                            fresh: true,
                            received: 0,
                            missed: 0,
                        });
                    }
                });
            }
            Event::Closed {
                connection,
                kind,
                reason,
            } => {
                let why = match reason {
                    CloseReason::ForwardClose => "Forward_Close",
                    CloseReason::TimedOut => "timed out",
                    CloseReason::LinkClosed => "its TCP connection closed",
                };
                let lost = self.hub.with(|m| {
                    m.owner.enip_connections = m.owner.enip_connections.saturating_sub(1);
                    let Some(owner) = m.owner.enip_owner.filter(|o| o.connection == connection.0)
                    else {
                        return false;
                    };
                    info!(
                        "enip: owner connection {}: {} O->T datagrams received, {} missed",
                        connection.0, owner.received, owner.missed
                    );
                    m.owner.enip_owner = None;
                    // The owner is gone while a motion runs: nobody holds
                    // its heartbeat any more.
                    let lost = m.active_motion.is_some();
                    m.plc.lost |= lost;
                    lost
                });
                if lost {
                    warn!(
                        "enip: the owner's connection {} closed ({}) during a motion: heartbeat lost",
                        connection.0, why
                    );
                    self.hub.job_queued.signal(());
                } else {
                    info!(
                        "enip: connection {} closed ({}, {})",
                        connection.0,
                        why,
                        kind_name(kind)
                    );
                }
            }
            Event::RunIdle { connection, run } => {
                self.hub.with(|m| {
                    if let Some(o) = m
                        .owner
                        .enip_owner
                        .as_mut()
                        .filter(|o| o.connection == connection.0)
                    {
                        o.run = run;
                    }
                });
                info!(
                    "enip: connection {}: {}",
                    connection.0,
                    if run { "run" } else { "idle" }
                );
            }
        }
    }

    fn admit_open(
        &mut self,
        kind: ConnectionKind,
        originator: Ipv4Addr,
        held: usize,
    ) -> Result<(), ExtendedStatus> {
        self.hub.with(|m| {
            let refusal = if held >= PER_ORIGINATOR {
                Some(ExtendedStatus::OutOfConnections)
            } else if kind == ConnectionKind::ExclusiveOwner
                && !crate::plc::enip_may_own(m, originator)
            {
                Some(ExtendedStatus::OwnershipConflict)
            } else {
                None
            };
            match refusal {
                None => Ok(()),
                Some(r) => {
                    m.owner.enip_refused = m.owner.enip_refused.wrapping_add(1);
                    Err(r)
                }
            }
        })
    }
}

fn kind_name(kind: ConnectionKind) -> &'static str {
    match kind {
        ConnectionKind::ExclusiveOwner => "exclusive owner",
        ConnectionKind::InputOnly => "input only",
        ConnectionKind::ListenOnly => "listen only",
        ConnectionKind::Explicit => "class 3",
    }
}
