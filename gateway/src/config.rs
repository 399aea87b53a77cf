//! The gateway's configuration, its register form, and persistence.
//!
//! The PLC edits the configuration registers (`CFG_*`), then writes 1 to
//! `CONFIG_COMMAND`: the values are checked, applied and saved together with
//! the trigger table through a [`Storage`]: a file on Linux
//! (`FileStorage` in the host binary), flash or RAM ([`RamStorage`]) on boards.
//!
//! The stored image is `HGW1`, a format version, the number of words, the
//! configuration words, the trigger texts' words (all little-endian) and a
//! CRC-32. An image that fails any check is ignored (defaults are used, and
//! the log says so).

use core::net::{Ipv4Addr, SocketAddrV4};

use crate::registers::{self as r, RegisterFile};

/// Word order of 32-bit values in two registers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WordOrder {
    /// High word at the lower address ("big-endian words", the default).
    #[default]
    HighFirst,
    /// Low word at the lower address.
    LowFirst,
}

/// Who opens the robot connection (chapter 3.1 of the protocol document).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LinkMode {
    /// The gateway connects to the controller's command port.
    #[default]
    Connect,
    /// The controller connects to the gateway (its client mode); a new
    /// connection replaces the old one.
    Listen,
}

/// What the watchdog does when the PLC heartbeat stops during a motion.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WatchdogAction {
    /// Report only (the motion goes on).
    ReportOnly,
    /// Send `GrpStop` (default).
    #[default]
    Stop,
    /// Send `GrpInterrupt` (pause).
    Pause,
}

/// Where the status mirror comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StatusSource {
    /// Poll the command port (`ReadRobotState`, `ReadCurFSM`, ...).
    #[default]
    Polling,
    /// Read the DataSheet port's JSON packets (spares the command port).
    DataSheet,
}

/// The configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Robot controller address (connect mode). `0.0.0.0` = not configured:
    /// the link stays down.
    pub robot_ip: Ipv4Addr,
    /// Robot command port (connect mode), default 10003.
    pub robot_port: u16,
    /// Connect or listen.
    pub link_mode: LinkMode,
    /// Port listened on in listen mode, default 10003.
    pub listen_port: u16,
    /// Status poll period \[ms\], 10-100, default 100.
    pub poll_ms: u16,
    /// Reply timeout \[ms\], 50-60000, default 1000.
    pub reply_timeout_ms: u16,
    /// Word order of 32-bit values.
    pub word_order: WordOrder,
    /// Watchdog period \[ms\], 0 = off (default), else 50-60000.
    pub watchdog_ms: u16,
    /// Watchdog action.
    pub watchdog_action: WatchdogAction,
    /// Also wait for blending done before a motion is Done.
    pub wait_blending_done: bool,
    /// Also wait for in position before a motion is Done.
    pub wait_in_position: bool,
    /// \[ms\] a motion may report "not moving" after being accepted before that
    /// counts as finished (the moving flag lags ~50 ms), 0-5000, default 200.
    pub start_grace_ms: u16,
    /// Send `GrpReset` after a motion ends in a robot error (default off).
    pub auto_reset: bool,
    /// Status source.
    pub status_source: StatusSource,
    /// DataSheet port, default 10005 (10 Hz).
    pub datasheet_port: u16,
    /// Robot id, 0-5.
    pub robot_id: u8,
}

impl Default for Config {
    fn default() -> Self {
        Config::DEFAULT
    }
}

impl Config {
    /// The factory defaults (as `Default`, usable in constants).
    pub const DEFAULT: Config = Config {
        robot_ip: Ipv4Addr::UNSPECIFIED,
        robot_port: 10003,
        link_mode: LinkMode::Connect,
        listen_port: 10003,
        poll_ms: 100,
        reply_timeout_ms: 1000,
        word_order: WordOrder::HighFirst,
        watchdog_ms: 0,
        watchdog_action: WatchdogAction::Stop,
        wait_blending_done: false,
        wait_in_position: false,
        start_grace_ms: 200,
        auto_reset: false,
        status_source: StatusSource::Polling,
        datasheet_port: 10005,
        robot_id: 0,
    };
}

/// A configuration register holds a value outside its range.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct InvalidValue {
    /// The register.
    pub addr: u16,
}

