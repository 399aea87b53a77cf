//! The audit log's records in files on Linux (feature `audit`): the
//! `--config` file's name with `.audit` appended (`gateway.toml.audit`),
//! beside it, for the security records, and `.audit.failures` for the
//! failure records.
//!
//! A file is the records one after the other, in their stored form
//! (`audit::record`: a version byte, the fields, a CRC; each record says
//! its own length). A record is appended and synced (`fdatasync`) before
//! the next is written, by a writer thread of the files' own (started at
//! the first record, 64 KiB of stack; the gateway goes on meanwhile, and
//! tokio's blocking pool is left to the configuration's saves), so a power
//! cut loses at most the record being written; the gateway answers a
//! request that caused a security record only once it is synced. A
//! torn record at the end (the cut came during the write) fails its CRC:
//! at start it is cut off, so that the next record follows the last whole
//! one. Damaged bytes inside a file are skipped up to the next record
//! that reads.
//!
//! ## Two stores: failures never rotate security records away
//! Security records (`Kind::security`: starts, the configuration loaded
//! or changed, logins and logouts, accounts, restarts, firmware, the
//! clock) go to `FILE`; failure records (failed logins, refused
//! connections and changes, the watchdog, lost records) to
//! `FILE.failures`. Each is bounded on its own: when a record would take
//! a file past its limit ([`DEFAULT_LIMIT`], 1 MiB: ~10,000 records), it
//! is renamed to `FILE.1` (or `FILE.failures.1`, replacing the previous
//! one) and a new file begins, so each keeps its newest records: between
//! one and two limits' worth, 4 MiB at most in all. However many failure
//! records an attacker causes (the log aggregates them: at most two per
//! period per class, the period doubling up to an hour), they rotate only
//! their own file: a security record goes only when 1-2 MiB of newer
//! security records were written, which takes accounts and their
//! sessions. Reading merges the two by sequence number (oldest first); a
//! file from before the split (all records in `FILE`) reads as it was.
//! All files are created readable and writable by their owner only (mode
//! 0600): they name accounts and addresses.

extern crate std;

use std::fs;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::vec::Vec;

use hans_gateway::audit::Record;
use hans_gateway::storage::{AuditStore, StorageError};

/// The size a file grows to before it is rotated (each of the two).
pub const DEFAULT_LIMIT: u64 = 1 << 20;

/// The two stores: security records, failure records.
const SECURITY: usize = 0;
const FAILURES: usize = 1;

/// The audit records in two files, each rotated at a limit (see the
/// module documentation).
#[derive(Debug)]
pub struct AuditFile {
    path: PathBuf,
    limit: u64,
    /// Each file's size, once known.
    size: [Option<u64>; 2],
    /// The writer thread's queue, once started (it ends when this is
    /// dropped).
    writer: Option<mpsc::Sender<Job>>,
}

/// One append for the writer thread: the record, which file, the file's
/// size before it, and where the new size (or the error) goes.
#[derive(Debug)]
struct Job {
    record: Vec<u8>,
    file: usize,
    size: u64,
    done: tokio::sync::oneshot::Sender<io::Result<u64>>,
}

impl AuditFile {
    /// Records in `path` (and `path.failures`), rotated at
    /// [`DEFAULT_LIMIT`].
    pub fn new(path: impl Into<PathBuf>) -> Self {
        AuditFile::with_limit(path, DEFAULT_LIMIT)
    }

    /// Records in `path` (and `path.failures`), each rotated when a record
    /// would take it past `limit` bytes.
    pub fn with_limit(path: impl Into<PathBuf>, limit: u64) -> Self {
        AuditFile {
            path: path.into(),
            limit,
            size: [None; 2],
            writer: None,
        }
    }

    /// The records of the configuration file `config`: in
    /// `CONFIG.audit`.
    pub fn beside(config: &Path) -> Self {
        AuditFile::new(suffixed(config, ".audit"))
    }

    /// Where the security records go.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Where the security records of the previous file are (`FILE.1`).
    pub fn rotated(&self) -> PathBuf {
        suffixed(&self.path, ".1")
    }

