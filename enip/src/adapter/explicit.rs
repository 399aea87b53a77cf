//! Explicit messages: a Message Router request routed to the object its
//! path names, and the reply written in its place.

use core::net::{Ipv4Addr, SocketAddrV4};

use super::{Adapter, LinkId};
use crate::app::Application;
use crate::device::ConnectionKind;
use crate::objects::{
    assembly, class, ethernet_link, identity, message_router, tcpip, Failure, Outcome,
};
use crate::time::Instant;
use crate::wire::cip::{AppPath, GeneralStatus, Request, ResponseHeader, Service, REPLY_BIT};
use crate::wire::{Error, Writer};

/// Where an explicit request came from.
#[derive(Debug, Clone, Copy)]
pub(super) struct Context {
    pub(super) link: LinkId,
    pub(super) peer: Ipv4Addr,
    pub(super) now: Instant,
    /// The Sockaddr Info T->O item of a SendRRData, if it had one.
    pub(super) t_o_dest: Option<SocketAddrV4>,
}

impl<const SESSIONS: usize, const CONNECTIONS: usize> Adapter<'_, SESSIONS, CONNECTIONS> {
    /// Answers a Message Router request: the reply goes into `w`, success or
    /// not. Only a buffer too small for even an error reply is an error.
    pub(super) fn explicit<A: Application>(
        &mut self,
        ctx: &Context,
        request: &[u8],
        app: &mut A,
        w: &mut Writer<'_>,
    ) -> Result<(), Error> {
        let start = w.len();
        let req = match Request::parse(request) {
            Ok(r) => r,
            Err(_) => {
                let service = Service::from(request.first().map_or(0, |s| s & !REPLY_BIT));
                let status = if request.len() < 2 {
                    GeneralStatus::NotEnoughData
                } else if request.first().is_some_and(|s| s & REPLY_BIT != 0) {
                    GeneralStatus::ServiceNotSupported
                } else {
                    GeneralStatus::PathSizeInvalid
                };
                return ResponseHeader::error(service, status).emit(w);
            }
        };
        ResponseHeader::success(req.service).emit(w)?;
        if let Err(f) = self.dispatch(ctx, &req, app, w) {
            w.truncate(start);
            ResponseHeader {
                service: req.service,
                status: f.status,
                additional: f.additional,
            }
            .emit(w)?;
            w.bytes(&f.data, "error reply data")?;
        }
        Ok(())
    }

    fn dispatch<A: Application>(
        &mut self,
        ctx: &Context,
        req: &Request<'_>,
        app: &mut A,
        w: &mut Writer<'_>,
    ) -> Outcome {
        let path = AppPath::parse(req.path).map_err(Failure::from)?;
        match path.class {
            class::IDENTITY => {
                let status = self.identity_status(app.identity().status);
                identity::handle(req, &path, status, app, w)
            }
            class::MESSAGE_ROUTER => message_router::handle(
                req,
                &path,
                u16::try_from(CONNECTIONS).unwrap_or(u16::MAX),
                w,
            ),
            class::ASSEMBLY => {
                let conns = &self.conns;
                let owned = |instance: u16| {
                    conns.iter().any(|c| {
                        c.kind == ConnectionKind::ExclusiveOwner && c.output == Some(instance)
                    })
                };
                assembly::handle(req, &path, self.device, &owned, app, w)
            }
            class::CONNECTION_MANAGER => self.connection_manager(ctx, req, &path, app, w),
            class::TCP_IP => tcpip::handle(req, &path, &app.tcp_ip(), w),
            class::ETHERNET_LINK => ethernet_link::handle(req, &path, &app.ethernet_link(), w),
            _ => Err(GeneralStatus::PathDestinationUnknown.into()),
        }
    }
}
