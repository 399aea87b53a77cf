//! One audit record, and its stored form (the same bytes in the board's
//! flash ring and in the Linux file).
//!
//! ## Stored form, version 1
//! A record is self-delimiting (its two lengths are in its fixed part) and
//! at most [`RECORD_MAX`] bytes:
//!
//! | bytes | what |
//! |---|---|
//! | 0 | version, 1 |
//! | 1..5 | sequence number (u32, little-endian, as every number here) |
//! | 5..9 | boot counter |
//! | 9..17 | uptime \[ms\] (u64) |
//! | 17..21 | wall time, Unix seconds (u32); 0 = not known |
//! | 21 | kind ([`Kind`]) |
//! | 22 | interface ([`Interface`]) |
//! | 23..27 | source IPv4 address; 0.0.0.0 = none |
//! | 27 | actor length A (0..=[`ACTOR_MAX`]; 0 = no account, shown as `-`) |
//! | 28 | detail length D (0..=[`DETAIL_MAX`]) |
//! | 29..29+A | actor (printable ASCII) |
//! | 29+A..29+A+D | detail (printable ASCII) |
//! | then 4 | CRC-32 (IEEE) of everything before |
//!
//! A kind or interface code this version does not know (written by a newer
//! one) is kept as read ([`Kind::Unknown`]), not refused. A record whose
//! version, lengths or CRC do not check is refused as a whole
//! ([`DecodeError`]): a torn write never shows as a record.

use core::net::Ipv4Addr;

use crate::crc::crc32;

/// Bytes of a stored record at most.
pub const RECORD_MAX: usize = 128;
/// Bytes of an actor (an account name) at most: longer ones are cut.
pub const ACTOR_MAX: usize = 16;
/// Bytes of a record's detail at most: a longer one is cut and ends in
/// `...`.
pub const DETAIL_MAX: usize = RECORD_MAX - field::TEXT - 4 - ACTOR_MAX;
/// The version byte this gateway writes (and reads).
pub const VERSION: u8 = 1;

/// Byte ranges of the fixed part (see the module documentation).
mod field {
    use core::ops::Range;
    pub(super) const VERSION: usize = 0;
    pub(super) const SEQ: Range<usize> = 1..5;
    pub(super) const BOOT: Range<usize> = 5..9;
    pub(super) const UPTIME: Range<usize> = 9..17;
    pub(super) const WALL: Range<usize> = 17..21;
    pub(super) const KIND: usize = 21;
    pub(super) const INTERFACE: usize = 22;
    pub(super) const FROM: Range<usize> = 23..27;
    pub(super) const ACTOR_LEN: usize = 27;
    pub(super) const DETAIL_LEN: usize = 28;
    /// Where the actor's text starts.
    pub(super) const TEXT: usize = 29;
}

