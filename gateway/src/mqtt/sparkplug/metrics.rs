//! The metric table: every metric the edge node publishes, with its name,
//! Sparkplug datatype, unit, where it is born (NBIRTH or DBIRTH) and when
//! it is published after the birth. The births, the data messages and
//! `gateway/SPARKPLUG.md` (checked by a test) all come from [`TABLE`].
//!
//! A row is one metric, or one metric per command source ([`Family`]): the
//! row `Phase` of family `PerSource` is `Channel 0/Phase`, `Channel 1/Phase`,
//! `RAW/Phase`, `Trigger 0/Phase` ... `Trigger 15/Phase`.
//!
//! Values are read from the typed state ([`Model`]), never from the register
//! map. Something the gateway does not know (no robot state yet, no error)
//! is published as a null metric (`is_null`) of the row's datatype.

use core::fmt::Write as _;

use embassy_time::Instant;
use hans_codec::{ErrorCode, FsmState, ProtocolLevel};

use crate::error::Outcome;
use crate::job::{Source, CHANNELS, TRIGGERS};
use crate::state::history::CommandEntry;
use crate::state::{Io, LinkState, Model, RobotFlags};

/// A Sparkplug B basic datatype (the specification's `DataType` enum; only
/// the basic types, 1-14), with the value field each travels in
/// ([`DataType::field`]).
///
/// The gateway's metrics use only the integer types whose field the
/// specification's table and Eclipse Tahu's Java and JavaScript decoders
/// agree on: Int8/16/32, UInt8/16 in `int_value`, Int64/UInt64 in
/// `long_value`. `UInt32` is the one they do not agree on (the table:
/// `int_value`; Tahu's JavaScript decoder: `long_value` only; Tahu's Java:
/// either), so no metric has it (gateway/SPARKPLUG.md, "Integers").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DataType {
    /// Signed 8-bit integer (`int_value`).
    Int8 = 1,
    /// Signed 16-bit integer (`int_value`).
    Int16 = 2,
    /// Signed 32-bit integer (`int_value`, two's complement).
    Int32 = 3,
    /// Signed 64-bit integer (`long_value`).
    Int64 = 4,
    /// Unsigned 8-bit integer (`int_value`).
    UInt8 = 5,
    /// Unsigned 16-bit integer (`int_value`).
    UInt16 = 6,
    /// Unsigned 32-bit integer (`int_value` in the specification's table;
    /// read from `long_value` only by Tahu's JavaScript decoder: not used).
    UInt32 = 7,
    /// Unsigned 64-bit integer (`long_value`).
    UInt64 = 8,
    /// 32-bit float (`float_value`).
    Float = 9,
    /// 64-bit float (`double_value`).
    Double = 10,
    /// Boolean (`boolean_value`).
    Boolean = 11,
    /// UTF-8 string (`string_value`).
    String = 12,
    /// Milliseconds since 1970 UTC (`long_value`).
    DateTime = 13,
    /// UTF-8 text (`string_value`).
    Text = 14,
}

impl DataType {
    /// The number on the wire (`Metric.datatype`).
    pub const fn code(self) -> u32 {
        self as u32
    }

    /// The specification's name.
    pub const fn name(self) -> &'static str {
        match self {
            DataType::Int8 => "Int8",
            DataType::Int16 => "Int16",
            DataType::Int32 => "Int32",
            DataType::Int64 => "Int64",
            DataType::UInt8 => "UInt8",
            DataType::UInt16 => "UInt16",
            DataType::UInt32 => "UInt32",
            DataType::UInt64 => "UInt64",
            DataType::Float => "Float",
            DataType::Double => "Double",
            DataType::Boolean => "Boolean",
            DataType::String => "String",
            DataType::DateTime => "DateTime",
            DataType::Text => "Text",
        }
    }

    /// The value field of `Payload.Metric` a value of this type travels in:
    /// the specification's datatype table.
    pub const fn field(self) -> ValueField {
        match self {
            DataType::Int8
            | DataType::Int16
            | DataType::Int32
            | DataType::UInt8
            | DataType::UInt16
            | DataType::UInt32 => ValueField::Int,
            DataType::Int64 | DataType::UInt64 | DataType::DateTime => ValueField::Long,
            DataType::Float => ValueField::Float,
            DataType::Double => ValueField::Double,
            DataType::Boolean => ValueField::Boolean,
            DataType::String | DataType::Text => ValueField::String,
        }
    }
}

