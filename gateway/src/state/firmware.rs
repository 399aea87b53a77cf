//! The firmware as the gateway knows it: the running and previous
//! versions, the boot state of an A/B update, the last upload. Part of the
//! typed state (every build has it: a build or platform without updates
//! shows `supported: false`), so the registers (`FW_VERSION`, `FW_STATE`)
//! and the page are views of it; the update machinery (`crate::update`,
//! feature `update`) changes it.

pub use hans_fw_image::Version;

/// The boot state, as the application finds it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BootState {
    /// The running image is confirmed (or was never updated).
    Confirmed,
    /// The running image was just swapped in and is on trial: unless it
    /// confirms itself, the next restart brings the previous one back.
    Trial,
    /// An update is marked and waits for the restart that swaps it in.
    Pending,
    /// The bootloader rolled a trial image back: the running image is the
    /// one from before the update.
    RolledBack,
}

impl BootState {
    /// The state's name in the API (`/api/status`, `firmware.state`).
    pub fn as_str(self) -> &'static str {
        match self {
            BootState::Confirmed => "confirmed",
            BootState::Trial => "trial",
            BootState::Pending => "pending",
            BootState::RolledBack => "rolled back",
        }
    }

    /// Its code in `FW_STATE` (0 is "no updates here").
    pub fn code(self) -> u16 {
        match self {
            BootState::Confirmed => 1,
            BootState::Trial => 2,
            BootState::Pending => 3,
            BootState::RolledBack => 4,
        }
    }
}

/// Where an upload is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Upload {
    /// None since the start.
    Idle,
    /// An image of `version` is arriving: `received` of `total` bytes.
    Receiving {
        /// Its version.
        version: Version,
        /// Bytes received.
        received: u32,
        /// Bytes in all.
        total: u32,
    },
    /// `version` is written and marked: the next restart swaps it in.
    Installed {
        /// Its version.
        version: Version,
    },
    /// The last image was refused (nothing was installed): why.
    Refused {
        /// Why, for the page and the log.
        reason: &'static str,
    },
}

/// What the gateway knows of its firmware.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Firmware {
    /// This platform installs images (a board with the bootloader).
    pub supported: bool,
    /// The running image's version (its header in the active slot).
    pub running: Option<Version>,
    /// The other image the slots keep: after an update the one it
    /// replaced; after a rollback the one rolled back; none before any.
    pub previous: Option<Version>,
    /// The boot state.
    pub boot: Option<BootState>,
    /// The last upload.
    pub upload: Upload,
}

impl Firmware {
    /// Nothing known: no updates here (until the storage task finds slots).
    pub const NONE: Firmware = Firmware {
        supported: false,
        running: None,
        previous: None,
        boot: None,
        upload: Upload::Idle,
    };
}
