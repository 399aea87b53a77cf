//! Alternative field orders accepted on input.
//!
//! Where the document's signature, its examples and the vendor's SDKs send
//! the same command with fields in another order, the alternative is
//! recognised by the types of its fields and reordered into the canonical
//! order of the table. Output is always canonical. Each case:
//!
//! * `MoveS`: the signature puts `sTcpName,sUcsName` before the velocity;
//!   the document's example and the vendor SDK put them after the radius.
//!   Canonical: the example/SDK order (names after the numbers, as in every
//!   other move). The signature order is recognised by a name at field 3.
//! * `WayPoint2`: the vendor's Python SDK sends `EndPos, AuxPos, cmdID, Tcp,
//!   Ucs, Vel, Acc, Radius, type, isJoint, isSeek, bit, state, Joints`;
//!   the document's signature (canonical here) is `EndPos, Joints, Tcp, Ucs,
//!   Vel, Acc, Radius, type, isJoint, isSeek, bit, state, AuxPos, cmdID`.
//!   Both have 30 fields; the SDK order has a name at field 15 where the
//!   document has the velocity.
//! * `MoveJ`: the signature has 23 fields; the document's examples send 24,
//!   with a move type (always 0) after the radius, as `WayPoint` does. The
//!   extra field is dropped.
//!
//! And one reply whose shape the table cannot say, read and written by hand
//! with the `v6` feature (`reply = by_hand` in the table; without `v6` the
//! table's reader, of HR-TCP V1.0.0.3's form only, is used):
//!
//! * `ReadBoxAO`: HR-TCP V1.0.0.3 replies one value per channel asked for,
//!   the V6 document (and the vendor SDK) the mode and the value of each.
//!   Against its request (`n` channels) `n` values are the first form and
//!   `2n` the second; without a request 4 values are the second form and 1
//!   or 2 the first. Written back in the form read.

use super::{CommandId, QUIRK_FIELDS};
use crate::grammar::RawMessage;
use crate::number::Decimal;
#[cfg(feature = "v6")]
use {
    super::{response, Message},
    crate::error::{Expected, Got},
    crate::grammar::Cursor,
    crate::types::{Field, Param},
    crate::writer::Writer,
};

type Scratch<'a> = heapless::Vec<&'a str, QUIRK_FIELDS>;

/// `true` for the commands that have an alternative layout.
#[inline]
pub(crate) fn applies(id: CommandId) -> bool {
    matches!(
        id,
        CommandId::MoveS | CommandId::WayPoint2 | CommandId::MoveJ
    )
}

/// If `raw` is an alternative layout of `id`, writes its fields in canonical
/// order into `out` and returns `true`.
pub(crate) fn reorder<'a>(id: CommandId, raw: &RawMessage<'a>, out: &mut Scratch<'a>) -> bool {
    match id {
        CommandId::MoveS => move_s(raw, out),
        CommandId::WayPoint2 => way_point2(raw, out),
        CommandId::MoveJ => move_j(raw, out),
        _ => false,
    }
}

fn is_number(f: &str) -> bool {
    f.is_empty() || Decimal::parse(f).is_ok()
}

fn collect<'a>(raw: &RawMessage<'a>, out: &mut Scratch<'a>) -> bool {
    out.clear();
    raw.fields().all(|f| out.push(f).is_ok())
}

/// Rewrites `out` as `out[perm[0]], out[perm[1]], ...`.
fn permute(out: &mut Scratch<'_>, perm: &[usize]) -> bool {
    let src = out.clone();
    out.clear();
    perm.iter()
        .all(|&i| src.get(i).is_some_and(|f| out.push(f).is_ok()))
}

fn field<'a>(out: &Scratch<'a>, i: usize) -> &'a str {
    out.get(i).copied().unwrap_or("")
}

fn move_s<'a>(raw: &RawMessage<'a>, out: &mut Scratch<'a>) -> bool {
    // Signature: rbt, incr, diam, tcp, ucs, vel, acc, radius, cmd
    const FROM_SIGNATURE: [usize; 9] = [0, 1, 2, 5, 6, 7, 3, 4, 8];
    raw.len() == 9
        && collect(raw, out)
        && !is_number(field(out, 3))
        && is_number(field(out, 5))
        && permute(out, &FROM_SIGNATURE)
}

fn way_point2<'a>(raw: &RawMessage<'a>, out: &mut Scratch<'a>) -> bool {
    // SDK: 0 rbt, 1-6 end, 7-12 aux, 13 cmd, 14 tcp, 15 ucs, 16 vel, 17 acc,
    // 18 radius, 19 type, 20 isJoint, 21 seek, 22 bit, 23 state, 24-29 joints.
    const FROM_SDK: [usize; 30] = [
        0, 1, 2, 3, 4, 5, 6, 24, 25, 26, 27, 28, 29, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 7, 8,
        9, 10, 11, 12, 13,
    ];
    raw.len() == 30 && collect(raw, out) && !is_number(field(out, 15)) && permute(out, &FROM_SDK)
}

fn move_j<'a>(raw: &RawMessage<'a>, out: &mut Scratch<'a>) -> bool {
    // Examples: ..., 17 radius, 18 move type, 19 isUseJoint, ... 23 cmd.
    const DROP_MOVE_TYPE: [usize; 23] = [
        0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 19, 20, 21, 22, 23,
    ];
    raw.len() == 24 && collect(raw, out) && permute(out, &DROP_MOVE_TYPE)
}

/// The reply's fields after the request's one parameter (`channels`).
#[cfg(feature = "v6")]
const AO_VALUES: Param = Param(1);
#[cfg(feature = "v6")]
const AO_MODES: Param = Param(2);

#[cfg(feature = "v6")]
impl<'a> Message<'a> for response::ReadBoxAO {
    fn blank() -> Self {
        response::ReadBoxAO {
            values: heapless::Vec::new(),
            modes: None,
        }
    }

    fn read_in(&mut self, c: &mut Cursor<'_, 'a>) {
        let got = c.remaining();
        let pairs = match c.expected_len() {
            Some(n) => n > 0 && u32::from(got) == 2 * u32::from(n),
            None => got == 4,
        };
        if !pairs {
            self.values.read_in(c, AO_VALUES);
            return;
        }
        if got > 4 {
            c.fail(AO_VALUES, Expected::AtMost(4), Got::Count(got));
            return;
        }
        let mut modes = heapless::Vec::new();
        while !c.at_end() {
            let mode = i32::read(c, AO_MODES);
            let value = Decimal::read(c, AO_VALUES);
            // At most two pairs: checked above.
            let _ = self.values.push(value);
            let _ = modes.push(mode);
        }
        self.modes = Some(modes);
    }

    fn write_fields(&self, w: &mut Writer<'_>) {
        if let Some(modes) = &self.modes {
            if modes.len() != self.values.len() {
                w.fail_list_too_long(AO_MODES);
            }
            for (m, v) in modes.iter().zip(&self.values) {
                m.write(w, AO_MODES);
                v.write(w, AO_VALUES);
            }
            return;
        }
        self.values.write(w, AO_VALUES);
    }
}
