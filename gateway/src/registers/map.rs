//! The register map: every address the PLC sees, declared once.
//! (The values are the model's: [`super::view`] encodes and decodes them.)
//!
//! `REGISTERS.md` (beside `Cargo.toml`) documents this map for PLC
//! programmers; a test compares its table with [`TABLE`] row by row.
//!
//! ## One address space, four views
//! * Holding registers (FC 3 read, FC 6/16/23 write): every address below.
//!   Writing a read-only or unmapped address fails the whole request with
//!   exception 02 and changes nothing.
//! * Input registers (FC 4): the same addresses, read-only.
//! * Coils (FC 1 read, FC 5/15 write) and discrete inputs (FC 2): bit `b` of
//!   register `r` is bit address `16 × r + b` (bit 0 = least significant).
//!   Coils may be written only where the register is writable.
//!
//! ## Value encodings
//! * `u16`: one register. `bits`: one register of flags.
//! * `f32`: IEEE-754 single in two registers; word order per
//!   [`CONFIG_FLOAT_WORD_ORDER`] (default: high word at the lower address).
//!   With [`CONFIG_NUMBER_FORMAT`] 1 every `f32` of the map is an `i32` of
//!   thousandths instead (unknown = `i32::MIN`).
//! * `i32`: two's complement in two registers, same word order as `f32`.
//! * `text`: ASCII, two characters per register, first character in the
//!   high byte; ends at the first NUL byte or at the end of the area.

/// Who may write a register.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Access {
    /// Read-only (the gateway writes it).
    Ro,
    /// Read-write (the PLC writes it).
    Rw,
}

/// What a register (group) holds, for the documentation table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Type {
    /// One 16-bit unsigned value.
    U16,
    /// A register of flag bits.
    Bits,
    /// `n` IEEE-754 single floats, two registers each.
    F32,
    /// `n` 32-bit signed integers, two registers each.
    I32,
    /// ASCII text, two characters per register.
    Text,
}

impl Type {
    /// The name used in `REGISTERS.md`.
    pub const fn name(self) -> &'static str {
        match self {
            Type::U16 => "u16",
            Type::Bits => "bits",
            Type::F32 => "f32",
            Type::I32 => "i32",
            Type::Text => "text",
        }
    }
}

/// One row of the map: a register or a group of registers of one kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Area {
    /// Name used in `REGISTERS.md`.
    pub name: &'static str,
    /// First address (0-based protocol address).
    pub start: u16,
    /// Number of registers.
    pub len: u16,
    /// Access.
    pub access: Access,
    /// Value type.
    pub ty: Type,
}

/// The register map's version in `VERSION`: `major × 256 + minor`. The
/// minor number grows when the map gains registers or a documented detail
/// changes (1.1: RESULTS read NaN until a command gives them; urgent RAW and
/// trigger texts go out in their canonical form; 1.2: the network and
/// access settings at 160-193, the access status at 50-53; 1.3: the
/// firmware's version and update state at 55-58; 1.4: the number format
/// at 117, real numbers as thousandths in 32-bit integers for PLCs that
/// cannot pack floats; 1.5: the protected settings, which Modbus changes
/// only where an administrator allowed configuration over Modbus, and
/// `ACCESS` bit 5; who owns the command inputs and the EtherNet/IP
/// adapter's status at 59-63, Modbus writes to the command inputs refused
/// while an EtherNet/IP PLC owns them); the major number when a PLC
/// program written for the old map would break.
pub const MAP_VERSION: u16 = 0x0105;

