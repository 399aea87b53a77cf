//! The command catalogue: all 139 commands of chapter 4, declared once.
//!
//! [`table`](self) holds one entry per command — wire name, aliases,
//! document section, request parameters with their types, ranges and units,
//! and the values of its success reply. The `catalogue!` macro below turns
//! that table into:
//!
//! * [`CommandId`], with names, aliases and sections,
//! * one struct per command in [`request`] and in [`response`],
//! * the [`Request`] and [`Response`] enums (plus `Unknown` for names this
//!   crate does not know: newer firmware keeps working),
//! * reading, writing and a generic [`Visitor`] walk for each, and the
//!   ranges the writers' walk is checked against (`Request::validate`).
//!
//! A reply is read against the request it answers ([`ReplyExpect`]), so
//! `ReadBoxDI,5,6,;` expects exactly two values back.
//!
//! Where the document, its examples and the vendor SDKs disagree on the
//! order of fields, `quirks` reorders the accepted alternative into the
//! canonical order before the table's reader runs; output is always the
//! canonical form.

use crate::error::{EncodeError, ParseError, RangeError};
use crate::grammar::{self, Cursor, Kind, RawMessage};
use crate::level::{LevelError, ProtocolLevel};
use crate::number::Decimal;
use crate::types::{Param, Range, Visitor};
use crate::writer::{Check, Writer};
use crate::ErrorCode;

mod packing;
mod quirks;
mod table;

pub use table::{request, response, CommandId, Request, Response};

/// Implemented by every request struct of [`request`].
pub trait Command<'a>: Sized {
    /// Which command this is.
    const ID: CommandId;

    /// Reads this command from one message (with or without `;`). Aliases of
    /// its name are accepted.
    fn parse(text: &'a str) -> Result<Self, ParseError<'a>>;

    /// Writes the canonical message `Name,p1,...,pn,;` into `buf` and returns
    /// its length.
    fn encode(&self, buf: &mut [u8]) -> Result<usize, EncodeError>;

    /// What the reply to this request must look like.
    fn expect(&self) -> ReplyExpect;

    /// Checks every parameter against the range of the document's tables.
    fn validate(&self) -> Result<(), RangeError>;

    /// Walks the parameters in wire order.
    fn visit(&self, v: &mut dyn Visitor);

    /// This command as a [`Request`] (what `Request::from` does).
    fn into_request(self) -> Request<'a>;

    /// Checks that controllers of `level` have this command (see
    /// [`crate::level`]).
    fn check_level(&self, level: ProtocolLevel) -> Result<(), LevelError> {
        Self::ID.check_level(level)
    }

    /// [`Command::encode`] for a controller of `level`: a command that
    /// level does not have is an [`EncodeError::Unsupported`], and nothing
    /// is written.
    fn encode_at(&self, level: ProtocolLevel, buf: &mut [u8]) -> Result<usize, EncodeError> {
        self.check_level(level).map_err(EncodeError::Unsupported)?;
        self.encode(buf)
    }
}

/// Implemented by every success-reply struct of [`response`].
pub trait ReplyValues<'a>: Sized {
    /// Which command's reply this is.
    const ID: CommandId;

    /// These values as a [`Response`] (what `Response::from` does).
    fn into_response(self) -> Response<'a>;
}

// One `From` impl for each enum, over the traits every table struct
// implements, rather than one `From` impl per command: rustc checks the
// impls of one trait for one type pairwise (coherence), and the ~280 impls
// of `From<_> for Request` and `Response` took ~6 of the crate's 25 s of
// compile time, in every build of it (-Z time-passes).
impl<'a, C: Command<'a>> From<C> for Request<'a> {
    fn from(c: C) -> Self {
        c.into_request()
    }
}

impl<'a, R: ReplyValues<'a>> From<R> for Response<'a> {
    fn from(r: R) -> Self {
        r.into_response()
    }
}

/// How a table struct reads and writes its fields (crate-internal).
pub(crate) trait Message<'a>: Sized {
    /// A value with every field blank (zero, empty).
    fn blank() -> Self;
    /// Reads the fields into `self`, in place: each value is written once,
    /// where it stays.
    fn read_in(&mut self, c: &mut Cursor<'_, 'a>);
    fn write_fields(&self, w: &mut Writer<'_>);
    fn read_fields(c: &mut Cursor<'_, 'a>) -> Self {
        let mut m = Self::blank();
        m.read_in(c);
        m
    }
}

/// Most fields any command with a field-order quirk has.
const QUIRK_FIELDS: usize = 48;

