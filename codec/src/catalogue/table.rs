//! THE command table: every command of chapter 4 of HR-TCP V1.0.0.3 and,
//! with the `v6` feature, every command the V6 document (V1.0.19.1) adds,
//! each declared once, in document order.
//!
//! Entry syntax:
//!
//! ```text
//! /// description
//! Name<'a> = "WireName" | "Alias" @ v5 "4.5.15" v6 "4.5.20",
//!     since "HR5.50.3", removed "HR6.5.0", changed "HR6.3.3", len = |r| <reply list length>;
//! { /// doc   param: Type = range, ... }      // request, wire order
//! => <'a> { /// doc   value: Type, ... }      // success reply, wire order
//! ```
//!
//! * `@ v5 ... v6 ...`: the command's section in the HR-TCP V1.0.0.3
//!   document and in the V6 document (`v5` only: gone from the V6 document;
//!   `v6` only: new in it).
//! * `since`, `removed`, `changed`: the controller versions of the V6
//!   document's revision table ([`ProtocolLevel`]); no `since` means the V5
//!   level (the commands of HR-TCP V1.0.0.3, and those the revision table
//!   gives for all controllers). What changed is said in the entry's doc.
//! * `len`: for replies whose length depends on the request, that length.
//! * `reply = by_hand`: the reply's reader and writer are written by hand
//!   in `quirks` (a shape the table cannot say).
//! * A parameter marked `#[cfg(feature = "v6")]` is one the V6 document adds
//!   to a command of HR-TCP V1.0.0.3.
//!
//! Parameter names are snake_case versions of the document's (`nRbtID` →
//! `rbt_id`); each doc line gives the document's name, unit and valid
//! range. Ranges marked with `=` are checked by `validate()`, not by
//! parsing: an out-of-range request still parses so that a controller (or
//! the simulator) can answer it with `Fail,20006`. Where the two documents
//! give different ranges, the table has the union (each such case says so).
//!
//! Deviations from the document's signatures, each from `NOTES.md`:
//! `ReadBoxAO` takes a channel list like `ReadBoxAI`; `SetMaxAcsRange` has
//! 1 + 12 parameters; `ReadLinearMaxVel` replies 3 values; `ReadFTControlState`
//! sends only `nRbtID`; `MoveRelL`'s `nToolMotion` may be omitted; `MoveJ`
//! and `MoveL` send the tool name first; `InitMovePathL` sends the UCS name
//! before the TCP name; `PushServoP` and `WayPointEx` send the UCS block
//! before the TCP block; `PushMovePaths` and `SetMoveTraceInitParams` follow
//! their tables; `ReadSoftMotionProgress` is the wire name (the heading says
//! `...Process`, accepted as an alias); `Base2UcsTcp` has 6 + 6 + 6 values
//! (its signature lacks `dUcs_Ry`). `HRSetControlGoal`'s six distances may be
//! omitted (the vendor SDK sends them only sometimes) and `ReadBoxInfo`
//! replies with 6 or 8 values. The V6 document's own deviations are listed
//! in `host-tests/vectors/v6/DEFECTS.md`.

use super::{catalogue, catalogue_items, first_section, level_of, maybe_level, maybe_section};
use super::{
    encode_with, parse_request_as, reply_message, Command, Message, ReplyExpect, ReplyValues,
};
use super::{range_entry, read_known, request_head, validate_with, visit_raw};
#[cfg(feature = "v6")]
use crate::error::ErrorCode;
use crate::error::{EncodeError, ParseError, RangeError};
use crate::fsm::FsmState;
use crate::grammar::{Cursor, RawMessage};
use crate::level::{LevelError, ProtocolLevel};
use crate::number::Decimal;
#[cfg(feature = "v6")]
use crate::path::{CartesianPath, PathReply};
use crate::types::{
    above, at_least, either, int, num, CountedList, Field, Joints, Param, PointList, Pose, Range,
    RobotId, TextList, Visitor,
};
#[cfg(feature = "v6")]
use crate::types::{FreeText, ValueGroups};
use crate::writer::Writer;

/// `nRbtID`: 0-5.
const RBT: Range = int(0, 5);
/// A 0/1 switch.
const FLAG: Range = int(0, 1);
/// A box digital I/O bit index 0-7.
const BOX_BIT: Range = int(0, 7);

