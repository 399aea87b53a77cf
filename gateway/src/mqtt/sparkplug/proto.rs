//! The Sparkplug B payload's messages (`sparkplug_b.proto` beside this
//! file) as femtopb messages, for decoding NCMD/DCMD payloads zero-copy
//! from the received bytes. The gateway's own payloads are written by
//! `payload.rs` (which says why not with these).

use femtopb::item_encoding;
use femtopb::repeated::Repeated;
use femtopb::UnknownFields;

/// `Payload.Metric`.
#[derive(Clone, Debug, PartialEq, femtopb::Message)]
pub(crate) struct Metric<'a> {
    /// 1: the name.
    #[femtopb(string, optional, tag = 1)]
    pub name: Option<&'a str>,
    /// 2: the alias (a write by alias is refused).
    #[femtopb(uint64, optional, tag = 2)]
    pub alias: Option<u64>,
    /// 3: when the value was taken, ms since 1970 UTC.
    #[femtopb(uint64, optional, tag = 3)]
    pub timestamp: Option<u64>,
    /// 4: the datatype (`metrics::DataType`).
    #[femtopb(uint32, optional, tag = 4)]
    pub datatype: Option<u32>,
    /// 7: the value is null (then no value field).
    #[femtopb(bool, optional, tag = 7)]
    pub is_null: Option<bool>,
    /// 10-16: the value.
    #[femtopb(oneof, tags = [10, 11, 12, 13, 14, 15, 16])]
    pub value: Option<Value<'a>>,
    /// Fields the gateway does not read (5, 6, 8, 9, 17-19), skipped.
    #[femtopb(unknown_fields)]
    pub unknown_fields: UnknownFields<'a>,
}

/// `Payload.Metric.value`.
#[derive(Clone, Debug, PartialEq, femtopb::Oneof)]
pub(crate) enum Value<'a> {
    /// 10: Int8-32, UInt8-32.
    #[femtopb(uint32, tag = 10)]
    Int(u32),
    /// 11: Int64, UInt64, DateTime.
    #[femtopb(uint64, tag = 11)]
    Long(u64),
    /// 12: Float.
    #[femtopb(float, tag = 12)]
    Float(f32),
    /// 13: Double.
    #[femtopb(double, tag = 13)]
    Double(f64),
    /// 14: Boolean.
    #[femtopb(bool, tag = 14)]
    Boolean(bool),
    /// 15: String, Text.
    #[femtopb(string, tag = 15)]
    String(&'a str),
    /// 16: Bytes, File.
    #[femtopb(bytes, tag = 16)]
    Bytes(&'a [u8]),
}

/// `Payload`, as decoded (NCMD, DCMD).
#[derive(Clone, Debug, PartialEq, femtopb::Message)]
pub(crate) struct Payload<'a> {
    /// 1: when it was published.
    #[femtopb(uint64, optional, tag = 1)]
    pub timestamp: Option<u64>,
    /// 2: the metrics, decoded one by one while iterating.
    #[femtopb(message, repeated, tag = 2)]
    pub metrics: Repeated<'a, Metric<'a>, item_encoding::Message<'a, Metric<'a>>>,
    /// 3: the sequence number (absent in commands).
    #[femtopb(uint64, optional, tag = 3)]
    pub seq: Option<u64>,
    /// Fields not read (uuid, body, extensions), skipped.
    #[femtopb(unknown_fields)]
    pub unknown_fields: UnknownFields<'a>,
}

/// Field numbers of `Payload` the writer uses.
pub(crate) mod field {
    /// `Payload.timestamp`.
    pub const TIMESTAMP: u32 = 1;
    /// `Payload.metrics`.
    pub const METRICS: u32 = 2;
    /// `Payload.seq`.
    pub const SEQ: u32 = 3;
}
