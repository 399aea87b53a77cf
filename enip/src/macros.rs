//! Crate-internal macros.

/// An enum of named protocol values plus `Unknown(n)`, with `From` both
/// ways, so values from the wire that this crate has no name for survive
/// instead of failing (the pattern of smoltcp's `enum_with_unknown!`).
macro_rules! enum_with_unknown {
    (
        $(#[doc = $edoc:literal])*
        pub enum $Enum:ident($Ty:ty) {
            $( $(#[doc = $doc:literal])* $name:ident = $code:literal, )*
        }
    ) => {
        $(#[doc = $edoc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub enum $Enum {
            $( $(#[doc = $doc])* $name, )*
            /// A value this crate has no name for, kept as sent.
            Unknown($Ty),
        }

        impl From<$Ty> for $Enum {
            fn from(v: $Ty) -> Self {
                match v {
                    $( $code => $Enum::$name, )*
                    other => $Enum::Unknown(other),
                }
            }
        }

        impl From<$Enum> for $Ty {
            fn from(c: $Enum) -> $Ty {
                match c {
                    $( $Enum::$name => $code, )*
                    $Enum::Unknown(v) => v,
                }
            }
        }
    };
}

/// Logs through `defmt` when the feature is on, and compiles to nothing
/// (the arguments still type-check) without it.
macro_rules! log_debug {
    ($($arg:tt)*) => {{
        #[cfg(feature = "defmt")]
        defmt::debug!($($arg)*);
    }};
}