/// The value fields of `Payload.Metric` the basic types use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ValueField {
    /// `int_value` (10, uint32): Int8/16/32 as their two's complement,
    /// UInt8/16/32.
    Int,
    /// `long_value` (11, uint64): Int64 as its two's complement, UInt64,
    /// DateTime.
    Long,
    /// `float_value` (12).
    Float,
    /// `double_value` (13).
    Double,
    /// `boolean_value` (14).
    Boolean,
    /// `string_value` (15).
    String,
}

/// `bdSeq`'s datatype, in the NBIRTH and the NDEATH alike.
pub const BD_SEQ: DataType = DataType::Int64;

/// Which birth declares a metric, and so which data message updates it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scope {
    /// The edge node (the gateway): NBIRTH, NDATA. Published while the
    /// robot link is down too.
    Node,
    /// The device `robot` (the controller): DBIRTH, DDATA, only while the
    /// robot link is up.
    Device,
}

/// One metric, or one per command source.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// One metric, named as the row.
    One,
    /// One metric per source, the row's name under the source's folder:
    /// `Channel 0/`, `Channel 1/`, `RAW/`, `Trigger 0/` ... `Trigger 15/`.
    PerSource,
}

/// When a metric is published after its birth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Report {
    /// In the births only (it never changes within a session).
    Birth,
    /// When its value changes (null to a value and back included).
    Change,
    /// When it moved by at least the joints' deadband since last
    /// published ([`super::NodeConfig::joint_deadband`]).
    JointBand,
    /// When it moved by at least the pose's deadband
    /// ([`super::NodeConfig::pose_deadband`]).
    PoseBand,
    /// When it moved by at least this much.
    Band(f32),
    /// Once per finished command, with the command's end as its timestamp
    /// (several in one message if several finished in one period).
    Event,
}

/// What a row reads from the state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Field {
    BdSeq,
    Rebirth,
    Version,
    MapVersion,
    Uptime,
    LinkState,
    LinkConnects,
    LinkLosses,
    LinkErrorCode,
    LinkError,
    Protocol,
    WatchdogArmed,
    WatchdogTripped,
    WatchdogTrips,
    ModbusSessions,
    ModbusRefused,
    ModbusWritesRefused,
    WebRefused,
    MqttRefused,
    QueueUsed,
    ActiveMotion,
    Cmd(Cmd),
    Phase,
    LastOutcome,
    LastErrorId,
    FsmCode,
    FsmName,
    Flag(Flag),
    ErrorCode,
    ErrorAxis,
    ErrorText,
    Override,
    Joint(u8),
    Pose(u8),
    Io(Io),
}

/// A field of a command event.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Cmd {
    Source,
    Code,
    Text,
    Result,
    ErrorId,
    ErrorSource,
    Duration,
}

/// A robot flag.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Flag {
    Moving,
    Enabled,
    Error,
    Paused,
    EmergencyStop,
    SafetyGuard,
    Powered,
    BoxConnected,
    BlendingDone,
    InPosition,
    BrakeReleased,
}

impl Flag {
    fn of(self, f: &RobotFlags) -> bool {
        match self {
            Flag::Moving => f.moving,
            Flag::Enabled => f.enabled,
            Flag::Error => f.error,
            Flag::Paused => f.paused,
            Flag::EmergencyStop => f.emergency_stop,
            Flag::SafetyGuard => f.safety_guard,
            Flag::Powered => f.powered,
            Flag::BoxConnected => f.box_connected,
            Flag::BlendingDone => f.blending_done,
            Flag::InPosition => f.in_position,
            Flag::BrakeReleased => f.brake_released,
        }
    }
}

/// A row of the table.
#[derive(Clone, Copy, Debug)]
pub struct Def {
    /// The metric's name (under the source's folder for `PerSource`).
    pub name: &'static str,
    /// Its datatype.
    pub datatype: DataType,
    /// Its unit (empty: none).
    pub unit: &'static str,
    /// NBIRTH/NDATA or DBIRTH/DDATA.
    pub scope: Scope,
    /// One metric or one per source.
    pub family: Family,
    /// When it is published after the birth.
    pub report: Report,
    /// What it means, for the document.
    pub doc: &'static str,
    pub(crate) field: Field,
}

const fn def(
    name: &'static str,
    datatype: DataType,
    unit: &'static str,
    scope: Scope,
    report: Report,
    field: Field,
    doc: &'static str,
) -> Def {
    Def {
        name,
        datatype,
        unit,
        scope,
        family: Family::One,
        report,
        doc,
        field,
    }
}

