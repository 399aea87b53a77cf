//! Logging macros: one line per event, through `defmt` on boards (feature
//! `defmt`), through `log` on Linux (feature `log`), or nowhere.
//!
//! Arguments must be `Display` and `defmt::Format` alike (integers, `&str`):
//! the same call compiles for both back ends.
#![allow(unused_macros)]

macro_rules! info {
    ($($arg:tt)*) => {{
        #[cfg(feature = "defmt")]
        defmt::info!($($arg)*);
        #[cfg(all(feature = "log", not(feature = "defmt")))]
        log::info!($($arg)*);
        #[cfg(not(any(feature = "log", feature = "defmt")))]
        { let _ = ($crate::fmt::Ignore, $($arg)*); }
    }};
}

macro_rules! warn {
    ($($arg:tt)*) => {{
        #[cfg(feature = "defmt")]
        defmt::warn!($($arg)*);
        #[cfg(all(feature = "log", not(feature = "defmt")))]
        log::warn!($($arg)*);
        #[cfg(not(any(feature = "log", feature = "defmt")))]
        { let _ = ($crate::fmt::Ignore, $($arg)*); }
    }};
}

macro_rules! debug {
    ($($arg:tt)*) => {{
        #[cfg(feature = "defmt")]
        defmt::debug!($($arg)*);
        #[cfg(all(feature = "log", not(feature = "defmt")))]
        log::debug!($($arg)*);
        #[cfg(not(any(feature = "log", feature = "defmt")))]
        { let _ = ($crate::fmt::Ignore, $($arg)*); }
    }};
}

/// Placeholder that lets the no-logging arm evaluate (and so "use") the
/// arguments without printing them.
#[allow(dead_code)]
pub(crate) struct Ignore;
