//! Ethernet Link object (class 0xF6): the link's speed, flags and MAC
//! address (attributes 1-3).

use super::{class_level, no_data, read_only, Outcome};
use crate::device::EthernetLinkInfo;
use crate::wire::cip::{AppPath, GeneralStatus, Request, Service};
use crate::wire::Writer;

/// The class revision.
const REVISION: u16 = 4;

/// Serves a request to the Ethernet Link class or instance 1.
pub(crate) fn handle(
    req: &Request<'_>,
    path: &AppPath,
    info: &EthernetLinkInfo,
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
                1 => w.u32(info.speed_mbps, "interface speed")?,
                2 => w.u32(info.flags, "interface flags")?,
                3 => w.bytes(&info.mac, "physical address")?,
                _ => return Err(GeneralStatus::AttributeNotSupported.into()),
            }
            Ok(())
        }
        Service::SetAttributeSingle => Err(read_only((1..=3).contains(&attr))),
        _ => Err(GeneralStatus::ServiceNotSupported.into()),
    }
}
