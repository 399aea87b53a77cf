//! Bytes from a DataSheet socket (ports 10004-10006), in reads of any size,
//! through the deframer; every payload through the JSON decoder. A payload
//! that decodes is written again (JSON and packet) and must decode to the
//! same sheet.
//!
//! Input: the first byte picks the read sizes, the rest is the stream.
#![no_main]

use hans_codec::datasheet::{DataSheet, Deframer};
use libfuzzer_sys::fuzz_target;

const N: usize = 4096;

fuzz_target!(|data: &[u8]| {
    let Some((&seed, stream)) = data.split_first() else {
        return;
    };
    let mut deframer = Deframer::<N>::new();
    let mut sheets = Vec::new();
    let mut rest = stream;
    let mut k = usize::from(seed);
    while !rest.is_empty() {
        let n = (k % 64 + 1).min(rest.len());
        k = k.wrapping_mul(31).wrapping_add(7);
        let (chunk, tail) = rest.split_at(n);
        deframer.feed(chunk, |item| {
            if let Ok(payload) = item {
                assert!(payload.len() <= N);
                if let Ok(sheet) = DataSheet::parse(payload) {
                    sheets.push(sheet);
                }
            }
        });
        rest = tail;
    }
    let mut out = vec![0u8; 12 + DataSheet::MAX_JSON_LEN];
    for sheet in sheets {
        let n = sheet.write_packet(&mut out).expect("a decoded sheet fits MAX_JSON_LEN");
        let mut again = Deframer::<{ 12 + DataSheet::MAX_JSON_LEN }>::new();
        let mut decoded = None;
        again.feed(&out[..n], |item| {
            decoded = Some(DataSheet::parse(item.expect("own packet")).expect("own JSON"));
        });
        assert_eq!(decoded.as_ref(), Some(&sheet));
    }
});