// ----------------------------------------------------------------- status
/// The register map's version ([`MAP_VERSION`]).
pub const STATUS_VERSION: u16 = 0;
/// Incremented by the gateway every poll period (wraps), robot or not.
pub const STATUS_HEARTBEAT: u16 = 1;
/// Milliseconds since the robot status was last refreshed (65535 = never or
/// longer).
pub const STATUS_AGE_MS: u16 = 2;
/// Robot link state, see [`LinkState`](crate::state::LinkState).
pub const STATUS_LINK_STATE: u16 = 3;
/// Number of robot connections established since start (wraps).
pub const STATUS_LINK_CONNECTS: u16 = 4;
/// Gateway error code of the last link failure (0 = none yet).
pub const STATUS_LINK_LAST_ERROR: u16 = 5;
/// FSM state (`ReadCurFSM`), 65535 = unknown.
pub const STATUS_FSM: u16 = 6;
/// Robot flags, see the `FLAG_*` bits.
pub const STATUS_FLAGS: u16 = 7;
/// Robot error code (`ReadRobotState` `nErrorCode`), i32.
pub const STATUS_ERROR_CODE: u16 = 8;
/// Robot error axis.
pub const STATUS_ERROR_AXIS: u16 = 10;
/// Where the status comes from: 0 = polling the command port, 1 = DataSheet.
pub const STATUS_SOURCE: u16 = 11;
/// Speed override ratio 0.01-1, f32 (NaN = unknown).
pub const STATUS_OVERRIDE: u16 = 12;
/// Actual joints J1-J6 \[°\], 6 × f32.
pub const STATUS_JOINTS: u16 = 14;
/// Actual TCP pose X, Y, Z \[mm\], Rx, Ry, Rz \[°\], 6 × f32.
pub const STATUS_POSE: u16 = 26;
/// Electric box general digital inputs, bits 0-7.
pub const STATUS_BOX_DI: u16 = 38;
/// Electric box general digital outputs, bits 0-7.
pub const STATUS_BOX_DO: u16 = 39;
/// Electric box configurable digital inputs, bits 0-7.
pub const STATUS_BOX_CI: u16 = 40;
/// Electric box configurable digital outputs, bits 0-7.
pub const STATUS_BOX_CO: u16 = 41;
/// Tool-end digital inputs, bits 0-2.
pub const STATUS_END_DI: u16 = 42;
/// Tool-end digital outputs, bits 0-2.
pub const STATUS_END_DO: u16 = 43;
/// Which I/O registers are valid: bit 0 box DI, 1 box DO, 2 box CI, 3 box
/// CO, 4 end DI, 5 end DO.
pub const STATUS_IO_VALID: u16 = 44;
/// Jobs waiting in the command queue.
pub const STATUS_QUEUE_USED: u16 = 45;
/// Modbus clients connected.
pub const STATUS_SESSIONS: u16 = 46;
/// Watchdog: bit 0 armed (a motion runs and the watchdog is on), bit 1
/// tripped (latched until the PLC heartbeat changes again).
pub const STATUS_WATCHDOG: u16 = 47;
/// Number of watchdog trips since start (wraps).
pub const STATUS_WATCHDOG_TRIPS: u16 = 48;
/// The command whose motion is running on the robot: 0 none, 1-2 command
/// channel, 3 RAW, 16-31 trigger entry 0-15.
pub const STATUS_ACTIVE_MOTION: u16 = 49;
/// Access flags ([`ACCESS_WRITE_PROTECTED`], ...).
pub const STATUS_ACCESS: u16 = 50;
/// Modbus connections refused by [`MODBUS_ALLOW`] since start (wraps).
pub const STATUS_MODBUS_REFUSED: u16 = 51;
/// Web connections refused by [`WEB_ALLOW`] since start (wraps).
pub const STATUS_WEB_REFUSED: u16 = 52;
/// Modbus writes refused by the write protection, or by the role of a
/// Modbus/TCP Security client's certificate, since start (wraps).
pub const STATUS_WRITES_REFUSED: u16 = 53;
/// The controller's protocol level in use: major × 100 + minor (606 for
/// HR6.6.x, 500 for V5), 0 = not known yet.
pub const STATUS_PROTOCOL: u16 = 54;
/// The running firmware's version: major, minor, patch (from its signed
/// image header); 0, 0, 0 where the platform installs no images (Linux,
/// the core firmwares).
pub const STATUS_FW_VERSION: u16 = 55;
/// The firmware update's state: 0 = no updates here, 1 = confirmed, 2 = on
/// trial (swapped in, not yet confirmed by its self-check), 3 = an update
/// waits for the restart, 4 = rolled back (the last update never confirmed
/// itself).
pub const STATUS_FW_STATE: u16 = 58;
/// Who owns the command inputs: 0 Modbus, 1 an EtherNet/IP PLC (its
/// exclusive-owner connection is open and in Run), 2 the same in Idle
/// (program mode: its data is not applied). While it is not 0, Modbus
/// writes to the command inputs get exception 01.
pub const STATUS_COMMAND_OWNER: u16 = 59;
/// EtherNet/IP connections open (class 1 and class 3).
pub const STATUS_ENIP_CONNECTIONS: u16 = 60;
/// EtherNet/IP sessions and datagrams refused by the allow-list
/// (`enip.allow`) and Forward_Opens refused by the ownership rule,
/// since start (wraps).
pub const STATUS_ENIP_REFUSED: u16 = 61;
/// O->T class 1 datagrams missed since start, every connection: produced
/// by the PLC at its RPI (its sequence numbers count them) and never
/// received (wraps).
pub const STATUS_ENIP_MISSED: u16 = 62;
/// Datagrams on the class 1 I/O port from allowed addresses that no
/// connection took (unknown connection id, wrong originator, malformed,
/// stale, wrong size): dropped, counted since start (wraps).
pub const STATUS_ENIP_IO_DROPPED: u16 = 63;

/// `STATUS_ACCESS` bit: the configuration registers and trigger texts are
/// write-protected ([`CONFIG_WRITE_PROTECT`]).
pub const ACCESS_WRITE_PROTECTED: u16 = 1 << 0;
/// `STATUS_ACCESS` bit: an administrator account exists.
pub const ACCESS_ADMIN: u16 = 1 << 1;
/// `STATUS_ACCESS` bit: the network settings applied differ from the ones
/// running (they take effect at the next start).
pub const ACCESS_RESTART_PENDING: u16 = 1 << 2;
/// `STATUS_ACCESS` bit: started with the factory network and access
/// settings (the board's button was held at power-up).
pub const ACCESS_RECOVERY: u16 = 1 << 3;
/// `STATUS_ACCESS` bit: the web page is served.
pub const ACCESS_WEB_ON: u16 = 1 << 4;
/// `STATUS_ACCESS` bit: the protected settings (robot endpoint, link mode,
/// network and access settings) may be changed over Modbus: an
/// administrator allowed configuration over Modbus, or a recovery start.
pub const ACCESS_MODBUS_CONFIG: u16 = 1 << 5;

