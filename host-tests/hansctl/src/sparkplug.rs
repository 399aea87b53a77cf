//! Sparkplug B 3.0 as `hansctl fleet` reads it: topics and payloads.
//!
//! The contract is `gateway/SPARKPLUG.md`; the field numbers are those of
//! the specification's `org.eclipse.tahu.protobuf.Payload`, as in
//! `gateway/src/sparkplug/sparkplug_b.proto`. This is a reader written
//! apart from the gateway's encoder (prost derive structs here, femtopb
//! there), so the one checks the other.
//!
//! Topic: `spBv1.0/GROUP/TYPE/EDGE[/DEVICE]`, TYPE one of NBIRTH, NDEATH,
//! NDATA, NCMD (no DEVICE) or DBIRTH, DDEATH, DDATA, DCMD (with DEVICE).
//! A host application's `spBv1.0/STATE/HOST` is told apart.
//!
//! Payload fields read (the rest, metadata, properties, DataSet, Template,
//! extensions, are skipped by prost):
//!
//! | field | tag | wire type |
//! |---|---|---|
//! | Payload.timestamp | 1 | uint64 |
//! | Payload.metrics | 2 | repeated Metric |
//! | Payload.seq | 3 | uint64 |
//! | Metric.name | 1 | string |
//! | Metric.alias | 2 | uint64 |
//! | Metric.timestamp | 3 | uint64 |
//! | Metric.datatype | 4 | uint32 |
//! | Metric.is_null | 7 | bool |
//! | Metric.int_value / long_value / float_value / double_value / boolean_value / string_value / bytes_value | 10-16 | oneof |

use std::fmt;

/// The topic namespace of Sparkplug B.
pub(crate) const NAMESPACE: &str = "spBv1.0";

/// The eight message types of an edge node and its devices.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum MsgType {
    NBirth,
    NDeath,
    NData,
    NCmd,
    DBirth,
    DDeath,
    DData,
    DCmd,
}

impl MsgType {
    const ALL: [MsgType; 8] = [
        MsgType::NBirth,
        MsgType::NDeath,
        MsgType::NData,
        MsgType::NCmd,
        MsgType::DBirth,
        MsgType::DDeath,
        MsgType::DData,
        MsgType::DCmd,
    ];

    /// The name in the topic (`NBIRTH`).
    pub(crate) fn as_str(self) -> &'static str {
        match self {
            MsgType::NBirth => "NBIRTH",
            MsgType::NDeath => "NDEATH",
            MsgType::NData => "NDATA",
            MsgType::NCmd => "NCMD",
            MsgType::DBirth => "DBIRTH",
            MsgType::DDeath => "DDEATH",
            MsgType::DData => "DDATA",
            MsgType::DCmd => "DCMD",
        }
    }

    fn parse(s: &str) -> Option<MsgType> {
        MsgType::ALL.into_iter().find(|t| t.as_str() == s)
    }

    /// A device's message (its topic has a device id).
    pub(crate) fn is_device(self) -> bool {
        matches!(
            self,
            MsgType::DBirth | MsgType::DDeath | MsgType::DData | MsgType::DCmd
        )
    }

    /// A host's command to the node, not a message from it.
    pub(crate) fn is_command(self) -> bool {
        matches!(self, MsgType::NCmd | MsgType::DCmd)
    }
}

/// A node's or device's topic, borrowed from the topic string.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Topic<'a> {
    pub(crate) group: &'a str,
    pub(crate) kind: MsgType,
    pub(crate) node: &'a str,
    pub(crate) device: Option<&'a str>,
}

/// Why a topic is not a node's or device's.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum TopicError {
    /// Not under `spBv1.0/`.
    Namespace,
    /// `spBv1.0/STATE/HOST`: a host application's state, not a node's.
    HostState,
    /// The third level is not one of the eight types.
    UnknownType(String),
    /// Wrong number of levels for its type, or an empty id.
    Shape(MsgType),
}

impl fmt::Display for TopicError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TopicError::Namespace => write!(f, "not a {NAMESPACE} topic"),
            TopicError::HostState => f.write_str("a host application's STATE topic"),
            TopicError::UnknownType(t) => write!(f, "unknown message type {t:?}"),
            TopicError::Shape(t) if t.is_device() => write!(
                f,
                "a {} topic is {NAMESPACE}/GROUP/{}/EDGE/DEVICE",
                t.as_str(),
                t.as_str()
            ),
            TopicError::Shape(t) => write!(
                f,
                "a {} topic is {NAMESPACE}/GROUP/{}/EDGE",
                t.as_str(),
                t.as_str()
            ),
        }
    }
}

