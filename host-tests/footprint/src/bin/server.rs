//! A server (the simulator's side, or a controller): frames requests, reads
//! and validates a request of ANY command, writes the reply of ANY command
//! (success, failure, errorcmd).
#![no_std]
#![no_main]

use core::hint::black_box;
use hans_codec::{ErrorCode, Failure, Framer, RawMessage, Reply, Request, Response};
use hans_codec_footprint::{input, output, output_bytes};

#[cortex_m_rt::entry]
fn main() -> ! {
    let mut rx = [0u8; 512];
    let mut tx = [0u8; 512];
    let mut framer = Framer::<512>::new();
    loop {
        let bytes = input(&mut rx).as_bytes();
        framer.feed(bytes, |msg| {
            let Ok(msg) = msg else {
                return;
            };
            let reply = match Request::parse(msg) {
                Ok(request) => match request.validate() {
                    Ok(()) => {
                        output(&request, 1);
                        // The answer of any command: opaque, so every writer stays.
                        let raw = RawMessage::parse(msg).ok();
                        raw.map(|r| black_box(Reply::Ok(Response::Unknown(r))))
                    }
                    Err(_) => Some(Reply::Fail(Failure {
                        name: request.name(),
                        code: ErrorCode::ParameterError,
                        detail: "",
                    })),
                },
                Err(_) => RawMessage::parse(msg).ok().map(Reply::ErrorCmd),
            };
            if let Some(reply) = reply {
                if let Ok(n) = reply.encode(&mut tx) {
                    output_bytes(&tx[..n]);
                }
            }
        });
    }
}