/// `STATUS_FLAGS` bit: moving.
pub const FLAG_MOVING: u16 = 1 << 0;
/// `STATUS_FLAGS` bit: enabled.
pub const FLAG_ENABLED: u16 = 1 << 1;
/// `STATUS_FLAGS` bit: error.
pub const FLAG_ERROR: u16 = 1 << 2;
/// `STATUS_FLAGS` bit: paused.
pub const FLAG_PAUSED: u16 = 1 << 3;
/// `STATUS_FLAGS` bit: emergency stop.
pub const FLAG_EMERGENCY_STOP: u16 = 1 << 4;
/// `STATUS_FLAGS` bit: safety guard.
pub const FLAG_SAFETY_GUARD: u16 = 1 << 5;
/// `STATUS_FLAGS` bit: powered (48 V).
pub const FLAG_POWERED: u16 = 1 << 6;
/// `STATUS_FLAGS` bit: electric box connected.
pub const FLAG_BOX_CONNECTED: u16 = 1 << 7;
/// `STATUS_FLAGS` bit: blending (way-point motion) done.
pub const FLAG_BLENDING_DONE: u16 = 1 << 8;
/// `STATUS_FLAGS` bit: in position.
pub const FLAG_IN_POSITION: u16 = 1 << 9;
/// `STATUS_FLAGS` bit: brakes released.
pub const FLAG_BRAKE_RELEASED: u16 = 1 << 10;
/// `STATUS_FLAGS` bit: the flags above come from the robot over the current
/// link (0 = no valid robot state).
pub const FLAG_VALID: u16 = 1 << 15;

// ----------------------------------------------------------------- config
/// Robot IPv4 address, first two octets (`a × 256 + b`).
pub const CONFIG_ROBOT_IP: u16 = 100;
/// Robot command port (connect mode).
pub const CONFIG_ROBOT_PORT: u16 = 102;
/// 0 = the gateway connects to the robot, 1 = the robot connects to the
/// gateway (controller client mode).
pub const CONFIG_LINK_MODE: u16 = 103;
/// Port the gateway listens on in listen mode.
pub const CONFIG_LISTEN_PORT: u16 = 104;
/// Status poll period \[ms\], 10-100.
pub const CONFIG_POLL_MS: u16 = 105;
/// Reply timeout \[ms\], 50-60000.
pub const CONFIG_REPLY_TIMEOUT_MS: u16 = 106;
/// Word order of `f32`/`i32`: 0 = high word first, 1 = low word first.
pub const CONFIG_FLOAT_WORD_ORDER: u16 = 107;
/// Watchdog period \[ms\]: 0 = off, else 50-60000.
pub const CONFIG_WATCHDOG_MS: u16 = 108;
/// Watchdog action: 0 = report only, 1 = `GrpStop`, 2 = `GrpInterrupt`.
pub const CONFIG_WATCHDOG_ACTION: u16 = 109;
/// Motion-completion policy bits: 0 = also wait for blending done, 1 = also
/// wait for in position.
pub const CONFIG_MOTION_POLICY: u16 = 110;
/// Time a motion may report "not moving" after it was accepted (or after a
/// `GrpContinue`) before that counts as finished \[ms\], 0-5000.
pub const CONFIG_START_GRACE_MS: u16 = 111;
/// 1 = send `GrpReset` after a motion ends in a robot error.
pub const CONFIG_AUTO_RESET: u16 = 112;
/// Status source: 0 = poll the command port, 1 = DataSheet port.
pub const CONFIG_STATUS_SOURCE: u16 = 113;
/// DataSheet port (JSON, 10004-10006).
pub const CONFIG_DATASHEET_PORT: u16 = 114;
/// Robot id sent in commands (`nRbtID`), 0-5.
pub const CONFIG_ROBOT_ID: u16 = 115;
/// Protocol level: 0 detect, 1 V5, 2 V6.
pub const CONFIG_PROTOCOL: u16 = 116;
/// How the `f32` registers carry numbers: 0 = IEEE-754 single (default),
/// 1 = a 32-bit integer of thousandths.
pub const CONFIG_NUMBER_FORMAT: u16 = 117;
/// Number of configuration registers from [`CONFIG_ROBOT_IP`].
pub const CONFIG_LEN: u16 = 18;