impl<'a> Topic<'a> {
    /// Reads `spBv1.0/GROUP/TYPE/EDGE[/DEVICE]`.
    pub(crate) fn parse(topic: &'a str) -> Result<Topic<'a>, TopicError> {
        let mut levels = topic.split('/');
        if levels.next() != Some(NAMESPACE) {
            return Err(TopicError::Namespace);
        }
        let rest: Vec<&str> = levels.collect();
        match rest.as_slice() {
            ["STATE", _host] => Err(TopicError::HostState),
            [group, kind, ids @ ..] => {
                let kind = MsgType::parse(kind)
                    .ok_or_else(|| TopicError::UnknownType((*kind).to_string()))?;
                let (node, device) = match (ids, kind.is_device()) {
                    ([node], false) => (*node, None),
                    ([node, device], true) if !device.is_empty() => (*node, Some(*device)),
                    _ => return Err(TopicError::Shape(kind)),
                };
                if group.is_empty() || node.is_empty() {
                    return Err(TopicError::Shape(kind));
                }
                Ok(Topic {
                    group,
                    kind,
                    node,
                    device,
                })
            }
            _ => Err(TopicError::UnknownType(String::new())),
        }
    }
}

/// `org.eclipse.tahu.protobuf.Payload`, the fields read.
#[derive(Clone, PartialEq, prost::Message)]
pub(crate) struct WirePayload {
    #[prost(uint64, optional, tag = "1")]
    pub(crate) timestamp: Option<u64>,
    #[prost(message, repeated, tag = "2")]
    pub(crate) metrics: Vec<WireMetric>,
    #[prost(uint64, optional, tag = "3")]
    pub(crate) seq: Option<u64>,
}

/// `Payload.Metric`, the fields read.
#[derive(Clone, PartialEq, prost::Message)]
pub(crate) struct WireMetric {
    #[prost(string, optional, tag = "1")]
    pub(crate) name: Option<String>,
    #[prost(uint64, optional, tag = "2")]
    pub(crate) alias: Option<u64>,
    #[prost(uint64, optional, tag = "3")]
    pub(crate) timestamp: Option<u64>,
    #[prost(uint32, optional, tag = "4")]
    pub(crate) datatype: Option<u32>,
    #[prost(bool, optional, tag = "7")]
    pub(crate) is_null: Option<bool>,
    #[prost(oneof = "WireValue", tags = "10, 11, 12, 13, 14, 15, 16")]
    pub(crate) value: Option<WireValue>,
}

/// `Metric.value`, the basic types.
#[derive(Clone, PartialEq, prost::Oneof)]
pub(crate) enum WireValue {
    #[prost(uint32, tag = "10")]
    Int(u32),
    #[prost(uint64, tag = "11")]
    Long(u64),
    #[prost(float, tag = "12")]
    Float(f32),
    #[prost(double, tag = "13")]
    Double(f64),
    #[prost(bool, tag = "14")]
    Boolean(bool),
    #[prost(string, tag = "15")]
    String(String),
    #[prost(bytes = "vec", tag = "16")]
    Bytes(Vec<u8>),
}

/// `Metric.datatype` values that change how a value is read.
pub(crate) mod datatype {
    pub(crate) const INT8: u32 = 1;
    pub(crate) const INT16: u32 = 2;
    pub(crate) const INT32: u32 = 3;
    pub(crate) const INT64: u32 = 4;
}

/// A metric's value, typed.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Value {
    /// `is_null`, or no value at all.
    Null,
    Bool(bool),
    /// Int8/16/32 (two's complement in `int_value`) and Int64.
    Int(i64),
    /// UInt8/16/32 (`int_value`), UInt64 and DateTime (`long_value`).
    UInt(u64),
    Float(f32),
    Double(f64),
    Str(String),
    Bytes(Vec<u8>),
}

