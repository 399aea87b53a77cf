//! Identity object (class 0x01): who the device is. Instance 1 has the
//! seven required attributes; Get_Attributes_All returns them in order;
//! Reset asks the application.

use super::{class_level, no_data, read_only, Outcome};
use crate::app::Application;
use crate::device::Identity;
use crate::wire::cip::{AppPath, GeneralStatus, Request, Service};
use crate::wire::identity_item::short_name;
use crate::wire::Writer;

/// The class revision.
const REVISION: u16 = 1;

fn attribute(
    id: &Identity<'_>,
    attr: u32,
    w: &mut Writer<'_>,
) -> Option<Result<(), crate::wire::Error>> {
    Some(match attr {
        1 => w.u16(id.vendor_id, "vendor id"),
        2 => w.u16(id.device_type, "device type"),
        3 => w.u16(id.product_code, "product code"),
        4 => w
            .u8(id.revision.major, "major")
            .and_then(|()| w.u8(id.revision.minor, "minor")),
        5 => w.u16(id.status, "status"),
        6 => w.u32(id.serial, "serial"),
        7 => {
            let name = short_name(id.product_name);
            // short_name keeps at most 32 bytes.
            w.u8(name.len() as u8, "product name length")
                .and_then(|()| w.bytes(name.as_bytes(), "product name"))
        }
        _ => return None,
    })
}

/// Serves a request to the Identity class or instance 1; `status` is the
/// status word to report (the application's with the adapter's bits).
pub(crate) fn handle<A: Application>(
    req: &Request<'_>,
    path: &AppPath,
    status: u16,
    app: &mut A,
    w: &mut Writer<'_>,
) -> Outcome {
    match path.instance {
        0 => return class_level(req, path, REVISION, 1, w),
        1 => {}
        _ => return Err(GeneralStatus::ObjectDoesNotExist.into()),
    }
    match req.service {
        Service::GetAttributeSingle => {
            no_data(req)?;
            let attr = path
                .attribute
                .ok_or(GeneralStatus::PathDestinationUnknown)?;
            let id = Identity {
                status,
                ..app.identity()
            };
            attribute(&id, attr, w).ok_or(GeneralStatus::AttributeNotSupported)??;
        }
        Service::GetAttributesAll => {
            no_data(req)?;
            let id = Identity {
                status,
                ..app.identity()
            };
            for a in 1..=7 {
                if let Some(r) = attribute(&id, a, w) {
                    r?;
                }
            }
        }
        Service::SetAttributeSingle => {
            let attr = path
                .attribute
                .ok_or(GeneralStatus::PathDestinationUnknown)?;
            return Err(read_only((1..=7).contains(&attr)));
        }
        Service::Reset => {
            let kind = match req.data {
                [] => 0,
                [k] => *k,
                _ => return Err(GeneralStatus::TooMuchData.into()),
            };
            if kind > 1 {
                return Err(GeneralStatus::InvalidParameter.into());
            }
            if !app.reset(kind) {
                return Err(GeneralStatus::ObjectStateConflict.into());
            }
        }
        _ => return Err(GeneralStatus::ServiceNotSupported.into()),
    }
    Ok(())
}