// ------------------------------------------- network and access settings
// Settings like the ones above: edited, then applied with CONFIG_COMMAND 1.
/// The gateway's IPv4 address (two registers).
pub const NET_IP: u16 = 160;
/// Network mask (two registers).
pub const NET_MASK: u16 = 162;
/// Default gateway (two registers), 0.0.0.0 = none.
pub const NET_GATEWAY: u16 = 164;
/// 1 = DHCP.
pub const NET_DHCP: u16 = 166;
/// Modbus TCP port.
pub const NET_MODBUS_PORT: u16 = 167;
/// Web page port, 0 = off.
pub const NET_WEB_PORT: u16 = 168;
/// 1 = configuration registers and trigger texts write-protected.
pub const CONFIG_WRITE_PROTECT: u16 = 169;
/// Modbus allow-list: 4 entries of 3 registers (address, prefix length).
pub const MODBUS_ALLOW: u16 = 170;
/// Web allow-list, as [`MODBUS_ALLOW`].
pub const WEB_ALLOW: u16 = 182;
/// Number of registers from [`NET_IP`].
pub const NET_LEN: u16 = 34;

// ---------------------------------------------------------------- control
/// PLC heartbeat: the PLC changes it; watched while a motion runs.
pub const CONTROL_HEARTBEAT: u16 = 140;
/// Configuration command (write-triggered, reads 0): 1 = apply the
/// configuration registers and save them with the trigger table, 2 =
/// discard edits (reload the active configuration), 3 = load factory
/// defaults into the configuration registers (not applied until 1).
pub const CONTROL_CONFIG_COMMAND: u16 = 141;
/// Result of the last configuration command: 0 ok (applied and saved), 1
/// invalid value, 2 applied but storage failed, 3 applied but not saved (no
/// persistent storage).
pub const CONTROL_CONFIG_RESULT: u16 = 142;
/// Address of the first invalid configuration register (when result = 1).
pub const CONTROL_CONFIG_BAD_ADDR: u16 = 143;
/// Number of saves to persistent storage since start (wraps).
pub const CONTROL_SAVES: u16 = 144;

// ------------------------------------------------------- command channels
/// Number of command channels (a size of the state).
pub use crate::state::CHANNELS;
/// First address of command channel 0.
pub const CHANNEL_BASE: u16 = 200;
/// Distance between channels.
pub const CHANNEL_STRIDE: u16 = 200;
/// Offset: control bits (bit 0 = Execute).
pub const CH_CONTROL: u16 = 0;
/// Offset: command code, see [`crate::job::code`].
pub const CH_COMMAND: u16 = 1;
/// Offset: sequence number, echoed in [`CH_SEQ_ECHO`].
pub const CH_SEQUENCE: u16 = 2;
/// Offset: reserved (writable, ignored), so that a channel's inputs are one
/// contiguous block.
pub const CH_RESERVED: u16 = 3;
/// Offset: parameters P0-P11, 12 × f32.
pub const CH_PARAMS: u16 = 4;
/// Number of `f32` parameters.
pub const CH_PARAM_COUNT: usize = 12;
/// Offset: text 1 (32 characters): tool name, or script function name.
pub const CH_TEXT1: u16 = 28;
/// Offset: text 2 (32 characters): user frame name, or function parameters
/// separated by `|`.
pub const CH_TEXT2: u16 = 44;
/// Registers per text parameter.
pub const CH_TEXT_REGS: u16 = 16;
/// Offset: status bits ([`ST_BUSY`] ...).
pub const CH_STATUS: u16 = 60;
/// Offset: the sequence number of the command shown.
pub const CH_SEQ_ECHO: u16 = 61;
/// Offset: ErrorID, i32.
pub const CH_ERROR_ID: u16 = 62;
/// Offset: error source, see [`ErrorSource`](crate::engine::ErrorSource).
pub const CH_ERROR_SOURCE: u16 = 64;
/// Offset: the command code of the command shown.
pub const CH_COMMAND_ECHO: u16 = 65;
/// Offset: results R0-R23, 24 × f32.
pub const CH_RESULTS: u16 = 66;
/// Number of `f32` results.
pub const CH_RESULT_COUNT: usize = 24;

/// Status bit: the command is queued or running.
pub const ST_BUSY: u16 = 1 << 0;
/// Status bit: the command finished successfully.
pub const ST_DONE: u16 = 1 << 1;
/// Status bit: the command failed; see ErrorID and error source.
pub const ST_ERROR: u16 = 1 << 2;
/// Status bit: the command was aborted by another command (`GrpStop`).
pub const ST_ABORTED: u16 = 1 << 3;
/// Status bit: its motion is running on the robot.
pub const ST_ACTIVE: u16 = 1 << 4;
/// Status bit: waiting in the queue.
pub const ST_QUEUED: u16 = 1 << 5;

/// First address of command channel `i`.
pub const fn channel_base(i: usize) -> u16 {
    CHANNEL_BASE + CHANNEL_STRIDE * i as u16
}

