//! Board-independent helpers shared by the firmware boards.
#![no_std]
#![deny(missing_docs)]

pub mod stack;
