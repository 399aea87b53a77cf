//! Any text through `Request::parse`; whatever reads must write back to a
//! message that reads as the same request, and writing that again must give
//! the same bytes (the canonical form is a fixed point).
#![no_main]

use hans_codec::Request;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(request) = Request::parse(text) else {
        return;
    };
    let _ = request.validate();
    let _ = request.expect();
    let mut buf = [0u8; 8192];
    let Ok(n) = request.encode(&mut buf) else {
        return;
    };
    let canonical = std::str::from_utf8(&buf[..n]).expect("the writer writes ASCII");
    let again = Request::parse(canonical).expect("the canonical form reads");
    assert_eq!(again, request, "{text:?} -> {canonical:?}");
    let mut buf2 = [0u8; 8192];
    let m = again.encode(&mut buf2).expect("writes again");
    assert_eq!(&buf2[..m], &buf[..n]);
});
