//! The DataSheet payload (chapter 5.1): a typed model, its decoder and its
//! encoder.
//!
//! # Layout
//! The payload is one JSON object whose members are groups (objects) of
//! fields. Every field this crate models, in the order the encoder writes
//! it, with its Rust home and the form the vendor sends:
//!
//! | group | field | Rust | form |
//! |---|---|---|---|
//! | `PosAndVel` | `Actual_Position` | [`PosAndVel::position`] | 6 or 12 strings |
//! | | `Actual_PCS_TCP`, `Actual_PCS_Base`, `Actual_PCS_Tool` | `pcs_tcp`, `pcs_base`, `pcs_tool` | 6 strings |
//! | | `Actual_Joint_Current`, `_Velocity`, `_Acceleration` | `joint_current`, ... | 6 strings |
//! | | `Actual_Override` | `override_ratio` | string |
//! | `EndIO` | `EndDI`, `EndDO`, `EndButton` | `end_di`, `end_do`, `end_button` | integer lists |
//! | | `EnableEndBTN` | `enable_end_btn` | integer |
//! | | `EndAI` | `end_ai` | number list |
//! | `ElectricBoxIO` | `BoxCI`, `BoxCO`, `BoxDI`, `BoxDO` | `box_ci`, ... | integer lists |
//! | | `Conveyor` / `Encode` | `conveyor` / `encode` | string / integer |
//! | `ElectricBoxAnalogIO` | `BoxAnalogOutMode_1/2` | `out_mode` | integers |
//! | | `BoxAnalogOut_1/2`, `BoxAnalogIn_1/2` | `out`, `input` | strings |
//! | `StateAndError` | `robotState` | [`StateAndError::robot_state`] | integer |
//! | | `robotEnabled`, `robotPaused`, `robotMoving`, `robotBlendingDone`, `InPos` | flags | 0 / 1 |
//! | | `Error_AxisID`, `Error_Code` | `error_axis_id`, `error_code` | integers |
//! | | `BrakeState`, `nAxisStatus`, `nAxisErrorCode` | 6 integers each | lists |
//! | | `nResetSafeSpace`, `nAxisGroupStatus`, `nAxisGroupErrorCode` | per axis group | lists |
//! | `HardLoad` | `EtherCAT_TotalFrame`, `_FramesPerSecond`, `_TotalLostFrame`, `_TxErrorFrame`, `_RxErrorFrame` | counters | integers |
//! | | `Box48IN_Voltage`, `Box48IN_Current`, `Box48Out_Voltage`, `Box48Out_Current` | `box48_*` | numbers |
//! | | `Slave_temperature`, `Slave_Voltage` | per module | number lists |
//! | `FTData` | `FTControlState` / `FTData`, `FTSrcData` | [`FtData`] | integer / 6 numbers |
//! | `Script` | `errorCode` | [`Script::error_code`] | integer |
//!
//! # Reading
//! [`DataSheet::parse`] is lenient where controllers and documents differ,
//! strict where a value would be wrong:
//! * Field names match ignoring ASCII case, with a space equal to `_`
//!   (`"Actual Position"`, `"Box48OUT_Voltage"` and `"Box48Out_Voltage"` all
//!   match). Escapes in names are not decoded (a name spelt with `\u`
//!   escapes does not match and is skipped).
//! * Fields are found in any of the groups above and at the top level, so a
//!   payload that nests the groups differently still reads. Unknown members
//!   (`pluginsdata`, `cmdid`, `GlobalVar`, new fields) are skipped whatever
//!   their shape, and nothing inside an unknown object is read.
//! * A number may be a JSON number or a string holding one (`"0.000"`,
//!   `48.00`, `"33"`), in any form [`Decimal::parse`] reads; flags and
//!   integers also accept `true` / `false`. `null` or `""` leaves a field
//!   unset. NUL, `\n` and `\t` bytes are ignored anywhere (see
//!   [`json`](super::json)).
//! * A missing field stays `None` (lists: empty).
//! * A value of the wrong kind, an integer with decimals or out of its type's
//!   range, a flag other than 0/1, a list of the wrong length: a
//!   [`DataSheetError::Field`] naming the field, what was expected and the
//!   offset.
//!
//! Lists have a fixed capacity (the constants below, about twice what the
//! document shows); a longer list is a [`FieldExpected::AtMost`] error, not
//! a silent cut.
//!
//! Decoding a payload in the form controllers send (members in the order
//! above, no escapes, numbers in the plain form) takes a single pass that
//! reads each number as it finds it; anything else is read by the
//! [`json`](super::json) tokenizer, with the same results. (A 2 KiB payload
//! of the usual form: about 40k instructions, 2 µs on a PC.)
//!
//! # Writing
//! [`DataSheet::write_json`] writes compact JSON in the layout above: groups
//! in that order, names with underscores, each decimal in the form the
//! vendor uses for that field (string or number) with at least three
//! decimals (`"0.000"`, `48.000`; a value with more decimals keeps them all,
//! so nothing is ever rounded). Fields that are `None` are left out; lists
//! are always written. `parse(write_json(x)) == x` for every `DataSheet`
//! (given a large enough buffer, and `robot_state` values made by
//! `FsmState::from`: a hand-made `FsmState::Unknown(33)` reads back as
//! `StandBy`).

use core::fmt;

use heapless::Vec;

use super::deframer::is_stripped;
use super::header::{emit_header, HEADER_LEN, MAX_PAYLOAD};
use super::json::{significant, JsonError, Token, Writer};
use super::names::Names;
use super::read;
use crate::error::EncodeError;
use crate::fsm::FsmState;
use crate::number::Decimal;

/// Capacity of the tool-flange I/O lists (`EndDI`, `EndDO`, `EndButton`;
/// the document shows 4).
pub const MAX_END_IO: usize = 8;
/// Capacity of `EndAI` (the document shows 2).
pub const MAX_END_AI: usize = 4;
/// Capacity of the electric-box I/O lists (`BoxCI`, `BoxCO`, `BoxDI`,
/// `BoxDO`; the document shows 8 or 9).
pub const MAX_BOX_IO: usize = 16;
/// Capacity of the per-axis-group lists (`nResetSafeSpace`, ...; the
/// document shows 1).
pub const MAX_AXIS_GROUPS: usize = 4;
/// Capacity of the per-module lists (`Slave_temperature`, `Slave_Voltage`;
/// the document shows 3).
pub const MAX_SLAVES: usize = 8;

