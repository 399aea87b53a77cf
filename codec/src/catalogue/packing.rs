//! How the command table is packed into flash: every byte-saving trick of
//! the catalogue lives here, and nowhere else.
//!
//! ## What the table says, and where it ends up
//!
//! The table (`table.rs`) declares each command once. The `catalogue!`
//! macro turns it into code (one struct, reader and writer per command) and
//! into plain lists that only the compiler reads: every wire name
//! (`WIRE_NAME_LIST`), every parameter's name (`PARAM_NAMES`) and range
//! (`PARAM_RANGES`), how many parameters each command has
//! (`PARAM_COUNTS`). The `const` code below builds the flash tables from
//! those lists; the lists themselves never reach flash.
//!
//! * **Wire names**: one text with all names run together ([`WIRE_TEXT`])
//!   and where each ends ([`NAME_ENDS`], 2 bytes per command, where a table
//!   of string references took 8). [`CommandId::name`] slices the text.
//! * **Name lookup**: an open-addressing hash table ([`BY_HASH`], one byte
//!   per slot) over the names and aliases; one or two probes where a binary
//!   search made eight comparisons (every message read looks its name up).
//! * **Parameters**: readers, writers and range checks identify a parameter
//!   by a [`Param`], one byte: its position in its command's entry (the
//!   request's parameters from 0, the reply's values after them). Passing
//!   that byte instead of a name (a pointer and a length) at each of the
//!   table's ~1,200 call sites saves ~5 KiB of flash. The name is looked up
//!   only to report an error, the range only when a checking writer meets a
//!   value (`Request::validate`). Each distinct name is stored once
//!   ([`POOL`]), each distinct range once ([`RANGE_POOL`]), each distinct
//!   (name, range) pair once ([`PAIRS`]); every parameter of every command
//!   is one byte in [`IDS`].
//! * **Protocol levels**: most commands are there since V5 and never
//!   removed; only the others have an entry in [`EXCEPTIONS`] (the version
//!   that added and removed each, as indices into [`LEVELS`]).
//!
//! ## Following a parameter from the table to its range check
//!
//! The table entry `SetOverride { rbt_id: RobotId = RBT, ratio: Decimal =
//! num("0.01", "1") }` makes `ratio` parameter 1 of `SetOverride`.
//! `Request::validate` runs the request's writer in checking mode; the writer
//! hands each number with its `Param` to the check, which asks
//! [`Param::range`]: `PARAM_STARTS[SetOverride] + 1` is the parameter's
//! index in the table, [`IDS`] gives its pair, [`PAIRS`] its range's index in
//! [`RANGE_POOL`]: `0.01..=1`. [`Param::name`] follows the same path to
//! `"ratio"`. The tests at the end check both against the table's lists for
//! every parameter of every command.
//!
//! Indexing in the `const fn`s runs only in the compiler, where an
//! out-of-bounds index is a build error.
#![allow(clippy::indexing_slicing)]

use super::table::{ALIASES, PARAM_COUNTS, PARAM_NAMES, PARAM_RANGES, WIRE_NAME_LIST};
use super::table::{REMOVED_LIST, SINCE_LIST};
use super::CommandId;
use crate::level::ProtocolLevel;
use crate::types::{Param, Range};

// ------------------------------------------------------------- wire names

/// Commands in the table.
const COMMANDS: usize = WIRE_NAME_LIST.len();

/// The bytes of every wire name, run together.
const WIRE_LEN: usize = {
    let (mut n, mut i) = (0, 0);
    while i < COMMANDS {
        n += WIRE_NAME_LIST[i].len();
        i += 1;
    }
    n
};

/// Every wire name, in [`CommandId::ALL`] order, run together.
const WIRE_BYTES: [u8; WIRE_LEN] = {
    let mut text = [0u8; WIRE_LEN];
    let (mut at, mut i) = (0, 0);
    while i < COMMANDS {
        let name = WIRE_NAME_LIST[i].as_bytes();
        let mut k = 0;
        while k < name.len() {
            text[at] = name[k];
            at += 1;
            k += 1;
        }
        i += 1;
    }
    text
};

/// [`WIRE_BYTES`] as text.
const WIRE_TEXT: &str = match core::str::from_utf8(&WIRE_BYTES) {
    Ok(s) => s,
    Err(_) => panic!("wire names are ASCII"),
};

/// Where each wire name ends in [`WIRE_TEXT`].
const NAME_ENDS: [u16; COMMANDS] = {
    let mut ends = [0u16; COMMANDS];
    let (mut total, mut i) = (0, 0);
    while i < COMMANDS {
        total += WIRE_NAME_LIST[i].len();
        assert!(total <= u16::MAX as usize);
        ends[i] = total as u16;
        i += 1;
    }
    ends
};

