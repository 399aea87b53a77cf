//! Error types: what went wrong reading or writing a message, and the
//! protocol's own error codes.
//!
//! Every error names what it can: the command, the parameter, what was
//! expected and what came. Nothing here allocates or builds strings at run
//! time; `Display` writes the sentence on demand.

use core::fmt;

use crate::catalogue::CommandId;
use crate::grammar::GrammarError;

/// What a parameter should have been.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Expected {
    /// A whole number that fits an `i32`.
    Integer,
    /// A decimal number.
    Number,
    /// A text field (anything without `,` and `;`).
    Text,
    /// At least this many list elements.
    AtLeast(u16),
    /// At most this many list elements.
    AtMost(u16),
    /// Exactly this many list elements (as the request asked for).
    Exactly(u16),
    /// A whole number of groups of this many values.
    MultipleOf(u16),
}

/// What came instead.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Got<'a> {
    /// This field text.
    Field(&'a str),
    /// The message ended.
    End,
    /// This many elements.
    Count(u16),
}

/// Why a message could not be read as the command it names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ParseError<'a> {
    /// Not a message at all (empty, bad name).
    Grammar(GrammarError),
    /// A parameter is missing or has the wrong type.
    Field {
        /// The command being read.
        command: CommandId,
        /// The parameter, as named in the command table.
        param: &'static str,
        /// Index of the offending field after the name (0-based).
        index: u16,
        /// What the parameter should be.
        expected: Expected,
        /// What came.
        got: Got<'a>,
    },
    /// More fields than the command takes.
    TooManyFields {
        /// The command being read.
        command: CommandId,
        /// How many fields the command takes.
        expected: u16,
        /// How many came.
        got: u16,
        /// The first field that was not expected.
        first_extra: &'a str,
    },
    /// A reply names another command than the request it answers.
    NameMismatch {
        /// The command that was asked.
        expected: CommandId,
        /// The name in the reply.
        got: &'a str,
    },
    /// A reply was expected but the message is neither `OK`, `Fail` nor
    /// `errorcmd`.
    NotAReply,
    /// A request was expected but the message is shaped like a reply.
    NotARequest,
    /// A `Fail` reply without an integer error code.
    BadErrorCode(Got<'a>),
}

impl From<GrammarError> for ParseError<'_> {
    fn from(e: GrammarError) -> Self {
        ParseError::Grammar(e)
    }
}

impl fmt::Display for Expected {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Expected::Integer => f.write_str("an integer"),
            Expected::Number => f.write_str("a number"),
            Expected::Text => f.write_str("a text field"),
            Expected::AtLeast(n) => write!(f, "at least {n} values"),
            Expected::AtMost(n) => write!(f, "at most {n} values"),
            Expected::Exactly(n) => write!(f, "exactly {n} values"),
            Expected::MultipleOf(n) => write!(f, "a multiple of {n} values"),
        }
    }
}

impl fmt::Display for Got<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Got::Field(s) => write!(f, "{s:?}"),
            Got::End => f.write_str("the end of the message"),
            Got::Count(n) => write!(f, "{n} values"),
        }
    }
}

impl fmt::Display for GrammarError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            GrammarError::Empty => "empty message",
            GrammarError::BadName => "invalid command name",
            GrammarError::TooManyFields => "too many fields",
        })
    }
}

impl fmt::Display for ParseError<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParseError::Grammar(g) => g.fmt(f),
            ParseError::Field {
                command,
                param,
                index,
                expected,
                got,
            } => write!(
                f,
                "{}: parameter {param} (field {index}) must be {expected}, got {got}",
                command.name()
            ),
            ParseError::TooManyFields {
                command,
                expected,
                got,
                first_extra,
            } => write!(
                f,
                "{}: takes {expected} fields, got {got} (first extra: {first_extra:?})",
                command.name()
            ),
            ParseError::NameMismatch { expected, got } => {
                write!(f, "reply to {} names {got:?}", expected.name())
            }
            ParseError::NotAReply => f.write_str("not a reply (no OK, Fail or errorcmd)"),
            ParseError::NotARequest => f.write_str("a reply where a request was expected"),
            ParseError::BadErrorCode(got) => {
                write!(f, "Fail reply needs an integer error code, got {got}")
            }
        }
    }
}

/// Why a message could not be written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EncodeError {
    /// The output buffer is too small; nothing usable was written.
    BufferTooSmall,
    /// A text parameter contains `,`, `;`, a control character, a non-ASCII
    /// character or leading/trailing spaces, which the grammar cannot carry.
    InvalidText {
        /// The parameter, as named in the command table.
        param: &'static str,
    },
    /// A list has more elements than the protocol allows or the count
    /// field can say.
    ListTooLong {
        /// The parameter, as named in the command table.
        param: &'static str,
    },
    /// The command is not available at the protocol level written for
    /// (`encode_at`); nothing was written.
    Unsupported(crate::level::LevelError),
}

impl fmt::Display for EncodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EncodeError::BufferTooSmall => f.write_str("output buffer too small"),
            EncodeError::InvalidText { param } => {
                write!(
                    f,
                    "parameter {param}: text cannot be carried by the protocol"
                )
            }
            EncodeError::ListTooLong { param } => write!(f, "parameter {param}: list too long"),
            EncodeError::Unsupported(e) => e.fmt(f),
        }
    }
}