// -------------------------------------------------------------------- RAW
/// RAW: control bits (bit 0 = Execute).
pub const RAW_CONTROL: u16 = 600;
/// RAW: sequence number.
pub const RAW_SEQUENCE: u16 = 601;
/// RAW: the request text, 128 registers (256 characters).
pub const RAW_REQUEST: u16 = 602;
/// Registers of the RAW request text.
pub const RAW_REQUEST_REGS: u16 = 128;
/// RAW: status bits, as [`CH_STATUS`].
pub const RAW_STATUS: u16 = 730;
/// RAW: sequence echo.
pub const RAW_SEQ_ECHO: u16 = 731;
/// RAW: ErrorID, i32.
pub const RAW_ERROR_ID: u16 = 732;
/// RAW: error source.
pub const RAW_ERROR_SOURCE: u16 = 734;
/// RAW: length of the reply in characters (whole reply, even if truncated).
pub const RAW_REPLY_LEN: u16 = 735;
/// RAW: 1 when the reply was longer than the reply area and was cut.
pub const RAW_REPLY_TRUNCATED: u16 = 736;
/// RAW: the reply text, 256 registers (512 characters).
pub const RAW_REPLY: u16 = 737;
/// Registers of the RAW reply text.
pub const RAW_REPLY_REGS: u16 = 256;

// --------------------------------------------------------------- triggers
// ------------------------------------------------------------ error text
/// The robot error code whose text is shown (i32).
pub const ERROR_TEXT_CODE: u16 = 1000;
/// Where the text comes from: 0 none yet, 1 the controller
/// (`GetErrorCodeStr`), 2 the gateway's table, 3 unknown code.
pub const ERROR_TEXT_SOURCE: u16 = 1002;
/// Texts stored since start (wraps): a new one has come.
pub const ERROR_TEXT_COUNT: u16 = 1003;
/// The text, 64 registers (128 characters).
pub const ERROR_TEXT: u16 = 1004;
/// Registers of the error text.
pub const ERROR_TEXT_REGS: u16 = 64;

/// Number of trigger-table entries (a size of the state).
pub use crate::state::inputs::TRIGGERS;
/// Trigger bits: a rising edge of bit `i` fires entry `i`.
pub const TRIG_BITS: u16 = 1100;
/// Busy bits, one per entry.
pub const TRIG_BUSY: u16 = 1101;
/// Done bits.
pub const TRIG_DONE: u16 = 1102;
/// Error bits.
pub const TRIG_ERROR: u16 = 1103;
/// CommandAborted bits.
pub const TRIG_ABORTED: u16 = 1104;
/// ErrorID per entry, 16 × i32.
pub const TRIG_ERROR_ID: u16 = 1105;
/// Error source per entry, 16 × u16.
pub const TRIG_ERROR_SOURCE: u16 = 1137;
/// First entry's protocol text.
pub const TRIG_TEXT_BASE: u16 = 1200;
/// Distance between entries' texts.
pub const TRIG_TEXT_STRIDE: u16 = 100;
/// Registers per entry text (192 characters).
pub const TRIG_TEXT_REGS: u16 = 96;

/// First address of trigger entry `i`'s text.
pub const fn trigger_text(i: usize) -> u16 {
    TRIG_TEXT_BASE + TRIG_TEXT_STRIDE * i as u16
}

/// Registers in the map (one past the highest address).
pub const MAP_LEN: usize =
    (TRIG_TEXT_BASE + TRIG_TEXT_STRIDE * (TRIGGERS as u16 - 1) + TRIG_TEXT_REGS) as usize;

// Every register's bits are reachable as coils (16 × address < 65536).
const _: () = assert!(MAP_LEN * 16 <= 65536);

macro_rules! area {
    ($name:expr, $start:expr, $len:expr, $acc:ident, $ty:ident) => {
        Area {
            name: $name,
            start: $start,
            len: $len,
            access: Access::$acc,
            ty: Type::$ty,
        }
    };
}

macro_rules! channel_areas {
    ($i:literal) => {
        [
            area!(
                concat!("CH", $i, "_CONTROL"),
                channel_base($i) + CH_CONTROL,
                1,
                Rw,
                Bits
            ),
            area!(
                concat!("CH", $i, "_COMMAND"),
                channel_base($i) + CH_COMMAND,
                1,
                Rw,
                U16
            ),
            area!(
                concat!("CH", $i, "_SEQUENCE"),
                channel_base($i) + CH_SEQUENCE,
                1,
                Rw,
                U16
            ),
            area!(
                concat!("CH", $i, "_RESERVED"),
                channel_base($i) + CH_RESERVED,
                1,
                Rw,
                U16
            ),
            area!(
                concat!("CH", $i, "_PARAMS"),
                channel_base($i) + CH_PARAMS,
                24,
                Rw,
                F32
            ),
            area!(
                concat!("CH", $i, "_TEXT1"),
                channel_base($i) + CH_TEXT1,
                16,
                Rw,
                Text
            ),
            area!(
                concat!("CH", $i, "_TEXT2"),
                channel_base($i) + CH_TEXT2,
                16,
                Rw,
                Text
            ),
            area!(
                concat!("CH", $i, "_STATUS"),
                channel_base($i) + CH_STATUS,
                1,
                Ro,
                Bits
            ),
            area!(
                concat!("CH", $i, "_SEQ_ECHO"),
                channel_base($i) + CH_SEQ_ECHO,
                1,
                Ro,
                U16
            ),
            area!(
                concat!("CH", $i, "_ERROR_ID"),
                channel_base($i) + CH_ERROR_ID,
                2,
                Ro,
                I32
            ),
            area!(
                concat!("CH", $i, "_ERROR_SOURCE"),
                channel_base($i) + CH_ERROR_SOURCE,
                1,
                Ro,
                U16
            ),
            area!(
                concat!("CH", $i, "_COMMAND_ECHO"),
                channel_base($i) + CH_COMMAND_ECHO,
                1,
                Ro,
                U16
            ),
            area!(
                concat!("CH", $i, "_RESULTS"),
                channel_base($i) + CH_RESULTS,
                48,
                Ro,
                F32
            ),
        ]
    };
}

