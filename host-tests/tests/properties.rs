//! Property tests of the codec (proptest, stable Rust, part of `cargo test`).
//!
//! * Every command of `CommandId::ALL`, request and success reply, with random
//!   values of each parameter's type, reads and writes back byte-identically.
//!   The parameter layout of each command is learnt from the codec itself
//!   (the `Visitor` walk of a parsed template), so the test follows the table.
//! * Variable-length parameters (bit lists, counted lists, point lists, text
//!   lists, optional tails) at every length, and replies checked against the
//!   count their request asked for.
//! * The framer: random bytes and random read splits never panic, never give
//!   different messages for different splits, and never lose a valid message
//!   that follows garbage or an over-long message.
//! * Random and mutated text through `Request::parse` / `Reply::parse` never
//!   panics, and whatever parses writes back to something that reads the same.
//! * With the `v6` feature, the V6 commands (all of them, by the layouts
//!   above) and their special parameters: groups of values, reply forms that
//!   follow the request, texts with commas.
//! * Protocol levels: `check_level` against the V6 document's revision table,
//!   transcribed in `vectors/v6/revisions.table` (not against the codec's own
//!   rule), and every version in the codec's table found there.

use std::path::Path;

use hans_codec::{
    request, Command, CommandId, Decimal, EncodeError, FrameError, Framer, LevelError,
    ProtocolLevel, Reply, ReplyExpect, Request, Visitor,
};
use hans_host_tests::corpus::Corpus;
use proptest::prelude::*;
use proptest::test_runner::{Config, TestCaseError, TestRunner};

// ---------------------------------------------------------------- parameter layouts

/// One parameter leaf or list, as the codec's `Visitor` shows it.
#[derive(Clone, Debug, PartialEq)]
enum Shape {
    Int,
    Num,
    Text,
    /// An array or list; `counted` when a count field precedes it on the wire
    /// (the `Visitor` does not show count fields).
    List {
        items: Vec<Shape>,
        counted: bool,
    },
}

#[derive(Default)]
struct ShapeOf {
    stack: Vec<Vec<Shape>>,
}

impl ShapeOf {
    fn of(visit: impl FnOnce(&mut dyn Visitor)) -> Vec<Shape> {
        let mut s = ShapeOf {
            stack: vec![Vec::new()],
        };
        visit(&mut s);
        s.stack.pop().unwrap_or_default()
    }
    fn push(&mut self, shape: Shape) {
        if let Some(top) = self.stack.last_mut() {
            top.push(shape);
        }
    }
}

impl Visitor for ShapeOf {
    fn int(&mut self, _: &str, _: i32) {
        self.push(Shape::Int)
    }
    fn num(&mut self, _: &str, _: Decimal) {
        self.push(Shape::Num)
    }
    fn text(&mut self, _: &str, _: &str) {
        self.push(Shape::Text)
    }
    fn begin_list(&mut self, _: &str) {
        self.stack.push(Vec::new())
    }
    fn end_list(&mut self) {
        let items = self.stack.pop().unwrap_or_default();
        self.push(Shape::List {
            items,
            counted: false,
        })
    }
}

fn leaves(shapes: &[Shape]) -> usize {
    shapes
        .iter()
        .map(|s| match s {
            Shape::List { items, counted } => leaves(items) + usize::from(*counted),
            _ => 1,
        })
        .sum()
}

/// Writes the fields of `shapes` with values from `next` (count fields are
/// the number of direct items of their list).
fn render(shapes: &[Shape], next: &mut dyn FnMut(&Shape) -> String, out: &mut Vec<String>) {
    for s in shapes {
        match s {
            Shape::List { items, counted } => {
                if *counted {
                    out.push(items.len().to_string());
                }
                render(items, next, out);
            }
            leaf => out.push(next(leaf)),
        }
    }
}

fn message(name: &str, ok: bool, fields: &[String]) -> String {
    let mut s = String::from(name);
    s.push(',');
    if ok {
        s.push_str("OK,");
    }
    for f in fields {
        s.push_str(f);
        s.push(',');
    }
    s.push(';');
    s
}

