//! Paging through the whole log: `GET /api/audit?before=SEQ&limit=N`
//! (`gateway/WEB.md`). A page is the newest `limit` records (at most
//! [`PAGE_MAX`]) with a sequence number below `before` (any, without it),
//! oldest first, read from the medium (Linux: both files and their
//! previous generations; a board: its flash ring), or from the RAM ring
//! where nothing is kept. The answer says whether older records exist and
//! where the next page starts (`before` = the page's oldest record).
//!
//! The medium belongs to the storage task: a request asks it through
//! `Pages` (one at a time, the others wait their turn) and reads the
//! page from its [`Window`], a fixed buffer of [`PAGE_MAX`] records in the
//! log: no allocation, and the store is read once per page, oldest first,
//! whatever its size (the window keeps the newest `limit` it saw).

use core::cell::RefCell;

use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::signal::Signal;

use super::record::Record;

/// Records a page holds at most (a larger `limit` is taken as this): the
/// window's buffer, ~4.5 KiB of RAM.
pub const PAGE_MAX: usize = 32;

/// A page asked for ([`Query::parse`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Query {
    /// Only records with a sequence number below this; `None`: the newest.
    pub before: Option<u32>,
    /// Records at most, 1..=[`PAGE_MAX`].
    pub limit: usize,
}

/// Why a query was refused (400).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum QueryError {
    /// `before` is not a number from 1 to 4294967295.
    Before,
    /// `limit` is not a number from 1 up.
    Limit,
    /// `before` or `limit` given twice.
    Repeated,
}

impl QueryError {
    /// The answer's text.
    pub fn as_str(self) -> &'static str {
        match self {
            QueryError::Before => "before is a record's number (1 to 4294967295)",
            QueryError::Limit => "limit is a number of records from 1 (at most 32 are sent)",
            QueryError::Repeated => "before and limit may each be given once",
        }
    }
}

/// A decimal number of at most ten digits that fits a `u32`, nothing else
/// (no sign, no spaces, no `0x`).
fn number(s: &str) -> Option<u32> {
    if s.is_empty() || s.len() > 10 || !s.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    s.parse().ok()
}

impl Query {
    /// The newest page.
    pub const NEWEST: Query = Query {
        before: None,
        limit: PAGE_MAX,
    };

    /// The page a query string asks for (`before=SEQ`, `limit=N`; other
    /// parameters, `format` among them, are not looked at). `limit` above
    /// [`PAGE_MAX`] is taken as that.
    pub fn parse(query: &str) -> Result<Query, QueryError> {
        let mut q = Query::NEWEST;
        let (mut before, mut limit) = (false, false);
        for p in query.split('&') {
            if let Some(v) = p.strip_prefix("before=") {
                if core::mem::replace(&mut before, true) {
                    return Err(QueryError::Repeated);
                }
                q.before = Some(number(v).filter(|&n| n > 0).ok_or(QueryError::Before)?);
            } else if let Some(v) = p.strip_prefix("limit=") {
                if core::mem::replace(&mut limit, true) {
                    return Err(QueryError::Repeated);
                }
                // Ten digits at most, then capped.
                let n = number(v).filter(|&n| n > 0).ok_or(QueryError::Limit)?;
                q.limit = usize::try_from(n).unwrap_or(PAGE_MAX).min(PAGE_MAX);
            }
        }
        Ok(q)
    }
}

/// The newest `limit` records below `before` among those offered, oldest
/// first: offered in the medium's order (oldest first), each one below
/// the cursor goes in, and the oldest goes out when the window is full
/// (then older records exist).
#[derive(Clone, Debug)]
pub struct Window {
    query: Query,
    records: heapless::Deque<Record, PAGE_MAX>,
    older: bool,
    damaged: u32,
}

impl Window {
    /// An empty window for `query`.
    pub const fn new(query: Query) -> Self {
        Window {
            query,
            records: heapless::Deque::new(),
            older: false,
            damaged: 0,
        }
    }

    /// Offers a record in its stored form (damaged bytes are counted and
    /// skipped).
    pub fn feed(&mut self, bytes: &[u8]) {
        match Record::parse(bytes) {
            Ok((r, _)) => self.offer(r),
            Err(_) => self.damaged = self.damaged.saturating_add(1),
        }
    }

    /// Offers a record.
    pub fn offer(&mut self, r: Record) {
        if self.query.before.is_some_and(|b| r.seq >= b) {
            return;
        }
        let limit = self.query.limit.clamp(1, PAGE_MAX);
        while self.records.len() >= limit {
            self.records.pop_front();
            self.older = true;
        }
        // Cannot fail: there is room now.
        let _ = self.records.push_back(r);
    }

    /// The page's records, oldest first.
    pub fn records(&self) -> impl Iterator<Item = &Record> {
        self.records.iter()
    }

    /// Record `n` of the page (0: its oldest).
    pub fn get(&self, n: usize) -> Option<Record> {
        self.records.iter().nth(n).copied()
    }

    /// Older records than the page's exist.
    pub fn older(&self) -> bool {
        self.older
    }

