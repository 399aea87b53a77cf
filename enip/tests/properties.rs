//! Properties over generated inputs: the framer does not care how the
//! stream is cut, the adapter answers any stream with well-formed packets
//! within its bounds, and the wire formats read back what they write.

mod common;
use common::*;

use proptest::prelude::*;

use hans_enip::wire::cip::{AppPath, Service};
use hans_enip::wire::conn_mgr::{ConnectionType, ForwardOpen, NetParams, Transport, Triad};
use hans_enip::wire::encap::{Command, Header, HEADER_LEN};
use hans_enip::wire::epath::{segments, LogicalType, Segment};
use hans_enip::wire::Writer;
use hans_enip::*;

/// Packets: mostly valid headers with random commands, lengths and data.
fn stream() -> impl Strategy<Value = Vec<u8>> {
    let packet = (
        prop::sample::select(vec![
            0x00u16, 0x04, 0x63, 0x64, 0x65, 0x66, 0x6F, 0x70, 0x01, 0xFF,
        ]),
        prop::collection::vec(any::<u8>(), 0..80),
        any::<u32>(),
        prop::bool::weighted(0.1),
    )
        .prop_map(|(cmd, data, session, options)| {
            let mut p = encap(Command::from(cmd), session % 4, &data);
            if options {
                p[20] = 1;
            }
            p
        });
    prop::collection::vec(packet, 0..12).prop_map(|ps| ps.concat())
}

fn frames_of(bytes: &[u8], cuts: &[usize]) -> Vec<(Header, Vec<u8>)> {
    let mut f = Framer::<64>::new();
    let mut out = Vec::new();
    let mut rest = bytes;
    let mut i = 0;
    while !rest.is_empty() {
        let piece = cuts
            .get(i)
            .copied()
            .unwrap_or(rest.len())
            .clamp(1, rest.len());
        i += 1;
        let mut chunk = &rest[..piece];
        rest = &rest[piece..];
        while !chunk.is_empty() {
            let n = f.push(chunk);
            chunk = &chunk[n..];
            match f.frame() {
                Some(Frame::Complete { header, data }) => out.push((header, data.to_vec())),
                Some(Frame::TooLong { header }) => out.push((header, b"too long".to_vec())),
                None => {}
            }
        }
    }
    out
}

proptest! {
    #[test]
    fn the_framer_does_not_care_how_the_stream_is_cut(s in stream(), cuts in prop::collection::vec(1usize..40, 0..60)) {
        prop_assert_eq!(frames_of(&s, &cuts), frames_of(&s, &[]));
    }

    #[test]
    fn any_stream_gets_well_formed_replies_within_bounds(s in stream(), step in 0u64..200_000) {
        let mut a = adapter();
        let mut app = TestApp::new();
        let mut f = Framer::<600>::new();
        let mut rest = &s[..];
        let mut now = 0;
        while !rest.is_empty() {
            let n = f.push(rest);
            rest = &rest[n..];
            let Some(frame) = f.frame() else { continue };
            let req = match frame { Frame::Complete { header, .. } | Frame::TooLong { header } => header };
            let mut out = [0u8; 1024];
            if let TcpAction::Reply(n) = a.handle_tcp(LinkId(1), PEER, frame, Instant::from_micros(now), &mut app, &mut out) {
                let h = Header::parse(&out[..n]).unwrap();
                prop_assert_eq!(usize::from(h.length), n - HEADER_LEN);
                prop_assert_eq!(h.command, req.command);
                prop_assert_eq!(h.context, req.context);
            }
            prop_assert!(a.session_count() <= 1, "one TCP connection, one session");
            now += step;
            let mut buf = [0u8; 128];
            while a.poll(Instant::from_micros(now), &mut app, &mut buf).is_some() {}
        }
    }

    #[test]
    fn forward_open_reads_back(
        large in any::<bool>(), ids in any::<(u32, u32)>(), triad in any::<(u16, u16, u32)>(),
        multiplier in any::<u8>(), rpis in any::<(u32, u32)>(), sizes in any::<(u16, u16)>(),
        kinds in (0u8..4, 0u8..4), transport in any::<u8>(), words in prop::collection::vec(any::<u16>(), 0..20),
    ) {
        let path: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
        let kind = |k| match k { 0 => ConnectionType::Null, 1 => ConnectionType::Multicast, 2 => ConnectionType::PointToPoint, _ => ConnectionType::Reserved };
        let params = |size: u16, k| NetParams {
            redundant_owner: size & 1 == 1, kind: kind(k), priority: (size >> 1) as u8 & 3, variable: size & 8 == 8,
            size: if large { size } else { size & 0x1FF },
        };
        let fo = ForwardOpen {
            large, priority_tick: 1, timeout_ticks: 2, o_t_id: ids.0, t_o_id: ids.1,
            triad: Triad { serial: triad.0, vendor: triad.1, originator_serial: triad.2 }, multiplier,
            o_t_rpi: rpis.0, o_t_params: params(sizes.0, kinds.0), t_o_rpi: rpis.1, t_o_params: params(sizes.1, kinds.1),
            transport: Transport::from(transport), path: &path,
        };
        let mut buf = [0u8; 128];
        let mut w = Writer::new(&mut buf);
        fo.emit(&mut w).unwrap();
        let n = w.len();
        prop_assert_eq!(ForwardOpen::parse(&buf[..n], large).unwrap(), fo);
    }

    #[test]
    fn logical_segments_and_paths_read_back(class in any::<u32>(), instance in any::<u32>(), attribute in prop::option::of(any::<u32>())) {
        let p = AppPath { class, instance, attribute };
        let mut buf = [0u8; 32];
        let mut w = Writer::new(&mut buf);
        p.emit(&mut w).unwrap();
        let n = w.len();
        prop_assert_eq!(AppPath::parse(&buf[..n]), Ok(p));
        let segs: Vec<_> = segments(&buf[..n]).collect::<Result<_, _>>().unwrap();
        prop_assert_eq!(segs[0], Segment::Logical { kind: LogicalType::Class, value: class });
    }

    #[test]
    fn any_request_is_answered_with_its_service(service in 0u8..0x7F, path in prop::collection::vec(any::<u8>(), 0..12), data in prop::collection::vec(any::<u8>(), 0..40)) {
        let mut a = adapter();
        let mut app = TestApp::new();
        let s = register(&mut a, 1, &mut app);
        let path = if path.len() % 2 == 1 { &path[1..] } else { &path[..] };
        let (h, _) = ask(&mut a, 1, s, &mr(Service::from(service), path, &data), Instant::ZERO, &mut app);
        prop_assert_eq!(u8::from(h.service), service);
    }
}

#[test]
fn net_params_read_back_for_every_value() {
    for v in 0..=u16::MAX {
        assert_eq!(
            NetParams::from_u16(v).to_u16(),
            v & !0x1000,
            "{v:#06x} (bit 12 is reserved)"
        );
    }
}
