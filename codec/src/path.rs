//! Parameter types of the path commands the V6 document adds (section
//! 4.11, from `HR6.3.3`): the Cartesian part of `InitPath` and the two
//! shapes of the `ReadPath` reply.
//!
//! A path ("轨迹") has raw points (joint or Cartesian, `nRawDataType`) and
//! is computed twice by the controller: once to run with `MovePathJ`, once
//! with `MovePathL`. Each computation has its own state (`stateJ`,
//! `stateL`): 0 not taught, 1 teaching, 2 computing, 3 computed, 4 teaching
//! ended, 5 computation error (with an error code), 9 imported, 10
//! processing an import.

use core::fmt;

use crate::error::{ErrorCode, Expected, Got};
use crate::grammar::Cursor;
use crate::number::Decimal;
use crate::types::{Field, Param, Pose, TextList, Visitor};
use crate::writer::Writer;

/// The parameters `InitPath` needs to compute the `MovePathL` form of a
/// path: required when the raw points are Cartesian (`nRawDataType` 1),
/// omitted otherwise (the controller then uses its maximum values, `Base`
/// and `TCP`). Sent as five fields after the radius.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CartesianPath<'a> {
    /// `dVelocity`: [mm/s].
    pub velocity: Decimal,
    /// `dAcc`: [mm/s²].
    pub acc: Decimal,
    /// `dJerk`: [mm/s³].
    pub jerk: Decimal,
    /// `sUcsName`: user frame name (sent before the tool name).
    pub ucs_name: &'a str,
    /// `sTcpName`: tool frame name.
    pub tcp_name: &'a str,
}

impl<'a> Field<'a> for CartesianPath<'a> {
    const BLANK: Self = CartesianPath {
        velocity: Decimal::ZERO,
        acc: Decimal::ZERO,
        jerk: Decimal::ZERO,
        ucs_name: "",
        tcp_name: "",
    };
    fn read(c: &mut Cursor<'_, 'a>, param: Param) -> Self {
        CartesianPath {
            velocity: Decimal::read(c, param),
            acc: Decimal::read(c, param),
            jerk: Decimal::read(c, param),
            ucs_name: <&str>::read(c, param),
            tcp_name: <&str>::read(c, param),
        }
    }
    fn write(&self, w: &mut Writer<'_>, param: Param) {
        self.velocity.write(w, param);
        self.acc.write(w, param);
        self.jerk.write(w, param);
        self.ucs_name.write(w, param);
        self.tcp_name.write(w, param);
    }
    fn visit(&self, _: &str, v: &mut dyn Visitor) {
        v.num("velocity", self.velocity);
        v.num("acc", self.acc);
        v.num("jerk", self.jerk);
        v.text("ucs_name", self.ucs_name);
        v.text("tcp_name", self.tcp_name);
    }
}

/// What `ReadPath` replies about one path (the request named it).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PathInfo {
    /// `nRawDataType`: 0 = joint raw points, 1 = Cartesian.
    pub raw_data_type: i32,
    /// `stateJ`: state of the `MovePathJ` computation (see the module).
    pub state_j: i32,
    /// `ErrorCodeJ`: its error, when `state_j` is 5.
    pub error_j: ErrorCode,
    /// `stateL`: state of the `MovePathL` computation.
    pub state_l: i32,
    /// `ErrorCodeL`: its error, when `state_l` is 5.
    pub error_l: ErrorCode,
    /// `dbOverride`: speed ratio (`MovePathJ` only).
    pub speed_ratio: Decimal,
    /// `dbRadius`: blend radius \[mm\] (`MovePathJ` only).
    pub radius: Decimal,
    /// `dbLinearVel`: [mm/s] (`MovePathL` only).
    pub velocity: Decimal,
    /// `dbLinearAcc`: [mm/s²] (`MovePathL` only).
    pub acc: Decimal,
    /// `dbLinearJerk`: [mm/s³] (`MovePathL` only).
    pub jerk: Decimal,
    /// `dUcs_X..Rz`: the user frame of the `MovePathL` computation [mm, °].
    pub ucs: Pose,
    /// `dTcp_X..Rz`: the tool frame of the `MovePathL` computation [mm, °].
    pub tcp: Pose,
    /// `nRawPointCount`: raw points taught.
    pub raw_points: i32,
    /// `HeadPoint[]`: the first raw point (joints or a pose), sent when
    /// there is one.
    pub first_point: Option<[Decimal; 6]>,
}

/// Fields of a [`PathInfo`] with its first point, and without.
const INFO_FIELDS: [u16; 2] = [29, 23];

