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

/// For each parameter, the index of the first parameter with its name.
const FIRST: [u16; FIELDS] = {
    let mut first = [0u16; FIELDS];
    let mut i = 0;
    while i < FIELDS {
        let mut j = 0;
        while j < i && !same(PARAM_NAMES[j], PARAM_NAMES[i]) {
            j += 1;
        }
        assert!(j <= u16::MAX as usize);
        first[i] = j as u16;
        i += 1;
    }
    first
};

/// Distinct names, and their bytes run together.
const DISTINCT: (usize, usize) = {
    let (mut n, mut bytes, mut i) = (0, 0, 0);
    while i < FIELDS {
        if FIRST[i] as usize == i {
            n += 1;
            bytes += PARAM_NAMES[i].len();
        }
        i += 1;
    }
    (n, bytes)
};

/// Each distinct name once, in table order, run together.
const POOL_BYTES: [u8; DISTINCT.1] = {
    let mut pool = [0u8; DISTINCT.1];
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
const OFFSETS: [u16; DISTINCT.0 + 1] = {
    let mut offsets = [0u16; DISTINCT.0 + 1];
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

/// For each parameter of the table, its name as an index into [`OFFSETS`].
const NAME_IDS: [u8; FIELDS] = {
    assert!(DISTINCT.0 < u8::MAX as usize);
    let mut ids = [0u8; FIELDS];
    let (mut n, mut i) = (0u8, 0);
    while i < FIELDS {
        let f = FIRST[i] as usize;
        if f == i {
            ids[i] = n;
            n += 1;
        } else {
            ids[i] = ids[f];
        }
        i += 1;
    }
    ids
};

/// Distinct ranges in the table.
const RANGES: usize = {
    let (mut n, mut i) = (0, 0);
    while i < FIELDS {
        if let Some(r) = &PARAM_RANGES[i] {
            if first_range(r, i) == i {
                n += 1;
            }
        }
        i += 1;
    }
    n
};

/// The index of the first parameter before `end` whose range is `r` (`end`
/// if none).
const fn first_range(r: &Range, end: usize) -> usize {
    let mut j = 0;
    while j < end {
        if let Some(q) = &PARAM_RANGES[j] {
            if q.same(r) {
                return j;
            }
        }
        j += 1;
    }
    end
}

/// Each distinct range once, and for each parameter of the table its range
/// as an index into that list (`u8::MAX`: no range).
const RANGE_TABLE: ([Range; RANGES], [u8; FIELDS]) = {
    assert!(RANGES < u8::MAX as usize);
    let mut pool = [Range::Int { min: 0, max: 0 }; RANGES];
    let mut ids = [u8::MAX; FIELDS];
    let (mut n, mut i) = (0, 0);
    while i < FIELDS {
        if let Some(r) = &PARAM_RANGES[i] {
            let f = first_range(r, i);
            if f == i {
                pool[n] = *r;
                ids[i] = n as u8;
                n += 1;
            } else {
                ids[i] = ids[f];
            }
        }
        i += 1;
    }
    (pool, ids)
};

/// The distinct ranges (a `static`: one copy, referenced by errors).
static RANGE_POOL: [Range; RANGES] = RANGE_TABLE.0;

/// For each parameter, the first parameter with the same name and range.
const SAME: [u16; FIELDS] = {
    let ranges = &RANGE_TABLE.1;
    let mut same = [0u16; FIELDS];
    let mut i = 0;
    while i < FIELDS {
        let mut j = 0;
        while j < i && (NAME_IDS[j] != NAME_IDS[i] || ranges[j] != ranges[i]) {
            j += 1;
        }
        same[i] = j as u16;
        i += 1;
    }
    same
};

/// Distinct (name, range) pairs.
const PAIR_COUNT: usize = {
    let (mut n, mut i) = (0, 0);
    while i < FIELDS {
        if SAME[i] as usize == i {
            n += 1;
        }
        i += 1;
    }
    n
};

/// Each distinct pair of a name (index into [`OFFSETS`]) and a range
/// (index into [`RANGE_POOL`], `u8::MAX` for none), and for each parameter
/// of the table its pair. One byte per parameter: a name and a range
/// index each took 480 bytes, the pairs take ~2 × 170.
const PAIR_TABLE: ([[u8; 2]; PAIR_COUNT], [u8; FIELDS]) = {
    assert!(PAIR_COUNT < u8::MAX as usize);
    let mut pairs = [[0u8; 2]; PAIR_COUNT];
    let mut ids = [0u8; FIELDS];
    let (mut n, mut i) = (0, 0);
    while i < FIELDS {
        let f = SAME[i] as usize;
        if f == i {
            pairs[n] = [NAME_IDS[i], RANGE_TABLE.1[i]];
            ids[i] = n as u8;
            n += 1;
        } else {
            ids[i] = ids[f];
        }
        i += 1;
    }
    (pairs, ids)
};

/// The distinct (name, range) pairs.
static PAIRS: [[u8; 2]; PAIR_COUNT] = PAIR_TABLE.0;
/// Each parameter's pair, as an index into [`PAIRS`].
static IDS: [u8; FIELDS] = PAIR_TABLE.1;

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
        RANGE_POOL.get(usize::from(pair(command?, self)?[1]))
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
        assert!(RANGES < ranged / 4, "{RANGES} distinct ranges");
        // Pairs pay off only while fewer than half the parameters are distinct.
        const { assert!(PAIR_COUNT < FIELDS / 2) };
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