impl Config {
    /// The robot's command endpoint.
    pub fn robot(&self) -> SocketAddrV4 {
        SocketAddrV4::new(self.robot_ip, self.robot_port)
    }

    /// The configuration as its [`r::CONFIG_LEN`] registers.
    pub fn to_words(&self) -> [u16; r::CONFIG_LEN as usize] {
        let ip = self.robot_ip.octets();
        [
            u16::from_be_bytes([ip[0], ip[1]]),
            u16::from_be_bytes([ip[2], ip[3]]),
            self.robot_port,
            match self.link_mode {
                LinkMode::Connect => 0,
                LinkMode::Listen => 1,
            },
            self.listen_port,
            self.poll_ms,
            self.reply_timeout_ms,
            match self.word_order {
                WordOrder::HighFirst => 0,
                WordOrder::LowFirst => 1,
            },
            self.watchdog_ms,
            match self.watchdog_action {
                WatchdogAction::ReportOnly => 0,
                WatchdogAction::Stop => 1,
                WatchdogAction::Pause => 2,
            },
            u16::from(self.wait_blending_done) | (u16::from(self.wait_in_position) << 1),
            self.start_grace_ms,
            u16::from(self.auto_reset),
            match self.status_source {
                StatusSource::Polling => 0,
                StatusSource::DataSheet => 1,
            },
            self.datasheet_port,
            u16::from(self.robot_id),
        ]
    }

    /// Reads and checks the configuration from its registers.
    pub fn from_words(w: &[u16; r::CONFIG_LEN as usize]) -> Result<Config, InvalidValue> {
        let bad = |off: u16| InvalidValue {
            addr: r::CONFIG_ROBOT_IP + off,
        };
        let at = |reg: u16| w[usize::from(reg - r::CONFIG_ROBOT_IP) % w.len()];
        let off = |reg: u16| reg - r::CONFIG_ROBOT_IP;
        let in_range = |reg: u16, lo: u16, hi: u16| {
            let v = at(reg);
            if (lo..=hi).contains(&v) {
                Ok(v)
            } else {
                Err(bad(off(reg)))
            }
        };
        let [a, b] = at(r::CONFIG_ROBOT_IP).to_be_bytes();
        let [c, d] = at(r::CONFIG_ROBOT_IP + 1).to_be_bytes();
        let watchdog_ms = at(r::CONFIG_WATCHDOG_MS);
        if watchdog_ms != 0 && !(50..=60000).contains(&watchdog_ms) {
            return Err(bad(off(r::CONFIG_WATCHDOG_MS)));
        }
        let policy = in_range(r::CONFIG_MOTION_POLICY, 0, 3)?;
        Ok(Config {
            robot_ip: Ipv4Addr::new(a, b, c, d),
            robot_port: in_range(r::CONFIG_ROBOT_PORT, 1, u16::MAX)?,
            link_mode: match in_range(r::CONFIG_LINK_MODE, 0, 1)? {
                0 => LinkMode::Connect,
                _ => LinkMode::Listen,
            },
            listen_port: in_range(r::CONFIG_LISTEN_PORT, 1, u16::MAX)?,
            poll_ms: in_range(r::CONFIG_POLL_MS, 10, 100)?,
            reply_timeout_ms: in_range(r::CONFIG_REPLY_TIMEOUT_MS, 50, 60000)?,
            word_order: match in_range(r::CONFIG_FLOAT_WORD_ORDER, 0, 1)? {
                0 => WordOrder::HighFirst,
                _ => WordOrder::LowFirst,
            },
            watchdog_ms,
            watchdog_action: match in_range(r::CONFIG_WATCHDOG_ACTION, 0, 2)? {
                0 => WatchdogAction::ReportOnly,
                1 => WatchdogAction::Stop,
                _ => WatchdogAction::Pause,
            },
            wait_blending_done: policy & 1 != 0,
            wait_in_position: policy & 2 != 0,
            start_grace_ms: in_range(r::CONFIG_START_GRACE_MS, 0, 5000)?,
            auto_reset: in_range(r::CONFIG_AUTO_RESET, 0, 1)? == 1,
            status_source: match in_range(r::CONFIG_STATUS_SOURCE, 0, 1)? {
                0 => StatusSource::Polling,
                _ => StatusSource::DataSheet,
            },
            datasheet_port: in_range(r::CONFIG_DATASHEET_PORT, 1, u16::MAX)?,
            robot_id: in_range(r::CONFIG_ROBOT_ID, 0, 5)? as u8,
        })
    }

