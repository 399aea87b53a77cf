//! `hans-fw`: makes signing keys, signs firmware images for the gateway and
//! checks them, with the image format and checks the device itself uses
//! (`hans_fw_image`).
//!
//! ```text
//! hans-fw keygen --out DIR [--name NAME]        NAME.key (secret, 0600) and NAME.pub
//! hans-fw sign --key K --board B --version X.Y.Z FIRMWARE.bin -o IMAGE
//! hans-fw verify --pub P --board B [--running X.Y.Z] [--allow-downgrade] IMAGE
//! hans-fw inspect IMAGE
//! hans-fw install --layout BOARD --out FLASH.bin IMAGE [--dfu IMAGE2 | --slot-only]
//! ```
//!
//! Keys are 32 bytes in hex on one line. Exit status: 0 done (verify: the
//! image passes), 1 the image is refused or a file cannot be read or
//! written (the reason on stderr), 2 a bad command line.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use hans_fw_image::layout::{Layout, HEADER_PAGE};
use hans_fw_image::{
    check, field, key_from_hex, public_key, sign, Expect, Header, Version, HEADER_LEN,
};

#[derive(Parser, Debug)]
#[command(
    name = "hans-fw",
    about = "Signs and checks firmware images of the Hans gateway"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand, Debug)]
enum Cmd {
    /// Makes a signing key (NAME.key, readable by its owner only: keep it
    /// off the devices and off shared disks) and its public key
    /// (NAME.pub, compiled into the bootloader).
    Keygen {
        /// Directory for the two files.
        #[arg(long)]
        out: PathBuf,
        /// Their name.
        #[arg(long, default_value = "signing")]
        name: String,
    },
    /// Signs a firmware (the raw bytes the bootloader writes to flash).
    Sign {
        /// The secret key (from keygen).
        #[arg(long)]
        key: PathBuf,
        /// The board the image is for (mps2-an386, nucleo-f767zi).
        #[arg(long)]
        board: String,
        /// The firmware's version, X.Y.Z.
        #[arg(long, value_parser = parse_version)]
        version: Version,
        /// The firmware.
        firmware: PathBuf,
        /// The signed image to write.
        #[arg(short, long)]
        out: PathBuf,
    },
    /// Checks an image as the device does before installing it.
    Verify {
        /// The public key (from keygen).
        #[arg(long = "pub")]
        public: PathBuf,
        /// The device's board.
        #[arg(long)]
        board: String,
        /// The device's running version (default 0.0.0: any version).
        #[arg(long, value_parser = parse_version, default_value = "0.0.0")]
        running: Version,
        /// Accept an older version than --running.
        #[arg(long)]
        allow_downgrade: bool,
        /// The image.
        image: PathBuf,
    },
    /// Prints an image's header (board, version, length, hash); checks
    /// nothing that needs a key.
    Inspect {
        /// The image.
        image: PathBuf,
    },
    /// Writes a whole flash as a device's bootloader finds it: erased
    /// (0xFF), the image in the active slot (its header at the slot's
    /// start, the body a header page further), nothing to swap. The QEMU
    /// board's flash file is made so; checks the image's form, board and
    /// size (not its signature: the bootloader does that).
    Install {
        /// The board whose layout to use (mps2-an386, nucleo-f767zi).
        #[arg(long)]
        layout: String,
        /// The flash file to write (replaced if it exists).
        #[arg(long)]
        out: PathBuf,
        /// The image for the active slot.
        image: PathBuf,
        /// An image for the download slot as well (not marked for a swap).
        #[arg(long, conflicts_with = "slot_only")]
        dfu: Option<PathBuf>,
        /// Writes the active slot's bytes alone (header page and body, no
        /// padding), for a probe to program at the slot's address (the
        /// NUCLEO's first flashing: 0x0802_0000), leaving the rest of the
        /// flash (the bootloader, the configuration) as it is.
        #[arg(long)]
        slot_only: bool,
    },
}

/// The layout of `board`.
fn layout(board: &str) -> Result<&'static Layout, String> {
    hans_fw_image::layout::of(board)
        .ok_or_else(|| format!("no layout for board {board:?} (mps2-an386, nucleo-f767zi)"))
}

/// Puts the image at `path` into `flash` at `slot` (its header at the
/// start, its body `HEADER_PAGE` further), after checking its form, its
/// board and that it fits; returns its header.
fn put_image(
    flash: &mut [u8],
    slot: &std::ops::Range<u32>,
    layout: &Layout,
    path: &Path,
) -> Result<Header, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let h = Header::parse(&bytes).map_err(|e| format!("{}: {}", path.display(), e.as_str()))?;
    let body = &bytes[HEADER_LEN..];
    if h.board() != layout.board {
        return Err(format!(
            "{}: an image for {}, not {}",
            path.display(),
            h.board(),
            layout.board
        ));
    }
    if body.len() as u64 != u64::from(h.body_len) {
        return Err(format!(
            "{}: the header says {} bytes of firmware, the file has {}",
            path.display(),
            h.body_len,
            body.len()
        ));
    }
    // A slot as long as the active one: the download slot's last page is
    // the swap's.
    let room = u64::from(layout.max_body());
    if body.len() as u64 > room {
        return Err(format!(
            "{}: {} bytes of firmware, a slot holds {room}",
            path.display(),
            body.len()
        ));
    }
    let at = slot.start as usize;
    let body_at = at + HEADER_PAGE as usize;
    flash[at..at + HEADER_LEN].copy_from_slice(&bytes[..HEADER_LEN]);
    flash[body_at..body_at + body.len()].copy_from_slice(body);
    Ok(h)
}