/// A parameter layout of `id`: the request's (`ok == false`) or the success
/// reply's. Found by parsing `Name,1,1,...,;` with the fewest fields that
/// reads, walking the result with a `Visitor`, and placing the count field of
/// a counted list where the codec accepts it.
fn layout(id: CommandId, ok: bool) -> Vec<Shape> {
    let walk = |text: &str| -> Option<Vec<Shape>> {
        if ok {
            match Reply::parse(text, ReplyExpect::of(id)) {
                Ok(Reply::Ok(r)) => Some(ShapeOf::of(|v| r.visit(v))),
                _ => None,
            }
        } else {
            match Request::parse(text) {
                Ok(r) if r.command() == Some(id) => Some(ShapeOf::of(|v| r.visit(v))),
                _ => None,
            }
        }
    };
    for k in 0..64 {
        let ones = vec!["1".to_string(); k];
        let Some(mut shape) = walk(&message(id.name(), ok, &ones)) else {
            continue;
        };
        if leaves(&shape) == k {
            return shape;
        }
        if leaves(&shape) > k {
            // A parameter the codec lets a message omit (`GrpEnable,;` reads
            // as robot 0): look for the full form.
            continue;
        }
        // One field more than the walk shows: a count field before one of the
        // lists. Try each list with distinct values until the codec agrees.
        assert_eq!(leaves(&shape) + 1, k, "{id}: unexplained fields");
        for i in 0..shape.len() {
            if let Shape::List { counted, .. } = &mut shape[i] {
                *counted = true;
            } else {
                continue;
            }
            let mut n = 1;
            let mut fields = Vec::new();
            render(
                &shape,
                &mut |_| {
                    n += 1;
                    n.to_string()
                },
                &mut fields,
            );
            if walk(&message(id.name(), ok, &fields)).as_ref() == Some(&shape_uncounted(&shape)) {
                return shape;
            }
            if let Shape::List { counted, .. } = &mut shape[i] {
                *counted = false;
            }
        }
        panic!("{id}: no place for the count field");
    }
    panic!("{id}: no message of 0..64 fields reads");
}

fn shape_uncounted(shapes: &[Shape]) -> Vec<Shape> {
    shapes
        .iter()
        .map(|s| match s {
            Shape::List { items, .. } => Shape::List {
                items: shape_uncounted(items),
                counted: false,
            },
            other => other.clone(),
        })
        .collect()
}

// ---------------------------------------------------------------- value strategies

/// Any decimal the codec can hold, in its canonical text (`-0.000`
/// included).
fn decimal() -> impl Strategy<Value = String> {
    (any::<bool>(), any::<u64>(), 0u8..=18).prop_map(|(neg, coeff, scale)| {
        Decimal::from_parts(neg, coeff, scale)
            .expect("scale <= 18")
            .to_string()
    })
}

/// Decimals as clients write them (small, few decimals), for lists.
fn small_decimal() -> impl Strategy<Value = Decimal> {
    (any::<bool>(), 0u64..10_000_000, 0u8..=6)
        .prop_map(|(neg, c, s)| Decimal::from_parts(neg, c, s).expect("scale <= 18"))
}

/// Text the grammar can carry: printable ASCII without `,` and `;`, no
/// spaces at the ends; empty included. Not `OK`/`Fail` (any case), which
/// make a request's first field look like a reply (see `variants.txt`).
fn text() -> impl Strategy<Value = String> {
    prop_oneof![
        1 => Just(String::new()),
        8 => "[!-+\\--:<-~]([ !-+\\--:<-~]{0,14}[!-+\\--:<-~])?",
    ]
    .prop_filter("reply marker", |s| {
        !s.eq_ignore_ascii_case("ok") && !s.eq_ignore_ascii_case("fail")
    })
}

fn values(shapes: &[Shape]) -> BoxedStrategy<Vec<String>> {
    let n = leaves(shapes);
    let leaf_kinds = {
        let mut v = Vec::new();
        collect_leaves(shapes, &mut v);
        v
    };
    let per_leaf: Vec<BoxedStrategy<String>> = leaf_kinds
        .iter()
        .map(|k| match k {
            Shape::Int => any::<i32>().prop_map(|v| v.to_string()).boxed(),
            Shape::Num => decimal().boxed(),
            _ => text().boxed(),
        })
        .collect();
    assert_eq!(per_leaf.len() + count_fields(shapes), n);
    per_leaf.boxed()
}

fn collect_leaves(shapes: &[Shape], out: &mut Vec<Shape>) {
    for s in shapes {
        match s {
            Shape::List { items, .. } => collect_leaves(items, out),
            leaf => out.push(leaf.clone()),
        }
    }
}

fn count_fields(shapes: &[Shape]) -> usize {
    shapes
        .iter()
        .map(|s| match s {
            Shape::List { items, counted } => count_fields(items) + usize::from(*counted),
            _ => 0,
        })
        .sum()
}

fn runner(cases: u32) -> TestRunner {
    TestRunner::new(Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    })
}