const fn per_source(
    name: &'static str,
    datatype: DataType,
    field: Field,
    doc: &'static str,
) -> Def {
    Def {
        name,
        datatype,
        unit: "",
        scope: Scope::Node,
        family: Family::PerSource,
        report: Report::Change,
        doc,
        field,
    }
}

use DataType as T;
use Report as R;
use Scope::{Device as D, Node as N};

/// Every metric, in the order of the births.
#[rustfmt::skip]
pub const TABLE: &[Def] = &[
    // Int64: the datatype the specification's normative rules give bdSeq
    // (its example shows UInt64; the TCK checks INT64).
    def("bdSeq", BD_SEQ, "", N, R::Birth, Field::BdSeq, "birth/death sequence of this MQTT session (0-255), as in the NDEATH"),
    def("Node Control/Rebirth", T::Boolean, "", N, R::Birth, Field::Rebirth, "always false; an NCMD writing true asks for new births"),
    // On change: a board reads its image's version from the update slots
    // just after the start, possibly after the first birth.
    def("Gateway/Version", T::String, "", N, R::Change, Field::Version, "the software's version: the running firmware image's on a board with updates, the program's (its package's) on Linux"),
    def("Gateway/Map Version", T::String, "", N, R::Birth, Field::MapVersion, "the Modbus register map's version (major.minor)"),
    // Every 10 s: also what tells a host that subscribed after the births
    // that the node is there (it then asks for a rebirth).
    def("Gateway/Uptime", T::Int32, "s", N, R::Band(10.0), Field::Uptime, "time since start (held at 2147483647)"),
    def("Link/State", T::String, "", N, R::Change, Field::LinkState, "robot link: down, connecting, listening, connected"),
    def("Link/Connects", T::UInt16, "", N, R::Change, Field::LinkConnects, "connections established since start (wraps)"),
    def("Link/Losses", T::UInt16, "", N, R::Change, Field::LinkLosses, "connected links lost since start (wraps)"),
    def("Link/Last Error Code", T::Int32, "", N, R::Change, Field::LinkErrorCode, "gateway error code of the last link failure (null: none)"),
    def("Link/Last Error", T::String, "", N, R::Change, Field::LinkError, "its text (null: none)"),
    def("Link/Protocol", T::String, "", N, R::Change, Field::Protocol, "controller protocol level in use, `V5` or `HRa.b.c` (null: not known)"),
    def("Watchdog/Armed", T::Boolean, "", N, R::Change, Field::WatchdogArmed, "the PLC heartbeat watchdog watches a running motion"),
    def("Watchdog/Tripped", T::Boolean, "", N, R::Change, Field::WatchdogTripped, "the watchdog tripped (latched until the heartbeat changes)"),
    def("Watchdog/Trips", T::UInt16, "", N, R::Change, Field::WatchdogTrips, "trips since start (wraps)"),
    def("Modbus/Sessions", T::UInt16, "", N, R::Change, Field::ModbusSessions, "Modbus clients connected"),
    def("Modbus/Refused", T::UInt16, "", N, R::Change, Field::ModbusRefused, "Modbus connections refused by the allow-list (wraps)"),
    def("Modbus/Writes Refused", T::UInt16, "", N, R::Change, Field::ModbusWritesRefused, "Modbus writes refused by write protection (wraps)"),
    def("Web/Refused", T::UInt16, "", N, R::Change, Field::WebRefused, "web connections refused by the allow-list (wraps)"),
    def("MQTT/Writes Refused", T::Int32, "", N, R::Change, Field::MqttRefused, "NCMD/DCMD metric writes refused: MQTT never moves the robot (held at 2147483647)"),
    def("Queue/Used", T::UInt16, "", N, R::Change, Field::QueueUsed, "commands waiting in the queue"),
    def("Queue/Active Motion", T::String, "", N, R::Change, Field::ActiveMotion, "whose motion runs: `Channel 0`, `RAW`, `Trigger 3` (null: none)"),
    def("Last Command/Source", T::String, "", N, R::Event, Field::Cmd(Cmd::Source), "who fired it: `Channel 0`, `RAW`, `Trigger 3`"),
    def("Last Command/Code", T::UInt16, "", N, R::Event, Field::Cmd(Cmd::Code), "the channel's command code (0 for RAW and triggers)"),
    def("Last Command/Text", T::String, "", N, R::Event, Field::Cmd(Cmd::Text), "the last request sent to the robot, cut at 64 bytes (empty: none sent)"),
    def("Last Command/Result", T::String, "", N, R::Event, Field::Cmd(Cmd::Result), "done, error or aborted"),
    def("Last Command/Error Id", T::Int32, "", N, R::Event, Field::Cmd(Cmd::ErrorId), "ErrorID (0 unless error)"),
    def("Last Command/Error Source", T::UInt8, "", N, R::Event, Field::Cmd(Cmd::ErrorSource), "1 robot refused, 2 robot motion error, 3 gateway (0 unless error)"),
    def("Last Command/Duration", T::Int32, "ms", N, R::Event, Field::Cmd(Cmd::Duration), "from the rising edge to the outcome (held at 2147483647)"),
    per_source("Phase", T::String, Field::Phase, "idle, queued, running, moving, done, error, aborted"),
    per_source("Last Outcome", T::String, Field::LastOutcome, "outcome of its last finished command: done, error, aborted (null: none yet)"),
    per_source("Last Error Id", T::Int32, Field::LastErrorId, "ErrorID of its last finished command (0 unless error)"),
    def("FSM/Code", T::Int32, "", D, R::Change, Field::FsmCode, "controller state machine code (null: unknown)"),
    def("FSM/Name", T::String, "", D, R::Change, Field::FsmName, "its name (null: unknown or unnamed)"),
    def("Flags/Moving", T::Boolean, "", D, R::Change, Field::Flag(Flag::Moving), "robot flag (null: no robot state yet)"),
    def("Flags/Enabled", T::Boolean, "", D, R::Change, Field::Flag(Flag::Enabled), "robot flag"),
    def("Flags/Error", T::Boolean, "", D, R::Change, Field::Flag(Flag::Error), "robot flag"),
    def("Flags/Paused", T::Boolean, "", D, R::Change, Field::Flag(Flag::Paused), "robot flag"),
    def("Flags/Emergency Stop", T::Boolean, "", D, R::Change, Field::Flag(Flag::EmergencyStop), "robot flag"),
    def("Flags/Safety Guard", T::Boolean, "", D, R::Change, Field::Flag(Flag::SafetyGuard), "robot flag"),
    def("Flags/Powered", T::Boolean, "", D, R::Change, Field::Flag(Flag::Powered), "robot flag (48 V)"),
    def("Flags/Box Connected", T::Boolean, "", D, R::Change, Field::Flag(Flag::BoxConnected), "robot flag"),
    def("Flags/Blending Done", T::Boolean, "", D, R::Change, Field::Flag(Flag::BlendingDone), "robot flag"),
    def("Flags/In Position", T::Boolean, "", D, R::Change, Field::Flag(Flag::InPosition), "robot flag"),
    def("Flags/Brake Released", T::Boolean, "", D, R::Change, Field::Flag(Flag::BrakeReleased), "robot flag"),
    def("Error/Code", T::Int32, "", D, R::Change, Field::ErrorCode, "robot error code (0: none)"),
    def("Error/Axis", T::UInt16, "", D, R::Change, Field::ErrorAxis, "axis of the error (0: none)"),
    def("Error/Text", T::String, "", D, R::Change, Field::ErrorText, "the controller's text, else the protocol document's (null: no error or no text)"),
    def("Override", T::Float, "ratio", D, R::Band(0.001), Field::Override, "speed override (null: unknown)"),
    def("Joints/J1", T::Float, "deg", D, R::JointBand, Field::Joint(0), "actual joint angle (null: unknown)"),
    def("Joints/J2", T::Float, "deg", D, R::JointBand, Field::Joint(1), "actual joint angle"),
    def("Joints/J3", T::Float, "deg", D, R::JointBand, Field::Joint(2), "actual joint angle"),
    def("Joints/J4", T::Float, "deg", D, R::JointBand, Field::Joint(3), "actual joint angle"),
    def("Joints/J5", T::Float, "deg", D, R::JointBand, Field::Joint(4), "actual joint angle"),
    def("Joints/J6", T::Float, "deg", D, R::JointBand, Field::Joint(5), "actual joint angle"),
    def("Pose/X", T::Float, "mm", D, R::PoseBand, Field::Pose(0), "actual TCP pose in the user frame (null: unknown)"),
    def("Pose/Y", T::Float, "mm", D, R::PoseBand, Field::Pose(1), "actual TCP pose"),
    def("Pose/Z", T::Float, "mm", D, R::PoseBand, Field::Pose(2), "actual TCP pose"),
    def("Pose/Rx", T::Float, "deg", D, R::PoseBand, Field::Pose(3), "actual TCP pose"),
    def("Pose/Ry", T::Float, "deg", D, R::PoseBand, Field::Pose(4), "actual TCP pose"),
    def("Pose/Rz", T::Float, "deg", D, R::PoseBand, Field::Pose(5), "actual TCP pose"),
    def("IO/Box DI", T::UInt16, "bits", D, R::Change, Field::Io(Io::BoxDi), "box digital inputs DI0-DI7, bit n = DIn (null: unknown)"),
    def("IO/Box DO", T::UInt16, "bits", D, R::Change, Field::Io(Io::BoxDo), "box digital outputs DO0-DO7"),
    def("IO/Box CI", T::UInt16, "bits", D, R::Change, Field::Io(Io::BoxCi), "box configurable inputs CI0-CI7"),
    def("IO/Box CO", T::UInt16, "bits", D, R::Change, Field::Io(Io::BoxCo), "box configurable outputs CO0-CO7"),
    def("IO/Tool DI", T::UInt16, "bits", D, R::Change, Field::Io(Io::EndDi), "tool flange digital inputs 0-2"),
    def("IO/Tool DO", T::UInt16, "bits", D, R::Change, Field::Io(Io::EndDo), "tool flange digital outputs 0-2"),
];