/// `Actual_Position`: six joint angles, then (on controllers that send 12
/// values) the TCP pose in the current user and tool frames.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Position {
    /// Joint angles J1-J6 (°).
    pub joints: [Decimal; 6],
    /// X, Y, Z (mm), Rx, Ry, Rz (°) in the current UCS/TCP, when sent.
    pub pose: Option<[Decimal; 6]>,
}

/// Group `PosAndVel`: positions, velocities, currents.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PosAndVel {
    /// `Actual_Position`: joints, and the pose in the current UCS/TCP.
    pub position: Option<Position>,
    /// `Actual_PCS_TCP`: pose in the current tool frame.
    pub pcs_tcp: Option<[Decimal; 6]>,
    /// `Actual_PCS_Base`: pose in the base frame.
    pub pcs_base: Option<[Decimal; 6]>,
    /// `Actual_PCS_Tool`: pose in the tool frame (no longer sent by newer
    /// controllers).
    pub pcs_tool: Option<[Decimal; 6]>,
    /// `Actual_Joint_Current` (A).
    pub joint_current: Option<[Decimal; 6]>,
    /// `Actual_Joint_Velocity` (°/s).
    pub joint_velocity: Option<[Decimal; 6]>,
    /// `Actual_Joint_Acceleration` (°/s²).
    pub joint_acceleration: Option<[Decimal; 6]>,
    /// `Actual_Override`: speed ratio, 0 to 1.
    pub override_ratio: Option<Decimal>,
}

/// Group `EndIO`: the tool flange's I/O.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EndIo {
    /// `EndDI`: digital inputs.
    pub end_di: Vec<i32, MAX_END_IO>,
    /// `EndDO`: digital outputs.
    pub end_do: Vec<i32, MAX_END_IO>,
    /// `EndButton`: the flange buttons.
    pub end_button: Vec<i32, MAX_END_IO>,
    /// `EnableEndBTN`: whether the flange buttons are enabled.
    pub enable_end_btn: Option<i32>,
    /// `EndAI`: analog inputs.
    pub end_ai: Vec<Decimal, MAX_END_AI>,
}

/// Group `ElectricBoxIO`: the control box's digital I/O.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BoxIo {
    /// `BoxCI`: configurable inputs.
    pub box_ci: Vec<i32, MAX_BOX_IO>,
    /// `BoxCO`: configurable outputs.
    pub box_co: Vec<i32, MAX_BOX_IO>,
    /// `BoxDI`: digital inputs.
    pub box_di: Vec<i32, MAX_BOX_IO>,
    /// `BoxDO`: digital outputs.
    pub box_do: Vec<i32, MAX_BOX_IO>,
    /// `Conveyor`: conveyor value.
    pub conveyor: Option<Decimal>,
    /// `Encode`: encoder value.
    pub encode: Option<i32>,
}

/// Group `ElectricBoxAnalogIO`: the control box's analog I/O. Index 0 is
/// the document's channel `_1`, index 1 channel `_2`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BoxAnalogIo {
    /// `BoxAnalogOutMode_1/2`: 0 channel off, 1 voltage, 2 current.
    pub out_mode: [Option<i32>; 2],
    /// `BoxAnalogOut_1/2`: output values.
    pub out: [Option<Decimal>; 2],
    /// `BoxAnalogIn_1/2`: input values.
    pub input: [Option<Decimal>; 2],
}

/// Group `StateAndError`: state machine, motion flags and errors.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StateAndError {
    /// `robotState`: the controller's state machine.
    pub robot_state: Option<FsmState>,
    /// `robotEnabled`.
    pub enabled: Option<bool>,
    /// `robotPaused`.
    pub paused: Option<bool>,
    /// `robotMoving`.
    pub moving: Option<bool>,
    /// `robotBlendingDone`: way-point motion finished.
    pub blending_done: Option<bool>,
    /// `InPos`: at the target position.
    pub in_pos: Option<bool>,
    /// `Error_AxisID`: axis in error, 1-6.
    pub error_axis_id: Option<i32>,
    /// `Error_Code`: the controller's error code.
    pub error_code: Option<i32>,
    /// `BrakeState`: per axis, 0 braked, 1 released.
    pub brake_state: Option<[i32; 6]>,
    /// `nAxisStatus`: per axis status.
    pub axis_status: Option<[i32; 6]>,
    /// `nAxisErrorCode`: per axis error code.
    pub axis_error_code: Option<[i32; 6]>,
    /// `nResetSafeSpace`: per axis group, whether it moves back into its
    /// safe space.
    pub reset_safe_space: Vec<i32, MAX_AXIS_GROUPS>,
    /// `nAxisGroupStatus`: per axis group.
    pub axis_group_status: Vec<i32, MAX_AXIS_GROUPS>,
    /// `nAxisGroupErrorCode`: per axis group.
    pub axis_group_error_code: Vec<i32, MAX_AXIS_GROUPS>,
}

/// Group `HardLoad`: bus statistics and power.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HardLoad {
    /// `EtherCAT_TotalFrame`: frames exchanged with the arm.
    pub ethercat_total_frame: Option<u64>,
    /// `EtherCAT_FramesPerSecond`.
    pub ethercat_frames_per_second: Option<u64>,
    /// `EtherCAT_TotalLostFrame`.
    pub ethercat_total_lost_frame: Option<u64>,
    /// `EtherCAT_TxErrorFrame`.
    pub ethercat_tx_error_frame: Option<u64>,
    /// `EtherCAT_RxErrorFrame`.
    pub ethercat_rx_error_frame: Option<u64>,
    /// `Box48IN_Voltage`: 48 V supply voltage (V).
    pub box48_in_voltage: Option<Decimal>,
    /// `Box48IN_Current`: 48 V supply current (A).
    pub box48_in_current: Option<Decimal>,
    /// `Box48Out_Voltage` (the table spells it `Box48OUT_`): voltage to the
    /// arm (V).
    pub box48_out_voltage: Option<Decimal>,
    /// `Box48Out_Current`: current to the arm (A).
    pub box48_out_current: Option<Decimal>,
    /// `Slave_temperature`: per joint module (°C).
    pub slave_temperature: Vec<Decimal, MAX_SLAVES>,
    /// `Slave_Voltage`: per joint module (V).
    pub slave_voltage: Vec<Decimal, MAX_SLAVES>,
}

/// Group `FTData`: the force/torque sensor.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FtData {
    /// `FTControlState`: 0 force control off, 1 on.
    pub control_state: Option<i32>,
    /// `FTData`: calibrated X, Y, Z (N), Rx, Ry, Rz (Nm).
    pub data: Option<[Decimal; 6]>,
    /// `FTSrcData`: raw sensor values, same units.
    pub src_data: Option<[Decimal; 6]>,
}

