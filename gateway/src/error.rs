//! How a command ends, and the gateway's own error codes.

/// Who reported an error (register `*_ERROR_SOURCE`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ErrorSource {
    /// The robot refused the command: ErrorID is its `Fail` code.
    RobotFail = 1,
    /// The robot reported an error during the motion: ErrorID is its
    /// `ReadRobotState` error code (or a gateway code if it gave none).
    RobotMotion = 2,
    /// The gateway: ErrorID is a [`GatewayError`] code.
    Gateway = 3,
}

/// The gateway's own error codes (ErrorID with error source 3). The
/// 395xx codes are the ones the vendor's SDKs use for the same situations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GatewayError {
    /// 39500: the robot link is down.
    NotConnected = 39500,
    /// 39501: a parameter is invalid (range, integer expected, unknown
    /// command code, text not ASCII or too long).
    BadParameter = 39501,
    /// 39502: the reply could not be read, or the robot answered `errorcmd`.
    BadReply = 39502,
    /// 39503: no reply within the reply timeout (the link is reset).
    ReplyTimeout = 39503,
    /// 39504: connecting to the robot failed (refused, unreachable, no
    /// answer within the connect timeout) or its port could not be listened
    /// on. Shown in `LINK_LAST_ERROR` only.
    ConnectFailed = 39504,
    /// 39505: the reply names another command (the link is reset).
    ReplyMismatch = 39505,
    /// 39600: the command queue is full.
    QueueFull = 39600,
    /// 39601: the robot link was lost while the command was queued or ran.
    LinkLost = 39601,
    /// 39602: the watchdog stopped the motion (PLC heartbeat missing).
    Watchdog = 39602,
    /// 39603: the trigger entry is empty.
    TriggerEmpty = 39603,
    /// 39604: the robot reported an error without a code.
    RobotErrorNoCode = 39604,
    /// 39605: the robot reported an emergency stop during the motion.
    EmergencyStop = 39605,
    /// 39606: the robot reported the safety guard during the motion.
    SafetyGuard = 39606,
    /// 39607: after a bring-up step (`ConnectToBox`, `Electrify`,
    /// `StartMaster`, `GrpEnable`) the robot did not reach the state the
    /// step leads to within `engine::bringup::STATE_TIMEOUT` (30 s), or
    /// went to a fault state instead (`FSM_STATE` shows where it is).
    StateNotReached = 39607,
    /// 39608: the command is not available: the controller's protocol
    /// level lacks it (jogging needs HR6.2.17), or this build of the
    /// gateway does (the core firmwares have no jogging).
    NotSupported = 39608,
}

impl GatewayError {
    /// Every code, in order (for documentation checks and views).
    pub const ALL: [GatewayError; 15] = [
        GatewayError::NotConnected,
        GatewayError::BadParameter,
        GatewayError::BadReply,
        GatewayError::ReplyTimeout,
        GatewayError::ConnectFailed,
        GatewayError::ReplyMismatch,
        GatewayError::QueueFull,
        GatewayError::LinkLost,
        GatewayError::Watchdog,
        GatewayError::TriggerEmpty,
        GatewayError::RobotErrorNoCode,
        GatewayError::EmergencyStop,
        GatewayError::SafetyGuard,
        GatewayError::StateNotReached,
        GatewayError::NotSupported,
    ];

    /// The numeric code.
    pub const fn code(self) -> i32 {
        self as i32
    }

    /// The error with code `code`, if it is one of the gateway's.
    pub fn from_code(code: i32) -> Option<GatewayError> {
        GatewayError::ALL.into_iter().find(|e| e.code() == code)
    }

    /// A short text for logs and views.
    pub const fn as_str(self) -> &'static str {
        match self {
            GatewayError::NotConnected => "robot link down",
            GatewayError::BadParameter => "bad parameter",
            GatewayError::BadReply => "bad reply",
            GatewayError::ReplyTimeout => "reply timeout",
            GatewayError::ConnectFailed => "connect failed",
            GatewayError::ReplyMismatch => "reply names another command",
            GatewayError::QueueFull => "queue full",
            GatewayError::LinkLost => "robot link lost",
            GatewayError::Watchdog => "watchdog",
            GatewayError::TriggerEmpty => "trigger entry empty",
            GatewayError::RobotErrorNoCode => "robot error without code",
            GatewayError::EmergencyStop => "emergency stop",
            GatewayError::SafetyGuard => "safety guard",
            GatewayError::StateNotReached => "state not reached",
            GatewayError::NotSupported => "not supported by the controller or this build",
        }
    }
}

/// How a command ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Outcome {
    /// Done.
    Done,
    /// Error with its source and ErrorID.
    Error(ErrorSource, i32),
    /// CommandAborted (another command stopped the motion).
    Aborted,
}

impl Outcome {
    /// Its word in the views (`done`, `error`, `aborted`: the page, the
    /// API, the Sparkplug metrics).
    pub const fn as_str(self) -> &'static str {
        match self {
            Outcome::Done => "done",
            Outcome::Error(..) => "error",
            Outcome::Aborted => "aborted",
        }
    }

    /// A gateway error.
    pub const fn gateway(e: GatewayError) -> Outcome {
        Outcome::Error(ErrorSource::Gateway, e.code())
    }
}
