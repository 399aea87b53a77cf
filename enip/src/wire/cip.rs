//! Message Router request and response: the CIP message inside an
//! Unconnected or Connected Data item.
//!
//! ```text
//! request:  | service u8 | path size u8 (words) | path | data ...
//! response: | service|0x80 u8 | 0 u8 | general status u8 | additional size u8 (words) |
//!           | additional status u16 * size | data ...
//! ```

use super::epath::{segments, LogicalType, Segment};
use super::{Error, Reader, Writer};

/// The bit that marks a service code as a reply.
pub const REPLY_BIT: u8 = 0x80;

enum_with_unknown! {
    /// A CIP service code.
    pub enum Service(u8) {
        /// Get_Attributes_All.
        GetAttributesAll = 0x01,
        /// Set_Attributes_All.
        SetAttributesAll = 0x02,
        /// Get_Attribute_List.
        GetAttributeList = 0x03,
        /// Reset.
        Reset = 0x05,
        /// Get_Attribute_Single.
        GetAttributeSingle = 0x0E,
        /// Set_Attribute_Single.
        SetAttributeSingle = 0x10,
        /// Forward_Close (Connection Manager).
        ForwardClose = 0x4E,
        /// Unconnected_Send (Connection Manager).
        UnconnectedSend = 0x52,
        /// Forward_Open (Connection Manager).
        ForwardOpen = 0x54,
        /// Large_Forward_Open (Connection Manager).
        LargeForwardOpen = 0x5B,
    }
}

enum_with_unknown! {
    /// The general status of a CIP response.
    pub enum GeneralStatus(u8) {
        /// Success.
        Success = 0x00,
        /// A connection-related service failed (see the extended status).
        ConnectionFailure = 0x01,
        /// Resources needed for the service are not available.
        ResourceUnavailable = 0x02,
        /// A parameter of the request is invalid.
        InvalidParameterValue = 0x03,
        /// The path has a segment that cannot be processed.
        PathSegmentError = 0x04,
        /// The path names an object that does not exist.
        PathDestinationUnknown = 0x05,
        /// The service is not supported by the object.
        ServiceNotSupported = 0x08,
        /// The attribute data is invalid.
        InvalidAttributeValue = 0x09,
        /// The object is in a state that forbids the service.
        ObjectStateConflict = 0x0C,
        /// The attribute cannot be set.
        AttributeNotSettable = 0x0E,
        /// The device is in a state that forbids the service.
        DeviceStateConflict = 0x10,
        /// The reply would not fit.
        ReplyDataTooLarge = 0x11,
        /// The request has too little data.
        NotEnoughData = 0x13,
        /// The attribute is not supported.
        AttributeNotSupported = 0x14,
        /// The request has too much data.
        TooMuchData = 0x15,
        /// The object (instance) does not exist.
        ObjectDoesNotExist = 0x16,
        /// The request is malformed.
        InvalidParameter = 0x20,
        /// The path size does not match the path.
        PathSizeInvalid = 0x26,
    }
}

/// A Message Router request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Request<'a> {
    /// The service code (without the reply bit).
    pub service: Service,
    /// The request path.
    pub path: &'a [u8],
    /// The service's data.
    pub data: &'a [u8],
}

impl<'a> Request<'a> {
    /// Reads a request.
    pub fn parse(bytes: &'a [u8]) -> Result<Request<'a>, Error> {
        let mut r = Reader::new(bytes);
        let service = r.u8("CIP service")?;
        if service & REPLY_BIT != 0 {
            return Err(Error::Invalid {
                what: "CIP service (a reply)",
                value: u32::from(service),
            });
        }
        let words = r.u8("CIP path size")?;
        let path = r.take(usize::from(words) * 2, "CIP path")?;
        Ok(Request {
            service: Service::from(service),
            path,
            data: r.rest(),
        })
    }

    /// Writes a request.
    pub fn emit(&self, w: &mut Writer<'_>) -> Result<(), Error> {
        if self.path.len() % 2 == 1 {
            return Err(Error::Invalid {
                what: "CIP path length",
                value: self.path.len() as u32,
            });
        }
        let words =
            u8::try_from(self.path.len() / 2).map_err(|_| Error::Exhausted { what: "CIP path" })?;
        w.u8(u8::from(self.service), "CIP service")?;
        w.u8(words, "CIP path size")?;
        w.bytes(self.path, "CIP path")?;
        w.bytes(self.data, "CIP data")
    }
}

/// The most additional status words a response carries here.
pub const MAX_ADDITIONAL: usize = 2;

/// A Message Router response's header (the data follows it).
#[derive(Debug, Clone, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ResponseHeader {
    /// The service code of the request (the reply bit is added on the wire).
    pub service: Service,
    /// The general status.
    pub status: GeneralStatus,
    /// Additional status words (the extended status first).
    pub additional: heapless::Vec<u16, MAX_ADDITIONAL>,
}

