//! Puts the board's linker inputs on the link search path: the top-level
//! `memory.x` (the default board's memory map) and this crate's `device.x`
//! (interrupt handler names for the vector table).
use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let dir = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    let memory = dir.join("../../../memory.x");
    let device = dir.join("device.x");
    fs::copy(&memory, out.join("memory.x")).expect("top-level memory.x is readable");
    fs::copy(&device, out.join("device.x")).expect("device.x is readable");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={}", memory.display());
    println!("cargo:rerun-if-changed={}", device.display());
}