const CH0: [Area; 13] = channel_areas!(0);
const CH1: [Area; 13] = channel_areas!(1);

// Only called from constants (an index out of bounds fails the build).
#[allow(clippy::indexing_slicing)]
const fn trigger_text_area(i: usize) -> Area {
    const NAMES: [&str; TRIGGERS] = [
        "TRIG0_TEXT",
        "TRIG1_TEXT",
        "TRIG2_TEXT",
        "TRIG3_TEXT",
        "TRIG4_TEXT",
        "TRIG5_TEXT",
        "TRIG6_TEXT",
        "TRIG7_TEXT",
        "TRIG8_TEXT",
        "TRIG9_TEXT",
        "TRIG10_TEXT",
        "TRIG11_TEXT",
        "TRIG12_TEXT",
        "TRIG13_TEXT",
        "TRIG14_TEXT",
        "TRIG15_TEXT",
    ];
    Area {
        name: if i < TRIGGERS { NAMES[i] } else { "TRIG?_TEXT" },
        start: trigger_text(i),
        len: TRIG_TEXT_REGS,
        access: Access::Rw,
        ty: Type::Text,
    }
}

/// Every mapped register group, sorted by address. The single source the
/// `REGISTERS.md` table is checked against.
pub const TABLE: &[Area] = &[
    area!("VERSION", STATUS_VERSION, 1, Ro, U16),
    area!("HEARTBEAT", STATUS_HEARTBEAT, 1, Ro, U16),
    area!("STATUS_AGE_MS", STATUS_AGE_MS, 1, Ro, U16),
    area!("LINK_STATE", STATUS_LINK_STATE, 1, Ro, U16),
    area!("LINK_CONNECTS", STATUS_LINK_CONNECTS, 1, Ro, U16),
    area!("LINK_LAST_ERROR", STATUS_LINK_LAST_ERROR, 1, Ro, U16),
    area!("FSM_STATE", STATUS_FSM, 1, Ro, U16),
    area!("ROBOT_FLAGS", STATUS_FLAGS, 1, Ro, Bits),
    area!("ROBOT_ERROR_CODE", STATUS_ERROR_CODE, 2, Ro, I32),
    area!("ROBOT_ERROR_AXIS", STATUS_ERROR_AXIS, 1, Ro, U16),
    area!("STATUS_SOURCE", STATUS_SOURCE, 1, Ro, U16),
    area!("OVERRIDE", STATUS_OVERRIDE, 2, Ro, F32),
    area!("ACT_JOINTS", STATUS_JOINTS, 12, Ro, F32),
    area!("ACT_POSE", STATUS_POSE, 12, Ro, F32),
    area!("BOX_DI", STATUS_BOX_DI, 1, Ro, Bits),
    area!("BOX_DO", STATUS_BOX_DO, 1, Ro, Bits),
    area!("BOX_CI", STATUS_BOX_CI, 1, Ro, Bits),
    area!("BOX_CO", STATUS_BOX_CO, 1, Ro, Bits),
    area!("END_DI", STATUS_END_DI, 1, Ro, Bits),
    area!("END_DO", STATUS_END_DO, 1, Ro, Bits),
    area!("IO_VALID", STATUS_IO_VALID, 1, Ro, Bits),
    area!("QUEUE_USED", STATUS_QUEUE_USED, 1, Ro, U16),
    area!("MODBUS_SESSIONS", STATUS_SESSIONS, 1, Ro, U16),
    area!("WATCHDOG", STATUS_WATCHDOG, 1, Ro, Bits),
    area!("WATCHDOG_TRIPS", STATUS_WATCHDOG_TRIPS, 1, Ro, U16),
    area!("ACTIVE_MOTION", STATUS_ACTIVE_MOTION, 1, Ro, U16),
    area!("ACCESS", STATUS_ACCESS, 1, Ro, Bits),
    area!("MODBUS_REFUSED", STATUS_MODBUS_REFUSED, 1, Ro, U16),
    area!("WEB_REFUSED", STATUS_WEB_REFUSED, 1, Ro, U16),
    area!("WRITES_REFUSED", STATUS_WRITES_REFUSED, 1, Ro, U16),
    area!("PROTOCOL_LEVEL", STATUS_PROTOCOL, 1, Ro, U16),
    area!("FW_VERSION", STATUS_FW_VERSION, 3, Ro, U16),
    area!("FW_STATE", STATUS_FW_STATE, 1, Ro, U16),
    area!("COMMAND_OWNER", STATUS_COMMAND_OWNER, 1, Ro, U16),
    area!("ENIP_CONNECTIONS", STATUS_ENIP_CONNECTIONS, 1, Ro, U16),
    area!("ENIP_REFUSED", STATUS_ENIP_REFUSED, 1, Ro, U16),
    area!("ENIP_MISSED", STATUS_ENIP_MISSED, 1, Ro, U16),
    area!("ENIP_IO_DROPPED", STATUS_ENIP_IO_DROPPED, 1, Ro, U16),
    area!("CFG_ROBOT_IP", CONFIG_ROBOT_IP, 2, Rw, U16),
    area!("CFG_ROBOT_PORT", CONFIG_ROBOT_PORT, 1, Rw, U16),
    area!("CFG_LINK_MODE", CONFIG_LINK_MODE, 1, Rw, U16),
    area!("CFG_LISTEN_PORT", CONFIG_LISTEN_PORT, 1, Rw, U16),
    area!("CFG_POLL_MS", CONFIG_POLL_MS, 1, Rw, U16),
    area!("CFG_REPLY_TIMEOUT_MS", CONFIG_REPLY_TIMEOUT_MS, 1, Rw, U16),
    area!("CFG_FLOAT_WORD_ORDER", CONFIG_FLOAT_WORD_ORDER, 1, Rw, U16),
    area!("CFG_WATCHDOG_MS", CONFIG_WATCHDOG_MS, 1, Rw, U16),
    area!("CFG_WATCHDOG_ACTION", CONFIG_WATCHDOG_ACTION, 1, Rw, U16),
    area!("CFG_MOTION_POLICY", CONFIG_MOTION_POLICY, 1, Rw, Bits),
    area!("CFG_START_GRACE_MS", CONFIG_START_GRACE_MS, 1, Rw, U16),
    area!("CFG_AUTO_RESET", CONFIG_AUTO_RESET, 1, Rw, U16),
    area!("CFG_STATUS_SOURCE", CONFIG_STATUS_SOURCE, 1, Rw, U16),
    area!("CFG_DATASHEET_PORT", CONFIG_DATASHEET_PORT, 1, Rw, U16),
    area!("CFG_ROBOT_ID", CONFIG_ROBOT_ID, 1, Rw, U16),
    area!("CFG_PROTOCOL", CONFIG_PROTOCOL, 1, Rw, U16),
    area!("CFG_NUMBER_FORMAT", CONFIG_NUMBER_FORMAT, 1, Rw, U16),
    area!("PLC_HEARTBEAT", CONTROL_HEARTBEAT, 1, Rw, U16),
    area!("CONFIG_COMMAND", CONTROL_CONFIG_COMMAND, 1, Rw, U16),
    area!("CONFIG_RESULT", CONTROL_CONFIG_RESULT, 1, Ro, U16),
    area!("CONFIG_BAD_ADDR", CONTROL_CONFIG_BAD_ADDR, 1, Ro, U16),
    area!("CONFIG_SAVES", CONTROL_SAVES, 1, Ro, U16),
    area!("NET_IP", NET_IP, 2, Rw, U16),
    area!("NET_MASK", NET_MASK, 2, Rw, U16),
    area!("NET_GATEWAY", NET_GATEWAY, 2, Rw, U16),
    area!("NET_DHCP", NET_DHCP, 1, Rw, U16),
    area!("NET_MODBUS_PORT", NET_MODBUS_PORT, 1, Rw, U16),
    area!("NET_WEB_PORT", NET_WEB_PORT, 1, Rw, U16),
    area!("CFG_WRITE_PROTECT", CONFIG_WRITE_PROTECT, 1, Rw, U16),
    area!("MODBUS_ALLOW", MODBUS_ALLOW, 12, Rw, U16),
    area!("WEB_ALLOW", WEB_ALLOW, 12, Rw, U16),
    CH0[0],
    CH0[1],
    CH0[2],
    CH0[3],
    CH0[4],
    CH0[5],
    CH0[6],
    CH0[7],
    CH0[8],
    CH0[9],
    CH0[10],
    CH0[11],
    CH0[12],
    CH1[0],
    CH1[1],
    CH1[2],
    CH1[3],
    CH1[4],
    CH1[5],
    CH1[6],
    CH1[7],
    CH1[8],
    CH1[9],
    CH1[10],
    CH1[11],
    CH1[12],
    area!("RAW_CONTROL", RAW_CONTROL, 1, Rw, Bits),
    area!("RAW_SEQUENCE", RAW_SEQUENCE, 1, Rw, U16),
    area!("RAW_REQUEST", RAW_REQUEST, RAW_REQUEST_REGS, Rw, Text),
    area!("RAW_STATUS", RAW_STATUS, 1, Ro, Bits),
    area!("RAW_SEQ_ECHO", RAW_SEQ_ECHO, 1, Ro, U16),
    area!("RAW_ERROR_ID", RAW_ERROR_ID, 2, Ro, I32),
    area!("RAW_ERROR_SOURCE", RAW_ERROR_SOURCE, 1, Ro, U16),
    area!("RAW_REPLY_LEN", RAW_REPLY_LEN, 1, Ro, U16),
    area!("RAW_REPLY_TRUNCATED", RAW_REPLY_TRUNCATED, 1, Ro, U16),
    area!("RAW_REPLY", RAW_REPLY, RAW_REPLY_REGS, Ro, Text),
    area!("ERROR_TEXT_CODE", ERROR_TEXT_CODE, 2, Ro, I32),
    area!("ERROR_TEXT_SOURCE", ERROR_TEXT_SOURCE, 1, Ro, U16),
    area!("ERROR_TEXT_COUNT", ERROR_TEXT_COUNT, 1, Ro, U16),
    area!("ERROR_TEXT", ERROR_TEXT, ERROR_TEXT_REGS, Ro, Text),
    area!("TRIG_BITS", TRIG_BITS, 1, Rw, Bits),
    area!("TRIG_BUSY", TRIG_BUSY, 1, Ro, Bits),
    area!("TRIG_DONE", TRIG_DONE, 1, Ro, Bits),
    area!("TRIG_ERROR", TRIG_ERROR, 1, Ro, Bits),
    area!("TRIG_ABORTED", TRIG_ABORTED, 1, Ro, Bits),
    area!("TRIG_ERROR_ID", TRIG_ERROR_ID, 32, Ro, I32),
    area!("TRIG_ERROR_SOURCE", TRIG_ERROR_SOURCE, 16, Ro, U16),
    trigger_text_area(0),
    trigger_text_area(1),
    trigger_text_area(2),
    trigger_text_area(3),
    trigger_text_area(4),
    trigger_text_area(5),
    trigger_text_area(6),
    trigger_text_area(7),
    trigger_text_area(8),
    trigger_text_area(9),
    trigger_text_area(10),
    trigger_text_area(11),
    trigger_text_area(12),
    trigger_text_area(13),
    trigger_text_area(14),
    trigger_text_area(15),
];