impl ResponseHeader {
    /// A success header.
    pub fn success(service: Service) -> ResponseHeader {
        ResponseHeader {
            service,
            status: GeneralStatus::Success,
            additional: heapless::Vec::new(),
        }
    }

    /// A failure header without additional status.
    pub fn error(service: Service, status: GeneralStatus) -> ResponseHeader {
        ResponseHeader {
            service,
            status,
            additional: heapless::Vec::new(),
        }
    }

    /// Reads a response; returns its header and data.
    pub fn parse(bytes: &[u8]) -> Result<(ResponseHeader, &[u8]), Error> {
        let mut r = Reader::new(bytes);
        let service = r.u8("CIP reply service")?;
        if service & REPLY_BIT == 0 {
            return Err(Error::Invalid {
                what: "CIP reply service (a request)",
                value: u32::from(service),
            });
        }
        r.u8("CIP reply reserved")?;
        let status = GeneralStatus::from(r.u8("CIP general status")?);
        let n = r.u8("CIP additional status size")?;
        if usize::from(n) > MAX_ADDITIONAL {
            return Err(Error::Invalid {
                what: "CIP additional status size",
                value: u32::from(n),
            });
        }
        let mut additional = heapless::Vec::new();
        for _ in 0..n {
            let v = r.u16("CIP additional status")?;
            // Cannot fail: n <= MAX_ADDITIONAL.
            additional.push(v).map_err(|_| Error::Invalid {
                what: "CIP additional status size",
                value: u32::from(n),
            })?;
        }
        let h = ResponseHeader {
            service: Service::from(service & !REPLY_BIT),
            status,
            additional,
        };
        Ok((h, r.rest()))
    }

    /// Writes the header (the caller writes the data after it).
    pub fn emit(&self, w: &mut Writer<'_>) -> Result<(), Error> {
        w.u8(u8::from(self.service) | REPLY_BIT, "CIP reply service")?;
        w.u8(0, "CIP reply reserved")?;
        w.u8(u8::from(self.status), "CIP general status")?;
        // At most MAX_ADDITIONAL (2) words: fits a u8.
        w.u8(self.additional.len() as u8, "CIP additional status size")?;
        for a in &self.additional {
            w.u16(*a, "CIP additional status")?;
        }
        Ok(())
    }
}

/// The object a request path names: a class, an instance and an attribute.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AppPath {
    /// The class id.
    pub class: u32,
    /// The instance id (0 names the class itself).
    pub instance: u32,
    /// The attribute id, if any.
    pub attribute: Option<u32>,
}

impl AppPath {
    /// Reads a request path of the form class, instance, optional attribute. Any
    /// other segment (a member, a symbol, a route) is a path segment error:
    /// this device neither routes nor has tags.
    pub fn parse(path: &[u8]) -> Result<AppPath, GeneralStatus> {
        let mut class = None;
        let mut instance = None;
        let mut attribute = None;
        for seg in segments(path) {
            match seg {
                Ok(Segment::Logical {
                    kind: LogicalType::Class,
                    value,
                }) if class.is_none() => class = Some(value),
                Ok(Segment::Logical {
                    kind: LogicalType::Instance,
                    value,
                }) if class.is_some() && instance.is_none() => instance = Some(value),
                Ok(Segment::Logical {
                    kind: LogicalType::Attribute,
                    value,
                }) if instance.is_some() && attribute.is_none() => attribute = Some(value),
                _ => return Err(GeneralStatus::PathSegmentError),
            }
        }
        match (class, instance) {
            (Some(class), Some(instance)) => Ok(AppPath {
                class,
                instance,
                attribute,
            }),
            _ => Err(GeneralStatus::PathDestinationUnknown),
        }
    }

