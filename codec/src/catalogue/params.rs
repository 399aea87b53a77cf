//! The names and ranges of the table's parameters, packed for flash.
//!
//! Readers, writers and range checks identify a parameter by a [`Param`],
//! its position in its command's entry (request parameters from 0, the
//! reply's values after them). Its name is looked up here only when an
//! error is reported, its range when a checking writer meets one of its
//! values (`Request::validate`). Passing one byte instead of a
//! `&'static str` at each of the table's ~1,200 call sites saves ~5 KiB of
//! flash on Cortex-M; names and ranges then cost about 2.5 KiB here, and
//! error texts are unchanged.
//!
//! The compiler builds everything below from the table (`PARAM_NAMES`,
//! `PARAM_RANGES`, `PARAM_STARTS`): each distinct name is stored once in
//! [`POOL`] (141 of 480 are distinct), each distinct range once in
//! [`RANGE_POOL`], each distinct (name, range) pair once in [`PAIRS`], and
//! every parameter of every command is one byte in [`IDS`]. The lists the
//! table gives are only read by the compiler and never reach flash.
//! Indexing in the `const fn`s runs only in the compiler, where an
//! out-of-bounds index is a build error.
#![allow(clippy::indexing_slicing)]

use super::table::{PARAM_NAMES, PARAM_RANGES, PARAM_STARTS};
use super::CommandId;
use crate::types::{Param, Range};

/// Parameters in the whole table (every command's request and reply).
const FIELDS: usize = PARAM_NAMES.len();

/// `true` when two names are equal (`==` on `str` is not `const`).
const fn same(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

/// `true` when two parameters have the same range, or both none.
const fn same_range(a: &Option<Range>, b: &Option<Range>) -> bool {
    match (a, b) {
        (Some(a), Some(b)) => a.same(b),
        (None, None) => true,
        _ => false,
    }
}

/// For each parameter, the index of the first parameter equal to it by
/// `KIND`: 0 the name, 1 the range, 2 both.
const fn firsts<const KIND: u8>() -> [u16; FIELDS] {
    let mut first = [0u16; FIELDS];
    let mut i = 0;
    while i < FIELDS {
        let mut j = 0;
        while j < i {
            let name = same(PARAM_NAMES[j], PARAM_NAMES[i]);
            let range = same_range(&PARAM_RANGES[j], &PARAM_RANGES[i]);
            let equal = match KIND {
                0 => name,
                1 => range,
                _ => name && range,
            };
            if equal {
                break;
            }
            j += 1;
        }
        first[i] = j as u16;
        i += 1;
    }
    first
}

/// Classes of equal parameters, numbered in order of first appearance:
/// `first` as `firsts` gives it; for each parameter its class, and how
/// many classes there are.
const fn classes(first: &[u16; FIELDS]) -> ([u8; FIELDS], usize) {
    let mut ids = [0u8; FIELDS];
    let (mut n, mut i) = (0, 0);
    while i < FIELDS {
        let f = first[i] as usize;
        if f == i {
            assert!(n < u8::MAX as usize);
            ids[i] = n as u8;
            n += 1;
        } else {
            ids[i] = ids[f];
        }
        i += 1;
    }
    (ids, n)
}

/// For each parameter, the first parameter with its name.
const FIRST: [u16; FIELDS] = firsts::<0>();
/// For each parameter, its name (an index into [`OFFSETS`]); distinct names.
const NAMES: ([u8; FIELDS], usize) = classes(&FIRST);

/// The bytes of the distinct names run together.
const POOL_LEN: usize = {
    let (mut bytes, mut i) = (0, 0);
    while i < FIELDS {
        if FIRST[i] as usize == i {
            bytes += PARAM_NAMES[i].len();
        }
        i += 1;
    }
    bytes
};

/// Each distinct name once, in table order, run together.
const POOL_BYTES: [u8; POOL_LEN] = {
    let mut pool = [0u8; POOL_LEN];
    let (mut at, mut i) = (0, 0);
    while i < FIELDS {
        if FIRST[i] as usize == i {
            let name = PARAM_NAMES[i].as_bytes();
            let mut k = 0;
            while k < name.len() {
                pool[at] = name[k];
                at += 1;
                k += 1;
            }
        }
        i += 1;
    }
    pool
};

/// [`POOL_BYTES`] as text.
const POOL: &str = match core::str::from_utf8(&POOL_BYTES) {
    Ok(s) => s,
    Err(_) => panic!("parameter names are ASCII"),
};

/// Where the distinct names start in [`POOL`], and where the last ends.
const OFFSETS: [u16; NAMES.1 + 1] = {
    let mut offsets = [0u16; NAMES.1 + 1];
    let (mut at, mut n, mut i) = (0, 0, 0);
    while i < FIELDS {
        if FIRST[i] as usize == i {
            offsets[n] = at as u16;
            at += PARAM_NAMES[i].len();
            n += 1;
        }
        i += 1;
    }
    assert!(at <= u16::MAX as usize);
    offsets[n] = at as u16;
    offsets
};

/// For each parameter, the first parameter with its range.
const FIRST_RANGE: [u16; FIELDS] = firsts::<1>();
/// For each parameter, its range (an index into [`RANGE_POOL`]); distinct
/// ranges ("none" is one of them).
const RANGES: ([u8; FIELDS], usize) = classes(&FIRST_RANGE);

/// The distinct ranges (a `static`: one copy, referenced by errors).
static RANGE_POOL: [Option<Range>; RANGES.1] = {
    let mut pool = [None; RANGES.1];
    let mut i = 0;
    while i < FIELDS {
        pool[RANGES.0[i] as usize] = PARAM_RANGES[i];
        i += 1;
    }
    pool
};

/// For each parameter, the first parameter with its name and range.
const FIRST_PAIR: [u16; FIELDS] = firsts::<2>();
/// For each parameter, its (name, range) pair (an index into [`PAIRS`]);
/// distinct pairs.
const PAIR_IDS: ([u8; FIELDS], usize) = classes(&FIRST_PAIR);

/// Each distinct pair of a name (index into [`OFFSETS`]) and a range (index
/// into [`RANGE_POOL`]). One byte per parameter and two per pair: a name
/// and a range index per parameter took 2 × 480 bytes, pairs ~480 + 2 × 170.
static PAIRS: [[u8; 2]; PAIR_IDS.1] = {
    let mut pairs = [[0u8; 2]; PAIR_IDS.1];
    let mut i = 0;
    while i < FIELDS {
        pairs[PAIR_IDS.0[i] as usize] = [NAMES.0[i], RANGES.0[i]];
        i += 1;
    }
    pairs
};
/// Each parameter's pair, as an index into [`PAIRS`].
static IDS: [u8; FIELDS] = PAIR_IDS.0;

/// The (name, range) pair of parameter `p` of `command`.
fn pair(command: CommandId, p: Param) -> Option<&'static [u8; 2]> {
    PAIRS.get(usize::from(*IDS.get(position(command, p)?)?))
}