    /// Where the failure records go (`FILE.failures`).
    pub fn failures(&self) -> PathBuf {
        suffixed(&self.path, ".failures")
    }

    /// The file of store `file` and its rotated one.
    fn files(&self, file: usize) -> (PathBuf, PathBuf) {
        let p = if file == SECURITY {
            self.path.clone()
        } else {
            self.failures()
        };
        let r = suffixed(&p, ".1");
        (p, r)
    }

    /// The writer thread's queue, the thread started if it is not yet.
    fn writer(&mut self) -> io::Result<&mpsc::Sender<Job>> {
        if self.writer.is_none() {
            let (tx, rx) = mpsc::channel::<Job>();
            let files = [self.files(SECURITY), self.files(FAILURES)];
            let limit = self.limit;
            std::thread::Builder::new()
                .name("audit-file".into())
                .stack_size(64 << 10)
                .spawn(move || {
                    while let Ok(job) = rx.recv() {
                        let (path, rotated) = &files[job.file.min(FAILURES)];
                        let r = append(path, rotated, limit, job.size, &job.record);
                        let _ = job.done.send(r);
                    }
                })?;
            self.writer = Some(tx);
        }
        self.writer
            .as_ref()
            .ok_or_else(|| io::Error::other("no writer"))
    }

    /// Reads store `file` (its rotated file, then its file): where each
    /// record is in `old` and `new`, and cuts a torn tail off the file.
    fn read_store(&mut self, file: usize) -> Result<Store, StorageError> {
        let io = |e: io::Error, path: &Path| {
            log::warn!("audit: cannot read {}: {e}", path.display());
            StorageError::Io
        };
        let (path, rotated) = self.files(file);
        let old = read_or_empty(&rotated).map_err(|e| io(e, &rotated))?;
        let new = read_or_empty(&path).map_err(|e| io(e, &path))?;
        let (old_at, _) = positions(&old);
        let (new_at, end) = positions(&new);
        if end < new.len() {
            // A torn record at the end: cut off, so that the next one
            // follows the last whole record.
            log::warn!(
                "audit: {} ends in {} damaged bytes (a cut write): removed",
                path.display(),
                new.len() - end
            );
            let f = fs::OpenOptions::new()
                .write(true)
                .open(&path)
                .map_err(|e| io(e, &path))?;
            f.set_len(end as u64)
                .and_then(|()| f.sync_all())
                .map_err(|e| io(e, &path))?;
        }
        if let Some(s) = self.size.get_mut(file) {
            *s = Some(end as u64);
        }
        Ok(Store {
            old,
            new,
            old_at,
            new_at,
        })
    }
}

/// One store's bytes read: its rotated file and its file, and the records'
/// places in them (sequence number, range).
struct Store {
    old: Vec<u8>,
    new: Vec<u8>,
    old_at: Vec<(u32, core::ops::Range<usize>)>,
    new_at: Vec<(u32, core::ops::Range<usize>)>,
}

impl Store {
    /// Its records, oldest first: (sequence number, bytes).
    fn records(&self) -> impl Iterator<Item = (u32, &[u8])> {
        let old = self
            .old_at
            .iter()
            .map(|(s, r)| (*s, self.old.get(r.clone()).unwrap_or(&[])));
        let new = self
            .new_at
            .iter()
            .map(|(s, r)| (*s, self.new.get(r.clone()).unwrap_or(&[])));
        old.chain(new)
    }
}

/// `path` with `suffix` appended to its name.
fn suffixed(path: &Path, suffix: &str) -> PathBuf {
    let mut p = path.as_os_str().to_os_string();
    p.push(suffix);
    PathBuf::from(p)
}