    /// Writes the configuration into its registers.
    pub fn store(&self, regs: &mut RegisterFile) {
        for (i, w) in self.to_words().iter().enumerate() {
            regs.set(r::CONFIG_ROBOT_IP + i as u16, *w);
        }
    }

    /// Reads the configuration registers (unchecked words).
    pub fn words_of(regs: &RegisterFile) -> [u16; r::CONFIG_LEN as usize] {
        let mut w = [0u16; r::CONFIG_LEN as usize];
        for (i, slot) in w.iter_mut().enumerate() {
            *slot = regs.get(r::CONFIG_ROBOT_IP + i as u16);
        }
        w
    }
}

/// Why storage failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StorageError {
    /// The medium reported an error.
    Io,
    /// The image does not fit the medium.
    TooLarge,
}

/// Where the configuration and trigger table are kept. Implemented by the
/// board (flash, RAM) or the host (file).
///
/// Calls are blocking and rare (at start and on each save command).
pub trait Storage {
    /// Copies the stored image into `buf` and returns its length (0 when
    /// nothing is stored).
    fn load(&mut self, buf: &mut [u8]) -> Result<usize, StorageError>;
    /// Replaces the stored image.
    fn save(&mut self, image: &[u8]) -> Result<(), StorageError>;
    /// `true` if a saved image survives a restart (file, flash). A
    /// configuration applied with a storage that does not is reported as
    /// "applied, not saved" (`CONFIG_RESULT` 3).
    fn is_persistent(&self) -> bool {
        true
    }
}

/// Storage in RAM, lost at every restart: for boards without persistent
/// storage (the QEMU board) and the host binary without `--config`. It is
/// not persistent ([`Storage::is_persistent`]): a configuration applied
/// with it is reported as not saved.
pub struct RamStorage {
    image: [u8; IMAGE_LEN],
    len: usize,
}

impl Default for RamStorage {
    fn default() -> Self {
        Self::new()
    }
}

impl RamStorage {
    /// Empty storage.
    pub const fn new() -> Self {
        RamStorage {
            image: [0; IMAGE_LEN],
            len: 0,
        }
    }
}

impl Storage for RamStorage {
    fn is_persistent(&self) -> bool {
        false
    }

    fn load(&mut self, buf: &mut [u8]) -> Result<usize, StorageError> {
        let src = self.image.get(..self.len).ok_or(StorageError::Io)?;
        let dst = buf.get_mut(..self.len).ok_or(StorageError::TooLarge)?;
        dst.copy_from_slice(src);
        Ok(self.len)
    }

    fn save(&mut self, image: &[u8]) -> Result<(), StorageError> {
        let dst = self
            .image
            .get_mut(..image.len())
            .ok_or(StorageError::TooLarge)?;
        dst.copy_from_slice(image);
        self.len = image.len();
        Ok(())
    }
}

const MAGIC: &[u8; 4] = b"HGW1";
const FORMAT: u16 = 1;
const TRIGGER_WORDS: usize = r::TRIGGERS * r::TRIG_TEXT_REGS as usize;
const WORDS: usize = r::CONFIG_LEN as usize + TRIGGER_WORDS;
/// Bytes of a stored image.
pub const IMAGE_LEN: usize = 4 + 2 + 2 + WORDS * 2 + 4;

/// Writes the image of `config` and the trigger texts in `regs`.
pub fn encode_image(config: &Config, regs: &RegisterFile, out: &mut [u8; IMAGE_LEN]) {
    let mut words = config.to_words().into_iter().chain(
        (0..r::TRIGGERS)
            .flat_map(|i| (0..r::TRIG_TEXT_REGS).map(move |k| r::trigger_text(i) + k))
            .map(|a| regs.get(a)),
    );
    out[..4].copy_from_slice(MAGIC);
    out[4..6].copy_from_slice(&FORMAT.to_le_bytes());
    out[6..8].copy_from_slice(&(WORDS as u16).to_le_bytes());
    for chunk in out[8..IMAGE_LEN - 4].chunks_exact_mut(2) {
        chunk.copy_from_slice(&words.next().unwrap_or(0).to_le_bytes());
    }
    let crc = crc32(&out[..IMAGE_LEN - 4]);
    out[IMAGE_LEN - 4..].copy_from_slice(&crc.to_le_bytes());
}