/// The area holding `addr`, if mapped.
pub fn area_of(addr: u16) -> Option<&'static Area> {
    let i = TABLE.partition_point(|a| a.start + a.len <= addr);
    TABLE.get(i).filter(|a| a.start <= addr)
}

/// Why a register access was refused (maps to a Modbus exception).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AccessError {
    /// An address is unmapped, or read-only for a write (exception 02).
    IllegalAddress,
}

/// Checks that `count` registers from `start` are mapped (and writable if
/// `write`).
pub fn check(start: u16, count: u16, write: bool) -> Result<(), AccessError> {
    let end = u32::from(start) + u32::from(count);
    if end > MAP_LEN as u32 {
        return Err(AccessError::IllegalAddress);
    }
    let mut addr = u32::from(start);
    while addr < end {
        let a = area_of(addr as u16).ok_or(AccessError::IllegalAddress)?;
        if write && a.access != Access::Rw {
            return Err(AccessError::IllegalAddress);
        }
        addr = u32::from(a.start) + u32::from(a.len);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_is_sorted_without_overlap_and_inside_the_map() {
        for w in TABLE.windows(2) {
            assert!(
                w[0].start + w[0].len <= w[1].start,
                "{:?} overlaps {:?}",
                w[0],
                w[1]
            );
        }
        let last = TABLE.last().unwrap();
        assert_eq!(usize::from(last.start + last.len), MAP_LEN);
    }

    #[test]
    fn area_lookup_and_access_checks() {
        assert_eq!(area_of(STATUS_JOINTS + 11).unwrap().name, "ACT_JOINTS");
        assert_eq!(area_of(57).unwrap().name, "FW_VERSION");
        assert_eq!(area_of(61).unwrap().name, "ENIP_REFUSED");
        assert_eq!(area_of(63).unwrap().name, "ENIP_IO_DROPPED");
        assert!(area_of(64).is_none());
        assert!(check(0, 64, false).is_ok());
        assert_eq!(check(0, 65, false), Err(AccessError::IllegalAddress));
        assert!(check(NET_IP, NET_LEN, true).is_ok());
        assert!(check(NET_IP, NET_LEN + 1, true).is_err());
        assert_eq!(check(0, 1, true), Err(AccessError::IllegalAddress));
        assert!(check(CONFIG_ROBOT_IP, CONFIG_LEN, true).is_ok());
        // A channel's inputs are one writable block, its whole extent readable.
        assert!(check(channel_base(1), CH_STATUS, true).is_ok());
        assert!(check(channel_base(1), CH_STATUS + 1, true).is_err());
        assert!(check(channel_base(1), CH_RESULTS + 48, false).is_ok());
        assert!(check(RAW_CONTROL, RAW_REPLY + RAW_REPLY_REGS - RAW_CONTROL, false).is_ok());
        assert!(check(TRIG_BITS, TRIG_ERROR_SOURCE + 16 - TRIG_BITS, false).is_ok());
        assert!(check(u16::MAX, 1, false).is_err());
    }
}
