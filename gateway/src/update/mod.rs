//! Firmware updates (feature `update`): the signed image format and its
//! checks ([`image`]). Built so far: the format, the checks an upload
//! passes before anything is installed, and the host tool that signs
//! (`host-tests/hans-fw`). The bootloader, the A/B slots and the page's
//! upload come next (issue: signed A/B updates).

pub mod image;

#[cfg(test)]
mod tests;