impl Value {
    /// Reads a metric's value: signed types from their two's complement,
    /// anything else as it travels. A value that does not fit its datatype
    /// (a string for an Int32) is kept as it travels: hansctl shows what
    /// was sent.
    fn read(datatype: Option<u32>, is_null: bool, wire: Option<&WireValue>) -> Value {
        if is_null {
            return Value::Null;
        }
        match wire {
            None => Value::Null,
            Some(WireValue::Int(v)) => match datatype {
                // Two's complement of the width, whether sent sign-extended
                // to 32 bits or not.
                Some(datatype::INT8) => Value::Int(i64::from(*v as u8 as i8)),
                Some(datatype::INT16) => Value::Int(i64::from(*v as u16 as i16)),
                Some(datatype::INT32) => Value::Int(i64::from(*v as i32)),
                _ => Value::UInt(u64::from(*v)),
            },
            Some(WireValue::Long(v)) => match datatype {
                Some(datatype::INT64) => Value::Int(*v as i64),
                _ => Value::UInt(*v),
            },
            Some(WireValue::Float(v)) => Value::Float(*v),
            Some(WireValue::Double(v)) => Value::Double(*v),
            Some(WireValue::Boolean(v)) => Value::Bool(*v),
            Some(WireValue::String(v)) => Value::Str(v.clone()),
            Some(WireValue::Bytes(v)) => Value::Bytes(v.clone()),
        }
    }

    /// The value as an unsigned integer, if it is a non-negative integer.
    pub(crate) fn as_u64(&self) -> Option<u64> {
        match self {
            Value::UInt(v) => Some(*v),
            Value::Int(v) => u64::try_from(*v).ok(),
            _ => None,
        }
    }

    /// The value as a signed integer, if it is an integer that fits.
    pub(crate) fn as_i64(&self) -> Option<i64> {
        match self {
            Value::UInt(v) => i64::try_from(*v).ok(),
            Value::Int(v) => Some(*v),
            _ => None,
        }
    }

    /// The text of a String metric.
    pub(crate) fn as_str(&self) -> Option<&str> {
        match self {
            Value::Str(s) => Some(s),
            _ => None,
        }
    }
}

/// Short text for a table cell (`-` for null).
impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Null => f.write_str("-"),
            Value::Bool(v) => write!(f, "{v}"),
            Value::Int(v) => write!(f, "{v}"),
            Value::UInt(v) => write!(f, "{v}"),
            Value::Float(v) => write!(f, "{v}"),
            Value::Double(v) => write!(f, "{v}"),
            Value::Str(v) => f.write_str(v),
            Value::Bytes(v) => {
                for b in v {
                    write!(f, "{b:02x}")?;
                }
                Ok(())
            }
        }
    }
}

/// Who a metric is: its name, or only its alias (a birth gives both, data
/// messages may then use the alias alone).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum MetricId {
    Name(String),
    Alias(u64),
    /// Neither: the metric cannot be told apart from others.
    Anonymous,
}

/// One metric, decoded.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Metric {
    pub(crate) id: MetricId,
    /// The alias a birth gives it (with its name).
    pub(crate) alias: Option<u64>,
    pub(crate) timestamp: Option<u64>,
    pub(crate) value: Value,
}

/// A payload, decoded.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Payload {
    pub(crate) timestamp: Option<u64>,
    pub(crate) seq: Option<u64>,
    pub(crate) metrics: Vec<Metric>,
}

/// Why a payload could not be read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct DecodeError(String);

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "not a Sparkplug B payload: {}", self.0)
    }
}

impl Payload {
    /// Decodes a payload; never panics on input.
    pub(crate) fn decode(bytes: &[u8]) -> Result<Payload, DecodeError> {
        let wire = <WirePayload as prost::Message>::decode(bytes)
            .map_err(|e| DecodeError(e.to_string()))?;
        let metrics = wire
            .metrics
            .iter()
            .map(|m| Metric {
                id: match (&m.name, m.alias) {
                    (Some(n), _) => MetricId::Name(n.clone()),
                    (None, Some(a)) => MetricId::Alias(a),
                    (None, None) => MetricId::Anonymous,
                },
                alias: m.alias,
                timestamp: m.timestamp,
                value: Value::read(m.datatype, m.is_null.unwrap_or(false), m.value.as_ref()),
            })
            .collect();
        Ok(Payload {
            timestamp: wire.timestamp,
            seq: wire.seq,
            metrics,
        })
    }

