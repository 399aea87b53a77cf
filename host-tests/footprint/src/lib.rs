//! The harness every footprint binary shares, the baseline included, so that
//! "binary minus baseline" is the codec alone.
//!
//! * Input comes from volatile reads of RAM, one byte at a time, as from a
//!   UART or a DMA buffer: the compiler cannot know a single byte. (A
//!   volatile read of a whole array would compile into a byte-by-byte copy
//!   unrolled in flash and distort the numbers.)
//! * Results are consumed by volatile writes and `black_box`, so nothing is
//!   optimised away.
//! * A panic halts (`panic = "abort"`); nothing on input panics in the codec.
//! * The command-port profiles are made of [`client_round`] and
//!   [`server_round`]; the other binaries call neither, and LTO drops them.
#![no_std]

use core::hint::black_box;
use core::ptr::{read_volatile, write_volatile};

use hans_codec::{ErrorCode, Failure, Framer, ProtocolLevel, RawMessage, Reply, Request, Response};

/// Where the bytes come from (RAM the program never writes).
const RX: usize = 0x2010_0000;
/// Where results go.
const TX: usize = 0x2018_0000;

/// Fills `buf` from the receive area, one volatile read per byte, and
/// returns the bytes as text (empty if they are not UTF-8).
pub fn input(buf: &mut [u8]) -> &str {
    for (i, b) in buf.iter_mut().enumerate() {
        // SAFETY: a readable RAM address of the target (memory.x); the
        // binary is built to be measured, not run on other memory maps.
        *b = unsafe { read_volatile((RX + i) as *const u8) };
    }
    core::str::from_utf8(buf).unwrap_or("")
}

/// One byte of input, for choices (which request, which expectation).
pub fn selector() -> u8 {
    // SAFETY: as in `input`.
    unsafe { read_volatile((RX + 0xFFFF) as *const u8) }
}

/// Consumes a value: its address escapes and a word derived from it is
/// written out.
pub fn output<T>(value: &T, word: u32) {
    black_box(value);
    // SAFETY: a writable RAM address of the target (memory.x).
    unsafe { write_volatile(TX as *mut u32, word) };
}

/// Consumes written bytes.
pub fn output_bytes(bytes: &[u8]) {
    black_box(bytes);
    // SAFETY: as in `output`.
    unsafe { write_volatile(TX as *mut u32, bytes.len() as u32) };
}

/// The size of the receive and transmit buffers and of the framer.
pub const BUF: usize = 512;

/// One round of a client (the gateway's side): writes a request of ANY
/// command, then frames the socket's bytes and reads each reply against it.
///
/// The request is made opaque with `black_box`, so the compiler must keep the
/// writer of every command, as a client that may send any of them does.
// Inlined into `main`, as the loop was before it became a function, so the
// figures count no harness call.
#[inline(always)]
pub fn client_round(framer: &mut Framer<BUF>, rx: &mut [u8; BUF], tx: &mut [u8; BUF]) {
    let text = input(rx);
    let Ok(raw) = RawMessage::parse(text) else {
        return;
    };
    let request: Request<'_> = black_box(Request::Unknown(raw));
    // Written for the controller's protocol level, as a client configured
    // with one does: the level check of every command is linked.
    let level = ProtocolLevel::new(selector(), selector(), selector());
    if let Ok(n) = request.encode_at(level, tx) {
        output_bytes(tx.get(..n).unwrap_or(&[]));
    }
    let expect = request.expect();
    let bytes = input(rx).as_bytes();
    framer.feed(bytes, |msg| {
        if let Ok(msg) = msg {
            let reply = Reply::parse(msg, expect);
            output(&reply, reply.is_ok() as u32);
        }
    });
}

/// One round of a server (the simulator's side, or a controller): frames
/// requests, reads and validates a request of ANY command, writes the reply
/// of ANY command (success, failure, errorcmd).
// Inlined, as `client_round`.
#[inline(always)]
pub fn server_round(framer: &mut Framer<BUF>, rx: &mut [u8; BUF], tx: &mut [u8; BUF]) {
    let bytes = input(rx).as_bytes();
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
            if let Ok(n) = reply.encode(tx) {
                output_bytes(tx.get(..n).unwrap_or(&[]));
            }
        }
    });
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    loop {
        core::hint::spin_loop();
    }
}
