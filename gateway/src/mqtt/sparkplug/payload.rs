//! Writes a `Payload` into the caller's buffer, metric by metric, without
//! building the message first: the timestamp (field 1), each metric as a
//! length-delimited field 2, then `seq` (field 3). Room for `seq` is kept
//! from the start, so a payload that took its last metric can always be
//! finished.
//!
//! The metrics are encoded here, with femtopb's low-level writers, rather
//! than by its derived `Message::encode`: femtopb 0.9 leaves out an
//! `optional` or `oneof` field whose value equals the type's default (its
//! proto3 habit), and Sparkplug needs them present (`bdSeq` 0, a `false`
//! flag, a count of 0 would arrive as metrics without a value). The derived
//! structs (`proto.rs`) decode commands; a test decodes what this writes
//! with prost.
//!
//! A metric that does not fit is not written ([`Writer::push`] says so):
//! the caller decides to finish this payload and put the rest in the next.
//! Every length is measured before a byte is written, so femtopb's
//! writers (which panic on a short buffer) never meet one.

use femtopb::encoding::{encode_key, encode_varint, encoded_len_varint, key_len, WireType};

use super::metrics::{DataType, Val, ValueField};
use super::proto::field;

/// Bytes `seq` takes at most: its key and a varint up to 255.
const SEQ_RESERVE: usize = 3;

/// `Payload.Metric` field numbers the gateway writes.
mod metric_field {
    pub const NAME: u32 = 1;
    pub const TIMESTAMP: u32 = 3;
    pub const DATATYPE: u32 = 4;
    pub const IS_NULL: u32 = 7;
    pub const INT_VALUE: u32 = 10;
    pub const LONG_VALUE: u32 = 11;
    pub const FLOAT_VALUE: u32 = 12;
    pub const BOOLEAN_VALUE: u32 = 14;
    pub const STRING_VALUE: u32 = 15;
}

/// A metric's value on the wire.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Wire<'v> {
    /// `is_null` = true, no value.
    Null,
    /// `int_value`.
    Int(u32),
    /// `long_value`.
    Long(u64),
    /// `float_value`.
    Float(f32),
    /// `boolean_value`.
    Boolean(bool),
    /// `string_value`.
    String(&'v str),
}

/// A metric as the gateway writes it: name, timestamp, datatype always
/// (no aliases), then the value or `is_null`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Metric<'v> {
    name: &'v str,
    timestamp: u64,
    datatype: u32,
    value: Wire<'v>,
}

impl Metric<'_> {
    /// Bytes of the message body.
    fn body_len(&self) -> usize {
        use metric_field as f;
        let text = |tag, s: &str| key_len(tag) + encoded_len_varint(s.len() as u64) + s.len();
        let value = match self.value {
            Wire::Null => key_len(f::IS_NULL) + 1,
            Wire::Int(v) => key_len(f::INT_VALUE) + encoded_len_varint(v.into()),
            Wire::Long(v) => key_len(f::LONG_VALUE) + encoded_len_varint(v),
            Wire::Float(_) => key_len(f::FLOAT_VALUE) + 4,
            Wire::Boolean(_) => key_len(f::BOOLEAN_VALUE) + 1,
            Wire::String(s) => text(f::STRING_VALUE, s),
        };
        text(f::NAME, self.name)
            + key_len(f::TIMESTAMP)
            + encoded_len_varint(self.timestamp)
            + key_len(f::DATATYPE)
            + encoded_len_varint(self.datatype.into())
            + value
    }

    /// Writes the body; `cur` holds at least [`Metric::body_len`] bytes.
    fn encode_body(&self, cur: &mut &mut [u8]) {
        use metric_field as f;
        put_text(f::NAME, self.name, cur);
        encode_key(f::TIMESTAMP, WireType::Varint, cur);
        encode_varint(self.timestamp, cur);
        encode_key(f::DATATYPE, WireType::Varint, cur);
        encode_varint(self.datatype.into(), cur);
        match self.value {
            Wire::Null => {
                encode_key(f::IS_NULL, WireType::Varint, cur);
                encode_varint(1, cur);
            }
            Wire::Int(v) => {
                encode_key(f::INT_VALUE, WireType::Varint, cur);
                encode_varint(v.into(), cur);
            }
            Wire::Long(v) => {
                encode_key(f::LONG_VALUE, WireType::Varint, cur);
                encode_varint(v, cur);
            }
            Wire::Float(v) => {
                encode_key(f::FLOAT_VALUE, WireType::ThirtyTwoBit, cur);
                put(&v.to_le_bytes(), cur);
            }
            Wire::Boolean(b) => {
                encode_key(f::BOOLEAN_VALUE, WireType::Varint, cur);
                encode_varint(b.into(), cur);
            }
            Wire::String(s) => put_text(f::STRING_VALUE, s, cur),
        }
    }
}

/// Copies `bytes` to the cursor (nothing if they do not fit: measured
/// before, cannot happen).
fn put(bytes: &[u8], cur: &mut &mut [u8]) {
    let buf = core::mem::take(cur);
    if buf.len() < bytes.len() {
        *cur = buf;
        return;
    }
    let (head, rest) = buf.split_at_mut(bytes.len());
    head.copy_from_slice(bytes);
    *cur = rest;
}

/// A length-delimited string field.
fn put_text(tag: u32, s: &str, cur: &mut &mut [u8]) {
    encode_key(tag, WireType::LengthDelimited, cur);
    encode_varint(s.len() as u64, cur);
    put(s.as_bytes(), cur);
}

