//! DataSheet (chapter 5): sample payloads and property tests.
//!
//! * The sample payloads under `vectors/datasheet/` decode to the values
//!   written in them, through the deframer at every split point, and write
//!   back to a payload that decodes the same.
//! * The deframer: random bytes in random reads never panic and respect its
//!   bounds; valid packets mixed with garbage, bad headers and over-size
//!   packets all come out, in order, stripped, whatever the read splits.
//! * The decoder and tokenizer never panic on random or mutated payloads.
//! * Random `DataSheet`s survive `write_json` / `write_packet` → deframer →
//!   `parse` unchanged.

use hans_codec::datasheet::json::{Token, Tokenizer};
use hans_codec::datasheet::sheet::{
    MAX_AXIS_GROUPS, MAX_BOX_IO, MAX_END_AI, MAX_END_IO, MAX_SLAVES,
};
use hans_codec::datasheet::{
    self, BoxAnalogIo, BoxIo, DataSheet, DataSheetError, Deframer, EndIo, FtData, HardLoad,
    HeaderError, PosAndVel, Position, Script, StateAndError, HEADER_LEN, MAGIC,
};
use hans_codec::{Decimal, FsmState};
use proptest::prelude::*;

const STANDBY: &[u8] = include_bytes!("../vectors/datasheet/standby.json");
const DOCUMENT: &[u8] = include_bytes!("../vectors/datasheet/document-spellings.json");

/// Payload capacity of the deframer for the samples: real payloads are
/// ~2 KiB.
const CAP: usize = 4096;

/// Payload capacity of the deframer in the stream properties (small, so
/// over-size packets stay short and the cases fast).
const SMALL: usize = 256;

fn d(s: &str) -> Decimal {
    Decimal::parse(s).unwrap()
}

fn six(v: [&str; 6]) -> [Decimal; 6] {
    v.map(d)
}

/// Header + payload.
fn packet(payload: &[u8]) -> Vec<u8> {
    let mut v = vec![0; HEADER_LEN];
    datasheet::emit_header(payload.len(), &mut v).unwrap();
    v.extend_from_slice(payload);
    v
}

fn stripped(payload: &[u8]) -> Vec<u8> {
    payload
        .iter()
        .copied()
        .filter(|b| !matches!(b, 0 | b'\n' | b'\t'))
        .collect()
}

/// Everything the deframer yields for `input` read in pieces ending at
/// `cuts` (sorted offsets into `input`).
fn deframe<const N: usize>(
    d: &mut Deframer<N>,
    input: &[u8],
    cuts: &[usize],
) -> Vec<Result<Vec<u8>, HeaderError>> {
    let mut out = Vec::new();
    let mut start = 0;
    for &end in cuts.iter().chain(std::iter::once(&input.len())) {
        let end = end.clamp(start, input.len());
        d.feed(&input[start..end], |item| {
            out.push(item.map(<[u8]>::to_vec))
        });
        start = end;
    }
    out
}

// ---------------------------------------------------------------- sample payloads

