//! Bytes from a socket, in reads of any size, through the command-port
//! framer; every message it yields through the request and reply readers.
//!
//! Input: the first byte picks the read sizes (1-16 bytes, cycled from the
//! following bytes' low bits), the rest is the stream.
#![no_main]

use hans_codec::{Framer, Reply, ReplyExpect, Request};
use libfuzzer_sys::fuzz_target;

const N: usize = 256;

fuzz_target!(|data: &[u8]| {
    let Some((&seed, stream)) = data.split_first() else {
        return;
    };
    let mut framer = Framer::<N>::new();
    let mut whole = Framer::<N>::new();
    let mut split_items = Vec::new();
    let mut whole_items = Vec::new();
    let mut rest = stream;
    let mut k = usize::from(seed);
    while !rest.is_empty() {
        let n = (k % 16 + 1).min(rest.len());
        k = k.wrapping_mul(31).wrapping_add(7);
        let (chunk, tail) = rest.split_at(n);
        framer.feed(chunk, |m| split_items.push(m.map(str::to_owned)));
        rest = tail;
    }
    whole.feed(stream, |m| whole_items.push(m.map(str::to_owned)));
    // The same messages whatever the read sizes.
    assert_eq!(split_items, whole_items);
    assert_eq!(framer.pending(), whole.pending());
    for m in whole_items.iter().flatten() {
        assert!(m.len() <= N && m.ends_with(';'));
        assert!(m.bytes().all(|b| (0x20..0x7f).contains(&b)));
        let _ = Request::parse(m);
        let _ = Reply::parse(m, ReplyExpect { command: None, count: None });
        if let Ok(raw) = hans_codec::RawMessage::parse(m) {
            let _ = Reply::parse(m, ReplyExpect::from_name(raw.name()));
        }
    }
});