/// A parameter outside the valid range given in the document's tables.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RangeError {
    /// The command.
    pub command: CommandId,
    /// The parameter, as named in the command table.
    pub param: &'static str,
    /// For list or array parameters, the element (0-based).
    pub element: u16,
    /// The valid range.
    pub range: crate::types::Range,
}

impl fmt::Display for RangeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: parameter {}[{}] outside {}",
            self.command.name(),
            self.param,
            self.element,
            self.range
        )
    }
}

enum_with_unknown! {
    /// An error code from a `Fail` reply, or one of the client-side codes
    /// the official SDKs use. Codes not listed survive as
    /// [`ErrorCode::Unknown`]; the vendor's full table
    /// ("HuayanRobot_ErrorCode.docx") is not public. The names are those the
    /// documents and SDKs give, or infer; [`ErrorCode::text`] is the
    /// controller's own text where the V6 document prints it, and a
    /// controller at `HR5.50.3` or later explains any code itself
    /// (`GetErrorCodeStr`). The V6 document also uses 20016
    /// (`ReadPointByName`), 20022 (`RunFunc`) and 20046 (a path computation
    /// error) without saying what they are.
    pub enum ErrorCode {
    /// 10000: short-circuit error.
    ShortCircuit = 10000,
    /// 20005: unknown or unsupported command (inferred from SDK behaviour).
    UnknownCommand = 20005,
    /// 20006: parameter error (out of range).
    ParameterError = 20006,
    /// 20007: format error (the message could not be read).
    FormatError = 20007,
    /// 20009: the I/O does not exist.
    IoNotExist = 20009,
    /// 20018: command refused in the current state (the most common failure).
    StateRefused = 20018,
    /// 20029: the TCP (tool) name does not exist.
    TcpNameNotExist = 20029,
    /// 20030: the UCS (user frame) name does not exist.
    UcsNameNotExist = 20030,
    /// 20042: the path is not ready.
    PathNotReady = 20042,
    /// 20601: the script has no such function.
    ScriptNoSuchFunction = 20601,
    /// 40014: the robot is stopping.
    RobotStopping = 40014,
    /// 40020: not in force-control state.
    NotInForceControl = 40020,
    /// 40058: tool I/O type error.
    ToolIoTypeError = 40058,
    /// 39500 (client side, never on the wire): not connected.
    NotConnected = 39500,
    /// 39501 (client side): bad input parameter.
    BadInputParameter = 39501,
    /// 39502 (client side): bad reply.
    BadReply = 39502,
    /// 39503 (client side): socket error or timeout.
    SocketError = 39503,
    /// 39504 (client side): connect failed.
    ConnectFailed = 39504,
    /// 39505 (client side): the reply names another command than the request.
    ReplyNameMismatch = 39505,
    }
}

impl ErrorCode {
    /// The text a controller gives for this code, as the V6 document
    /// prints it in its examples (`20018`: `command forbidden in this
    /// state`; the text of `GetErrorCodeStr` and of failure replies), or
    /// for the client-side codes the vendor SDK's description. `None` for
    /// codes without one: ask the controller (`GetErrorCodeStr`).
    pub fn text(self) -> Option<&'static str> {
        Some(match self {
            ErrorCode::ShortCircuit => "Short circuit error",
            ErrorCode::ParameterError => "command parameters error",
            ErrorCode::FormatError => "command format error",
            ErrorCode::IoNotExist => "IO not exist",
            ErrorCode::StateRefused => "command forbidden in this state",
            ErrorCode::TcpNameNotExist => "TCP not exist",
            ErrorCode::UcsNameNotExist => "UCS not exist",
            ErrorCode::ScriptNoSuchFunction => "Script has no such function",
            ErrorCode::RobotStopping => "Robot in stopping state",
            ErrorCode::NotInForceControl => "Robot not in force control state",
            ErrorCode::ToolIoTypeError => "EndIO type Error",
            ErrorCode::NotConnected => "not connected to the robot",
            ErrorCode::BadInputParameter => "parameter error in the command",
            ErrorCode::BadReply => "parameter error in the reply",
            ErrorCode::SocketError => "socket error (timeout, receive failure)",
            ErrorCode::ConnectFailed => "connecting to the robot failed",
            ErrorCode::ReplyNameMismatch => "the reply names another command",
            _ => return None,
        })
    }
}

/// Code 0: no error (the value of an error field when all is well).
impl Default for ErrorCode {
    fn default() -> Self {
        ErrorCode::Unknown(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texts_are_the_documents() {
        assert_eq!(
            ErrorCode::from(20018).text(),
            Some("command forbidden in this state")
        );
        assert_eq!(ErrorCode::from(10000).text(), Some("Short circuit error"));
        assert_eq!(ErrorCode::from(20042).text(), None);
        assert_eq!(ErrorCode::from(20016).text(), None);
        assert_eq!(ErrorCode::from(20016), ErrorCode::Unknown(20016));
    }
}