/// Group `Script`: script execution. Its `cmdid` and `GlobalVar` lists are
/// skipped (strings of unbounded number and size).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Script {
    /// `errorCode`: the script's error code.
    pub error_code: Option<i32>,
}

/// One DataSheet payload, decoded. Every field is optional (lists: may be
/// empty); `Default` is the empty sheet. It is a plain value of about 1.9 KiB
/// with no borrowed data: keep the latest one in a task or a static rather
/// than many copies on a small stack.
///
/// ```
/// use hans_codec::datasheet::DataSheet;
/// use hans_codec::{Decimal, FsmState};
///
/// let payload = br#"{"PosAndVel":{"Actual Position":["0.000","-0.000","90.000",
///     "0.000","90.000","0.000"],"Actual_Override":"0.050"},
///     "StateAndError":{"robotState":33,"robotMoving":0},"pluginsdata":{}}"#;
/// let sheet = DataSheet::parse(payload).unwrap();
/// assert_eq!(sheet.state.robot_state, Some(FsmState::StandBy));
/// assert_eq!(sheet.state.moving, Some(false));
/// let joints = sheet.pos_and_vel.position.unwrap().joints;
/// assert_eq!(joints[2], Decimal::from_int(90));
///
/// let mut out = [0u8; 512];
/// let n = sheet.write_json(&mut out).unwrap();
/// assert!(out[..n].starts_with(br#"{"PosAndVel":{"Actual_Position":["0.000","-0.000","90.000""#));
/// assert_eq!(DataSheet::parse(&out[..n]).unwrap(), sheet);
/// ```
#[derive(Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DataSheet {
    /// `PosAndVel`.
    pub pos_and_vel: PosAndVel,
    /// `EndIO`.
    pub end_io: EndIo,
    /// `ElectricBoxIO`.
    pub box_io: BoxIo,
    /// `ElectricBoxAnalogIO`.
    pub box_analog_io: BoxAnalogIo,
    /// `StateAndError`.
    pub state: StateAndError,
    /// `HardLoad`.
    pub hard_load: HardLoad,
    /// `FTData`.
    pub ft: FtData,
    /// `Script`.
    pub script: Script,
}

/// What a field's value should have been.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FieldExpected {
    /// A number, or a string holding one.
    Number,
    /// A whole number that fits the field's type.
    Integer,
    /// 0 or 1 (or `true` / `false`).
    Flag,
    /// A single value, not a list or object.
    Single,
    /// A list.
    List,
    /// A list of exactly this many values.
    Exactly(u16),
    /// A list of 6 or 12 values (`Actual_Position`).
    SixOrTwelve,
    /// A list of at most this many values (the capacity).
    AtMost(u16),
}

impl fmt::Display for FieldExpected {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FieldExpected::Number => f.write_str("a number"),
            FieldExpected::Integer => f.write_str("an integer in range"),
            FieldExpected::Flag => f.write_str("0 or 1"),
            FieldExpected::Single => f.write_str("a single value"),
            FieldExpected::List => f.write_str("a list"),
            FieldExpected::Exactly(n) => write!(f, "exactly {n} values"),
            FieldExpected::SixOrTwelve => f.write_str("6 or 12 values"),
            FieldExpected::AtMost(n) => write!(f, "at most {n} values"),
        }
    }
}

/// Why a payload could not be decoded.
///
/// ```
/// use hans_codec::datasheet::{DataSheet, DataSheetError, FieldExpected};
///
/// let e = DataSheet::parse(br#"{"StateAndError":{"robotMoving":2}}"#).unwrap_err();
/// assert_eq!(
///     e,
///     DataSheetError::Field { field: "robotMoving", expected: FieldExpected::Flag, offset: 32 }
/// );
/// assert_eq!(e.to_string(), "robotMoving must be 0 or 1 (offset 32)");
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DataSheetError {
    /// The payload is not well-formed JSON.
    Json(JsonError),
    /// The payload is JSON but not an object.
    NotAnObject,
    /// A known field has a value of the wrong kind or size.
    Field {
        /// The field, as this crate names it (`"Actual_PCS_TCP"`).
        field: &'static str,
        /// What it should have been.
        expected: FieldExpected,
        /// Byte offset in the payload of the offending value or element.
        offset: usize,
    },
}

impl From<JsonError> for DataSheetError {
    fn from(e: JsonError) -> Self {
        DataSheetError::Json(e)
    }
}

impl fmt::Display for DataSheetError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DataSheetError::Json(e) => e.fmt(f),
            DataSheetError::NotAnObject => f.write_str("DataSheet payload is not a JSON object"),
            DataSheetError::Field {
                field,
                expected,
                offset,
            } => write!(f, "{field} must be {expected} (offset {offset})"),
        }
    }
}

impl core::error::Error for DataSheetError {}

/// Whether a decimal is written as a JSON string (`"0.000"`) or a number.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Form {
    Text,
    Plain,
}

/// The number in a number or string token. `Ok(None)` for `null` and `""`;
/// `Err(())` for anything else that is not a number.
pub(super) fn decimal_of(token: &Token<'_>) -> Result<Option<Decimal>, ()> {
    let raw = match *token {
        Token::Number(raw) | Token::Str(raw) => raw,
        Token::Bool(b) => return Ok(Some(Decimal::from_int(i64::from(b)))),
        Token::Null => return Ok(None),
        _ => return Err(()),
    };
    // The longest number worth reading is far shorter than this; longer
    // text is not a number we take.
    const CAP: usize = 64;
    let mut buf = [0u8; CAP];
    let text = if raw.iter().any(|&b| is_stripped(b)) {
        // Copy the significant bytes.
        let mut n = 0;
        for b in significant(raw) {
            let slot = buf.get_mut(n).ok_or(())?;
            *slot = b;
            n += 1;
        }
        buf.get(..n).unwrap_or(&[])
    } else if raw.len() <= CAP {
        raw
    } else {
        return Err(());
    };
    // Spaces around a number in a string are trimmed.
    let text = text.trim_ascii();
    if text.is_empty() {
        return Ok(None);
    }
    Decimal::parse_bytes(text).map(Some).map_err(|_| ())
}