/// Reads the fields of known command `id` from `rest`, the message text
/// after the name (or after `OK`), terminator included, with `read`; then
/// checks that nothing is left over. One function for every command (the
/// reader is called through a reference), so it is in flash once.
pub(crate) fn read_known<'a>(
    id: CommandId,
    name: &'a str,
    rest: Option<&'a str>,
    list_len: Option<u16>,
    read: &mut dyn FnMut(&mut Cursor<'_, 'a>),
) -> Result<(), ParseError<'a>> {
    let mut scratch = heapless::Vec::<&'a str, QUIRK_FIELDS>::new();
    let mut c = if quirks::applies(id) && reorder(id, name, rest, &mut scratch)? {
        Cursor::from_slice(&scratch, id)
    } else {
        Cursor::new(rest, id)
    }
    .with_list_len(list_len);
    read(&mut c);
    c.finish()
}

/// Reorders the fields of a command with a field-order quirk into `out`
/// if `quirks` recognises an alternative layout.
#[inline(never)]
fn reorder<'a>(
    id: CommandId,
    name: &'a str,
    rest: Option<&'a str>,
    out: &mut heapless::Vec<&'a str, QUIRK_FIELDS>,
) -> Result<bool, ParseError<'a>> {
    let raw = RawMessage::from_parts(name, rest)?;
    Ok(quirks::reorder(id, &raw, out))
}

/// The name and fields' text of a request, or why it is not one.
#[inline]
fn request_head(text: &str) -> Result<(&str, Option<&str>), ParseError<'_>> {
    let (name, rest) = grammar::head(text)?;
    let first = rest.map(|r| grammar::next_field(r).0);
    match grammar::kind_of(name, first) {
        Kind::Request => Ok((name, rest)),
        _ => Err(ParseError::NotARequest),
    }
}

/// `true` when `name` is the wire name of `id` or one of its aliases.
#[inline]
fn names(id: CommandId, name: &str) -> bool {
    id.name() == name || CommandId::from_name(name) == Some(id)
}

