//! The codec against a naive `std` implementation of the same job, in the
//! same run: parse the 24-value `ReadActPos` reply, parse and format a
//! `WayPoint` request, deframe and decode a DataSheet packet.
//!
//! The naive side is what a first implementation on a PC would do: `String`s,
//! `split(',')`, `str::parse::<f64>()`, `Vec`, `format!`. Criterion measures
//! each; after each pair the ratio naive / codec is printed, measured again
//! with a simple timer (rounds of both sides in turn, the fastest of each)
//! so that it appears in the same run.
//!
//! Goal (issue 12, "Codec", item 4): every figure at least 6x the naive
//! baseline, in the same run.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion};
use hans_codec::datasheet::{emit_header, DataSheet, Deframer, HEADER_LEN};
use hans_codec::{Command, CommandId, ParseError, Reply, ReplyExpect, Request, Response};

const ACT_POS: &str = "ReadActPos,OK,10.759,0.000,37.828,0.000,37.828,0.000,400.581,76.115,\
970.143,0.000,75.655,10.759,0.000,0.000,100.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,\
-0.000,;";

const WAY_POINT: &str =
    "WayPoint,0,420.000,0.000,445.000,180.000,0.000,180.000,0.000,0.000,90.000,0.000,90.000,0.000,\
TCP,Base,50.000,360.000,0.000,0,0,0,0,0,P17,;";

/// A DataSheet payload written for this project (tests/datasheet.rs reads it too).
const SHEET_JSON: &[u8] = include_bytes!("../vectors/datasheet/standby.json");

// ---------------------------------------------------------------- naive std baselines

/// A message split into owned, trimmed fields (the final `,;` dropped).
fn naive_fields(text: &str) -> Vec<String> {
    text.trim()
        .trim_end_matches(';')
        .trim_end_matches(',')
        .split(',')
        .map(|f| f.trim().to_string())
        .collect()
}

/// The reply split into owned strings, checked and converted with `f64`.
fn naive_read_act_pos(text: &str) -> Option<Vec<f64>> {
    let fields = naive_fields(text);
    if fields.len() != 26 || fields[0] != "ReadActPos" || fields[1] != "OK" {
        return None;
    }
    fields[2..].iter().map(|f| f.parse::<f64>().ok()).collect()
}

#[derive(Debug, Default)]
#[allow(dead_code)] // the fields are the point: they are filled, then dropped
struct NaiveWayPoint {
    rbt_id: i32,
    pose: Vec<f64>,
    joints: Vec<f64>,
    tcp_name: String,
    ucs_name: String,
    velocity: f64,
    acc: f64,
    radius: f64,
    ints: Vec<i32>,
    cmd_id: String,
}

fn naive_parse_way_point(text: &str) -> Option<NaiveWayPoint> {
    let fields = naive_fields(text);
    if fields.len() != 25 || fields[0] != "WayPoint" {
        return None;
    }
    let num = |i: usize| fields[i].parse::<f64>().ok();
    Some(NaiveWayPoint {
        rbt_id: fields[1].parse().ok()?,
        pose: (2..8).map(num).collect::<Option<Vec<_>>>()?,
        joints: (8..14).map(num).collect::<Option<Vec<_>>>()?,
        tcp_name: fields[14].clone(),
        ucs_name: fields[15].clone(),
        velocity: num(16)?,
        acc: num(17)?,
        radius: num(18)?,
        ints: (19..24)
            .map(|i| fields[i].parse::<i32>().ok())
            .collect::<Option<Vec<_>>>()?,
        cmd_id: fields[24].clone(),
    })
}

fn naive_format_way_point(w: &NaiveWayPoint) -> String {
    let nums = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x:.3}"))
            .collect::<Vec<_>>()
            .join(",")
    };
    format!(
        "WayPoint,{},{},{},{},{},{:.3},{:.3},{:.3},{},{},;",
        w.rbt_id,
        nums(&w.pose),
        nums(&w.joints),
        w.tcp_name,
        w.ucs_name,
        w.velocity,
        w.acc,
        w.radius,
        w.ints
            .iter()
            .map(|i| i.to_string())
            .collect::<Vec<_>>()
            .join(","),
        w.cmd_id
    )
}