/// Command sources: the channels, RAW, the trigger entries.
pub(crate) const SOURCES: usize = CHANNELS + 1 + TRIGGERS;

/// How many metrics a row stands for.
const fn instances(d: &Def) -> usize {
    match d.family {
        Family::One => 1,
        Family::PerSource => SOURCES,
    }
}

/// The number of metrics (rows expanded).
pub const COUNT: usize = {
    let mut n = 0;
    let mut i = 0;
    while i < TABLE.len() {
        // Indexing a const slice in a const block: checked at compile time.
        #[allow(clippy::indexing_slicing)]
        {
            n += instances(&TABLE[i]);
        }
        i += 1;
    }
    n
};

/// The source of index `i` in [`crate::job::Source::all`]'s order.
pub(crate) fn source_at(i: usize) -> Option<Source> {
    Source::all().nth(i)
}

/// A source's index in [`crate::job::Source::all`]'s order.
pub(crate) fn source_index(s: Source) -> usize {
    match s {
        Source::Channel(i) => usize::from(i),
        Source::Raw => CHANNELS,
        Source::Trigger(i) => CHANNELS + 1 + usize::from(i),
    }
}

/// Characters of a metric's full name, at most (`Trigger 15/Last Error Id`
/// is the longest; a test checks every name fits).
pub const NAME_MAX: usize = 48;