/// Declares a one-byte code: the enum with `Unknown(n)` for codes this
/// version does not know, its code both ways and its word.
macro_rules! coded {
    ($(#[$m:meta])* $name:ident { $($(#[$vm:meta])* $v:ident = $code:literal, $word:literal;)* }) => {
        $(#[$m])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum $name {
            $($(#[$vm])* $v,)*
            /// A code this version does not know (a newer one wrote it):
            /// kept as read.
            Unknown(u8),
        }

        impl $name {
            /// Every known value (tests and documentation).
            #[cfg(test)]
            pub const ALL: &'static [$name] = &[$($name::$v),*];

            /// The value of a stored code.
            pub fn from_code(c: u8) -> Self {
                match c {
                    $($code => $name::$v,)*
                    n => $name::Unknown(n),
                }
            }

            /// The stored code.
            pub fn code(self) -> u8 {
                match self {
                    $($name::$v => $code,)*
                    $name::Unknown(n) => n,
                }
            }

            /// The word in the exports (JSON and CSV).
            pub fn as_str(self) -> &'static str {
                match self {
                    $($name::$v => $word,)*
                    $name::Unknown(_) => "unknown",
                }
            }
        }
    };
}

coded! {
    /// What a record is about (stable codes: never reused or renumbered).
    Kind {
        /// The gateway started (detail: its version).
        Start = 1, "start";
        /// Started in recovery (a board's button held at power-up): the
        /// factory network and access settings for this run.
        Recovery = 2, "recovery";
        /// A login that succeeded (actor: the account).
        Login = 3, "login";
        /// A login that was refused (actor: the name tried).
        LoginFailed = 4, "login-failed";
        /// A session ended by its user.
        Logout = 5, "logout";
        /// An account was created (detail: its name and role).
        AccountCreated = 6, "account-created";
        /// An account was removed.
        AccountRemoved = 7, "account-removed";
        /// An account was given another role.
        AccountRole = 8, "account-role";
        /// An account's password was set.
        AccountPassword = 9, "account-password";
        /// A setting or trigger entry changed (detail: `key: old -> new`).
        Config = 10, "config";
        /// The configuration was loaded at start (detail: from where, and
        /// the CRC of what was loaded).
        ConfigLoaded = 11, "config-loaded";
        /// Connections refused by an allow-list, counted over a period
        /// (detail: how many, over how long; source: the last address).
        Refused = 12, "refused";
        /// A restart was asked for.
        Restart = 13, "restart";
        /// A firmware update: an image installed, or refused and why.
        Firmware = 14, "firmware";
        /// The PLC watchdog tripped.
        Watchdog = 15, "watchdog";
        /// Records were lost before they could be kept (detail: how many).
        Lost = 16, "lost";
        /// The wall clock was set (detail: from where).
        Time = 17, "time";
        /// A change of a protected setting was refused (detail: the
        /// setting, and why): Modbus while configuration over Modbus is
        /// off.
        ConfigRefused = 18, "config-refused";
        /// The gateway stopped in order (detail: why, e.g. `SIGTERM`):
        /// the records after it are of the next start. A start without a
        /// stop before it followed a power cut, a crash or a kill.
        Stop = 19, "stop";
    }
}

impl Kind {
    /// A security record: a start or stop, the configuration loaded or changed, a
    /// login or logout, an account's change, a restart, a firmware update,
    /// the wall clock set. The others (failed logins, refused connections
    /// and changes, the watchdog, lost records, unknown kinds) are failure
    /// records, which an attacker without an account can cause (bounded by
    /// the log's aggregation): a store may keep the two apart, so that
    /// failures never push security records out (Linux's `audit_file`).
    pub fn security(self) -> bool {
        matches!(
            self,
            Kind::Start
                | Kind::Recovery
                | Kind::Login
                | Kind::Logout
                | Kind::AccountCreated
                | Kind::AccountRemoved
                | Kind::AccountRole
                | Kind::AccountPassword
                | Kind::Config
                | Kind::ConfigLoaded
                | Kind::Restart
                | Kind::Stop
                | Kind::Firmware
                | Kind::Time
        )
    }
}

coded! {
    /// Where an event came from.
    Interface {
        /// The gateway itself (start, watchdog, the log).
        System = 0, "system";
        /// The web page and its API.
        Web = 1, "web";
        /// Modbus TCP.
        Modbus = 2, "modbus";
        /// The configuration file (Linux).
        File = 3, "file";
        /// The board's button (a recovery start).
        Button = 4, "button";
        /// The robot link's listen port (listen mode).
        Robot = 5, "robot";
    }
}

/// A short text of printable ASCII, at most `N` bytes: other bytes are
/// stored as `?`; a longer text is cut and ends in `...` (`Short::cut`).
/// Writable with `write!`, never failing.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct Short<const N: usize> {
    bytes: [u8; N],
    len: u8,
    cut: bool,
}

impl<const N: usize> core::fmt::Debug for Short<N> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl<const N: usize> Default for Short<N> {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl<const N: usize> Short<N> {
    /// No text.
    pub const EMPTY: Self = {
        assert!(N < 256 && N >= 3, "a length byte, and room for the ...");
        Short {
            bytes: [0; N],
            len: 0,
            cut: false,
        }
    };

    /// `s`, made printable and cut to fit.
    pub fn new(s: &[u8]) -> Self {
        let mut t = Self::EMPTY;
        t.push(s);
        t
    }

    /// Appends `s`, made printable; what does not fit is cut (the text
    /// then ends in `...` and takes nothing more).
    pub fn push(&mut self, s: &[u8]) {
        for &b in s {
            if self.cut {
                return;
            }
            let b = if (0x20..0x7f).contains(&b) { b } else { b'?' };
            match self.bytes.get_mut(usize::from(self.len)) {
                Some(slot) => {
                    *slot = b;
                    self.len += 1;
                }
                None => {
                    self.cut = true;
                    if let Some(tail) = self.bytes.get_mut(N - 3..) {
                        tail.copy_from_slice(b"...");
                    }
                }
            }
        }
    }

    /// The text.
    pub fn as_bytes(&self) -> &[u8] {
        self.bytes.get(..usize::from(self.len)).unwrap_or(&[])
    }

    /// The text (always ASCII).
    pub fn as_str(&self) -> &str {
        core::str::from_utf8(self.as_bytes()).unwrap_or("")
    }

    /// `true` if text was cut to fit.
    #[cfg(test)]
    pub fn cut(&self) -> bool {
        self.cut
    }
}

impl<const N: usize> core::fmt::Write for Short<N> {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        self.push(s.as_bytes());
        Ok(())
    }
}

/// One audit record (see the module documentation for its stored form).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Record {
    /// Counts every record, across restarts (a gap: records lost).
    pub seq: u32,
    /// Which start of the gateway: counts every start, across restarts.
    pub boot: u32,
    /// Time since that start \[ms\].
    pub uptime_ms: u64,
    /// Wall time, Unix seconds, when the gateway knew it.
    pub wall: Option<u32>,
    /// What happened.
    pub kind: Kind,
    /// Who: an account name, empty for none (`-`).
    pub actor: Short<ACTOR_MAX>,
    /// Through which interface.
    pub interface: Interface,
    /// From which address, when known.
    pub from: Option<Ipv4Addr>,
    /// What exactly (a setting's key with its old and new value, ...).
    pub detail: Short<DETAIL_MAX>,
}

