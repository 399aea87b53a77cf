//! A firmware image uploaded to the device (`hans_fw_image`):
//! any bytes as the image, fed in pieces whose sizes come from the input.
//! Never a panic; judged in pieces exactly as whole; what passes is
//! exactly a signed body: its length and SHA-256 (computed here with the
//! sha2 crate) are the header's. The seed (run.sh) is an image signed with
//! the development key, so the fuzzer mutates past the signature.
//!
//! Input: one byte of piece size (1-256), one byte of flags (bit 0: allow
//! a downgrade; bit 1: the other board), then the image.
#![no_main]

use hans_fw_image::{check, Expect, Verifier, Version, HEADER_LEN};
use libfuzzer_sys::fuzz_target;

/// `firmware/keys/dev.pub` (the development key: its secret half is in
/// the repository, never trusted by a plant's devices).
const DEV_PUB: [u8; 32] = [
    0xf3, 0xd6, 0xc3, 0xf2, 0x4d, 0xe5, 0x73, 0xf8, 0x52, 0x3d, 0x65, 0x0e, 0x70, 0x5a, 0x4e, 0x2c,
    0x32, 0xaa, 0xa7, 0x24, 0x43, 0x10, 0x51, 0xc7, 0x5f, 0xfa, 0x82, 0xfe, 0xfc, 0x66, 0xc4, 0x2e,
];

fuzz_target!(|data: &[u8]| {
    let [piece, flags, image @ ..] = data else {
        return;
    };
    let piece = usize::from(*piece) + 1;
    let expect = Expect {
        key: &DEV_PUB,
        board: if flags & 2 == 0 { "mps2-an386" } else { "nucleo-f767zi" },
        running: Version { major: 1, minor: 0, patch: 0 },
        allow_downgrade: flags & 1 != 0,
        max_body: 1 << 20,
    };
    let whole = check(image, &expect);
    let chunked = Verifier::new(image, &expect).and_then(|mut v| {
        for c in image.get(HEADER_LEN..).unwrap_or(&[]).chunks(piece) {
            v.update(c)?;
        }
        v.finish()
    });
    assert_eq!(whole, chunked, "pieces of {piece}");
    if let Ok(h) = whole {
        use sha2::Digest;
        let body = &image[HEADER_LEN..];
        assert_eq!(body.len() as u64, u64::from(h.body_len));
        assert_eq!(<[u8; 32]>::from(sha2::Sha256::digest(body)), h.sha256);
        assert_eq!(h.board(), expect.board);
    }
});