    /// The value of the metric named `name` (the last one, if several).
    pub(crate) fn get(&self, name: &str) -> Option<&Value> {
        self.metrics
            .iter()
            .rev()
            .find(|m| matches!(&m.id, MetricId::Name(n) if n == name))
            .map(|m| &m.value)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use prost::Message as _;

    /// A metric as the gateway writes one.
    pub(crate) fn metric(name: &str, datatype: u32, value: Option<WireValue>) -> WireMetric {
        WireMetric {
            name: Some(name.to_string()),
            alias: None,
            timestamp: Some(1_700_000_000_000),
            datatype: Some(datatype),
            is_null: value.is_none().then_some(true),
            value,
        }
    }

    pub(crate) fn encode(seq: Option<u64>, metrics: Vec<WireMetric>) -> Vec<u8> {
        WirePayload {
            timestamp: Some(1_700_000_000_000),
            metrics,
            seq,
        }
        .encode_to_vec()
    }

    #[test]
    fn topics_of_nodes_devices_and_hosts() {
        assert_eq!(
            Topic::parse("spBv1.0/Plant A/NBIRTH/cell-7"),
            Ok(Topic {
                group: "Plant A",
                kind: MsgType::NBirth,
                node: "cell-7",
                device: None
            })
        );
        assert_eq!(
            Topic::parse("spBv1.0/G/DDATA/e/robot"),
            Ok(Topic {
                group: "G",
                kind: MsgType::DData,
                node: "e",
                device: Some("robot")
            })
        );
        assert_eq!(
            Topic::parse("spBv1.0/STATE/scada"),
            Err(TopicError::HostState)
        );
        assert_eq!(
            Topic::parse("spAv1.0/G/NDATA/e"),
            Err(TopicError::Namespace)
        );
        assert_eq!(
            Topic::parse("spBv1.0/G/NOTE/e"),
            Err(TopicError::UnknownType("NOTE".into()))
        );
        // A node message with a device id, a device message without one,
        // empty ids.
        for bad in [
            "spBv1.0/G/NDATA/e/robot",
            "spBv1.0/G/DDATA/e",
            "spBv1.0/G/DBIRTH/e/",
            "spBv1.0//NDATA/e",
            "spBv1.0/G/NDATA/",
        ] {
            assert!(
                matches!(Topic::parse(bad), Err(TopicError::Shape(_))),
                "{bad}"
            );
        }
        assert!(Topic::parse("spBv1.0/G").is_err());
        assert_eq!(
            TopicError::Shape(MsgType::DDeath).to_string(),
            "a DDEATH topic is spBv1.0/GROUP/DDEATH/EDGE/DEVICE"
        );
    }

    #[test]
    fn values_are_read_by_their_datatype() {
        let bytes = encode(
            Some(7),
            vec![
                metric("bdSeq", 8, Some(WireValue::Long(u64::MAX))),
                metric("i8", datatype::INT8, Some(WireValue::Int(0xFF))),
                metric(
                    "i8 extended",
                    datatype::INT8,
                    Some(WireValue::Int(u32::MAX)),
                ),
                metric("i16", datatype::INT16, Some(WireValue::Int(0x8000))),
                metric(
                    "Error/Code",
                    datatype::INT32,
                    Some(WireValue::Int(-20018i32 as u32)),
                ),
                metric("i64", datatype::INT64, Some(WireValue::Long(-5i64 as u64))),
                metric("Error/Axis", 6, Some(WireValue::Int(65535))),
                metric("Override", 9, Some(WireValue::Float(0.5))),
                metric("d", 10, Some(WireValue::Double(-1.25))),
                metric("Flags/Moving", 11, Some(WireValue::Boolean(true))),
                metric("FSM/Name", 12, Some(WireValue::String("StandBy".into()))),
                metric("Error/Text", 12, None),
                metric("b", 17, Some(WireValue::Bytes(vec![0xab, 1]))),
            ],
        );
        let p = Payload::decode(&bytes).unwrap();
        assert_eq!((p.seq, p.timestamp), (Some(7), Some(1_700_000_000_000)));
        let v = |n| p.get(n).cloned().unwrap();
        assert_eq!(v("bdSeq"), Value::UInt(u64::MAX));
        assert_eq!(v("i8"), Value::Int(-1));
        assert_eq!(v("i8 extended"), Value::Int(-1));
        assert_eq!(v("i16"), Value::Int(-32768));
        assert_eq!(v("Error/Code"), Value::Int(-20018));
        assert_eq!(v("i64"), Value::Int(-5));
        assert_eq!(v("Error/Axis"), Value::UInt(65535));
        assert_eq!(v("Override"), Value::Float(0.5));
        assert_eq!(v("d"), Value::Double(-1.25));
        assert_eq!(v("Flags/Moving"), Value::Bool(true));
        assert_eq!(v("FSM/Name").as_str(), Some("StandBy"));
        assert_eq!(v("Error/Text"), Value::Null);
        assert_eq!(v("b").to_string(), "ab01");
        assert_eq!(p.get("absent"), None);
        assert_eq!(v("Error/Code").as_u64(), None);
        assert_eq!(v("bdSeq").as_i64(), None);
    }

    #[test]
    fn every_encoding_of_an_integer_reads_the_same() {
        // The gateway's (gateway/SPARKPLUG.md, "Integers"): bdSeq INT64 in
        // long_value, counts Int32 in int_value; and other nodes': bdSeq
        // UInt64 (the specification's example), UInt32 in int_value (its
        // table) or in long_value (Tahu's encoders).
        let bytes = encode(
            Some(0),
            vec![
                metric("gateway bdSeq", datatype::INT64, Some(WireValue::Long(7))),
                metric("old bdSeq", 8, Some(WireValue::Long(7))),
                metric("Int32", datatype::INT32, Some(WireValue::Int(2990))),
                metric("UInt32 table", 7, Some(WireValue::Int(2990))),
                metric("UInt32 tahu", 7, Some(WireValue::Long(2990))),
                metric("UInt32 top", 7, Some(WireValue::Long(u64::from(u32::MAX)))),
            ],
        );
        let p = Payload::decode(&bytes).unwrap();
        let n = |name| p.get(name).and_then(Value::as_u64);
        assert_eq!((n("gateway bdSeq"), n("old bdSeq")), (Some(7), Some(7)));
        for name in ["Int32", "UInt32 table", "UInt32 tahu"] {
            assert_eq!(n(name), Some(2990), "{name}");
        }
        assert_eq!(n("UInt32 top"), Some(u64::from(u32::MAX)));
    }

    #[test]
    fn is_null_wins_over_a_value_and_aliases_are_kept() {
        let mut m = metric("x", 3, Some(WireValue::Int(5)));
        m.is_null = Some(true);
        let aliased = WireMetric {
            name: None,
            alias: Some(12),
            ..metric("", 3, Some(WireValue::Int(1)))
        };
        let p = Payload::decode(&encode(None, vec![m, aliased, WireMetric::default()])).unwrap();
        assert_eq!(p.metrics[0].value, Value::Null);
        assert_eq!(p.metrics[1].id, MetricId::Alias(12));
        assert_eq!(p.metrics[2].id, MetricId::Anonymous);
        assert_eq!(p.metrics[2].value, Value::Null);
        assert_eq!(p.seq, None);
    }

    #[test]
    fn fields_it_does_not_read_are_skipped_and_garbage_is_an_error() {
        // A metric carrying properties (tag 9, length-delimited) and a
        // DataSet value (tag 17): skipped, the rest read.
        let mut m =
            metric("Gateway/Version", 12, Some(WireValue::String("1.2".into()))).encode_to_vec();
        // Tag 17 needs two bytes of varint: (17 << 3 | 2) = 0x8a 0x01.
        m.extend_from_slice(&[9 << 3 | 2, 2, 0x08, 0x01, 0x8a, 0x01, 0]);
        let mut bytes = vec![2 << 3 | 2, m.len() as u8];
        bytes.extend_from_slice(&m);
        bytes.extend_from_slice(&[3 << 3, 42]);
        let p = Payload::decode(&bytes).unwrap();
        assert_eq!(
            p.get("Gateway/Version").and_then(Value::as_str),
            Some("1.2")
        );
        assert_eq!(p.seq, Some(42));

        for garbage in [
            &b"\xff\xff\xff"[..],
            b"{\"json\": true}",
            &[2 << 3 | 2, 50, 1],
        ] {
            let e = Payload::decode(garbage).unwrap_err();
            assert!(
                e.to_string().starts_with("not a Sparkplug B payload"),
                "{e}"
            );
        }
        // The empty payload is a valid (empty) message.
        assert_eq!(Payload::decode(&[]).unwrap().metrics, vec![]);
    }
}