/// Why stored bytes are not a record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DecodeError {
    /// Shorter than its lengths say (or than the fixed part).
    Short,
    /// A version this gateway does not read.
    Version(u8),
    /// A length beyond its maximum.
    Length,
    /// The CRC does not match (damaged, or a torn write).
    Crc,
}

impl Record {
    /// An empty record (a slot of the ring).
    pub const EMPTY: Record = Record {
        seq: 0,
        boot: 0,
        uptime_ms: 0,
        wall: None,
        kind: Kind::Start,
        actor: Short::EMPTY,
        interface: Interface::System,
        from: None,
        detail: Short::EMPTY,
    };

    /// Bytes of the stored form.
    #[cfg(test)]
    pub(crate) fn encoded_len(&self) -> usize {
        field::TEXT + self.actor.as_bytes().len() + self.detail.as_bytes().len() + 4
    }

    /// Writes the stored form into `out`; returns its length.
    pub fn emit(&self, out: &mut [u8; RECORD_MAX]) -> usize {
        let put = |out: &mut [u8; RECORD_MAX], at: core::ops::Range<usize>, v: &[u8]| {
            if let Some(dst) = out.get_mut(at) {
                dst.copy_from_slice(v);
            }
        };
        let actor = self.actor.as_bytes();
        let detail = self.detail.as_bytes();
        out[field::VERSION] = VERSION;
        put(out, field::SEQ, &self.seq.to_le_bytes());
        put(out, field::BOOT, &self.boot.to_le_bytes());
        put(out, field::UPTIME, &self.uptime_ms.to_le_bytes());
        put(out, field::WALL, &self.wall.unwrap_or(0).to_le_bytes());
        out[field::KIND] = self.kind.code();
        out[field::INTERFACE] = self.interface.code();
        let from = self.from.unwrap_or(Ipv4Addr::UNSPECIFIED).octets();
        put(out, field::FROM, &from);
        // Both at most their maximum (a Short never holds more), so the
        // record is at most RECORD_MAX.
        out[field::ACTOR_LEN] = actor.len() as u8;
        out[field::DETAIL_LEN] = detail.len() as u8;
        let a = field::TEXT + actor.len();
        let d = a + detail.len();
        put(out, field::TEXT..a, actor);
        put(out, a..d, detail);
        let crc = crc32(out.get(..d).unwrap_or(&[]));
        put(out, d..d + 4, &crc.to_le_bytes());
        d + 4
    }

