//! Field-name look-up for the DataSheet decoder: one hash probe per key
//! instead of a comparison against every known name.
//!
//! # The matching rule
//! A key matches a name when both are equal after *normalising*: ASCII
//! letters to lower case, a space to `_`, and NUL/`\n`/`\t` bytes (which
//! the official readers strip) skipped. So `"Actual Position"`,
//! `"ACTUAL_POSITION"` and `"Actual_Pos\nition"` all match
//! `Actual_Position`. Nothing else is decoded: a name spelt with `\u`
//! escapes matches nothing.
//!
//! # How
//! [`Names::new`] runs at compile time: it hashes every field and group
//! name and places it in an open-addressing table of [`SLOTS`]
//! one-byte-index slots with linear probing; a name that appears twice among
//! the fields (or among the groups) after normalising stops the build, and
//! so does a name with a byte other than an ASCII letter, digit or `_`.
//!
//! The hash mixes only four values: the length and the first, middle and
//! last bytes, case folded (`| 0x20`). That is enough to spread the names of
//! the table (a few share a hash and sit in neighbouring slots) and costs
//! the same for every key, however long. [`Names::find`] probes from the
//! key's slot: an empty slot ends the search, an occupied one is confirmed
//! by comparing the whole name byte by byte by the rule.
//! The table is never more than three-quarters full, so the probe always
//! reaches an empty slot; the loop is bounded by [`SLOTS`] anyway.
//!
//! A key holding a space or a stripped byte can miss that look-up (case
//! folding does not make a space `_`, and a stripped byte changes the
//! length); only then, and only if it does hold one, it is copied
//! normalised (stripped bytes dropped, spaces made `_`) into a buffer of
//! [`KEY_CAP`] bytes and looked up again. A longer key cannot be a name.
//!
//! Why not `phf` or a `match`: `phf` needs a build script or proc macros
//! for a table of some seventy names, and a `match` on byte strings would
//! need every name written a second time in lower case. A `const fn` keeps
//! the names where they are declared, once.

use super::deframer::is_stripped;

/// Number of slots of the hash table (a power of two).
pub(crate) const SLOTS: usize = 128;

/// Longest key, in significant bytes, that can match a name (the longest
/// name, `Actual_Joint_Acceleration`, has 25).
pub(crate) const KEY_CAP: usize = 32;

/// Slot content meaning "none".
const NONE: u8 = u8::MAX;

/// Knuth's multiplicative-hash constant (2^32 / golden ratio): the top bits
/// of the product depend on every bit of the word.
const GOLDEN: u32 = 0x9E37_79B1;

/// A byte as the matching rule sees it.
const fn normalise(b: u8) -> u8 {
    if b == b' ' {
        b'_'
    } else {
        b.to_ascii_lowercase()
    }
}

/// The slot a hash starts probing at: its top bits (the multiplication
/// mixes them best).
const fn home(h: u32) -> usize {
    (h >> (32 - SLOTS.trailing_zeros())) as usize
}

/// One slot: the field and/or the group with that name (`FTData` is both).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Slot {
    field: u8,
    group: u8,
}

impl Slot {
    const EMPTY: Slot = Slot {
        field: NONE,
        group: NONE,
    };

    const fn is_empty(self) -> bool {
        self.field == NONE && self.group == NONE
    }
}

/// What a key names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Found {
    /// Index into the field names given to [`Names::new`].
    pub(crate) field: Option<usize>,
    /// Index into the group names, when it is (also) the name of a group.
    pub(crate) group: Option<usize>,
}

impl Found {
    const NOTHING: Found = Found {
        field: None,
        group: None,
    };
}

/// The look-up table over a list of field names and a list of group names.
#[derive(Debug)]
pub(crate) struct Names {
    fields: &'static [&'static str],
    groups: &'static [&'static str],
    slots: [Slot; SLOTS],
}

/// The hash of a key: its length and its first, middle and last bytes,
/// case folded, multiplied into 32 bits. Equal for two spellings of a name
/// that differ only in case; a space and `_` hash differently (see the
/// module documentation). `0` for an empty key (no name is empty).
const fn hash_key(key: &[u8]) -> u32 {
    let len = key.len();
    let (first, mid, last) = match (key.first(), key.last()) {
        (Some(&first), Some(&last)) => {
            // `len / 2 < len`: the index is in range.
            let (_, right) = key.split_at(len / 2);
            match right.first() {
                Some(&mid) => (first, mid, last),
                None => return 0,
            }
        }
        _ => return 0,
    };
    let word = u32::from_le_bytes([(len & 0xFF) as u8, first, mid, last]) | 0x2020_2000;
    word.wrapping_mul(GOLDEN)
}

/// A byte of a key against a byte of a table name (an ASCII letter, digit
/// or `_`: [`Names::new`] checks): the same after normalising.
fn same(k: u8, n: u8) -> bool {
    k == n || (k.is_ascii_alphabetic() && k ^ 0x20 == n) || (k == b' ' && n == b'_')
}