    /// Writes the path.
    pub fn emit(&self, w: &mut Writer<'_>) -> Result<(), Error> {
        Segment::Logical {
            kind: LogicalType::Class,
            value: self.class,
        }
        .emit(w)?;
        Segment::Logical {
            kind: LogicalType::Instance,
            value: self.instance,
        }
        .emit(w)?;
        if let Some(a) = self.attribute {
            Segment::Logical {
                kind: LogicalType::Attribute,
                value: a,
            }
            .emit(w)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn request_round_trips() {
        let b = [0x0E, 0x03, 0x20, 0x01, 0x24, 0x01, 0x30, 0x07, 0xAA];
        let r = Request::parse(&b).unwrap();
        assert_eq!(r.service, Service::GetAttributeSingle);
        assert_eq!(r.data, &[0xAA]);
        assert_eq!(
            AppPath::parse(r.path),
            Ok(AppPath {
                class: 1,
                instance: 1,
                attribute: Some(7)
            })
        );
        let mut out = [0u8; 16];
        let mut w = Writer::new(&mut out);
        r.emit(&mut w).unwrap();
        let n = w.len();
        assert_eq!(&out[..n], &b);
    }

    #[test]
    fn request_errors() {
        assert!(Request::parse(&[]).is_err());
        assert!(Request::parse(&[0x0E]).is_err());
        assert!(matches!(
            Request::parse(&[0x0E, 0x02, 0x20, 0x01]),
            Err(Error::Truncated {
                what: "CIP path",
                ..
            })
        ));
        assert!(matches!(
            Request::parse(&[0x8E, 0x00]),
            Err(Error::Invalid { .. })
        ));
        let odd = Request {
            service: Service::GetAttributeSingle,
            path: &[0x20],
            data: &[],
        };
        assert!(odd.emit(&mut Writer::new(&mut [0u8; 8])).is_err());
        let r = Request {
            service: Service::GetAttributeSingle,
            path: &[0x20, 1],
            data: &[1, 2],
        };
        assert!(r.emit(&mut Writer::new(&mut [0u8; 5])).is_err());
    }

    #[test]
    fn response_round_trips() {
        let mut h = ResponseHeader::error(Service::ForwardOpen, GeneralStatus::ConnectionFailure);
        h.additional.push(0x0113).unwrap();
        let mut out = [0u8; 16];
        let mut w = Writer::new(&mut out);
        h.emit(&mut w).unwrap();
        w.bytes(&[9, 9], "data").unwrap();
        let n = w.len();
        assert_eq!(&out[..6], &[0xD4, 0, 0x01, 0x01, 0x13, 0x01]);
        let (back, data) = ResponseHeader::parse(&out[..n]).unwrap();
        assert_eq!(back, h);
        assert_eq!(data, &[9, 9]);
    }

    #[test]
    fn response_errors() {
        assert!(ResponseHeader::parse(&[0x8E, 0, 0]).is_err());
        assert!(matches!(
            ResponseHeader::parse(&[0x0E, 0, 0, 0]),
            Err(Error::Invalid { .. })
        ));
        assert!(matches!(
            ResponseHeader::parse(&[0x8E, 0, 0, 3]),
            Err(Error::Invalid { .. })
        ));
        assert!(ResponseHeader::parse(&[0x8E, 0, 0, 1, 0]).is_err());
        assert!(ResponseHeader::success(Service::Reset)
            .emit(&mut Writer::new(&mut [0u8; 3]))
            .is_err());
    }

    #[test]
    fn app_path_rules() {
        assert_eq!(
            AppPath::parse(&[0x20, 0x04, 0x24, 0x64]),
            Ok(AppPath {
                class: 4,
                instance: 100,
                attribute: None
            })
        );
        // A class alone names no instance.
        assert_eq!(
            AppPath::parse(&[0x20, 0x04]),
            Err(GeneralStatus::PathDestinationUnknown)
        );
        assert_eq!(
            AppPath::parse(&[]),
            Err(GeneralStatus::PathDestinationUnknown)
        );
        // Instance before class, two classes, a member, a symbol, a route, a bad segment.
        for bad in [
            &[0x24, 0x01, 0x20, 0x01][..],
            &[0x20, 0x01, 0x20, 0x01],
            &[0x20, 0x01, 0x24, 0x01, 0x28, 0x01],
            &[0x91, 0x02, b'a', b'b'],
            &[0x01, 0x00, 0x20, 0x01, 0x24, 0x01],
            &[0x23, 0x00],
        ] {
            assert_eq!(
                AppPath::parse(bad),
                Err(GeneralStatus::PathSegmentError),
                "{bad:02x?}"
            );
        }
        let p = AppPath {
            class: 0xF5,
            instance: 1,
            attribute: Some(0x100),
        };
        let mut out = [0u8; 16];
        let mut w = Writer::new(&mut out);
        p.emit(&mut w).unwrap();
        let n = w.len();
        assert_eq!(AppPath::parse(&out[..n]), Ok(p));
    }
}
