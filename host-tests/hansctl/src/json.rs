//! hansctl's JSON output: numbers exactly as the codec read them.
//!
//! `serde_json::Value` stores a number as `f64` (unless its
//! `arbitrary_precision` feature is on), which turns `-0.000` into `-0.0`
//! and `0.123456789012345678` into `0.12345678901234568`. The protocol's
//! numbers are exact decimals ([`Decimal`]), so hansctl writes its JSON with
//! this small tree instead: a [`Json::Num`] is written with the `Decimal`'s
//! own digits, which are always valid JSON number text (`-?digits[.digits]`).
//! `arbitrary_precision` was not used because Cargo unifies features across
//! the workspace: it would change how every other crate that links
//! serde_json (criterion in the benchmarks) reads numbers. Strings are still
//! escaped by serde_json. Object keys keep their insertion order.

use std::fmt;

use hans_codec::Decimal;

/// A JSON value.
#[derive(Clone, Debug, PartialEq)]
pub enum Json {
    /// `null`.
    Null,
    /// `true` / `false`.
    Bool(bool),
    /// An integer (every integer the codec reads is an `i32`).
    Int(i32),
    /// An exact decimal, written with its own digits (`-0.000` stays so).
    Num(Decimal),
    /// A 64-bit integer (Sparkplug's Int64).
    Long(i64),
    /// An unsigned 64-bit integer (Sparkplug's UInt64, DateTime).
    ULong(u64),
    /// A binary float (Sparkplug's Float and Double), written with the
    /// shortest digits that read back as the same `f64`; `null` if not
    /// finite (JSON has no NaN).
    Float(f64),
    /// A string.
    Str(String),
    /// An array.
    Arr(Vec<Json>),
    /// An object, keys in insertion order.
    Obj(Obj),
}

/// A JSON object whose keys keep the order they were inserted in.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Obj(Vec<(String, Json)>);

impl Obj {
    /// An empty object.
    pub fn new() -> Obj {
        Obj(Vec::new())
    }

    /// Sets `key` (replacing its value in place if present).
    pub fn insert(&mut self, key: &str, value: impl Into<Json>) {
        let value = value.into();
        match self.0.iter_mut().find(|(k, _)| k == key) {
            Some((_, v)) => *v = value,
            None => self.0.push((key.to_string(), value)),
        }
    }

    /// The keys and values, in order.
    pub fn iter(&self) -> impl Iterator<Item = (&str, &Json)> {
        self.0.iter().map(|(k, v)| (k.as_str(), v))
    }

    /// The value of `key`.
    pub fn get(&self, key: &str) -> Option<&Json> {
        self.0.iter().find(|(k, _)| k == key).map(|(_, v)| v)
    }
}

impl From<bool> for Json {
    fn from(v: bool) -> Json {
        Json::Bool(v)
    }
}
impl From<i32> for Json {
    fn from(v: i32) -> Json {
        Json::Int(v)
    }
}
impl From<Decimal> for Json {
    fn from(v: Decimal) -> Json {
        Json::Num(v)
    }
}
impl From<&str> for Json {
    fn from(v: &str) -> Json {
        Json::Str(v.to_string())
    }
}
impl From<String> for Json {
    fn from(v: String) -> Json {
        Json::Str(v)
    }
}
impl<T: Into<Json>> From<Option<T>> for Json {
    fn from(v: Option<T>) -> Json {
        v.map_or(Json::Null, Into::into)
    }
}
impl<T: Into<Json>> From<Vec<T>> for Json {
    fn from(v: Vec<T>) -> Json {
        Json::Arr(v.into_iter().map(Into::into).collect())
    }
}
impl<T: Into<Json> + Clone> From<&[T]> for Json {
    fn from(v: &[T]) -> Json {
        Json::Arr(v.iter().cloned().map(Into::into).collect())
    }
}
impl<T: Into<Json> + Clone, const N: usize> From<&[T; N]> for Json {
    fn from(v: &[T; N]) -> Json {
        Json::from(v.as_slice())
    }
}

