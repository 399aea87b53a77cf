//! The image checks, against images signed here with ed25519-dalek.

use std::format;
use std::vec::Vec;

use crate::*;

const SEED: [u8; 32] = [7; 32];
const OTHER: [u8; 32] = [9; 32];
const V: Version = Version {
    major: 1,
    minor: 2,
    patch: 3,
};

fn sign(seed: &[u8; 32], board: &str, version: Version, body: &[u8]) -> Vec<u8> {
    let mut out = crate::sign(seed, board, version, body).unwrap().to_vec();
    out.extend_from_slice(body);
    out
}

fn public(seed: &[u8; 32]) -> [u8; 32] {
    public_key(seed)
}

fn body() -> Vec<u8> {
    (0..5000u32).map(|i| (i * 31 % 251) as u8).collect()
}

fn expect(key: &[u8; 32]) -> Expect<'_> {
    Expect {
        key,
        board: "mps2-an386",
        running: Version {
            major: 1,
            minor: 2,
            patch: 0,
        },
        allow_downgrade: false,
        max_body: 1 << 20,
    }
}

#[test]
fn a_signed_image_passes_and_says_what_it_is() {
    let key = public(&SEED);
    let img = sign(&SEED, "mps2-an386", V, &body());
    let h = check(&img, &expect(&key)).unwrap();
    assert_eq!((h.board(), h.version, h.body_len), ("mps2-an386", V, 5000));
}

#[test]
fn every_kind_of_bad_image_is_refused_with_its_reason() {
    let key = public(&SEED);
    let e = expect(&key);
    let good = sign(&SEED, "mps2-an386", V, &body());
    // Another key.
    let other = sign(&OTHER, "mps2-an386", V, &body());
    assert_eq!(check(&other, &e), Err(ImageError::BadSignature));
    // Another board (signed by the right key).
    let board = sign(&SEED, "nucleo-f767zi", V, &body());
    assert_eq!(check(&board, &e), Err(ImageError::WrongBoard));
    // Truncated, and too long.
    assert_eq!(
        check(&good[..good.len() - 1], &e),
        Err(ImageError::WrongLength)
    );
    let mut long = good.clone();
    long.push(0);
    assert_eq!(check(&long, &e), Err(ImageError::WrongLength));
    // A byte of the body changed.
    let mut bad = good.clone();
    bad[HEADER_LEN + 100] ^= 1;
    assert_eq!(check(&bad, &e), Err(ImageError::HashMismatch));
    // A byte of the signed header changed (the version, to upgrade).
    let mut bad = good.clone();
    bad[28] ^= 1;
    assert_eq!(check(&bad, &e), Err(ImageError::BadSignature));
    // The signature changed.
    let mut bad = good.clone();
    bad[SIGNED_LEN + 3] ^= 0x40;
    assert_eq!(check(&bad, &e), Err(ImageError::BadSignature));
    // Older than the running one: only when allowed.
    let old = sign(
        &SEED,
        "mps2-an386",
        Version {
            major: 1,
            minor: 1,
            patch: 9,
        },
        &body(),
    );
    assert_eq!(check(&old, &e), Err(ImageError::Downgrade));
    assert!(check(
        &old,
        &Expect {
            allow_downgrade: true,
            ..e
        }
    )
    .is_ok());
    // Larger than the slot.
    assert_eq!(
        check(
            &good,
            &Expect {
                max_body: 4999,
                ..e
            }
        ),
        Err(ImageError::TooLarge)
    );
    // Not an image at all, too short, another format.
    assert_eq!(check(&[0u8; 200], &e), Err(ImageError::NotAnImage));
    assert_eq!(
        check(&good[..HEADER_LEN - 1], &e),
        Err(ImageError::TooShort)
    );
    let mut fmt = good.clone();
    fmt[10] = 2;
    assert_eq!(check(&fmt, &e), Err(ImageError::UnknownFormat(2)));
    // Every refusal has a text.
    assert!(!ImageError::HashMismatch.as_str().is_empty());
}

