//! RAW requests and trigger entries: one protocol message written by the
//! PLC, checked once with the codec's grammar when fired.

use hans_codec::{CommandId, Decimal, Kind, RawMessage, ReplyExpect};

use super::{JobKind, Message, Urgent};
use crate::error::GatewayError;

/// Longest text of a job: a RAW request of 256 characters and the `,;` the
/// gateway may add.
pub const TEXT_MAX: usize = 258;

/// A message as the PLC wrote it, with what the engine needs to know about
/// it, found when it was checked.
#[derive(Clone, Debug, PartialEq)]
pub struct TextJob {
    /// The message, sent as is (a missing `,;` was added).
    pub text: heapless::String<TEXT_MAX>,
    /// Its command, if the codec knows the name (unknown names are sent
    /// too: newer firmware).
    pub id: Option<CommandId>,
    /// The reply it expects.
    pub expect: ReplyExpect,
    /// Length of its name (the reply of an unknown command must carry it).
    pub name_len: u8,
    /// For `SetOverride`: the ratio, shown in `OVERRIDE` once accepted.
    pub override_ratio: Option<Decimal>,
}

impl TextJob {
    /// The command name as written.
    pub fn name(&self) -> &str {
        self.text.get(..usize::from(self.name_len)).unwrap_or("")
    }

    /// Writes the text into `buf`.
    pub fn encode(&self, buf: &mut [u8]) -> Option<Message> {
        let b = self.text.as_bytes();
        buf.get_mut(..b.len())?.copy_from_slice(b);
        Some(Message {
            len: b.len(),
            expect: self.expect,
            id: self.id,
        })
    }
}

/// Checks one protocol message written by the PLC (RAW or a trigger entry)
/// and builds its job: printable ASCII, one message only, valid for the
/// codec's grammar (a known command's fields are read and typed; unknown
/// names pass). A missing terminator is added (`GrpStop,0` →
/// `GrpStop,0,;`). Urgent commands become [`Urgent`] and go out in the
/// canonical form (`GrpStop, 0 ,;` → `GrpStop,0,;`), whatever their length.
/// Returns the job and the robot id of an urgent command.
pub(crate) fn build(bytes: &[u8]) -> Result<(JobKind, Option<u8>), GatewayError> {
    const BAD: GatewayError = GatewayError::BadParameter;
    if !bytes.iter().all(|b| (0x20..0x7f).contains(b)) {
        return Err(BAD);
    }
    let t = core::str::from_utf8(bytes).map_err(|_| BAD)?;
    let t = t.trim_matches(' ');
    if t.is_empty() {
        return Err(BAD);
    }
    // One message only: nothing but blanks after the first `;`.
    if let Some(i) = t.find(';') {
        if !t.get(i + 1..).unwrap_or("").trim().is_empty() {
            return Err(BAD);
        }
    }
    let msg = RawMessage::parse(t).map_err(|_| BAD)?;
    if msg.kind() != Kind::Request {
        return Err(BAD);
    }
    let id = CommandId::from_name(msg.name());
    let number = |i: usize| msg.fields().nth(i).and_then(|f| Decimal::parse(f).ok());
    if let Some(u) = id.and_then(Urgent::of) {
        // The robot id of those that have one (0 when left out); one that is
        // not a number 0-255 has no canonical form here: refused.
        let rbt = match u {
            Urgent::StopScript | Urgent::PauseScript | Urgent::ContinueScript => 0,
            _ if msg.is_empty() => 0,
            _ => number(0)
                .and_then(|d| d.to_i64())
                .and_then(|v| u8::try_from(v).ok())
                .ok_or(BAD)?,
        };
        return Ok((JobKind::Urgent(u), Some(rbt)));
    }
    let mut text = heapless::String::new();
    text.push_str(t).map_err(|_| BAD)?;
    if !t.ends_with(';') {
        let tail = if t.ends_with(',') { ";" } else { ",;" };
        text.push_str(tail).map_err(|_| BAD)?;
    }
    let name_len = u8::try_from(msg.name().len()).map_err(|_| BAD)?;
    let override_ratio = match id {
        Some(CommandId::SetOverride) => number(1),
        _ => None,
    };
    Ok((
        JobKind::Text(TextJob {
            text,
            id,
            expect: ReplyExpect {
                command: id,
                count: list_len(id, &msg),
            },
            name_len: name_len.min(u8::try_from(t.len()).unwrap_or(u8::MAX)),
            override_ratio,
        }),
        None,
    ))
}

/// For the reads whose reply has one value per index asked for, how many
/// (`ReadBoxDI,5,6,;` → 2; `ReadEI,0,1,2,;` → 2 after the robot id).
fn list_len(id: Option<CommandId>, msg: &RawMessage<'_>) -> Option<u16> {
    let skip = match id? {
        CommandId::ReadBoxDI
        | CommandId::ReadBoxDO
        | CommandId::ReadBoxCI
        | CommandId::ReadBoxCO
        | CommandId::ReadBoxAI
        | CommandId::ReadBoxAO => 0,
        CommandId::ReadEI | CommandId::ReadEO | CommandId::ReadEAI => 1,
        _ => return None,
    };
    u16::try_from(msg.len().saturating_sub(skip)).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text_of(t: &str) -> TextJob {
        match build(t.as_bytes()).unwrap().0 {
            JobKind::Text(t) => t,
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn raw_text_is_checked_and_terminated() {
        let j = text_of("MoveRelJ,0,1,1,5");
        assert_eq!(j.text.as_str(), "MoveRelJ,0,1,1,5,;");
        assert_eq!(j.id, Some(CommandId::MoveRelJ));
        assert_eq!(j.name(), "MoveRelJ");
        assert_eq!(text_of("SetBoxDO,1,1,").text.as_str(), "SetBoxDO,1,1,;");
        assert_eq!(
            build(b"GrpStop,0,;GrpReset,0,;").unwrap_err(),
            GatewayError::BadParameter
        );
        assert!(build(b"  ").is_err());
        assert!(build(b"SetBoxDO,1,\x011,;").is_err());
        // Unknown names pass through (newer firmware).
        let j = text_of("ReadVersion,;");
        assert_eq!((j.id, j.name()), (None, "ReadVersion"));
        assert_eq!(
            text_of("SetOverride,0,0.25,;").override_ratio,
            Decimal::parse("0.25").ok()
        );
    }

    #[test]
    fn urgent_texts_are_typed_with_their_robot_id() {
        assert_eq!(
            build(b"GrpStop, 1 ,;").unwrap(),
            (JobKind::Urgent(Urgent::Stop), Some(1))
        );
        assert_eq!(
            build(b"StopScript").unwrap(),
            (JobKind::Urgent(Urgent::StopScript), Some(0))
        );
        for id in CommandId::ALL
            .iter()
            .copied()
            .filter(|&i| Urgent::of(i).is_some())
        {
            let wide = format!("{},{:>30},;", id.name(), 0);
            let (kind, _) = build(wide.as_bytes()).unwrap();
            assert_eq!(kind, JobKind::Urgent(Urgent::of(id).unwrap()), "{wide}");
        }
    }
}
