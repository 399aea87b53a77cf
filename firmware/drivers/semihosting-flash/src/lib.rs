//! A NOR flash backed by a file on the host, reached through semihosting:
//! the persistent "flash" of the QEMU board (mps2-an386 has none), shared
//! by the bootloader (blocking [`embedded_storage::nor_flash::NorFlash`])
//! and the application (async
//! [`embedded_storage_async::nor_flash::NorFlash`]; each call completes
//! before it returns, the guest sees no time pass).
//!
//! The file survives a restart of QEMU, so an update written by one run
//! is swapped in by the bootloader of the next. Its name comes from the
//! word `flash=PATH` of QEMU's command line (`-append`, read through
//! semihosting; [`FlashPath::from_args`]), [`DEFAULT_PATH`] without it. A
//! relative path is relative to QEMU's working directory.
//!
//! It behaves as NOR flash, so that code tested on it is right on a real
//! chip: [`ERASE_SIZE`] pages erase to 0xFF, writes are [`WRITE_SIZE`]
//! aligned and only clear bits (the new contents are the old AND the
//! written bytes: a second write of a word that was not erased in between
//! shows up as mixed bits, as on the chip). Nothing here panics; every
//! failure is an [`Error`].
//!
//! ```no_run
//! use embedded_storage::nor_flash::ReadNorFlash;
//! use semihosting_flash::{FlashPath, SemihostingFlash};
//!
//! let path = FlashPath::from_args()?;
//! let mut flash = SemihostingFlash::open(&path, 0x10_2000)?;
//! let mut magic = [0u8; 8];
//! flash.read(0x1000, &mut magic)?;
//! # Ok::<(), semihosting_flash::Error>(())
//! ```
#![no_std]
#![deny(missing_docs)]

use core::ffi::CStr;

use embedded_storage::nor_flash::{self as blocking, NorFlashError, NorFlashErrorKind};
use embedded_storage_async::nor_flash as asynch;
use semihosting::fs::File;
use semihosting::io::{Read as _, Seek as _, SeekFrom, Write as _};

/// The erase unit: a page of the QEMU board's layout
/// (`hans_fw_image::layout::MPS2_AN386.page`).
pub const ERASE_SIZE: usize = 4096;
/// The write unit (a word, as on the boards' flash).
pub const WRITE_SIZE: usize = 4;
/// The read unit.
pub const READ_SIZE: usize = 1;
/// The file opened when the command line names none.
pub const DEFAULT_PATH: &str = "flash.bin";
/// The longest path taken from the command line.
pub const PATH_MAX: usize = 255;
/// The longest command line read: the kernel's path and the words of
/// `-append` (QEMU refuses the whole line to a shorter buffer).
const CMDLINE_MAX: usize = 512;
/// Bytes moved through the host per semihosting call.
const CHUNK: usize = 256;

/// Why the flash cannot be opened or an operation failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Error {
    /// QEMU's command line could not be read (longer than 512 bytes?).
    CommandLine,
    /// The path is longer than [`PATH_MAX`] bytes or holds a NUL.
    BadPath,
    /// The file cannot be opened for reading and writing (absent, or no
    /// permission); the host's errno when it gave one.
    Open(Option<i32>),
    /// The file's size is not the flash's.
    Size {
        /// Bytes the flash has.
        expected: u32,
        /// Bytes the file has.
        found: u64,
    },
    /// The capacity is not a whole number of pages.
    Capacity,
    /// An offset or length not aligned to the operation's unit.
    NotAligned,
    /// An operation beyond the flash's end (or an erase with `to < from`).
    OutOfBounds,
    /// The host failed a seek, read or write of the open file.
    Io,
}

impl Error {
    /// A short text for a log.
    pub fn as_str(self) -> &'static str {
        match self {
            Error::CommandLine => "the command line is not readable (too long?)",
            Error::BadPath => "the flash file's path is too long or malformed",
            Error::Open(_) => "the flash file cannot be opened for reading and writing (absent?)",
            Error::Size { .. } => "the flash file's size is not the flash's",
            Error::Capacity => "the flash's size is not a whole number of pages",
            Error::NotAligned => "flash operation not aligned",
            Error::OutOfBounds => "flash operation out of bounds",
            Error::Io => "the host failed a read or write of the flash file",
        }
    }
}

impl NorFlashError for Error {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            Error::NotAligned => NorFlashErrorKind::NotAligned,
            Error::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            _ => NorFlashErrorKind::Other,
        }
    }
}

impl From<NorFlashErrorKind> for Error {
    fn from(kind: NorFlashErrorKind) -> Error {
        match kind {
            NorFlashErrorKind::NotAligned => Error::NotAligned,
            NorFlashErrorKind::OutOfBounds => Error::OutOfBounds,
            _ => Error::Io,
        }
    }
}

/// The flash file's path, NUL-terminated for the host.
#[derive(Clone, Debug)]
pub struct FlashPath {
    buf: [u8; PATH_MAX + 1],
    len: usize,
}

