//! Message Router object (class 0x02): instance 1 lists the classes it
//! routes to (attribute 1) and how many connections it supports (2).

use super::{class_level, no_data, read_only, Outcome, CLASSES};
use crate::wire::cip::{AppPath, GeneralStatus, Request, Service};
use crate::wire::Writer;

/// Serves a request to the Message Router; `max_connections` is attribute 2.
pub(crate) fn handle(
    req: &Request<'_>,
    path: &AppPath,
    max_connections: u16,
    w: &mut Writer<'_>,
) -> Outcome {
    match path.instance {
        0 => return class_level(req, path, 1, 1, w),
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
                1 => {
                    w.u16(CLASSES.len() as u16, "object list count")?;
                    for c in CLASSES {
                        w.u16(c, "object list class")?;
                    }
                }
                2 => w.u16(max_connections, "connections supported")?,
                _ => return Err(GeneralStatus::AttributeNotSupported.into()),
            }
            Ok(())
        }
        Service::SetAttributeSingle => Err(read_only(attr == 1 || attr == 2)),
        _ => Err(GeneralStatus::ServiceNotSupported.into()),
    }
}