/// A metric's full name.
pub type Name = heapless::String<NAME_MAX>;

/// A source's folder: `Channel 0`, `RAW`, `Trigger 3`.
pub(crate) fn source_folder(s: Source) -> heapless::String<12> {
    let mut out = heapless::String::new();
    // Cannot fail: `Trigger 255` is 11 characters.
    let _ = match s {
        Source::Channel(i) => write!(out, "Channel {i}"),
        Source::Raw => out.push_str("RAW").map_err(|_| core::fmt::Error),
        Source::Trigger(i) => write!(out, "Trigger {i}"),
    };
    out
}

/// One metric: a row, and the source for a `PerSource` row.
#[derive(Clone, Copy, Debug)]
pub struct Metric {
    /// The row.
    pub def: &'static Def,
    /// The source (`PerSource` rows).
    pub source: Option<Source>,
}

impl Metric {
    /// Its full name (cut at [`NAME_MAX`], which no name reaches).
    pub fn name(&self) -> Name {
        let mut out = Name::new();
        if let Some(s) = self.source {
            let _ = out.push_str(&source_folder(s));
            let _ = out.push('/');
        }
        let _ = out.push_str(self.def.name);
        out
    }
}

/// Every metric, expanded, in table order: the index is its slot in the
/// node's record of what was last published.
pub fn all() -> impl Iterator<Item = Metric> {
    TABLE.iter().flat_map(|def| {
        let n = instances(def);
        (0..n).map(move |i| Metric {
            def,
            source: match def.family {
                Family::One => None,
                Family::PerSource => source_at(i),
            },
        })
    })
}