/// The wire name of the command with discriminant `i` (`""` for none).
#[cfg_attr(not(target_os = "none"), inline)]
pub(super) const fn wire_name(i: usize) -> &'static str {
    let (start, end) = match i {
        0 => (0, NAME_ENDS[0]),
        // `i` is a discriminant: below `NAME_ENDS.len()`.
        _ if i < NAME_ENDS.len() => (NAME_ENDS[i - 1], NAME_ENDS[i]),
        _ => (0, 0),
    };
    match WIRE_TEXT.split_at_checked(end as usize) {
        Some((head, _)) => match head.split_at_checked(start as usize) {
            Some((_, name)) => name,
            None => "",
        },
        None => "",
    }
}

// ------------------------------------------------------------- name lookup

/// Names the hash table holds: wire names, then aliases.
const KEYS: usize = COMMANDS + ALIASES.len();

/// Slots of the name table: a power of two, under two thirds full.
const HASH_SLOTS: usize = {
    let mut slots = 64;
    while KEYS * 3 >= slots * 2 {
        slots *= 2;
    }
    slots
};

/// A slot of the name table for a name, from its length and three of its
/// bytes (also run by the compiler to build the table). Cheap rather than
/// strong: a collision costs one more probe, which compares lengths first.
const fn name_hash(name: &[u8]) -> usize {
    // The top bits of the product mix all of the input's.
    (mix(name) >> (32 - HASH_SLOTS.trailing_zeros())) as usize
}

/// A name's length and three of its bytes, multiplied to spread them over
/// all 32 bits (the top ones best).
const fn mix(name: &[u8]) -> u32 {
    let n = name.len();
    let h = match n {
        0 => 0,
        _ => {
            (n as u32)
                | (name[0] as u32) << 8
                | (name[n / 2] as u32) << 16
                | (name[n - 1] as u32) << 24
        }
    };
    h.wrapping_mul(0x9E37_79B1)
}

/// The name of key `k`: a wire name, or an alias after them.
const fn key_name(k: usize) -> &'static str {
    if k < COMMANDS {
        WIRE_NAME_LIST[k]
    } else {
        ALIASES[k - COMMANDS].0
    }
}

/// Open addressing (linear probing) over the keys, as their index (wire
/// names: the discriminant; aliases: [`COMMANDS`] plus their index into
/// `ALIASES`); indexed by [`name_hash`], `u8::MAX` marks a free slot.
static BY_HASH: [u8; HASH_SLOTS] = {
    assert!(KEYS < u8::MAX as usize);
    let mut table = [u8::MAX; HASH_SLOTS];
    let mut k = 0;
    while k < KEYS {
        let mut slot = name_hash(key_name(k).as_bytes());
        while table[slot] != u8::MAX {
            slot = (slot + 1) % HASH_SLOTS;
        }
        table[slot] = k as u8;
        k += 1;
    }
    table
};

/// The command with this wire name or alias (exact letter case).
pub(super) fn command_named(name: &str) -> Option<CommandId> {
    let mut slot = name_hash(name.as_bytes());
    for _ in 0..HASH_SLOTS {
        let key = usize::from(*BY_HASH.get(slot)?);
        let (k, id) = match CommandId::ALL.get(key) {
            Some(&id) => (id.name(), id),
            None => *ALIASES.get(key - COMMANDS)?,
        };
        if k == name {
            return Some(id);
        }
        slot = (slot + 1) % HASH_SLOTS;
    }
    None
}

// ------------------------------------------------------------- levels

/// `true` when a command has the default levels: there since V5, never
/// removed.
const fn default_levels(i: usize) -> bool {
    SINCE_LIST[i].same(&ProtocolLevel::V5) && REMOVED_LIST[i].is_none()
}

/// Commands whose levels are not the default.
const EXCEPTIONS_LEN: usize = {
    let (mut n, mut i) = (0, 0);
    while i < COMMANDS {
        if !default_levels(i) {
            n += 1;
        }
        i += 1;
    }
    n
};

/// Marks "none" among level indices.
const NO_LEVEL: u8 = u8::MAX;

/// The index of `level` in `levels[..n]`, or `n` when it is not there.
const fn level_index(levels: &[ProtocolLevel], n: usize, level: &ProtocolLevel) -> usize {
    let mut k = 0;
    while k < n {
        if levels[k].same(level) {
            return k;
        }
        k += 1;
    }
    n
}