/// One value of a field or list element.
trait Scalar: Copy {
    /// A placeholder value (fills arrays before they are read).
    const ZERO: Self;
    /// What [`Scalar::from_decimal`] wants.
    const EXPECTED: FieldExpected;
    /// The value for a number; [`Scalar::EXPECTED`] if it does not fit.
    fn from_decimal(d: Decimal) -> Result<Self, FieldExpected>;
    /// The value of a scalar token; `Ok(None)` for `null` / `""`.
    fn from_token(token: &Token<'_>) -> Result<Option<Self>, FieldExpected> {
        match decimal_of(token) {
            Ok(Some(d)) => Self::from_decimal(d).map(Some),
            Ok(None) => Ok(None),
            Err(()) => Err(Self::EXPECTED),
        }
    }
    fn write(&self, form: Form, w: &mut Writer<'_>);
}

impl Scalar for Decimal {
    const ZERO: Self = Decimal::ZERO;
    const EXPECTED: FieldExpected = FieldExpected::Number;
    fn from_decimal(d: Decimal) -> Result<Self, FieldExpected> {
        Ok(d)
    }
    fn write(&self, form: Form, w: &mut Writer<'_>) {
        // Three decimals as controllers write them; more are kept, never
        // rounded away; a value too large to rescale is written as it is.
        let v = self.rescale(self.scale().max(3)).unwrap_or(*self);
        w.decimal(&v, form == Form::Text)
    }
}

impl Scalar for i32 {
    const ZERO: Self = 0;
    const EXPECTED: FieldExpected = FieldExpected::Integer;
    fn from_decimal(d: Decimal) -> Result<Self, FieldExpected> {
        d.to_i64()
            .and_then(|v| i32::try_from(v).ok())
            .ok_or(Self::EXPECTED)
    }
    fn write(&self, _: Form, w: &mut Writer<'_>) {
        w.int(i64::from(*self))
    }
}

impl Scalar for u64 {
    const ZERO: Self = 0;
    const EXPECTED: FieldExpected = FieldExpected::Integer;
    fn from_decimal(d: Decimal) -> Result<Self, FieldExpected> {
        if d.is_sign_negative() && !d.is_zero() {
            return Err(Self::EXPECTED);
        }
        // Whole numbers above i64::MAX are read from the coefficient.
        if d.scale() == 0 {
            return Ok(d.coefficient());
        }
        d.to_i64()
            .and_then(|v| u64::try_from(v).ok())
            .ok_or(Self::EXPECTED)
    }
    fn write(&self, _: Form, w: &mut Writer<'_>) {
        w.uint(*self)
    }
}

impl Scalar for bool {
    const ZERO: Self = false;
    const EXPECTED: FieldExpected = FieldExpected::Flag;
    fn from_decimal(d: Decimal) -> Result<Self, FieldExpected> {
        match d.to_i64() {
            Some(0) => Ok(false),
            Some(1) => Ok(true),
            _ => Err(Self::EXPECTED),
        }
    }
    fn write(&self, _: Form, w: &mut Writer<'_>) {
        w.int(i64::from(*self))
    }
}

impl Scalar for FsmState {
    const ZERO: Self = FsmState::UnInitialize;
    const EXPECTED: FieldExpected = FieldExpected::Integer;
    fn from_decimal(d: Decimal) -> Result<Self, FieldExpected> {
        i32::from_decimal(d).map(FsmState::from)
    }
    fn write(&self, _: Form, w: &mut Writer<'_>) {
        w.int(i64::from(self.code()))
    }
}

/// A value or list element, as the readers hand it to a field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Value<'a> {
    /// A plain number (bare or the whole of a string), already read: the
    /// value [`decimal_of`] gives for its token.
    Number(Decimal),
    /// Any other token: a string, a literal, a number in another form, or
    /// the start of an array or object (always wrong for a field here).
    Token(Token<'a>),
}

/// A field of the table, read side. The reader (`read.rs`) drives it:
/// [`Member::set`] for a single value, or [`Member::begin`], one
/// [`Member::push`] per element and [`Member::end`] for a list; so what a
/// field accepts is defined once, here.
///
/// Reading and writing are separate traits so that a decoder-only program
/// (the gateway) does not link the encoder through the `dyn` tables.
pub(super) trait Member {
    /// The value is not a list (`null` clears a list field).
    fn set(&mut self, v: Value<'_>) -> Result<(), FieldExpected>;
    /// The value is a list; its elements follow.
    fn begin(&mut self) -> Result<(), FieldExpected>;
    /// Element `i` of the list, a number: the value [`decimal_of`] gives
    /// for its token. (Any other element is a list with a hole, the error
    /// [`Member::expected`].)
    fn push(&mut self, i: usize, d: Decimal) -> Result<(), FieldExpected>;
    /// The list ended after `n` elements.
    fn end(&mut self, n: usize) -> Result<(), FieldExpected>;
    /// What an element should have been.
    fn expected(&self) -> FieldExpected;
    /// A whole list at once, in one dynamic call: the effect of
    /// [`Member::begin`], [`Member::push`] for each value in order and
    /// [`Member::end`] when all succeed; an error when one of them would
    /// fail (which one need not be the same: the reader then reads the list
    /// again element by element for the precise error and its offset).
    fn list(&mut self, values: &[Decimal]) -> Result<(), FieldExpected> {
        self.begin()?;
        for (i, &d) in values.iter().enumerate() {
            self.push(i, d)?;
        }
        self.end(values.len())
    }
}

/// The longest list any field takes (the capacities above, 6 values for a
/// pose, 12 for `Actual_Position`): a longer one is an error whatever the
/// field.
pub(super) const MAX_LIST: usize = 16;

const _: () = assert!(
    MAX_END_IO <= MAX_LIST
        && MAX_END_AI <= MAX_LIST
        && MAX_BOX_IO <= MAX_LIST
        && MAX_AXIS_GROUPS <= MAX_LIST
        && MAX_SLAVES <= MAX_LIST
        && 12 <= MAX_LIST
);

/// A field of the table, write side.
trait Emit {
    /// Writes `"name":value` (or nothing for an unset optional field).
    fn write(&self, name: &str, form: Form, w: &mut Writer<'_>);
}

impl<T: Scalar> Member for Option<T> {
    fn set(&mut self, v: Value<'_>) -> Result<(), FieldExpected> {
        *self = match v {
            Value::Number(d) => Some(T::from_decimal(d)?),
            Value::Token(Token::BeginArray | Token::BeginObject) => {
                return Err(FieldExpected::Single)
            }
            Value::Token(token) => T::from_token(&token)?,
        };
        Ok(())
    }
    fn begin(&mut self) -> Result<(), FieldExpected> {
        Err(FieldExpected::Single)
    }
    fn push(&mut self, _: usize, _: Decimal) -> Result<(), FieldExpected> {
        Err(FieldExpected::Single)
    }
    fn end(&mut self, _: usize) -> Result<(), FieldExpected> {
        Err(FieldExpected::Single)
    }
    fn expected(&self) -> FieldExpected {
        FieldExpected::Single
    }
}

impl<T: Scalar> Emit for Option<T> {
    fn write(&self, name: &str, form: Form, w: &mut Writer<'_>) {
        if let Some(v) = self {
            w.key(name);
            v.write(form, w);
        }
    }
}

/// A list field given a single value: `null` leaves it unset, anything
/// else is an error.
fn list_null(v: Value<'_>) -> Result<(), FieldExpected> {
    match v {
        Value::Token(Token::Null) => Ok(()),
        _ => Err(FieldExpected::List),
    }
}

impl<T: Scalar, const N: usize> Member for Option<[T; N]> {
    fn set(&mut self, v: Value<'_>) -> Result<(), FieldExpected> {
        list_null(v)?;
        *self = None;
        Ok(())
    }
    fn begin(&mut self) -> Result<(), FieldExpected> {
        *self = Some([T::ZERO; N]);
        Ok(())
    }
    fn push(&mut self, i: usize, d: Decimal) -> Result<(), FieldExpected> {
        let v = T::from_decimal(d)?;
        let slot = self.as_mut().and_then(|a| a.get_mut(i));
        *slot.ok_or(FieldExpected::Exactly(N as u16))? = v;
        Ok(())
    }
    fn end(&mut self, n: usize) -> Result<(), FieldExpected> {
        if n == N {
            Ok(())
        } else {
            Err(FieldExpected::Exactly(N as u16))
        }
    }
    fn expected(&self) -> FieldExpected {
        T::EXPECTED
    }
}

impl<T: Scalar, const N: usize> Emit for Option<[T; N]> {
    fn write(&self, name: &str, form: Form, w: &mut Writer<'_>) {
        if let Some(a) = self {
            w.key(name);
            write_list(a, form, w);
        }
    }
}

fn write_list<T: Scalar>(values: &[T], form: Form, w: &mut Writer<'_>) {
    w.begin_array();
    for v in values {
        v.write(form, w);
    }
    w.end_array();
}

impl<T: Scalar, const N: usize> Member for Vec<T, N> {
    fn set(&mut self, v: Value<'_>) -> Result<(), FieldExpected> {
        self.clear();
        list_null(v)
    }
    fn begin(&mut self) -> Result<(), FieldExpected> {
        self.clear();
        Ok(())
    }
    fn push(&mut self, _: usize, d: Decimal) -> Result<(), FieldExpected> {
        let v = T::from_decimal(d)?;
        Vec::push(self, v).map_err(|_| FieldExpected::AtMost(N as u16))
    }
    fn end(&mut self, _: usize) -> Result<(), FieldExpected> {
        Ok(())
    }
    fn expected(&self) -> FieldExpected {
        T::EXPECTED
    }
}

impl<T: Scalar, const N: usize> Emit for Vec<T, N> {
    fn write(&self, name: &str, form: Form, w: &mut Writer<'_>) {
        w.key(name);
        write_list(self, form, w);
    }
}

impl Member for Option<Position> {
    fn set(&mut self, v: Value<'_>) -> Result<(), FieldExpected> {
        list_null(v)?;
        *self = None;
        Ok(())
    }
    fn begin(&mut self) -> Result<(), FieldExpected> {
        // Six joints, then the pose if six more values come.
        *self = Some(Position {
            joints: [Decimal::ZERO; 6],
            pose: Some([Decimal::ZERO; 6]),
        });
        Ok(())
    }
    fn push(&mut self, i: usize, v: Decimal) -> Result<(), FieldExpected> {
        let p = self.as_mut().ok_or(FieldExpected::SixOrTwelve)?;
        let slot = match i.checked_sub(6) {
            None => p.joints.get_mut(i),
            Some(j) => p.pose.as_mut().and_then(|pose| pose.get_mut(j)),
        };
        *slot.ok_or(FieldExpected::SixOrTwelve)? = v;
        Ok(())
    }
    fn end(&mut self, n: usize) -> Result<(), FieldExpected> {
        match (n, self.as_mut()) {
            (6, Some(p)) => p.pose = None,
            (12, Some(_)) => {}
            _ => return Err(FieldExpected::SixOrTwelve),
        }
        Ok(())
    }
    fn expected(&self) -> FieldExpected {
        FieldExpected::Number
    }
}

impl Emit for Option<Position> {
    fn write(&self, name: &str, form: Form, w: &mut Writer<'_>) {
        if let Some(p) = self {
            w.key(name);
            w.begin_array();
            for v in p.joints.iter().chain(p.pose.iter().flatten()) {
                v.write(form, w);
            }
            w.end_array();
        }
    }
}

/// How the decoder reaches a field of a sheet.
pub(super) type ReadField = fn(&mut DataSheet) -> &mut dyn Member;

/// A field of the encoder's table.
struct WriteField {
    name: &'static str,
    form: Form,
    get: fn(&DataSheet) -> &dyn Emit,
}

/// One group of a table.
struct Group<F: 'static> {
    name: &'static str,
    fields: &'static [F],
}

/// The field table: every group and field, declared once and expanded into
/// tables of data. The decoder tries the name expected next and otherwise
/// looks keys up in a hash table built from the names at compile time
/// ([`Names`]); the encoder walks its table in order. So the code is one
/// loop each whatever the number of fields, and a program that only decodes
/// does not link the encoder. (On thumbv7em, opt-level z: deframer +
/// `parse` ~16 KiB of flash including ~4 KiB of compiler builtins;
/// `write_json` ~5 KiB more.)
macro_rules! layout {
    ($(
        $group:literal => $g:ident {
            $( $name:literal => ($form:ident, $($f:tt)+), )*
        }
    )*) => {
        /// The decoder's field names, every group's together (a field is
        /// read in whichever group it comes)...
        pub(super) const READ_NAMES: &[&str] = &[$($($name,)*)*];
        /// ...and how to reach each one, in the same order.
        pub(super) const READ: &[ReadField] = &[$($(|ds| &mut ds.$g.$($f)+,)*)*];
        /// The group names: an object under one of these is read as a group.
        pub(super) const GROUP_NAMES: &[&str] = &[$($group,)*];

        /// The encoder's table, in the order it writes.
        const WRITE: &[Group<WriteField>] = &[$(
            Group {
                name: $group,
                fields: &[$(
                    WriteField { name: $name, form: Form::$form, get: |ds| &ds.$g.$($f)+ },
                )*],
            },
        )*];
    };
}

layout! {
    "PosAndVel" => pos_and_vel {
        "Actual_Position" => (Text, position),
        "Actual_PCS_TCP" => (Text, pcs_tcp),
        "Actual_PCS_Base" => (Text, pcs_base),
        "Actual_PCS_Tool" => (Text, pcs_tool),
        "Actual_Joint_Current" => (Text, joint_current),
        "Actual_Joint_Velocity" => (Text, joint_velocity),
        "Actual_Joint_Acceleration" => (Text, joint_acceleration),
        "Actual_Override" => (Text, override_ratio),
    }
    "EndIO" => end_io {
        "EndDI" => (Plain, end_di),
        "EndDO" => (Plain, end_do),
        "EndButton" => (Plain, end_button),
        "EnableEndBTN" => (Plain, enable_end_btn),
        "EndAI" => (Plain, end_ai),
    }
    "ElectricBoxIO" => box_io {
        "BoxCI" => (Plain, box_ci),
        "BoxCO" => (Plain, box_co),
        "BoxDI" => (Plain, box_di),
        "BoxDO" => (Plain, box_do),
        "Conveyor" => (Text, conveyor),
        "Encode" => (Plain, encode),
    }
    "ElectricBoxAnalogIO" => box_analog_io {
        "BoxAnalogOutMode_1" => (Plain, out_mode[0]),
        "BoxAnalogOutMode_2" => (Plain, out_mode[1]),
        "BoxAnalogOut_1" => (Text, out[0]),
        "BoxAnalogOut_2" => (Text, out[1]),
        "BoxAnalogIn_1" => (Text, input[0]),
        "BoxAnalogIn_2" => (Text, input[1]),
    }
    "StateAndError" => state {
        "robotState" => (Plain, robot_state),
        "robotEnabled" => (Plain, enabled),
        "robotPaused" => (Plain, paused),
        "robotMoving" => (Plain, moving),
        "robotBlendingDone" => (Plain, blending_done),
        "InPos" => (Plain, in_pos),
        "Error_AxisID" => (Plain, error_axis_id),
        "Error_Code" => (Plain, error_code),
        "BrakeState" => (Plain, brake_state),
        "nAxisStatus" => (Plain, axis_status),
        "nAxisErrorCode" => (Plain, axis_error_code),
        "nResetSafeSpace" => (Plain, reset_safe_space),
        "nAxisGroupStatus" => (Plain, axis_group_status),
        "nAxisGroupErrorCode" => (Plain, axis_group_error_code),
    }
    "HardLoad" => hard_load {
        "EtherCAT_TotalFrame" => (Plain, ethercat_total_frame),
        "EtherCAT_FramesPerSecond" => (Plain, ethercat_frames_per_second),
        "EtherCAT_TotalLostFrame" => (Plain, ethercat_total_lost_frame),
        "EtherCAT_TxErrorFrame" => (Plain, ethercat_tx_error_frame),
        "EtherCAT_RxErrorFrame" => (Plain, ethercat_rx_error_frame),
        "Box48IN_Voltage" => (Plain, box48_in_voltage),
        "Box48IN_Current" => (Plain, box48_in_current),
        "Box48Out_Voltage" => (Plain, box48_out_voltage),
        "Box48Out_Current" => (Plain, box48_out_current),
        "Slave_temperature" => (Plain, slave_temperature),
        "Slave_Voltage" => (Plain, slave_voltage),
    }
    "FTData" => ft {
        "FTControlState" => (Plain, control_state),
        "FTData" => (Plain, data),
        "FTSrcData" => (Plain, src_data),
    }
    "Script" => script {
        "errorCode" => (Plain, error_code),
    }
}

/// The decoder's look-up table of [`READ_NAMES`] and [`GROUP_NAMES`].
pub(super) static NAMES: Names = Names::new(READ_NAMES, GROUP_NAMES);

const _: () = assert!(READ.len() == READ_NAMES.len());

impl DataSheet {
    /// Upper bound of [`DataSheet::write_json`]'s output for any sheet whose
    /// decimals have at most three decimals and at most 15 integer digits
    /// (a buffer this size never fails for what a controller reports).
    pub const MAX_JSON_LEN: usize = 5120;

