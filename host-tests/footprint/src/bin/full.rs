//! Both sides of the command port: everything `client` and `server` do.
#![no_std]
#![no_main]

use core::hint::black_box;
use hans_codec::{ErrorCode, Failure, Framer, RawMessage, Reply, Request, Response};
use hans_codec_footprint::{input, output, output_bytes, selector};

#[cortex_m_rt::entry]
fn main() -> ! {
    let mut rx = [0u8; 512];
    let mut tx = [0u8; 512];
    let mut framer = Framer::<512>::new();
    loop {
        if selector() & 1 == 0 {
            // Client: write any request, read the reply against it.
            let text = input(&mut rx);
            let Ok(raw) = RawMessage::parse(text) else {
                continue;
            };
            let request: Request<'_> = black_box(Request::Unknown(raw));
            if let Ok(n) = request.encode(&mut tx) {
                output_bytes(&tx[..n]);
            }
            let expect = request.expect();
            let bytes = input(&mut rx).as_bytes();
            framer.feed(bytes, |msg| {
                if let Ok(msg) = msg {
                    let reply = Reply::parse(msg, expect);
                    output(&reply, reply.is_ok() as u32);
                }
            });
        } else {
            // Server: read and validate any request, write any reply.
            let bytes = input(&mut rx).as_bytes();
            framer.feed(bytes, |msg| {
                let Ok(msg) = msg else {
                    return;
                };
                let reply = match Request::parse(msg) {
                    Ok(request) => match request.validate() {
                        Ok(()) => {
                            output(&request, 1);
                            RawMessage::parse(msg)
                                .ok()
                                .map(|r| black_box(Reply::Ok(Response::Unknown(r))))
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
}