/// Reads `text`, writes it back, and checks it came back byte for byte and
/// reads again as the same value.
fn round_trip(id: CommandId, ok: bool, text: &str) -> Result<(), TestCaseError> {
    let mut buf = [0u8; 4096];
    let n = if ok {
        let r = Reply::parse(text, ReplyExpect::of(id))
            .map_err(|e| TestCaseError::fail(format!("{text}: {e:?}")))?;
        prop_assert!(matches!(&r, Reply::Ok(resp) if resp.command() == Some(id)));
        let n = r
            .encode(&mut buf)
            .map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
        let again = std::str::from_utf8(&buf[..n]).expect("ASCII");
        prop_assert_eq!(Reply::parse(again, ReplyExpect::of(id)), Ok(r));
        n
    } else {
        let r = Request::parse(text).map_err(|e| TestCaseError::fail(format!("{text}: {e:?}")))?;
        prop_assert_eq!(r.command(), Some(id));
        let n = r
            .encode(&mut buf)
            .map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
        let again = std::str::from_utf8(&buf[..n]).expect("ASCII");
        prop_assert_eq!(Request::parse(again), Ok(r));
        n
    };
    prop_assert_eq!(std::str::from_utf8(&buf[..n]).expect("ASCII"), text);
    Ok(())
}

fn every_command(ok: bool) {
    for &id in CommandId::ALL {
        let shape = layout(id, ok);
        let strategy = values(&shape);
        runner(24)
            .run(&strategy, |vals| {
                let mut it = vals.into_iter();
                let mut fields = Vec::new();
                render(
                    &shape,
                    &mut |_| it.next().expect("one value per leaf"),
                    &mut fields,
                );
                round_trip(id, ok, &message(id.name(), ok, &fields))
            })
            .unwrap_or_else(|e| panic!("{id}: {e}"));
    }
}

#[test]
fn every_request_round_trips_with_random_values() {
    every_command(false);
}

#[test]
fn every_reply_round_trips_with_random_values() {
    every_command(true);
}

/// The layouts learnt are the table's: spot checks against the document.
#[test]
fn layouts_match_the_document() {
    use Shape::*;
    let six = |s: Shape| List {
        items: vec![s; 6],
        counted: false,
    };
    assert_eq!(
        layout(CommandId::WayPoint, false),
        [
            Int,
            six(Num),
            six(Num),
            Text,
            Text,
            Num,
            Num,
            Num,
            Int,
            Int,
            Int,
            Int,
            Int,
            Text
        ]
    );
    assert_eq!(
        layout(CommandId::WriteHoldingRegisters, false),
        [
            Int,
            Int,
            Int,
            Int,
            List {
                items: vec![Int],
                counted: true
            }
        ]
    );
    assert_eq!(
        layout(CommandId::ReadActPos, true),
        [six(Num), six(Num), six(Num), six(Num)]
    );
    assert_eq!(layout(CommandId::StartMaster, false), []);
}

// ---------------------------------------------------------------- variable lengths

fn encode<'a, C: Command<'a>>(c: &C) -> String {
    let mut buf = [0u8; 8192];
    let n = c.encode(&mut buf).expect("encodes");
    String::from_utf8(buf[..n].to_vec()).expect("ASCII")
}

