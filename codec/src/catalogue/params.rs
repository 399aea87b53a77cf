//! The names of the table's parameters, packed for flash.
//!
//! Readers, writers and range checks identify a parameter by a [`Param`],
//! its position in its command's entry (request parameters from 0, the
//! reply's values after them), and name it only when they report an error.
//! Passing one byte instead of a `&'static str` at each of the table's
//! ~1,200 call sites saves ~5 KiB of flash on Cortex-M; the names then cost
//! about 2 KiB here, and error texts are unchanged.
//!
//! The compiler builds everything below from the table (`PARAM_NAMES`,
//! `PARAM_STARTS`): each distinct name is stored once in [`POOL`] (141 of
//! 480 are distinct), and every parameter of every command is one byte in
//! [`IDS`]. The lists of names themselves are only read by the compiler
//! and never reach flash. Indexing in the `const fn`s runs only in the
//! compiler, where an out-of-bounds index is a build error.
#![allow(clippy::indexing_slicing)]

use super::table::{PARAM_NAMES, PARAM_STARTS};
use super::CommandId;
use crate::types::Param;

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
const IDS: [u8; FIELDS] = {
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

impl Param {
    /// The name of this parameter of `command`, as in the table (empty for
    /// a position the command does not have).
    pub(crate) fn name(self, command: Option<CommandId>) -> &'static str {
        if self == Param::RAW {
            return "field";
        }
        let Some(id) = command else {
            return "";
        };
        let i = id as usize;
        let (Some(&start), Some(&end)) = (PARAM_STARTS.get(i), PARAM_STARTS.get(i + 1)) else {
            return "";
        };
        let k = usize::from(start) + usize::from(self.0);
        if k >= usize::from(end) {
            return "";
        }
        let Some(&n) = IDS.get(k) else {
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
