//! The stored image: the configuration and the trigger table.
//!
//! | offset | bytes | content |
//! |---|---|---|
//! | 0 | 4 | magic `HGW1` |
//! | 4 | 2 | format version 1 |
//! | 6 | 2 | number of words that follow (1552) |
//! | 8 | 32 | the 16 configuration registers |
//! | 40 | 3072 | the 16 trigger entries, 96 registers each |
//! | 3112 | 4 | CRC-32 (IEEE) of everything before |
//!
//! Words and numbers little-endian; a trigger entry's register holds two
//! characters, the first in its high byte (as the PLC sees them). An image
//! that fails any check (length, magic, version, CRC, a configuration value
//! out of range) is refused as a whole: nothing of it is used.

use super::StorageError;
use crate::config::{Config, InvalidValue, Words};
use crate::registers::map as r;
use crate::state::inputs::{Text, TRIGGERS, TRIGGER_TEXT};

const MAGIC: &[u8; 4] = b"HGW1";
const FORMAT: u16 = 1;
const TRIGGER_WORDS: usize = TRIGGERS * TRIGGER_TEXT / 2;
const WORDS: usize = r::CONFIG_LEN as usize + TRIGGER_WORDS;
/// Bytes of a stored image.
pub const IMAGE_LEN: usize = 4 + 2 + 2 + WORDS * 2 + 4;
const BODY: usize = IMAGE_LEN - 4;

/// The trigger entries as stored.
pub type Entries = [Text<TRIGGER_TEXT>; TRIGGERS];

/// Writes the image of `config` and the trigger `entries` into `out` and
/// returns its length ([`IMAGE_LEN`]); `out` must have room for it.
pub fn encode(config: &Config, entries: &Entries, out: &mut [u8]) -> Result<usize, StorageError> {
    let out: &mut [u8; IMAGE_LEN] = out
        .get_mut(..IMAGE_LEN)
        .and_then(|o| o.try_into().ok())
        .ok_or(StorageError::TooLarge)?;
    let (head, rest) = out.split_at_mut(8);
    head[..4].copy_from_slice(MAGIC);
    head[4..6].copy_from_slice(&FORMAT.to_le_bytes());
    head[6..8].copy_from_slice(&(WORDS as u16).to_le_bytes());
    let trig = entries
        .iter()
        .flat_map(|e| (0..TRIGGER_TEXT / 2).map(move |i| e.word(i)));
    let mut words = config.to_words().into_iter().chain(trig);
    let (body, _) = rest.split_at_mut(WORDS * 2);
    for chunk in body.chunks_exact_mut(2) {
        chunk.copy_from_slice(&words.next().unwrap_or(0).to_le_bytes());
    }
    let crc = crc32(&out[..BODY]);
    out[BODY..].copy_from_slice(&crc.to_le_bytes());
    Ok(IMAGE_LEN)
}

/// Why a stored image was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ImageError {
    /// Wrong length, magic or format version.
    Format,
    /// The CRC does not match.
    Crc,
    /// A configuration value is out of range.
    Invalid(InvalidValue),
}

impl ImageError {
    /// A short text for logs.
    pub fn as_str(self) -> &'static str {
        match self {
            ImageError::Format => "not an image of this format",
            ImageError::Crc => "CRC mismatch (damaged)",
            ImageError::Invalid(_) => "a setting out of range",
        }
    }
}

/// Reads an image: the configuration is returned, the trigger texts are
/// written into `entries`. Nothing is changed on error.
pub fn decode(image: &[u8], entries: &mut Entries) -> Result<Config, ImageError> {
    if image.len() != IMAGE_LEN
        || image.get(..4) != Some(&MAGIC[..])
        || image.get(4..6) != Some(&FORMAT.to_le_bytes()[..])
        || image.get(6..8) != Some(&(WORDS as u16).to_le_bytes()[..])
    {
        return Err(ImageError::Format);
    }
    let (body, crc) = image.split_at(BODY);
    if crc != crc32(body).to_le_bytes() {
        return Err(ImageError::Crc);
    }
    let mut words = body.get(8..).unwrap_or(&[]).chunks_exact(2).map(|c| {
        u16::from_le_bytes([
            c.first().copied().unwrap_or(0),
            c.get(1).copied().unwrap_or(0),
        ])
    });
    let mut cw: Words = [0; r::CONFIG_LEN as usize];
    for slot in cw.iter_mut() {
        *slot = words.next().unwrap_or(0);
    }
    let config = Config::from_words(&cw).map_err(ImageError::Invalid)?;
    for e in entries.iter_mut() {
        for i in 0..TRIGGER_TEXT / 2 {
            e.set_word(i, words.next().unwrap_or(0));
        }
    }
    Ok(config)
}

/// CRC-32 (IEEE, reflected), bitwise: a few bytes of code for a check run
/// only at load and save, not worth a dependency.
fn crc32(data: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in data {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_matches_the_standard_check_value() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn image_round_trip_and_corruption() {
        let mut entries: Entries = [Text::EMPTY; TRIGGERS];
        entries[3].set(b"GrpStop,0,;");
        let c = Config {
            robot_port: 4242,
            ..Config::default()
        };
        let mut img = [0u8; IMAGE_LEN];
        assert_eq!(encode(&c, &entries, &mut img), Ok(IMAGE_LEN));
        assert_eq!(
            encode(&c, &entries, &mut [0u8; 100]),
            Err(StorageError::TooLarge)
        );
        let mut back: Entries = [Text::EMPTY; TRIGGERS];
        assert_eq!(decode(&img, &mut back), Ok(c));
        assert_eq!(back[3].bytes(), b"GrpStop,0,;");
        assert_eq!(back, entries);
        let mut bad = img;
        bad[100] ^= 1;
        let mut untouched: Entries = [Text::EMPTY; TRIGGERS];
        assert_eq!(decode(&bad, &mut untouched), Err(ImageError::Crc));
        assert_eq!(untouched, [Text::EMPTY; TRIGGERS]);
        assert_eq!(decode(&img[..10], &mut back), Err(ImageError::Format));
    }
}
