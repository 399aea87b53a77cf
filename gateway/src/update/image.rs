//! The signed firmware image (feature `update`): a fixed header in front of
//! the firmware's bytes, and its checks.
//!
//! ```text
//! offset  size  field (little-endian)
//!      0     8  magic "HANSFW1\0"
//!      8     2  header length (HEADER_LEN)
//!     10     2  format (1)
//!     12    16  board id, ASCII, NUL-padded ("mps2-an386", "nucleo-f767zi")
//!     28     6  version: major, minor, patch (u16 each)
//!     34     2  flags (0; reserved)
//!     36     4  body length in bytes
//!     40    32  SHA-256 of the body
//!     72    64  ed25519 signature of bytes 0..72
//!    136        the body (the firmware, as the bootloader writes it to flash)
//! ```
//!
//! The signature covers the header's first 72 bytes, which hold the body's
//! hash: one signature check and one hash over the body prove both.
//! [`Verifier`] checks an image as it arrives in pieces (an upload), with
//! bounded memory; [`check`] does it for an image in one slice. Every
//! refusal has its [`ImageError`]: what the page and the log show.

use ed25519_dalek::{Signature, VerifyingKey};
use sha2::{Digest, Sha256};

/// The header's magic.
pub const MAGIC: [u8; 8] = *b"HANSFW1\0";
/// The header's length.
pub const HEADER_LEN: usize = 136;
/// The format this code reads and writes.
pub const FORMAT: u16 = 1;
/// Bytes of the signed part of the header.
pub const SIGNED_LEN: usize = 72;
/// Bytes of a board id, at most.
pub const BOARD_MAX: usize = 16;

pub use crate::state::firmware::Version;

/// What the header says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    board: [u8; BOARD_MAX],
    /// The firmware's version.
    pub version: Version,
    /// The body's length.
    pub body_len: u32,
    /// The body's SHA-256.
    pub sha256: [u8; 32],
    signed: [u8; SIGNED_LEN],
    signature: [u8; 64],
}

/// Why an image is refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageError {
    /// Fewer bytes than a header.
    TooShort,
    /// Not an image of this project (magic).
    NotAnImage,
    /// A format this code does not read.
    UnknownFormat(u16),
    /// The header is malformed (length, flags, board id).
    BadHeader,
    /// For another board.
    WrongBoard,
    /// Not signed by the key (or the header was changed).
    BadSignature,
    /// The body is shorter or longer than the header says.
    WrongLength,
    /// The body is not the one signed (corrupted).
    HashMismatch,
    /// Older than the running firmware, and downgrades are not allowed.
    Downgrade,
    /// Larger than the slot it would go to.
    TooLarge,
}

impl ImageError {
    /// A short text for the page and the log.
    pub fn as_str(self) -> &'static str {
        match self {
            ImageError::TooShort => "not an image: too short for a header",
            ImageError::NotAnImage => "not a firmware image of this gateway",
            ImageError::UnknownFormat(_) => "image format not known to this firmware",
            ImageError::BadHeader => "malformed image header",
            ImageError::WrongBoard => "image for another board",
            ImageError::BadSignature => "not signed by the trusted key",
            ImageError::WrongLength => "image truncated or too long",
            ImageError::HashMismatch => "image corrupted (hash mismatch)",
            ImageError::Downgrade => "older than the running firmware (downgrade not allowed)",
            ImageError::TooLarge => "image larger than the update slot",
        }
    }
}

fn le16(b: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_le_bytes([*b.get(at)?, *b.get(at + 1)?]))
}

fn le32(b: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes([
        *b.get(at)?,
        *b.get(at + 1)?,
        *b.get(at + 2)?,
        *b.get(at + 3)?,
    ]))
}