    /// The `before` of the next (older) page: the page's oldest record,
    /// if older records exist.
    pub fn next_before(&self) -> Option<u32> {
        self.records.front().filter(|_| self.older).map(|r| r.seq)
    }

    /// Stored records that did not read (skipped).
    pub fn damaged(&self) -> u32 {
        self.damaged
    }

    /// The query it was filled for.
    pub fn query(&self) -> Query {
        self.query
    }
}

/// What the storage task answered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Filled {
    /// The window holds the page of request `id`.
    Page(u32),
    /// The medium could not be read for request `id`.
    Failed(u32),
}

/// The mailbox between the page's requests and the storage task (see the
/// module documentation).
pub(crate) struct Pages {
    /// One request at a time: held while its page is read and sent.
    pub(crate) turn: embassy_sync::mutex::Mutex<NoopRawMutex, ()>,
    /// A request's page, asked of the storage task (with its number).
    asked: Signal<NoopRawMutex, (u32, Query)>,
    /// The storage task's answer.
    filled: Signal<NoopRawMutex, Filled>,
    /// The page read, and the number of the next request.
    window: Mutex<NoopRawMutex, RefCell<(Window, u32)>>,
}

impl Pages {
    pub(crate) const fn new() -> Self {
        Pages {
            turn: embassy_sync::mutex::Mutex::new(()),
            asked: Signal::new(),
            filled: Signal::new(),
            window: Mutex::new(RefCell::new((Window::new(Query::NEWEST), 0))),
        }
    }

    /// Runs `f` on the window.
    pub(crate) fn with<R>(&self, f: impl FnOnce(&mut Window) -> R) -> R {
        self.window.lock(|w| f(&mut w.borrow_mut().0))
    }

    /// Asks the storage task for the page of `query` (the caller holds
    /// [`Self::turn`]) and waits for it: `true` once the window holds it,
    /// `false` if the medium could not be read.
    pub(crate) async fn ask(&self, query: Query) -> bool {
        let id = self.window.lock(|w| {
            let w = &mut w.borrow_mut().1;
            *w = w.wrapping_add(1);
            *w
        });
        self.filled.reset();
        self.asked.signal((id, query));
        loop {
            // An answer to an earlier request (given up by its caller's
            // deadline) is not this one's.
            match self.filled.wait().await {
                Filled::Page(n) if n == id => return true,
                Filled::Failed(n) if n == id => return false,
                _ => {}
            }
        }
    }

    /// Waits for a request (the storage task).
    pub(crate) async fn asked(&self) -> (u32, Query) {
        self.asked.wait().await
    }

    /// The storage task's answer to request `id`.
    pub(crate) fn answer(&self, filled: Filled) {
        self.filled.signal(filled);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn queries_parse_or_are_refused_with_their_reason() {
        assert_eq!(Query::parse(""), Ok(Query::NEWEST));
        assert_eq!(Query::parse("format=csv"), Ok(Query::NEWEST));
        assert_eq!(
            Query::parse("before=120&limit=5&format=json"),
            Ok(Query {
                before: Some(120),
                limit: 5
            })
        );
        assert_eq!(
            Query::parse("limit=1000000"),
            Ok(Query {
                before: None,
                limit: PAGE_MAX
            })
        );
        assert_eq!(
            Query::parse("before=4294967295").unwrap().before,
            Some(u32::MAX)
        );
        for bad in [
            "before=",
            "before=0",
            "before=-1",
            "before=+3",
            "before=4294967296",
            "before=0x10",
            "before=1%32",
            "before= 3",
        ] {
            assert_eq!(Query::parse(bad), Err(QueryError::Before), "{bad}");
        }
        for bad in ["limit=", "limit=0", "limit=12345678901", "limit=a"] {
            assert_eq!(Query::parse(bad), Err(QueryError::Limit), "{bad}");
        }
        assert_eq!(Query::parse("before=3&before=4"), Err(QueryError::Repeated));
        assert_eq!(Query::parse("limit=3&limit=3"), Err(QueryError::Repeated));
    }

    fn rec(seq: u32) -> Record {
        Record {
            seq,
            ..Record::EMPTY
        }
    }

    fn seqs(w: &Window) -> std::vec::Vec<u32> {
        w.records().map(|r| r.seq).collect()
    }

    #[test]
    fn a_window_keeps_the_newest_below_its_cursor() {
        let mut w = Window::new(Query {
            before: Some(8),
            limit: 3,
        });
        for s in 1..=10 {
            w.offer(rec(s));
        }
        assert_eq!(seqs(&w), [5, 6, 7]);
        assert!(w.older());
        assert_eq!(w.next_before(), Some(5));
        let mut w = Window::new(Query {
            before: Some(3),
            limit: 3,
        });
        for s in 1..=10 {
            w.offer(rec(s));
        }
        assert_eq!(seqs(&w), [1, 2]);
        assert!(!w.older());
        assert_eq!(w.next_before(), None);
        let mut w = Window::new(Query::NEWEST);
        w.feed(b"\x01not a record");
        assert_eq!(w.damaged(), 1);
        assert!(seqs(&w).is_empty());
    }
}