    /// Decodes a payload (as delivered by the [`Deframer`](super::Deframer),
    /// or still holding NUL/`\n`/`\t` bytes: they are ignored either way).
    /// See the [module documentation](self) for what is accepted.
    pub fn parse(payload: &[u8]) -> Result<DataSheet, DataSheetError> {
        read::parse(payload)
    }

    /// Writes the payload JSON into `out`; returns its length, or
    /// [`EncodeError::BufferTooSmall`].
    pub fn write_json(&self, out: &mut [u8]) -> Result<usize, EncodeError> {
        let mut w = Writer::new(out);
        w.begin_object();
        for g in WRITE {
            w.key(g.name);
            w.begin_object();
            for f in g.fields {
                (f.get)(self).write(f.name, f.form, &mut w);
            }
            w.end_object();
        }
        w.end_object();
        w.finish()
    }

    /// Writes a whole packet, header then JSON payload, into `out`; returns
    /// its length, or [`EncodeError::BufferTooSmall`].
    ///
    /// ```
    /// use hans_codec::datasheet::{DataSheet, Deframer};
    ///
    /// let mut sheet = DataSheet::default();
    /// sheet.state.moving = Some(true);
    /// let mut wire = [0u8; DataSheet::MAX_JSON_LEN + 12];
    /// let n = sheet.write_packet(&mut wire).unwrap();
    /// assert_eq!(&wire[..4], b"LTBR");
    ///
    /// let mut deframer = Deframer::<{ DataSheet::MAX_JSON_LEN }>::new();
    /// let (used, item) = deframer.push(&wire[..n]);
    /// assert_eq!(used, n);
    /// assert_eq!(DataSheet::parse(item.unwrap().unwrap()).unwrap(), sheet);
    /// ```
    pub fn write_packet(&self, out: &mut [u8]) -> Result<usize, EncodeError> {
        let (head, body) = out
            .split_at_mut_checked(HEADER_LEN)
            .ok_or(EncodeError::BufferTooSmall)?;
        let cap = body.len().min(MAX_PAYLOAD);
        let n = self.write_json(body.get_mut(..cap).unwrap_or(&mut []))?;
        // 0 < n <= MAX_PAYLOAD and `head` is a whole header: cannot fail.
        emit_header(n, head).map_err(|_| EncodeError::BufferTooSmall)?;
        Ok(HEADER_LEN + n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn d(s: &str) -> Decimal {
        Decimal::parse(s).unwrap()
    }

    fn six(vals: [&str; 6]) -> [Decimal; 6] {
        vals.map(d)
    }

    fn round_trip(ds: &DataSheet) -> DataSheet {
        let mut buf = [0u8; DataSheet::MAX_JSON_LEN];
        let n = ds.write_json(&mut buf).unwrap();
        DataSheet::parse(&buf[..n]).unwrap()
    }

    #[test]
    fn document_spellings_and_forms() {
        let payload = br#"{"PosAndVel":{"Actual Position":["1.000","2","3","4","5","6",
            "7","8","9","10","11","-0.000"],"Actual PCS TCP":["0.5",0,0,0,0,0],
            "Actual Override": "0.050"},
          "ElectricBoxAnalogIO":{"BoxAnalogOutMode 1":0,"BoxAnalogOut 2":"0.00",
            "BoxAnalogIn_1":"-12.50"},
          "StateAndError": {"robotState": "33", "robotEnabled": true, "InPos": 0,
            "BrakeState": [0, 0, 0, 0, 0, 1],},
          "HardLoad":{"Box48OUT_Voltage":48.00,"box48in_voltage":1,"EtherCAT_TotalFrame":18446744073709551615},
          "FTData":{"FTData":[0.00,0.00,0.00,0.00,0.00,1.25],"FTControlState":"0"}}"#;
        let ds = DataSheet::parse(payload).unwrap();
        let p = ds.pos_and_vel.position.unwrap();
        assert_eq!(p.joints, six(["1", "2", "3", "4", "5", "6"]));
        assert_eq!(p.pose, Some(six(["7", "8", "9", "10", "11", "0"])));
        assert_eq!(
            ds.pos_and_vel.pcs_tcp,
            Some(six(["0.5", "0", "0", "0", "0", "0"]))
        );
        assert_eq!(ds.pos_and_vel.override_ratio, Some(d("0.05")));
        assert_eq!(ds.box_analog_io.out_mode, [Some(0), None]);
        assert_eq!(ds.box_analog_io.out, [None, Some(d("0"))]);
        assert_eq!(ds.box_analog_io.input, [Some(d("-12.5")), None]);
        assert_eq!(ds.state.robot_state, Some(FsmState::StandBy));
        assert_eq!(ds.state.enabled, Some(true));
        assert_eq!(ds.state.in_pos, Some(false));
        assert_eq!(ds.state.brake_state, Some([0, 0, 0, 0, 0, 1]));
        assert_eq!(ds.hard_load.box48_out_voltage, Some(d("48")));
        // Case is ignored.
        assert_eq!(ds.hard_load.box48_in_voltage, Some(d("1")));
        assert_eq!(ds.hard_load.ethercat_total_frame, Some(u64::MAX));
        assert_eq!(ds.ft.data, Some(six(["0", "0", "0", "0", "0", "1.25"])));
        assert_eq!(ds.ft.control_state, Some(0));
        assert_eq!(ds.end_io, EndIo::default());
        assert_eq!(round_trip(&ds), ds);
    }

