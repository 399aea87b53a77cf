//! Forward_Open, class 1 I/O, watchdogs, Forward_Close and class 3, in
//! virtual time.

mod common;
use common::*;

use core::net::{Ipv4Addr, SocketAddrV4};

use hans_enip::wire::cip::{GeneralStatus, Service};
use hans_enip::wire::conn_mgr::{
    ConnectionType, ExtendedStatus, ForwardOpen, ForwardOpenReply, Transport, Triad,
};
use hans_enip::wire::cpf::{Cpf, CpfWriter, ItemType};
use hans_enip::wire::encap::{Command, Header, HEADER_LEN};
use hans_enip::wire::io::IoPacket;
use hans_enip::wire::session::SendDataRepr;
use hans_enip::wire::Writer;
use hans_enip::*;

const MS: u64 = 1000;

fn t(us: u64) -> Instant {
    Instant::from_micros(us)
}

/// Opens a connection; its reply.
fn open(
    a: &mut TestAdapter,
    s: u32,
    fo: &ForwardOpen<'_>,
    now: Instant,
    app: &mut TestApp,
) -> ForwardOpenReply {
    let (h, d) = ask(a, 1, s, &fo_request(fo), now, app);
    ok(&h);
    ForwardOpenReply::parse(&d).unwrap()
}

/// A refused Forward_Open: its extended status and second word.
fn refused(
    a: &mut TestAdapter,
    s: u32,
    fo: &ForwardOpen<'_>,
    app: &mut TestApp,
) -> (ExtendedStatus, Option<u16>) {
    let (h, d) = ask(a, 1, s, &fo_request(fo), Instant::ZERO, app);
    assert_eq!(h.status, GeneralStatus::ConnectionFailure, "{h:?}");
    let t = fo.triad;
    let mut want = Vec::new();
    want.extend(t.serial.to_le_bytes());
    want.extend(t.vendor.to_le_bytes());
    want.extend(t.originator_serial.to_le_bytes());
    want.extend([0, 0]);
    assert_eq!(d, want, "the failure reply carries the triad");
    (
        ExtendedStatus::from(h.additional[0]),
        h.additional.get(1).copied(),
    )
}

fn setup() -> (TestAdapter, TestApp, u32) {
    let mut a = adapter();
    let mut app = TestApp::new();
    let s = register(&mut a, 1, &mut app);
    (a, app, s)
}

#[test]
fn exclusive_owner_opens_and_is_announced() {
    let (mut a, mut app, s) = setup();
    let fo = fo_owner(1, 10_000, 2);
    let r = open(&mut a, s, &fo, Instant::ZERO, &mut app);
    assert_eq!(
        r.t_o_id, fo.t_o_id,
        "point to point T->O: the originator's id"
    );
    assert_ne!(r.o_t_id, 0);
    assert_eq!((r.o_t_api, r.t_o_api), (10_000, 10_000));
    assert_eq!(r.triad, fo.triad);
    assert_eq!(
        app.events,
        [Event::Opened {
            connection: ConnectionId(r.o_t_id),
            kind: ConnectionKind::ExclusiveOwner,
            output: Some(OUTPUT),
            input: Some(INPUT),
            originator: PEER,
        }]
    );
    let info = a.connections().next().unwrap();
    assert_eq!(info.timeout_us, 10_000 * 16);
    assert_eq!(info.destination, SocketAddrV4::new(PEER, 2222));
    // Large_Forward_Open works the same.
    let large = ForwardOpen {
        large: true,
        ..fo_owner(2, 20_000, 0)
    };
    let fo_in = ForwardOpen {
        o_t_params: p2p(2),
        path: &[
            0x20,
            0x04,
            0x24,
            CONFIG as u8,
            0x2C,
            HEARTBEAT_IN as u8,
            0x2C,
            INPUT as u8,
        ],
        ..large
    };
    let r = open(&mut a, s, &fo_in, Instant::ZERO, &mut app);
    assert_eq!(r.t_o_api, 20_000);
    assert_eq!(a.connections().count(), 2);
}