    /// Reads a stored record from the start of `bytes` (which may go on
    /// with the next one); returns it and its length.
    pub fn parse(bytes: &[u8]) -> Result<(Record, usize), DecodeError> {
        let byte = |i: usize| bytes.get(i).copied().ok_or(DecodeError::Short);
        let word = |r: core::ops::Range<usize>| -> Result<[u8; 4], DecodeError> {
            bytes
                .get(r)
                .and_then(|b| b.try_into().ok())
                .ok_or(DecodeError::Short)
        };
        let version = byte(field::VERSION)?;
        if version != VERSION {
            return Err(DecodeError::Version(version));
        }
        let (a, d) = (
            usize::from(byte(field::ACTOR_LEN)?),
            usize::from(byte(field::DETAIL_LEN)?),
        );
        if a > ACTOR_MAX || d > DETAIL_MAX {
            return Err(DecodeError::Length);
        }
        let end = field::TEXT + a + d;
        let body = bytes.get(..end).ok_or(DecodeError::Short)?;
        let crc = word(end..end + 4)?;
        if crc32(body) != u32::from_le_bytes(crc) {
            return Err(DecodeError::Crc);
        }
        let uptime = bytes
            .get(field::UPTIME)
            .and_then(|b| b.try_into().ok())
            .ok_or(DecodeError::Short)?;
        let text = |r: core::ops::Range<usize>| bytes.get(r).unwrap_or(&[]);
        let wall = u32::from_le_bytes(word(field::WALL)?);
        let from = Ipv4Addr::from(word(field::FROM)?);
        let record = Record {
            seq: u32::from_le_bytes(word(field::SEQ)?),
            boot: u32::from_le_bytes(word(field::BOOT)?),
            uptime_ms: u64::from_le_bytes(uptime),
            wall: (wall != 0).then_some(wall),
            kind: Kind::from_code(byte(field::KIND)?),
            actor: Short::new(text(field::TEXT..field::TEXT + a)),
            interface: Interface::from_code(byte(field::INTERFACE)?),
            from: (!from.is_unspecified()).then_some(from),
            detail: Short::new(text(field::TEXT + a..end)),
        };
        Ok((record, end + 4))
    }

