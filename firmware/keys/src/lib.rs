//! The public key (ed25519) a firmware image must be signed with: the
//! bootloader checks it before it swaps in or starts an image, the
//! field-device firmware before it takes an upload. One constant for both,
//! so they cannot trust different keys.
//!
//! It is `HANS_FW_PUBKEY` at build time (64 hex digits, as `hans-fw keygen`
//! writes them to `NAME.pub`), else **the development key** `dev.pub`,
//! whose secret half is in this repository: anyone can sign with it. A
//! plant makes its own key and builds its firmware with it (README.md
//! here):
//!
//! ```sh
//! HANS_FW_PUBKEY=$(cat plant-2027.pub) cargo build --release -p bootloader-mps2
//! ```
#![no_std]
#![deny(missing_docs)]

/// The trusted key.
pub const TRUSTED: [u8; 32] = match option_env!("HANS_FW_PUBKEY") {
    Some(hex) => parse(hex.as_bytes()),
    None => parse(include_bytes!("../dev.pub")),
};

/// Whether [`TRUSTED`] is the development key (a build without
/// `HANS_FW_PUBKEY`): worth a warning in a log.
pub const IS_DEVELOPMENT_KEY: bool = option_env!("HANS_FW_PUBKEY").is_none();

/// 64 hex digits (white space may follow) as 32 bytes, read by the image
/// crate's parser (the one `hans-fw` uses). Malformed text stops the
/// build: the constant's evaluation fails.
const fn parse(text: &[u8]) -> [u8; 32] {
    match hans_fw_image::key_from_hex(text) {
        Some(key) => key,
        None => panic!("HANS_FW_PUBKEY / dev.pub: not 64 hex digits"),
    }
}
