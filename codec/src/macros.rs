//! Crate-internal macros.

/// An enum of named protocol values plus `Unknown(i32)`, with `From` both
/// ways, so values this crate has no name for survive instead of failing
/// (the pattern of smoltcp's `enum_with_unknown!`).
macro_rules! enum_with_unknown {
    (
        $(#[doc = $edoc:literal])*
        pub enum $Enum:ident {
            $( $(#[doc = $doc:literal])* $name:ident = $code:literal, )*
        }
    ) => {
        $(#[doc = $edoc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub enum $Enum {
            $( $(#[doc = $doc])* $name, )*
            /// A value this crate has no name for, kept as sent.
            Unknown(i32),
        }

        impl From<i32> for $Enum {
            fn from(v: i32) -> Self {
                match v {
                    $( $code => $Enum::$name, )*
                    other => $Enum::Unknown(other),
                }
            }
        }

        impl From<$Enum> for i32 {
            fn from(c: $Enum) -> i32 {
                match c {
                    $( $Enum::$name => $code, )*
                    $Enum::Unknown(v) => v,
                }
            }
        }

        impl $Enum {
            /// The name, or `None` for values without one.
            pub fn name(&self) -> Option<&'static str> {
                match self {
                    $( $Enum::$name => Some(stringify!($name)), )*
                    $Enum::Unknown(_) => None,
                }
            }

            /// The numeric value.
            pub fn code(self) -> i32 {
                i32::from(self)
            }
        }

        impl core::fmt::Display for $Enum {
            fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                match self.name() {
                    Some(n) => write!(f, "{} ({n})", self.code()),
                    None => write!(f, "{}", self.code()),
                }
            }
        }
    };
}
