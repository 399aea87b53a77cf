//! The stored image: the configuration, the trigger table and the web
//! password's hash.
//!
//! Format 2 (written since register map 1.2):
//!
//! | offset | bytes | content |
//! |---|---|---|
//! | 0 | 4 | magic `HGW1` |
//! | 4 | 2 | format version 2 |
//! | 6 | 2 | N, the number of settings registers that follow |
//! | 8 | 4 × N | each: register address, value |
//! | 8 + 4N | 3072 | the 16 trigger entries, 96 registers each |
//! | 3080 + 4N | 52 | the password: PBKDF2 rounds (0 = no password), salt, hash |
//! | 3132 + 4N | 4 | CRC-32 (IEEE) of everything before |
//!
//! Settings are stored by address, so a later version that adds settings
//! reads an older image (the new settings take their defaults), and an
//! older version reading a newer image ignores what it does not know.
//! Format 1 (register map 1.1: the 16 registers 100-115 in order, the
//! triggers, no password) is still read.
//!
//! Words and numbers little-endian; a trigger entry's register holds two
//! characters, the first in its high byte (as the PLC sees them). An image
//! that fails any check (length, magic, version, CRC, a configuration value
//! out of range) is refused as a whole: nothing of it is used.

use super::StorageError;
use crate::access::password::{PasswordHash, STORED_LEN};
use crate::config::{slot_of, Config, InvalidValue, Words, CONFIG_WORDS, FIELDS};
use crate::registers::map as r;
use crate::state::inputs::{Text, TRIGGERS, TRIGGER_TEXT};

const MAGIC: &[u8; 4] = b"HGW1";
const FORMAT: u16 = 2;
const TRIGGER_WORDS: usize = TRIGGERS * TRIGGER_TEXT / 2;
const TRIGGER_BYTES: usize = TRIGGER_WORDS * 2;
/// Bytes of an image this version writes.
pub const IMAGE_LEN: usize = 8 + 4 * CONFIG_WORDS + TRIGGER_BYTES + STORED_LEN + 4;
/// The longest image read (a newer version's, with more settings).
pub const IMAGE_MAX: usize = 8 + 4 * 256 + TRIGGER_BYTES + STORED_LEN + 4;
/// Settings registers of a format-1 image (100-115).
const V1_CONFIG: usize = 16;
const V1_WORDS: usize = V1_CONFIG + TRIGGER_WORDS;
const V1_LEN: usize = 8 + V1_WORDS * 2 + 4;

/// The trigger entries as stored.
pub type Entries = [Text<TRIGGER_TEXT>; TRIGGERS];

/// What an image holds besides the trigger entries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stored {
    /// The configuration.
    pub config: Config,
    /// The web password's hash, if one was set.
    pub password: Option<PasswordHash>,
}

/// Writes the image of `stored` and the trigger `entries` into `out` and
/// returns its length ([`IMAGE_LEN`]); `out` must have room for it.
pub fn encode(stored: &Stored, entries: &Entries, out: &mut [u8]) -> Result<usize, StorageError> {
    let out = out.get_mut(..IMAGE_LEN).ok_or(StorageError::TooLarge)?;
    let mut w = Writer { out, at: 0 };
    w.put(MAGIC);
    w.put(&FORMAT.to_le_bytes());
    w.put(&(CONFIG_WORDS as u16).to_le_bytes());
    let words = stored.config.to_words();
    for f in FIELDS {
        for i in 0..f.len {
            let v = words.get(usize::from(f.slot + i)).copied().unwrap_or(0);
            w.put(&(f.addr + i).to_le_bytes());
            w.put(&v.to_le_bytes());
        }
    }
    for e in entries {
        for i in 0..TRIGGER_TEXT / 2 {
            w.put(&e.word(i).to_le_bytes());
        }
    }
    match &stored.password {
        Some(p) => w.put(&p.to_bytes()),
        None => w.put(&[0; STORED_LEN]),
    }
    let body = w.at;
    let crc = crc32(w.out.get(..body).unwrap_or(&[]));
    w.put(&crc.to_le_bytes());
    if w.at != IMAGE_LEN {
        return Err(StorageError::TooLarge);
    }
    Ok(IMAGE_LEN)
}

struct Writer<'a> {
    out: &'a mut [u8],
    at: usize,
}