#[test]
fn standby_sample_decodes_to_its_values() {
    let s = DataSheet::parse(STANDBY).unwrap();
    let p = &s.pos_and_vel;
    assert_eq!(
        p.position,
        Some(Position {
            joints: six(["0", "0", "90", "0", "90", "0"]),
            pose: Some(six(["420", "0", "445", "180", "0", "180"])),
        })
    );
    assert!(p.position.unwrap().pose.unwrap()[4].is_sign_negative());
    assert_eq!(p.pcs_tcp, Some(six(["420", "0", "445", "180", "0", "180"])));
    assert_eq!(p.pcs_base, p.pcs_tcp);
    assert_eq!(p.pcs_tool, None);
    assert_eq!(
        p.joint_current,
        Some(six([
            "-0.012", "1.804", "-0.937", "0.021", "-0.154", "0.003"
        ]))
    );
    assert_eq!(p.joint_velocity, Some([Decimal::ZERO; 6]));
    assert_eq!(p.override_ratio, Some(d("0.5")));

    assert_eq!(s.end_io.end_di.as_slice(), &[0, 0, 0, 0]);
    assert_eq!(s.end_io.end_do.as_slice(), &[0, 1, 0, 0]);
    assert_eq!(s.end_io.end_button.as_slice(), &[1, 1, 1, 1]);
    assert_eq!(s.end_io.enable_end_btn, Some(0));
    assert_eq!(s.end_io.end_ai.as_slice(), &[Decimal::ZERO; 2]);

    assert_eq!(s.box_io.box_ci.len(), 9);
    assert_eq!(s.box_io.box_co.len(), 9);
    assert_eq!(s.box_io.box_di.as_slice(), &[1, 0, 0, 0, 0, 0, 0, 0, 0]);
    assert_eq!(s.box_io.box_do.as_slice(), &[0, 0, 0, 0, 1, 0, 0, 0]);
    assert_eq!(s.box_io.conveyor, Some(Decimal::ZERO));
    assert_eq!(s.box_io.encode, Some(0));

    assert_eq!(
        s.box_analog_io,
        BoxAnalogIo {
            out_mode: [Some(1), Some(0)],
            out: [Some(d("5")), Some(Decimal::ZERO)],
            input: [Some(d("-12.5")), Some(d("-12.5"))],
        }
    );

    let st = &s.state;
    assert_eq!(st.robot_state, Some(FsmState::StandBy));
    assert_eq!(
        (
            st.enabled,
            st.paused,
            st.moving,
            st.blending_done,
            st.in_pos
        ),
        (Some(true), Some(false), Some(false), Some(true), Some(true))
    );
    assert_eq!((st.error_axis_id, st.error_code), (Some(0), Some(0)));
    assert_eq!(st.brake_state, Some([1; 6]));
    assert_eq!(st.axis_status, Some([3; 6]));
    assert_eq!(st.axis_error_code, Some([0; 6]));
    assert_eq!(st.reset_safe_space.as_slice(), &[1]);
    assert_eq!(st.axis_group_status.as_slice(), &[0]);
    assert_eq!(st.axis_group_error_code.as_slice(), &[0]);

    let h = &s.hard_load;
    assert_eq!(h.ethercat_total_frame, Some(48_211_972));
    assert_eq!(h.ethercat_frames_per_second, Some(1000));
    assert_eq!(h.ethercat_total_lost_frame, Some(2));
    assert_eq!(h.ethercat_tx_error_frame, Some(0));
    assert_eq!(h.ethercat_rx_error_frame, Some(0));
    assert_eq!(h.box48_in_voltage, Some(d("48.12")));
    assert_eq!(h.box48_in_current, Some(d("0.85")));
    assert_eq!(h.box48_out_voltage, Some(d("47.96")));
    assert_eq!(h.box48_out_current, Some(d("0.79")));
    assert_eq!(
        h.slave_temperature.as_slice(),
        &[d("36.5"), d("37.25"), d("35")]
    );
    assert_eq!(
        h.slave_voltage.as_slice(),
        &[d("47.9"), d("47.88"), d("47.91")]
    );

    assert_eq!(
        s.ft,
        FtData {
            control_state: Some(0),
            data: Some([Decimal::ZERO; 6]),
            src_data: Some([Decimal::ZERO; 6]),
        }
    );
    assert_eq!(
        s.script,
        Script {
            error_code: Some(0)
        }
    );
}

