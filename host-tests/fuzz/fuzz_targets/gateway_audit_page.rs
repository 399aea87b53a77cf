//! The audit export's paging (`GET /api/audit?before=SEQ&limit=N`): the
//! query as a client sends it, and a page read over whatever the medium
//! holds (damaged flash, a file cut or edited). The query parses or is
//! refused with its reason, never a panic; the page is exactly the newest
//! `limit` readable records below `before`, in the medium's order, and
//! says older records exist exactly when some were left out.
//!
//! Input: the query string up to the first newline, then the stored
//! records, each a length byte and that many bytes (as the medium hands
//! them over). Every few inputs the records are made valid (their CRC
//! fixed) so that the paging, not only the CRC check, is reached.
#![no_main]

use hans_gateway::audit::page::{Query, Window, PAGE_MAX};
use hans_gateway::audit::{Record, RECORD_MAX};
use hans_gateway::crc::crc32;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let (query, rest) = match data.iter().position(|&b| b == b'\n') {
        Some(n) => (&data[..n], &data[n + 1..]),
        None => (data, &[][..]),
    };
    let Ok(query) = core::str::from_utf8(query) else {
        return;
    };
    let q = match Query::parse(query) {
        Ok(q) => q,
        Err(e) => {
            assert!(!e.as_str().is_empty());
            return;
        }
    };
    assert!((1..=PAGE_MAX).contains(&q.limit), "{q:?}");
    let mut chunks = Vec::new();
    let mut at = rest;
    while let Some((&n, tail)) = at.split_first() {
        let n = usize::from(n).min(tail.len());
        let mut c = tail[..n].to_vec();
        // Odd lengths: the CRC made right, when there is room for one.
        if n % 2 == 1 && n >= 4 {
            let crc = crc32(&c[..n - 4]).to_le_bytes();
            c[n - 4..].copy_from_slice(&crc);
        }
        chunks.push(c);
        at = &tail[n..];
    }
    let mut w = Window::new(q);
    let mut model = Vec::new();
    for c in &chunks {
        w.feed(c);
        if let Ok((r, n)) = Record::parse(c) {
            assert!(n <= RECORD_MAX && n <= c.len());
            if q.before.is_none_or(|b| r.seq < b) {
                model.push(r);
            }
        }
    }
    let got: Vec<Record> = w.records().copied().collect();
    let keep = model.len().min(q.limit);
    assert_eq!(got, model[model.len() - keep..], "{q:?}");
    assert_eq!(w.older(), model.len() > q.limit);
    assert_eq!(w.next_before(), w.older().then(|| got[0].seq));
    for (i, r) in got.iter().enumerate() {
        assert_eq!(w.get(i), Some(*r));
    }
    assert_eq!(w.get(got.len()), None);
});
