//! The signed firmware image: a fixed header in front of the firmware's
//! bytes, and its checks.
//!
//! ```text
//! offset  size  field (little-endian)                    field::
//!      0     8  magic "HANSFW1\0"                        MAGIC
//!      8     2  header length (HEADER_LEN)               HEADER_LEN
//!     10     2  format (FORMAT, 1)                       FORMAT
//!     12    16  board id, ASCII, NUL-padded              BOARD
//!               ("mps2-an386", "nucleo-f767zi")
//!     28     6  version: major, minor, patch (u16 each)  MAJOR, MINOR, PATCH
//!     34     2  flags (0; reserved)                      FLAGS
//!     36     4  body length in bytes                     BODY_LEN
//!     40    32  SHA-256 of the body                      SHA256
//!     72    64  ed25519 signature of bytes 0..72         SIGNATURE
//!    136        the body (the firmware, as the bootloader writes it to flash)
//! ```
//!
//! The signature covers the header's first 72 bytes ([`field::SIGNED`]),
//! which hold the body's hash: one signature check and one hash over the
//! body prove both. [`Packet`] reads the fields of a header in a buffer
//! (its length checked once, so no getter can fail), [`Header`] is what a
//! header says. [`Verifier`] checks an image as it arrives in pieces (an
//! upload), with bounded memory; [`check`] does it for an image in one
//! slice. Every refusal has its [`ImageError`]: what the page and the log
//! show.

#[cfg(feature = "verify")]
use ed25519_dalek::{Signature, VerifyingKey};
#[cfg(feature = "verify")]
use sha2::{Digest, Sha256};

/// The header's magic.
pub const MAGIC: [u8; 8] = *b"HANSFW1\0";
/// The header's length.
pub const HEADER_LEN: usize = field::SIGNATURE.end;
/// The format this code reads and writes.
pub const FORMAT: u16 = 1;
/// Bytes of the signed part of the header.
#[cfg(feature = "verify")]
pub const SIGNED_LEN: usize = field::SIGNED.end;
/// Bytes of a board id, at most.
pub const BOARD_MAX: usize = field::BOARD.end - field::BOARD.start;

/// The byte ranges of the header's fields (see the module docs).
pub mod field {
    /// A field: its bytes in the header.
    pub type Field = core::ops::Range<usize>;
    /// The magic, [`super::MAGIC`].
    pub const MAGIC: Field = 0..8;
    /// The header's length, [`super::HEADER_LEN`].
    pub const HEADER_LEN: Field = 8..10;
    /// The format, [`super::FORMAT`].
    pub const FORMAT: Field = 10..12;
    /// The board id, NUL-padded.
    pub const BOARD: Field = 12..28;
    /// The version's major number.
    pub const MAJOR: Field = 28..30;
    /// The version's minor number.
    pub const MINOR: Field = 30..32;
    /// The version's patch number.
    pub const PATCH: Field = 32..34;
    /// Flags: 0 (reserved).
    pub const FLAGS: Field = 34..36;
    /// The body's length.
    pub const BODY_LEN: Field = 36..40;
    /// The body's SHA-256.
    pub const SHA256: Field = 40..72;
    /// What the signature covers.
    pub const SIGNED: Field = 0..72;
    /// The ed25519 signature of [`SIGNED`].
    pub const SIGNATURE: Field = 72..136;
}

/// A firmware version (semantic: major.minor.patch), as an image's signed
/// header gives it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Version {
    /// Major.
    pub major: u16,
    /// Minor.
    pub minor: u16,
    /// Patch.
    pub patch: u16,
}

impl core::fmt::Display for Version {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{}.{}.{}", self.major, self.minor, self.patch)
    }
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

impl core::fmt::Display for ImageError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A header in a buffer: the fields of the module docs, read in place.
#[derive(Clone, Copy, Debug)]
pub struct Packet<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> Packet<T> {
    /// The buffer as a header, unchecked: a getter of a field past its end
    /// reads zeros.
    pub const fn new_unchecked(buffer: T) -> Packet<T> {
        Packet { buffer }
    }

    /// The buffer as a header: [`ImageError::TooShort`] when it is shorter
    /// than [`HEADER_LEN`] (the body may follow).
    pub fn new_checked(buffer: T) -> Result<Packet<T>, ImageError> {
        if buffer.as_ref().len() < HEADER_LEN {
            return Err(ImageError::TooShort);
        }
        Ok(Packet { buffer })
    }

