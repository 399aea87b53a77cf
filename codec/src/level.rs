//! Protocol levels: which controller versions support which command.
//!
//! The V6 document ("Huayan Robot V6 控制通信协议" V1.0.19.1) opens with a
//! revision table that says, for each command it added, changed or removed,
//! from which controller version on (`HR5.50.3`, `HR6.3.3`, ...). The command
//! table carries that data ([`CommandId::since`], [`CommandId::removed`],
//! [`CommandId::changed`]); a client chooses the level of the controller it
//! talks to and checks each request against it before sending
//! ([`Request::check_level`](crate::Request::check_level),
//! [`Request::encode_at`](crate::Request::encode_at)): `MoveJ` at the V6
//! level, or a V6 command at the V5 level, is a [`LevelError`], and nothing
//! is written.
//!
//! Reading is not affected: every known command parses at any level (a
//! controller, or a log, may well contain them).
//!
//! ```
//! use hans_codec::{request, Command, ProtocolLevel, RobotId};
//!
//! let stop = request::GrpStop { rbt_id: RobotId(0) };
//! assert!(stop.check_level(ProtocolLevel::V5).is_ok());
//! assert!(stop.check_level(ProtocolLevel::V6).is_ok());
//!
//! let old = request::MoveJ::default();
//! let e = old.check_level(ProtocolLevel::V6).unwrap_err();
//! assert_eq!(e.to_string(), "MoveJ was removed at HR5.50.3 (level HR6.6.1)");
//! let mut buf = [0u8; 256];
//! assert!(old.encode_at(ProtocolLevel::V6, &mut buf).is_err());
//! ```
//!
//! ## How versions compare
//!
//! A level is a controller version `major.minor.patch`, compared number by
//! number. The controllers the HR-TCP V1.0.0.3 document describes (versions
//! `20220314.180` to `20220825.214`, before `HR5.50.3`) are
//! [`ProtocolLevel::V5`]; [`ProtocolLevel::V6`] is the newest version the V6
//! document names (`HR6.6.1`). Two simplifications, written down where they
//! apply in the table:
//!
//! * Branch releases (`HR6.4ER.13`, `HR6.3XD.11`, `6.5ZT.12`) are not
//!   modelled: where the revision table gives a main-line version beside
//!   them, the table uses it.
//! * Maintenance releases of an older line that gained a command after a
//!   newer line had shipped (`HR6.2.17`, March 2024, after `HR6.3.3`) are
//!   taken by their number: such a command counts as present from that
//!   number on, on every line.
//!
//! [`CommandId::since`]: crate::CommandId::since
//! [`CommandId::removed`]: crate::CommandId::removed
//! [`CommandId::changed`]: crate::CommandId::changed

use core::fmt;

use crate::catalogue::CommandId;

/// A controller version, the level of the protocol it speaks (see the
/// [module](self) documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ProtocolLevel {
    major: u8,
    minor: u8,
    patch: u8,
}

impl ProtocolLevel {
    /// The controllers of the HR-TCP V1.0.0.3 document (versions
    /// `20220314.180` to `20220825.214`, before `HR5.50.3`): its 139
    /// commands.
    pub const V5: ProtocolLevel = ProtocolLevel::new(5, 0, 0);

    /// The newest controller version the V6 document (V1.0.19.1) names,
    /// `HR6.6.1`: every command of that document except those it removed.
    pub const V6: ProtocolLevel = ProtocolLevel::new(6, 6, 1);

    /// Controller version `major.minor.patch` (`HR6.4.8` is `new(6, 4, 8)`).
    pub const fn new(major: u8, minor: u8, patch: u8) -> Self {
        ProtocolLevel {
            major,
            minor,
            patch,
        }
    }

    /// The version's three numbers.
    pub const fn parts(self) -> (u8, u8, u8) {
        (self.major, self.minor, self.patch)
    }

    /// Reads a version as controllers and the documents write it: an
    /// optional `HR` prefix, then `major.minor.patch`; letters after the
    /// minor number (a branch: `6.4ER.13`) and anything after the patch
    /// number (`PackageVersion` replies `6.3.6.20240305`) are ignored.
    /// `None` when there are not three numbers of at most 255.
    ///
    /// ```
    /// use hans_codec::ProtocolLevel;
    /// assert_eq!(ProtocolLevel::parse("HR6.4.8"), Some(ProtocolLevel::new(6, 4, 8)));
    /// assert_eq!(ProtocolLevel::parse("6.3.6.20240305"), Some(ProtocolLevel::new(6, 3, 6)));
    /// assert_eq!(ProtocolLevel::parse("HR6.4ER.13"), Some(ProtocolLevel::new(6, 4, 13)));
    /// assert_eq!(ProtocolLevel::parse("20220825.214"), None);
    /// ```
    pub const fn parse(text: &str) -> Option<ProtocolLevel> {
        let rest = match text.as_bytes() {
            [b'H', b'R', rest @ ..] => rest,
            all => all,
        };
        let Some((major, rest)) = number(rest) else {
            return None;
        };
        let [b'.', rest @ ..] = rest else {
            return None;
        };
        let Some((minor, mut rest)) = number(rest) else {
            return None;
        };
        // A branch tag after the minor number.
        while let [c, r @ ..] = rest {
            if !c.is_ascii_alphabetic() {
                break;
            }
            rest = r;
        }
        let [b'.', rest @ ..] = rest else {
            return None;
        };
        match number(rest) {
            Some((patch, [] | [b'.', ..])) => Some(ProtocolLevel::new(major, minor, patch)),
            _ => None,
        }
    }