fn parse_request_as<'a, M: Message<'a>>(id: CommandId, text: &'a str) -> Result<M, ParseError<'a>> {
    let (name, rest) = request_head(text)?;
    if !names(id, name) {
        return Err(ParseError::NameMismatch {
            expected: id,
            got: name,
        });
    }
    let mut out = None;
    read_known(id, name, rest, None, &mut |c| out = Some(M::read_fields(c)))?;
    // `read_known` always calls the reader.
    out.ok_or(ParseError::NotARequest)
}

fn encode_with(
    id: Option<CommandId>,
    name: &str,
    ok: bool,
    buf: &mut [u8],
    fields: impl FnOnce(&mut Writer<'_>),
) -> Result<usize, EncodeError> {
    let mut w = Writer::of(buf, id);
    w.name(name);
    if ok {
        w.raw_field("OK");
    }
    fields(&mut w);
    w.finish()
}

fn encode_raw(raw: &RawMessage<'_>, ok: bool, buf: &mut [u8]) -> Result<usize, EncodeError> {
    encode_with(None, raw.name(), ok, buf, |w| {
        raw.fields().for_each(|f| w.text_at(f, Param::RAW))
    })
}

/// A value outside its parameter's range: the parameter, the element (0
/// for a single value), the range.
type Violation = (Param, u16, &'static Range);

/// Checks the numbers of a request against their parameters' ranges, as a
/// checking [`Writer`] walks them (range checks have no per-command code:
/// they reuse the writers').
struct RangeCheck {
    /// The parameter of the last value, and that value's element index.
    last: Param,
    element: u16,
    /// The first value outside its range.
    first: Option<Violation>,
}

impl Check for RangeCheck {
    fn value(&mut self, v: Decimal, param: Param, command: Option<CommandId>) {
        if self.last == param {
            self.element = self.element.saturating_add(1);
        } else {
            self.last = param;
            self.element = 0;
        }
        if self.first.is_none() {
            if let Some(range) = param.range(command) {
                if !range.contains(v) {
                    self.first = Some((param, self.element, range));
                }
            }
        }
    }
}

/// Checks the parameters of command `id` against their ranges: `fields`
/// walks them through a checking writer.
fn validate_with(id: CommandId, fields: impl FnOnce(&mut Writer<'_>)) -> Result<(), RangeError> {
    let mut check = RangeCheck {
        last: Param::RAW,
        element: 0,
        first: None,
    };
    fields(&mut Writer::checking(id, &mut check));
    range_error(id, check.first)
}

fn range_error(command: CommandId, v: Option<Violation>) -> Result<(), RangeError> {
    match v {
        None => Ok(()),
        Some((param, element, range)) => Err(RangeError {
            command,
            param: param.name(Some(command)),
            element,
            range: *range,
        }),
    }
}

/// What the reply to a request must look like: which command must answer,
/// and for list replies how many values (`ReadBoxDI,5,6,;` → 2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ReplyExpect {
    /// The command that must answer; `None` for names this crate does not
    /// know (the reply is then read as [`Response::Unknown`]).
    pub command: Option<CommandId>,
    /// For replies whose length depends on the request, the number of values.
    pub count: Option<u16>,
}

impl ReplyExpect {
    /// The reply of `command`, of any valid length.
    pub const fn of(command: CommandId) -> Self {
        ReplyExpect {
            command: Some(command),
            count: None,
        }
    }

    /// A reply read by its own name, without knowing the request: known
    /// names are typed (lists of any valid length), others stay generic.
    pub fn from_name(name: &str) -> Self {
        ReplyExpect {
            command: CommandId::from_name(name),
            count: None,
        }
    }
}

/// A `Fail` reply: `Name,Fail,code[,anything],;`.
///
/// Controllers send the code alone, the code plus an explanation, an
/// explanation containing commas, or data fields before the explanation;
/// everything after the code is kept verbatim in `detail`. The name is not
/// checked against the request: a failure is reported whatever it is called
/// (the document itself has `ReadActPos,Fail` under `ReadCmdPos`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Failure<'a> {
    /// The name the reply carries.
    pub name: &'a str,
    /// The error code.
    pub code: ErrorCode,
    /// Everything after the code, without terminator, trimmed at its ends
    /// (inside, commas and spaces are kept as sent).
    pub detail: &'a str,
}

impl<'a> Failure<'a> {
    /// The command named by the reply, if known.
    pub fn command(&self) -> Option<CommandId> {
        CommandId::from_name(self.name)
    }

    /// Writes `Name,Fail,code,;` or `Name,Fail,code,detail,;`.
    pub fn encode(&self, buf: &mut [u8]) -> Result<usize, EncodeError> {
        let detail_ok = self
            .detail
            .bytes()
            .all(|b| (0x20..0x7f).contains(&b) && b != b';');
        if !detail_ok {
            return Err(EncodeError::InvalidText { param: "detail" });
        }
        let mut w = Writer::new(buf);
        w.name(self.name);
        w.raw_field("Fail");
        w.int(self.code.code());
        // Written as read: `detail` then the terminator `,;`, so that
        // reading it back gives the same detail (an empty last field in it
        // included).
        let d = crate::grammar::trim(self.detail);
        if !d.is_empty() {
            w.raw_field(d);
        }
        w.finish()
    }
}

/// A reply from the controller.
///
/// It is as large as the largest reply (`ReadActPos`, 24 numbers, ~400
/// bytes) because nothing is boxed: the codec does not allocate.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Reply<'a> {
    /// `Name,OK,...,;` with its typed values.
    Ok(Response<'a>),
    /// `Name,Fail,code,...;`.
    Fail(Failure<'a>),
    /// `errorcmd,...`: the controller could not parse the request. The
    /// fields are kept as sent (no full capture of this reply is public).
    ErrorCmd(RawMessage<'a>),
}

impl<'a> Reply<'a> {
    /// Reads a reply to the request described by `expect`. A success reply
    /// must carry the request's name (or one of its aliases).
    // Not inlined: inlined into a caller that moves the big reply around,
    // the copies measured slower in some callers (up to 1.5x) than the one
    // move out of a call.
    #[inline(never)]
    pub fn parse(text: &'a str, expect: ReplyExpect) -> Result<Self, ParseError<'a>> {
        // The reply is read in place, into the value returned.
        let mut reply = Ok(Reply::Ok(Response::Unknown(RawMessage::EMPTY)));
        if let Ok(r) = &mut reply {
            if let Err(e) = Self::parse_into(text, expect, r) {
                reply = Err(e);
            }
        }
        reply
    }

    /// [`Reply::parse`] into `out`.
    fn parse_into(
        text: &'a str,
        expect: ReplyExpect,
        out: &mut Self,
    ) -> Result<(), ParseError<'a>> {
        let (name, rest) = grammar::head(text)?;
        let (first, after) = match rest {
            Some(r) => {
                let (f, after) = grammar::next_field(r);
                (Some(f), after)
            }
            None => (None, None),
        };
        match grammar::kind_of(name, first) {
            Kind::Ok => {
                let Some(id) = expect.command else {
                    *out = Reply::Ok(Response::Unknown(RawMessage::from_parts(name, after)?));
                    return Ok(());
                };
                if !names(id, name) {
                    return Err(ParseError::NameMismatch {
                        expected: id,
                        got: name,
                    });
                }
                let Reply::Ok(response) = out else {
                    // `parse` hands in an `Ok` reply.
                    return Err(ParseError::NotAReply);
                };
                read_known(id, name, after, expect.count, &mut |c| {
                    Response::read_into(id, c, response)
                })
            }
            Kind::ErrorCmd => {
                *out = Reply::ErrorCmd(RawMessage::from_parts(name, rest)?);
                Ok(())
            }
            Kind::Request => Err(ParseError::NotAReply),
            Kind::Fail => {
                *out = Self::failure(name, after)?;
                Ok(())
            }
        }
    }

    /// `Name,Fail,code,...`: `rest` is the text after `Fail`.
    #[inline(never)]
    fn failure(name: &'a str, rest: Option<&'a str>) -> Result<Self, ParseError<'a>> {
        use crate::error::Got;
        let Some(rest) = rest else {
            return Err(ParseError::BadErrorCode(Got::End));
        };
        let (f, detail) = grammar::next_field(rest);
        // Read as every integer field is (`20007`, also ` 20007 ` or
        // `20007.0`), with the number reader the codec links anyway.
        let code = crate::number::Decimal::parse(grammar::trim(f))
            .ok()
            .and_then(|d| i32::try_from(d.to_i64()?).ok())
            .ok_or(ParseError::BadErrorCode(Got::Field(f)))?;
        let detail = RawMessage::from_parts(name, detail)?;
        Ok(Reply::Fail(Failure {
            name,
            code: ErrorCode::from(code),
            detail: grammar::trim(detail.body()),
        }))
    }

    /// Writes the reply canonically.
    pub fn encode(&self, buf: &mut [u8]) -> Result<usize, EncodeError> {
        match self {
            Reply::Ok(r) => r.encode(buf),
            Reply::Fail(f) => f.encode(buf),
            Reply::ErrorCmd(raw) => encode_raw(raw, false, buf),
        }
    }

    /// The failure code, for `Fail` replies.
    pub fn error_code(&self) -> Option<ErrorCode> {
        match self {
            Reply::Fail(f) => Some(f.code),
            _ => None,
        }
    }
}

/// Defines the whole catalogue from the table (see `table.rs`): the
/// commands of the HR-TCP V1.0.0.3 document, and with the `v6` feature
/// those the V6 document adds after them. The catalogue is generated once
/// per feature set, so a build without `v6` has no trace of the V6
/// commands (their names pass through as `Unknown`).
macro_rules! catalogue {
    (v5 { $($v5:tt)* } v6 { $($v6:tt)* }) => {
        #[cfg(not(feature = "v6"))]
        catalogue_items! { $($v5)* }
        #[cfg(feature = "v6")]
        catalogue_items! { $($v5)* $($v6)* }
    };
}
use catalogue;

/// The section a command is known by: the HR-TCP V1.0.0.3 document's if
/// it has one, else the V6 document's.
macro_rules! first_section {
    ($s5:literal; $($s6:literal)?) => {
        $s5
    };
    (; $s6:literal) => {
        $s6
    };
}
use first_section;

/// An optional section of the table.
macro_rules! maybe_section {
    () => {
        None
    };
    ($s:literal) => {
        Some($s)
    };
}
use maybe_section;

/// A controller version of the table (`since "HR5.50.3"`), or the V5 level
/// when none is given.
macro_rules! level_of {
    () => {
        ProtocolLevel::V5
    };
    ($l:literal) => {
        const { ProtocolLevel::lit($l) }
    };
}
use level_of;

/// An optional controller version of the table (`removed`, `changed`).
macro_rules! maybe_level {
    () => {
        None
    };
    ($l:literal) => {
        Some(const { ProtocolLevel::lit($l) })
    };
}
use maybe_level;

/// The `Message` impl of a success reply: generated from the table, or,
/// with `v6`, written by hand in `quirks` (`reply = by_hand`) for a reply
/// whose V6 form the table cannot say (without `v6` the table's reader of
/// the HR-TCP V1.0.0.3 form is used: the V6 form's code is not linked).
macro_rules! reply_message {
    (by_hand; $($rest:tt)*) => {
        #[cfg(not(feature = "v6"))]
        reply_message! { ; $($rest)* }
    };
    (; $Cmd:ident $(<$rlt:lifetime>)? [$( $(#[cfg($fcfg:meta)])? $field:ident ),*]
        [$( $(#[cfg($rfcfg:meta)])? $rfield:ident ),*]) => {
        impl<'a> Message<'a> for response::$Cmd $(<$rlt>)? {
            #[inline(always)]
            fn blank() -> Self {
                response::$Cmd { $( $(#[cfg($rfcfg)])? $rfield: Field::BLANK, )* }
            }
            #[inline]
            #[allow(unused_variables, unused_mut, unused_assignments)]
            fn read_in(&mut self, c: &mut Cursor<'_, 'a>) {
                // The reply's values follow the request's parameters.
                let mut i = <[&str]>::len(&[$( $(#[cfg($fcfg)])? stringify!($field) ),*]) as u8;
                $( $(#[cfg($rfcfg)])? {
                    Field::read_in(&mut self.$rfield, c, Param(i));
                    i += 1;
                } )*
            }
            #[inline(never)]
            #[allow(unused_variables, unused_mut, unused_assignments)]
            fn write_fields(&self, w: &mut Writer<'_>) {
                let mut i = <[&str]>::len(&[$( $(#[cfg($fcfg)])? stringify!($field) ),*]) as u8;
                $( $(#[cfg($rfcfg)])? {
                    Field::write(&self.$rfield, w, Param(i));
                    i += 1;
                } )*
            }
        }
    };
}
use reply_message;

/// The catalogue of the commands it is given (see `catalogue!`).
macro_rules! catalogue_items {
    ($(
        $(#[doc = $doc:literal])*
        $Cmd:ident $(<$lt:lifetime>)? = $wire:literal $(| $(#[cfg($acfg:meta)])? $alias:literal)*
            @ $(v5 $s5:literal)? $(v6 $s6:literal)?
            $(, since $since:literal)? $(, removed $removed:literal)? $(, changed $changed:literal)?
            $(, len = $len:expr)? $(, reply = $by_hand:ident)? ;
        { $( $(#[doc = $fdoc:literal])* $(#[cfg($fcfg:meta)])?
            $field:ident : $fty:ty $(= $range:expr)? ),* $(,)? }
        => $(<$rlt:lifetime>)? { $( $(#[doc = $rdoc:literal])* $(#[cfg($rfcfg:meta)])?
            $rfield:ident : $rty:ty ),* $(,)? }
    )*) => {
        /// Identifies a command of the catalogue.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub enum CommandId {
            $( #[doc = concat!("`", $wire, "` (section ", first_section!($($s5)?; $($s6)?), ").")] $Cmd, )*
        }

        impl CommandId {
            /// Every command, in document order.
            pub const ALL: &'static [CommandId] = &[$(CommandId::$Cmd),*];

            /// The name written on the wire.
            #[cfg_attr(not(target_os = "none"), inline)]
            pub const fn name(self) -> &'static str {
                super::packing::wire_name(self as usize)
            }

            /// Other names accepted on input for this command.
            pub fn aliases(self) -> impl Iterator<Item = &'static str> {
                ALIASES.iter().filter(move |(_, id)| *id == self).map(|(a, _)| *a)
            }

            /// The section of the protocol document (`"4.10.5"`): of the
            /// HR-TCP V1.0.0.3 document if the command is in it, else of the
            /// V6 document.
            pub const fn section(self) -> &'static str {
                match self { $(CommandId::$Cmd => first_section!($($s5)?; $($s6)?),)* }
            }

            /// The section of the HR-TCP V1.0.0.3 document, if the command is
            /// in it.
            pub const fn section_v5(self) -> Option<&'static str> {
                match self { $(CommandId::$Cmd => maybe_section!($($s5)?),)* }
            }

            /// The section of the V6 document (V1.0.19.1), if the command is
            /// in it (`MoveJ`, for one, is not).
            pub const fn section_v6(self) -> Option<&'static str> {
                match self { $(CommandId::$Cmd => maybe_section!($($s6)?),)* }
            }

            /// The first controller version that has the command
            /// ([`ProtocolLevel::V5`] for the commands of the HR-TCP
            /// V1.0.0.3 document).
            pub const fn since(self) -> ProtocolLevel {
                super::packing::since(self as usize)
            }

            /// The first controller version without the command, if the V6
            /// document removes it.
            pub const fn removed(self) -> Option<ProtocolLevel> {
                super::packing::removed(self as usize)
            }

            /// The controller version that changed the command's parameters
            /// or reply, if the V6 document names one (the table's entry says
            /// what changed; the codec reads both forms).
            pub const fn changed(self) -> Option<ProtocolLevel> {
                match self { $(CommandId::$Cmd => maybe_level!($($changed)?),)* }
            }

            /// The command with this wire name or alias (exact letter case).
            pub fn from_name(name: &str) -> Option<CommandId> {
                super::packing::command_named(name)
            }
        }

        /// Every wire name, in [`CommandId::ALL`] order. Read only by the
        /// compiler (see `packing`).
        pub(super) const WIRE_NAME_LIST: &[&str] = &[$($wire),*];

        /// Every parameter name of the table: each command's request
        /// parameters, then its reply's values. Read only by the compiler
        /// (see `packing`).
        pub(super) const PARAM_NAMES: &[&str] = &[$(
            $( $(#[cfg($fcfg)])? stringify!($field), )*
            $( $(#[cfg($rfcfg)])? stringify!($rfield), )*
        )*];

        /// The range of each parameter of [`PARAM_NAMES`] that has one (none
        /// for replies). Read only by the compiler (see `packing`).
        pub(super) const PARAM_RANGES: &[Option<Range>] = &[$(
            $( $(#[cfg($fcfg)])? range_entry!($($range)?), )*
            $( $(#[cfg($rfcfg)])? range_entry!(@reply $rfield), )*
        )*];

        /// How many parameters (request and reply) each command has. Read
        /// only by the compiler (see `packing`).
        pub(super) const PARAM_COUNTS: &[usize] = &[$(
            <[&str]>::len(&[$( $(#[cfg($fcfg)])? stringify!($field) ),*])
                + <[&str]>::len(&[$( $(#[cfg($rfcfg)])? stringify!($rfield) ),*])
        ),*];

        /// The controller version that added each command. Read only by
        /// the compiler (see `packing`).
        pub(super) const SINCE_LIST: &[ProtocolLevel] = &[$(level_of!($($since)?)),*];

        /// The controller version that removed each command, if any. Read
        /// only by the compiler (see `packing`).
        pub(super) const REMOVED_LIST: &[Option<ProtocolLevel>] = &[$(maybe_level!($($removed)?)),*];

        /// Every alias with its command (a short list: most commands have none).
        pub(super) const ALIASES: &[(&str, CommandId)] = &[
            $( $( $(#[cfg($acfg)])? ($alias, CommandId::$Cmd), )* )*
        ];

        impl core::fmt::Display for CommandId {
            fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                f.write_str(self.name())
            }
        }

        /// Request structs, one per command: the parameters in wire order.
        pub mod request {
            #[allow(unused_imports)]
            use super::*;
            $(
                $(#[doc = $doc])*
                #[doc = ""]
                #[doc = concat!("Wire: `", $wire, "`", $(", HR-TCP V1.0.0.3 section ", $s5,)?
                    $(", V6 document section ", $s6,)? ".")]
                #[derive(Clone, Debug, Default, PartialEq)]
                #[cfg_attr(feature = "defmt", derive(defmt::Format))]
                pub struct $Cmd $(<$lt>)? { $( $(#[doc = $fdoc])* $(#[cfg($fcfg)])? pub $field: $fty, )* }
            )*
        }

        /// Success-reply structs, one per command: the values after `OK`.
        pub mod response {
            #[allow(unused_imports)]
            use super::*;
            $(
                #[doc = concat!("Values of a `", $wire, ",OK,...,;` reply (section ",
                    first_section!($($s5)?; $($s6)?), ").")]
                #[derive(Clone, Debug, PartialEq)]
                #[cfg_attr(feature = "defmt", derive(defmt::Format))]
                pub struct $Cmd $(<$rlt>)? { $( $(#[doc = $rdoc])* $(#[cfg($rfcfg)])? pub $rfield: $rty, )* }
            )*
        }

        $(
            impl<'a> Message<'a> for request::$Cmd $(<$lt>)? {
                #[inline(always)]
                fn blank() -> Self {
                    request::$Cmd { $( $(#[cfg($fcfg)])? $field: Field::BLANK, )* }
                }
                #[inline]
                #[allow(unused_variables, unused_mut, unused_assignments)]
                fn read_in(&mut self, c: &mut Cursor<'_, 'a>) {
                    let names: &[&str] = &[$( $(#[cfg($fcfg)])? stringify!($field) ),*];
                    if names.is_empty() {
                        c.skip_stray_robot_id();
                    }
                    let mut i = 0;
                    $( $(#[cfg($fcfg)])? {
                        Field::read_in(&mut self.$field, c, Param(i));
                        i += 1;
                    } )*
                }
                #[inline(never)]
                #[allow(unused_variables, unused_mut, unused_assignments)]
                fn write_fields(&self, w: &mut Writer<'_>) {
                    let mut i = 0;
                    $( $(#[cfg($fcfg)])? {
                        Field::write(&self.$field, w, Param(i));
                        i += 1;
                    } )*
                }
            }

            impl<'a> Command<'a> for request::$Cmd $(<$lt>)? {
                const ID: CommandId = CommandId::$Cmd;

                fn parse(text: &'a str) -> Result<Self, ParseError<'a>> {
                    parse_request_as(CommandId::$Cmd, text)
                }

                fn encode(&self, buf: &mut [u8]) -> Result<usize, EncodeError> {
                    let id = CommandId::$Cmd;
                    encode_with(Some(id), id.name(), false, buf, |w| self.write_fields(w))
                }

                fn expect(&self) -> ReplyExpect {
                    ReplyExpect {
                        command: Some(CommandId::$Cmd),
                        count: None $( .or({
                            let f: fn(&Self) -> usize = $len;
                            Some(u16::try_from(f(self)).unwrap_or(u16::MAX))
                        }) )?,
                    }
                }

                fn validate(&self) -> Result<(), RangeError> {
                    validate_with(CommandId::$Cmd, |w| self.write_fields(w))
                }

                #[allow(unused_variables)]
                fn visit(&self, v: &mut dyn Visitor) {
                    $( $(#[cfg($fcfg)])? Field::visit(&self.$field, stringify!($field), v); )*
                }

                fn into_request(self) -> Request<'a> {
                    Request::$Cmd(self)
                }
            }

            reply_message! { $($by_hand)?; $Cmd $(<$rlt>)?
                [$( $(#[cfg($fcfg)])? $field ),*] [$( $(#[cfg($rfcfg)])? $rfield ),*] }

            impl<'a> ReplyValues<'a> for response::$Cmd $(<$rlt>)? {
                const ID: CommandId = CommandId::$Cmd;

                fn into_response(self) -> Response<'a> {
                    Response::$Cmd(self)
                }
            }
        )*

        /// A request of any command, or an unknown one passed through.
        #[derive(Clone, Debug, PartialEq)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub enum Request<'a> {
            $( #[doc = concat!("`", $wire, "`.")] $Cmd(request::$Cmd $(<$lt>)?), )*
            /// A name this crate does not know, with its fields as sent.
            Unknown(RawMessage<'a>),
        }

        impl<'a> Request<'a> {
            /// Reads a request. Names this crate does not know come back as
            /// [`Request::Unknown`], not as an error.
            // Not inlined, as `Reply::parse`.
            #[inline(never)]
            pub fn parse(text: &'a str) -> Result<Self, ParseError<'a>> {
                // The request is read in place, into the value returned.
                let mut out = Ok(Request::Unknown(RawMessage::EMPTY));
                if let Ok(r) = &mut out {
                    if let Err(e) = Self::parse_into(text, r) {
                        out = Err(e);
                    }
                }
                out
            }

            /// [`Request::parse`] into `out`.
            fn parse_into(text: &'a str, out: &mut Self) -> Result<(), ParseError<'a>> {
                let (name, rest) = request_head(text)?;
                let Some(id) = CommandId::from_name(name) else {
                    *out = Request::Unknown(RawMessage::from_parts(name, rest)?);
                    return Ok(());
                };
                read_known(id, name, rest, None, &mut |c| Request::read_into(id, c, out))
            }

            /// Reads the fields of command `id` into `out`, in place.
            #[inline(never)]
            fn read_into(id: CommandId, c: &mut Cursor<'_, 'a>, out: &mut Self) {
                match id {
                    $( CommandId::$Cmd => {
                        *out = Request::$Cmd(Message::blank());
                        if let Request::$Cmd(m) = out {
                            m.read_in(c);
                        }
                    } )*
                }
            }

            /// The command, or `None` for an unknown name.
            pub fn command(&self) -> Option<CommandId> {
                match self {
                    $( Request::$Cmd(_) => Some(CommandId::$Cmd), )*
                    Request::Unknown(_) => None,
                }
            }

            /// The name written on the wire (as received for unknown names).
            pub fn name(&self) -> &'a str {
                match self.command() {
                    Some(id) => id.name(),
                    None => match self {
                        Request::Unknown(raw) => raw.name(),
                        _ => "",
                    },
                }
            }

            /// Writes the canonical message and returns its length.
            pub fn encode(&self, buf: &mut [u8]) -> Result<usize, EncodeError> {
                // One writer for all commands; each arm is a single call.
                encode_with(self.command(), self.name(), false, buf, |w| self.write_fields(w))
            }

            /// Checks that controllers of `level` have this command (see
            /// [`crate::level`]). Names this crate does not know pass: they
            /// are sent as given.
            pub fn check_level(&self, level: ProtocolLevel) -> Result<(), LevelError> {
                match self.command() {
                    Some(id) => id.check_level(level),
                    None => Ok(()),
                }
            }

            /// [`Request::encode`] for a controller of `level`: a command
            /// that level does not have is an [`EncodeError::Unsupported`],
            /// and nothing is written.
            pub fn encode_at(&self, level: ProtocolLevel, buf: &mut [u8]) -> Result<usize, EncodeError> {
                self.check_level(level).map_err(EncodeError::Unsupported)?;
                self.encode(buf)
            }

            /// Writes the parameters. Out of line, so that each arm is one
            /// jump to the command's writer (6 bytes, where an arm inlined
            /// into `encode` took 14).
            #[inline(never)]
            fn write_fields(&self, w: &mut Writer<'_>) {
                match self {
                    $( Request::$Cmd(r) => r.write_fields(w), )*
                    Request::Unknown(raw) => raw.fields().for_each(|f| w.text_at(f, Param::RAW)),
                }
            }

            /// What the reply must look like.
            pub fn expect(&self) -> ReplyExpect {
                // Only the few commands whose reply length depends on the
                // request need code of their own.
                let count = match self {
                    $( $( Request::$Cmd(r) => {
                        let f: fn(&request::$Cmd) -> usize = $len;
                        Some(u16::try_from(f(r)).unwrap_or(u16::MAX))
                    } )? )*
                    _ => None,
                };
                ReplyExpect { command: self.command(), count }
            }

            /// Checks the parameters against the document's ranges (unknown
            /// commands always pass).
            pub fn validate(&self) -> Result<(), RangeError> {
                match self.command() {
                    // The writers walk the parameters; a checking writer
                    // checks instead of writing.
                    Some(id) => validate_with(id, |w| self.write_fields(w)),
                    None => Ok(()),
                }
            }

            /// Walks the parameters in wire order (unknown commands: each
            /// field as text named by its index).
            pub fn visit(&self, v: &mut dyn Visitor) {
                match self {
                    $( Request::$Cmd(r) => r.visit(v), )*
                    Request::Unknown(raw) => visit_raw(raw, v),
                }
            }
        }

        /// The values of a success reply of any command.
        #[derive(Clone, Debug, PartialEq)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub enum Response<'a> {
            $( #[doc = concat!("`", $wire, ",OK,...`.")] $Cmd(response::$Cmd $(<$rlt>)?), )*
            /// The reply of a command this crate does not know: its name and
            /// the fields after `OK`, as sent.
            Unknown(RawMessage<'a>),
        }

        impl<'a> Response<'a> {
            /// Reads the values of command `id` into `out`, in place.
            #[inline(never)]
            pub(crate) fn read_into(id: CommandId, c: &mut Cursor<'_, 'a>, out: &mut Self) {
                match id {
                    $( CommandId::$Cmd => {
                        *out = Response::$Cmd(Message::blank());
                        if let Response::$Cmd(m) = out {
                            m.read_in(c);
                        }
                    } )*
                }
            }

            /// The command, or `None` for an unknown name.
            pub fn command(&self) -> Option<CommandId> {
                match self {
                    $( Response::$Cmd(_) => Some(CommandId::$Cmd), )*
                    Response::Unknown(_) => None,
                }
            }

            /// The name written on the wire (as received for unknown names).
            pub fn name(&self) -> &'a str {
                match self.command() {
                    Some(id) => id.name(),
                    None => match self {
                        Response::Unknown(raw) => raw.name(),
                        _ => "",
                    },
                }
            }

            /// Writes `Name,OK,v1,...,vn,;` and returns its length.
            pub fn encode(&self, buf: &mut [u8]) -> Result<usize, EncodeError> {
                encode_with(self.command(), self.name(), true, buf, |w| self.write_fields(w))
            }

            /// Writes the values. Out of line, as `Request::write_fields`.
            #[inline(never)]
            fn write_fields(&self, w: &mut Writer<'_>) {
                match self {
                    $( Response::$Cmd(r) => r.write_fields(w), )*
                    Response::Unknown(raw) => raw.fields().for_each(|f| w.text_at(f, Param::RAW)),
                }
            }

            /// Walks the values in wire order.
            pub fn visit(&self, v: &mut dyn Visitor) {
                match self {
                    $( Response::$Cmd(_r) => {
                        $( $(#[cfg($rfcfg)])? Field::visit(&_r.$rfield, stringify!($rfield), v); )*
                    } )*
                    Response::Unknown(raw) => visit_raw(raw, v),
                }
            }
        }
    };
}

use catalogue_items;

/// An entry of `PARAM_RANGES`: the range a table parameter declares after
/// `=`, if any; a reply's values have none.
macro_rules! range_entry {
    () => {
        None
    };
    (@reply $value:ident) => {
        None
    };
    ($range:expr) => {
        Some($range)
    };
}
use range_entry;

/// Visits the fields of an unknown message as texts named `0`, `1`, ...
fn visit_raw(raw: &RawMessage<'_>, v: &mut dyn Visitor) {
    let mut name = itoa::Buffer::new();
    for (i, f) in raw.fields().enumerate() {
        v.text(name.format(i), f);
    }
}

impl CommandId {
    /// `true` for commands that start a motion whose end is observed by
    /// polling `ReadRobotState` (chapter 6): the moves of section 4.10 and
    /// the path moves `MovePath` and `MovePathL` (with `v6` also the V6
    /// document's jogs, `MoveJTo`/`MoveLTo`/`MoveAlignToZ`, `MovePathJ`,
    /// `MovePathJOL`, `SpeedJ` and `SpeedL`).
    pub fn is_motion(self) -> bool {
        use CommandId as C;
        matches!(
            self,
            C::MoveRelJ
                | C::MoveRelL
                | C::WayPointRel
                | C::WayPointEx
                | C::WayPoint
                | C::WayPoint2
                | C::MoveJ
                | C::MoveL
                | C::MoveC
                | C::MoveZ
                | C::MoveE
                | C::MoveS
                | C::MovePath
                | C::MovePathL
        ) || self.is_v6_motion()
    }

    /// The motions of the V6 document: jogs, hold-to-move, path and
    /// velocity moves.
    #[cfg(feature = "v6")]
    fn is_v6_motion(self) -> bool {
        use CommandId as C;
        matches!(
            self,
            C::MoveAlignToZ
                | C::MoveJTo
                | C::MoveLTo
                | C::ShortJogJ
                | C::ShortJogL
                | C::LongJogJ
                | C::LongJogL
                | C::MovePathJ
                | C::MovePathJOL
                | C::SpeedJ
                | C::SpeedL
        )
    }

    #[cfg(not(feature = "v6"))]
    fn is_v6_motion(self) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_and_alias_is_found() {
        for &id in CommandId::ALL {
            assert_eq!(CommandId::from_name(id.name()), Some(id));
            for alias in id.aliases() {
                assert_eq!(CommandId::from_name(alias), Some(id));
            }
        }
        for unknown in ["", "grpenable", "GrpEnable ", "ReadVersion", "Z", "A"] {
            assert_eq!(CommandId::from_name(unknown), None, "{unknown:?}");
        }
    }
}