/// `X.Y.Z`, each 0-65535.
fn parse_version(s: &str) -> Result<Version, String> {
    let parts: Vec<&str> = s.split('.').collect();
    let n = |t: &str| {
        t.parse::<u16>()
            .map_err(|_| format!("{s:?}: expected X.Y.Z, each 0-65535"))
    };
    match parts.as_slice() {
        [a, b, c] => Ok(Version {
            major: n(a)?,
            minor: n(b)?,
            patch: n(c)?,
        }),
        _ => Err(format!("{s:?}: expected X.Y.Z")),
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// 32 bytes from a file of 64 hex digits (one line).
fn read_key(path: &Path) -> Result<[u8; 32], String> {
    let text = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    key_from_hex(&text).ok_or_else(|| format!("{}: expected 64 hex digits", path.display()))
}

fn write_file(path: &Path, bytes: &[u8], mode: u32) -> Result<(), String> {
    use std::os::unix::fs::OpenOptionsExt;
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .mode(mode)
        .open(path)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    f.write_all(bytes)
        .map_err(|e| format!("{}: {e}", path.display()))
}

fn run(cli: Cli) -> Result<(), String> {
    match cli.cmd {
        Cmd::Keygen { out, name } => {
            let mut seed = [0u8; 32];
            getrandom::fill(&mut seed).map_err(|e| format!("the system's random source: {e}"))?;
            let (secret, public) = (
                out.join(format!("{name}.key")),
                out.join(format!("{name}.pub")),
            );
            if secret.exists() {
                return Err(format!("{}: exists (not overwritten)", secret.display()));
            }
            write_file(&secret, format!("{}\n", hex(&seed)).as_bytes(), 0o600)?;
            write_file(
                &public,
                format!("{}\n", hex(&public_key(&seed))).as_bytes(),
                0o644,
            )?;
            println!(
                "{} (secret, mode 0600) and {}",
                secret.display(),
                public.display()
            );
            Ok(())
        }
        Cmd::Sign {
            key,
            board,
            version,
            firmware,
            out,
        } => {
            let seed = read_key(&key)?;
            let body =
                std::fs::read(&firmware).map_err(|e| format!("{}: {e}", firmware.display()))?;
            let header = sign(&seed, &board, version, &body).ok_or_else(|| {
                format!("board {board:?}: 1-16 letters, digits or '-' (and a body under 4 GiB)")
            })?;
            let mut image = header.to_vec();
            image.extend_from_slice(&body);
            write_file(&out, &image, 0o644)?;
            println!(
                "{}: {board} {}.{}.{}, {} bytes of firmware, sha256 {}",
                out.display(),
                version.major,
                version.minor,
                version.patch,
                body.len(),
                hex(&image[field::SHA256])
            );
            Ok(())
        }
        Cmd::Verify {
            public,
            board,
            running,
            allow_downgrade,
            image,
        } => {
            let key = read_key(&public)?;
            let bytes = std::fs::read(&image).map_err(|e| format!("{}: {e}", image.display()))?;
            let h = check(
                &bytes,
                &Expect {
                    key: &key,
                    board: &board,
                    running,
                    allow_downgrade,
                    max_body: u32::MAX,
                },
            )
            .map_err(|e| format!("{}: refused: {}", image.display(), e.as_str()))?;
            println!(
                "{}: ok: {} {}.{}.{}, signed by the key",
                image.display(),
                h.board(),
                h.version.major,
                h.version.minor,
                h.version.patch
            );
            Ok(())
        }
        Cmd::Inspect { image } => {
            let bytes = std::fs::read(&image).map_err(|e| format!("{}: {e}", image.display()))?;
            let h = Header::parse(&bytes)
                .map_err(|e| format!("{}: {}", image.display(), e.as_str()))?;
            let body = bytes.len().saturating_sub(HEADER_LEN);
            println!("board    {}", h.board());
            println!(
                "version  {}.{}.{}",
                h.version.major, h.version.minor, h.version.patch
            );
            println!(
                "length   {} bytes{}",
                h.body_len,
                if body as u64 == u64::from(h.body_len) {
                    String::new()
                } else {
                    format!(" (the file has {body}: truncated or extended)")
                }
            );
            println!("sha256   {}", hex(&h.sha256));
            Ok(())
        }
        Cmd::Install {
            layout: board,
            out,
            image,
            dfu,
            slot_only,
        } => {
            let l = layout(&board)?;
            let mut flash = vec![0xFF; l.size as usize];
            let h = put_image(&mut flash, &l.active, l, &image)?;
            if slot_only {
                let at = l.active.start as usize;
                let end = at + (HEADER_PAGE + h.body_len) as usize;
                write_file(&out, &flash[at..end], 0o644)?;
                println!(
                    "{}: {} bytes, {} {}.{}.{} for the active slot at offset {:#x}",
                    out.display(),
                    end - at,
                    h.board(),
                    h.version.major,
                    h.version.minor,
                    h.version.patch,
                    l.active.start
                );
                return Ok(());
            }
            let mut said = format!(
                "{}: {} bytes, {} {}.{}.{} in the active slot",
                out.display(),
                l.size,
                h.board(),
                h.version.major,
                h.version.minor,
                h.version.patch
            );
            if let Some(dfu) = dfu {
                let h = put_image(&mut flash, &l.dfu, l, &dfu)?;
                said += &format!(
                    ", {}.{}.{} in the download slot",
                    h.version.major, h.version.minor, h.version.patch
                );
            }
            write_file(&out, &flash, 0o644)?;
            println!("{said}");
            Ok(())
        }
    }
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("hans-fw: {e}");
            ExitCode::FAILURE
        }
    }
}
