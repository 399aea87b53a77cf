//! CIP requests from arbitrary bytes, Forward_Open and Large_Forward_Open
//! included: what parses (requests, paths, segments, Forward_Open,
//! Forward_Close) reads back the same after writing; and the bytes as a
//! Message Router request to the adapter, on a registered session, get a
//! well-formed SendRRData reply whose response answers the service asked,
//! with the connection table within its bound. Never a panic.
#![no_main]

mod enip_common;
use enip_common::*;

use core::net::Ipv4Addr;

use hans_enip::wire::cip::{AppPath, Request, ResponseHeader, Service, REPLY_BIT};
use hans_enip::wire::conn_mgr::{ForwardClose, ForwardOpen};
use hans_enip::wire::cpf::{Cpf, CpfWriter, ItemType};
use hans_enip::wire::encap::{Command, Header, Status, HEADER_LEN};
use hans_enip::wire::epath::segments;
use hans_enip::wire::session::SendDataRepr;
use hans_enip::wire::Writer;
use hans_enip::*;
use libfuzzer_sys::fuzz_target;

fn encap(command: Command, session: u32, data: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; HEADER_LEN + data.len()];
    Header { command, length: data.len() as u16, session, status: Status::Success, context: [7; 8], options: 0 }
        .emit(&mut out)
        .expect("24 bytes");
    out[HEADER_LEN..].copy_from_slice(data);
    out
}

fn send(a: &mut FuzzAdapter, app: &mut App, packet: &[u8], now: u64) -> Option<Vec<u8>> {
    let mut f = Framer::<600>::new();
    f.push(packet);
    let frame = f.frame()?;
    let request = match frame {
        Frame::Complete { header, .. } | Frame::TooLong { header } => header,
    };
    let mut out = [0u8; 1024];
    match a.handle_tcp(LinkId(1), Ipv4Addr::new(127, 0, 0, 2), frame, Instant::from_micros(now), app, &mut out) {
        TcpAction::Reply(n) => {
            check_reply(&request, &out[..n]);
            Some(out[..n].to_vec())
        }
        _ => None,
    }
}

fuzz_target!(|data: &[u8]| {
    let mut buf = vec![0u8; data.len() + 64];
    // The wire formats: parse, write, parse again.
    if let Ok(r) = Request::parse(data) {
        let mut w = Writer::new(&mut buf);
        r.emit(&mut w).expect("room");
        let n = w.len();
        assert_eq!(&buf[..n], data);
        let _ = AppPath::parse(r.path);
        for s in segments(r.path).flatten() {
            let mut b = [0u8; 600];
            let mut w = Writer::new(&mut b);
            if s.emit(&mut w).is_ok() {
                let n = w.len();
                let back: Vec<_> = segments(&b[..n]).collect();
                assert_eq!(back, vec![Ok(s)]);
            }
        }
    }
    for large in [false, true] {
        if let Ok(fo) = ForwardOpen::parse(data, large) {
            let mut w = Writer::new(&mut buf);
            fo.emit(&mut w).expect("room");
            let n = w.len();
            assert_eq!(ForwardOpen::parse(&buf[..n], large), Ok(fo));
        }
    }
    if let Ok(fc) = ForwardClose::parse(data) {
        let mut w = Writer::new(&mut buf);
        fc.emit(&mut w).expect("room");
        let n = w.len();
        assert_eq!(ForwardClose::parse(&buf[..n]), Ok(fc));
    }

    // The adapter: the bytes as a request, unconnected.
    let mut a = adapter();
    let mut app = App::default();
    let reg = send(&mut a, &mut app, &encap(Command::RegisterSession, 0, &[1, 0, 0, 0]), 0).expect("registered");
    let session = Header::parse(&reg).expect("header").session;
    let mut rr = vec![0u8; data.len() + 32];
    let mut w = Writer::new(&mut rr);
    SendDataRepr::emit_prefix(0, 0, &mut w).expect("room");
    let mut c = CpfWriter::begin(&mut w).expect("room");
    c.item(&mut w, ItemType::NullAddress, &[]).expect("room");
    if c.item(&mut w, ItemType::UnconnectedData, data).is_err() {
        return;
    }
    let n = w.len();
    rr.truncate(n);
    // Twice: a Forward_Open the first time may be a duplicate the second.
    for now in [0u64, 1_000] {
        let Some(reply) = send(&mut a, &mut app, &encap(Command::SendRrData, session, &rr), now) else {
            // Too long for the framer: answered with "invalid length" and checked in send.
            return;
        };
        let h = Header::parse(&reply).expect("header");
        assert_eq!(h.status, Status::Success);
        let sd = SendDataRepr::parse(&reply[HEADER_LEN..]).expect("prefix");
        let cpf = Cpf::parse(sd.cpf).expect("CPF");
        let (rh, _) = ResponseHeader::parse(cpf.get(1).expect("item").data).expect("response");
        if let Some(&s) = data.first() {
            if s & REPLY_BIT == 0 {
                assert_eq!(rh.service, Service::from(s), "the response answers the service asked");
            }
        }
        assert!(a.connections().count() <= CONNS);
    }
    // Every connection it opened times out and is told.
    let _ = a.poll(Instant::from_micros(3_600_000_000), &mut app, &mut [0u8; 64]);
    while a.poll(Instant::from_micros(3_600_000_000), &mut app, &mut [0u8; 64]).is_some() {}
    assert_eq!(a.connections().count(), 0);
    assert_eq!(app.opened, app.closed);
});