    /// `==` for the compiler (`PartialEq` is not `const`).
    pub(crate) const fn same(&self, other: &ProtocolLevel) -> bool {
        self.major == other.major && self.minor == other.minor && self.patch == other.patch
    }

    /// A version written in the table (`"HR5.50.3"`); a build error when it
    /// does not read.
    pub(crate) const fn lit(text: &str) -> ProtocolLevel {
        let parsed = ProtocolLevel::parse(text);
        assert!(parsed.is_some(), "a controller version such as HR6.3.3");
        match parsed {
            Some(l) => l,
            None => ProtocolLevel::V5,
        }
    }
}

/// The decimal number (1-3 digits, at most 255) at the start of `b`, and
/// what follows it.
const fn number(b: &[u8]) -> Option<(u8, &[u8])> {
    let (mut v, mut digits, mut rest) = (0u32, 0, b);
    while let [c @ b'0'..=b'9', r @ ..] = rest {
        if digits == 3 {
            return None;
        }
        v = v * 10 + (*c - b'0') as u32;
        digits += 1;
        rest = r;
    }
    if digits == 0 || v > 255 {
        return None;
    }
    Some((v as u8, rest))
}

impl fmt::Display for ProtocolLevel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if *self == ProtocolLevel::V5 {
            f.write_str("V5")
        } else {
            write!(f, "HR{}.{}.{}", self.major, self.minor, self.patch)
        }
    }
}

/// A command the chosen protocol level does not have: found before
/// anything is sent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LevelError {
    /// The command came with a later controller version.
    TooNew {
        /// The command.
        command: CommandId,
        /// The first version that has it.
        since: ProtocolLevel,
        /// The level checked against.
        level: ProtocolLevel,
    },
    /// The command was removed.
    Removed {
        /// The command.
        command: CommandId,
        /// The first version without it.
        removed: ProtocolLevel,
        /// The level checked against.
        level: ProtocolLevel,
    },
}

impl LevelError {
    /// The command refused.
    pub fn command(&self) -> CommandId {
        match *self {
            LevelError::TooNew { command, .. } | LevelError::Removed { command, .. } => command,
        }
    }
}

impl fmt::Display for LevelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LevelError::TooNew {
                command,
                since,
                level,
            } => write!(f, "{command} needs {since} (level {level})"),
            LevelError::Removed {
                command,
                removed,
                level,
            } => write!(f, "{command} was removed at {removed} (level {level})"),
        }
    }
}

impl CommandId {
    /// `true` when controllers of `level` have this command.
    pub fn available_at(self, level: ProtocolLevel) -> bool {
        self.check_level(level).is_ok()
    }

    /// Checks that controllers of `level` have this command.
    pub fn check_level(self, level: ProtocolLevel) -> Result<(), LevelError> {
        let since = self.since();
        if level < since {
            return Err(LevelError::TooNew {
                command: self,
                since,
                level,
            });
        }
        match self.removed() {
            Some(removed) if level >= removed => Err(LevelError::Removed {
                command: self,
                removed,
                level,
            }),
            _ => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn versions_read_and_compare() {
        let l = |s| ProtocolLevel::parse(s).unwrap();
        assert!(l("HR5.50.3") < l("HR5.50.5"));
        assert!(l("HR6.2.17") < l("HR6.3.3"));
        assert!(l("HR6.5.1") > l("6.4.17"));
        assert!(ProtocolLevel::V5 < l("HR5.50.3"));
        assert!(ProtocolLevel::V6 == l("HR6.6.1"));
        for bad in [
            "", "HR", "6", "6.4", "6.4.", "6..4", "x6.4.8", "6.4.8x", "6.4.256", "6.4.1000",
        ] {
            assert_eq!(ProtocolLevel::parse(bad), None, "{bad:?}");
        }
        assert_eq!(l("6.5ZT.12"), ProtocolLevel::new(6, 5, 12));
    }
}