#[test]
fn every_refusal_has_its_extended_status() {
    let (mut a, mut app, s) = setup();
    let base = fo_owner(1, 10_000, 0);
    let with_path = |path: &'static [u8]| ForwardOpen { path, ..base };
    use ExtendedStatus::*;
    // Sizes: the second word is the size that would be accepted.
    assert_eq!(
        refused(
            &mut a,
            s,
            &ForwardOpen {
                o_t_params: p2p(SIZE + 2),
                ..base
            },
            &mut app
        ),
        (InvalidOToTSize, Some(SIZE + 6))
    );
    assert_eq!(
        refused(
            &mut a,
            s,
            &ForwardOpen {
                t_o_params: p2p(SIZE + 6),
                ..base
            },
            &mut app
        ),
        (InvalidTToOSize, Some(SIZE + 2))
    );
    // RPI under 2 ms and over 10 s.
    assert_eq!(
        refused(
            &mut a,
            s,
            &ForwardOpen {
                o_t_rpi: 1_999,
                ..base
            },
            &mut app
        )
        .0,
        RpiNotSupported
    );
    assert_eq!(
        refused(
            &mut a,
            s,
            &ForwardOpen {
                t_o_rpi: 10_000_001,
                ..base
            },
            &mut app
        )
        .0,
        RpiNotSupported
    );
    // Electronic keys.
    let key = |v: u16, d: u16, p: u16, major: u8, minor: u8| {
        let mut path = vec![0x34, 0x04];
        path.extend(v.to_le_bytes());
        path.extend(d.to_le_bytes());
        path.extend(p.to_le_bytes());
        path.extend([
            major,
            minor,
            0x20,
            0x04,
            0x24,
            CONFIG as u8,
            0x2C,
            OUTPUT as u8,
            0x2C,
            INPUT as u8,
        ]);
        &*Box::leak(path.into_boxed_slice())
    };
    assert_eq!(
        refused(&mut a, s, &with_path(key(VENDOR + 1, 0, 0, 0, 0)), &mut app).0,
        VendorOrProductMismatch
    );
    assert_eq!(
        refused(
            &mut a,
            s,
            &with_path(key(0, 0, PRODUCT + 1, 0, 0)),
            &mut app
        )
        .0,
        VendorOrProductMismatch
    );
    assert_eq!(
        refused(
            &mut a,
            s,
            &with_path(key(VENDOR, DEVICE_TYPE + 1, PRODUCT, 0, 0)),
            &mut app
        )
        .0,
        DeviceTypeMismatch
    );
    assert_eq!(
        refused(
            &mut a,
            s,
            &with_path(key(VENDOR, DEVICE_TYPE, PRODUCT, 2, 1)),
            &mut app
        )
        .0,
        RevisionMismatch
    );
    assert_eq!(
        refused(
            &mut a,
            s,
            &with_path(key(VENDOR, DEVICE_TYPE, PRODUCT, 0x81, 4)),
            &mut app
        )
        .0,
        RevisionMismatch
    );
    // Paths: a route segment, unknown points, one point only, another class, bad config data.
    assert_eq!(
        refused(
            &mut a,
            s,
            &with_path(&[0x01, 0x00, 0x20, 0x04, 0x24, 0x97, 0x2C, 0x96, 0x2C, 0x64]),
            &mut app
        )
        .0,
        InvalidSegment
    );
    assert_eq!(
        refused(
            &mut a,
            s,
            &with_path(&[0x20, 0x04, 0x24, 0x97, 0x2C, 0x96, 0x2C, 0x65]),
            &mut app
        )
        .0,
        InvalidApplicationPath
    );
    assert_eq!(
        refused(
            &mut a,
            s,
            &with_path(&[0x20, 0x04, 0x24, 0x97, 0x2C, 0x64]),
            &mut app
        )
        .0,
        InvalidApplicationPath
    );
    assert_eq!(
        refused(
            &mut a,
            s,
            &with_path(&[0x20, 0x05, 0x24, 0x97, 0x2C, 0x96, 0x2C, 0x64]),
            &mut app
        )
        .0,
        InvalidApplicationPath
    );
    assert_eq!(
        refused(
            &mut a,
            s,
            &with_path(&[0x20, 0x04, 0x24, 0x97, 0x2C, 0x96, 0x2C, 0x64, 0x80, 0x01, 1, 2]),
            &mut app
        )
        .0,
        InvalidConfigurationPath
    );
    assert_eq!(
        refused(&mut a, s, &with_path(&[0x24, 0x01, 0x20, 0x04]), &mut app).0,
        InvalidSegment
    );
    // Multicast T->O, a null O->T.
    let mut mc = p2p(SIZE + 2);
    mc.kind = ConnectionType::Multicast;
    assert_eq!(
        refused(
            &mut a,
            s,
            &ForwardOpen {
                t_o_params: mc,
                ..base
            },
            &mut app
        )
        .0,
        InvalidConnectionType
    );
    mc.kind = ConnectionType::Null;
    assert_eq!(
        refused(
            &mut a,
            s,
            &ForwardOpen {
                o_t_params: mc,
                ..base
            },
            &mut app
        )
        .0,
        InvalidConnectionType
    );
    // Transport class 0 and a change-of-state trigger; a multiplier over 7.
    assert_eq!(
        refused(
            &mut a,
            s,
            &ForwardOpen {
                transport: Transport {
                    server: false,
                    trigger: 0,
                    class: 0
                },
                ..base
            },
            &mut app
        )
        .0,
        TransportNotSupported
    );
    assert_eq!(
        refused(
            &mut a,
            s,
            &ForwardOpen {
                transport: Transport {
                    server: false,
                    trigger: 1,
                    class: 1
                },
                ..base
            },
            &mut app
        )
        .0,
        TransportNotSupported
    );
    assert_eq!(
        refused(
            &mut a,
            s,
            &ForwardOpen {
                multiplier: 8,
                ..base
            },
            &mut app
        )
        .0,
        ParameterError
    );
    // Listen-only before any owner of the input.
    let listen = ForwardOpen {
        o_t_params: p2p(2),
        path: &[0x20, 0x04, 0x24, 0x97, 0x2C, 0xC7, 0x2C, 0x64],
        ..base
    };
    assert_eq!(
        refused(&mut a, s, &listen, &mut app).0,
        NonListenOnlyNotOpen
    );
    // Class 3 larger than 504 bytes.
    let class3 = ForwardOpen {
        o_t_params: p2p(505),
        t_o_params: p2p(504),
        transport: Transport {
            server: true,
            trigger: 2,
            class: 3,
        },
        path: &[0x20, 0x02, 0x24, 0x01],
        ..base
    };
    assert_eq!(
        refused(&mut a, s, &class3, &mut app),
        (InvalidConnectionSize, Some(504))
    );
    assert!(a.connections().next().is_none(), "nothing opened");
    assert!(app.events.is_empty());

    // Now open one; a second with the same triad, a second owner, a full table.
    open(&mut a, s, &base, Instant::ZERO, &mut app);
    assert_eq!(refused(&mut a, s, &base, &mut app).0, ConnectionInUse);
    assert_eq!(
        refused(&mut a, s, &fo_owner(2, 10_000, 0), &mut app).0,
        OwnershipConflict
    );
    open(
        &mut a,
        s,
        &ForwardOpen {
            triad: Triad {
                serial: 3,
                ..base.triad
            },
            ..listen
        },
        Instant::ZERO,
        &mut app,
    );
    let input_only = ForwardOpen {
        o_t_params: p2p(6),
        path: &[0x20, 0x04, 0x24, 0x97, 0x2C, 0xC6, 0x2C, 0x64],
        ..base
    };
    open(
        &mut a,
        s,
        &ForwardOpen {
            triad: Triad {
                serial: 4,
                ..base.triad
            },
            ..input_only
        },
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(
        refused(
            &mut a,
            s,
            &ForwardOpen {
                triad: Triad {
                    serial: 5,
                    ..base.triad
                },
                ..input_only
            },
            &mut app
        )
        .0,
        OutOfConnections
    );
    // Heartbeat sizes other than 0, 2, 6.
    let (mut a, mut app, s) = setup();
    assert_eq!(
        refused(
            &mut a,
            s,
            &ForwardOpen {
                o_t_params: p2p(4),
                ..input_only
            },
            &mut app
        ),
        (InvalidOToTSize, Some(2))
    );
}

/// The T->O datagrams `poll` gives at `now`.
fn produce(a: &mut TestAdapter, now: Instant, app: &mut TestApp) -> Vec<(SocketAddrV4, Vec<u8>)> {
    let mut out = Vec::new();
    let mut buf = [0u8; 600];
    while let Some((dest, n)) = a.poll(now, app, &mut buf) {
        out.push((dest, buf[..n].to_vec()));
        assert!(out.len() < 100, "poll must run dry");
    }
    out
}

#[test]
fn t_o_production_at_the_rpi_with_increasing_sequence_numbers() {
    let (mut a, mut app, s) = setup();
    let fo = fo_owner(1, 10_000, 3);
    let dest = SocketAddrV4::new(Ipv4Addr::UNSPECIFIED, 50_000);
    let r = one(
        &mut a,
        1,
        &encap(
            Command::SendRrData,
            s,
            &rr_data(&fo_request(&fo), Some(dest)),
        ),
        Instant::ZERO,
        &mut app,
    );
    let (h, _) = rr_response(&r);
    ok(&h);
    let mut seen = Vec::new();
    let mut now = 0;
    // 100 ms of virtual time, run as the gateway would: wake at poll_at.
    while now <= 100 * MS {
        for (to, pkt) in produce(&mut a, t(now), &mut app) {
            assert_eq!(
                to,
                SocketAddrV4::new(PEER, 50_000),
                "sent to the originator's address at its port"
            );
            let p = IoPacket::parse(&pkt).unwrap();
            assert_eq!(p.connection_id, fo.t_o_id);
            assert_eq!(p.data.len(), SIZE as usize, "no run/idle header T->O");
            seen.push((now, p.sequence, p.sequence_count));
        }
        // Keep the connection alive.
        let oid = a.connections().next().unwrap().id.0;
        let n = (now / (10 * MS)) as u32 + 1;
        a.handle_io(
            from_peer(),
            &o_t(oid, n, n as u16, true, &[n as u8; 8]),
            t(now),
            &mut app,
        );
        now = a.poll_at().unwrap().as_micros();
    }
    assert_eq!(seen.len(), 11, "{seen:?}");
    for (i, (at, seq, count)) in seen.iter().enumerate() {
        assert_eq!(*at, i as u64 * 10 * MS, "one datagram per RPI");
        assert_eq!(*seq, i as u32 + 1);
        assert_eq!(*count, i as u16 + 1);
    }
    // A late poll sends once, not once per missed interval.
    assert_eq!(produce(&mut a, t(135 * MS), &mut app).len(), 1);
    assert_eq!(produce(&mut a, t(136 * MS), &mut app).len(), 0);
    assert_eq!(produce(&mut a, t(145 * MS), &mut app).len(), 1);
    // The T->O data is what the application gives: input = output echoed.
    let p = produce(&mut a, t(160 * MS), &mut app);
    let p = IoPacket::parse(&p[0].1).unwrap();
    assert_eq!(&p.data[..7], &[11; 7]);
}

#[test]
fn o_t_data_reaches_the_application_and_run_idle_is_reported() {
    let (mut a, mut app, s) = setup();
    let r = open(&mut a, s, &fo_owner(1, 10_000, 0), Instant::ZERO, &mut app);
    let id = r.o_t_id;
    let io =
        |a: &mut TestAdapter, app: &mut TestApp, seq: u32, count: u16, run: bool, data: &[u8]| {
            a.handle_io(
                from_peer(),
                &o_t(id, seq, count, run, data),
                t(u64::from(seq) * MS),
                app,
            )
        };
    assert_eq!(
        io(&mut a, &mut app, 1, 1, false, &[1; 8]),
        IoOutcome::Consumed
    );
    assert_eq!(app.output, [1; 8]);
    assert_eq!(
        io(&mut a, &mut app, 2, 2, true, &[2; 8]),
        IoOutcome::Consumed
    );
    assert_eq!(
        io(&mut a, &mut app, 3, 2, true, &[3; 8]),
        IoOutcome::Consumed
    );
    assert_eq!(app.output, [2; 8], "same sequence count: no new data");
    assert_eq!(io(&mut a, &mut app, 3, 3, true, &[3; 8]), IoOutcome::Stale);
    assert_eq!(io(&mut a, &mut app, 2, 3, true, &[3; 8]), IoOutcome::Stale);
    assert_eq!(
        io(&mut a, &mut app, 6, 3, true, &[6; 8]),
        IoOutcome::Consumed
    );
    assert_eq!(app.output, [6; 8]);
    assert_eq!(
        io(&mut a, &mut app, 7, 4, true, &[6; 7]),
        IoOutcome::WrongSize
    );
    assert_eq!(
        io(&mut a, &mut app, 7, 4, true, &[6; 9]),
        IoOutcome::WrongSize
    );
    assert_eq!(
        a.handle_io(
            SocketAddrV4::new(Ipv4Addr::new(127, 0, 0, 9), 2222),
            &o_t(id, 7, 4, true, &[7; 8]),
            t(7),
            &mut app
        ),
        IoOutcome::WrongSource
    );
    assert_eq!(
        a.handle_io(
            from_peer(),
            &o_t(id ^ 1, 7, 4, true, &[7; 8]),
            t(7),
            &mut app
        ),
        IoOutcome::UnknownConnection
    );
    assert_eq!(
        a.handle_io(from_peer(), &[1, 2, 3], t(7), &mut app),
        IoOutcome::Malformed
    );
    let info = a.connections().next().unwrap();
    assert_eq!((info.received, info.missed, info.run), (4, 2, Some(true)));
    assert_eq!(a.io_missed(), 2, "the adapter's total");
    let runs: Vec<_> = app
        .events
        .iter()
        .filter_map(|e| match e {
            Event::RunIdle { run, .. } => Some(*run),
            _ => None,
        })
        .collect();
    assert_eq!(runs, [false, true]);
    // The identity status follows: owned, I/O running.
    let (h, d) = ask(
        &mut a,
        1,
        s,
        &mr(
            Service::GetAttributeSingle,
            &[0x20, 0x01, 0x24, 0x01, 0x30, 0x05],
            &[],
        ),
        Instant::ZERO,
        &mut app,
    );
    ok(&h);
    assert_eq!(d, 0x0065u16.to_le_bytes());
}

#[test]
fn the_watchdog_closes_at_rpi_times_the_multiplier() {
    for multiplier in [0u8, 1, 3, 7] {
        let (mut a, mut app, s) = setup();
        let rpi = 10_000u64;
        let r = open(
            &mut a,
            s,
            &fo_owner(1, rpi as u32, multiplier),
            Instant::ZERO,
            &mut app,
        );
        let timeout = rpi * (4 << multiplier);
        // Data for a while, then the scanner stops at 50 ms.
        let mut seq = 0;
        for now in (0..=50 * MS).step_by(10 * MS as usize) {
            seq += 1;
            assert_eq!(
                a.handle_io(
                    from_peer(),
                    &o_t(r.o_t_id, seq, seq as u16, true, &[0; 8]),
                    t(now),
                    &mut app
                ),
                IoOutcome::Consumed
            );
            produce(&mut a, t(now), &mut app);
        }
        let last = 50 * MS;
        produce(&mut a, t(last + timeout - 1), &mut app);
        assert_eq!(a.connections().count(), 1, "open just before the timeout");
        assert!(a.poll_at().unwrap() <= t(last + timeout));
        produce(&mut a, t(last + timeout), &mut app);
        assert_eq!(
            a.connections().count(),
            0,
            "closed at the timeout (multiplier {multiplier})"
        );
        assert_eq!(
            app.events.last(),
            Some(&Event::Closed {
                connection: ConnectionId(r.o_t_id),
                kind: ConnectionKind::ExclusiveOwner,
                reason: CloseReason::TimedOut
            })
        );
        assert_eq!(a.poll_at(), None);
        // Data after the close is for no connection.
        assert_eq!(
            a.handle_io(
                from_peer(),
                &o_t(r.o_t_id, 99, 99, true, &[0; 8]),
                t(last + timeout),
                &mut app
            ),
            IoOutcome::UnknownConnection
        );
    }
}

#[test]
fn a_half_open_forward_open_is_freed_at_the_first_packet_timeout() {
    let (mut a, mut app, s) = setup();
    // Fill the table with connections that never send O->T data.
    let input_only = |serial| ForwardOpen {
        o_t_params: p2p(2),
        path: &[0x20, 0x04, 0x24, 0x97, 0x2C, 0xC6, 0x2C, 0x64],
        ..fo_owner(serial, 2_000, 0)
    };
    for serial in 1..=3 {
        open(&mut a, s, &input_only(serial), t(serial as u64), &mut app);
    }
    let (h, d) = ask(&mut a, 1, s, &fo_request(&input_only(4)), t(5), &mut app);
    assert_eq!(
        (h.status, h.additional[0]),
        (GeneralStatus::ConnectionFailure, 0x0113)
    );
    let _ = d;
    // 8 ms x 4 = 8 ms would be the timeout; the first packet gets 10 s.
    produce(&mut a, t(10_000_000), &mut app);
    assert_eq!(
        a.connections().count(),
        3,
        "opened at 1, 2 and 3 us: all open at 10 s"
    );
    produce(&mut a, t(10_000_001), &mut app);
    assert_eq!(
        a.connections().count(),
        2,
        "the first one expires at 10 s + 1 us"
    );
    produce(&mut a, t(10_000_003), &mut app);
    assert_eq!(a.connections().count(), 0);
    let timed_out = app
        .events
        .iter()
        .filter(|e| {
            matches!(
                e,
                Event::Closed {
                    reason: CloseReason::TimedOut,
                    ..
                }
            )
        })
        .count();
    assert_eq!(timed_out, 3);
    open(&mut a, s, &input_only(4), t(10_000_003), &mut app);
}

#[test]
fn forward_close_closes_and_checks_the_triad_and_originator() {
    let (mut a, mut app, s) = setup();
    let fo = fo_owner(1, 10_000, 0);
    let r = open(&mut a, s, &fo, Instant::ZERO, &mut app);
    let (h, d) = ask(
        &mut a,
        1,
        s,
        &fc_request(Triad {
            serial: 2,
            ..fo.triad
        }),
        Instant::ZERO,
        &mut app,
    );
    assert_eq!(
        (h.status, h.additional[0]),
        (GeneralStatus::ConnectionFailure, 0x0107)
    );
    assert_eq!(&d[..2], &[2, 0]);
    // Another host on another TCP connection cannot close it.
    let mut other_framer = Framer::<600>::new();
    let s2 = register(&mut a, 2, &mut app);
    let pkt = encap(
        Command::SendRrData,
        s2,
        &rr_data(&fc_request(fo.triad), None),
    );
    other_framer.push(&pkt);
    let mut buf = [0u8; 600];
    let TcpAction::Reply(n) = a.handle_tcp(
        LinkId(2),
        Ipv4Addr::new(127, 0, 0, 66),
        other_framer.frame().unwrap(),
        Instant::ZERO,
        &mut app,
        &mut buf,
    ) else {
        panic!()
    };
    let (h, _) = rr_response(&buf[..n]);
    assert_eq!(h.additional[0], 0x0107);
    // Its originator can.
    let (h, d) = ask(&mut a, 1, s, &fc_request(fo.triad), Instant::ZERO, &mut app);
    ok(&h);
    assert_eq!(d, [1, 0, 1, 0, 0xFE, 0xCA, 0xAD, 0x0B, 0, 0]);
    assert_eq!(a.connections().count(), 0);
    assert_eq!(
        app.events.last(),
        Some(&Event::Closed {
            connection: ConnectionId(r.o_t_id),
            kind: ConnectionKind::ExclusiveOwner,
            reason: CloseReason::ForwardClose
        })
    );
    assert!(
        produce(&mut a, t(10 * MS), &mut app).is_empty(),
        "no production after the close"
    );
}

fn unit_data(session: u32, id: u32, seq: u16, request: &[u8]) -> Vec<u8> {
    let mut buf = vec![0u8; 600];
    let mut w = Writer::new(&mut buf);
    SendDataRepr::emit_prefix(0, 0, &mut w).unwrap();
    let mut c = CpfWriter::begin(&mut w).unwrap();
    c.item(&mut w, ItemType::ConnectedAddress, &id.to_le_bytes())
        .unwrap();
    let mut data = seq.to_le_bytes().to_vec();
    data.extend_from_slice(request);
    c.item(&mut w, ItemType::ConnectedData, &data).unwrap();
    let n = w.len();
    encap(Command::SendUnitData, session, &buf[..n])
}

#[test]
fn class_3_connected_messaging() {
    let (mut a, mut app, s) = setup();
    let fo = ForwardOpen {
        o_t_params: p2p(504),
        t_o_params: p2p(504),
        transport: Transport {
            server: true,
            trigger: 2,
            class: 3,
        },
        path: &[0x20, 0x02, 0x24, 0x01],
        t_o_id: 0x5555,
        ..fo_owner(9, 2_000_000, 1)
    };
    let r = open(&mut a, s, &fo, Instant::ZERO, &mut app);
    let get = mr(
        Service::GetAttributeSingle,
        &[0x20, 0x01, 0x24, 0x01, 0x30, 0x03],
        &[],
    );
    let reply = one(&mut a, 1, &unit_data(s, r.o_t_id, 7, &get), t(MS), &mut app);
    let h = Header::parse(&reply).unwrap();
    assert_eq!(h.command, Command::SendUnitData);
    let sd = SendDataRepr::parse(&reply[HEADER_LEN..]).unwrap();
    let cpf = Cpf::parse(sd.cpf).unwrap();
    assert_eq!(cpf.get(0).unwrap().kind, ItemType::ConnectedAddress);
    assert_eq!(cpf.get(0).unwrap().data, &0x5555u32.to_le_bytes());
    let data = cpf.get(1).unwrap().data;
    assert_eq!(&data[..2], &[7, 0], "the sequence count echoed");
    assert_eq!(&data[2..], &[0x8E, 0, 0, 0, 0x42, 0]);
    // Unknown connection, or another TCP connection's: dropped.
    assert_eq!(
        feed(
            &mut a,
            1,
            &unit_data(s, r.o_t_id ^ 1, 8, &get),
            t(MS),
            &mut app
        ),
        vec![Err(TcpAction::None)]
    );
    let s2 = register(&mut a, 2, &mut app);
    assert_eq!(
        feed(
            &mut a,
            2,
            &unit_data(s2, r.o_t_id, 8, &get),
            t(MS),
            &mut app
        ),
        vec![Err(TcpAction::None)]
    );
    // Malformed items: incorrect data.
    let bad = encap(
        Command::SendUnitData,
        s,
        &[0, 0, 0, 0, 0, 0, 1, 0, 0xA1, 0, 4, 0, 1, 2, 3, 4],
    );
    let reply = one(&mut a, 1, &bad, t(MS), &mut app);
    assert_eq!(
        Header::parse(&reply).unwrap().status,
        hans_enip::wire::encap::Status::IncorrectData
    );
    // Its watchdog: 2 s x 8, restarted by each request.
    produce(&mut a, t(MS + 16_000_000 - 1), &mut app);
    assert_eq!(a.connections().count(), 1);
    // The TCP connection closes: so does the class 3 connection.
    a.tcp_closed(LinkId(1), t(2 * MS), &mut app);
    assert_eq!(a.connections().count(), 0);
    assert_eq!(
        app.events.last(),
        Some(&Event::Closed {
            connection: ConnectionId(r.o_t_id),
            kind: ConnectionKind::Explicit,
            reason: CloseReason::LinkClosed
        })
    );
}

#[test]
fn class_1_connections_outlive_their_tcp_connection() {
    let (mut a, mut app, s) = setup();
    open(&mut a, s, &fo_owner(1, 10_000, 0), Instant::ZERO, &mut app);
    a.tcp_closed(LinkId(1), Instant::ZERO, &mut app);
    assert_eq!(a.connections().count(), 1);
    assert_eq!(a.session_count(), 0);
}

#[test]
fn configuration_data_goes_to_the_config_assembly() {
    let (mut a, mut app, s) = setup();
    let fo = ForwardOpen {
        path: &[
            0x20,
            0x04,
            0x24,
            CONFIG as u8,
            0x2C,
            OUTPUT as u8,
            0x2C,
            INPUT as u8,
            0x80,
            0x02,
            9,
            8,
            7,
            6,
        ],
        ..fo_owner(1, 10_000, 0)
    };
    open(&mut a, s, &fo, Instant::ZERO, &mut app);
    assert_eq!(app.config, [9, 8, 7, 6]);
}
