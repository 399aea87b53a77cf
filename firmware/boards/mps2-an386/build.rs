//! Puts the board's linker inputs on the link search path: its memory maps
//! and this crate's `device.x` (interrupt handler names for the vector
//! table).
//!
//! cortex-m-rt's `link.x` includes `memory.x`, found on the search path;
//! each binary gets the directory of its own:
//! * `gateway` and `smoke` run alone (QEMU's `-kernel`): the top-level
//!   `memory.x`, code from 0x0;
//! * `field-device` runs through the bootloader (`firmware/bootloader-mps2`),
//!   which copies the flash file's active slot to RAM and starts it there:
//!   `memory-slot.x`, code from `layout::MPS2_AN386.entry` (0x0001_0400).
use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let dir = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    let device = dir.join("device.x");
    fs::copy(&device, out.join("device.x")).expect("device.x is readable");
    // No memory.x beside device.x: it would be found before a binary's own
    // (left there by the build script of earlier versions).
    let _ = fs::remove_file(out.join("memory.x"));
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={}", device.display());
    for (map, bins) in [
        (dir.join("../../../memory.x"), &["gateway", "smoke"][..]),
        (dir.join("memory-slot.x"), &["field-device"][..]),
    ] {
        let name = map
            .file_stem()
            .and_then(|s| s.to_str())
            .expect("a memory map's name");
        let search = out.join(name);
        fs::create_dir_all(&search).expect("OUT_DIR is writable");
        fs::copy(&map, search.join("memory.x")).expect("the memory map is readable");
        println!("cargo:rerun-if-changed={}", map.display());
        for bin in bins {
            println!("cargo:rustc-link-arg-bin={bin}=-L{}", search.display());
        }
    }
}