/// The distinct versions of the table other than V5, and how many there
/// are.
const LEVEL_LIST: ([ProtocolLevel; 2 * EXCEPTIONS_LEN], usize) = {
    let mut levels = [ProtocolLevel::V5; 2 * EXCEPTIONS_LEN];
    let (mut n, mut i) = (0, 0);
    while i < COMMANDS {
        if !default_levels(i) {
            let since = SINCE_LIST[i];
            if !since.same(&ProtocolLevel::V5) && level_index(&levels, n, &since) == n {
                levels[n] = since;
                n += 1;
            }
            if let Some(r) = REMOVED_LIST[i] {
                if level_index(&levels, n, &r) == n {
                    levels[n] = r;
                    n += 1;
                }
            }
        }
        i += 1;
    }
    (levels, n)
};

/// Each distinct version once (indexed by [`EXCEPTIONS`]).
static LEVELS: [ProtocolLevel; LEVEL_LIST.1] = {
    let mut levels = [ProtocolLevel::V5; LEVEL_LIST.1];
    let mut k = 0;
    while k < LEVEL_LIST.1 {
        levels[k] = LEVEL_LIST.0[k];
        k += 1;
    }
    levels
};

/// The commands whose levels are not the default, in discriminant order:
/// the discriminant, the index of the version that added it in [`LEVELS`]
/// ([`NO_LEVEL`] for V5) and of the version that removed it ([`NO_LEVEL`]
/// for none). Most commands need no entry: three bytes each for the few
/// that do, where a version per command took four.
static EXCEPTIONS: [[u8; 3]; EXCEPTIONS_LEN] = {
    let mut out = [[0u8; 3]; EXCEPTIONS_LEN];
    let (mut n, mut i) = (0, 0);
    while i < COMMANDS {
        if !default_levels(i) {
            assert!(i < u8::MAX as usize && LEVEL_LIST.1 < NO_LEVEL as usize);
            let since = SINCE_LIST[i];
            let s = if since.same(&ProtocolLevel::V5) {
                NO_LEVEL
            } else {
                level_index(&LEVEL_LIST.0, LEVEL_LIST.1, &since) as u8
            };
            let r = match REMOVED_LIST[i] {
                Some(r) => level_index(&LEVEL_LIST.0, LEVEL_LIST.1, &r) as u8,
                None => NO_LEVEL,
            };
            out[n] = [i as u8, s, r];
            n += 1;
        }
        i += 1;
    }
    out
};

/// The level indices (added, removed) of the command with discriminant `i`.
const fn level_codes(i: usize) -> (u8, u8) {
    let mut k = 0;
    while k < EXCEPTIONS.len() {
        let [cmd, s, r] = EXCEPTIONS[k];
        if cmd as usize == i {
            return (s, r);
        }
        k += 1;
    }
    (NO_LEVEL, NO_LEVEL)
}

/// The version at index `code` of [`LEVELS`], `None` for [`NO_LEVEL`].
const fn level_at(code: u8) -> Option<ProtocolLevel> {
    if (code as usize) < LEVELS.len() {
        Some(LEVELS[code as usize])
    } else {
        None
    }
}

/// The controller version that added the command with discriminant `i`.
pub(super) const fn since(i: usize) -> ProtocolLevel {
    match level_at(level_codes(i).0) {
        Some(l) => l,
        None => ProtocolLevel::V5,
    }
}

/// The controller version that removed the command with discriminant `i`.
pub(super) const fn removed(i: usize) -> Option<ProtocolLevel> {
    level_at(level_codes(i).1)
}

// ------------------------------------------------------------- parameters

/// Parameters in the whole table (every command's request and reply).
const FIELDS: usize = PARAM_NAMES.len();

/// Where each command's parameters start in the table's lists, and where
/// the last command's end.
const PARAM_STARTS: [u16; COMMANDS + 1] = {
    let mut starts = [0u16; COMMANDS + 1];
    let mut i = 0;
    while i < COMMANDS {
        // A `Param` is one byte, `u8::MAX` excluded.
        assert!(PARAM_COUNTS[i] < u8::MAX as usize);
        let next = starts[i] as usize + PARAM_COUNTS[i];
        assert!(next <= u16::MAX as usize);
        starts[i + 1] = next as u16;
        i += 1;
    }
    assert!(starts[COMMANDS] as usize == FIELDS);
    starts
};

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

// The three `FIRST*` lists below say, for each parameter, which earlier
// parameter is equal to it. They are built in O(n) (names through a hash
// table, ranges and pairs against the few distinct values seen so far):
// comparing every parameter with every earlier one is O(n²) in the
// compiler's `const` interpreter, and took 6 s of every build of the crate.

/// Slots of the table [`FIRST`] is built with: a power of two, at most
/// half full.
const FIELD_SLOTS: usize = {
    let mut slots = 64;
    while FIELDS * 2 > slots {
        slots *= 2;
    }
    slots
};