proptest! {
    #![proptest_config(Config { cases: 128, failure_persistence: None, ..Config::default() })]

    /// A bit list of any valid length; the reply must have exactly as many
    /// values as bits were asked for.
    #[test]
    fn box_bit_lists_and_their_replies(
        bits in prop::collection::vec(0i32..8, 1..=8),
        levels in prop::collection::vec(0i32..2, 1..=8),
    ) {
        let r = request::ReadBoxDI { bits: bits.iter().copied().collect() };
        let text = encode(&r);
        prop_assert_eq!(request::ReadBoxDI::parse(&text), Ok(r.clone()));
        prop_assert_eq!(r.expect().count, Some(bits.len() as u16));
        let reply = message("ReadBoxDI", true, &levels.iter().map(|l| l.to_string()).collect::<Vec<_>>());
        let parsed = Reply::parse(&reply, r.expect());
        prop_assert_eq!(parsed.is_ok(), levels.len() == bits.len(), "{} -> {:?}", reply, parsed);
        // Without the request, any valid length reads.
        prop_assert!(Reply::parse(&reply, ReplyExpect::of(CommandId::ReadBoxDI)).is_ok());
    }

    #[test]
    fn end_io_lists(rbt in 0i32..6, bits in prop::collection::vec(0i32..3, 0..=4)) {
        let text = message("ReadEO", false,
            &std::iter::once(rbt).chain(bits.iter().copied()).map(|b| b.to_string()).collect::<Vec<_>>());
        let parsed = request::ReadEO::parse(&text);
        prop_assert_eq!(parsed.is_ok(), (1..=3).contains(&bits.len()), "{}", text);
        if let Ok(r) = parsed {
            prop_assert_eq!(r.rbt_id.0, rbt);
            prop_assert_eq!(r.bits.as_slice(), &bits[..]);
            prop_assert_eq!(encode(&r), text);
        }
    }

    #[test]
    fn holding_registers(data in prop::collection::vec(any::<u16>(), 1..=11), count in 1i32..=12) {
        let w = request::WriteHoldingRegisters {
            rbt_id: hans_codec::RobotId(0),
            slave: 1,
            function: 16,
            address: 5000,
            data: hans_codec::CountedList::from_slice(&data.iter().map(|&d| i32::from(d)).collect::<Vec<_>>())
                .expect("<= 11"),
        };
        let text = encode(&w);
        prop_assert_eq!(request::WriteHoldingRegisters::parse(&text), Ok(w.clone()));
        prop_assert!(w.validate().is_ok());
        let r = request::ReadHoldingRegisters { count, slave: 1, function: 3, address: 5000, ..Default::default() };
        let n = usize::try_from(count).expect("positive");
        let reply = message("ReadHoldingRegisters", true,
            &data.iter().cycle().take(n).map(|d| d.to_string()).collect::<Vec<_>>());
        prop_assert!(Reply::parse(&reply, r.expect()).is_ok(), "{}", reply);
        let short = message("ReadHoldingRegisters", true,
            &data.iter().cycle().take(n - 1).map(|d| d.to_string()).collect::<Vec<_>>());
        prop_assert!(Reply::parse(&short, r.expect()).is_err(), "{}", short);
    }

    #[test]
    fn point_lists(points in prop::collection::vec(prop::array::uniform6(small_decimal()), 0..24)) {
        let p = request::PushMovePaths {
            rbt_id: hans_codec::RobotId(0),
            track: "Path1",
            move_type: 1,
            points: hans_codec::PointList::new(&points),
        };
        let text = encode(&p);
        let back = request::PushMovePaths::parse(&text).expect("reads");
        prop_assert_eq!(back.points.len(), points.len());
        prop_assert!(back.points.iter().zip(&points).all(|(a, b)| a.iter().zip(b).all(|(x, y)| x.is_identical(y))));
        prop_assert_eq!(encode(&back), text);
    }

    #[test]
    fn text_lists(name in text(), params in prop::collection::vec(text(), 0..12)) {
        let refs: Vec<&str> = params.iter().map(String::as_str).collect();
        let r = request::RunFunc { func_name: &name, params: hans_codec::TextList::new(&refs) };
        let text = encode(&r);
        let back = request::RunFunc::parse(&text).expect("reads");
        prop_assert_eq!(back.func_name, name.as_str());
        prop_assert_eq!(back.params.iter().collect::<Vec<_>>(), refs);
        prop_assert_eq!(encode(&back), text);
    }

    #[test]
    fn optional_tails(force in prop::array::uniform6(small_decimal()),
                      distance in prop::option::of(prop::array::uniform6(small_decimal())),
                      tool in prop::option::of(0i32..2)) {
        let g = request::HRSetControlGoal { rbt_id: hans_codec::RobotId(0), force, distance };
        let text = encode(&g);
        prop_assert_eq!(request::HRSetControlGoal::parse(&text), Ok(g));
        let m = request::MoveRelL { axis: 2, direction: 1, distance: force[0], tool_motion: tool, ..Default::default() };
        let text = encode(&m);
        prop_assert_eq!(request::MoveRelL::parse(&text), Ok(m));
    }

    /// Text the grammar cannot carry is refused when writing, never sent.
    #[test]
    fn uncarriable_text_is_refused(
        good in text(),
        bad in prop_oneof![
            "[ -~]{0,5}[,;][ -~]{0,5}",
            "[ -~]{0,5}[\\x00-\\x1f\\x7f][ -~]{0,5}",
            "[ -~]{0,5}[\u{80}-\u{10ffff}][ -~]{0,5}",
            " [!-~]{0,5}",
            "[!-~]{0,5} ",
        ],
    ) {
        let w = request::WayPoint { tcp_name: &good, ucs_name: &bad, cmd_id: "1", ..Default::default() };
        let mut buf = [0u8; 512];
        prop_assert_eq!(w.encode(&mut buf), Err(EncodeError::InvalidText { param: "ucs_name" }));
    }

    /// A buffer too small is an error, never a panic nor a partial message.
    #[test]
    fn small_buffers(len in 0usize..80) {
        let w = request::WayPoint { tcp_name: "TCP", ucs_name: "Base", cmd_id: "1", ..Default::default() };
        let full = encode(&w);
        let mut buf = vec![0u8; len];
        match w.encode(&mut buf) {
            Ok(n) => prop_assert_eq!(&buf[..n], full.as_bytes()),
            Err(e) => {
                prop_assert_eq!(e, EncodeError::BufferTooSmall);
                prop_assert!(len < full.len());
            }
        }
    }
}