    /// The actor as shown: the account name, or `-` for none.
    pub fn actor_str(&self) -> &str {
        match self.actor.as_str() {
            "" => "-",
            a => a,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::fmt::Write;

    fn sample() -> Record {
        Record {
            seq: 0x0102_0304,
            boot: 7,
            uptime_ms: 0x0000_0102_0304_0506,
            wall: Some(1_795_000_000),
            kind: Kind::Config,
            actor: Short::new(b"alice"),
            interface: Interface::Web,
            from: Some(Ipv4Addr::new(10, 0, 0, 5)),
            detail: Short::new(b"link.poll_ms: 100 -> 50"),
        }
    }

    #[test]
    fn a_record_reads_back_what_was_written() {
        let mut buf = [0u8; RECORD_MAX];
        for r in [sample(), Record::EMPTY] {
            let n = r.emit(&mut buf);
            assert_eq!(n, r.encoded_len());
            assert_eq!(Record::parse(&buf[..n]), Ok((r, n)));
            // Followed by the next one: only its own bytes are read.
            let mut two = buf[..n].to_vec();
            two.extend_from_slice(&buf[..n]);
            assert_eq!(Record::parse(&two), Ok((r, n)));
        }
        // The fixed part, byte by byte (the documented layout).
        let n = sample().emit(&mut buf);
        assert_eq!(buf[0], VERSION);
        assert_eq!(&buf[1..5], &[4, 3, 2, 1]);
        assert_eq!(&buf[5..9], &[7, 0, 0, 0]);
        assert_eq!(buf[21], 10, "kind config");
        assert_eq!(buf[22], 1, "interface web");
        assert_eq!(&buf[23..27], &[10, 0, 0, 5]);
        assert_eq!((buf[27], buf[28]), (5, 23));
        assert_eq!(&buf[29..34], b"alice");
        assert_eq!(n, 29 + 5 + 23 + 4);
    }

    #[test]
    fn the_longest_record_is_record_max_bytes() {
        let mut r = sample();
        r.actor = Short::new(&[b'a'; 100]);
        r.detail = Short::new(&[b'd'; 300]);
        let mut buf = [0u8; RECORD_MAX];
        assert_eq!(r.emit(&mut buf), RECORD_MAX);
        let (back, n) = Record::parse(&buf).unwrap();
        assert_eq!(n, RECORD_MAX);
        assert!(back.detail.as_str().ends_with("..."), "a cut shows");
        assert_eq!(back.actor.as_bytes().len(), ACTOR_MAX);
    }

    #[test]
    fn damaged_or_torn_records_are_refused_whole() {
        let mut buf = [0u8; RECORD_MAX];
        let n = sample().emit(&mut buf);
        for cut in 0..n {
            assert!(Record::parse(&buf[..cut]).is_err(), "torn at {cut}");
        }
        for i in 0..n {
            for bit in 0..8 {
                let mut b = buf;
                b[i] ^= 1 << bit;
                assert!(Record::parse(&b[..n]).is_err(), "byte {i} bit {bit}");
            }
        }
        let mut b = buf;
        b[0] = 2;
        assert_eq!(Record::parse(&b[..n]), Err(DecodeError::Version(2)));
        assert_eq!(Record::parse(&[0xFF; 40]), Err(DecodeError::Version(0xFF)));
    }

    #[test]
    fn unknown_codes_survive() {
        let mut r = sample();
        r.kind = Kind::Unknown(200);
        r.interface = Interface::Unknown(9);
        let mut buf = [0u8; RECORD_MAX];
        let n = r.emit(&mut buf);
        let (back, _) = Record::parse(&buf[..n]).unwrap();
        assert_eq!(back.kind, Kind::Unknown(200));
        assert_eq!(back.kind.as_str(), "unknown");
        assert_eq!(back.interface.code(), 9);
        for k in Kind::ALL {
            assert_eq!(Kind::from_code(k.code()), *k);
        }
        for i in Interface::ALL {
            assert_eq!(Interface::from_code(i.code()), *i);
        }
    }

    #[test]
    fn short_texts_are_printable_and_say_when_cut() {
        let s = Short::<8>::new(b"a\x00b\xffc\n");
        assert_eq!(s.as_str(), "a?b?c?");
        assert!(!s.cut());
        let mut s = Short::<8>::EMPTY;
        write!(s, "{}-{}", 12345, 67890).unwrap();
        assert_eq!(s.as_str(), "12345...");
        assert!(s.cut());
        s.push(b"more");
        assert_eq!(s.as_str(), "12345...", "nothing after a cut");
        assert_eq!(Short::<8>::new(b"12345678").as_str(), "12345678");
    }
}