/// Where every record that reads in `bytes` is (its sequence number and
/// range), in order, skipping damaged bytes up to the next record that
/// reads; and where the last whole record ends.
fn positions(bytes: &[u8]) -> (Vec<(u32, core::ops::Range<usize>)>, usize) {
    let (mut at, mut end) = (0, 0);
    let mut found = Vec::new();
    while let Some(rest) = bytes.get(at..).filter(|r| !r.is_empty()) {
        match Record::parse(rest) {
            Ok((r, n)) => {
                found.push((r.seq, at..at + n));
                at += n;
                end = at;
            }
            Err(_) => at += 1,
        }
    }
    (found, end)
}

/// A file's bytes; none if it does not exist.
fn read_or_empty(path: &Path) -> io::Result<Vec<u8>> {
    match fs::read(path) {
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(Vec::new()),
        r => r,
    }
}

/// Opens `path` to append, creating it with mode 0600.
fn open_append(path: &Path) -> io::Result<fs::File> {
    let mut options = fs::OpenOptions::new();
    options.append(true).create(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o600);
    options.open(path)
}

/// Syncs the directory of `path` (a file created or renamed there).
fn sync_dir(path: &Path) -> io::Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    fs::File::open(dir)?.sync_all()
}

/// Appends `record` to `path` (of `size` bytes), rotating first if it
/// would pass `limit`; returns the new size.
fn append(path: &Path, rotated: &Path, limit: u64, size: u64, record: &[u8]) -> io::Result<u64> {
    let len = record.len() as u64;
    let mut size = size;
    if size > 0 && size + len > limit {
        fs::rename(path, rotated)?;
        size = 0;
    }
    let mut f = open_append(path)?;
    f.write_all(record)?;
    f.sync_data()?;
    if size == 0 {
        // A new file (or a rotation): its name must survive a cut too.
        sync_dir(path)?;
    }
    Ok(size + len)
}

impl AuditStore for AuditFile {
    async fn read(&mut self, each: &mut dyn FnMut(&[u8])) -> Result<(), StorageError> {
        let security = self.read_store(SECURITY)?;
        let failures = self.read_store(FAILURES)?;
        // Each store is in order: merged by sequence number.
        let mut a = security.records().peekable();
        let mut b = failures.records().peekable();
        loop {
            let take_a = match (a.peek(), b.peek()) {
                (Some((sa, _)), Some((sb, _))) => sa <= sb,
                (Some(_), None) => true,
                (None, Some(_)) => false,
                (None, None) => break,
            };
            let next = if take_a { a.next() } else { b.next() };
            if let Some((_, bytes)) = next {
                each(bytes);
            }
        }
        Ok(())
    }

    async fn append(&mut self, record: &[u8]) -> Result<(), StorageError> {
        let file = match Record::parse(record) {
            Ok((r, _)) if !r.kind.security() => FAILURES,
            _ => SECURITY,
        };
        let size = match self.size.get(file).copied().flatten() {
            Some(s) => s,
            None => fs::metadata(self.files(file).0).map_or(0, |m| m.len()),
        };
        let (done, answer) = tokio::sync::oneshot::channel();
        let job = Job {
            record: record.to_vec(),
            file,
            size,
            done,
        };
        let sent = self.writer().and_then(|w| {
            w.send(job)
                .map_err(|_| io::Error::other("the writer ended"))
        });
        let result = match sent {
            Ok(()) => answer
                .await
                .unwrap_or_else(|_| Err(io::Error::other("the writer ended"))),
            Err(e) => Err(e),
        };
        match result {
            Ok(size) => {
                if let Some(s) = self.size.get_mut(file) {
                    *s = Some(size);
                }
                Ok(())
            }
            Err(e) => {
                log::warn!("audit: cannot write {}: {e}", self.files(file).0.display());
                // Unknown now: asked again at the next append; a writer
                // that ended is started again.
                if let Some(s) = self.size.get_mut(file) {
                    *s = None;
                }
                self.writer = None;
                Err(StorageError::Io)
            }
        }
    }

    fn persistent(&self) -> bool {
        true
    }
}

/// The host's clock: Unix seconds now (`None` if it reads before 1970).
pub fn unix_now() -> Option<u64> {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .ok()
        .map(|d| d.as_secs())
}

#[cfg(test)]
mod tests {
    use super::*;
    use hans_gateway::audit::{Kind, Short, RECORD_MAX};