// ---------------------------------------------------------------- framer

const FRAME: usize = 64;

/// Every item the framer yields for `input` fed in chunks of the given sizes
/// (cycled), as owned values.
fn frames(input: &[u8], splits: &[usize]) -> Vec<Result<String, FrameError>> {
    let mut framer = Framer::<FRAME>::new();
    let mut out = Vec::new();
    let mut rest = input;
    let mut sizes = splits.iter().cycle();
    while !rest.is_empty() {
        let n = sizes.next().copied().unwrap_or(1).clamp(1, rest.len());
        let (chunk, tail) = rest.split_at(n);
        framer.feed(chunk, |m| out.push(m.map(str::to_owned)));
        rest = tail;
    }
    out
}

/// Valid messages as a controller or client sends them.
fn valid_message() -> impl Strategy<Value = String> {
    (
        "[A-Za-z][A-Za-z0-9_]{0,15}",
        prop::collection::vec("[!-+\\--:<-~]{0,6}", 0..6),
    )
        .prop_map(|(name, fields)| message(&name, false, &fields))
        .prop_filter("fits the framer", |m| m.len() <= FRAME)
}

proptest! {
    #![proptest_config(Config { cases: 256, failure_persistence: None, ..Config::default() })]

    #[test]
    fn framer_any_bytes_any_splits(
        input in prop::collection::vec(any::<u8>(), 0..600),
        splits in prop::collection::vec(1usize..40, 1..8),
    ) {
        let whole = frames(&input, &[input.len().max(1)]);
        let split = frames(&input, &splits);
        prop_assert_eq!(&split, &whole);
        for m in whole.iter().flatten() {
            prop_assert!(m.len() <= FRAME && m.ends_with(';'));
            prop_assert!(m.bytes().all(|b| (0x20..0x7f).contains(&b)));
        }
    }

    /// Garbage, then `;` (the end of whatever the garbage was), then valid
    /// messages: every valid message comes out, in order, whatever the splits.
    #[test]
    fn framer_resynchronises_after_garbage(
        garbage in prop::collection::vec(any::<u8>(), 0..300),
        messages in prop::collection::vec(valid_message(), 1..6),
        splits in prop::collection::vec(1usize..50, 1..8),
    ) {
        let mut input = garbage.clone();
        input.push(b';');
        for m in &messages {
            input.extend_from_slice(m.as_bytes());
        }
        let out = frames(&input, &splits);
        prop_assert!(out.len() >= messages.len());
        let tail: Vec<_> = out[out.len() - messages.len()..].to_vec();
        let want: Vec<Result<String, FrameError>> = messages.iter().cloned().map(Ok).collect();
        prop_assert_eq!(tail, want);
    }

    /// A message longer than the buffer costs exactly that message.
    #[test]
    fn framer_survives_over_long_messages(
        long in prop::collection::vec(0x20u8..0x7f, FRAME + 1..400),
        messages in prop::collection::vec(valid_message(), 1..4),
        splits in prop::collection::vec(1usize..70, 1..8),
    ) {
        let long: Vec<u8> = long.into_iter().filter(|&b| b != b';').chain([b';']).collect();
        prop_assume!(long.len() > FRAME && !long[0].is_ascii_whitespace());
        let mut input = long.clone();
        for m in &messages {
            input.extend_from_slice(m.as_bytes());
        }
        let out = frames(&input, &splits);
        prop_assert_eq!(out.len(), messages.len() + 1);
        prop_assert_eq!(&out[0], &Err(FrameError::TooLong { len: long.len() }));
        for (got, want) in out[1..].iter().zip(&messages) {
            prop_assert_eq!(got.as_deref(), Ok(want.as_str()));
        }
    }
}

// ---------------------------------------------------------------- parsers never panic

fn corpus_lines() -> Vec<String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("vectors");
    let mut files = vec!["chapter4.txt", "variants.txt"];
    if cfg!(feature = "v6") {
        files.extend(["v6/chapter4.txt", "v6/variants.txt"]);
    } else {
        files.push("v5-only/variants.txt");
    }
    files
        .iter()
        .flat_map(|f| {
            Corpus::load(&dir.join(f))
                .unwrap_or_else(|e| panic!("{e}"))
                .vectors
                .into_iter()
                .map(|v| v.text)
        })
        .collect()
}