/// Deframes with a growing `Vec`, then reads every `"key": value(s)` pair
/// into owned keys and `f64` values by splitting on the JSON punctuation.
fn naive_datasheet(stream: &[&[u8]]) -> Vec<(String, Vec<f64>)> {
    let mut buf: Vec<u8> = Vec::new();
    let mut out = Vec::new();
    for chunk in stream {
        buf.extend_from_slice(chunk);
        while buf.len() >= 12 {
            if &buf[..4] != b"LTBR" {
                buf.remove(0);
                continue;
            }
            let total = u32::from_le_bytes(buf[4..8].try_into().unwrap()) as usize;
            if buf.len() < total {
                break;
            }
            let payload: Vec<u8> = buf.drain(..total).skip(12).collect();
            let text = String::from_utf8(payload).unwrap_or_default();
            let flat = text.replace(['{', '}', '[', ']', '\n', '\t', ' '], ",");
            let mut key = String::new();
            let mut values = Vec::new();
            for token in flat.split(',').filter(|t| !t.is_empty()) {
                let value = match token.split_once(':') {
                    Some((k, v)) => {
                        if !key.is_empty() {
                            out.push((std::mem::take(&mut key), std::mem::take(&mut values)));
                        }
                        key = k.trim_matches('"').to_string();
                        v
                    }
                    None => token,
                };
                if let Ok(x) = value.trim_matches('"').parse::<f64>() {
                    values.push(x);
                }
            }
            if !key.is_empty() {
                out.push((key, values));
            }
        }
    }
    out
}

// ---------------------------------------------------------------- the codec

/// The reply as the codec gives it: its 24 values typed in place (the
/// naive side's output is its `Vec<f64>`). Returned as it is, not copied
/// into another shape, so that only the codec's work is timed.
fn codec_read_act_pos(text: &str) -> Result<Reply<'_>, ParseError<'_>> {
    Reply::parse(text, ReplyExpect::of(CommandId::ReadActPos))
}

/// The request as the codec gives it, typed (returned as it is).
fn codec_parse_way_point(text: &str) -> Result<Request<'_>, ParseError<'_>> {
    Request::parse(text)
}

fn codec_datasheet(
    stream: &[&[u8]],
    deframer: &mut Deframer<{ DataSheet::MAX_JSON_LEN }>,
) -> usize {
    let mut n = 0;
    for chunk in stream {
        deframer.feed(chunk, |item| {
            if let Ok(payload) = item {
                if let Ok(sheet) = DataSheet::parse(payload) {
                    black_box(&sheet);
                    n += 1;
                }
            }
        });
    }
    n
}

// ---------------------------------------------------------------- ratio

/// How many times faster than the naive baseline each job should be.
const GOAL: f64 = 6.0;

/// Calls per round so that a round of `f` takes about 5 ms.
fn calls_per_round(f: &mut impl FnMut()) -> u32 {
    let mut calls = 1u32;
    loop {
        let t = Instant::now();
        for _ in 0..calls {
            f();
        }
        if t.elapsed() > Duration::from_millis(5) {
            return calls;
        }
        calls = calls.saturating_mul(2);
    }
}

/// Time per call of one round of `calls` calls.
fn round(f: &mut impl FnMut(), calls: u32) -> Duration {
    let t = Instant::now();
    for _ in 0..calls {
        f();
    }
    t.elapsed() / calls
}

/// The time per call of each side: rounds of both, taken in turns so that
/// both meet the same conditions, and the fastest round of each kept. On a
/// shared machine another process steals time from some rounds, never
/// gives any; the fastest round is the one least disturbed, for both sides
/// alike. (A median of rounds, as before, moved by a third between runs
/// of the same code on a busy machine.)
fn times_per_call(mut naive: impl FnMut(), mut codec: impl FnMut()) -> (Duration, Duration) {
    let (cn, cc) = (calls_per_round(&mut naive), calls_per_round(&mut codec));
    let (mut n, mut c) = (Duration::MAX, Duration::MAX);
    for _ in 0..20 {
        n = n.min(round(&mut naive, cn));
        c = c.min(round(&mut codec, cc));
    }
    (n, c)
}

