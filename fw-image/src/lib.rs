//! # hans-fw-image
//!
//! The signed firmware image of the Hans gateway, and where it goes on
//! each board: the contract between the programs that meet an image.
//!
//! | who | what it uses |
//! |---|---|
//! | `hans-fw` (the signing tool) | [`Header::signed_part`], [`Header::write`], [`check`], [`layout`] |
//! | the bootloaders (`fw-boot`) | [`Header::parse`], [`Verifier`], [`layout`] |
//! | the gateway (the upload, its state) | [`Verifier`], [`Version`], [`layout::of`] |
//!
//! A bootloader stays on a board for years while the gateway is updated
//! under it, so this crate is kept apart from the gateway: it depends on
//! nothing of it, and a change here is a change of the contract.
//!
//! ## The format is versioned
//! The header carries its format ([`FORMAT`], today 1). A reader refuses a
//! format it does not know ([`ImageError::UnknownFormat`]), and the images
//! in `vectors/` (written by this crate's first release, signed with the
//! development key) must be read by every later release: a test checks
//! them. A change of the layout of the header is a new format number and
//! new vectors beside the old ones.
//!
//! ## Features
//! * `verify` (default): the checks that need cryptography (ed25519,
//!   SHA-256). Without it the header's form, [`Version`] and the layouts
//!   remain.
//! * `sign`: making images (`sign`, `public_key`), for the signing tool and
//!   tests; never in a firmware.
#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]
#![cfg_attr(
    test,
    allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )
)]

#[cfg(test)]
extern crate std;

mod image;
pub mod layout;

pub use image::BOARD_MAX;
#[cfg(feature = "verify")]
pub use image::{check, Expect, Verifier, SIGNED_LEN};
pub use image::{
    field, key_from_hex, Header, ImageError, Packet, Version, FORMAT, HEADER_LEN, MAGIC,
};
#[cfg(feature = "sign")]
pub use image::{public_key, sign};

#[cfg(test)]
mod tests;