impl Header {
    /// Reads a header from the first [`HEADER_LEN`] bytes of `bytes`
    /// (checks its form only: [`Header::verify`] checks the signature).
    pub fn parse(bytes: &[u8]) -> Result<Header, ImageError> {
        let h = bytes.get(..HEADER_LEN).ok_or(ImageError::TooShort)?;
        if h.get(..8) != Some(&MAGIC[..]) {
            return Err(ImageError::NotAnImage);
        }
        let format = le16(h, 10).ok_or(ImageError::TooShort)?;
        if format != FORMAT {
            return Err(ImageError::UnknownFormat(format));
        }
        if le16(h, 8) != Some(HEADER_LEN as u16) || le16(h, 34) != Some(0) {
            return Err(ImageError::BadHeader);
        }
        let mut board = [0u8; BOARD_MAX];
        board.copy_from_slice(h.get(12..28).ok_or(ImageError::TooShort)?);
        let len = board.iter().position(|b| *b == 0).unwrap_or(BOARD_MAX);
        let (id, pad) = board.split_at(len);
        if id.is_empty()
            || !id.iter().all(|b| b.is_ascii_alphanumeric() || *b == b'-')
            || pad.iter().any(|b| *b != 0)
        {
            return Err(ImageError::BadHeader);
        }
        let v = |at| le16(h, at).ok_or(ImageError::TooShort);
        let version = Version {
            major: v(28)?,
            minor: v(30)?,
            patch: v(32)?,
        };
        let body_len = le32(h, 36).ok_or(ImageError::TooShort)?;
        let mut sha256 = [0u8; 32];
        sha256.copy_from_slice(h.get(40..72).ok_or(ImageError::TooShort)?);
        let mut signed = [0u8; SIGNED_LEN];
        signed.copy_from_slice(h.get(..SIGNED_LEN).ok_or(ImageError::TooShort)?);
        let mut signature = [0u8; 64];
        signature.copy_from_slice(h.get(SIGNED_LEN..HEADER_LEN).ok_or(ImageError::TooShort)?);
        Ok(Header {
            board,
            version,
            body_len,
            sha256,
            signed,
            signature,
        })
    }

    /// The board id.
    pub fn board(&self) -> &str {
        let len = self.board.iter().position(|b| *b == 0).unwrap_or(BOARD_MAX);
        core::str::from_utf8(self.board.get(..len).unwrap_or(&[])).unwrap_or("")
    }

    /// Checks the signature with `key` (ed25519, strict verification).
    pub fn verify(&self, key: &[u8; 32]) -> Result<(), ImageError> {
        let key = VerifyingKey::from_bytes(key).map_err(|_| ImageError::BadSignature)?;
        let sig = Signature::from_bytes(&self.signature);
        key.verify_strict(&self.signed, &sig)
            .map_err(|_| ImageError::BadSignature)
    }

    /// Writes the signed part of a header for `board`, `version` and
    /// `body` (the signing tool signs it and appends the signature:
    /// [`Header::write`]). `None` for a board id that is not 1 to
    /// [`BOARD_MAX`] letters, digits or `-`, or a body over 4 GiB.
    pub fn signed_part(board: &str, version: Version, body: &[u8]) -> Option<[u8; SIGNED_LEN]> {
        let b = board.as_bytes();
        if b.is_empty()
            || b.len() > BOARD_MAX
            || !b.iter().all(|c| c.is_ascii_alphanumeric() || *c == b'-')
        {
            return None;
        }
        let len = u32::try_from(body.len()).ok()?;
        let mut out = [0u8; SIGNED_LEN];
        out.get_mut(..8)?.copy_from_slice(&MAGIC);
        out.get_mut(8..10)?
            .copy_from_slice(&(HEADER_LEN as u16).to_le_bytes());
        out.get_mut(10..12)?.copy_from_slice(&FORMAT.to_le_bytes());
        out.get_mut(12..12 + b.len())?.copy_from_slice(b);
        out.get_mut(28..30)?
            .copy_from_slice(&version.major.to_le_bytes());
        out.get_mut(30..32)?
            .copy_from_slice(&version.minor.to_le_bytes());
        out.get_mut(32..34)?
            .copy_from_slice(&version.patch.to_le_bytes());
        out.get_mut(36..40)?.copy_from_slice(&len.to_le_bytes());
        out.get_mut(40..72)?.copy_from_slice(&Sha256::digest(body));
        Some(out)
    }