/// Builds a [`Json::Obj`]: `obj! { "a" => 1, "b" => "x" }`.
#[macro_export]
macro_rules! obj {
    ($($k:literal => $v:expr),* $(,)?) => {{
        #[allow(unused_mut)]
        let mut o = $crate::json::Obj::new();
        $( o.insert($k, $v); )*
        $crate::json::Json::Obj(o)
    }};
}

fn write_str(f: &mut fmt::Formatter<'_>, s: &str) -> fmt::Result {
    f.write_str(&serde_json::to_string(s).map_err(|_| fmt::Error)?)
}

/// Compact JSON text, on one line.
impl fmt::Display for Json {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Json::Null => f.write_str("null"),
            Json::Bool(b) => write!(f, "{b}"),
            Json::Int(i) => write!(f, "{i}"),
            Json::Num(d) => write!(f, "{d}"),
            Json::Long(i) => write!(f, "{i}"),
            Json::ULong(u) => write!(f, "{u}"),
            Json::Float(x) if x.is_finite() => write!(f, "{x}"),
            Json::Float(_) => f.write_str("null"),
            Json::Str(s) => write_str(f, s),
            Json::Arr(items) => {
                f.write_str("[")?;
                for (i, v) in items.iter().enumerate() {
                    if i > 0 {
                        f.write_str(",")?;
                    }
                    write!(f, "{v}")?;
                }
                f.write_str("]")
            }
            Json::Obj(Obj(pairs)) => {
                f.write_str("{")?;
                for (i, (k, v)) in pairs.iter().enumerate() {
                    if i > 0 {
                        f.write_str(",")?;
                    }
                    write_str(f, k)?;
                    write!(f, ":{v}")?;
                }
                f.write_str("}")
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dec(s: &str) -> Decimal {
        Decimal::parse(s).unwrap()
    }

    #[test]
    fn numbers_keep_their_digits_and_the_text_is_valid_json() {
        let v = obj! {
            "z" => dec("-0.000"),
            "a" => vec![dec("10.759"), dec("0.123456789012345678"), dec("1.500000")],
            "big" => dec("12345678901234567890"),
            "s" => "quote \" backslash \\ tab \t nul \u{0}",
            "none" => Option::<i32>::None,
            "i" => -7,
            "t" => true,
        };
        let text = v.to_string();
        assert_eq!(
            text,
            r#"{"z":-0.000,"a":[10.759,0.123456789012345678,1.500000],"big":12345678901234567890,"s":"quote \" backslash \\ tab \t nul \u0000","none":null,"i":-7,"t":true}"#
        );
        let parsed: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(parsed["s"], "quote \" backslash \\ tab \t nul \u{0}");
        assert_eq!(parsed["i"], -7);
    }

    #[test]
    fn insert_replaces_in_place() {
        let mut o = Obj::new();
        o.insert("a", 1);
        o.insert("b", 2);
        o.insert("a", 3);
        assert_eq!(Json::Obj(o.clone()).to_string(), r#"{"a":3,"b":2}"#);
        assert_eq!(o.get("a"), Some(&Json::Int(3)));
        assert_eq!(o.get("c"), None);
    }

    #[test]
    fn wide_and_binary_numbers_are_valid_json() {
        let v = Json::Arr(vec![
            Json::Long(i64::MIN),
            Json::ULong(u64::MAX),
            Json::Float(0.1),
            Json::Float(1e21),
            Json::Float(-0.0),
            Json::Float(f64::NAN),
        ]);
        let text = v.to_string();
        assert_eq!(
            text,
            "[-9223372036854775808,18446744073709551615,0.1,1000000000000000000000,-0,null]"
        );
        let parsed: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(parsed[1].as_u64(), Some(u64::MAX));
    }
}