#[test]
fn document_sample_decodes_despite_its_spellings() {
    let s = DataSheet::parse(DOCUMENT).unwrap();
    let p = s.pos_and_vel.position.unwrap();
    assert_eq!(p.joints, six(["10", "-20", "95.5", "0", "84.5", "-5"]));
    assert_eq!(p.pose, None);
    assert_eq!(
        s.pos_and_vel.pcs_tcp,
        Some(six(["401.25", "-35.117", "512.004", "179.998", "0", "175"]))
    );
    assert_eq!(
        s.pos_and_vel.joint_velocity,
        Some(six(["5", "-10", "2.75", "0", "-2.75", "0"]))
    );
    assert_eq!(s.pos_and_vel.override_ratio, Some(d("0.05")));
    // EndIO nested inside PosAndVel, as the document shows it.
    assert_eq!(s.end_io.end_button.as_slice(), &[1, 1, 1, 1]);
    assert_eq!(s.box_io.box_do.len(), 8);
    assert_eq!(s.box_analog_io.out_mode, [Some(0), Some(0)]);
    assert_eq!(s.box_analog_io.input, [Some(d("-12.5")), Some(d("-12.5"))]);
    assert_eq!(s.state.robot_state, Some(FsmState::Moving));
    assert_eq!(s.state.moving, Some(true));
    assert_eq!(s.state.blending_done, Some(false));
    assert_eq!(s.hard_load.box48_out_voltage, Some(d("48")));
    assert_eq!(s.hard_load.box48_out_current, Some(Decimal::ZERO));
    assert_eq!(s.script.error_code, Some(0));
}

#[test]
fn samples_survive_every_split_and_write_back() {
    for sample in [STANDBY, DOCUMENT] {
        let direct = DataSheet::parse(sample).unwrap();
        // Padding NULs after the JSON, counted in the payload, as some
        // servers send them.
        let mut payload = sample.to_vec();
        payload.extend_from_slice(&[0, 0]);
        let wire = packet(&payload);
        let want = stripped(sample);
        assert_eq!(DataSheet::parse(&want).unwrap(), direct);
        let mut d = Deframer::<CAP>::new();
        for cut in 0..=wire.len() {
            let items = deframe(&mut d, &wire, &[cut]);
            assert_eq!(items.len(), 1, "cut {cut}");
            assert_eq!(items[0].as_ref().unwrap(), &want, "cut {cut}");
        }
        assert_eq!(d.discarded(), 0);

        let mut out = [0u8; DataSheet::MAX_JSON_LEN];
        let n = direct.write_json(&mut out).unwrap();
        assert_eq!(DataSheet::parse(&out[..n]).unwrap(), direct);
    }
}

#[test]
fn standby_sample_writes_the_vendor_forms() {
    let s = DataSheet::parse(STANDBY).unwrap();
    let mut out = [0u8; DataSheet::MAX_JSON_LEN];
    let n = s.write_json(&mut out).unwrap();
    let text = std::str::from_utf8(&out[..n]).unwrap();
    assert!(text.starts_with(
        r#"{"PosAndVel":{"Actual_Position":["0.000","0.000","90.000","0.000","90.000","0.000","420.000","0.000","445.000","180.000","-0.000","180.000"],"#
    ));
    for part in [
        r#""Actual_Override":"0.500"}"#,
        r#""EndAI":[0.000,0.000]}"#,
        r#""BoxDO":[0,0,0,0,1,0,0,0],"Conveyor":"0.000","Encode":0}"#,
        r#""BoxAnalogIn_1":"-12.500","#,
        r#""StateAndError":{"robotState":33,"robotEnabled":1,"#,
        r#""Box48IN_Voltage":48.120,"#,
        r#""Script":{"errorCode":0}}"#,
    ] {
        assert!(text.contains(part), "{part} not in {text}");
    }
}

// ---------------------------------------------------------------- deframer properties

/// A piece of a byte stream.
#[derive(Clone, Debug)]
enum Piece {
    /// A good packet with this payload (may hold stripped bytes, has at
    /// least one other byte).
    Packet(Vec<u8>),
    /// A packet whose payload is over the deframer's capacity (text).
    Oversize(Vec<u8>),
    /// Bytes that are not a packet.
    Garbage(Vec<u8>),
}

fn payload() -> impl Strategy<Value = Vec<u8>> {
    (
        prop::collection::vec(any::<u8>(), 0..SMALL),
        any::<u8>().prop_filter("not stripped", |b| !matches!(b, 0 | b'\n' | b'\t')),
        any::<prop::sample::Index>(),
    )
        .prop_map(|(mut v, keep, at)| {
            let i = at.index(v.len() + 1);
            v.insert(i, keep);
            v
        })
}