/// A payload being written.
pub(crate) struct Writer<'b> {
    buf: &'b mut [u8],
    len: usize,
    metrics: usize,
}

impl<'b> Writer<'b> {
    /// Starts a payload stamped `timestamp`; `None` if `buf` cannot hold
    /// even that and a `seq`.
    pub(crate) fn new(buf: &'b mut [u8], timestamp: u64) -> Option<Self> {
        let head = key_len(field::TIMESTAMP) + encoded_len_varint(timestamp);
        if head + SEQ_RESERVE > buf.len() {
            return None;
        }
        let mut w = Writer {
            buf,
            len: 0,
            metrics: 0,
        };
        w.write(|cur| {
            encode_key(field::TIMESTAMP, WireType::Varint, cur);
            encode_varint(timestamp, cur);
        });
        Some(w)
    }

    /// Bytes a metric takes in the payload (its key, length and body).
    pub(crate) fn len_of(m: &Metric<'_>) -> usize {
        let n = m.body_len();
        key_len(field::METRICS) + encoded_len_varint(n as u64) + n
    }

    /// Bytes still free for metrics.
    pub(crate) fn room(&self) -> usize {
        self.buf
            .len()
            .saturating_sub(self.len)
            .saturating_sub(SEQ_RESERVE)
    }

    /// Metrics written so far.
    pub(crate) fn metrics(&self) -> usize {
        self.metrics
    }

    /// Writes `m` if it fits; `false` (nothing written) if not.
    pub(crate) fn push(&mut self, m: &Metric<'_>) -> bool {
        if Self::len_of(m) > self.room() {
            return false;
        }
        let n = m.body_len();
        self.write(|cur| {
            encode_key(field::METRICS, WireType::LengthDelimited, cur);
            encode_varint(n as u64, cur);
            m.encode_body(cur);
        });
        self.metrics += 1;
        true
    }

    /// Ends the payload with `seq` (none for NDEATH): its bytes.
    pub(crate) fn finish(mut self, seq: Option<u8>) -> &'b [u8] {
        if let Some(seq) = seq {
            self.write(|cur| {
                encode_key(field::SEQ, WireType::Varint, cur);
                encode_varint(seq.into(), cur);
            });
        }
        let Writer { buf, len, .. } = self;
        buf.get(..len).unwrap_or(&[])
    }

    /// Runs `f` on the free part of the buffer and counts what it wrote.
    /// Callers have checked the room.
    fn write(&mut self, f: impl FnOnce(&mut &mut [u8])) {
        let Some(mut cur) = self.buf.get_mut(self.len..) else {
            return;
        };
        let before = cur.len();
        f(&mut cur);
        let written = before - cur.len();
        self.len += written;
    }
}

/// The metric for a value of datatype `datatype` taken at `ts`. The value
/// goes in the field the datatype's row of the specification's table names
/// ([`DataType::field`]), whatever its variant: an Int32 in `int_value` as
/// its two's complement, an Int64 in `long_value` as its two's complement.
/// A value that does not fit its datatype (a text for an Int32, a negative
/// number for a UInt16) is never in the table (a test reads every row);
/// should one be, it goes out as a null metric, never as a wrong number.
pub(crate) fn metric<'v>(name: &'v str, datatype: DataType, ts: u64, v: &'v Val<'_>) -> Metric<'v> {
    Metric {
        name,
        timestamp: ts,
        datatype: datatype.code(),
        value: wire(datatype, v),
    }
}

/// `v` in the value field of `datatype`.
pub(crate) fn wire<'v>(datatype: DataType, v: &'v Val<'_>) -> Wire<'v> {
    use DataType as T;
    let int = |x: i64| -> Option<Wire<'v>> {
        let ok = match datatype {
            T::Int8 => i8::try_from(x).is_ok(),
            T::Int16 => i16::try_from(x).is_ok(),
            T::Int32 => i32::try_from(x).is_ok(),
            T::UInt8 => u8::try_from(x).is_ok(),
            T::UInt16 => u16::try_from(x).is_ok(),
            T::UInt32 => u32::try_from(x).is_ok(),
            T::Int64 | T::DateTime => true,
            T::UInt64 => x >= 0,
            _ => false,
        };
        // Signed types are sign-extended to the field's width first (the
        // two's complement of an Int8 -1 in `int_value` is 0xFFFF_FFFF,
        // which every reader takes for -1).
        ok.then(|| match datatype.field() {
            ValueField::Int => Wire::Int(x as u32),
            _ => Wire::Long(x as u64),
        })
    };
    let value = match (v, datatype.field()) {
        (Val::Null, _) => None,
        (Val::Bool(b), ValueField::Boolean) => Some(Wire::Boolean(*b)),
        (Val::I32(x), ValueField::Int | ValueField::Long) => int(i64::from(*x)),
        (Val::U32(x), ValueField::Int | ValueField::Long) => int(i64::from(*x)),
        (Val::I64(x), ValueField::Int | ValueField::Long) => int(*x),
        (Val::F32(x), ValueField::Float) => Some(Wire::Float(*x)),
        (Val::Str(s), ValueField::String) => Some(Wire::String(s)),
        (Val::Small(s), ValueField::String) => Some(Wire::String(s.as_str())),
        _ => None,
    };
    value.unwrap_or(Wire::Null)
}