/// A metric's value, read from the state.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Val<'a> {
    /// Not known.
    Null,
    Bool(bool),
    /// Int8/16/32.
    I32(i32),
    /// UInt8/16.
    U32(u32),
    /// Int64.
    I64(i64),
    F32(f32),
    Str(&'a str),
    /// A string written on the spot (a protocol level, an image's
    /// version: `65535.65535.65535` is the longest, 17 bytes).
    Small(heapless::String<20>),
}

impl Val<'_> {
    /// A fingerprint to tell a change: the bits of numbers, a hash of
    /// strings (FNV-1a, 64 bits), a marker for null.
    pub(crate) fn fingerprint(&self) -> Option<u64> {
        match self {
            Val::Null => None,
            Val::Bool(b) => Some(u64::from(*b)),
            Val::I32(v) => Some(u64::from(*v as u32)),
            Val::U32(v) => Some(u64::from(*v)),
            Val::I64(v) => Some(*v as u64),
            Val::F32(v) => Some(u64::from(v.to_bits())),
            Val::Str(s) => Some(fnv(s.as_bytes())),
            Val::Small(s) => Some(fnv(s.as_bytes())),
        }
    }

    /// As a number, for deadbands.
    pub(crate) fn number(&self) -> Option<f64> {
        match self {
            Val::I32(v) => Some(f64::from(*v)),
            Val::U32(v) => Some(f64::from(*v)),
            Val::I64(v) => Some(*v as f64),
            Val::F32(v) => Some(f64::from(*v)),
            _ => None,
        }
    }
}

fn fnv(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(*b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// The valid UTF-8 start of `bytes` (texts from the robot are ASCII; a
/// stray byte cuts the text there rather than failing the payload).
pub(crate) fn utf8(bytes: &[u8]) -> &str {
    match core::str::from_utf8(bytes) {
        Ok(s) => s,
        Err(e) => bytes
            .get(..e.valid_up_to())
            .and_then(|b| core::str::from_utf8(b).ok())
            .unwrap_or(""),
    }
}

/// What the values are read from besides the state.
pub(crate) struct Ctx<'a> {
    pub m: &'a Model,
    pub now: Instant,
    pub bd_seq: u8,
    pub mqtt_refused: u32,
    /// The software's version where no firmware image names one
    /// ([`super::NodeConfig::version`]).
    pub version: &'a str,
    /// Each source's last finished outcome, as the node saw it.
    pub outcomes: &'a [Option<Outcome>; SOURCES],
    /// The command event being published (or the last one, in a birth).
    pub event: Option<&'a CommandEntry>,
}

fn error_id(o: Outcome) -> i32 {
    match o {
        Outcome::Error(_, id) => id,
        _ => 0,
    }
}

fn level(l: ProtocolLevel) -> heapless::String<20> {
    let mut out = heapless::String::new();
    if l == ProtocolLevel::V5 {
        let _ = out.push_str("V5");
    } else {
        let (a, b, c) = l.parts();
        // Cannot fail: `HR255.255.255` is 13 characters.
        let _ = write!(out, "HR{a}.{b}.{c}");
    }
    out
}

fn six(v: Option<[f32; 6]>, i: u8) -> Val<'static> {
    v.and_then(|a| a.get(usize::from(i)).copied())
        .map_or(Val::Null, Val::F32)
}

fn robot_error_text(m: &Model) -> Option<&str> {
    let code = m.robot.error_code;
    if code == 0 {
        return None;
    }
    let fetched = &m.error_text;
    if fetched.code == code && !fetched.text.is_empty() {
        return Some(utf8(fetched.text.bytes()));
    }
    let c = ErrorCode::from(code);
    c.text().or(c.name())
}