impl FlashPath {
    /// `path` (at most [`PATH_MAX`] bytes, no NUL).
    pub fn new(path: &str) -> Result<FlashPath, Error> {
        let bytes = path.as_bytes();
        if bytes.is_empty() || bytes.contains(&0) {
            return Err(Error::BadPath);
        }
        let mut buf = [0u8; PATH_MAX + 1];
        buf.get_mut(..bytes.len())
            .ok_or(Error::BadPath)?
            .copy_from_slice(bytes);
        Ok(FlashPath {
            buf,
            len: bytes.len(),
        })
    }

    /// The path named by the word `flash=PATH` of QEMU's command line
    /// (semihosting), else [`DEFAULT_PATH`].
    pub fn from_args() -> Result<FlashPath, Error> {
        let args = semihosting::experimental::env::args::<CMDLINE_MAX>()
            .map_err(|_| Error::CommandLine)?;
        let word = (&args).find_map(|a| a.ok().and_then(|a| a.strip_prefix("flash=")));
        FlashPath::new(word.unwrap_or(DEFAULT_PATH))
    }

    /// The path.
    pub fn as_str(&self) -> &str {
        self.buf
            .get(..self.len)
            .and_then(|b| core::str::from_utf8(b).ok())
            .unwrap_or("")
    }

    fn c_str(&self) -> Result<&CStr, Error> {
        let with_nul = self.buf.get(..=self.len).ok_or(Error::BadPath)?;
        CStr::from_bytes_with_nul(with_nul).map_err(|_| Error::BadPath)
    }
}

/// The flash: an open host file of `capacity` bytes.
#[derive(Debug)]
pub struct SemihostingFlash {
    file: File,
    capacity: u32,
}

impl SemihostingFlash {
    /// Opens the file at `path` for reading and writing; it must exist and
    /// have `capacity` bytes, a whole number of [`ERASE_SIZE`] pages (the
    /// host tool `hans-fw install` makes one).
    pub fn open(path: &FlashPath, capacity: u32) -> Result<SemihostingFlash, Error> {
        if !(capacity as usize).is_multiple_of(ERASE_SIZE) {
            return Err(Error::Capacity);
        }
        let file = File::options()
            .read(true)
            .write(true)
            .open(path.c_str()?)
            .map_err(|e| Error::Open(e.raw_os_error()))?;
        let found = file.metadata().map_err(|_| Error::Io)?.len();
        if found != u64::from(capacity) {
            return Err(Error::Size {
                expected: capacity,
                found,
            });
        }
        Ok(SemihostingFlash { file, capacity })
    }

    fn seek(&mut self, offset: u32) -> Result<(), Error> {
        self.file
            .seek(SeekFrom::Start(u64::from(offset)))
            .map(|_| ())
            .map_err(|_| Error::Io)
    }

    fn read_at(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Error> {
        blocking::check_read(&*self, offset, bytes.len())?;
        if bytes.is_empty() {
            return Ok(());
        }
        self.seek(offset)?;
        self.file.read_exact(bytes).map_err(|_| Error::Io)
    }

    fn write_at(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Error> {
        blocking::check_write(&*self, offset, bytes.len())?;
        let mut at = offset;
        for piece in bytes.chunks(CHUNK) {
            // NOR: a write only clears bits.
            let mut old = [0u8; CHUNK];
            let old = old.get_mut(..piece.len()).ok_or(Error::OutOfBounds)?;
            self.read_at(at, old)?;
            for (o, n) in old.iter_mut().zip(piece) {
                *o &= *n;
            }
            self.seek(at)?;
            self.file.write_all(old).map_err(|_| Error::Io)?;
            at = at.saturating_add(piece.len() as u32);
        }
        Ok(())
    }

    fn erase_range(&mut self, from: u32, to: u32) -> Result<(), Error> {
        blocking::check_erase(&*self, from, to)?;
        const ERASED: [u8; CHUNK] = [0xFF; CHUNK];
        self.seek(from)?;
        let mut left = (to - from) as usize;
        while left > 0 {
            let n = left.min(CHUNK);
            let piece = ERASED.get(..n).ok_or(Error::OutOfBounds)?;
            self.file.write_all(piece).map_err(|_| Error::Io)?;
            left -= n;
        }
        Ok(())
    }
}

impl blocking::ErrorType for SemihostingFlash {
    type Error = Error;
}

impl blocking::ReadNorFlash for SemihostingFlash {
    const READ_SIZE: usize = READ_SIZE;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Error> {
        self.read_at(offset, bytes)
    }

    fn capacity(&self) -> usize {
        self.capacity as usize
    }
}

impl blocking::NorFlash for SemihostingFlash {
    const WRITE_SIZE: usize = WRITE_SIZE;
    const ERASE_SIZE: usize = ERASE_SIZE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Error> {
        self.erase_range(from, to)
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Error> {
        self.write_at(offset, bytes)
    }
}

impl asynch::ReadNorFlash for SemihostingFlash {
    const READ_SIZE: usize = READ_SIZE;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Error> {
        self.read_at(offset, bytes)
    }

    fn capacity(&self) -> usize {
        self.capacity as usize
    }
}

impl asynch::NorFlash for SemihostingFlash {
    const WRITE_SIZE: usize = WRITE_SIZE;
    const ERASE_SIZE: usize = ERASE_SIZE;

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), Error> {
        self.erase_range(from, to)
    }

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Error> {
        self.write_at(offset, bytes)
    }
}
