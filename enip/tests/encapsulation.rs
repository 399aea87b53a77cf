//! The encapsulation layer and the objects, through the adapter's public
//! API, in virtual time.

mod common;
use common::*;

use hans_enip::wire::cip::{GeneralStatus, Service};
use hans_enip::wire::cpf::{Cpf, CpfWriter, ItemType};
use hans_enip::wire::encap::{Command, Header, Status, HEADER_LEN};
use hans_enip::wire::identity_item::{IdentityItem, ServicesItem};
use hans_enip::wire::session::SendDataRepr;
use hans_enip::wire::Writer;
use hans_enip::*;

fn status_of(reply: &[u8]) -> Status {
    let h = Header::parse(reply).unwrap();
    assert_eq!(
        h.length as usize,
        reply.len() - HEADER_LEN,
        "length field matches"
    );
    h.status
}

#[test]
fn sessions_are_bounded_one_per_connection_and_freed() {
    let mut a = adapter(); // 2 sessions
    let mut app = TestApp::new();
    let s1 = register(&mut a, 1, &mut app);
    let s2 = register(&mut a, 2, &mut app);
    assert_ne!(s1, s2);
    // The table is full: a third connection is refused with 0x0002.
    let r = one(
        &mut a,
        3,
        &encap(Command::RegisterSession, 0, &[1, 0, 0, 0]),
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(status_of(&r), Status::InsufficientMemory);
    assert_eq!(Header::parse(&r).unwrap().session, 0);
    // A second session on the same TCP connection: 0x0001.
    let r = one(
        &mut a,
        1,
        &encap(Command::RegisterSession, 0, &[1, 0, 0, 0]),
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(status_of(&r), Status::InvalidCommand);
    assert_eq!(a.session_count(), 2);
    // UnRegisterSession: no reply, close; the slot is free again.
    let r = feed(
        &mut a,
        1,
        &encap(Command::UnRegisterSession, s1, &[]),
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(r, vec![Err(TcpAction::Close)]);
    assert_eq!(a.session_count(), 1);
    register(&mut a, 3, &mut app);
    // A TCP connection that closes frees its session too.
    a.tcp_closed(LinkId(2), Instant::ZERO, &mut app);
    assert_eq!(a.session_count(), 1);
    register(&mut a, 4, &mut app);
}

#[test]
fn a_session_flood_holds_at_the_bound() {
    let mut a = adapter();
    let mut app = TestApp::new();
    let mut refused = 0;
    for link in 0..1000 {
        let r = one(
            &mut a,
            link,
            &encap(Command::RegisterSession, 0, &[1, 0, 0, 0]),
            Instant::ZERO,
            &mut app,
        );
        if status_of(&r) == Status::InsufficientMemory {
            refused += 1;
        }
    }
    assert_eq!(refused, 998);
    assert_eq!(a.session_count(), 2);
}

#[test]
fn session_handles_are_checked() {
    let mut a = adapter();
    let mut app = TestApp::new();
    let s1 = register(&mut a, 1, &mut app);
    let s2 = register(&mut a, 2, &mut app);
    let req = mr(
        Service::GetAttributeSingle,
        &[0x20, 0x01, 0x24, 0x01, 0x30, 0x01],
        &[],
    );
    for (link, session) in [(1, 0), (1, s1 ^ 1), (1, s2), (3, s1)] {
        let r = one(
            &mut a,
            link,
            &encap(Command::SendRrData, session, &rr_data(&req, None)),
            Instant::ZERO,
            &mut app,
        );
        assert_eq!(
            status_of(&r),
            Status::InvalidSessionHandle,
            "link {link} session {session:#x}"
        );
        let r = one(
            &mut a,
            link,
            &encap(Command::SendUnitData, session, &[0; 6]),
            Instant::ZERO,
            &mut app,
        );
        assert_eq!(status_of(&r), Status::InvalidSessionHandle);
        let r = one(
            &mut a,
            link,
            &encap(Command::UnRegisterSession, session, &[]),
            Instant::ZERO,
            &mut app,
        );
        assert_eq!(status_of(&r), Status::InvalidSessionHandle);
    }
    let (h, data) = ask(&mut a, 1, s1, &req, Instant::ZERO, &mut app);
    ok(&h);
    assert_eq!(data, VENDOR.to_le_bytes());
}

#[test]
fn bad_lengths_unknown_commands_and_versions() {
    let mut a = adapter();
    let mut app = TestApp::new();
    for data in [&[1, 0, 0][..], &[1, 0, 0, 0, 0]] {
        let r = one(
            &mut a,
            1,
            &encap(Command::RegisterSession, 0, data),
            Instant::ZERO,
            &mut app,
        );
        assert_eq!(status_of(&r), Status::InvalidLength);
    }
    let r = one(
        &mut a,
        1,
        &encap(Command::RegisterSession, 0, &[2, 0, 0, 0]),
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(status_of(&r), Status::UnsupportedProtocolRevision);
    assert_eq!(&r[HEADER_LEN..], &[1, 0, 0, 0], "the reply names version 1");
    let r = one(
        &mut a,
        1,
        &encap(Command::ListIdentity, 0, &[0]),
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(status_of(&r), Status::InvalidLength);
    let r = one(
        &mut a,
        1,
        &encap(Command::Unknown(0x00FF), 0, &[]),
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(status_of(&r), Status::InvalidCommand);
    assert_eq!(Header::parse(&r).unwrap().command, Command::Unknown(0x00FF));
    let s = register(&mut a, 1, &mut app);
    // SendRRData shorter than its prefix.
    let r = one(
        &mut a,
        1,
        &encap(Command::SendRrData, s, &[0, 0, 0, 0]),
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(status_of(&r), Status::InvalidLength);
    // A packet longer than the framer holds: refused, and the stream goes on.
    let mut stream = encap(Command::SendRrData, s, &vec![0u8; 2000]);
    stream.extend(encap(Command::ListServices, 0, &[]));
    let r = feed(&mut a, 1, &stream, Instant::ZERO, &mut app);
    assert_eq!(r.len(), 2);
    assert_eq!(status_of(r[0].as_ref().unwrap()), Status::InvalidLength);
    assert_eq!(status_of(r[1].as_ref().unwrap()), Status::Success);
}

#[test]
fn nop_and_options_get_no_reply() {
    let mut a = adapter();
    let mut app = TestApp::new();
    assert_eq!(
        feed(
            &mut a,
            1,
            &encap(Command::Nop, 0, &[1, 2, 3]),
            Instant::ZERO,
            &mut app
        ),
        vec![Err(TcpAction::None)]
    );
    assert_eq!(
        feed(
            &mut a,
            1,
            &encap(Command::Nop, 0, &vec![0; 5000]),
            Instant::ZERO,
            &mut app
        ),
        vec![Err(TcpAction::None)]
    );
    let mut p = encap(Command::RegisterSession, 0, &[1, 0, 0, 0]);
    p[20] = 1;
    assert_eq!(
        feed(&mut a, 1, &p, Instant::ZERO, &mut app),
        vec![Err(TcpAction::None)]
    );
    assert_eq!(a.session_count(), 0);
}

#[test]
fn malformed_and_oversized_items_are_refused() {
    let mut a = adapter();
    let mut app = TestApp::new();
    let s = register(&mut a, 1, &mut app);
    let mut cases: Vec<Vec<u8>> = Vec::new();
    // Five items: more than any request has.
    let mut five = vec![0, 0, 0, 0, 0, 0, 5, 0];
    for _ in 0..5 {
        five.extend([0, 0, 0, 0]);
    }
    cases.push(five);
    // An item longer than the packet.
    cases.push(vec![
        0, 0, 0, 0, 0, 0, 2, 0, 0, 0, 0, 0, 0xB2, 0, 0xFF, 0x7F, 1, 2,
    ]);
    // Data first, address second.
    cases.push(vec![0, 0, 0, 0, 0, 0, 2, 0, 0xB2, 0, 0, 0, 0, 0, 0, 0]);
    // A null address with data.
    cases.push(vec![0, 0, 0, 0, 0, 0, 2, 0, 0, 0, 1, 0, 9, 0xB2, 0, 0, 0]);
    // One item only.
    cases.push(vec![0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0]);
    // A third item that is not a Sockaddr Info.
    cases.push(vec![
        0, 0, 0, 0, 0, 0, 3, 0, 0, 0, 0, 0, 0xB2, 0, 0, 0, 0xB1, 0, 0, 0,
    ]);
    // Bytes after the items.
    cases.push(vec![0, 0, 0, 0, 0, 0, 2, 0, 0, 0, 0, 0, 0xB2, 0, 0, 0, 7]);
    for (i, data) in cases.iter().enumerate() {
        let r = one(
            &mut a,
            1,
            &encap(Command::SendRrData, s, data),
            Instant::ZERO,
            &mut app,
        );
        assert_eq!(status_of(&r), Status::IncorrectData, "case {i}");
    }
}

#[test]
fn list_identity_services_and_interfaces_on_tcp_and_udp() {
    let mut a = adapter();
    let mut app = TestApp::new();
    let r = one(
        &mut a,
        1,
        &encap(Command::ListIdentity, 0, &[]),
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(status_of(&r), Status::Success);
    let cpf = Cpf::parse(&r[HEADER_LEN..]).unwrap();
    let id = IdentityItem::parse(cpf.find(ItemType::CipIdentity).unwrap().data).unwrap();
    assert_eq!(id.identity.vendor_id, VENDOR);
    assert_eq!(id.identity.product_code, PRODUCT);
    assert_eq!(id.identity.product_name, "Hans EtherNet/IP test");
    assert_eq!(
        id.identity.status, 0x0034,
        "configured (the app's) + no I/O (the adapter's)"
    );
    assert_eq!(id.socket.port(), 44818);
    assert_eq!(id.socket.ip().octets(), [192, 168, 1, 50]);
    let mut out = [0u8; 600];
    let n = a
        .handle_udp(&encap(Command::ListIdentity, 0, &[]), &mut app, &mut out)
        .unwrap();
    assert_eq!(&out[..n], &r[..]);
    let r = one(
        &mut a,
        1,
        &encap(Command::ListServices, 0, &[]),
        Instant::ZERO,
        &mut app,
    );
    let cpf = Cpf::parse(&r[HEADER_LEN..]).unwrap();
    let s = ServicesItem::parse(cpf.find(ItemType::ListServices).unwrap().data).unwrap();
    assert_eq!(s, ServicesItem::communications());
    let r = one(
        &mut a,
        1,
        &encap(Command::ListInterfaces, 0, &[]),
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(&r[HEADER_LEN..], &[0, 0]);
    // UDP: only the List commands; the rest is dropped, never answered.
    for c in [
        Command::RegisterSession,
        Command::SendRrData,
        Command::Nop,
        Command::Unknown(7),
    ] {
        assert_eq!(
            a.handle_udp(&encap(c, 0, &[1, 0, 0, 0]), &mut app, &mut out),
            None
        );
    }
    // A UDP datagram whose length field disagrees, or too short: dropped.
    let mut bad = encap(Command::ListIdentity, 0, &[]);
    bad.push(0);
    assert_eq!(a.handle_udp(&bad, &mut app, &mut out), None);
    assert_eq!(a.handle_udp(&bad[..20], &mut app, &mut out), None);
}

#[test]
fn identity_object() {
    let mut a = adapter();
    let mut app = TestApp::new();
    let s = register(&mut a, 1, &mut app);
    let (h, d) = ask(
        &mut a,
        1,
        s,
        &mr(Service::GetAttributesAll, &[0x20, 0x01, 0x24, 0x01], &[]),
        Instant::ZERO,
        &mut app,
    );
    ok(&h);
    let mut want = Vec::new();
    want.extend(VENDOR.to_le_bytes());
    want.extend(DEVICE_TYPE.to_le_bytes());
    want.extend(PRODUCT.to_le_bytes());
    want.extend([1, 3]);
    want.extend(0x0034u16.to_le_bytes());
    want.extend(0x1234_5678u32.to_le_bytes());
    want.push(21);
    want.extend(b"Hans EtherNet/IP test");
    assert_eq!(d, want);
    let get = |attr: u8| {
        mr(
            Service::GetAttributeSingle,
            &[0x20, 0x01, 0x24, 0x01, 0x30, attr],
            &[],
        )
    };
    let (h, d) = ask(&mut a, 1, s, &get(7), Instant::ZERO, &mut app);
    ok(&h);
    assert_eq!(d[0], 21);
    let (h, _) = ask(&mut a, 1, s, &get(8), Instant::ZERO, &mut app);
    assert_eq!(h.status, GeneralStatus::AttributeNotSupported);
    // Class attributes.
    let (h, d) = ask(
        &mut a,
        1,
        s,
        &mr(
            Service::GetAttributeSingle,
            &[0x20, 0x01, 0x24, 0x00, 0x30, 0x01],
            &[],
        ),
        Instant::ZERO,
        &mut app,
    );
    ok(&h);
    assert_eq!(d, [1, 0]);
    // Instance 2, unknown class, a symbol, a set, a service it lacks.
    let (h, _) = ask(
        &mut a,
        1,
        s,
        &mr(
            Service::GetAttributeSingle,
            &[0x20, 0x01, 0x24, 0x02, 0x30, 0x01],
            &[],
        ),
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(h.status, GeneralStatus::ObjectDoesNotExist);
    let (h, _) = ask(
        &mut a,
        1,
        s,
        &mr(
            Service::GetAttributeSingle,
            &[0x20, 0x77, 0x24, 0x01, 0x30, 0x01],
            &[],
        ),
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(h.status, GeneralStatus::PathDestinationUnknown);
    let (h, _) = ask(
        &mut a,
        1,
        s,
        &mr(
            Service::Unknown(0x4C),
            &[0x91, 0x03, b'T', b'a', b'g', 0],
            &[],
        ),
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(h.status, GeneralStatus::PathSegmentError);
    assert_eq!(h.service, Service::Unknown(0x4C));
    let (h, _) = ask(
        &mut a,
        1,
        s,
        &mr(
            Service::SetAttributeSingle,
            &[0x20, 0x01, 0x24, 0x01, 0x30, 0x01],
            &[1, 0],
        ),
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(h.status, GeneralStatus::AttributeNotSettable);
    let (h, _) = ask(
        &mut a,
        1,
        s,
        &mr(Service::Unknown(0x33), &[0x20, 0x01, 0x24, 0x01], &[]),
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(h.status, GeneralStatus::ServiceNotSupported);
    let (h, _) = ask(
        &mut a,
        1,
        s,
        &mr(
            Service::GetAttributeSingle,
            &[0x20, 0x01, 0x24, 0x01, 0x30, 0x01],
            &[9],
        ),
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(h.status, GeneralStatus::TooMuchData);
    // A request too short to have a path, a path size past the end.
    let (h, _) = ask(&mut a, 1, s, &[0x0E], Instant::ZERO, &mut app);
    assert_eq!(h.status, GeneralStatus::NotEnoughData);
    let (h, _) = ask(
        &mut a,
        1,
        s,
        &[0x0E, 0x09, 0x20, 0x01],
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(h.status, GeneralStatus::PathSizeInvalid);
}

#[test]
fn identity_reset_asks_the_application() {
    let mut a = adapter();
    let mut app = TestApp::new();
    let s = register(&mut a, 1, &mut app);
    let reset = |data: &[u8]| mr(Service::Reset, &[0x20, 0x01, 0x24, 0x01], data);
    let (h, _) = ask(&mut a, 1, s, &reset(&[]), Instant::ZERO, &mut app);
    assert_eq!(h.status, GeneralStatus::ObjectStateConflict);
    app.accept_reset = true;
    let (h, _) = ask(&mut a, 1, s, &reset(&[1]), Instant::ZERO, &mut app);
    ok(&h);
    let (h, _) = ask(&mut a, 1, s, &reset(&[2]), Instant::ZERO, &mut app);
    assert_eq!(h.status, GeneralStatus::InvalidParameter);
    let (h, _) = ask(&mut a, 1, s, &reset(&[0, 0]), Instant::ZERO, &mut app);
    assert_eq!(h.status, GeneralStatus::TooMuchData);
    assert_eq!(app.resets, [0, 1]);
}

#[test]
fn assembly_object() {
    let mut a = adapter();
    let mut app = TestApp::new();
    let s = register(&mut a, 1, &mut app);
    let path = |inst: u8, attr: u8| [0x20, 0x04, 0x24, inst, 0x30, attr];
    let (h, _) = ask(
        &mut a,
        1,
        s,
        &mr(
            Service::SetAttributeSingle,
            &path(OUTPUT as u8, 3),
            &[1, 2, 3, 4, 5, 6, 7, 8],
        ),
        Instant::ZERO,
        &mut app,
    );
    ok(&h);
    assert_eq!(app.output, [1, 2, 3, 4, 5, 6, 7, 8]);
    let (h, d) = ask(
        &mut a,
        1,
        s,
        &mr(Service::GetAttributeSingle, &path(INPUT as u8, 3), &[]),
        Instant::ZERO,
        &mut app,
    );
    ok(&h);
    assert_eq!(d, [1, 2, 3, 4, 5, 6, 7, 1]);
    let (h, d) = ask(
        &mut a,
        1,
        s,
        &mr(Service::GetAttributeSingle, &path(INPUT as u8, 4), &[]),
        Instant::ZERO,
        &mut app,
    );
    ok(&h);
    assert_eq!(d, [8, 0]);
    for (data, status) in [
        (&[1u8; 7][..], GeneralStatus::NotEnoughData),
        (&[1u8; 9][..], GeneralStatus::TooMuchData),
    ] {
        let (h, _) = ask(
            &mut a,
            1,
            s,
            &mr(Service::SetAttributeSingle, &path(OUTPUT as u8, 3), data),
            Instant::ZERO,
            &mut app,
        );
        assert_eq!(h.status, status);
    }
    let (h, _) = ask(
        &mut a,
        1,
        s,
        &mr(Service::SetAttributeSingle, &path(INPUT as u8, 3), &[0; 8]),
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(h.status, GeneralStatus::AttributeNotSettable);
    let (h, _) = ask(
        &mut a,
        1,
        s,
        &mr(Service::GetAttributeSingle, &path(101, 3), &[]),
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(h.status, GeneralStatus::ObjectDoesNotExist);
    let (h, _) = ask(
        &mut a,
        1,
        s,
        &mr(Service::GetAttributeSingle, &path(INPUT as u8, 9), &[]),
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(h.status, GeneralStatus::AttributeNotSupported);
    // While an exclusive owner holds the output, explicit writes are refused.
    let (h, _) = ask(
        &mut a,
        1,
        s,
        &fo_request(&fo_owner(1, 10_000, 0)),
        Instant::ZERO,
        &mut app,
    );
    ok(&h);
    let (h, _) = ask(
        &mut a,
        1,
        s,
        &mr(Service::SetAttributeSingle, &path(OUTPUT as u8, 3), &[0; 8]),
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(h.status, GeneralStatus::DeviceStateConflict);
}

#[test]
fn tcp_ip_and_ethernet_link_objects() {
    let mut a = adapter();
    let mut app = TestApp::new();
    let s = register(&mut a, 1, &mut app);
    let mut get = |class: u8, attr: u8| {
        ask(
            &mut a,
            1,
            s,
            &mr(
                Service::GetAttributeSingle,
                &[0x20, class, 0x24, 0x01, 0x30, attr],
                &[],
            ),
            Instant::ZERO,
            &mut app,
        )
    };
    assert_eq!(get(0xF5, 1).1, [1, 0, 0, 0]);
    assert_eq!(get(0xF5, 2).1, [4, 0, 0, 0]);
    assert_eq!(get(0xF5, 3).1, [0, 0, 0, 0]);
    assert_eq!(get(0xF5, 4).1, [2, 0, 0x20, 0xF6, 0x24, 0x01]);
    let (h, d) = get(0xF5, 5);
    ok(&h);
    assert_eq!(&d[..4], &[50, 1, 168, 192], "UDINT, little-endian");
    assert_eq!(&d[4..8], &[0, 255, 255, 255]);
    assert_eq!(&d[20..22], &[11, 0]);
    assert_eq!(&d[22..33], b"plant.local");
    assert_eq!(d.len(), 34, "padded to an even length");
    assert_eq!(get(0xF5, 6).1, b"\x07\x00hans-gw\x00");
    assert_eq!(get(0xF5, 7).0.status, GeneralStatus::AttributeNotSupported);
    assert_eq!(get(0xF6, 1).1, [100, 0, 0, 0]);
    assert_eq!(get(0xF6, 2).1, [0x0F, 0, 0, 0]);
    assert_eq!(get(0xF6, 3).1, [0x02, 0, 0, 0x12, 0x34, 0x56]);
    assert_eq!(get(0xF6, 4).0.status, GeneralStatus::AttributeNotSupported);
    let (h, d) = get(0x02, 1);
    ok(&h);
    assert_eq!(&d[..2], &[6, 0]);
    let (h, _) = ask(
        &mut a,
        1,
        s,
        &mr(
            Service::SetAttributeSingle,
            &[0x20, 0xF5, 0x24, 0x01, 0x30, 0x05],
            &[0; 22],
        ),
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(h.status, GeneralStatus::AttributeNotSettable);
}

#[test]
fn a_reply_too_large_for_the_buffer_is_an_error_reply() {
    let mut a = adapter();
    let mut app = TestApp::new();
    let s = register(&mut a, 1, &mut app);
    let req = mr(Service::GetAttributesAll, &[0x20, 0x01, 0x24, 0x01], &[]);
    let pkt = encap(Command::SendRrData, s, &rr_data(&req, None));
    let mut framer = Framer::<600>::new();
    framer.push(&pkt);
    let frame = framer.frame().unwrap();
    // Header 24 + prefix 6 + CPF 10 + MR header 4 = 44: room for the error, not the data.
    let mut out = [0u8; 50];
    let TcpAction::Reply(n) =
        a.handle_tcp(LinkId(1), PEER, frame, Instant::ZERO, &mut app, &mut out)
    else {
        panic!("a reply");
    };
    let (h, d) = rr_response(&out[..n]);
    assert_eq!(h.status, GeneralStatus::ReplyDataTooLarge);
    assert!(d.is_empty());
    // A buffer that cannot hold even the header: nothing is sent.
    framer.push(&pkt);
    let frame = framer.frame().unwrap();
    assert_eq!(
        a.handle_tcp(
            LinkId(1),
            PEER,
            frame,
            Instant::ZERO,
            &mut app,
            &mut [0u8; 20]
        ),
        TcpAction::None
    );
}

#[test]
fn sender_context_and_session_are_echoed() {
    let mut a = adapter();
    let mut app = TestApp::new();
    let s = register(&mut a, 1, &mut app);
    let req = mr(
        Service::GetAttributeSingle,
        &[0x20, 0x01, 0x24, 0x01, 0x30, 0x01],
        &[],
    );
    let r = one(
        &mut a,
        1,
        &encap(Command::SendRrData, s, &rr_data(&req, None)),
        Instant::ZERO,
        &mut app,
    );
    let h = Header::parse(&r).unwrap();
    assert_eq!(
        (h.command, h.session, h.context, h.options),
        (Command::SendRrData, s, *b"testctx!", 0)
    );
    let sd = SendDataRepr::parse(&r[HEADER_LEN..]).unwrap();
    assert_eq!((sd.interface, sd.timeout), (0, 0));
    let _ = (CpfWriter::begin, Writer::new);
}