/// Reads metric `metric` from `ctx`.
pub(crate) fn read<'a>(metric: &Metric, ctx: &Ctx<'a>) -> Val<'a> {
    let m = ctx.m;
    let r = &m.robot;
    let source = metric.source.unwrap_or(Source::Raw);
    let handshake = m.handshake(source).copied().unwrap_or_default();
    let last = ctx.outcomes.get(source_index(source)).copied().flatten();
    match metric.def.field {
        Field::BdSeq => Val::I64(ctx.bd_seq.into()),
        Field::Rebirth => Val::Bool(false),
        Field::Version => match m.firmware.running {
            Some(v) => {
                let mut s = heapless::String::new();
                // 16 characters hold every version up to 9999.9999.99999;
                // a longer one is cut there (still published).
                let _ = write!(s, "{v}");
                Val::Small(s)
            }
            None => Val::Str(ctx.version),
        },
        Field::MapVersion => {
            let [major, minor] = crate::registers::map::MAP_VERSION.to_be_bytes();
            let mut s = heapless::String::new();
            let _ = write!(s, "{major}.{minor}");
            Val::Small(s)
        }
        Field::Uptime => Val::I32(i32::try_from(ctx.now.as_secs()).unwrap_or(i32::MAX)),
        Field::LinkState => Val::Str(m.link.state.as_str()),
        Field::LinkConnects => Val::U32(m.link.connects.into()),
        Field::LinkLosses => Val::U32(m.link.losses.into()),
        Field::LinkErrorCode => m.link.last_error.map_or(Val::Null, |e| Val::I32(e.code())),
        Field::LinkError => m
            .link
            .last_error
            .map_or(Val::Null, |e| Val::Str(e.as_str())),
        Field::Protocol => m.link.level.map_or(Val::Null, |l| Val::Small(level(l))),
        Field::WatchdogArmed => Val::Bool(m.watchdog_armed()),
        Field::WatchdogTripped => Val::Bool(m.plc.watchdog_tripped),
        Field::WatchdogTrips => Val::U32(m.plc.watchdog_trips.into()),
        Field::ModbusSessions => Val::U32(m.sessions.into()),
        Field::ModbusRefused => Val::U32(m.access.modbus_refused.into()),
        Field::ModbusWritesRefused => Val::U32(m.access.writes_refused.into()),
        Field::WebRefused => Val::U32(m.access.web_refused.into()),
        Field::MqttRefused => Val::I32(i32::try_from(ctx.mqtt_refused).unwrap_or(i32::MAX)),
        Field::QueueUsed => Val::U32(u32::try_from(m.queue.len()).unwrap_or(u32::MAX)),
        Field::ActiveMotion => m.active_motion.map_or(Val::Null, |s| {
            let folder = source_folder(s);
            let mut out = heapless::String::new();
            let _ = out.push_str(&folder);
            Val::Small(out)
        }),
        Field::Cmd(f) => match ctx.event {
            None => Val::Null,
            Some(c) => {
                let o = c.outcome.unwrap_or(Outcome::Aborted);
                match f {
                    Cmd::Source => {
                        let mut out = heapless::String::new();
                        let _ = out.push_str(&source_folder(c.source));
                        Val::Small(out)
                    }
                    Cmd::Code => Val::U32(c.code.into()),
                    Cmd::Text => Val::Str(utf8(&c.sent)),
                    Cmd::Result => Val::Str(o.as_str()),
                    Cmd::ErrorId => Val::I32(error_id(o)),
                    Cmd::ErrorSource => Val::U32(match o {
                        Outcome::Error(s, _) => s as u32,
                        _ => 0,
                    }),
                    Cmd::Duration => Val::I32(i32::try_from(c.took_ms).unwrap_or(i32::MAX)),
                }
            }
        },
        Field::Phase => Val::Str(handshake.phase.as_str()),
        Field::LastOutcome => last.map_or(Val::Null, |o| Val::Str(o.as_str())),
        Field::LastErrorId => Val::I32(last.map_or(0, error_id)),
        Field::FsmCode => r.fsm.map_or(Val::Null, |s| Val::I32(i32::from(s))),
        Field::FsmName => r
            .fsm
            .and_then(|s| FsmState::name(&s))
            .map_or(Val::Null, Val::Str),
        Field::Flag(f) => r.flags.map_or(Val::Null, |flags| Val::Bool(f.of(&flags))),
        Field::ErrorCode => Val::I32(r.error_code),
        Field::ErrorAxis => Val::U32(r.error_axis.into()),
        Field::ErrorText => robot_error_text(m).map_or(Val::Null, Val::Str),
        Field::Override => r.override_ratio.map_or(Val::Null, Val::F32),
        Field::Joint(i) => six(r.joints, i),
        Field::Pose(i) => six(r.pose, i),
        Field::Io(g) => r.io(g).map_or(Val::Null, |v| Val::U32(v.into())),
    }
}

/// Whether the link is up, as the device's life follows it.
pub(crate) fn device_alive(m: &Model) -> bool {
    m.link.state == LinkState::Connected
}
