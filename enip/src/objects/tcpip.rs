//! TCP/IP Interface object (class 0xF5): the interface's configuration as
//! scanners read it (attributes 1-6, read-only here: the gateway's network
//! settings are changed on its own page, behind its own access rules).

use super::{class_level, emit_string, no_data, read_only, Outcome};
use crate::device::TcpIpInfo;
use crate::wire::cip::{AppPath, GeneralStatus, Request, Service};
use crate::wire::Writer;

/// The class revision (4: the revision whose attributes 1-6 are read here).
const REVISION: u16 = 4;

/// The CIP byte order of an IP address: a UDINT whose value is the address
/// read as a big-endian number, sent little-endian like every UDINT.
fn ip(
    w: &mut Writer<'_>,
    a: core::net::Ipv4Addr,
    what: &'static str,
) -> Result<(), crate::wire::Error> {
    w.u32(u32::from(a), what)
}

/// Serves a request to the TCP/IP Interface class or instance 1.
pub(crate) fn handle(
    req: &Request<'_>,
    path: &AppPath,
    info: &TcpIpInfo<'_>,
    w: &mut Writer<'_>,
) -> Outcome {
    match path.instance {
        0 => return class_level(req, path, REVISION, 1, w),
        1 => {}
        _ => return Err(GeneralStatus::ObjectDoesNotExist.into()),
    }
    let attr = path
        .attribute
        .ok_or(GeneralStatus::PathDestinationUnknown)?;
    match req.service {
        Service::GetAttributeSingle => {
            no_data(req)?;
            match attr {
                1 => w.u32(info.status, "interface status")?,
                2 => w.u32(info.config_capability, "configuration capability")?,
                3 => w.u32(info.config_control, "configuration control")?,
                4 => {
                    // The physical link object: a path of 2 words to Ethernet Link instance 1.
                    w.u16(2, "physical link path size")?;
                    w.bytes(&[0x20, 0xF6, 0x24, 0x01], "physical link path")?;
                }
                5 => {
                    ip(w, info.ip, "ip address")?;
                    ip(w, info.netmask, "network mask")?;
                    ip(w, info.gateway, "gateway")?;
                    ip(w, info.dns1, "name server")?;
                    ip(w, info.dns2, "name server 2")?;
                    emit_string(info.domain, 48, w)?;
                }
                6 => emit_string(info.host_name, 64, w)?,
                _ => return Err(GeneralStatus::AttributeNotSupported.into()),
            }
            Ok(())
        }
        Service::SetAttributeSingle => Err(read_only((1..=6).contains(&attr))),
        _ => Err(GeneralStatus::ServiceNotSupported.into()),
    }
}