/// Why a stored image was ignored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ImageError {
    /// Wrong length, magic or format version.
    Format,
    /// The CRC does not match.
    Crc,
    /// A configuration value is out of range.
    Invalid(InvalidValue),
}

/// Reads an image: the configuration is returned, the trigger texts are
/// written into `regs`. Nothing is changed on error.
pub fn decode_image(image: &[u8], regs: &mut RegisterFile) -> Result<Config, ImageError> {
    if image.len() != IMAGE_LEN
        || image.get(..4) != Some(&MAGIC[..])
        || image.get(4..6) != Some(&FORMAT.to_le_bytes()[..])
        || image.get(6..8) != Some(&(WORDS as u16).to_le_bytes()[..])
    {
        return Err(ImageError::Format);
    }
    let (body, crc) = image.split_at(IMAGE_LEN - 4);
    if crc != crc32(body).to_le_bytes() {
        return Err(ImageError::Crc);
    }
    let mut words = body.get(8..).unwrap_or(&[]).chunks_exact(2).map(|c| {
        u16::from_le_bytes([
            c.first().copied().unwrap_or(0),
            c.get(1).copied().unwrap_or(0),
        ])
    });
    let mut cw = [0u16; r::CONFIG_LEN as usize];
    for slot in cw.iter_mut() {
        *slot = words.next().unwrap_or(0);
    }
    let config = Config::from_words(&cw).map_err(ImageError::Invalid)?;
    for i in 0..r::TRIGGERS {
        for k in 0..r::TRIG_TEXT_REGS {
            regs.set(r::trigger_text(i) + k, words.next().unwrap_or(0));
        }
    }
    Ok(config)
}

/// CRC-32 (IEEE, reflected), bitwise: a few bytes of code for a check run
/// only at load and save, not worth a dependency.
fn crc32(data: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in data {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_matches_the_standard_check_value() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn words_round_trip_and_ranges_are_checked() {
        let c = Config {
            robot_ip: Ipv4Addr::new(192, 168, 0, 7),
            link_mode: LinkMode::Listen,
            watchdog_ms: 500,
            watchdog_action: WatchdogAction::Pause,
            wait_in_position: true,
            word_order: WordOrder::LowFirst,
            ..Config::default()
        };
        let w = c.to_words();
        assert_eq!(w[0], 0xC0A8);
        assert_eq!(Config::from_words(&w), Ok(c));
        let mut bad = w;
        bad[usize::from(r::CONFIG_POLL_MS - r::CONFIG_ROBOT_IP)] = 101;
        assert_eq!(
            Config::from_words(&bad),
            Err(InvalidValue {
                addr: r::CONFIG_POLL_MS
            })
        );
        let mut bad = w;
        bad[usize::from(r::CONFIG_WATCHDOG_MS - r::CONFIG_ROBOT_IP)] = 10;
        assert!(Config::from_words(&bad).is_err());
    }

    #[test]
    fn image_round_trip_and_corruption() {
        let mut regs = RegisterFile::new();
        regs.set_text(r::trigger_text(3), r::TRIG_TEXT_REGS, b"GrpStop,0,;");
        let c = Config {
            robot_port: 4242,
            ..Config::default()
        };
        let mut img = [0u8; IMAGE_LEN];
        encode_image(&c, &regs, &mut img);
        let mut back = RegisterFile::new();
        assert_eq!(decode_image(&img, &mut back), Ok(c));
        let mut t = [0u8; 32];
        let n = back.get_text(r::trigger_text(3), r::TRIG_TEXT_REGS, &mut t);
        assert_eq!(&t[..n], b"GrpStop,0,;");
        img[100] ^= 1;
        assert_eq!(decode_image(&img, &mut back), Err(ImageError::Crc));
        assert_eq!(decode_image(&img[..10], &mut back), Err(ImageError::Format));
        let mut s = RamStorage::new();
        let mut buf = [0u8; IMAGE_LEN];
        assert_eq!(s.load(&mut buf), Ok(0));
        s.save(&img).unwrap();
        assert_eq!(s.load(&mut buf), Ok(IMAGE_LEN));
        assert_eq!(buf, img);
    }
}