    /// The bytes of `f` (zeros past the buffer's end, which
    /// [`Self::new_checked`] rules out).
    fn bytes<const N: usize>(&self, f: field::Field) -> [u8; N] {
        self.buffer
            .as_ref()
            .get(f)
            .and_then(|b| b.try_into().ok())
            .unwrap_or([0; N])
    }

    fn u16(&self, f: field::Field) -> u16 {
        u16::from_le_bytes(self.bytes(f))
    }

    /// The magic.
    pub fn magic(&self) -> [u8; 8] {
        self.bytes(field::MAGIC)
    }

    /// The header length it declares.
    pub fn header_len(&self) -> u16 {
        self.u16(field::HEADER_LEN)
    }

    /// The format.
    pub fn format(&self) -> u16 {
        self.u16(field::FORMAT)
    }

    /// The board id field, NUL-padded.
    pub fn board(&self) -> [u8; BOARD_MAX] {
        self.bytes(field::BOARD)
    }

    /// The version.
    pub fn version(&self) -> Version {
        Version {
            major: self.u16(field::MAJOR),
            minor: self.u16(field::MINOR),
            patch: self.u16(field::PATCH),
        }
    }

    /// The flags.
    pub fn flags(&self) -> u16 {
        self.u16(field::FLAGS)
    }

    /// The body's length.
    pub fn body_len(&self) -> u32 {
        u32::from_le_bytes(self.bytes(field::BODY_LEN))
    }

    /// The body's SHA-256.
    pub fn sha256(&self) -> [u8; 32] {
        self.bytes(field::SHA256)
    }

    /// The signed part.
    pub fn signed(&self) -> [u8; field::SIGNED.end] {
        self.bytes(field::SIGNED)
    }

    /// The signature.
    pub fn signature(&self) -> [u8; 64] {
        self.bytes(field::SIGNATURE)
    }
}

/// A board id is 1 to [`BOARD_MAX`] ASCII letters, digits or `-`.
fn board_id_ok(id: &[u8]) -> bool {
    !id.is_empty()
        && id.len() <= BOARD_MAX
        && id.iter().all(|b| b.is_ascii_alphanumeric() || *b == b'-')
}

/// What a header says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    board: [u8; BOARD_MAX],
    /// The firmware's version.
    pub version: Version,
    /// The body's length.
    pub body_len: u32,
    /// The body's SHA-256.
    pub sha256: [u8; 32],
    signed: [u8; field::SIGNED.end],
    signature: [u8; 64],
}

impl Header {
    /// Reads a header from the first [`HEADER_LEN`] bytes of `bytes`
    /// (checks its form only: [`Header::verify`] checks the signature).
    pub fn parse(bytes: &[u8]) -> Result<Header, ImageError> {
        Header::read(&Packet::new_checked(bytes)?)
    }

    /// What the header in `packet` says, its form checked.
    pub fn read<T: AsRef<[u8]>>(packet: &Packet<T>) -> Result<Header, ImageError> {
        if packet.magic() != MAGIC {
            return Err(ImageError::NotAnImage);
        }
        if packet.format() != FORMAT {
            return Err(ImageError::UnknownFormat(packet.format()));
        }
        if usize::from(packet.header_len()) != HEADER_LEN || packet.flags() != 0 {
            return Err(ImageError::BadHeader);
        }
        let board = packet.board();
        let len = board.iter().position(|b| *b == 0).unwrap_or(BOARD_MAX);
        let (id, pad) = board.split_at(len);
        if !board_id_ok(id) || pad.iter().any(|b| *b != 0) {
            return Err(ImageError::BadHeader);
        }
        Ok(Header {
            board,
            version: packet.version(),
            body_len: packet.body_len(),
            sha256: packet.sha256(),
            signed: packet.signed(),
            signature: packet.signature(),
        })
    }

    /// The board id.
    pub fn board(&self) -> &str {
        let len = self.board.iter().position(|b| *b == 0).unwrap_or(BOARD_MAX);
        core::str::from_utf8(self.board.get(..len).unwrap_or(&[])).unwrap_or("")
    }