/// Reads `text` every way there is; whatever reads must write back to text
/// that reads as the same value.
fn read_every_way(text: &str) -> Result<(), TestCaseError> {
    let mut buf = [0u8; 8192];
    if let Ok(r) = Request::parse(text) {
        if let Ok(n) = r.encode(&mut buf) {
            let again = std::str::from_utf8(&buf[..n]).expect("ASCII");
            prop_assert_eq!(Request::parse(again), Ok(r), "{:?} -> {:?}", text, again);
        }
    }
    let mut expects = vec![ReplyExpect {
        command: None,
        count: None,
    }];
    if let Ok(raw) = hans_codec::RawMessage::parse(text) {
        expects.push(ReplyExpect::from_name(raw.name()));
        if let Some(id) = CommandId::from_name(raw.name()) {
            expects.push(ReplyExpect {
                command: Some(id),
                count: Some(u16::try_from(raw.len()).unwrap_or(0).saturating_sub(1)),
            });
        }
    }
    for e in expects {
        if let Ok(r) = Reply::parse(text, e) {
            if let Ok(n) = r.encode(&mut buf) {
                let again = std::str::from_utf8(&buf[..n]).expect("ASCII");
                prop_assert_eq!(Reply::parse(again, e), Ok(r), "{:?} -> {:?}", text, again);
            }
        }
    }
    Ok(())
}

/// One random edit of a corpus line: delete, insert, replace or duplicate a
/// stretch, at byte positions (the result may not be UTF-8: lossy).
#[derive(Clone, Debug)]
enum Edit {
    Delete(usize, usize),
    Insert(usize, String),
    Replace(usize, u8),
    Splice(usize, usize, usize),
}

fn apply(line: &str, edits: &[Edit]) -> String {
    let mut b = line.as_bytes().to_vec();
    for e in edits {
        let len = b.len().max(1);
        match e {
            Edit::Delete(at, n) => {
                let at = at % len;
                let end = (at + n).min(b.len());
                if at < end {
                    b.drain(at..end);
                }
            }
            Edit::Insert(at, s) => {
                let at = (at % len).min(b.len());
                b.splice(at..at, s.bytes());
            }
            Edit::Replace(at, c) => {
                if !b.is_empty() {
                    let at = at % b.len();
                    b[at] = *c;
                }
            }
            Edit::Splice(from, n, to) => {
                let from = from % len;
                let end = (from + n).min(b.len());
                let piece: Vec<u8> = b.get(from..end).unwrap_or(&[]).to_vec();
                let to = (to % len).min(b.len());
                b.splice(to..to, piece);
            }
        }
    }
    String::from_utf8_lossy(&b).into_owned()
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (any::<usize>(), 1usize..8).prop_map(|(a, n)| Edit::Delete(a, n)),
        (
            any::<usize>(),
            prop_oneof![
                Just(",".to_string()),
                Just(";".to_string()),
                Just(" ".to_string()),
                Just("OK,".to_string()),
                Just("Fail,".to_string()),
                Just("-".to_string()),
                Just(".".to_string()),
                Just("e".to_string()),
                "[ -~]{1,4}",
                "\\PC{1,2}",
            ]
        )
            .prop_map(|(a, s)| Edit::Insert(a, s)),
        (any::<usize>(), any::<u8>()).prop_map(|(a, c)| Edit::Replace(a, c)),
        (any::<usize>(), 1usize..40, any::<usize>()).prop_map(|(f, n, t)| Edit::Splice(f, n, t)),
    ]
}

#[test]
fn mutated_corpus_lines_never_panic() {
    let lines = corpus_lines();
    let strategy = (0..lines.len(), prop::collection::vec(edit(), 1..5));
    runner(3000)
        .run(&strategy, |(i, edits)| {
            read_every_way(&apply(&lines[i], &edits))
        })
        .unwrap_or_else(|e| panic!("{e}"));
}

proptest! {
    #![proptest_config(Config { cases: 2000, failure_persistence: None, ..Config::default() })]

    #[test]
    fn random_text_never_panics(text in prop_oneof![
        "\\PC{0,80}",
        "[ -~]{0,120}",
        "[A-Za-z]{1,12}(,[ -~&&[^,;]]{0,8}){0,40},?;?",
    ]) {
        read_every_way(&text)?;
    }
}

// ---------------------------------------------------------------- protocol levels

#[derive(Clone, Copy, Debug, PartialEq)]
enum Revision {
    Added,
    Removed,
    Changed,
}

/// One line of `vectors/v6/revisions.table`: a command that came, went or
/// changed at a controller version, as the V6 document says.
#[derive(Debug)]
struct RevisionRow {
    line: usize,
    version: ProtocolLevel,
    kind: Revision,
    name: String,
}

impl RevisionRow {
    /// The codec's command of that name (`None` for a V6 command in a build
    /// without `v6`, where `MovePathJ` is the SDKs' alias of `MovePath`).
    fn command(&self) -> Option<CommandId> {
        CommandId::from_name(&self.name).filter(|id| cfg!(feature = "v6") || id.name() == self.name)
    }
}