    fn record(seq: u32) -> Vec<u8> {
        record_of(seq, Kind::Config)
    }

    fn record_of(seq: u32, kind: Kind) -> Vec<u8> {
        let r = Record {
            seq,
            kind,
            detail: Short::new(format!("setting {seq:03}").as_bytes()),
            ..Record::EMPTY
        };
        let mut buf = [0u8; RECORD_MAX];
        let n = r.emit(&mut buf);
        buf[..n].to_vec()
    }

    fn seqs(f: &mut AuditFile) -> Vec<u32> {
        let mut got = Vec::new();
        let rt = tokio::runtime::Builder::new_current_thread()
            .build()
            .unwrap();
        rt.block_on(f.read(&mut |b| got.push(Record::parse(b).unwrap().0.seq)))
            .unwrap();
        got
    }

    fn append_all(f: &mut AuditFile, range: core::ops::RangeInclusive<u32>) {
        let rt = tokio::runtime::Builder::new_current_thread()
            .build()
            .unwrap();
        for s in range {
            rt.block_on(f.append(&record(s))).unwrap();
        }
    }

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("hgw-audit-{name}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn records_survive_a_restart_and_sit_beside_the_configuration() {
        let d = dir("restart");
        let config = d.join("gateway.toml");
        let mut f = AuditFile::beside(&config);
        assert_eq!(f.path(), d.join("gateway.toml.audit"));
        assert_eq!(seqs(&mut f), Vec::<u32>::new(), "no file: nothing kept");
        append_all(&mut f, 1..=5);
        let mut f = AuditFile::beside(&config);
        assert_eq!(seqs(&mut f), [1, 2, 3, 4, 5]);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = fs::metadata(f.path()).unwrap().permissions().mode();
            assert_eq!(mode & 0o777, 0o600, "{mode:o}");
        }
        fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn the_file_rotates_at_its_limit_and_keeps_the_newest() {
        let d = dir("rotate");
        let len = record(1).len() as u64;
        // Ten records a file (all of one length).
        let mut f = AuditFile::with_limit(d.join("a.audit"), 10 * len);
        append_all(&mut f, 1..=35);
        let size = |p: &Path| fs::metadata(p).unwrap().len();
        assert!(size(f.path()) <= 10 * len);
        assert!(size(&f.rotated()) <= 10 * len);
        let mut f = AuditFile::with_limit(d.join("a.audit"), 10 * len);
        // 31-35 in the file, 21-30 in the rotated one: the oldest went.
        assert_eq!(seqs(&mut f), (21..=35).collect::<Vec<_>>());
        fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_torn_last_record_is_cut_off_and_damage_inside_skipped() {
        let d = dir("torn");
        let path = d.join("a.audit");
        let mut f = AuditFile::new(&path);
        append_all(&mut f, 1..=4);
        // Damage record 2, then a cut in the middle of writing record 5.
        let mut bytes = fs::read(&path).unwrap();
        let len = record(1).len();
        bytes[len + 3] ^= 0x40;
        bytes.extend_from_slice(&record(5)[..len / 2]);
        fs::write(&path, &bytes).unwrap();
        let mut f = AuditFile::new(&path);
        assert_eq!(seqs(&mut f), [1, 3, 4]);
        assert_eq!(
            fs::metadata(&path).unwrap().len(),
            4 * len as u64,
            "the torn tail is gone"
        );
        // The next record follows the last whole one.
        append_all(&mut f, 6..=6);
        let mut f = AuditFile::new(&path);
        assert_eq!(seqs(&mut f), [1, 3, 4, 6]);
        fs::remove_dir_all(&d).unwrap();
    }

    /// Issue 25: the file rotated at its limit into one previous
    /// generation, whatever the records were, so a flood of failure
    /// records (counted per period, but a long flood, or a medium far
    /// smaller than a year of them) pushed an account's creation out of
    /// both. Security records now have their own file: failures rotate
    /// only theirs.
    #[test]
    fn failure_records_never_rotate_a_security_record_away() {
        let d = dir("flood");
        let len = record_of(1, Kind::Refused).len() as u64;
        let mut f = AuditFile::with_limit(d.join("a.audit"), 10 * len);
        let rt = tokio::runtime::Builder::new_current_thread()
            .build()
            .unwrap();
        rt.block_on(f.append(&record_of(1, Kind::Start))).unwrap();
        rt.block_on(f.append(&record_of(2, Kind::AccountCreated)))
            .unwrap();
        // Ten files' worth of failures of every failure kind.
        let failures = [
            Kind::LoginFailed,
            Kind::Refused,
            Kind::ConfigRefused,
            Kind::Watchdog,
            Kind::Lost,
        ];
        for seq in 3..103 {
            let kind = failures[seq as usize % failures.len()];
            assert!(!kind.security());
            rt.block_on(f.append(&record_of(seq, kind))).unwrap();
        }
        rt.block_on(f.append(&record_of(103, Kind::Login))).unwrap();
        // Read back after a restart: the account's creation is there, the
        // oldest failures went, and the order is by sequence number.
        let mut f = AuditFile::with_limit(d.join("a.audit"), 10 * len);
        let got = seqs(&mut f);
        assert_eq!(&got[..2], [1, 2], "{got:?}");
        assert_eq!(got.last(), Some(&103));
        assert!(got.windows(2).all(|w| w[0] < w[1]), "{got:?}");
        assert!(!got.contains(&3), "the failures rotate: {got:?}");
        assert!(f.failures().exists() && f.failures().with_extension("failures.1").exists());
        fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_file_from_before_the_split_reads_as_it_was() {
        let d = dir("split");
        let path = d.join("a.audit");
        let mut bytes = Vec::new();
        for (seq, kind) in [(1, Kind::Start), (2, Kind::Refused), (3, Kind::Login)] {
            bytes.extend_from_slice(&record_of(seq, kind));
        }
        fs::write(&path, &bytes).unwrap();
        let mut f = AuditFile::new(&path);
        append_all(&mut f, 4..=4);
        let rt = tokio::runtime::Builder::new_current_thread()
            .build()
            .unwrap();
        rt.block_on(f.append(&record_of(5, Kind::LoginFailed)))
            .unwrap();
        let mut f = AuditFile::new(&path);
        assert_eq!(seqs(&mut f), [1, 2, 3, 4, 5]);
        fs::remove_dir_all(&d).unwrap();
    }

    /// Paging (`GET /api/audit?before=SEQ&limit=N`: the gateway's window
    /// over this store's `read`) walks back across the rotation boundary
    /// of both files, each record once, to the oldest kept.
    #[test]
    fn pages_walk_back_across_the_rotation_of_both_files() {
        use hans_gateway::audit::page::{Query, Window};
        let d = dir("pages");
        let len = record(1).len() as u64;
        let mut f = AuditFile::with_limit(d.join("a.audit"), 10 * len);
        let rt = tokio::runtime::Builder::new_current_thread()
            .build()
            .unwrap();
        for seq in 1..=60 {
            let kind = if seq % 3 == 0 {
                Kind::Refused
            } else {
                Kind::Config
            };
            rt.block_on(f.append(&record_of(seq, kind))).unwrap();
        }
        assert!(f.rotated().exists() && suffixed(&f.failures(), ".1").exists());
        let all = seqs(&mut f);
        // Both stores rotated: the oldest of each went, the rest is whole.
        assert!(all.len() < 60 && all.len() > 20, "{all:?}");
        let mut walked = Vec::new();
        let mut before = None;
        for _ in 0..20 {
            let mut w = Window::new(Query { before, limit: 7 });
            rt.block_on(f.read(&mut |b| w.feed(b))).unwrap();
            walked.splice(0..0, w.records().map(|r| r.seq));
            match w.next_before() {
                Some(n) => before = Some(n),
                None => break,
            }
        }
        assert_eq!(walked, all);
        fs::remove_dir_all(&d).unwrap();
    }
}