fn garbage() -> impl Strategy<Value = Vec<u8>> {
    let header_like = (any::<u32>(), any::<u32>()).prop_map(|(t, p)| {
        let mut v = MAGIC.to_vec();
        v.extend_from_slice(&t.to_le_bytes());
        v.extend_from_slice(&p.to_le_bytes());
        v
    });
    let mismatched = (0u32..SMALL as u32, 1u32..50).prop_map(|(p, off)| {
        let mut v = MAGIC.to_vec();
        v.extend_from_slice(&(p + 12 + off).to_le_bytes());
        v.extend_from_slice(&p.to_le_bytes());
        v
    });
    let empty = Just({
        let mut v = MAGIC.to_vec();
        v.extend_from_slice(&12u32.to_le_bytes());
        v.extend_from_slice(&0u32.to_le_bytes());
        v
    });
    let fragment = (1usize..=4).prop_map(|n| MAGIC[..n].to_vec());
    let chunk = prop_oneof![
        4 => prop::collection::vec(any::<u8>(), 1..40),
        2 => fragment,
        1 => header_like,
        1 => mismatched,
        1 => empty,
    ];
    prop::collection::vec(chunk, 1..4).prop_map(|v| v.concat())
}

fn oversize() -> impl Strategy<Value = Vec<u8>> {
    prop::collection::vec(
        prop_oneof![8 => 0x20u8..0x7f, 1 => Just(b'\n'), 1 => Just(b'\t')],
        SMALL + 1..SMALL + 300,
    )
}

fn pieces() -> impl Strategy<Value = Vec<Piece>> {
    prop::collection::vec(
        prop_oneof![
            4 => payload().prop_map(Piece::Packet),
            1 => oversize().prop_map(Piece::Oversize),
            3 => garbage().prop_map(Piece::Garbage),
        ],
        0..8,
    )
}

/// Up to 12 read boundaries, anywhere in a stream (see [`at`]).
fn cuts() -> impl Strategy<Value = Vec<prop::sample::Index>> {
    prop::collection::vec(any::<prop::sample::Index>(), 0..12)
}

