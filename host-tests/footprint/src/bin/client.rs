//! A client (the gateway's side): frames replies from the socket, writes a
//! request of ANY command, reads the reply of ANY command against it.
//!
//! The request is made opaque with `black_box`, so the compiler must keep the
//! writer of every command, as a client that may send any of them does.
#![no_std]
#![no_main]

use core::hint::black_box;
use hans_codec::{Framer, RawMessage, Reply, Request};
use hans_codec_footprint::{input, output, output_bytes};

#[cortex_m_rt::entry]
fn main() -> ! {
    let mut rx = [0u8; 512];
    let mut tx = [0u8; 512];
    let mut framer = Framer::<512>::new();
    loop {
        // Build a request (any command) and write it.
        let text = input(&mut rx);
        let Ok(raw) = RawMessage::parse(text) else {
            continue;
        };
        let request: Request<'_> = black_box(Request::Unknown(raw));
        if let Ok(n) = request.encode(&mut tx) {
            output_bytes(&tx[..n]);
        }
        let expect = request.expect();
        // Frame and read the reply.
        let bytes = input(&mut rx).as_bytes();
        framer.feed(bytes, |msg| {
            if let Ok(msg) = msg {
                let reply = Reply::parse(msg, expect);
                output(&reply, reply.is_ok() as u32);
            }
        });
    }
}
