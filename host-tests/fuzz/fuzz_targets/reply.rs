//! Any text through `Reply::parse`, against no request, against the command
//! it names, and against that command with a list length taken from the
//! input; whatever reads must write back to a reply that reads the same.
#![no_main]

use hans_codec::{CommandId, RawMessage, Reply, ReplyExpect};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&count, rest)) = data.split_first() else {
        return;
    };
    let Ok(text) = std::str::from_utf8(rest) else {
        return;
    };
    let mut expects = vec![ReplyExpect { command: None, count: None }];
    if let Ok(raw) = RawMessage::parse(text) {
        expects.push(ReplyExpect::from_name(raw.name()));
        if let Some(id) = CommandId::from_name(raw.name()) {
            expects.push(ReplyExpect { command: Some(id), count: Some(u16::from(count % 16)) });
        }
    }
    for expect in expects {
        let Ok(reply) = Reply::parse(text, expect) else {
            continue;
        };
        let _ = reply.error_code();
        let mut buf = [0u8; 8192];
        let Ok(n) = reply.encode(&mut buf) else {
            continue;
        };
        let canonical = std::str::from_utf8(&buf[..n]).expect("the writer writes ASCII");
        let again = Reply::parse(canonical, expect).expect("the canonical form reads");
        assert_eq!(again, reply, "{text:?} -> {canonical:?}");
    }
});