    #[test]
    fn every_table_name_is_found() {
        for (i, name) in READ_NAMES.iter().enumerate() {
            assert_eq!(NAMES.find(name.as_bytes()).field, Some(i), "{name}");
        }
        for name in GROUP_NAMES {
            assert!(NAMES.find(name.as_bytes()).group.is_some(), "{name}");
        }
        // The one name that is both.
        let ft = NAMES.find(b"ftdata");
        assert!(ft.group.is_some() && ft.field.is_some());
        super::super::names::tests::agrees_on_mutations(&NAMES);
    }

    #[test]
    fn unknown_members_are_skipped_and_groups_read_at_any_level() {
        let payload = br#"{"pluginsdata":{"robotState":5,"x":[{"y":[]}]},
            "Script":{"errorCode":7,"cmdid":["","",""],"GlobalVar":[]},
            "PosAndVel":{"EndIO":{"EndDI":[1,0,1,0]}},
            "robotMoving":1, "newField":{"a":[1,2,{"b":null}]}, "other":"text"}"#;
        let ds = DataSheet::parse(payload).unwrap();
        assert_eq!(ds.state.robot_state, None);
        assert_eq!(ds.script.error_code, Some(7));
        assert_eq!(&ds.end_io.end_di[..], &[1, 0, 1, 0]);
        assert_eq!(ds.state.moving, Some(true));
    }