/// The position of parameter `p` of `command` in the table's lists.
fn position(command: CommandId, p: Param) -> Option<usize> {
    let i = command as usize;
    let (Some(&start), Some(&end)) = (PARAM_STARTS.get(i), PARAM_STARTS.get(i + 1)) else {
        return None;
    };
    let k = usize::from(start) + usize::from(p.0);
    (k < usize::from(end)).then_some(k)
}

impl Param {
    /// The valid range of this parameter of `command`, if the table gives
    /// one.
    pub(crate) fn range(self, command: Option<CommandId>) -> Option<&'static Range> {
        RANGE_POOL
            .get(usize::from(pair(command?, self)?[1]))?
            .as_ref()
    }

    /// The name of this parameter of `command`, as in the table (empty for
    /// a position the command does not have).
    pub(crate) fn name(self, command: Option<CommandId>) -> &'static str {
        if self == Param::RAW {
            return "field";
        }
        let Some(&[n, _]) = command.and_then(|id| pair(id, self)) else {
            return "";
        };
        let n = usize::from(n);
        match (OFFSETS.get(n), OFFSETS.get(n + 1)) {
            (Some(&s), Some(&e)) => POOL.get(usize::from(s)..usize::from(e)).unwrap_or(""),
            _ => "",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_parameter_is_named_as_in_the_table() {
        let mut k = 0;
        for &id in CommandId::ALL {
            let (start, end) = (PARAM_STARTS[id as usize], PARAM_STARTS[id as usize + 1]);
            for p in 0..(end - start) {
                let name = Param(p as u8).name(Some(id));
                assert_eq!(name, PARAM_NAMES[k], "{id} parameter {p}");
                k += 1;
            }
            assert_eq!(Param((end - start) as u8).name(Some(id)), "", "{id}");
        }
        assert_eq!(k, PARAM_NAMES.len());
        assert_eq!(Param::RAW.name(None), "field");
        assert_eq!(Param(0).name(None), "");
    }

    #[test]
    fn every_parameter_has_its_range_from_the_table() {
        let mut k = 0;
        let mut ranged = 0;
        for &id in CommandId::ALL {
            let n = PARAM_STARTS[id as usize + 1] - PARAM_STARTS[id as usize];
            for p in 0..n {
                assert_eq!(
                    Param(p as u8).range(Some(id)),
                    PARAM_RANGES[k].as_ref(),
                    "{id} {p}"
                );
                ranged += usize::from(PARAM_RANGES[k].is_some());
                k += 1;
            }
            assert_eq!(Param(n as u8).range(Some(id)), None);
        }
        assert!(ranged > 200, "{ranged} parameters have a range");
        assert!(RANGES.1 < ranged / 4, "{} distinct ranges", RANGES.1);
        // Pairs pay off only while fewer than half the parameters are distinct.
        const { assert!(PAIR_IDS.1 < FIELDS / 2) };
        assert_eq!(Param::RAW.range(None), None);
    }

    #[test]
    fn each_name_is_stored_once() {
        for (a, pair) in OFFSETS.windows(2).enumerate() {
            let name = &POOL[usize::from(pair[0])..usize::from(pair[1])];
            assert!(!name.is_empty());
            for later in OFFSETS.windows(2).skip(a + 1) {
                assert_ne!(name, &POOL[usize::from(later[0])..usize::from(later[1])]);
            }
        }
    }
}