/// The boundaries as sorted offsets into a stream of `len` bytes.
fn at(cuts: &[prop::sample::Index], len: usize) -> Vec<usize> {
    let mut v: Vec<usize> = cuts.iter().map(|i| i.index(len + 1)).collect();
    v.sort_unstable();
    v
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Random bytes in random reads: no panic, bounds respected.
    #[test]
    fn deframer_survives_random_bytes(
        bytes in prop::collection::vec(any::<u8>(), 0..600),
        cut_points in cuts(),
    ) {
        let mut d = Deframer::<64>::new();
        for p in deframe(&mut d, &bytes, &at(&cut_points, bytes.len())).into_iter().flatten() {
            prop_assert!(!p.is_empty() && p.len() <= 64);
            prop_assert!(p.iter().all(|b| !matches!(b, 0 | b'\n' | b'\t')));
        }
        prop_assert!(d.pending() <= HEADER_LEN + 64);
        prop_assert!(d.discarded() <= bytes.len() as u64);
    }

    /// Every valid packet comes out, in order, whatever precedes it and
    /// however the stream is split; each over-size packet is reported.
    #[test]
    fn deframer_never_loses_a_valid_packet(
        pieces in pieces(),
        cut_points in cuts(),
    ) {
        let mut wire = Vec::new();
        let mut want = Vec::new();
        let mut oversize = 0;
        for p in &pieces {
            match p {
                Piece::Packet(payload) => {
                    wire.extend(packet(payload));
                    want.push(stripped(payload));
                }
                Piece::Oversize(payload) => {
                    wire.extend(packet(payload));
                    oversize += 1;
                }
                Piece::Garbage(g) => wire.extend_from_slice(g),
            }
        }
        let mut d = Deframer::<SMALL>::new();
        let items = deframe(&mut d, &wire, &at(&cut_points, wire.len()));
        let got: Vec<Vec<u8>> = items.iter().filter_map(|i| i.clone().ok()).collect();
        prop_assert_eq!(got, want);
        let too_large = items
            .iter()
            .filter(|i| matches!(i, Err(HeaderError::TooLarge { .. })))
            .count();
        prop_assert!(too_large >= oversize);
        // The same stream in one read gives the same items.
        let mut whole = Deframer::<SMALL>::new();
        prop_assert_eq!(deframe(&mut whole, &wire, &[]), items);
    }

    /// Random bytes never make the decoder or the tokenizer panic, and the
    /// tokenizer always ends.
    #[test]
    fn decoder_survives_random_bytes(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        let _ = DataSheet::parse(&bytes);
        let mut t = Tokenizer::new(&bytes);
        let mut steps = 0;
        while let Ok(Some(_)) = t.next_token() {
            steps += 1;
            prop_assert!(steps <= bytes.len());
        }
    }

    /// Mutations of a real payload (bytes replaced, inserted, removed) reach
    /// the decoder's deeper paths: no panic, and a field error points inside
    /// the payload.
    #[test]
    fn decoder_survives_mutated_samples(
        edits in prop::collection::vec(
            (any::<prop::sample::Index>(), any::<u8>(), 0u8..3),
            1..8,
        ),
        doc in any::<bool>(),
    ) {
        let mut bytes = if doc { DOCUMENT.to_vec() } else { STANDBY.to_vec() };
        for (at, b, kind) in edits {
            let i = at.index(bytes.len());
            match kind {
                0 => bytes[i] = b,
                1 => bytes.insert(i, b),
                _ => {
                    bytes.remove(i);
                }
            }
        }
        match DataSheet::parse(&bytes) {
            Err(DataSheetError::Field { offset, .. }) => prop_assert!(offset < bytes.len()),
            Err(DataSheetError::Json(e)) => prop_assert!(e.offset <= bytes.len()),
            _ => {}
        }
    }

    /// An unknown member, with an escaped name that the reader's short cuts
    /// do not take (it is looked up, read the tokenizer's way and skipped),
    /// changes nothing. On vendor-like payloads (random sheets as written,
    /// with whitespace, case changes and byte edits mixed in, and the
    /// samples edited): the same result to the last written digit, or both
    /// an error. (The codec's own tests compare the reader with a reference
    /// reader over the tokenizer's tokens, errors included.)
    #[test]
    fn an_unknown_member_changes_nothing(
        sheet in sheet(),
        sample in prop_oneof![Just(None), Just(Some(STANDBY)), Just(Some(DOCUMENT))],
        edits in prop::collection::vec(
            (any::<prop::sample::Index>(), any::<u8>(), 0u8..5),
            0..6,
        ),
    ) {
        let mut bytes = match sample {
            Some(sample) => sample.to_vec(),
            None => {
                let mut json = vec![0u8; 16 * 1024];
                let n = sheet.write_json(&mut json).unwrap();
                json.truncate(n);
                json
            }
        };
        for (at, b, kind) in edits {
            let i = at.index(bytes.len());
            match kind {
                0 => bytes[i] = b,
                1 => bytes.insert(i, b),
                2 => {
                    bytes.remove(i);
                }
                // Whitespace and ignored bytes, which the reader skips
                // between tokens.
                3 => bytes.insert(i, [b' ', b'\n', b'\t', b'\r', 0][usize::from(b % 5)]),
                _ => bytes[i] = bytes[i].to_ascii_uppercase(),
            }
        }
        let Some(open) = bytes.iter().position(|&b| b == b'{') else {
            return Ok(());
        };
        let mut with = bytes.clone();
        with.splice(open + 1..open + 1, br#""\u0078":0,"#.iter().copied());
        match (DataSheet::parse(&bytes), DataSheet::parse(&with)) {
            (Ok(a), Ok(b)) => prop_assert_eq!(format!("{a:?}"), format!("{b:?}")),
            (Err(_), Err(_)) => {}
            (a, b) => prop_assert!(false, "{:?} vs {:?} for {:?}", a, b, String::from_utf8_lossy(&bytes)),
        }
    }

    /// Random sheets: write → parse is the identity, as JSON and as packets
    /// through the deframer in random reads.
    #[test]
    fn random_sheets_round_trip(
        sheets in prop::collection::vec(sheet(), 1..4),
        cut_points in cuts(),
    ) {
        let mut wire = Vec::new();
        for s in &sheets {
            let mut json = vec![0u8; 16 * 1024];
            let n = s.write_json(&mut json).unwrap();
            prop_assert_eq!(&DataSheet::parse(&json[..n]).unwrap(), s);
            let mut out = vec![0u8; 16 * 1024];
            let n = s.write_packet(&mut out).unwrap();
            wire.extend_from_slice(&out[..n]);
        }
        let mut d = Deframer::<{ 16 * 1024 }>::new();
        let got: Vec<DataSheet> = deframe(&mut d, &wire, &at(&cut_points, wire.len()))
            .into_iter()
            .map(|i| DataSheet::parse(&i.unwrap()).unwrap())
            .collect();
        prop_assert_eq!(got, sheets);
    }
}

// ---------------------------------------------------------------- random sheets

fn dec() -> impl Strategy<Value = Decimal> {
    prop_oneof![
        // What controllers send: up to three decimals, modest magnitudes.
        4 => (any::<bool>(), 0u64..100_000_000, 0u8..=3)
            .prop_map(|(n, c, s)| Decimal::from_parts(n, c, s).unwrap()),
        // Anything a Decimal holds, including values too long to rescale.
        1 => (any::<bool>(), any::<u64>(), 0u8..=18)
            .prop_map(|(n, c, s)| Decimal::from_parts(n, c, s).unwrap()),
    ]
}

fn six_dec() -> impl Strategy<Value = Option<[Decimal; 6]>> {
    proptest::option::of(prop::array::uniform6(dec()))
}

/// A list of up to `max` values (filled into the `heapless::Vec` fields
/// with `extend_from_slice`, so this file needs no `heapless` dependency).
fn list<T: Clone + std::fmt::Debug>(
    s: impl Strategy<Value = T>,
    max: usize,
) -> impl Strategy<Value = Vec<T>> {
    prop::collection::vec(s, 0..=max)
}

fn opt<T: std::fmt::Debug>(s: impl Strategy<Value = T>) -> impl Strategy<Value = Option<T>> {
    proptest::option::of(s)
}

fn pos_and_vel() -> impl Strategy<Value = PosAndVel> {
    (
        opt((
            prop::array::uniform6(dec()),
            opt(prop::array::uniform6(dec())),
        )),
        six_dec(),
        six_dec(),
        six_dec(),
        six_dec(),
        six_dec(),
        six_dec(),
        opt(dec()),
    )
        .prop_map(|(pos, tcp, base, tool, cur, vel, acc, ovr)| PosAndVel {
            position: pos.map(|(joints, pose)| Position { joints, pose }),
            pcs_tcp: tcp,
            pcs_base: base,
            pcs_tool: tool,
            joint_current: cur,
            joint_velocity: vel,
            joint_acceleration: acc,
            override_ratio: ovr,
        })
}

fn sheet() -> BoxedStrategy<DataSheet> {
    let end_io = (
        prop::array::uniform3(list(any::<i32>(), MAX_END_IO)),
        opt(any::<i32>()),
        list(dec(), MAX_END_AI),
    )
        .prop_map(|([di, dout, button], enable_end_btn, ai)| {
            let mut e = EndIo {
                enable_end_btn,
                ..EndIo::default()
            };
            e.end_di.extend_from_slice(&di).unwrap();
            e.end_do.extend_from_slice(&dout).unwrap();
            e.end_button.extend_from_slice(&button).unwrap();
            e.end_ai.extend_from_slice(&ai).unwrap();
            e
        });
    let box_io = (
        prop::array::uniform4(list(0i32..2, MAX_BOX_IO)),
        opt(dec()),
        opt(any::<i32>()),
    )
        .prop_map(|([ci, co, di, dout], conveyor, encode)| {
            let mut b = BoxIo {
                conveyor,
                encode,
                ..BoxIo::default()
            };
            b.box_ci.extend_from_slice(&ci).unwrap();
            b.box_co.extend_from_slice(&co).unwrap();
            b.box_di.extend_from_slice(&di).unwrap();
            b.box_do.extend_from_slice(&dout).unwrap();
            b
        });
    let analog = (
        [opt(0i32..3), opt(0i32..3)],
        [opt(dec()), opt(dec())],
        [opt(dec()), opt(dec())],
    )
        .prop_map(|(out_mode, out, input)| BoxAnalogIo {
            out_mode,
            out,
            input,
        });
    let state = (
        opt(any::<i32>().prop_map(FsmState::from)),
        prop::array::uniform5(opt(any::<bool>())),
        prop::array::uniform2(opt(any::<i32>())),
        prop::array::uniform3(opt(prop::array::uniform6(any::<i32>()))),
        prop::array::uniform3(list(any::<i32>(), MAX_AXIS_GROUPS)),
    )
        .prop_map(
            |(
                robot_state,
                [enabled, paused, moving, blending_done, in_pos],
                [error_axis_id, error_code],
                [brake_state, axis_status, axis_error_code],
                [rss, gs, gec],
            )| {
                let mut s = StateAndError {
                    robot_state,
                    enabled,
                    paused,
                    moving,
                    blending_done,
                    in_pos,
                    error_axis_id,
                    error_code,
                    brake_state,
                    axis_status,
                    axis_error_code,
                    ..StateAndError::default()
                };
                s.reset_safe_space.extend_from_slice(&rss).unwrap();
                s.axis_group_status.extend_from_slice(&gs).unwrap();
                s.axis_group_error_code.extend_from_slice(&gec).unwrap();
                s
            },
        );
    let hard_load = (
        prop::array::uniform5(opt(any::<u64>())),
        prop::array::uniform4(opt(dec())),
        prop::array::uniform2(list(dec(), MAX_SLAVES)),
    )
        .prop_map(
            |([tf, fps, lost, tx, rx], [iv, ic, ov, oc], [temp, volt])| {
                let mut h = HardLoad {
                    ethercat_total_frame: tf,
                    ethercat_frames_per_second: fps,
                    ethercat_total_lost_frame: lost,
                    ethercat_tx_error_frame: tx,
                    ethercat_rx_error_frame: rx,
                    box48_in_voltage: iv,
                    box48_in_current: ic,
                    box48_out_voltage: ov,
                    box48_out_current: oc,
                    ..HardLoad::default()
                };
                h.slave_temperature.extend_from_slice(&temp).unwrap();
                h.slave_voltage.extend_from_slice(&volt).unwrap();
                h
            },
        );
    let ft =
        (opt(any::<i32>()), six_dec(), six_dec()).prop_map(|(control_state, data, src_data)| {
            FtData {
                control_state,
                data,
                src_data,
            }
        });
    (
        pos_and_vel().boxed(),
        end_io.boxed(),
        box_io.boxed(),
        analog.boxed(),
        state.boxed(),
        hard_load.boxed(),
        ft.boxed(),
        opt(any::<i32>()),
    )
        .prop_map(
            |(pos_and_vel, end_io, box_io, box_analog_io, state, hard_load, ft, err)| DataSheet {
                pos_and_vel,
                end_io,
                box_io,
                box_analog_io,
                state,
                hard_load,
                ft,
                script: Script { error_code: err },
            },
        )
        .boxed()
}

#[test]
fn tokenizer_sees_the_vendor_layout() {
    // The groups of the sample are top-level objects in the documented order.
    let mut t = Tokenizer::new(STANDBY);
    let mut groups = Vec::new();
    while let Some(tok) = t.next_token().unwrap() {
        if let Token::Key(k) = tok {
            if t.depth() == 1 {
                groups.push(String::from_utf8(k.to_vec()).unwrap());
            }
        }
    }
    assert_eq!(
        groups,
        [
            "PosAndVel",
            "EndIO",
            "ElectricBoxIO",
            "ElectricBoxAnalogIO",
            "StateAndError",
            "HardLoad",
            "FTData",
            "Script",
            "pluginsdata"
        ]
    );
}