#[test]
fn an_image_in_pieces_is_judged_as_the_whole() {
    let key = public(&SEED);
    let e = expect(&key);
    let good = sign(&SEED, "mps2-an386", V, &body());
    let mut bad = good.clone();
    bad[HEADER_LEN + 4321] ^= 0x80;
    for img in [&good, &bad, &good[..good.len() - 7].to_vec()] {
        let whole = check(img, &e);
        for piece in [1, 7, 64, 1000, 4096] {
            let mut v = Verifier::new(img, &e).unwrap();
            let mut r = Ok(());
            for c in img[HEADER_LEN..].chunks(piece) {
                r = v.update(c);
                if r.is_err() {
                    break;
                }
            }
            let got = r.and_then(|()| v.finish());
            assert_eq!(got, whole, "pieces of {piece}");
        }
    }
}

#[test]
fn the_signing_side_refuses_what_the_reader_would() {
    assert!(Header::signed_part("", V, b"x").is_none());
    assert!(Header::signed_part("a/b", V, b"x").is_none());
    assert!(Header::signed_part("seventeen-chars-x", V, b"x").is_none());
    assert!(Header::signed_part("sixteen-chars-xx", V, b"x").is_some());
}

#[test]
fn a_key_file_reads_as_its_key() {
    let text = *b"  f3d6c3f24de573f8523d650e705a4e2c32aaa724431051c75ffa82fefc66c42e\n";
    let k = key_from_hex(&text).expect("a key");
    assert_eq!(k[0], 0xf3);
    assert_eq!(k[31], 0x2e);
    assert_eq!(key_from_hex(b"f3d6"), None);
    let mut bad = text;
    bad[3] = b'g';
    assert_eq!(key_from_hex(&bad), None);
    let mut long = [b'a'; 66];
    assert_eq!(key_from_hex(&long), None);
    long[64] = b' ';
    long[65] = b' ';
    assert!(key_from_hex(&long).is_some());
    // Usable where a board compiles its key in.
    const K: Option<[u8; 32]> =
        key_from_hex(b"00000000000000000000000000000000000000000000000000000000000000ff");
    assert_eq!(K.map(|k| k[31]), Some(0xff));
}

/// The images of `vectors/format1.txt`, written by the first release:
/// every release reads them as the file says (the format is a contract).
#[test]
fn the_first_releases_images_read_as_they_did() {
    fn bytes(hex: &str) -> Vec<u8> {
        (0..hex.len())
            .step_by(2)
            .map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap())
            .collect()
    }
    let text = include_str!("../vectors/format1.txt");
    let mut key = None;
    let (mut passed, mut refused) = (0, 0);
    for line in text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.is_empty())
    {
        let f: Vec<&str> = line.split(' ').collect();
        match f[..] {
            ["key", hex] => key = key_from_hex(hex.as_bytes()),
            ["ok", board, version, len, hex] => {
                let key = key.expect("the key line comes first");
                let image = bytes(hex);
                let v: Vec<u16> = version.split('.').map(|n| n.parse().unwrap()).collect();
                let version = Version {
                    major: v[0],
                    minor: v[1],
                    patch: v[2],
                };
                let e = Expect {
                    key: &key,
                    board,
                    running: Version {
                        major: 0,
                        minor: 0,
                        patch: 0,
                    },
                    allow_downgrade: false,
                    max_body: u32::MAX,
                };
                let h = check(&image, &e).unwrap_or_else(|err| panic!("{line}: {err}"));
                assert_eq!(
                    (h.board(), h.version, h.body_len),
                    (board, version, len.parse().unwrap())
                );
                assert_eq!(Header::parse(&image), Ok(h));
                passed += 1;
            }
            ["err", reason, hex] => {
                let key = key.expect("the key line comes first");
                let image = bytes(hex);
                let e = Expect {
                    key: &key,
                    board: "mps2-an386",
                    running: Version {
                        major: 0,
                        minor: 0,
                        patch: 0,
                    },
                    allow_downgrade: false,
                    max_body: u32::MAX,
                };
                let got = check(&image, &e).expect_err(line);
                assert_eq!(format!("{got:?}").split('(').next(), Some(reason));
                refused += 1;
            }
            _ => panic!("a line the file's header does not describe: {line}"),
        }
    }
    assert_eq!((passed, refused), (3, 4));
}