impl Writer<'_> {
    fn put(&mut self, b: &[u8]) {
        if let Some(dst) = self.out.get_mut(self.at..self.at + b.len()) {
            dst.copy_from_slice(b);
        }
        self.at += b.len();
    }
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

fn word(b: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([
        b.get(at).copied().unwrap_or(0),
        b.get(at + 1).copied().unwrap_or(0),
    ])
}

/// Reads an image: the configuration (settings it does not hold keep
/// their values in `defaults`) and the password are returned, the trigger
/// texts are written into `entries`. Nothing is changed on error.
pub fn decode(
    image: &[u8],
    defaults: &Config,
    entries: &mut Entries,
) -> Result<Stored, ImageError> {
    if image.len() < 8 + 4 || image.get(..4) != Some(&MAGIC[..]) {
        return Err(ImageError::Format);
    }
    let (body, crc) = image.split_at(image.len() - 4);
    let format = word(image, 4);
    let n = usize::from(word(image, 6));
    let (settings_end, expected_len) = match format {
        1 if n == V1_WORDS => (8 + 2 * V1_CONFIG, V1_LEN),
        2 => (8 + 4 * n, 8 + 4 * n + TRIGGER_BYTES + STORED_LEN + 4),
        _ => return Err(ImageError::Format),
    };
    if image.len() != expected_len || expected_len > IMAGE_MAX {
        return Err(ImageError::Format);
    }
    if crc != crc32(body).to_le_bytes() {
        return Err(ImageError::Crc);
    }
    let mut words: Words = defaults.to_words();
    if format == 1 {
        for (i, slot) in words
            .iter_mut()
            .take(usize::from(r::CONFIG_LEN))
            .enumerate()
        {
            *slot = word(image, 8 + 2 * i);
        }
    } else {
        for at in (8..settings_end).step_by(4) {
            // Settings this version does not know are skipped.
            if let Some(slot) = slot_of(word(image, at)).and_then(|s| words.get_mut(s)) {
                *slot = word(image, at + 2);
            }
        }
    }
    let config = Config::from_words(&words).map_err(ImageError::Invalid)?;
    let password = if format == 2 {
        let at = settings_end + TRIGGER_BYTES;
        image
            .get(at..at + STORED_LEN)
            .and_then(|b| b.try_into().ok())
            .and_then(PasswordHash::from_bytes)
    } else {
        None
    };
    for (k, e) in entries.iter_mut().enumerate() {
        for i in 0..TRIGGER_TEXT / 2 {
            e.set_word(i, word(image, settings_end + k * TRIGGER_TEXT + 2 * i));
        }
    }
    Ok(Stored { config, password })
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
    extern crate std;
    use super::*;

    #[test]
    fn crc_matches_the_standard_check_value() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }

    use crate::access::password::{HASH_LEN, SALT_LEN};
    use crate::config::AllowEntry;
    use core::net::Ipv4Addr;

    fn sample() -> (Stored, Entries) {
        let mut entries: Entries = [Text::EMPTY; TRIGGERS];
        entries[3].set(b"GrpStop,0,;");
        entries[15].set(b"SetBoxDO,1,1,;");
        let mut config = Config {
            robot_port: 4242,
            write_protect: true,
            ..Config::default()
        };
        config.net.ip = Ipv4Addr::new(10, 0, 0, 9);
        config.web_allow.0[0] = AllowEntry {
            ip: Ipv4Addr::new(10, 0, 0, 0),
            prefix: 8,
        };
        let password = Some(PasswordHash {
            iterations: 1234,
            salt: [5; SALT_LEN],
            hash: [9; HASH_LEN],
        });
        (Stored { config, password }, entries)
    }

    #[test]
    fn image_round_trip_and_corruption() {
        let (stored, entries) = sample();
        let mut img = [0u8; IMAGE_LEN];
        assert_eq!(encode(&stored, &entries, &mut img), Ok(IMAGE_LEN));
        assert_eq!(
            encode(&stored, &entries, &mut [0u8; 100]),
            Err(StorageError::TooLarge)
        );
        let mut back: Entries = [Text::EMPTY; TRIGGERS];
        assert_eq!(decode(&img, &Config::DEFAULT, &mut back), Ok(stored));
        assert_eq!(back[3].bytes(), b"GrpStop,0,;");
        assert_eq!(back, entries);
        let mut bad = img;
        bad[100] ^= 1;
        let mut untouched: Entries = [Text::EMPTY; TRIGGERS];
        assert_eq!(
            decode(&bad, &Config::DEFAULT, &mut untouched),
            Err(ImageError::Crc)
        );
        assert_eq!(untouched, [Text::EMPTY; TRIGGERS]);
        assert_eq!(
            decode(&img[..10], &Config::DEFAULT, &mut back),
            Err(ImageError::Format)
        );
        let none = Stored {
            password: None,
            ..stored
        };
        encode(&none, &entries, &mut img).unwrap();
        assert_eq!(decode(&img, &Config::DEFAULT, &mut back), Ok(none));
    }

    /// A format-1 image (register map 1.1), built byte by byte as that
    /// version wrote it.
    #[test]
    fn a_format_1_image_is_read_with_defaults_for_the_new_settings() {
        let (stored, entries) = sample();
        let mut img = std::vec::Vec::new();
        img.extend_from_slice(b"HGW1");
        img.extend_from_slice(&1u16.to_le_bytes());
        img.extend_from_slice(&(V1_WORDS as u16).to_le_bytes());
        for w in &stored.config.to_words()[..16] {
            img.extend_from_slice(&w.to_le_bytes());
        }
        for e in &entries {
            for i in 0..TRIGGER_TEXT / 2 {
                img.extend_from_slice(&e.word(i).to_le_bytes());
            }
        }
        let crc = crc32(&img);
        img.extend_from_slice(&crc.to_le_bytes());
        assert_eq!(img.len(), 3116);
        let mut factory = Config::DEFAULT;
        factory.net.web_port = 8080;
        let mut back: Entries = [Text::EMPTY; TRIGGERS];
        let got = decode(&img, &factory, &mut back).unwrap();
        assert_eq!(got.config.robot_port, 4242);
        assert_eq!(got.config.net, factory.net);
        assert!(!got.config.write_protect);
        assert_eq!(got.password, None);
        assert_eq!(back, entries);
    }

    #[test]
    fn settings_are_found_by_address_and_unknown_ones_skipped() {
        let (stored, entries) = sample();
        // A "newer" image: one extra setting at an address this version
        // does not know, the known ones in another order.
        let mut img = std::vec::Vec::new();
        img.extend_from_slice(b"HGW1");
        img.extend_from_slice(&2u16.to_le_bytes());
        img.extend_from_slice(&(CONFIG_WORDS as u16 + 1).to_le_bytes());
        let words = stored.config.to_words();
        img.extend_from_slice(&117u16.to_le_bytes());
        img.extend_from_slice(&7u16.to_le_bytes());
        for f in FIELDS.iter().rev() {
            for i in 0..f.len {
                img.extend_from_slice(&(f.addr + i).to_le_bytes());
                img.extend_from_slice(&words[usize::from(f.slot + i)].to_le_bytes());
            }
        }
        for e in &entries {
            for i in 0..TRIGGER_TEXT / 2 {
                img.extend_from_slice(&e.word(i).to_le_bytes());
            }
        }
        img.extend_from_slice(&stored.password.unwrap().to_bytes());
        let crc = crc32(&img);
        img.extend_from_slice(&crc.to_le_bytes());
        let mut back: Entries = [Text::EMPTY; TRIGGERS];
        assert_eq!(decode(&img, &Config::DEFAULT, &mut back), Ok(stored));
        // An out-of-range setting refuses the whole image.
        let at = img.len() - 4 - STORED_LEN - TRIGGER_BYTES - 4 * CONFIG_WORDS;
        let mut bad = img.clone();
        // Find the pair of CFG_POLL_MS and make it 5 ms (below 10).
        let mut i = at;
        while word(&bad, i) != r::CONFIG_POLL_MS {
            i += 4;
        }
        bad[i + 2..i + 4].copy_from_slice(&5u16.to_le_bytes());
        let n = bad.len() - 4;
        let crc = crc32(&bad[..n]);
        bad[n..].copy_from_slice(&crc.to_le_bytes());
        assert_eq!(
            decode(&bad, &Config::DEFAULT, &mut back),
            Err(ImageError::Invalid(InvalidValue {
                addr: r::CONFIG_POLL_MS
            }))
        );
    }
}