    /// The whole header: the signed part and its signature.
    pub fn write(signed: &[u8; SIGNED_LEN], signature: &[u8; 64]) -> [u8; HEADER_LEN] {
        let mut out = [0u8; HEADER_LEN];
        let (a, b) = out.split_at_mut(SIGNED_LEN);
        a.copy_from_slice(signed);
        b.copy_from_slice(signature);
        out
    }
}

/// What an image must match to be installed.
#[derive(Clone, Copy, Debug)]
pub struct Expect<'a> {
    /// The trusted key (ed25519 public key).
    pub key: &'a [u8; 32],
    /// This device's board id.
    pub board: &'a str,
    /// The running firmware's version.
    pub running: Version,
    /// An administrator allowed an older version.
    pub allow_downgrade: bool,
    /// The largest body the update slot holds.
    pub max_body: u32,
}

/// Checks an image that arrives in pieces (an upload): the header first
/// (signature, board, version, size: refused before a byte of the body is
/// taken), then the body, hashed as it comes. Memory: the header and a
/// hash state.
#[derive(Clone, Debug)]
pub struct Verifier {
    header: Header,
    hasher: Sha256,
    seen: u64,
}

impl Verifier {
    /// Starts with the image's header (its first [`HEADER_LEN`] bytes).
    pub fn new(header: &[u8], expect: &Expect<'_>) -> Result<Verifier, ImageError> {
        let h = Header::parse(header)?;
        h.verify(expect.key)?;
        if h.board() != expect.board {
            return Err(ImageError::WrongBoard);
        }
        if h.body_len > expect.max_body {
            return Err(ImageError::TooLarge);
        }
        if h.version < expect.running && !expect.allow_downgrade {
            return Err(ImageError::Downgrade);
        }
        Ok(Verifier {
            header: h,
            hasher: Sha256::new(),
            seen: 0,
        })
    }

    /// The header (checked).
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// Takes the next piece of the body; refuses a body longer than the
    /// header says at once.
    pub fn update(&mut self, piece: &[u8]) -> Result<(), ImageError> {
        self.seen = self.seen.saturating_add(piece.len() as u64);
        if self.seen > u64::from(self.header.body_len) {
            return Err(ImageError::WrongLength);
        }
        self.hasher.update(piece);
        Ok(())
    }

    /// The body is complete: its length and hash are the signed ones.
    pub fn finish(self) -> Result<Header, ImageError> {
        if self.seen != u64::from(self.header.body_len) {
            return Err(ImageError::WrongLength);
        }
        let hash: [u8; 32] = self.hasher.finalize().into();
        if hash != self.header.sha256 {
            return Err(ImageError::HashMismatch);
        }
        Ok(self.header)
    }
}

/// Checks a whole image (header and body in `image`).
pub fn check(image: &[u8], expect: &Expect<'_>) -> Result<Header, ImageError> {
    let mut v = Verifier::new(image, expect)?;
    v.update(image.get(HEADER_LEN..).unwrap_or(&[]))?;
    v.finish()
}

/// A public key from its hex text (64 hex digits, surrounding whitespace
/// allowed), as `hans-fw keygen` writes it (a board compiles its key file
/// in with `include_bytes!`).
pub fn key_from_hex(text: &[u8]) -> Option<[u8; 32]> {
    fn digit(c: u8) -> Option<u8> {
        match c {
            b'0'..=b'9' => Some(c - b'0'),
            b'a'..=b'f' => Some(c - b'a' + 10),
            b'A'..=b'F' => Some(c - b'A' + 10),
            _ => None,
        }
    }
    let text = text.trim_ascii();
    if text.len() != 64 {
        return None;
    }
    let mut key = [0u8; 32];
    for (k, pair) in key.iter_mut().zip(text.chunks_exact(2)) {
        let [hi, lo] = pair else { return None };
        *k = digit(*hi)? << 4 | digit(*lo)?;
    }
    Some(key)
}