impl std::fmt::Display for RevisionRow {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "revisions.table:{}: {} {:?} at {}",
            self.line, self.name, self.kind, self.version
        )
    }
}

fn revision_rows() -> Vec<RevisionRow> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("vectors/v6/revisions.table");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
    let mut rows = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        if line.trim().is_empty() || line.starts_with('#') {
            continue;
        }
        let mut fields = line.split_whitespace();
        let (Some(version), Some(kind), Some(name), Some(_source)) =
            (fields.next(), fields.next(), fields.next(), fields.next())
        else {
            panic!("revisions.table:{line_no}: version, kind, command and source expected");
        };
        let version = match version {
            "V5" => ProtocolLevel::V5,
            v => ProtocolLevel::parse(v)
                .unwrap_or_else(|| panic!("revisions.table:{line_no}: version {v:?}")),
        };
        let kind = match kind {
            "added" => Revision::Added,
            "removed" => Revision::Removed,
            "changed" => Revision::Changed,
            k => panic!("revisions.table:{line_no}: kind {k:?}"),
        };
        rows.push(RevisionRow {
            line: line_no,
            version,
            kind,
            name: name.to_string(),
        });
    }
    rows
}

/// The last controller version before `v` (`HR6.5.0` -> `HR6.4.255`);
/// `None` for the V5 level, the first the codec knows.
fn just_before(v: ProtocolLevel) -> Option<ProtocolLevel> {
    if v <= ProtocolLevel::V5 {
        return None;
    }
    Some(match v.parts() {
        (a, b, c @ 1..) => ProtocolLevel::new(a, b, c - 1),
        (a, b @ 1.., 0) => ProtocolLevel::new(a, b - 1, u8::MAX),
        (a, 0, 0) => ProtocolLevel::new(a - 1, u8::MAX, u8::MAX),
    })
}

/// Every line of the document's revision data against what the codec says
/// at that version and just before it.
#[test]
fn the_levels_are_the_documents() {
    let rows = revision_rows();
    assert!(rows.len() > 100, "{} rows", rows.len());
    let has = |id: CommandId, kind: Revision, version: Option<ProtocolLevel>| {
        rows.iter().any(|r| {
            r.command() == Some(id) && r.kind == kind && version.is_none_or(|v| v == r.version)
        })
    };
    let mut checked = 0;
    for row in &rows {
        let Some(id) = row.command() else {
            #[cfg(feature = "v6")]
            panic!("{row}: no such command");
            #[cfg(not(feature = "v6"))]
            continue;
        };
        let v = row.version;
        let before = just_before(v);
        match row.kind {
            Revision::Added => {
                assert_eq!(id.check_level(v), Ok(()), "{row}");
                if let Some(b) = before {
                    assert_eq!(
                        id.check_level(b),
                        Err(LevelError::TooNew {
                            command: id,
                            since: v,
                            level: b
                        }),
                        "{row}: at {b}"
                    );
                }
                // Still there at the newest level, unless the document
                // removes it.
                assert_eq!(
                    id.available_at(ProtocolLevel::V6),
                    !has(id, Revision::Removed, None),
                    "{row}: at the V6 level"
                );
            }
            Revision::Removed => {
                let b = before.expect("a removal after V5");
                assert_eq!(id.check_level(b), Ok(()), "{row}: at {b}");
                for at in [v, ProtocolLevel::V6] {
                    assert_eq!(
                        id.check_level(at),
                        Err(LevelError::Removed {
                            command: id,
                            removed: v,
                            level: at
                        }),
                        "{row}: at {at}"
                    );
                }
            }
            Revision::Changed => {
                // There on both sides (just before: unless it came then).
                assert_eq!(id.check_level(v), Ok(()), "{row}");
                if let Some(b) = before.filter(|_| !has(id, Revision::Added, Some(v))) {
                    assert_eq!(id.check_level(b), Ok(()), "{row}: at {b}");
                }
            }
        }
        checked += 1;
    }
    if cfg!(feature = "v6") {
        assert_eq!(checked, rows.len());
    } else {
        // The HR-TCP commands the V6 document removed or changed.
        assert!(checked >= 16, "{checked} rows of V5 commands");
    }
}

