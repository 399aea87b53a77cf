//! The QEMU board's bootloader (`firmware/bootloader-mps2`) on flash files
//! made here with `hans-fw`: an update marked in the boot state is swapped
//! in and started (the slots' contents exchanged in the file), a corrupted
//! update is refused and not swapped in (the running image stays, the
//! boot state cleared), and a corrupted active image is never started
//! (status 1, the reason and the valid image in the download slot named).
//! The bootloader's log is its text on QEMU's stderr (`hans-boot: ...`).
//!
//! The flash file's layout is `hans_fw_image::layout::MPS2_AN386`:
//! boot state at 0, active slot at 0x1000, download slot at 0x8_1000, a
//! slot's body 1 KiB after its header, 4 KiB pages.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use qemu_tests::{firmware_elf, hans_fw, log_dir, repo_root, Ports, Qemu};

const ACTIVE: usize = 0x1000;
const DFU: usize = 0x8_1000;
const PAGE: usize = 0x1000;
const HEADER_PAGE: usize = 1024;
/// embassy-boot's "swap" magic in the boot state's first word: what the
/// application writes when it marks an update.
const SWAP_MAGIC: [u8; 4] = [0xF0; 4];

fn run(cmd: &mut Command) {
    let out = cmd.output().expect("run a tool");
    assert!(out.status.success(), "{cmd:?}: {out:?}");
}

/// The field-device firmware signed as `version` with the development key
/// (`scripts/fw-image.sh`, as `scripts/qemu-run.sh` signs it).
fn image(dir: &Path, version: &str) -> Vec<u8> {
    let img = dir.join(format!("{version}.img"));
    run(Command::new("bash")
        .arg(repo_root().join("scripts/fw-image.sh"))
        .arg(firmware_elf("field-device"))
        .arg(&img)
        .env("FW_VERSION", version)
        .env("HANS_FW", hans_fw())
        .env_remove("FW_KEY")
        .env_remove("FW_BOARD"));
    std::fs::read(&img).expect("the signed image")
}

/// A flash file with `a` active and `b` in the download slot.
fn flash(dir: &Path, name: &str, a: &Path, b: &Path) -> PathBuf {
    let f = dir.join(format!("{name}.flash"));
    run(Command::new(hans_fw())
        .args(["install", "--layout", "mps2-an386", "--out"])
        .arg(&f)
        .arg(a)
        .arg("--dfu")
        .arg(b));
    f
}

fn patch(file: &Path, at: usize, bytes: &[u8]) {
    let mut f = std::fs::read(file).expect("flash file");
    f[at..at + bytes.len()].copy_from_slice(bytes);
    std::fs::write(file, f).expect("flash file");
}

/// Inverts the byte at `at`: a corrupted image.
fn flip(file: &Path, at: usize) {
    let mut f = std::fs::read(file).expect("flash file");
    f[at] ^= 0xFF;
    std::fs::write(file, f).expect("flash file");
}

/// Starts the field device on `flash` and waits for the bootloader's line
/// holding `want` (or QEMU's end); returns QEMU and the log so far.
fn boot(name: &str, flash: &Path, want: &str) -> (Qemu, String) {
    let elf = firmware_elf("field-device");
    let env = [("FLASH_FILE", flash.display().to_string())];
    let mut qemu =
        Qemu::start_with_env(name, &elf, Ports::pick(), Duration::from_secs(60), "", &env)
            .expect("start QEMU");
    let log = log_dir().join(format!("{name}.qemu.log"));
    let start = Instant::now();
    loop {
        let text = std::fs::read_to_string(&log).unwrap_or_default();
        if text.contains(want) || !qemu.process().running() {
            return (qemu, text);
        }
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "{name}: no {want:?} in {text}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

struct Dir(PathBuf);

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

#[test]
fn the_bootloader_swaps_in_a_marked_update_and_refuses_corrupted_images() {
    let dir = Dir(log_dir().join(format!("bootloader-{}", std::process::id())));
    std::fs::create_dir_all(&dir.0).unwrap();
    let d = &dir.0;
    let a = image(d, "0.1.0");
    let b = image(d, "0.2.0");
    let (a_path, b_path) = (d.join("0.1.0.img"), d.join("0.2.0.img"));

    // An update marked: swapped in, started, and the previous image kept
    // in the download slot (one page further, as the swap leaves it).
    let f = flash(d, "swap", &a_path, &b_path);
    patch(&f, 0, &SWAP_MAGIC);
    let t0 = Instant::now();
    let (mut qemu, log) = boot("bootloader-swap", &f, "hans-boot: booting");
    assert!(
        log.contains("hans-boot: swapped in 0.2.0 from the download slot")
            && log.contains("hans-boot: booting 0.2.0 (swapped in"),
        "{log}"
    );
    println!(
        "bootloader: swap of a {} KiB image and start in {} ms",
        b.len().div_ceil(1024),
        t0.elapsed().as_millis()
    );
    assert!(qemu.process().running(), "the firmware runs: {log}");
    qemu.process().stop();
    let m = std::fs::read(&f).unwrap();
    assert_eq!(&m[ACTIVE..ACTIVE + 136], &b[..136], "B's header active");
    assert_eq!(
        &m[ACTIVE + HEADER_PAGE..ACTIVE + HEADER_PAGE + 4096],
        &b[136..136 + 4096],
        "B's body active"
    );
    assert_eq!(&m[DFU + PAGE..DFU + PAGE + 136], &a[..136], "A kept");

    // A corrupted update: not swapped in, the boot state cleared.
    let f = flash(d, "bad-update", &a_path, &b_path);
    flip(&f, DFU + HEADER_PAGE + 5000);
    patch(&f, 0, &SWAP_MAGIC);
    let (mut qemu, log) = boot("bootloader-bad-update", &f, "hans-boot: booting");
    assert!(
        log.contains(
            "hans-boot: update refused, not swapped in: image corrupted (hash mismatch); \
             the running image stays"
        ) && log.contains("hans-boot: booting 0.1.0\n"),
        "{log}"
    );
    qemu.process().stop();
    let m = std::fs::read(&f).unwrap();
    assert!(m[..PAGE].iter().all(|b| *b == 0xFF), "boot state cleared");
    assert_eq!(&m[ACTIVE..ACTIVE + 136], &a[..136], "A still active");

    // A corrupted active image: never started; the valid update named.
    let f = flash(d, "bad-active", &a_path, &b_path);
    flip(&f, ACTIVE + HEADER_PAGE + 100);
    let (mut qemu, log) = boot("bootloader-bad-active", &f, "not started");
    let status = qemu.process().wait(Duration::from_secs(10));
    assert_eq!(status.and_then(|s| s.code()), Some(1), "{log}");
    assert!(
        log.contains(
            "hans-boot: the active slot's image is refused: image corrupted (hash mismatch); \
             not started; the download slot holds a valid image 0.2.0"
        ),
        "{log}"
    );
}