/// For each parameter, the first parameter with its name.
const FIRST: [u16; FIELDS] = {
    assert!(FIELDS < u16::MAX as usize);
    let mut first = [0u16; FIELDS];
    // Slot -> parameter index + 1 (0: free).
    let mut table = [0u16; FIELD_SLOTS];
    let mut i = 0;
    while i < FIELDS {
        let mut slot =
            (mix(PARAM_NAMES[i].as_bytes()) >> (32 - FIELD_SLOTS.trailing_zeros())) as usize;
        loop {
            let seen = table[slot] as usize;
            if seen == 0 {
                table[slot] = i as u16 + 1;
                first[i] = i as u16;
                break;
            }
            if same(PARAM_NAMES[seen - 1], PARAM_NAMES[i]) {
                first[i] = (seen - 1) as u16;
                break;
            }
            slot = (slot + 1) % FIELD_SLOTS;
        }
        i += 1;
    }
    first
};

/// For each parameter, the first parameter with its range (compared with
/// the first of each distinct range: there are a few dozen).
const FIRST_RANGE: [u16; FIELDS] = {
    let mut first = [0u16; FIELDS];
    let mut distinct = [0u16; FIELDS];
    let (mut n, mut i) = (0, 0);
    while i < FIELDS {
        let mut k = 0;
        while k < n && !same_range(&PARAM_RANGES[distinct[k] as usize], &PARAM_RANGES[i]) {
            k += 1;
        }
        if k == n {
            distinct[n] = i as u16;
            n += 1;
        }
        first[i] = distinct[k];
        i += 1;
    }
    first
};

/// For each parameter, the first parameter with its name and range: the
/// first with the same pair of [`FIRST`] and [`FIRST_RANGE`] entries.
const FIRST_PAIR: [u16; FIELDS] = {
    let mut first = [0u16; FIELDS];
    let mut distinct = [0u16; FIELDS];
    let (mut n, mut i) = (0, 0);
    while i < FIELDS {
        let mut k = 0;
        while k < n {
            let d = distinct[k] as usize;
            if FIRST[d] == FIRST[i] && FIRST_RANGE[d] == FIRST_RANGE[i] {
                break;
            }
            k += 1;
        }
        if k == n {
            distinct[n] = i as u16;
            n += 1;
        }
        first[i] = distinct[k];
        i += 1;
    }
    first
};

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

/// For each parameter, its range (an index into [`RANGE_POOL`]); distinct
/// ranges ("none" is one of them).
const RANGES: ([u8; FIELDS], usize) = classes(&FIRST_RANGE);

/// The distinct ranges (a `static`: one copy).
static RANGE_POOL: [Option<Range>; RANGES.1] = {
    let mut pool = [None; RANGES.1];
    let mut i = 0;
    while i < FIELDS {
        pool[RANGES.0[i] as usize] = PARAM_RANGES[i];
        i += 1;
    }
    pool
};

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
    fn every_wire_name_is_as_in_the_table() {
        for &id in CommandId::ALL {
            assert_eq!(id.name(), WIRE_NAME_LIST[id as usize]);
        }
        assert_eq!(wire_name(COMMANDS), "");
    }

    #[test]
    fn every_level_is_as_in_the_table() {
        for &id in CommandId::ALL {
            assert_eq!(id.since(), SINCE_LIST[id as usize], "{id}");
            assert_eq!(id.removed(), REMOVED_LIST[id as usize], "{id}");
        }
        assert_eq!(CommandId::MoveJ.removed(), ProtocolLevel::parse("HR5.50.3"));
    }

    #[test]
    fn the_name_table_has_room() {
        const { assert!(KEYS * 3 < HASH_SLOTS * 2) };
        let used = BY_HASH.iter().filter(|&&k| k != u8::MAX).count();
        assert_eq!(used, KEYS);
    }

    #[test]
    fn every_parameter_is_named_as_in_the_table() {
        let mut k = 0;
        for &id in CommandId::ALL {
            let (start, end) = (PARAM_STARTS[id as usize], PARAM_STARTS[id as usize + 1]);
            assert_eq!(usize::from(end - start), PARAM_COUNTS[id as usize]);
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
    fn the_documented_path_from_name_to_range() {
        // The example of the module's description.
        let id = CommandId::SetOverride;
        let k = usize::from(PARAM_STARTS[id as usize]) + 1;
        assert_eq!(PARAM_NAMES[k], "ratio");
        let [name, range] = PAIRS[usize::from(IDS[k])];
        let name = usize::from(name);
        assert_eq!(
            &POOL[usize::from(OFFSETS[name])..usize::from(OFFSETS[name + 1])],
            "ratio"
        );
        let range = RANGE_POOL[usize::from(range)].unwrap();
        assert!(range.same(&crate::types::num("0.01", "1")));
        assert_eq!(Param(1).range(Some(id)), Some(&range));
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