    #[test]
    fn ignored_bytes_anywhere() {
        let payload =
            b"\0{\"StateAndError\":{\"robot\nState\":3\t3,\n\"Error_Code\":\"2\x000\"}}\0\0";
        let ds = DataSheet::parse(payload).unwrap();
        assert_eq!(ds.state.robot_state, Some(FsmState::StandBy));
        assert_eq!(ds.state.error_code, Some(20));
    }

    #[test]
    fn null_and_empty_leave_fields_unset() {
        let ds = DataSheet::parse(
            br#"{"Actual_Override":null,"Error_Code":"","BoxDI":null,"FTData":null,"Actual_Position":null}"#,
        )
        .unwrap();
        assert_eq!(ds, DataSheet::default());
    }

    fn field_err(payload: &[u8]) -> (&'static str, FieldExpected, usize) {
        match DataSheet::parse(payload) {
            Err(DataSheetError::Field {
                field,
                expected,
                offset,
            }) => (field, expected, offset),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn typed_errors() {
        use FieldExpected::*;
        assert_eq!(
            field_err(br#"{"robotState":"abc"}"#),
            ("robotState", Integer, 14)
        );
        assert_eq!(field_err(br#"{"robotState":1.5}"#).1, Integer);
        assert_eq!(field_err(br#"{"Error_Code":3000000000}"#).1, Integer);
        assert_eq!(
            field_err(br#"{"robotMoving":2}"#),
            ("robotMoving", Flag, 15)
        );
        assert_eq!(field_err(br#"{"robotMoving":[1]}"#).1, Single);
        assert_eq!(field_err(br#"{"robotMoving":{}}"#).1, Single);
        assert_eq!(field_err(br#"{"BoxDI":1}"#), ("BoxDI", List, 9));
        assert_eq!(
            field_err(br#"{"Actual_PCS_TCP":["1","2"]}"#),
            ("Actual_PCS_TCP", Exactly(6), 26)
        );
        assert_eq!(
            field_err(br#"{"Actual_PCS_TCP":[1,2,3,4,5,6,7]}"#).1,
            Exactly(6)
        );
        assert_eq!(
            field_err(br#"{"Actual_Position":[1,2,3,4,5,6,7]}"#).1,
            SixOrTwelve
        );
        assert_eq!(
            field_err(br#"{"Actual_Position":[1,2,3,4,5,6,7,8,9,10,11,12,13]}"#).1,
            SixOrTwelve
        );
        assert_eq!(
            field_err(br#"{"EndAI":[1,2,3,4,5]}"#),
            ("EndAI", AtMost(4), 18)
        );
        assert_eq!(field_err(br#"{"EndAI":[1,null]}"#), ("EndAI", Number, 12));
        assert_eq!(field_err(br#"{"EndDI":[1,[0]]}"#).1, Integer);
        assert_eq!(field_err(br#"{"EtherCAT_TotalFrame":-1}"#).1, Integer);
        assert_eq!(
            DataSheet::parse(b"[1]").unwrap_err(),
            DataSheetError::NotAnObject
        );
        assert!(matches!(
            DataSheet::parse(b"{\"a\":1} x"),
            Err(DataSheetError::Json(JsonError { offset: 8, .. }))
        ));
        assert!(matches!(
            DataSheet::parse(b""),
            Err(DataSheetError::Json(_))
        ));
    }

    #[test]
    fn write_forms_follow_the_document() {
        let mut ds = DataSheet::default();
        ds.pos_and_vel.override_ratio = Some(d("0.05"));
        ds.hard_load.box48_in_voltage = Some(d("48"));
        ds.hard_load.slave_temperature.push(d("31.25")).unwrap();
        ds.box_io.conveyor = Some(d("-0"));
        ds.state.robot_state = Some(FsmState::Unknown(99));
        ds.state.moving = Some(false);
        ds.ft.data = Some(six(["1.23456", "0", "0", "0", "0", "0"]));
        let mut buf = [0u8; 1024];
        let n = ds.write_json(&mut buf).unwrap();
        let text = core::str::from_utf8(&buf[..n]).unwrap();
        for part in [
            r#"{"PosAndVel":{"Actual_Override":"0.050"},"EndIO":{"EndDI":[],"#,
            r#""ElectricBoxIO":{"BoxCI":[],"BoxCO":[],"BoxDI":[],"BoxDO":[],"Conveyor":"-0.000"},"#,
            r#""ElectricBoxAnalogIO":{},"StateAndError":{"robotState":99,"robotMoving":0,"#,
            r#""Box48IN_Voltage":48.000,"#,
            r#""Slave_temperature":[31.250],"#,
            r#""FTData":{"FTData":[1.23456,0.000,"#,
            r#""Script":{}}"#,
        ] {
            assert!(text.contains(part), "{part} not in {text}");
        }
        assert_eq!(round_trip(&ds), ds);
        // Too small a buffer is an error, at every size.
        for len in 0..n {
            assert_eq!(
                ds.write_json(&mut buf[..len]),
                Err(EncodeError::BufferTooSmall)
            );
        }
        let mut packet = [0u8; 1024];
        assert_eq!(
            ds.write_packet(&mut packet[..n + 11]),
            Err(EncodeError::BufferTooSmall)
        );
        assert_eq!(ds.write_packet(&mut packet[..n + 12]), Ok(n + 12));
        assert_eq!(&packet[12..n + 12], &buf[..n]);
    }

    /// The largest sheet the bound promises: every field set, every list
    /// full, every value as long as allowed.
    #[test]
    fn max_json_len_holds_for_the_largest_sheet() {
        let big = d("-123456789012345.678");
        let big6 = [big; 6];
        let int = i32::MIN;
        let full_i = |n: usize| (0..n).map(|_| int);
        let mut ds = DataSheet {
            pos_and_vel: PosAndVel {
                position: Some(Position {
                    joints: big6,
                    pose: Some(big6),
                }),
                pcs_tcp: Some(big6),
                pcs_base: Some(big6),
                pcs_tool: Some(big6),
                joint_current: Some(big6),
                joint_velocity: Some(big6),
                joint_acceleration: Some(big6),
                override_ratio: Some(big),
            },
            ..DataSheet::default()
        };
        ds.end_io.end_di.extend(full_i(MAX_END_IO));
        ds.end_io.end_do.extend(full_i(MAX_END_IO));
        ds.end_io.end_button.extend(full_i(MAX_END_IO));
        ds.end_io.enable_end_btn = Some(int);
        ds.end_io.end_ai.extend((0..MAX_END_AI).map(|_| big));
        ds.box_io.box_ci.extend(full_i(MAX_BOX_IO));
        ds.box_io.box_co.extend(full_i(MAX_BOX_IO));
        ds.box_io.box_di.extend(full_i(MAX_BOX_IO));
        ds.box_io.box_do.extend(full_i(MAX_BOX_IO));
        ds.box_io.conveyor = Some(big);
        ds.box_io.encode = Some(int);
        ds.box_analog_io = BoxAnalogIo {
            out_mode: [Some(int); 2],
            out: [Some(big); 2],
            input: [Some(big); 2],
        };
        ds.state = StateAndError {
            robot_state: Some(FsmState::Unknown(int)),
            enabled: Some(true),
            paused: Some(true),
            moving: Some(true),
            blending_done: Some(true),
            in_pos: Some(true),
            error_axis_id: Some(int),
            error_code: Some(int),
            brake_state: Some([int; 6]),
            axis_status: Some([int; 6]),
            axis_error_code: Some([int; 6]),
            reset_safe_space: full_i(MAX_AXIS_GROUPS).collect(),
            axis_group_status: full_i(MAX_AXIS_GROUPS).collect(),
            axis_group_error_code: full_i(MAX_AXIS_GROUPS).collect(),
        };
        let count = Some(u64::MAX);
        ds.hard_load = HardLoad {
            ethercat_total_frame: count,
            ethercat_frames_per_second: count,
            ethercat_total_lost_frame: count,
            ethercat_tx_error_frame: count,
            ethercat_rx_error_frame: count,
            box48_in_voltage: Some(big),
            box48_in_current: Some(big),
            box48_out_voltage: Some(big),
            box48_out_current: Some(big),
            slave_temperature: (0..MAX_SLAVES).map(|_| big).collect(),
            slave_voltage: (0..MAX_SLAVES).map(|_| big).collect(),
        };
        ds.ft = FtData {
            control_state: Some(int),
            data: Some(big6),
            src_data: Some(big6),
        };
        ds.script.error_code = Some(int);
        let mut buf = [0u8; DataSheet::MAX_JSON_LEN];
        let n = ds.write_json(&mut buf).unwrap();
        assert!(n > DataSheet::MAX_JSON_LEN * 3 / 4, "bound too loose: {n}");
        assert_eq!(DataSheet::parse(&buf[..n]).unwrap(), ds);
    }
}
