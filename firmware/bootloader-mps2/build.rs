//! Linker inputs of the bootloader: its own `memory.x` (64 KiB at 0x0), and
//! an empty `defmt.x`. The firmware workspace links every binary with
//! `-Tdefmt.x` (`.cargo/config.toml`), but the bootloader has no defmt
//! logger: its log is text on semihosting's stderr, because QEMU's stdout
//! carries the application's defmt frames, which are decoded with the
//! application's ELF (frames of another ELF would decode to wrong messages).
use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let dir = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    let memory = dir.join("memory.x");
    fs::copy(&memory, out.join("memory.x")).expect("memory.x is readable");
    fs::write(
        out.join("defmt.x"),
        "/* no defmt in the bootloader (see build.rs) */\n",
    )
    .expect("OUT_DIR is writable");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={}", memory.display());
    println!("cargo:rerun-if-changed=build.rs");
}