/// Two table names equal after normalising.
const fn same_name(a: &str, b: &str) -> bool {
    let (mut a, mut b) = (a.as_bytes(), b.as_bytes());
    while let ([x, a_tail @ ..], [y, b_tail @ ..]) = (a, b) {
        if normalise(*x) != normalise(*y) {
            return false;
        }
        (a, b) = (a_tail, b_tail);
    }
    a.is_empty() && b.is_empty()
}

// The builder runs at compile time (in `static` initialisers): an index out
// of range there is a build error, not a run-time panic.
#[allow(clippy::indexing_slicing)]
impl Names {
    /// Builds the table; meant for a `static`, evaluated at compile time,
    /// where every check below is a build error rather than a panic.
    ///
    /// Panics (fails the build) when a name is empty, longer than
    /// [`KEY_CAP`] or holds a byte other than an ASCII letter, digit or `_`,
    /// when two fields or two groups have the same normalised name, or when
    /// the lists are too long for the table.
    pub(crate) const fn new(
        fields: &'static [&'static str],
        groups: &'static [&'static str],
    ) -> Names {
        assert!(
            fields.len() < NONE as usize && groups.len() < NONE as usize,
            "too many names for one-byte indices"
        );
        assert!(
            (fields.len() + groups.len()) * 4 <= SLOTS * 3,
            "the name table must stay at most three-quarters full"
        );
        let mut names = Names {
            fields,
            groups,
            slots: [Slot::EMPTY; SLOTS],
        };
        let mut i = 0;
        while i < fields.len() {
            names.insert(fields[i], i as u8, true);
            i += 1;
        }
        let mut i = 0;
        while i < groups.len() {
            names.insert(groups[i], i as u8, false);
            i += 1;
        }
        names
    }

    /// The name a slot stands for (both of its entries have it).
    const fn name_of(&self, slot: Slot) -> &'static str {
        if slot.field != NONE {
            self.fields[slot.field as usize]
        } else {
            self.groups[slot.group as usize]
        }
    }

    const fn insert(&mut self, name: &'static str, index: u8, field: bool) {
        let mut b = name.as_bytes();
        assert!(!b.is_empty() && b.len() <= KEY_CAP, "name length");
        while let [first, tail @ ..] = b {
            assert!(
                first.is_ascii_alphanumeric() || *first == b'_',
                "a name holds a byte other than a letter, a digit or '_'"
            );
            b = tail;
        }
        let mut s = home(hash_key(name.as_bytes()));
        loop {
            let slot = &mut self.slots[s];
            if slot.is_empty() {
                if field {
                    slot.field = index;
                } else {
                    slot.group = index;
                }
                return;
            }
            let here = *slot;
            if same_name(self.name_of(here), name) {
                let slot = &mut self.slots[s];
                if field {
                    assert!(slot.field == NONE, "two fields with the same name");
                    slot.field = index;
                } else {
                    assert!(slot.group == NONE, "two groups with the same name");
                    slot.group = index;
                }
                return;
            }
            s = (s + 1) % SLOTS;
        }
    }

    /// What a raw key (as the tokenizer returns it: undecoded, possibly
    /// holding stripped bytes) names, if anything.
    pub(crate) fn find(&self, raw: &[u8]) -> Found {
        if let Some(found) = self.find_clean(raw) {
            return found;
        }
        // Not a name as it is; it may be one once normalised (rare: the
        // deframer has removed stripped bytes, and names come with `_`).
        if !raw.iter().any(|&b| b == b' ' || is_stripped(b)) {
            return Found::NOTHING;
        }
        let mut key = [0u8; KEY_CAP];
        let mut len = 0;
        for &b in raw.iter().filter(|&&b| !is_stripped(b)) {
            let Some(slot) = key.get_mut(len) else {
                return Found::NOTHING;
            };
            *slot = normalise(b);
            len += 1;
        }
        self.find_clean(key.get(..len).unwrap_or(&[]))
            .unwrap_or(Found::NOTHING)
    }

    /// The look-up proper, for a key taken as it is (one holding a stripped
    /// byte matches nothing here).
    fn find_clean(&self, key: &[u8]) -> Option<Found> {
        let start = home(hash_key(key));
        for i in 0..SLOTS {
            let slot = *self.slots.get((start + i) % SLOTS)?;
            if slot.is_empty() {
                return None;
            }
            let name = self.name_of_checked(slot).as_bytes();
            if name.len() == key.len() && name.iter().zip(key).all(|(&n, &k)| same(k, n)) {
                return Some(Found {
                    field: (slot.field != NONE).then_some(usize::from(slot.field)),
                    group: (slot.group != NONE).then_some(usize::from(slot.group)),
                });
            }
        }
        None
    }

    /// [`Names::name_of`] without indexing (the table only holds valid
    /// indices, but `find` runs on input and must not be able to panic).
    fn name_of_checked(&self, slot: Slot) -> &'static str {
        let name = if slot.field != NONE {
            self.fields.get(usize::from(slot.field))
        } else {
            self.groups.get(usize::from(slot.group))
        };
        name.copied().unwrap_or("")
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use heapless::Vec;

    type Bytes = Vec<u8, 64>;

    const FIELDS: &[&str] = &[
        "Actual_Position",
        "FTData",
        "robotState",
        "Box48Out_Voltage",
    ];
    const GROUPS: &[&str] = &["PosAndVel", "FTData"];
    static NAMES: Names = Names::new(FIELDS, GROUPS);

    /// The rule, written the plain way: the oracle for `find`.
    fn matches(raw: &[u8], name: &str) -> bool {
        raw.iter()
            .copied()
            .filter(|&b| !is_stripped(b))
            .map(normalise)
            .eq(name.bytes().map(normalise))
    }

    fn oracle(names: &Names, raw: &[u8]) -> Found {
        Found {
            field: names.fields.iter().position(|f| matches(raw, f)),
            group: names.groups.iter().position(|g| matches(raw, g)),
        }
    }

    fn bytes(b: &[u8]) -> Bytes {
        Vec::from_slice(b).unwrap()
    }

    #[test]
    fn spellings_of_each_name_find_it() {
        for (i, f) in FIELDS.iter().enumerate() {
            let upper = bytes(f.as_bytes())
                .iter()
                .map(u8::to_ascii_uppercase)
                .collect::<Bytes>();
            let spaced = f
                .bytes()
                .map(|b| if b == b'_' { b' ' } else { b })
                .collect::<Bytes>();
            let mut broken = bytes(f.as_bytes());
            broken.insert(1, b'\n').unwrap();
            broken.push(0).unwrap();
            for raw in [f.as_bytes(), &upper, &spaced, &broken] {
                assert_eq!(NAMES.find(raw).field, Some(i), "{raw:?}");
            }
        }
        assert_eq!(
            NAMES.find(b"ftdata"),
            Found {
                field: Some(1),
                group: Some(1)
            }
        );
        assert_eq!(
            NAMES.find(b"POSAND\nVEL"),
            Found {
                field: None,
                group: Some(0)
            }
        );
    }

    #[test]
    fn near_misses_find_nothing() {
        for raw in [
            &b""[..],
            b"Actual_Positio",
            b"Actual_Positionn",
            b"Actual-Position",
            b"Actual\\u005fPosition",
            b"robotState ",
            b"\x00\n\t",
            b"an_unknown_name_far_longer_than_any_in_the_table",
        ] {
            assert_eq!(NAMES.find(raw), Found::NOTHING, "{raw:?}");
        }
    }

    /// Every one-byte change (replace, insert, delete) of every name, with
    /// bytes that matter to the rule: `find` agrees with the oracle.
    pub(crate) fn agrees_on_mutations(names: &Names) {
        let alphabet = b"aAzZ_ \n\0-1xX";
        for name in names.fields.iter().chain(names.groups) {
            let base = name.as_bytes();
            assert_eq!(names.find(base), oracle(names, base));
            for at in 0..=base.len() {
                for &b in alphabet {
                    let mut ins = bytes(base);
                    ins.insert(at, b).unwrap();
                    assert_eq!(names.find(&ins), oracle(names, &ins), "{ins:?}");
                    if at < base.len() {
                        let mut rep = bytes(base);
                        rep[at] = b;
                        assert_eq!(names.find(&rep), oracle(names, &rep), "{rep:?}");
                    }
                }
                if at < base.len() {
                    let mut del = bytes(base);
                    del.remove(at);
                    assert_eq!(names.find(&del), oracle(names, &del), "{del:?}");
                }
            }
        }
    }

    #[test]
    fn agrees_with_the_plain_rule_on_mutated_names() {
        agrees_on_mutations(&NAMES);
    }

    #[test]
    fn colliding_names_still_resolve() {
        const MANY: &[&str] = &[
            "a0", "a1", "a2", "a3", "a4", "a5", "a6", "a7", "a8", "a9", "b0", "b1", "b2", "b3",
            "b4", "b5", "b6", "b7", "b8", "b9", "c0", "c1", "c2", "c3", "c4", "c5", "c6", "c7",
            "c8", "c9", "d0", "d1", "d2", "d3", "d4", "d5", "d6", "d7", "d8", "d9",
        ];
        static T: Names = Names::new(MANY, &["A0", "e0"]);
        // The list is long enough that some names share a home slot, so
        // the probing is exercised.
        let homes = MANY
            .iter()
            .map(|n| home(hash_key(n.as_bytes())))
            .collect::<Vec<usize, 64>>();
        let shared = homes
            .iter()
            .enumerate()
            .any(|(i, h)| homes[i + 1..].contains(h));
        assert!(shared);
        for (i, n) in MANY.iter().enumerate() {
            assert_eq!(T.find(n.as_bytes()).field, Some(i));
        }
        assert_eq!(T.find(b"a0").group, Some(0));
        assert_eq!(
            T.find(b"E0"),
            Found {
                field: None,
                group: Some(1)
            }
        );
        assert_eq!(T.find(b"f0"), Found::NOTHING);
        agrees_on_mutations(&T);
    }
}