    /// Checks the signature with `key` (ed25519, strict verification).
    #[cfg(feature = "verify")]
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
    #[cfg(feature = "verify")]
    pub fn signed_part(board: &str, version: Version, body: &[u8]) -> Option<[u8; SIGNED_LEN]> {
        let b = board.as_bytes();
        if !board_id_ok(b) {
            return None;
        }
        let len = u32::try_from(body.len()).ok()?;
        let mut out = [0u8; SIGNED_LEN];
        let mut put = |f: field::Field, bytes: &[u8]| -> Option<()> {
            out.get_mut(f)?
                .get_mut(..bytes.len())?
                .copy_from_slice(bytes);
            Some(())
        };
        put(field::MAGIC, &MAGIC)?;
        put(field::HEADER_LEN, &(HEADER_LEN as u16).to_le_bytes())?;
        put(field::FORMAT, &FORMAT.to_le_bytes())?;
        put(field::BOARD, b)?;
        put(field::MAJOR, &version.major.to_le_bytes())?;
        put(field::MINOR, &version.minor.to_le_bytes())?;
        put(field::PATCH, &version.patch.to_le_bytes())?;
        put(field::BODY_LEN, &len.to_le_bytes())?;
        put(field::SHA256, &Sha256::digest(body))?;
        Some(out)
    }

    /// The whole header: the signed part and its signature.
    #[cfg(feature = "verify")]
    pub fn write(signed: &[u8; SIGNED_LEN], signature: &[u8; 64]) -> [u8; HEADER_LEN] {
        let mut out = [0u8; HEADER_LEN];
        let (a, b) = out.split_at_mut(SIGNED_LEN);
        a.copy_from_slice(signed);
        b.copy_from_slice(signature);
        out
    }
}

/// What an image must match to be installed.
#[cfg(feature = "verify")]
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
#[cfg(feature = "verify")]
#[derive(Clone, Debug)]
pub struct Verifier {
    header: Header,
    hasher: Sha256,
    seen: u64,
}

#[cfg(feature = "verify")]
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
#[cfg(feature = "verify")]
pub fn check(image: &[u8], expect: &Expect<'_>) -> Result<Header, ImageError> {
    let mut v = Verifier::new(image, expect)?;
    v.update(image.get(HEADER_LEN..).unwrap_or(&[]))?;
    v.finish()
}

/// The header of a signed image of `body` for `board` at `version`,
/// signed with the ed25519 key whose secret seed is `seed`: the image is
/// this header, then the body (what `hans-fw sign` writes). `None` where
/// [`Header::signed_part`] refuses.
#[cfg(feature = "sign")]
pub fn sign(
    seed: &[u8; 32],
    board: &str,
    version: Version,
    body: &[u8],
) -> Option<[u8; HEADER_LEN]> {
    use ed25519_dalek::{Signer, SigningKey};
    let signed = Header::signed_part(board, version, body)?;
    let signature = SigningKey::from_bytes(seed).sign(&signed).to_bytes();
    Some(Header::write(&signed, &signature))
}

/// The public key of the secret seed `seed` (what a device trusts).
#[cfg(feature = "sign")]
pub fn public_key(seed: &[u8; 32]) -> [u8; 32] {
    ed25519_dalek::SigningKey::from_bytes(seed)
        .verifying_key()
        .to_bytes()
}

/// A public key from its hex text (64 hex digits, surrounding whitespace
/// allowed), as `hans-fw keygen` writes it. A `const fn`, so that a board
/// compiles its key file in (`fw-keys`: a malformed file stops the build).
pub const fn key_from_hex(text: &[u8]) -> Option<[u8; 32]> {
    const fn digit(c: u8) -> Option<u8> {
        match c {
            b'0'..=b'9' => Some(c - b'0'),
            b'a'..=b'f' => Some(c - b'a' + 10),
            b'A'..=b'F' => Some(c - b'A' + 10),
            _ => None,
        }
    }
    let mut rest = text.trim_ascii();
    let mut key = [0u8; 32];
    let mut i = 0;
    // Slice patterns rather than indexing: a `const fn` has no `get`.
    while let [hi, lo, tail @ ..] = rest {
        let (Some(hi), Some(lo)) = (digit(*hi), digit(*lo)) else {
            return None;
        };
        let Some(k) = byte_mut(&mut key, i) else {
            return None;
        };
        *k = hi << 4 | lo;
        i += 1;
        rest = tail;
    }
    if i == 32 && rest.is_empty() {
        Some(key)
    } else {
        None
    }
}

/// The `i`th byte of `key`, `None` past its end (a `const` stand-in for
/// `get_mut`).
const fn byte_mut(key: &mut [u8; 32], i: usize) -> Option<&mut u8> {
    match key.split_at_mut_checked(i) {
        Some((_, [k, ..])) => Some(k),
        _ => None,
    }
}
