//! The adapter fed an arbitrary TCP byte stream, in pieces of sizes taken
//! from the input, on two TCP connections, with time moving on between
//! packets: every reply is a well-formed encapsulation packet answering its
//! request; every T->O datagram is a well-formed class 1 packet; the
//! session and connection tables stay within their bounds. The input is
//! also tried as a UDP discovery datagram and as a class 1 datagram.
#![no_main]

mod enip_common;
use enip_common::*;

use core::net::{Ipv4Addr, SocketAddrV4};

use hans_enip::wire::io::IoPacket;
use hans_enip::*;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&seed, stream)) = data.split_first() else { return };
    let mut a = adapter();
    let mut app = App::default();
    let mut framers = [Framer::<600>::new(), Framer::<600>::new()];
    let peer = Ipv4Addr::new(127, 0, 0, 2);
    let mut now = 0u64;
    let mut out = [0u8; 1024];
    let mut rest = stream;
    let mut piece = usize::from(seed % 64) + 1;
    let mut turn = 0usize;
    while !rest.is_empty() {
        let link = turn % 2;
        let take = piece.min(rest.len());
        let mut chunk = &rest[..take];
        rest = &rest[take..];
        while !chunk.is_empty() {
            let used = framers[link].push(chunk);
            chunk = &chunk[used..];
            let Some(frame) = framers[link].frame() else { continue };
            let request = match frame {
                Frame::Complete { header, .. } | Frame::TooLong { header } => header,
            };
            match a.handle_tcp(LinkId(link as u32), peer, frame, Instant::from_micros(now), &mut app, &mut out) {
                TcpAction::Reply(n) => check_reply(&request, &out[..n]),
                TcpAction::Close => {
                    a.tcp_closed(LinkId(link as u32), Instant::from_micros(now), &mut app);
                    framers[link] = Framer::new();
                }
                TcpAction::None => {}
            }
            assert!(a.session_count() <= SESSIONS);
            assert!(a.connections().count() <= CONNS);
        }
        // Time moves on by up to ~65 ms a piece; the adapter produces and times out.
        now += u64::from(seed) * 256 + take as u64;
        while let Some((dest, n)) = a.poll(Instant::from_micros(now), &mut app, &mut out) {
            let p = IoPacket::parse(&out[..n]).expect("a T->O datagram parses");
            assert_eq!(p.data.len(), 8);
            assert_eq!(*dest.ip(), peer);
        }
        if let Some(at) = a.poll_at() {
            assert!(a.connections().count() > 0);
            let _ = at;
        }
        turn += 1;
        piece = usize::from(take as u8 ^ seed) % 64 + 1;
    }
    assert!(app.closed <= app.opened);
    if let Some(n) = a.handle_udp(stream, &mut app, &mut out) {
        let h = hans_enip::wire::encap::Header::parse(stream).expect("answered only if it parses");
        check_reply(&h, &out[..n]);
    }
    let _ = a.handle_io(SocketAddrV4::new(peer, 2222), stream, Instant::from_micros(now), &mut app);
});