fn print_ratio(what: &str, goal: f64, naive: impl FnMut(), codec: impl FnMut()) {
    let (n, c) = times_per_call(naive, codec);
    let ratio = n.as_secs_f64() / c.as_secs_f64();
    println!(
        "RATIO {what}: naive {n:?}, codec {c:?}: codec is {ratio:.1}x faster (goal {goal}x: {})",
        if ratio >= goal { "met" } else { "MISSED" }
    );
}

/// Benchmarks one job both ways in a criterion group and prints their ratio.
fn compare<N, C>(
    c: &mut Criterion,
    group: &str,
    what: &str,
    goal: f64,
    mut naive: impl FnMut() -> N,
    mut codec: impl FnMut() -> C,
) {
    let mut g = c.benchmark_group(group);
    g.bench_function("naive std", |b| b.iter(&mut naive));
    g.bench_function("codec", |b| b.iter(&mut codec));
    g.finish();
    print_ratio(
        what,
        goal,
        || {
            black_box(naive());
        },
        || {
            black_box(codec());
        },
    );
}

// ---------------------------------------------------------------- benches

fn read_act_pos(c: &mut Criterion) {
    assert_eq!(naive_read_act_pos(ACT_POS).map(|v| v.len()), Some(24));
    let Ok(Reply::Ok(Response::ReadActPos(r))) = codec_read_act_pos(ACT_POS) else {
        panic!("codec parses")
    };
    assert_eq!(r.pose[2].to_f64(), 970.143);
    assert_eq!(r.ucs[5].to_string(), "-0.000");
    compare(
        c,
        "parse ReadActPos reply (24 values)",
        "parse ReadActPos",
        GOAL,
        || naive_read_act_pos(black_box(ACT_POS)),
        || codec_read_act_pos(black_box(ACT_POS)),
    );
}

fn way_point(c: &mut Criterion) {
    let naive = naive_parse_way_point(WAY_POINT).expect("naive parses");
    assert_eq!(naive_format_way_point(&naive), WAY_POINT);
    let Ok(Request::WayPoint(wp)) = codec_parse_way_point(WAY_POINT) else {
        panic!("codec parses")
    };
    let mut buf = [0u8; 512];
    let n = wp.encode(&mut buf).expect("encodes");
    assert_eq!(&buf[..n], WAY_POINT.as_bytes());

    compare(
        c,
        "parse WayPoint request",
        "parse WayPoint",
        GOAL,
        || naive_parse_way_point(black_box(WAY_POINT)),
        || codec_parse_way_point(black_box(WAY_POINT)),
    );

    // Formatting from typed values: f64s with format! against Decimals.
    compare(
        c,
        "format WayPoint request",
        "format WayPoint",
        GOAL,
        || naive_format_way_point(black_box(&naive)),
        || black_box(&wp).encode(&mut buf),
    );
}

fn datasheet(c: &mut Criterion) {
    let payload: Vec<u8> = SHEET_JSON.to_vec();
    let mut packet = vec![0u8; HEADER_LEN];
    emit_header(payload.len(), &mut packet).expect("the payload fits a packet");
    packet.extend_from_slice(&payload);
    // As a socket delivers it: reads of 1460 bytes.
    let stream: Vec<&[u8]> = packet.chunks(1460).collect();
    assert!(!naive_datasheet(&stream).is_empty());
    let mut deframer = Deframer::<{ DataSheet::MAX_JSON_LEN }>::new();
    assert_eq!(codec_datasheet(&stream, &mut deframer), 1);

    compare(
        c,
        "deframe and decode a DataSheet packet",
        "DataSheet",
        GOAL,
        || naive_datasheet(black_box(&stream)),
        || codec_datasheet(black_box(&stream), &mut deframer),
    );
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    targets = read_act_pos, way_point, datasheet
}
criterion_main!(benches);
