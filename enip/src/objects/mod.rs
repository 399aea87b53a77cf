//! The CIP objects the adapter answers for, one file each. Each handler
//! writes its reply data on success, or returns a failure that the
//! dispatcher turns into an error reply. The Connection Manager's services
//! change the adapter's connection table, so they live in the adapter.

pub(crate) mod assembly;
pub(crate) mod ethernet_link;
pub(crate) mod identity;
pub(crate) mod message_router;
pub(crate) mod tcpip;

use crate::wire::cip::{AppPath, GeneralStatus, Request, Service};
use crate::wire::{Error, Writer};

/// Class ids.
pub mod class {
    /// Identity.
    pub const IDENTITY: u32 = 0x01;
    /// Message Router.
    pub const MESSAGE_ROUTER: u32 = 0x02;
    /// Assembly.
    pub const ASSEMBLY: u32 = 0x04;
    /// Connection Manager.
    pub const CONNECTION_MANAGER: u32 = 0x06;
    /// TCP/IP Interface.
    pub const TCP_IP: u32 = 0xF5;
    /// Ethernet Link.
    pub const ETHERNET_LINK: u32 = 0xF6;
}

/// The classes the Message Router knows, in its object list.
pub(crate) const CLASSES: [u16; 6] = [0x01, 0x02, 0x04, 0x06, 0xF5, 0xF6];

/// A failed request: the general status, additional status words and a
/// little reply data (Forward_Open's and Forward_Close's triad).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Failure {
    pub(crate) status: GeneralStatus,
    pub(crate) additional: heapless::Vec<u16, 2>,
    pub(crate) data: heapless::Vec<u8, 10>,
}

impl From<GeneralStatus> for Failure {
    fn from(status: GeneralStatus) -> Failure {
        Failure {
            status,
            additional: heapless::Vec::new(),
            data: heapless::Vec::new(),
        }
    }
}

/// A reply that does not fit the caller's buffer.
impl From<Error> for Failure {
    fn from(_: Error) -> Failure {
        GeneralStatus::ReplyDataTooLarge.into()
    }
}

pub(crate) type Outcome = Result<(), Failure>;

/// The class attributes every object here has: 1 revision, 2 highest
/// instance, 3 number of instances. Only Get_Attribute_Single is served.
pub(crate) fn class_level(
    req: &Request<'_>,
    path: &AppPath,
    revision: u16,
    instances: u16,
    w: &mut Writer<'_>,
) -> Outcome {
    if req.service != Service::GetAttributeSingle {
        return Err(GeneralStatus::ServiceNotSupported.into());
    }
    no_data(req)?;
    match path.attribute {
        Some(1) => w.u16(revision, "class revision")?,
        Some(2) | Some(3) => w.u16(instances, "class instances")?,
        Some(_) => return Err(GeneralStatus::AttributeNotSupported.into()),
        None => return Err(GeneralStatus::PathDestinationUnknown.into()),
    }
    Ok(())
}

/// Get services carry no data.
pub(crate) fn no_data(req: &Request<'_>) -> Outcome {
    if req.data.is_empty() {
        Ok(())
    } else {
        Err(GeneralStatus::TooMuchData.into())
    }
}

/// For attributes that exist but cannot be set: Set_Attribute_Single on a
/// known attribute is "not settable", on an unknown one "not supported".
pub(crate) fn read_only(known: bool) -> Failure {
    if known {
        GeneralStatus::AttributeNotSettable.into()
    } else {
        GeneralStatus::AttributeNotSupported.into()
    }
}

/// Writes a CIP STRING (u16 length, the characters, a pad byte to an even
/// length), cut to `max` bytes on a character boundary.
pub(crate) fn emit_string(s: &str, max: usize, w: &mut Writer<'_>) -> Result<(), Error> {
    let mut end = s.len().min(max);
    while !s.is_char_boundary(end) {
        end -= 1;
    }
    let s = s.get(..end).unwrap_or("");
    // Cannot truncate: end <= max, and max is at most 64 here.
    w.u16(s.len() as u16, "string length")?;
    w.bytes(s.as_bytes(), "string")?;
    if s.len() % 2 == 1 {
        w.u8(0, "string pad")?;
    }
    Ok(())
}