impl<'a> Field<'a> for PathInfo {
    const BLANK: Self = PathInfo {
        raw_data_type: 0,
        state_j: 0,
        error_j: ErrorCode::Unknown(0),
        state_l: 0,
        error_l: ErrorCode::Unknown(0),
        speed_ratio: Decimal::ZERO,
        radius: Decimal::ZERO,
        velocity: Decimal::ZERO,
        acc: Decimal::ZERO,
        jerk: Decimal::ZERO,
        ucs: [Decimal::ZERO; 6],
        tcp: [Decimal::ZERO; 6],
        raw_points: 0,
        first_point: None,
    };
    fn read(c: &mut Cursor<'_, 'a>, param: Param) -> Self {
        let got = c.remaining();
        if !INFO_FIELDS.contains(&got) {
            let want = if got < INFO_FIELDS[1] {
                Expected::AtLeast(INFO_FIELDS[1])
            } else {
                Expected::AtMost(INFO_FIELDS[0])
            };
            c.fail(param, want, Got::Count(got));
            return PathInfo::BLANK;
        }
        PathInfo {
            raw_data_type: i32::read(c, param),
            state_j: i32::read(c, param),
            error_j: ErrorCode::read(c, param),
            state_l: i32::read(c, param),
            error_l: ErrorCode::read(c, param),
            speed_ratio: Decimal::read(c, param),
            radius: Decimal::read(c, param),
            velocity: Decimal::read(c, param),
            acc: Decimal::read(c, param),
            jerk: Decimal::read(c, param),
            ucs: <[Decimal; 6]>::read(c, param),
            tcp: <[Decimal; 6]>::read(c, param),
            raw_points: i32::read(c, param),
            first_point: <Option<[Decimal; 6]>>::read(c, param),
        }
    }
    fn write(&self, w: &mut Writer<'_>, param: Param) {
        self.raw_data_type.write(w, param);
        self.state_j.write(w, param);
        self.error_j.write(w, param);
        self.state_l.write(w, param);
        self.error_l.write(w, param);
        self.speed_ratio.write(w, param);
        self.radius.write(w, param);
        self.velocity.write(w, param);
        self.acc.write(w, param);
        self.jerk.write(w, param);
        self.ucs.write(w, param);
        self.tcp.write(w, param);
        self.raw_points.write(w, param);
        self.first_point.write(w, param);
    }
    fn visit(&self, _: &str, v: &mut dyn Visitor) {
        v.int("raw_data_type", self.raw_data_type);
        v.int("state_j", self.state_j);
        v.int("error_j", self.error_j.code());
        v.int("state_l", self.state_l);
        v.int("error_l", self.error_l.code());
        v.num("speed_ratio", self.speed_ratio);
        v.num("radius", self.radius);
        v.num("velocity", self.velocity);
        v.num("acc", self.acc);
        v.num("jerk", self.jerk);
        self.ucs.visit("ucs", v);
        self.tcp.visit("tcp", v);
        v.int("raw_points", self.raw_points);
        self.first_point.visit("first_point", v);
    }
}

/// The reply of `ReadPath`: the names of every path when the request named
/// none, else what the controller knows of the one named.
///
/// Read against its request (`ReadPath,0,;` expects names,
/// `ReadPath,0,drag_1,;` a [`PathInfo`]). Read without it (a log), 23 or
/// 29 numeric fields whose first two are integers read as a [`PathInfo`],
/// anything else as names.
// As large as its details (~300 bytes): nothing is boxed, the codec does
// not allocate, and a reply is read in place.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PathReply<'a> {
    /// `Pathname1,Pathname2,...`: every path of the controller.
    Names(TextList<'a>),
    /// The path named in the request.
    Info(PathInfo),
}

impl Default for PathReply<'_> {
    fn default() -> Self {
        PathReply::Names(TextList::default())
    }
}

impl fmt::Debug for PathReply<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PathReply::Names(n) => f.debug_tuple("Names").field(n).finish(),
            PathReply::Info(i) => f.debug_tuple("Info").field(i).finish(),
        }
    }
}

/// `true` when the fields at the cursor look like a [`PathInfo`].
fn looks_like_info(c: &Cursor<'_, '_>) -> bool {
    if !INFO_FIELDS.contains(&c.remaining()) {
        return false;
    }
    let mut probe = c.clone();
    let mut integers = 0;
    while let Some(f) = probe.next_field() {
        match Decimal::parse(f) {
            Ok(d) if integers < 2 && d.to_i64().is_some() => integers += 1,
            Ok(_) if integers == 2 => {}
            _ => return false,
        }
    }
    true
}

impl<'a> Field<'a> for PathReply<'a> {
    const BLANK: Self = PathReply::Names(TextList::new(&[]));
    fn read(c: &mut Cursor<'_, 'a>, param: Param) -> Self {
        let info = match c.expected_len() {
            Some(n) => n > 0,
            None => looks_like_info(c),
        };
        if info {
            PathReply::Info(PathInfo::read(c, param))
        } else {
            PathReply::Names(TextList::read(c, param))
        }
    }
    fn write(&self, w: &mut Writer<'_>, param: Param) {
        match self {
            PathReply::Names(n) => n.write(w, param),
            PathReply::Info(i) => i.write(w, param),
        }
    }
    fn visit(&self, name: &str, v: &mut dyn Visitor) {
        match self {
            PathReply::Names(n) => n.visit("names", v),
            PathReply::Info(i) => i.visit(name, v),
        }
    }
}