/// Every version in the codec's table is one the document gives for that
/// command: no level data of the codec's own making (but the one reading
/// written down in the table and in revisions.table).
#[test]
fn every_version_in_the_table_is_in_the_document() {
    let rows = revision_rows();
    let has = |id: CommandId, kind: Revision, version: ProtocolLevel| {
        rows.iter()
            .any(|r| r.command() == Some(id) && r.kind == kind && r.version == version)
    };
    for &id in CommandId::ALL {
        let since = id.since();
        if since != ProtocolLevel::V5 {
            #[cfg(feature = "v6")]
            if id == CommandId::SetFTMotionFreedom {
                // No revision row: the codec's reading (its table says so).
                assert_eq!(since, ProtocolLevel::new(5, 50, 3));
                continue;
            }
            assert!(has(id, Revision::Added, since), "{id}: since {since}");
        }
        if let Some(removed) = id.removed() {
            assert!(
                has(id, Revision::Removed, removed),
                "{id}: removed {removed}"
            );
        }
        if let Some(changed) = id.changed() {
            assert!(
                has(id, Revision::Changed, changed),
                "{id}: changed {changed}"
            );
        }
    }
}

#[cfg(feature = "v6")]
mod v6 {
    use super::*;
    use hans_codec::{response, FreeText, Response, ValueGroups};

    proptest! {
        #![proptest_config(Config { cases: 256, failure_persistence: None, ..Config::default() })]

        /// Any number of values reads as points when it is a whole number of
        /// six, and the points write back as read.
        #[test]
        fn path_points_in_groups_of_six(values in prop::collection::vec(small_decimal(), 0..40)) {
            let fields: Vec<String> = ["0".to_string(), "aaa".to_string()]
                .into_iter()
                .chain(values.iter().map(|v| v.to_string()))
                .collect();
            let text = message("PushPathPoints", false, &fields);
            let parsed = request::PushPathPoints::parse(&text);
            let whole = !values.is_empty() && values.len() % 6 == 0;
            prop_assert_eq!(parsed.is_ok(), whole, "{}: {:?}", &text, parsed);
            if let Ok(r) = parsed {
                prop_assert_eq!(r.points.len(), values.len() / 6);
                let flat: Vec<Decimal> = r.points.iter().flatten().collect();
                prop_assert_eq!(&flat, &values);
                prop_assert_eq!(&encode(&r), &text);
                let groups: Vec<[Decimal; 6]> = r.points.iter().collect();
                let built = request::PushPathPoints { points: ValueGroups::new(&groups), ..r };
                prop_assert_eq!(encode(&built), encode(&r));
            }
        }

        /// `ReadBoxAO` replies: against a request of `n` channels, `n` values
        /// or `n` (mode, value) pairs read, anything else is an error.
        #[test]
        fn box_ao_replies_in_both_forms(
            channels in prop::collection::vec(0i32..2, 1..=2),
            reply in prop::collection::vec(small_decimal(), 0..6),
        ) {
            let r = request::ReadBoxAO { channels: channels.iter().copied().collect() };
            let fields: Vec<String> = reply.iter().map(|v| v.to_string()).collect();
            let text = message("ReadBoxAO", true, &fields);
            let n = channels.len();
            let parsed = Reply::parse(&text, r.expect());
            let pairs = reply.len() == 2 * n && reply.iter().step_by(2).all(|m| m.to_i64().is_some_and(|v| i32::try_from(v).is_ok()));
            prop_assert_eq!(parsed.is_ok(), reply.len() == n || pairs, "{}: {:?}", text, parsed);
            if let Ok(Reply::Ok(Response::ReadBoxAO(ao))) = &parsed {
                prop_assert_eq!(ao.values.len(), n);
                prop_assert_eq!(ao.modes.is_some(), reply.len() == 2 * n);
                let mut buf = [0u8; 256];
                let m = Response::ReadBoxAO(ao.clone()).encode(&mut buf).expect("encodes");
                let again = std::str::from_utf8(&buf[..m]).expect("ASCII");
                prop_assert_eq!(Reply::parse(again, r.expect()), parsed.clone());
            }
        }

        /// The controller's text comes back whole, commas included.
        #[test]
        fn error_texts_keep_their_commas(parts in prop::collection::vec("[!-+\\--:<-~]{1,8}", 1..5)) {
            let text = parts.join(",");
            let reply = format!("GetErrorCodeStr,OK,{text},;");
            let r = Reply::parse(&reply, ReplyExpect::of(CommandId::GetErrorCodeStr));
            let Ok(Reply::Ok(Response::GetErrorCodeStr(t))) = r else {
                return Err(TestCaseError::fail(format!("{reply}: {r:?}")));
            };
            prop_assert_eq!(t.text.as_str(), text.as_str());
            let built = response::GetErrorCodeStr { text: FreeText::new(&text) };
            let mut buf = [0u8; 256];
            let n = Response::from(built).encode(&mut buf).expect("encodes");
            prop_assert_eq!(std::str::from_utf8(&buf[..n]).expect("ASCII"), reply.as_str());
        }
    }
}