catalogue! {
v5 {
    // ---------------------------------------------------------------- 4.1
    /// Controller power off: stop, disable, cut 48 V (and optionally reboot).
    OSCmd = "OSCmd" @ v5 "4.1.1" v6 "4.1.1";
    {
        /// `nCmdType`: 1 = stop, disable, cut 48 V; 2 = the same, then restart the OS.
        cmd_type: i32 = int(1, 2),
    } => {}

    /// Connect to the electric box.
    ConnectToBox = "ConnectToBox" @ v5 "4.1.2" v6 "4.1.2";
    {} => {}

    /// Switch robot (48 V) power on.
    Electrify = "Electrify" @ v5 "4.1.3" v6 "4.1.3";
    {} => {}

    /// Switch robot (48 V) power off.
    BlackOut = "BlackOut" @ v5 "4.1.4" v6 "4.1.4";
    {} => {}

    /// Connect to the controller (starts the EtherCAT master).
    StartMaster = "StartMaster" @ v5 "4.1.5" v6 "4.1.5";
    {} => {}

    /// Disconnect from the controller (closes the master).
    CloseMaster = "CloseMaster" @ v5 "4.1.6" v6 "4.1.6";
    {} => {}

    /// Whether the robot is simulated.
    IsSimulation = "IsSimulation" @ v5 "4.1.7" v6 "4.1.7";
    {} => {
        /// `nSimulateRobot`: 0 = real robot, 1 = simulated.
        simulated: i32,
    }

    /// Whether the controller has finished starting.
    ReadControllerState = "ReadControllerState" @ v5 "4.1.8" v6 "4.1.8";
    {} => {
        /// `nStarted`: 0 = not started, 1 = started.
        started: i32,
    }

    /// The robot model.
    ReadRobotModel = "ReadRobotModel" @ v5 "4.1.9" v6 "4.1.10";
    {} => <'a> {
        /// `strModel`: model name, e.g. `5KG`.
        model: &'a str,
    }

    // ---------------------------------------------------------------- 4.2
    /// Enable the axis group (servo on). SDKs also send `GrpPowerOn`.
    GrpEnable = "GrpEnable" | "GrpPowerOn" @ v5 "4.2.1" v6 "4.2.1";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {}

    /// Disable the axis group (servo off). SDKs also send `GrpPowerOff`.
    GrpDisable = "GrpDisable" | "GrpPowerOff" @ v5 "4.2.2" v6 "4.2.2";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {}

    /// Reset (clear errors).
    GrpReset = "GrpReset" @ v5 "4.2.3" v6 "4.2.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {}

    /// Stop the motion.
    GrpStop = "GrpStop" @ v5 "4.2.4" v6 "4.2.4";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {}

    /// Pause the motion.
    GrpInterrupt = "GrpInterrupt" @ v5 "4.2.5" v6 "4.2.5";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {}

    /// Continue a paused motion.
    GrpContinue = "GrpContinue" @ v5 "4.2.6" v6 "4.2.6";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {}

    /// Close free drive.
    GrpCloseFreeDriver = "GrpCloseFreeDriver" @ v5 "4.2.7" v6 "4.2.7";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {}

    /// Open free drive (hand guiding).
    GrpOpenFreeDriver = "GrpOpenFreeDriver" @ v5 "4.2.8" v6 "4.2.8";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {}

    // ---------------------------------------------------------------- 4.3
    /// Run a script function by name.
    RunFunc<'a> = "RunFunc" @ v5 "4.3.1" v6 "4.3.1";
    {
        /// `strFuncName`: the script function (as named on the teach pendant).
        func_name: &'a str,
        /// `sParams1..n`: its parameters, any number.
        params: TextList<'a>,
    } => <'a> {
        /// `strName`: the function that runs.
        func_name: &'a str,
    }

    /// Run the compiled script's `Func_main`.
    StartScript = "StartScript" @ v5 "4.3.2" v6 "4.3.2";
    {} => {}

    /// Stop the running script.
    StopScript = "StopScript" @ v5 "4.3.3" v6 "4.3.3";
    {} => {}

    /// Pause the running script.
    PauseScript = "PauseScript" @ v5 "4.3.4" v6 "4.3.4";
    {} => {}

    /// Continue a paused script (`Fail,20018` when not paused).
    ContinueScript = "ContinueScript" @ v5 "4.3.5" v6 "4.3.5";
    {} => {}

    // ---------------------------------------------------------------- 4.4
    /// Electric box information.
    ReadBoxInfo = "ReadBoxInfo" @ v5 "4.4.1" v6 "4.4.1", changed "HR6.3.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `nConnected`: box connected, 0/1.
        connected: i32,
        /// `n48V_ON`: 48 V present (> 36 V), 0/1.
        power_48v: i32,
        /// `db48OUT_Voltag`: 48 V output voltage \[V\], 0-53.
        out_voltage: Decimal,
        /// `db48OUT_Current`: 48 V output current \[A\].
        out_current: Decimal,
        /// `nRemoteBTN`: remote shutdown button signal, 0/1.
        remote_button: i32,
        /// `nThreeStageBTN`: three-position enabling button signal, 0/1.
        three_stage_button: i32,
        /// 12 V voltage \[V\]; newer firmware only (8-value reply).
        voltage_12v: Option<Decimal>,
        /// 12 V current \[A\]; newer firmware only (8-value reply).
        current_12v: Option<Decimal>,
    }

    /// Box control digital inputs (CI), 1-8 bits per request.
    ReadBoxCI = "ReadBoxCI" @ v5 "4.4.2" v6 "4.4.2", len = |r| r.bits.len();
    {
        /// `nBit0..7`: bit indices 0-7, one to eight of them.
        bits: heapless::Vec<i32, 8> = BOX_BIT,
    } => {
        /// `nVal0..7`: one level (0/1) per bit asked for.
        values: heapless::Vec<i32, 8>,
    }

    /// Box general digital inputs (DI), 1-8 bits per request.
    ReadBoxDI = "ReadBoxDI" @ v5 "4.4.3" v6 "4.4.3", len = |r| r.bits.len();
    {
        /// `nBit0..7`: bit indices 0-7, one to eight of them.
        bits: heapless::Vec<i32, 8> = BOX_BIT,
    } => {
        /// `nVal0..7`: one level (0/1) per bit asked for.
        values: heapless::Vec<i32, 8>,
    }

    /// Box control digital outputs (CO), 1-8 bits per request.
    ReadBoxCO = "ReadBoxCO" @ v5 "4.4.4" v6 "4.4.4", len = |r| r.bits.len();
    {
        /// `nBit0..7`: bit indices 0-7, one to eight of them.
        bits: heapless::Vec<i32, 8> = BOX_BIT,
    } => {
        /// `nVal0..7`: one level (0/1) per bit asked for.
        values: heapless::Vec<i32, 8>,
    }

    /// Box general digital outputs (DO), 1-8 bits per request.
    ReadBoxDO = "ReadBoxDO" @ v5 "4.4.5" v6 "4.4.5", len = |r| r.bits.len();
    {
        /// `nBit0..7`: bit indices 0-7, one to eight of them.
        bits: heapless::Vec<i32, 8> = BOX_BIT,
    } => {
        /// `nVal0..7`: one level (0/1) per bit asked for.
        values: heapless::Vec<i32, 8>,
    }

    /// Box analog inputs, one or two channels.
    ReadBoxAI = "ReadBoxAI" @ v5 "4.4.6" v6 "4.4.6", len = |r| r.channels.len();
    {
        /// `nBit0..1`: channels 0/1, one or two of them.
        channels: heapless::Vec<i32, 2> = FLAG,
    } => {
        /// `dVal0..1`: one value per channel [mA in current mode 4-20, V in voltage mode 0-10].
        values: heapless::Vec<Decimal, 2>,
    }

    /// Box analog outputs, one or two channels (read like `ReadBoxAI`, see
    /// `NOTES.md`). HR-TCP V1.0.0.3's example replies one value per
    /// channel; the V6 document's, and the vendor SDK, the mode and the value
    /// of each channel (`ReadBoxAO,0,1,;` → `ReadBoxAO,OK,1,2.000,2,8.000,;`).
    /// With `v6` both are read (`quirks`); without, only the first.
    ReadBoxAO = "ReadBoxAO" @ v5 "4.4.7" v6 "4.4.7", len = |r| r.channels.len(), reply = by_hand;
    {
        /// `nBit`: channels 0/1, one or two of them.
        channels: heapless::Vec<i32, 2> = FLAG,
    } => {
        /// `dVal`: one value per channel [mA or V, 0-20].
        values: heapless::Vec<Decimal, 2>,
        /// `nType`: the mode of each channel, 1 = voltage, 2 = current; in
        /// replies of the V6 form only.
        #[cfg(feature = "v6")]
        modes: Option<heapless::Vec<i32, 2>>,
    }

    /// Set a box control digital output (CO).
    SetBoxCO = "SetBoxCO" @ v5 "4.4.8" v6 "4.4.8";
    {
        /// `nBit`: bit index 0-7.
        bit: i32 = BOX_BIT,
        /// `nVal`: 0 = low, 1 = high.
        value: i32 = FLAG,
    } => {}

    /// Set a box general digital output (DO).
    SetBoxDO = "SetBoxDO" @ v5 "4.4.9" v6 "4.4.9";
    {
        /// `nBit`: bit index 0-7.
        bit: i32 = BOX_BIT,
        /// `nVal`: 0 = low, 1 = high.
        value: i32 = FLAG,
    } => {}

    /// Set a box analog output's mode.
    SetBoxAOMode = "SetBoxAOMode" @ v5 "4.4.10" v6 "4.4.10";
    {
        /// `nBit`: channel 0/1.
        channel: i32 = FLAG,
        /// `nMode`: 1 = voltage, 2 = current.
        mode: i32 = int(1, 2),
    } => {}

    /// Set a box analog output's value and mode.
    SetBoxAO = "SetBoxAO" @ v5 "4.4.11" v6 "4.4.11";
    {
        /// `nBit`: channel 0/1.
        channel: i32 = FLAG,
        /// `dVal`: value [mA 4-20 in current mode, V 0-10 in voltage mode], 0-20.
        value: Decimal = num("0", "20"),
        /// `nMode`: 1 = voltage, 2 = current.
        mode: i32 = int(1, 2),
    } => {}

    /// Set a tool-end digital output.
    SetEndDO = "SetEndDO" @ v5 "4.4.12" v6 "4.4.12", changed "HR6.5.14";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nBit`: end output index 0-3.
        bit: i32 = int(0, 3),
        /// `nVal`: 0 = low, 1 = high.
        value: i32 = FLAG,
    } => {}

    /// Tool-end digital inputs, 1-3 bits per request.
    ReadEI = "ReadEI" @ v5 "4.4.13" v6 "4.4.13", len = |r| r.bits.len();
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nBit0..2`: end input indices 0-2, one to three of them.
        bits: heapless::Vec<i32, 3> = int(0, 2),
    } => {
        /// `nVal0..2`: one level (0/1) per bit asked for.
        values: heapless::Vec<i32, 3>,
    }

    /// Tool-end digital outputs, 1-3 bits per request.
    ReadEO = "ReadEO" @ v5 "4.4.14" v6 "4.4.14", len = |r| r.bits.len();
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nBit0..2`: end output indices 0-2, one to three of them.
        bits: heapless::Vec<i32, 3> = int(0, 2),
    } => {
        /// `nVal0..2`: one level (0/1) per bit asked for.
        values: heapless::Vec<i32, 3>,
    }

    /// A tool-end analog input.
    ReadEAI = "ReadEAI" @ v5 "4.4.15" v6 "4.4.15";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nBit`: channel 0/1.
        channel: i32 = FLAG,
    } => {
        /// `dVal`: value [mA 4-20 or V 0-10], 0-20.
        value: Decimal,
    }

    // ---------------------------------------------------------------- 4.5
    /// Set the speed override (not while moving).
    SetOverride = "SetOverride" @ v5 "4.5.1" v6 "4.5.1";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dOverride`: speed ratio 0.01-1.
        ratio: Decimal = num("0.01", "1"),
    } => {}

    /// Switch tool-frame motion mode. SDKs also send `SetTCPMotion`.
    SetToolMotion = "SetToolMotion" | "SetTCPMotion" @ v5 "4.5.2" v6 "4.5.2";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nState`: 0 = off, 1 = on.
        state: i32 = FLAG,
    } => {}

    /// Set the payload.
    SetPayload = "SetPayload" @ v5 "4.5.3" v6 "4.5.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dMass`: mass \[kg\], 0 to the model's maximum payload.
        mass: Decimal = at_least("0"),
        /// `dX, dY, dZ`: centre-of-mass offset \[mm\], each >= 0.
        center: [Decimal; 3] = at_least("0"),
        /// `bUpdateDB` (V6 document, may be omitted = 1): 1 = set mass and
        /// centre of mass, 3 = set the mass only; both saved.
        #[cfg(feature = "v6")]
        update_db: Option<i32> = either("1", "3"),
    } => {}

    /// Set the joints' maximum velocities.
    SetJointMaxVel = "SetJointMaxVel" @ v5 "4.5.4" v6 "4.5.4";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dJ1..dJ6`: maximum velocity [°/s], 0-200 (model dependent).
        joints: Joints = num("0", "200"),
    } => {}

    /// Set the joints' maximum accelerations.
    SetJointMaxAcc = "SetJointMaxAcc" @ v5 "4.5.5" v6 "4.5.5";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dJ1..dJ6`: maximum acceleration [°/s²], 0-720 (model dependent).
        joints: Joints = num("0", "720"),
    } => {}

    /// Set the maximum linear velocity.
    SetLinearMaxVel = "SetLinearMaxVel" @ v5 "4.5.6" v6 "4.5.6";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dMaxVel`: [mm/s], 0-3000, default 2000.
        max_vel: Decimal = num("0", "3000"),
    } => {}

    /// Set the maximum linear acceleration.
    SetLinearMaxAcc = "SetLinearMaxAcc" @ v5 "4.5.7" v6 "4.5.7";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dMaxAcc`: [mm/s²], 0-2500, default 2500.
        max_acc: Decimal = num("0", "2500"),
    } => {}

    /// Set the joint-space limits.
    SetMaxAcsRange = "SetMaxAcsRange" @ v5 "4.5.8" v6 "4.5.8";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dMaxJ1..dMaxJ6`: upper limits [°].
        max: Joints,
        /// `dMinJ1..dMinJ6`: lower limits [°].
        min: Joints,
    } => {}

    /// Set the Cartesian-space limits.
    SetMaxPcsRange = "SetMaxPcsRange" @ v5 "4.5.9" v6 "4.5.9";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dMaxX..dMaxRz`: upper limits [mm, °] (rotations unused, 0).
        max: Pose,
        /// `dMinX..dMinRz`: lower limits [mm, °].
        min: Pose,
        /// `dUcs_X..dUcs_Rz`: the user frame the limits are in [mm, °].
        ucs: Pose,
    } => {}

    /// The joints' maximum velocities.
    ReadJointMaxVel = "ReadJointMaxVel" @ v5 "4.5.10" v6 "4.5.15";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dJ1..dJ6`: [°/s].
        joints: Joints,
    }

    /// The joints' maximum accelerations.
    ReadJointMaxAcc = "ReadJointMaxAcc" @ v5 "4.5.11" v6 "4.5.16";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dJ1..dJ6`: [°/s²].
        joints: Joints,
    }

    /// The joints' maximum jerks.
    ReadJointMaxJerk = "ReadJointMaxJerk" @ v5 "4.5.12" v6 "4.5.17";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dJ1..dJ6`: [°/s³], 0-3600.
        joints: Joints,
    }

    /// Linear motion limits.
    ReadLinearMaxVel = "ReadLinearMaxVel" @ v5 "4.5.13" v6 "4.5.18";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dMaxVel`: [mm/s].
        max_vel: Decimal,
        /// `dMaxAcc`: [mm/s²].
        max_acc: Decimal,
        /// `dMaxJerk`: [mm/s³].
        max_jerk: Decimal,
    }

    /// Emergency-stop and safety-guard circuits.
    ReadEmergencyInfo = "ReadEmergencyInfo" @ v5 "4.5.14" v6 "4.5.19";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `nESTO_Error`: the two e-stop channels disagree, 0/1.
        estop_error: i32,
        /// `nESTO`: emergency stop active, 0/1.
        estop: i32,
        /// `nSafetyGuard_Error`: the two safety-guard channels disagree, 0/1.
        safety_guard_error: i32,
        /// `nSafetyGuard`: safety guard active, 0/1.
        safety_guard: i32,
    }

    /// The robot's state flags; poll it to follow a motion (chapter 6).
    ReadRobotState = "ReadRobotState" @ v5 "4.5.15" v6 "4.5.20", changed "HR6.2.17";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `nMovingState`: 1 while moving.
        moving: i32,
        /// `nEnableState`: 1 when enabled.
        enabled: i32,
        /// `nErrorState`: 1 when an error is active.
        error: i32,
        /// `nErrorCode`: the robot's error code.
        error_code: i32,
        /// `nErrorAxis`: the axis in error, 0-5.
        error_axis: i32,
        /// `nBreaking`: 0 = brakes applied, 1 = released.
        brake_released: i32,
        /// `nPause`: 1 when paused.
        paused: i32,
        /// `nEmergencyStop`: 1 in emergency stop.
        emergency_stop: i32,
        /// `nSaftyGuard`: 1 when the safety guard is active.
        safety_guard: i32,
        /// `nElectrify`: 1 when powered.
        powered: i32,
        /// `nIsConnectToBox`: 1 when the box is connected.
        box_connected: i32,
        /// `nBlendingDone`: 1 when the way-point motion is done.
        blending_done: i32,
        /// `nInPos`: 1 when the actual position reached the command position.
        in_position: i32,
    }

    /// The id of the way point being executed.
    ReadCurWayPointID = "ReadCurWayPointID" @ v5 "4.5.16" v6 "4.5.21";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => <'a> {
        /// `strCurWaypointID`: the `strCmdID` of the current way point.
        id: &'a str,
    }

    /// Axis error codes.
    ReadAxisErrorCode = "ReadAxisErrorCode" @ v5 "4.5.17" v6 "4.5.22";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `nErrorCode`: group error code, 0 when none.
        code: i32,
        /// `nJ1..nJ6`: per-axis error codes, 0 when none.
        axes: [i32; 6],
    }

    /// The FSM state.
    ReadCurFSM = "ReadCurFSM" @ v5 "4.5.18" v6 "4.5.23";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `nCurFSM`: the state, see [`FsmState`].
        state: FsmState,
    }

    // ---------------------------------------------------------------- 4.6
    /// Actual joint position, Cartesian pose, current TCP and UCS.
    ReadActPos = "ReadActPos" @ v5 "4.6.1" v6 "4.6.1";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dJ1..dJ6`: actual joints [°].
        joints: Joints,
        /// `dX..dRz`: actual pose [mm, °].
        pose: Pose,
        /// `dTcp_X..dTcp_Rz`: current tool frame [mm, °].
        tcp: Pose,
        /// `dUcs_X..dUcs_Rz`: current user frame [mm, °].
        ucs: Pose,
    }

    /// Command joint position and Cartesian pose.
    ReadCmdPos = "ReadCmdPos" @ v5 "4.6.2" v6 "4.6.2";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dJ1..dJ6`: command joints [°].
        joints: Joints,
        /// `dX..dRz`: command pose [mm, °].
        pose: Pose,
    }

    /// Command joint velocities.
    ReadCmdJointVel = "ReadCmdJointVel" @ v5 "4.6.3" v6 "4.6.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dJ1..dJ6`: [°/s].
        joints: Joints,
    }

    /// Actual joint velocities.
    ReadActJointVel = "ReadActJointVel" @ v5 "4.6.4" v6 "4.6.4";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dJ1..dJ6`: [°/s].
        joints: Joints,
    }

    /// Command TCP velocity.
    ReadCmdTcpVel = "ReadCmdTcpVel" @ v5 "4.6.5" v6 "4.6.5";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dX..dRz`: [mm/s, °/s].
        velocity: Pose,
    }

    /// Actual TCP velocity.
    ReadActTcpVel = "ReadActTcpVel" @ v5 "4.6.6" v6 "4.6.6";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dX..dRz`: [mm/s, °/s].
        velocity: Pose,
    }

    /// Command joint currents.
    ReadCmdJointCur = "ReadCmdJointCur" @ v5 "4.6.7" v6 "4.6.7";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dJ1..dJ6`: \[A\].
        joints: Joints,
    }

    /// Actual joint currents.
    ReadActJointCur = "ReadActJointCur" @ v5 "4.6.8" v6 "4.6.8";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dJ1..dJ6`: \[A\].
        joints: Joints,
    }

    /// Combined XYZ speed of the TCP.
    ReadTcpVelocity = "ReadTcpVelocity" @ v5 "4.6.9" v6 "4.6.9";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dCmdVel`: command speed [mm/s].
        cmd: Decimal,
        /// `dActVel`: actual speed [mm/s].
        act: Decimal,
    }

    // ---------------------------------------------------------------- 4.7
    /// Quaternion to roll-pitch-yaw.
    Quaternion2RPY = "Quaternion2RPY" @ v5 "4.7.1" v6 "4.7.1";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dQuaW, dQuaX, dQuaY, dQuaZ`.
        quaternion: [Decimal; 4],
    } => {
        /// `dRx, dRy, dRz`: [°], -180-180.
        rpy: [Decimal; 3],
    }

    /// Roll-pitch-yaw to quaternion.
    RPY2Quaternion = "RPY2Quaternion" @ v5 "4.7.2" v6 "4.7.2";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `Rx, Ry, Rz`: [°], -180-180.
        rpy: [Decimal; 3] = num("-180", "180"),
    } => {
        /// `dQuaW, dQuaX, dQuaY, dQuaZ`.
        quaternion: [Decimal; 4],
    }

    /// Inverse kinematics: pose in a TCP/UCS to joints. Also `PCS2ACS`.
    GetInverseKin = "GetInverseKin" | "PCS2ACS" @ v5 "4.7.3" v6 "4.7.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dX..dRz`: target pose [mm, °].
        pose: Pose,
        /// `dJ1..dJ6`: reference joints choosing among solutions [°].
        reference: Joints,
        /// `dTcp_X..dTcp_Rz`: tool frame (all 0 for none) [mm, °].
        tcp: Pose,
        /// `dUcs_X..dUcs_Rz`: user frame (all 0 for none) [mm, °].
        ucs: Pose,
    } => {
        /// `dTargetJ1..dTargetJ6`: [°].
        joints: Joints,
    }

    /// Forward kinematics: joints to a pose in a TCP/UCS. Also `ACS2PCS`.
    GetForwardKin = "GetForwardKin" | "ACS2PCS" @ v5 "4.7.4" v6 "4.7.4";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dJ1..dJ6`: joints [°].
        joints: Joints,
        /// `dTcp_X..dTcp_Rz`: tool frame (all 0 for none) [mm, °].
        tcp: Pose,
        /// `dUcs_X..dUcs_Rz`: user frame (all 0 for none) [mm, °].
        ucs: Pose,
    } => {
        /// `dX..dRz`: [mm, °].
        pose: Pose,
    }

    /// A base-frame pose expressed in a UCS and TCP.
    Base2UcsTcp = "Base2UcsTcp" @ v5 "4.7.5" v6 "4.7.5";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dX..dRz`: pose in the base frame [mm, °].
        pose: Pose,
        /// `dTcp_X..dTcp_Rz`: tool frame [mm, °].
        tcp: Pose,
        /// `dUcs_X..dUcs_Rz`: user frame [mm, °].
        ucs: Pose,
    } => {
        /// `dTargetX..dTargetRz`: [mm, °].
        pose: Pose,
    }

    /// A pose in a UCS and TCP expressed in the base frame.
    UcsTcp2Base = "UcsTcp2Base" @ v5 "4.7.6" v6 "4.7.6";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dX..dRz`: pose in the user frame [mm, °].
        pose: Pose,
        /// `dTcp_X..dTcp_Rz`: tool frame [mm, °].
        tcp: Pose,
        /// `dUcs_X..dUcs_Rz`: user frame [mm, °].
        ucs: Pose,
    } => {
        /// `dTargetX..dTargetRz`: [mm, °].
        pose: Pose,
    }

    /// Pose "addition": the second pose left-multiplies the first.
    PoseAdd = "PoseAdd" @ v5 "4.7.7" v6 "4.7.7";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dPose1_X..dPose1_Rz`: [mm, °].
        pose1: Pose,
        /// `dPose2_X..dPose2_Rz`: [mm, °].
        pose2: Pose,
    } => {
        /// `dTargetX..dTargetRz`: [mm, °].
        pose: Pose,
    }

    /// Pose "subtraction", relative to the second pose.
    PoseSub = "PoseSub" @ v5 "4.7.8" v6 "4.7.8";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dPose1_X..dPose1_Rz`: [mm, °].
        pose1: Pose,
        /// `dPose2_X..dPose2_Rz`: [mm, °].
        pose2: Pose,
    } => {
        /// `dTargetX..dTargetRz`: [mm, °].
        pose: Pose,
    }

    /// Frame transformation of two poses.
    PoseTrans = "PoseTrans" @ v5 "4.7.9" v6 "4.7.9";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dPose1_X..dPose1_Rz`: [mm, °].
        pose1: Pose,
        /// `dPose2_X..dPose2_Rz`: [mm, °].
        pose2: Pose,
    } => {
        /// `dTargetX..dTargetRz`: [mm, °].
        pose: Pose,
    }

    /// Inverse of a pose.
    PoseInverse = "PoseInverse" @ v5 "4.7.10" v6 "4.7.10";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dPose1_X..dPose1_Rz`: [mm, °].
        pose: Pose,
    } => {
        /// `dTargetX..dTargetRz`: [mm, °].
        pose: Pose,
    }

    /// Distance and orientation difference between two poses.
    PoseDist = "PoseDist" @ v5 "4.7.11" v6 "4.7.11";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dPose1_X..dPose1_Rz`: [mm, °].
        pose1: Pose,
        /// `dPose2_X..dPose2_Rz`: [mm, °].
        pose2: Pose,
    } => {
        /// `dDistance`: \[mm\].
        distance: Decimal,
        /// `dAngle`: [°].
        angle: Decimal,
    }

    /// Linear interpolation between two poses.
    PoseInterpolate = "PoseInterpolate" @ v5 "4.7.12" v6 "4.7.12";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dPose1_X..dPose1_Rz`: [mm, °].
        pose1: Pose,
        /// `dPose2_X..dPose2_Rz`: [mm, °].
        pose2: Pose,
        /// `dAlpha`: 0 = pose1, 1 = pose2, 0-1.
        alpha: Decimal = num("0", "1"),
    } => {
        /// `dTargetX..dTargetRz`: [mm, °].
        pose: Pose,
    }

    /// A user frame from three points before and three after a rotation.
    /// Also `DefdFrame`.
    PoseDefdFrame = "PoseDefdFrame" | "DefdFrame" @ v5 "4.7.13" v6 "4.7.13";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dPose1_X..Z`: \[mm\].
        p1: [Decimal; 3],
        /// `dPose2_X..Z`: \[mm\].
        p2: [Decimal; 3],
        /// `dPose3_X..Z`: \[mm\].
        p3: [Decimal; 3],
        /// `dPose4_X..Z`: \[mm\].
        p4: [Decimal; 3],
        /// `dPose5_X..Z`: \[mm\].
        p5: [Decimal; 3],
        /// `dPose6_X..Z`: \[mm\].
        p6: [Decimal; 3],
    } => {
        /// `dUcs_X..dUcs_Rz`: [mm, °].
        ucs: Pose,
    }

    // ---------------------------------------------------------------- 4.8
    /// Set the current tool frame (not saved).
    SetCurTCP = "SetCurTCP" @ v5 "4.8.1" v6 "4.8.1";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dTcp_X..dTcp_Rz`: [mm, °].
        tcp: Pose,
    } => {}

    /// Set the current user frame (not saved).
    SetCurUCS = "SetCurUCS" @ v5 "4.8.2" v6 "4.8.2";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dUcs_X..dUcs_Rz`: [mm, °].
        ucs: Pose,
    } => {}

    /// The current tool frame.
    ReadCurTCP = "ReadCurTCP" @ v5 "4.8.3" v6 "4.8.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dTcp_X..dTcp_Rz`: [mm, °].
        tcp: Pose,
    }

    /// The current user frame.
    ReadCurUCS = "ReadCurUCS" @ v5 "4.8.4" v6 "4.8.4";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dUcs_X..dUcs_Rz`: [mm, °].
        ucs: Pose,
    }

    /// Select a taught tool frame by name (`Fail,20029` if unknown).
    SetTCPByName<'a> = "SetTCPByName" @ v5 "4.8.5" v6 "4.8.5";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sTcpName`: tool frame name.
        name: &'a str,
    } => {}

    /// Select a taught user frame by name (`Fail,20030` if unknown).
    SetUCSByName<'a> = "SetUCSByName" @ v5 "4.8.6" v6 "4.8.6";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sUcsName`: user frame name.
        name: &'a str,
    } => {}

    /// A taught tool frame by name.
    ReadTCPByName<'a> = "ReadTCPByName" @ v5 "4.8.7" v6 "4.8.7";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sTcpName`: tool frame name.
        name: &'a str,
    } => {
        /// `dTcp_X..dTcp_Rz`: [mm, °].
        tcp: Pose,
    }

    /// A taught user frame by name.
    ReadUCSByName<'a> = "ReadUCSByName" @ v5 "4.8.8" v6 "4.8.8";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sUcsName`: user frame name.
        name: &'a str,
    } => {
        /// `dUcs_X..dUcs_Rz`: [mm, °].
        ucs: Pose,
    }

    // ---------------------------------------------------------------- 4.9
    /// Switch force control on or off.
    SetForceControlState = "SetForceControlState" @ v5 "4.9.1" v6 "4.9.1";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nState`: 0 = off, 1 = on.
        state: i32 = FLAG,
    } => {}

    /// The force-control state.
    ReadFTControlState = "ReadFTControlState" @ v5 "4.9.2" v6 "4.9.2";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `nState`: 0 off, 1 searching, 2 search done, 3 free drive.
        state: i32,
    }

    /// Use tool-frame directions for force control.
    SetForceToolCoordinateMotion = "SetForceToolCoordinateMotion" @ v5 "4.9.3" v6 "4.9.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nMode`: 0 = off, 1 = on.
        mode: i32 = FLAG,
    } => {}

    /// Pause force control only.
    GrpFCInterrupt = "GrpFCInterrupt" @ v5 "4.9.4" v6 "4.9.4";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {}

    /// Continue force control only.
    GrpFCContinue = "GrpFCContinue" @ v5 "4.9.5" v6 "4.9.5";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {}

    /// Re-zero the force sensor.
    SetForceZero = "SetForceZero" @ v5 "4.9.6" v6 "4.9.6";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {}

    /// Maximum force-search velocities.
    HRSetMaxSearchVelocities = "HRSetMaxSearchVelocities" @ v5 "4.9.7" v6 "4.9.7";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dMaxLinearVelocity`: [mm/s], > 0.
        max_linear: Decimal = above("0"),
        /// `dMaxAngularVelocity`: [°/s], > 0.
        max_angular: Decimal = above("0"),
    } => {}

    /// Force-search degrees of freedom.
    HRSetControlFreedom = "HRSetControlFreedom" @ v5 "4.9.8" v6 "4.9.8";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nX..nRz`: 0 = off, 1 = on, per direction.
        freedom: [i32; 6] = FLAG,
    } => {}

    /// Force-control strategy.
    HRSetForceControlStrategy = "HRSetForceControlStrategy" @ v5 "4.9.9" v6 "4.9.9";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nState`: 0 constant force, 1 compliant, 2 compliant with obstacle crossing.
        strategy: i32 = int(0, 2),
    } => {}

    /// Force sensor mounting pose relative to the flange.
    SetFTPosition = "SetFTPosition" @ v5 "4.9.10" v6 "4.9.10";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dX..dRz`: [mm, °].
        pose: Pose,
    } => {}

    /// Force-search PID parameters.
    HRSetPIDControlParams = "HRSetPIDControlParams" @ v5 "4.9.11" v6 "4.9.11";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dFp, dFi, dFd, dTp, dTi, dTd`.
        pid: [Decimal; 6],
    } => {}

    /// Inertia (mass) control parameters.
    HRSetMassParams = "HRSetMassParams" @ v5 "4.9.12" v6 "4.9.12";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dX..dRz`: per direction.
        mass: [Decimal; 6],
    } => {}

    /// Damping (b) control parameters.
    HRSetDampParams = "HRSetDampParams" @ v5 "4.9.13" v6 "4.9.13";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dX..dRz`: per direction.
        damp: [Decimal; 6],
    } => {}

    /// Stiffness (k) control parameters.
    HRSetStiffParams = "HRSetStiffParams" @ v5 "4.9.14" v6 "4.9.14";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dX..dRz`: per direction.
        stiff: [Decimal; 6],
    } => {}

    /// Force-control target force (and unused target distances).
    HRSetControlGoal = "HRSetControlGoal" @ v5 "4.9.15" v6 "4.9.15";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dX..dRz`: target force [N, N·m].
        force: [Decimal; 6],
        /// `dDistance1..6`: not used yet, 0; may be omitted.
        distance: Option<[Decimal; 6]>,
    } => {}

    /// Force limits beyond which the controller cuts power.
    HRSetForceDataLimit = "HRSetForceDataLimit" @ v5 "4.9.16" v6 "4.9.16", changed "HR6.3.4";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dMax_X..dMax_Rz`: [N, N·m].
        max: [Decimal; 6],
        /// `dMin_X..dMin_Rz`: [N, N·m].
        min: [Decimal; 6],
    } => {}

    /// Force-control deformation range.
    HRSetForceDistanceLimit = "HRSetForceDistanceLimit" @ v5 "4.9.17" v6 "4.9.17";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dAllowDistance`: maximum deformation \[mm\].
        allow_distance: Decimal,
        /// `dStrengthLevel`: exponent of the resistance, 2 or 3.
        strength_level: Decimal = either("2", "3"),
    } => {}

    /// Force-control free drive on or off.
    SetForceFreeDriveMode = "SetForceFreeDriveMode" @ v5 "4.9.18";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nMode`: 0 = off, 1 = on.
        mode: i32 = FLAG,
    } => {}

    /// Calibrated force-sensor data.
    ReadFTCabData = "ReadFTCabData" @ v5 "4.9.19" v6 "4.9.19";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dX..dRz`: [N, N·m].
        data: [Decimal; 6],
    }

    // ---------------------------------------------------------------- 4.10
    /// Relative joint move.
    MoveRelJ = "MoveRelJ" @ v5 "4.10.1" v6 "4.10.1";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nAxisId`: joint J1-J6 as 0-5.
        axis: i32 = int(0, 5),
        /// `nDirection`: 0 = negative, 1 = positive.
        direction: i32 = FLAG,
        /// `dDistance`: [°].
        distance: Decimal,
    } => {}

    /// Relative Cartesian move.
    MoveRelL = "MoveRelL" @ v5 "4.10.2" v6 "4.10.2";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nAxisId`: X, Y, Z, Rx, Ry, Rz as 0-5.
        axis: i32 = int(0, 5),
        /// `nDirection`: 0 = negative, 1 = positive.
        direction: i32 = FLAG,
        /// `dDistance`: [mm or °].
        distance: Decimal,
        /// `nToolMotion`: 0 = user frame, 1 = tool frame; omitted = the frame
        /// chosen on the jog page.
        tool_motion: Option<i32> = FLAG,
    } => {}

    /// Way-point relative move.
    WayPointRel<'a> = "WayPointRel" @ v5 "4.10.3" v6 "4.10.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nType`: 0 = joint relative, 1 = linear relative.
        move_type: i32 = FLAG,
        /// `nPointList`: 1 = use the point below as base.
        use_point_list: i32 = FLAG,
        /// `dPos_X..dPos_Rz`: base pose [mm, °] (0 when unused).
        pose: Pose,
        /// `dPos_J1..dPos_J6`: base joints [°] (0 when unused).
        joints: Joints,
        /// `nrelMoveType`: 0 = absolute, 1 = added.
        rel_move_type: i32 = FLAG,
        /// `nAxisMask_1..6`: 1 = move along this axis/direction.
        axis_mask: [i32; 6] = FLAG,
        /// `dTarget_1..6`: distances per axis [mm, °].
        target: [Decimal; 6],
        /// `sTcpName`: tool frame name (default `TCP`).
        tcp_name: &'a str,
        /// `sUcsName`: user frame name (default `Base`).
        ucs_name: &'a str,
        /// `dVelocity`: [°/s joint, mm/s linear].
        velocity: Decimal,
        /// `dAcc`: [°/s² joint, mm/s² linear].
        acc: Decimal,
        /// `dRadius`: blend radius \[mm\].
        radius: Decimal,
        /// `nIsUseJoint`: 1 = target given as joints.
        use_joint: i32 = FLAG,
        /// `nIsSeek`: 1 = stop when box DI `io_bit` equals `io_state`.
        seek: i32 = FLAG,
        /// `nIOBit`: box DI index 0-7.
        io_bit: i32 = BOX_BIT,
        /// `nIOState`: DI level 0/1.
        io_state: i32 = FLAG,
        /// `strCmdID`: way-point id, free text.
        cmd_id: &'a str,
    } => {}

    /// Way-point move with explicit TCP and UCS values.
    WayPointEx<'a> = "WayPointEx" @ v5 "4.10.4" v6 "4.10.4";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dX..dRz`: target pose [mm, °].
        pose: Pose,
        /// `dJ1..dJ6`: target or reference joints [°].
        joints: Joints,
        /// `dUcs_X..dUcs_Rz`: user frame values [mm, °].
        ucs: Pose,
        /// `dTcp_X..dTcp_Rz`: tool frame values [mm, °].
        tcp: Pose,
        /// `dVelocity`: [°/s joint, mm/s linear].
        velocity: Decimal,
        /// `dAcc`: [°/s² joint, mm/s² linear].
        acc: Decimal,
        /// `dRadius`: blend radius \[mm\].
        radius: Decimal,
        /// `nMoveType`: 0 = joint, 1 = linear.
        move_type: i32 = FLAG,
        /// `nIsUseJoint`: 1 = move to `joints` (joint moves only).
        use_joint: i32 = FLAG,
        /// `nIsSeek`: 1 = stop when box DI `io_bit` equals `io_state`.
        seek: i32 = FLAG,
        /// `nIOBit`: box DI index 0-7.
        io_bit: i32 = BOX_BIT,
        /// `nIOState`: DI level 0/1.
        io_state: i32 = FLAG,
        /// `strCmdID`: way-point id, free text.
        cmd_id: &'a str,
    } => {}

    /// Way-point move with taught TCP and UCS names: the everyday move.
    WayPoint<'a> = "WayPoint" @ v5 "4.10.5" v6 "4.10.5";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dX..dRz`: target pose [mm, °] (joint moves: solved by IK unless `use_joint`).
        pose: Pose,
        /// `dJ1..dJ6`: target joints when `use_joint`, else IK reference [°].
        joints: Joints,
        /// `sTcpName`: tool frame name (default `TCP`).
        tcp_name: &'a str,
        /// `sUcsName`: user frame name (default `Base`).
        ucs_name: &'a str,
        /// `dVelocity`: [°/s joint, mm/s linear].
        velocity: Decimal,
        /// `dAcc`: [°/s² joint, mm/s² linear].
        acc: Decimal,
        /// `dRadius`: blend radius \[mm\].
        radius: Decimal,
        /// `nMoveType`: 0 = joint, 1 = linear.
        move_type: i32 = FLAG,
        /// `nIsUseJoint`: 1 = move to `joints` (joint moves only).
        use_joint: i32 = FLAG,
        /// `nIsSeek`: 1 = stop when box DI `io_bit` equals `io_state`.
        seek: i32 = FLAG,
        /// `nIOBit`: box DI index 0-7.
        io_bit: i32 = BOX_BIT,
        /// `nIOState`: DI level 0/1.
        io_state: i32 = FLAG,
        /// `strCmdID`: way-point id, free text.
        cmd_id: &'a str,
    } => {}

    /// Way-point move that also blends into arcs without slowing down.
    WayPoint2<'a> = "WayPoint2" @ v5 "4.10.6" v6 "4.10.6";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dEndPos_X..dEndPos_Rz`: target pose [mm, °].
        end_pose: Pose,
        /// `dJ1..dJ6`: target joints when `use_joint`, else IK reference [°].
        joints: Joints,
        /// `sTcpName`: tool frame name (default `TCP`).
        tcp_name: &'a str,
        /// `sUcsName`: user frame name (default `Base`).
        ucs_name: &'a str,
        /// `dVelocity`: [°/s joint, mm/s linear].
        velocity: Decimal,
        /// `dAcc`: [°/s² joint, mm/s² linear].
        acc: Decimal,
        /// `dRadius`: blend radius \[mm\].
        radius: Decimal,
        /// `nMoveType`: 0 = joint, 1 = linear, 2 = arc through `aux_pose`.
        move_type: i32 = int(0, 2),
        /// `nIsUseJoint`: 1 = move to `joints` (joint moves only).
        use_joint: i32 = FLAG,
        /// `nIsSeek`: 1 = stop when box DI `io_bit` equals `io_state`.
        seek: i32 = FLAG,
        /// `nIOBit`: box DI index 0-7.
        io_bit: i32 = BOX_BIT,
        /// `nIOState`: DI level 0/1.
        io_state: i32 = FLAG,
        /// `dAuxPos_X..dAuxPos_Rz`: arc via point [mm, °] (arc moves only).
        aux_pose: Pose,
        /// `strCmdID`: way-point id, free text.
        cmd_id: &'a str,
    } => {}

    /// Joint move (deprecated in the document; use `WayPoint`).
    MoveJ<'a> = "MoveJ" @ v5 "4.10.7", removed "HR5.50.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dX..dRz`: target pose [mm, °].
        pose: Pose,
        /// `dJ1..dJ6`: target joints when `use_joint`, else IK reference [°].
        joints: Joints,
        /// `sTcpName`: tool frame name (the examples send it first).
        tcp_name: &'a str,
        /// `sUcsName`: user frame name.
        ucs_name: &'a str,
        /// `dVelocity`: [°/s].
        velocity: Decimal,
        /// `dAcc`: [°/s²].
        acc: Decimal,
        /// `dRadius`: blend radius \[mm\].
        radius: Decimal,
        /// `nIsUseJoint`: 1 = move to `joints`.
        use_joint: i32 = FLAG,
        /// `nIsSeek`: 1 = stop when box DI `io_bit` equals `io_state`.
        seek: i32 = FLAG,
        /// `nIOBit`: box DI index 0-7.
        io_bit: i32 = BOX_BIT,
        /// `nIOState`: DI level 0/1.
        io_state: i32 = FLAG,
        /// `strCmdID`: way-point id, free text.
        cmd_id: &'a str,
    } => {}

    /// Linear move (deprecated in the document; use `WayPoint`).
    MoveL<'a> = "MoveL" @ v5 "4.10.8", removed "HR5.50.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dX..dRz`: target pose [mm, °].
        pose: Pose,
        /// `dJ1..dJ6`: IK reference joints [°].
        joints: Joints,
        /// `sTcpName`: tool frame name (the examples send it first).
        tcp_name: &'a str,
        /// `sUcsName`: user frame name.
        ucs_name: &'a str,
        /// `dVelocity`: [mm/s].
        velocity: Decimal,
        /// `dAcc`: [mm/s²].
        acc: Decimal,
        /// `dRadius`: blend radius \[mm\].
        radius: Decimal,
        /// `nIsSeek`: 1 = stop when box DI `io_bit` equals `io_state`.
        seek: i32 = FLAG,
        /// `nIOBit`: box DI index 0-7.
        io_bit: i32 = BOX_BIT,
        /// `nIOState`: DI level 0/1.
        io_state: i32 = FLAG,
        /// `strCmdID`: way-point id, free text.
        cmd_id: &'a str,
    } => {}

    /// Circular move (arc or full circles).
    MoveC<'a> = "MoveC" @ v5 "4.10.9" v6 "4.10.7";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dStartPos_X..Rz`: start [mm, °].
        start: Pose,
        /// `dAuxPos_X..Rz`: via point [mm, °].
        aux: Pose,
        /// `dEndPos_X..Rz`: end [mm, °].
        end: Pose,
        /// `nFixedPosure`: 1 = keep the orientation.
        fixed_posture: i32 = FLAG,
        /// `nMoveCType`: 0 = full circle, 1 = arc.
        circle_type: i32 = FLAG,
        /// `dRadLen`: number of full circles (full-circle moves only).
        rad_len: Decimal,
        /// `dVelocity`: [mm/s].
        velocity: Decimal,
        /// `dAcc`: [mm/s²].
        acc: Decimal,
        /// `dRadius`: blend radius \[mm\].
        radius: Decimal,
        /// `sTcpName`: tool frame name.
        tcp_name: &'a str,
        /// `sUcsName`: user frame name.
        ucs_name: &'a str,
        /// `strCmdID`: way-point id, free text.
        cmd_id: &'a str,
    } => {}

    /// Zig-zag move.
    MoveZ<'a> = "MoveZ" @ v5 "4.10.10" v6 "4.10.8";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dStartPos_X..Rz`: [mm, °].
        start: Pose,
        /// `dEndPos_X..Rz`: [mm, °].
        end: Pose,
        /// `dPlanePos_X..Rz`: point fixing the plane [mm, °].
        plane: Pose,
        /// `dVelocity`: [mm/s].
        velocity: Decimal,
        /// `dAcc`: [mm/s²].
        acc: Decimal,
        /// `dWidth`: zig-zag width.
        width: Decimal,
        /// `dDensity`: zig-zag density.
        density: Decimal,
        /// `nEnableDensity`: 1 = use `density`.
        enable_density: i32 = FLAG,
        /// `nEnablePlane`: 1 = use `plane`.
        enable_plane: i32 = FLAG,
        /// `nEnableWaiTime`: 1 = wait at turning points.
        enable_wait_time: i32 = FLAG,
        /// `nPosiTime`: wait at positive turns \[ms\].
        positive_time: i32,
        /// `nNegaTime`: wait at negative turns \[ms\].
        negative_time: i32,
        /// `dRadius`: blend radius \[mm\].
        radius: Decimal,
        /// `sTcpName`: tool frame name.
        tcp_name: &'a str,
        /// `sUcsName`: user frame name.
        ucs_name: &'a str,
        /// `strCmdID`: way-point id, free text.
        cmd_id: &'a str,
    } => {}

    /// Elliptical move through five taught points.
    MoveE<'a> = "MoveE" @ v5 "4.10.11" v6 "4.10.9", removed "HR6.5.0", changed "HR6.4.8";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dP1_X..Rz`: [mm, °].
        p1: Pose,
        /// `dP2_X..Rz`: [mm, °].
        p2: Pose,
        /// `dP3_X..Rz`: [mm, °].
        p3: Pose,
        /// `dP4_X..Rz`: [mm, °].
        p4: Pose,
        /// `dP5_X..Rz`: [mm, °].
        p5: Pose,
        /// `nOrientMode`: 0 = elliptical arc, 1 = whole ellipse.
        orient_mode: i32 = FLAG,
        /// `nMoveType`: 1 = keep the orientation.
        move_type: i32 = FLAG,
        /// `dArcLength`: [°].
        arc_length: Decimal,
        /// `dVelocity`: [mm/s].
        velocity: Decimal,
        /// `dAcc`: [mm/s²].
        acc: Decimal,
        /// `dRadius`: blend radius \[mm\].
        radius: Decimal,
        /// `sTcpName`: tool frame name.
        tcp_name: &'a str,
        /// `sUcsName`: user frame name.
        ucs_name: &'a str,
        /// `strCmdID`: way-point id, free text.
        cmd_id: &'a str,
    } => {}

    /// Archimedean spiral from a 1 mm radius. Written in the order of the
    /// document's example and the vendor SDK; the signature's order (names
    /// before the velocity) is accepted on input.
    MoveS<'a> = "MoveS" @ v5 "4.10.12" v6 "4.10.10";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dSpiralIncrement`: radius increase per turn \[mm\], > 0.
        increment: Decimal = above("0"),
        /// `dSpiralDiameter`: end radius \[mm\], > 1.
        diameter: Decimal = above("1"),
        /// `dVelocity`: [°/s].
        velocity: Decimal,
        /// `dAcc`: [°/s²].
        acc: Decimal,
        /// `dRadius`: blend radius \[mm\].
        radius: Decimal,
        /// `sTcpName`: tool frame name.
        tcp_name: &'a str,
        /// `sUcsName`: user frame name.
        ucs_name: &'a str,
        /// `strCmdID`: way-point id, free text.
        cmd_id: &'a str,
    } => {}

    // ---------------------------------------------------------------- 4.11
    /// Start a joint path.
    StartPushMovePath<'a> = "StartPushMovePath" @ v5 "4.11.1" v6 "4.11.12", removed "HR6.5.0";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sTrackName`: path name.
        track: &'a str,
        /// `dSpeedRatio`: 0-1.
        speed_ratio: Decimal = num("0", "1"),
        /// `dRadius`: blend radius \[mm\], > 0.
        radius: Decimal = above("0"),
    } => {}

    /// Add a joint point to a path (usually more than 4).
    PushMovePathJ<'a> = "PushMovePathJ" @ v5 "4.11.2" v6 "4.11.13", removed "HR6.5.0";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sTrackName`: path name.
        track: &'a str,
        /// `dJ1..dJ6`: [°].
        joints: Joints,
    } => {}

    /// End a joint path and start computing it.
    EndPushMovePath<'a> = "EndPushMovePath" @ v5 "4.11.3" v6 "4.11.14", removed "HR6.5.0";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sTrackName`: path name.
        track: &'a str,
    } => {}

    /// Run a joint path. SDKs also send `MovePathJ`, read as this command
    /// without the `v6` feature; with it, `MovePathJ` is the V6 document's
    /// own command (paths of `InitPath`).
    MovePath<'a> = "MovePath" | #[cfg(not(feature = "v6"))] "MovePathJ" @ v5 "4.11.4" v6 "4.11.15";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sTrackName`: path name.
        track: &'a str,
    } => {}

    /// The state of a path.
    ReadMovePathState<'a> = "ReadMovePathState" @ v5 "4.11.5" v6 "4.11.16", removed "HR6.5.0";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sTrackName`: path name.
        track: &'a str,
    } => {
        /// `nState`: 0 not taught, 1 teaching, 2 computing, 3 ready, 4 teaching ended, 5 computation error.
        state: i32,
    }

    /// Rename a path.
    UpdateMovePathName<'a> = "UpdateMovePathName" @ v5 "4.11.6" v6 "4.11.17", removed "HR6.5.0";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sTrackName`: current name.
        track: &'a str,
        /// `sTrackNewName`: new name.
        new_name: &'a str,
    } => {}

    /// Delete a path.
    DelMovePath<'a> = "DelMovePath" @ v5 "4.11.7" v6 "4.11.18", removed "HR6.5.0";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sTrackName`: path name.
        track: &'a str,
    } => {}

    /// Progress of a `MovePathL` run. The heading calls it
    /// `ReadSoftMotionProcess`, accepted as an alias.
    ReadSoftMotionProgress = "ReadSoftMotionProgress" | "ReadSoftMotionProcess" @ v5 "4.11.8" v6 "4.11.19";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dProcess`: 0-1, above 0.999999 = done.
        progress: Decimal,
        /// `nIndex`: index of the current point.
        index: i32,
    }

    /// Start a Cartesian path.
    InitMovePathL<'a> = "InitMovePathL" @ v5 "4.11.9" v6 "4.11.20", removed "HR6.5.0";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sTrackName`: path name.
        track: &'a str,
        /// `dVelocity`: [mm/s].
        velocity: Decimal,
        /// `dAcc`: [mm/s²].
        acc: Decimal,
        /// `dJerk`: [mm/s³].
        jerk: Decimal,
        /// `sUcsName`: user frame name (sent before the tool name).
        ucs_name: &'a str,
        /// `sTcpName`: tool frame name.
        tcp_name: &'a str,
    } => {}

    /// Add a Cartesian point to a path (usually more than 4).
    PushMovePathL<'a> = "PushMovePathL" @ v5 "4.11.10" v6 "4.11.21", removed "HR6.5.0";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sTrackName`: path name.
        track: &'a str,
        /// `dX..dRz`: [mm, °].
        pose: Pose,
    } => {}

    /// Add many points to a path in one message.
    PushMovePaths<'a> = "PushMovePaths" @ v5 "4.11.11" v6 "4.11.22", removed "HR6.5.0";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sTrackName`: path name.
        track: &'a str,
        /// `nMoveType`: 0 = joint points (for `MovePath`), 1 = Cartesian (for `MovePathL`).
        move_type: i32 = FLAG,
        /// `nPointsSize` and `sPoints`: the points, six values each.
        points: PointList<'a>,
    } => {}

    /// Run a Cartesian path (computes 2-4 s, then moves).
    MovePathL<'a> = "MovePathL" @ v5 "4.11.12" v6 "4.11.9", changed "HR6.3.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sTrackName`: path name.
        track: &'a str,
    } => {}

    /// Speed ratio of a running `MovePath`.
    SetMovePathOverride = "SetMovePathOverride" @ v5 "4.11.13" v6 "4.11.23";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dOverride`: 0.01-1.
        ratio: Decimal = num("0.01", "1"),
    } => {}

    // ---------------------------------------------------------------- 4.12
    /// Start online (servo) control.
    StartServo = "StartServo" @ v5 "4.12.1" v6 "4.12.1";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dServoTime`: update period \[s\], > 0.
        servo_time: Decimal = above("0"),
        /// `dLookaheadTime`: look-ahead \[s\], > 0.
        lookahead_time: Decimal = above("0"),
    } => {}

    /// Stream a joint target.
    PushServoJ = "PushServoJ" @ v5 "4.12.2" v6 "4.12.2";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dJ1..dJ6`: [°].
        joints: Joints,
    } => {}

    /// Stream a Cartesian target.
    PushServoP = "PushServoP" @ v5 "4.12.3" v6 "4.12.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dX..dRz`: [mm, °].
        pose: Pose,
        /// `dUcs_X..dUcs_Rz`: user frame [mm, °] (sent before the tool frame).
        ucs: Pose,
        /// `dTcp_X..dTcp_Rz`: tool frame [mm, °].
        tcp: Pose,
    } => {}

    // ---------------------------------------------------------------- 4.13
    /// Relative tracking parameters.
    SetMoveTraceParams = "SetMoveTraceParams" @ v5 "4.13.1" v6 "4.13.1";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nState`: 0 = off, 1 = on.
        state: i32 = FLAG,
        /// `dDistance`: distance to keep, > 0.
        distance: Decimal = above("0"),
        /// `dAwayVelocity`: search speed away, > 0.
        away_velocity: Decimal = above("0"),
        /// `dBackVelocity`: search speed back, > 0.
        back_velocity: Decimal = above("0"),
    } => {}

    /// Relative tracking sensor parameters (`y = dK·x + dB`).
    SetMoveTraceInitParams = "SetMoveTraceInitParams" @ v5 "4.13.2" v6 "4.13.2";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dK`.
        k: Decimal,
        /// `dB`.
        b: Decimal,
        /// `dMaxLimit`: largest sensor distance.
        max_limit: Decimal,
        /// `dMinLimit`: smallest sensor distance.
        min_limit: Decimal,
    } => {}

    /// Relative tracking search direction.
    SetMoveTraceUcs = "SetMoveTraceUcs" @ v5 "4.13.3" v6 "4.13.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dX..dRz`: X, Y, Z unused; Rx, Ry, Rz the direction [°].
        direction: Pose,
    } => {}

    /// Conveyor tracking on or off.
    SetTrackingState = "SetTrackingState" @ v5 "4.13.4" v6 "4.13.4";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nState`: 0 = off, 1 = on.
        state: i32 = FLAG,
    } => {}

    // ---------------------------------------------------------------- 4.14
    /// Run a plug-in app command.
    HRAppCmd<'a> = "HRAppCmd" @ v5 "4.14.1" v6 "4.15.1";
    {
        /// `HRAppName`: the plug-in app.
        app: &'a str,
        /// `HRAppCmdName, sParams1..n`: the command name, then its parameters.
        args: TextList<'a>,
    } => {}

    /// Write registers of the tool-flange Modbus slave (EtherCAT end I/O).
    WriteHoldingRegisters = "WriteHoldingRegisters" @ v5 "4.14.2" v6 "4.15.2", changed "HR5.50.5";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nSlaveID`: 0/1 in HR-TCP V1.0.0.3, 1-255 from `HR5.50.5` (the
        /// V6 document): 0-255.
        slave: i32 = int(0, 255),
        /// `nFunction`: Modbus function code, > 0 (16 writes registers).
        function: i32 = int(1, 255),
        /// `nRegAddr`: first register address.
        address: i32 = int(0, 65535),
        /// `nRegCount` and `vecData`: 1-11 consecutive register values.
        data: CountedList<i32, 11>,
    } => {}

    /// Read registers of the tool-flange Modbus slave (EtherCAT end I/O).
    ReadHoldingRegisters = "ReadHoldingRegisters" @ v5 "4.14.3" v6 "4.15.3", changed "HR5.50.5", len = |r| usize::try_from(r.count).unwrap_or(0);
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nSlaveID`: 0/1 in HR-TCP V1.0.0.3, 1-255 from `HR5.50.5` (the
        /// V6 document): 0-255.
        slave: i32 = int(0, 255),
        /// `nFunction`: Modbus function code, > 0 (3 reads holding registers).
        function: i32 = int(1, 255),
        /// `nRegAddr`: first register address.
        address: i32 = int(0, 65535),
        /// `nRegCount`: 1-12.
        count: i32 = int(1, 12),
    } => {
        /// `vecData1..`: one value per register asked for.
        values: heapless::Vec<i32, 12>,
    }
}
v6 {
    // ================================================================
    // The V6 document's additions (feature `v6`), in its order. Versions
    // from its revision table; "All" there is the V5 level (no `since`).
    // ---------------------------------------------------------------- 4.1
    /// The controller's own text for an error code (it only ever replies
    /// OK; unknown codes get a text such as `unkown error`).
    GetErrorCodeStr = "GetErrorCodeStr" @ v6 "4.1.9", since "HR5.50.3";
    {
        /// `nErrorCode`: the code to explain.
        code: ErrorCode,
    } => <'a> {
        /// `strErrorMsg`: the explanation, commas included.
        text: FreeText<'a>,
    }

    /// The controller's software package version (`6.3.6.20240305`; its
    /// first three numbers are the controller's [`ProtocolLevel`]).
    PackageVersion = "PackageVersion" @ v6 "4.1.11", since "HR6.2.17";
    {} => <'a> {
        /// `strPackageVer`: the version.
        version: &'a str,
    }

    /// The fast command port, which serves the commands marked as fast
    /// (state reads) beside port 10003.
    ReadFastCmdPort = "ReadFastCmdPort" @ v6 "4.1.12", since "HR6.5.1";
    {} => {
        /// The port number (10001 in the document's example).
        port: i32,
    }

    // ---------------------------------------------------------------- 4.2
    /// Force the safety-guard state on or off: a software emergency stop.
    /// The name of controllers before `HR6.5.1`; the vendor's newest SDK
    /// still sends it.
    EnterSafetyGuard = "EnterSafetyGuard" @ v6 "4.2.9", since "HR6.2.17";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `bFlag`: 1 = enter the soft stop, 0 = leave it.
        flag: i32 = FLAG,
    } => {}

    /// Force the safety-guard state on or off: a software emergency stop
    /// (after leaving it, "restore" the guard on the pendant). Renamed from
    /// `EnterSafetyGuard` at `HR6.5.1`.
    EnterSafeGuard = "EnterSafeGuard" @ v6 "4.2.9", since "HR6.5.1";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `bFlag`: 1 = enter the soft stop, 0 = leave it.
        flag: i32 = FLAG,
    } => {}

    /// From any state back to enabled (StandBy), as far as the controller
    /// can do it alone: a task that tries for up to 30 s.
    XToStandby = "XToStandby" @ v6 "4.2.10", since "HR6.4.1";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {}

    /// The three-position enabling switch on or off, and its mode (the mode
    /// is ignored from `HR6.5.13` on).
    SetTriStageSwitch = "SetTriStageSwitch" @ v6 "4.2.11", since "HR6.5.1";
    {
        /// `rbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nThreeStageEnable`: 0 = off, 1 = on.
        enable: i32 = FLAG,
        /// `nThreeStageMode`: 0 = free drive, 1 = enable.
        mode: i32 = FLAG,
    } => {}

    /// Each joint's brake.
    ReadBrakeStatus = "ReadBrakeStatus" @ v6 "4.2.12", since "HR6.5.14";
    {
        /// `boxID`: electric box (robot) id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `stateJ1..J6`: per joint, 1 = released, 0 = braked (the vendor
        /// SDK's reading; the document says only "0/1").
        brakes: [i32; 6],
    }

    // ---------------------------------------------------------------- 4.3
    /// Apply (make current) a script file.
    SwitchScript<'a> = "SwitchScript" @ v6 "4.3.6", since "HR6.3.5";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sScriptName`: the script file, `.JSON`.
        script: &'a str,
    } => {}

    /// The script file currently applied.
    ReadDefaultScript = "ReadDefaultScript" @ v6 "4.3.7", since "HR6.3.5";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => <'a> {
        /// `sScriptName`: the script file, `.JSON`.
        script: &'a str,
    }

    /// Whether scripts with unsaved changes may run (kept across restarts).
    EnableRunningUnsavedProgram = "EnableRunningUnsavedProgram" @ v6 "4.3.8", since "HR6.5.4";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `enabledVal`: 0 = refuse them, 1 = allow.
        enabled: i32 = FLAG,
    } => {}

    // ---------------------------------------------------------------- 4.4
    /// Set outputs just before the current motion reaches its target. Bit
    /// masks say which outputs change, values their new level.
    CdsSetIO = "cdsSetIO" @ v6 "4.4.16", since "HR6.2.17";
    {
        /// `nEndDOMask`: tool outputs to change, bit 0-2.
        end_do_mask: i32,
        /// `nEndDOVal`: their levels, bit 0-2.
        end_do_value: i32,
        /// `nBoxDOMask`: box DO outputs to change, bit 0-7.
        box_do_mask: i32,
        /// `nBoxDOVal`: their levels, bit 0-7.
        box_do_value: i32,
        /// `nBoxCOMask`: box CO outputs to change, bit 0-7.
        box_co_mask: i32,
        /// `nBoxCOVal`: their levels, bit 0-7.
        box_co_value: i32,
        /// `nBoxAOCH0_Mask`: 1 = change analog output 0.
        ao0_mask: i32 = FLAG,
        /// `nBoxAOCH0_Mode`: 1 = voltage, 2 = current (the document's
        /// example sends 0 with the mask off: 0 is accepted).
        ao0_mode: i32 = int(0, 2),
        /// `nBoxAOCH1_Mask`: 1 = change analog output 1.
        ao1_mask: i32 = FLAG,
        /// `nBoxAOCH1_Mode`: as `ao0_mode`.
        ao1_mode: i32 = int(0, 2),
        /// `dbBoxAOCH0_Val`: [mA 4-20 or V 0-10], 0-20.
        ao0_value: Decimal = num("0", "20"),
        /// `dbBoxAOCH1_Val`: [mA 4-20 or V 0-10], 0-20.
        ao1_value: Decimal = num("0", "20"),
    } => {}

    /// The function of a box control input (CI).
    SetCIConfig = "SetCIConfig" @ v6 "4.4.17", since "HR6.5.1";
    {
        /// `nBit`: CI index 0-7.
        bit: i32 = BOX_BIT,
        /// `nFunction`: -1 none, 0 enable, 1 reset errors, 2 reduced mode,
        /// 3 pause script, 5 stop script, 6 continue script, 7 run script,
        /// 11 pause motion, 12 continue motion.
        function: i32 = int(-1, 12),
        /// `nTriggerType`: 0 low level, 1 high level, 2 rising edge, 3
        /// falling edge; may be omitted with function -1.
        trigger: Option<i32> = int(0, 3),
    } => {}

    /// The functions of the box control inputs: all eight, or one with its
    /// trigger.
    ReadCIConfig = "ReadCIConfig" @ v6 "4.4.18", since "HR6.5.1",
        len = |r| if r.bit.is_some() { 2 } else { 8 };
    {
        /// `nBit`: CI index 0-7; omitted = all eight.
        bit: Option<i32> = BOX_BIT,
    } => {
        /// Without `nBit`: `nFunction0..7`, the function of each CI (as
        /// `SetCIConfig`, plus 9 safety guard, 10 local e-stop). With it:
        /// `nFunction, nTriggerType` of that CI (trigger -1 with function -1).
        values: heapless::Vec<i32, 8>,
    }

    /// The function of a box control output (CO).
    SetCOConfig = "SetCOConfig" @ v6 "4.4.19", since "HR6.5.1";
    {
        /// `nBit`: CO index 0-7.
        bit: i32 = BOX_BIT,
        /// `nFunction`: -1 none, 0 enabled, 1 moving, 2 error, 3 reduced
        /// mode, 4 script running, 5 script paused, 6/7 system e-stop 1/2,
        /// 8/9 local e-stop 1/2, 10 motion paused.
        function: i32 = int(-1, 10),
    } => {}

    /// The functions of the eight box control outputs.
    ReadCOConfig = "ReadCOConfig" @ v6 "4.4.20", since "HR6.5.1";
    {} => {
        /// `nFunction0..7`: the function of each CO (as `SetCOConfig`).
        functions: [i32; 8],
    }

    // ---------------------------------------------------------------- 4.5
    /// The collision sensitivity.
    SetCollideLevel = "SetCollideLevel" @ v6 "4.5.10", since "HR6.3.6";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nSafeLevel`: 0 = low risk (most sensitive) to 5 = high risk.
        level: i32 = int(0, 5),
    } => {}

    /// The safety-guard (light curtain) configuration.
    SetSafeGuardConfig = "SetSafeGuardConfig" @ v6 "4.5.11", since "HR6.5.1";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nEnable`: 0 = off, 1 = on.
        enable: i32 = FLAG,
        /// `nMode`: 0 stop, 1 pause, 2 stop but allow jogging.
        mode: i32 = int(0, 2),
        /// `nBit1`: first guard input, CI 0-7.
        bit1: i32 = BOX_BIT,
        /// `nBit2`: second guard input, CI 0-7.
        bit2: i32 = BOX_BIT,
    } => {}

    /// The largest payload of the model.
    ReadMaxPayload = "ReadMaxPayload" @ v6 "4.5.12", since "HR6.3.6";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dbMaxPayload`: \[kg\].
        max_payload: Decimal,
    }

    /// The current payload.
    ReadPayload = "ReadPayload" @ v6 "4.5.13", since "HR6.3.6";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dMass`: \[kg\].
        mass: Decimal,
        /// `dX, dY, dZ`: centre-of-mass offset \[mm\].
        center: [Decimal; 3],
    }

    /// The speed override. The revision table gives controller
    /// `20220825.214` (the V5 level).
    ReadOverride = "ReadOverride" @ v6 "4.5.14";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dOverride`: speed ratio 0.01-1.
        ratio: Decimal,
    }

    /// A taught point by name: joints, pose, and its tool and user frames.
    ReadPointByName<'a> = "ReadPointByName" @ v6 "4.5.24", since "HR5.50.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sPointName`: the point's name.
        name: &'a str,
    } => {
        /// `dJ1..dJ6`: [°].
        joints: Joints,
        /// `dX..dRz`: [mm, °].
        pose: Pose,
        /// `dTcp_X..dTcp_Rz`: its tool frame [mm, °].
        tcp: Pose,
        /// `dUcs_X..dUcs_Rz`: its user frame [mm, °].
        ucs: Pose,
    }

    /// Motor-side and joint-side encoder values.
    ReadMotorAndJointEncode = "ReadMotorAndJointEncode" @ v6 "4.5.25", since "HR6.4.1";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `nMotorEncode_J1..J6`.
        motor: [i32; 6],
        /// `nJointEncode_J1..J6`.
        joint: [i32; 6],
    }

    // ---------------------------------------------------------------- 4.6
    /// Combined XYZ speed of the TCP, in mm/s (`ReadTcpVelocity` says m/s).
    ReadTcpVel = "ReadTcpVel" @ v6 "4.6.10", since "HR6.5.14";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dCmdVel`: command speed [mm/s].
        cmd: Decimal,
        /// `dActVel`: actual speed [mm/s].
        act: Decimal,
    }

    // ---------------------------------------------------------------- 4.7
    /// Actual joints, and the pose in a named user and tool frame. The
    /// revision table gives `6.5ZT.12` and `6.6.1`.
    ReadActCoord<'a> = "ReadActCoord" @ v6 "4.7.14", since "HR6.6.1";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `UcsName`: user frame name (sent before the tool name).
        ucs_name: &'a str,
        /// `TcpName`: tool frame name.
        tcp_name: &'a str,
    } => {
        /// `dJ1..dJ6`: [°].
        joints: Joints,
        /// `dX..dRz`: in the frames asked for [mm, °].
        pose: Pose,
    }

    /// Inverse dynamics: joint torques for positions, velocities and
    /// accelerations.
    GetInverseDynamics = "GetInverseDynamics" @ v6 "4.7.15", since "HR6.5.15";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dPose_J1..J6`: [°].
        joints: Joints,
        /// `dVel_J1..J6`: [°/s].
        velocities: Joints,
        /// `dAcc_J1..J6`: [°/s²].
        accelerations: Joints,
    } => {
        /// `dTorq_J1..J6`: [N·m].
        torques: Joints,
    }

    // ---------------------------------------------------------------- 4.8
    /// Create a named tool frame.
    ConfigTCP<'a> = "ConfigTCP" @ v6 "4.8.9", since "HR6.3.6";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sTcpName`: the new frame's name.
        name: &'a str,
        /// `dTcp_X..dTcp_Rz`: [mm, °].
        tcp: Pose,
    } => {}

    /// Create a named user frame.
    ConfigUCS<'a> = "ConfigUCS" @ v6 "4.8.10", since "HR6.3.6";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sUcsName` (the signature says `sTcpName`): the new frame's name.
        name: &'a str,
        /// `dUcs_X..dUcs_Rz`: [mm, °].
        ucs: Pose,
    } => {}

    /// Make a taught tool frame the default. The revision table gives
    /// `6.5ZT.12` and `6.6.1`.
    SetDftTCP<'a> = "SetDftTCP" @ v6 "4.8.11", since "HR6.6.1";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `TcpName`: tool frame name.
        name: &'a str,
    } => {}

    /// The tool orientation that aligns the tool with a user frame, from
    /// the flange pose.
    CalTCPOrt = "CalTCPOrt" @ v6 "4.8.12", since "HR6.6.1";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dUcs_X..dUcs_Rz`: the user frame [mm, °].
        ucs: Pose,
        /// `dPcs_X..dPcs_Rz`: the flange (TCP0) pose in the base [mm, °].
        pcs: Pose,
    } => {
        /// `Rx, Ry, Rz`: [°].
        orientation: [Decimal; 3],
    }

    /// The mounting angles of the base.
    SetBaseInstallingAngle = "SetBaseInstallingAngle" @ v6 "4.8.13", since "HR6.5.14";
    {
        /// `nRbtID`: robot id, 0-5 (the table calls it `boxID`).
        rbt_id: RobotId = RBT,
        /// `nRotation`: [°], -360-360.
        rotation: i32 = int(-360, 360),
        /// `nTilt`: [°], -360-360.
        tilt: i32 = int(-360, 360),
    } => {}

    /// The mounting angles of the base.
    GetBaseInstallingAngle = "GetBaseInstallingAngle" @ v6 "4.8.14", since "HR6.5.14";
    {
        /// `boxID`: electric box (robot) id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `nRotation`: [°].
        rotation: i32,
        /// `nTilt`: [°].
        tilt: i32,
    }

    /// The names of the saved tool frames.
    ReadTCPList = "ReadTCPList" @ v6 "4.8.15", since "HR6.5.14";
    {
        /// `boxID`: electric box (robot) id, 0-5.
        rbt_id: RobotId = RBT,
    } => <'a> {
        /// `TCP1..TCPN`: the names.
        names: TextList<'a>,
    }

    // ---------------------------------------------------------------- 4.9
    /// The Cartesian directions force-control free drive may move in. It
    /// took section 4.9.18 of HR-TCP V1.0.0.3's `SetForceFreeDriveMode`; the
    /// revision table has no entry for it (taken as present from
    /// `HR5.50.3`, the first controller of the V6 document).
    SetFTMotionFreedom = "SetFTMotionFreedom" @ v6 "4.9.18", since "HR5.50.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nFreedom_X..Rz`: 0 = locked, 1 = free, per direction.
        freedom: [i32; 6] = FLAG,
    } => {}

    /// Force-control free drive on or off ("All" controllers).
    SetFTFreeDriveState = "SetFTFreeDriveState" @ v6 "4.9.20";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nState`: 0 = off, 1 = on.
        state: i32 = FLAG,
    } => {}

    /// The speed mode of force-control free drive. The revision table
    /// (`HR6.4.1`, V1.0.17.2) says it takes no parameter; the section sends
    /// `nRbtID`: both are read, the robot id is written.
    ReadFTFreeDriveSpeedMode = "ReadFTFreeDriveSpeedMode" @ v6 "4.9.21", since "HR6.4.1";
    {
        /// `nRbtID`: robot id, 0-5 (may be omitted).
        rbt_id: RobotId = RBT,
    } => {
        /// `nState`: 0 normal, 1 slow, 2 fast, 3 welding.
        mode: i32,
    }

    /// The speed mode of force-control free drive.
    SetFTFreeDriveSpeedMode = "SetFTFreeDriveSpeedMode" @ v6 "4.9.22", since "HR6.4.1";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nState`: 0 normal, 1 slow, 2 fast, 3 welding.
        mode: i32 = int(0, 3),
    } => {}

    /// Translation and rotation compliance of force-control free drive
    /// ("All" controllers).
    SetFTFreeFactor = "SetFTFreeFactor" @ v6 "4.9.23";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dLinear`: translation compliance, 0-100.
        linear: Decimal = num("0", "100"),
        /// `dAngular`: rotation compliance, 0-100.
        angular: Decimal = num("0", "100"),
    } => {}

    /// Tangential force bounds in X/Y and the largest lifting speed ("All"
    /// controllers).
    SetTangentForceBounds = "SetTangentForceBounds" @ v6 "4.9.24";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dMax`: largest tangential force \[N\], 0-500.
        max: Decimal = num("0", "500"),
        /// `dMin`: smallest tangential force \[N\], 0-500.
        min: Decimal = num("0", "500"),
        /// `dVel`: largest lifting speed [mm/s], 0-100.
        velocity: Decimal = num("0", "100"),
    } => {}

    /// Compute a force-sensor calibration from 8-16 samples.
    SetFTCalibration<'a> = "SetFTCalibration" @ v6 "4.9.25", since "HR6.4.17";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `param1..paramN`: 8-16 samples of twelve values: the pose X..Rz
        /// [mm, °] in the base frame with the default tool, then the forces
        /// Fx, Fy, Fz \[N\] and torques Tx, Ty, Tz \[N·m\].
        samples: ValueGroups<'a, 12>,
    } => {}

    /// The force sensor's raw data.
    ReadForceData = "ReadForceData" @ v6 "4.9.26", since "HR6.5.14";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `FdX..FdRZ`: raw forces and torques.
        data: [Decimal; 6],
    }

    /// Translation and rotation compliance of force-control free drive.
    ReadFTFreeFactor = "ReadFTFreeFactor" @ v6 "4.9.27", since "HR6.5.14";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `Linear_compliance` (an integer in the document's table, a
        /// number where it is set).
        linear: Decimal,
        /// `angular_compliance`.
        angular: Decimal,
    }

    /// The user frame of force control (not saved).
    SetFTUCS = "SetFTUCS" @ v6 "4.9.28", since "HR6.5.14";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dUcs_X..dUcs_Rz`: [mm, °].
        ucs: Pose,
    } => {}

    /// The user frame of force control.
    ReadFTUCS = "ReadFTUCS" @ v6 "4.9.29", since "HR6.5.14";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `dUcs_X..dUcs_Rz`: [mm, °].
        ucs: Pose,
    }

    // ---------------------------------------------------------------- 4.10
    /// Align the tool's Z axis (with `LongMoveEvent` keeping it going).
    /// The revision table gives `HR6.4ER.13` and `HR6.5.1`.
    MoveAlignToZ<'a> = "MoveAlignToZ" @ v6 "4.10.11", since "HR6.5.1";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sTcpName`: tool frame name.
        tcp_name: &'a str,
        /// `sUcsName`: user frame name.
        ucs_name: &'a str,
    } => {
        /// `bIsReached`: 1 when aligned.
        aligned: i32,
        /// `dbJ1..dbJ6`: the aligned joints [°].
        joints: Joints,
    }

    /// Hold-to-move to joint positions (kept going by `LongMoveEvent`).
    /// The revision table gives `HR6.4ER.13` and `HR6.5.1`.
    MoveJTo = "MoveJTo" @ v6 "4.10.12", since "HR6.5.1";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dJ1..dJ6`: target joints [°].
        joints: Joints,
    } => {}

    /// Hold-to-move to a pose (kept going by `LongMoveEvent`).
    MoveLTo<'a> = "MoveLTo" @ v6 "4.10.13", since "HR6.5.1";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dX..dRz`: target pose [mm, °].
        pose: Pose,
        /// `sTcpName`: tool frame name.
        tcp_name: &'a str,
        /// `sUcsName`: user frame name.
        ucs_name: &'a str,
    } => {}

    /// Short joint jog: 2° at up to 10 °/s.
    ShortJogJ = "ShortJogJ" @ v6 "4.10.14", since "HR6.2.17";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nAxisId`: joint J1-J6 as 0-5.
        axis: i32 = int(0, 5),
        /// `nDirection`: 0 = negative, 1 = positive.
        direction: i32 = FLAG,
    } => {}

    /// Short Cartesian jog: 2 mm or 2° at up to 10 mm/s or 10 °/s.
    ShortJogL = "ShortJogL" @ v6 "4.10.15", since "HR6.2.17";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nAxisId`: direction X, Y, Z, Rx, Ry, Rz as 0-5.
        axis: i32 = int(0, 5),
        /// `nDirection`: 0 = negative, 1 = positive.
        direction: i32 = FLAG,
    } => {}

    /// Long joint jog, up to 10 °/s, while `LongMoveEvent` keeps coming.
    LongJogJ = "LongJogJ" @ v6 "4.10.16", since "HR6.2.17";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nAxisId`: joint J1-J6 as 0-5.
        axis: i32 = int(0, 5),
        /// `nDirection`: 0 = negative, 1 = positive.
        direction: i32 = FLAG,
        /// `nState`: 1 = start, 0 = stop.
        state: i32 = FLAG,
    } => {}

    /// Long Cartesian jog, up to 30 mm/s, while `LongMoveEvent` keeps
    /// coming.
    LongJogL = "LongJogL" @ v6 "4.10.17", since "HR6.2.17";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nAxisId`: direction X, Y, Z, Rx, Ry, Rz as 0-5.
        axis: i32 = int(0, 5),
        /// `nDirection`: 0 = negative, 1 = positive.
        direction: i32 = FLAG,
        /// `nState`: 1 = start, 0 = stop.
        state: i32 = FLAG,
    } => {}

    /// Keeps a long jog (or `MoveJTo`, `MoveLTo`, `MoveAlignToZ`) going:
    /// send at least every 200 ms, or the motion stops.
    LongMoveEvent = "LongMoveEvent" @ v6 "4.10.18", since "HR6.2.17";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {}

    // ---------------------------------------------------------------- 4.11
    /// Create a path (an existing path of that name is deleted first). Its
    /// parameters were redefined at `HR6.3.5`.
    InitPath<'a> = "InitPath" @ v6 "4.11.1", since "HR6.3.3", changed "HR6.3.5";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nRawDataType`: 0 = joint raw points, 1 = Cartesian.
        raw_data_type: i32 = FLAG,
        /// `sPathName`: letters, digits, `_`; at most 29 characters.
        path: &'a str,
        /// `dSpeedRatio`: 0.01-1 (for `MovePathJ`).
        speed_ratio: Decimal = num("0.01", "1"),
        /// `dRadius`: blend radius \[mm\], > 0 (for `MovePathJ`).
        radius: Decimal = above("0"),
        /// `dVelocity, dAcc, dJerk, sUcsName, sTcpName` (for `MovePathL`):
        /// required with Cartesian raw points, else may be omitted.
        cartesian: Option<CartesianPath<'a>>,
    } => {}

    /// Add raw points to a path (up to 10000 in all).
    PushPathPoints<'a> = "PushPathPoints" @ v6 "4.11.2", since "HR6.3.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sPathName`: path name.
        path: &'a str,
        /// `dValue1..6`, ...: six values per point, joints [°] or a pose
        /// [mm, °] as the path's raw data type says.
        points: ValueGroups<'a, 6>,
    } => {}

    /// End adding points; the controller then computes the path. The
    /// revision table calls it `EndPushPoints` (accepted as an alias).
    EndPushPathPoints<'a> = "EndPushPathPoints" | "EndPushPoints" @ v6 "4.11.3", since "HR6.3.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sPathName`: path name.
        path: &'a str,
    } => {}

    /// Delete a path.
    DelPath<'a> = "DelPath" @ v6 "4.11.4", since "HR6.3.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sPathName`: path name.
        path: &'a str,
    } => {}

    /// The names of all paths, or what is known of one.
    ReadPath<'a> = "ReadPath" @ v6 "4.11.5", since "HR6.3.3",
        len = |r| usize::from(r.path.is_some());
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sPathName`: a path; omitted = list every path.
        path: Option<&'a str>,
    } => <'a> {
        /// The names, or the path's details (see [`PathReply`]).
        path: PathReply<'a>,
    }

    /// Rename a path (no example in the document).
    UpdatePathName<'a> = "UpdatePathName" @ v6 "4.11.6", since "HR6.3.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sPathName`: current name.
        path: &'a str,
        /// `sPathNewName`: new name.
        new_name: &'a str,
    } => {}

    /// The states of a path's two computations.
    ReadPathState<'a> = "ReadPathState" @ v6 "4.11.7", since "HR6.3.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sPathName`: path name.
        path: &'a str,
    } => {
        /// `nStateJ`: the `MovePathJ` computation (see [`crate::path`]).
        state_j: i32,
        /// `nErrorCodeJ`: its error, when `state_j` is 5.
        error_j: ErrorCode,
        /// `nStateL`: the `MovePathL` computation.
        state_l: i32,
        /// `nErrorCodeL`: its error, when `state_l` is 5.
        error_l: ErrorCode,
    }

    /// Run a computed path in joint space (its `stateJ` must be 3).
    MovePathJ<'a> = "MovePathJ" @ v6 "4.11.8", since "HR6.3.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sPathName`: path name.
        path: &'a str,
    } => {}

    /// Start an online-planned joint path of 2-5000 points; more may
    /// follow in later messages.
    MovePathJOL<'a> = "MovePathJOL" @ v6 "4.11.10", since "HR6.4.1", changed "HR6.4.6";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dVel`: joint velocity [°/s].
        velocity: Decimal,
        /// `dAcc`: joint acceleration [°/s²].
        acc: Decimal,
        /// `dTol`: blending tolerance [°], >= 0.1 (changed at `HR6.4.6`).
        tolerance: Decimal = at_least("0.1"),
        /// Nineteen values per point: `dJ1..dJ6` [°], `nIsSetIO` (1 = set
        /// the outputs when the point is reached), then the twelve output
        /// fields of `cdsSetIO` (masks, values, analog modes and values).
        points: ValueGroups<'a, 19>,
    } => {}

    /// Progress of a `MovePathJOL` run.
    GetMovePathJOLIndex = "GetMovePathJOLIndex" @ v6 "4.11.11", since "HR6.4.1";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// The current point's index.
        index: i32,
        /// The number of points.
        total: i32,
    }

    /// The reference joints for computing a Cartesian path (kept).
    SetPathRefJoints<'a> = "SetPathRefJoints" @ v6 "4.11.24", since "HR6.5.15";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `sPathName`: path name.
        path: &'a str,
        /// `dJ1..dJ6`: [°].
        joints: Joints,
    } => {}

    // ---------------------------------------------------------------- 4.12
    /// Joint velocity control for a time (not scaled by the override).
    SpeedJ = "SpeedJ" @ v6 "4.12.4", since "HR6.4.8";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dJ1CmdVel..dJ6CmdVel`: [°/s].
        velocities: Joints,
        /// `dAcc`: [°/s²].
        acc: Decimal,
        /// `dRunTime`: the longest run \[s\], 0.001-86400, rounded to ms.
        run_time: Decimal = num("0.001", "86400"),
    } => {}

    /// Cartesian velocity control for a time (not scaled by the override).
    SpeedL = "SpeedL" @ v6 "4.12.5", since "HR6.4.8";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dXCmdVel..dRzCmdVel`: [mm/s, °/s].
        velocities: Pose,
        /// `dLinearAcc`: [mm/s²].
        linear_acc: Decimal,
        /// `dAngularAcc`: [°/s²].
        angular_acc: Decimal,
        /// `dRunTime`: the longest run \[s\], 0.001-86400, rounded to ms.
        run_time: Decimal = num("0.001", "86400"),
    } => {}

    // ---------------------------------------------------------------- 4.14
    /// Position following: the largest following speeds.
    SetPoseTrackingMaxMotionLimit = "SetPoseTrackingMaxMotionLimit" @ v6 "4.14.1", since "HR5.50.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dMaxLineVel`: [mm/s], > 0.
        max_line_vel: Decimal = above("0"),
        /// `dMaxOriVel`: [°/s], > 0.
        max_ori_vel: Decimal = above("0"),
    } => {}

    /// Position following: stop after this long without updates.
    SetPoseTrackingStopTimeOut = "SetPoseTrackingStopTimeOut" @ v6 "4.14.2", since "HR6.3.6";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dTime`: \[s\], >= 0.
        time: Decimal = at_least("0"),
    } => {}

    /// Position following: PID gains.
    SetPoseTrackingPIDParams = "SetPoseTrackingPIDParams" @ v6 "4.14.3", since "HR5.50.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dPosPID1..3`: position gains (defaults 5, 0.1, 0).
        position: [Decimal; 3],
        /// `dOriPID1..3`: orientation gains (defaults 5, 0.1, 0).
        orientation: [Decimal; 3],
    } => {}

    /// Position following: the offset to keep from the sensed pose.
    SetPoseTrackingTargetPos = "SetPoseTrackingTargetPos" @ v6 "4.14.4", since "HR5.50.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dX..dRz`: [mm, °].
        target: Pose,
    } => {}

    /// Position following on or off.
    SetPoseTrackingState = "SetPoseTrackingState" @ v6 "4.14.5", since "HR5.50.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nState`: 0 = off, 1 = on.
        state: i32 = FLAG,
    } => {}

    /// Position following: the sensed pose, streamed.
    SetUpdateTrackingPose = "SetUpdateTrackingPose" @ v6 "4.14.6", since "HR5.50.3";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `dX..dRz`: [mm, °].
        pose: Pose,
    } => {}

    // ---------------------------------------------------------------- 4.15
    /// Serial settings of the tool-flange Modbus (EtherCAT end I/O).
    SetEndModbusInfo = "SetEndModbusInfo" @ v6 "4.15.4", since "HR6.4.8";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
        /// `nBaudrate`: > 0 (default 115200).
        baudrate: i32 = int(1, i32::MAX),
        /// `nDataBit`: > 0 (default 8).
        data_bits: i32 = int(1, i32::MAX),
        /// `nParityBit`: 78 (`N`) none, 79 (`O`) odd, 69 (`E`) even.
        parity: i32 = int(1, i32::MAX),
        /// `nStopBit`: > 0 (default 1).
        stop_bits: i32 = int(1, i32::MAX),
    } => {}

    /// Start payload identification.
    LoadIdentify = "LoadIdentify" @ v6 "4.15.5", since "HR6.4.17";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {}

    /// Progress and result of payload identification. A failure reply
    /// carries the same values before its explanation (kept in
    /// [`Failure::detail`](crate::Failure)).
    GetLoadIdentifyResult = "GetLoadIdentifyResult" @ v6 "4.15.6", since "HR6.4.17";
    {
        /// `nRbtID`: robot id, 0-5.
        rbt_id: RobotId = RBT,
    } => {
        /// `status`: 0 done, 1-3 trajectory 1-3 failed, 4 running, 5
        /// stopped, 6 exited, 7 not started.
        status: i32,
        /// `progress`: 0-100.
        progress: i32,
        /// `mass`: \[kg\].
        mass: Decimal,
        /// `cx, cy, cz`: centre of mass \[mm\].
        center: [Decimal; 3],
    }
}
}

// The table must cover the whole of chapter 4 of HR-TCP V1.0.0.3, and with
// `v6` every command the V6 document adds (its 209 sections, less the two
// of HR-TCP V1.0.0.3 it has not, plus `EnterSafetyGuard`; `MoveJ`, `MoveL`
// and `SetForceFreeDriveMode` are in HR-TCP V1.0.0.3 only).
#[cfg(not(feature = "v6"))]
const _: () = assert!(CommandId::ALL.len() == 139);
#[cfg(feature = "v6")]
const _: () = assert!(CommandId::ALL.len() == 139 + 74);
