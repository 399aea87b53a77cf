//! `GET /api/audit`: a page of the audit log (`crate::audit::page`:
//! `?before=SEQ&limit=N`, the newest page without them), oldest record
//! first, as JSON or, with `?format=csv`, as a CSV file to download
//! (`gateway/WEB.md`).
//!
//! The page is read by the storage task into the log's window (one
//! request at a time: another waits its turn, at most [`PAGE_WAIT`]); the
//! answer is chunked: each record is copied out of the window, one at a
//! time, and written as one chunk from a small buffer ([`CHUNK`]). JSON
//! ends with `"older"` (older records exist) and `"next_before"` (the
//! `before` of the next page, or `null`); both forms have the header
//! `Audit-Next-Before` when older records exist.

use embassy_futures::select::{select, Either};
use embassy_time::{Duration, Instant};
use picoserve::io::{Read, Write};
use picoserve::request::RequestParts;
use picoserve::response::chunked::{ChunkWriter, ChunkedResponse, Chunks, ChunksWritten};
use picoserve::response::{Connection, IntoResponse, Response, ResponseWriter, StatusCode};
use picoserve::ResponseSent;

use super::json::Out;
use super::{error, App, Reply, SECURITY_HEADERS};
use crate::audit::page::{Query, PAGE_MAX};
use crate::audit::{Record, Short};
use crate::clock::Clock;
use crate::hub::Hub;

/// Bytes of the buffer a record is written into (the longest record, every
/// text character escaped, takes ~400 as JSON: tested).
pub(crate) const CHUNK: usize = 512;

/// Longest a request waits for its turn and its page (the storage task
/// may be writing flash, or another client reading its page): then 503.
pub(crate) const PAGE_WAIT: Duration = Duration::from_secs(10);

/// The form of the export.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Format {
    /// JSON (the default).
    Json,
    /// CSV with a header line, as a download.
    Csv,
}

impl<C: Clock> App<'_, C> {
    /// `GET /api/audit`: a session of any account (viewer and up), also
    /// while reading without login is on: who did what is not for
    /// everyone who reaches the page.
    pub(super) fn audit(&self, parts: &RequestParts<'_>) -> Reply {
        match self.require(parts, crate::access::accounts::Role::Viewer) {
            Ok(_) => reply(parts),
            Err(refused) => refused,
        }
    }
}

/// The answer to `GET /api/audit[?format=json|csv][&before=SEQ][&limit=N]`
/// (other query parameters are ignored; another format, or a `before` or
/// `limit` that is not a number in range, is 400).
pub(crate) fn reply(parts: &RequestParts<'_>) -> Reply {
    let query = parts.query().map_or("", |q| q.0);
    let format = query
        .split('&')
        .find_map(|p| p.strip_prefix("format="))
        .unwrap_or("json");
    let format = match format {
        "json" => Format::Json,
        "csv" => Format::Csv,
        _ => return error(StatusCode::BAD_REQUEST, "format is json or csv"),
    };
    match Query::parse(query) {
        Ok(q) => Reply::Audit(format, q),
        Err(e) => error(StatusCode::BAD_REQUEST, e.as_str()),
    }
}

impl Format {
    fn content_type(self) -> &'static str {
        match self {
            Format::Json => "application/json",
            Format::Csv => "text/csv; charset=utf-8",
        }
    }

    fn disposition(self) -> Option<(&'static str, &'static str)> {
        match self {
            Format::Json => None,
            Format::Csv => Some((
                "Content-Disposition",
                "attachment; filename=\"hans-gateway-audit.csv\"",
            )),
        }
    }
}

/// Writes the answer (for `HEAD` its head only).
pub(crate) async fn write<C: Clock, R: Read, W: ResponseWriter<Error = R::Error>>(
    hub: &Hub,
    clock: &C,
    (format, query, secure): (Format, Query, bool),
    head: bool,
    c: Connection<'_, R>,
    w: W,
) -> Result<ResponseSent, W::Error> {
    let headers = [("Cache-Control", "no-store")];
    if head {
        return Response::empty(StatusCode::OK)
            .with_headers([
                ("Content-Type", format.content_type()),
                ("Transfer-Encoding", "chunked"),
            ])
            .with_headers(format.disposition())
            .with_headers(headers)
            .with_headers(SECURITY_HEADERS)
            .with_headers(super::hsts(secure))
            .write_to(c, w)
            .await;
    }
    let pages = &hub.audit.pages;
    // The turn is held until the page is sent: the window is this
    // request's meanwhile.
    let turn = async {
        let turn = pages.turn.lock().await;
        let read = pages.ask(query).await;
        (turn, read)
    };
    let (turn, read) = match select(turn, clock.sleep(PAGE_WAIT)).await {
        Either::First(got) => got,
        Either::Second(()) => {
            return error_reply(
                (StatusCode::SERVICE_UNAVAILABLE, secure),
                "the audit log is busy: try again",
                c,
                w,
            )
            .await
        }
    };
    if !read {
        drop(turn);
        return error_reply(
            (StatusCode::SERVICE_UNAVAILABLE, secure),
            "the kept audit records could not be read",
            c,
            w,
        )
        .await;
    }
    let next = pages.with(|win| win.next_before());
    let mut cursor = Short::<12>::EMPTY;
    if let Some(n) = next {
        let _ = core::fmt::Write::write_fmt(&mut cursor, format_args!("{n}"));
    }
    let sent = ChunkedResponse::new(Export {
        hub,
        clock,
        format,
        query,
    })
    .into_response()
    .with_headers(format.disposition())
    .with_headers(next.map(|_| ("Audit-Next-Before", cursor.as_str())))
    .with_headers(headers)
    .with_headers(SECURITY_HEADERS)
    .with_headers(super::hsts(secure))
    .write_to(c, w)
    .await;
    drop(turn);
    sent
}

/// A JSON error answer (the page could not be had).
async fn error_reply<R: Read, W: ResponseWriter<Error = R::Error>>(
    (status, secure): (StatusCode, bool),
    text: &str,
    c: Connection<'_, R>,
    w: W,
) -> Result<ResponseSent, W::Error> {
    let body = super::error_json(text);
    Response::new(status, super::json_body(&body))
        .with_header("Cache-Control", "no-store")
        .with_headers(SECURITY_HEADERS)
        .with_headers(super::hsts(secure))
        .write_to(c, w)
        .await
}

/// The export's chunks.
struct Export<'a, C: Clock> {
    hub: &'a Hub,
    clock: &'a C,
    format: Format,
    query: Query,
}

impl<C: Clock> Chunks for Export<'_, C> {
    fn content_type(&self) -> &'static str {
        self.format.content_type()
    }

    async fn write_chunks<W: Write>(
        self,
        mut w: ChunkWriter<W>,
    ) -> Result<ChunksWritten, W::Error> {
        let log = &self.hub.audit;
        let (_, boot, _) = log.summary();
        let mut buf = [0u8; CHUNK];
        let now = self.clock.now();
        let n = head(
            self.format,
            self.query,
            boot,
            now,
            log.wall_at(now),
            &mut buf,
        );
        w.write_chunk(buf.get(..n).unwrap_or(&[])).await?;
        let mut i = 0;
        while let Some(r) = log.pages.with(|win| win.get(i)) {
            let n = match self.format {
                Format::Json => json_record(&r, i == 0, &mut buf),
                Format::Csv => csv_record(&r, &mut buf),
            };
            w.write_chunk(buf.get(..n).unwrap_or(&[])).await?;
            i += 1;
        }
        if self.format == Format::Json {
            let next = log.pages.with(|win| win.next_before());
            let n = tail(next, &mut buf);
            w.write_chunk(buf.get(..n).unwrap_or(&[])).await?;
        }
        w.finalize().await
    }
}

/// A byte buffer filled from the start; what does not fit is dropped (the
/// buffers are sized for the longest record: tested).
struct Fill<'b> {
    buf: &'b mut [u8],
    len: usize,
}

impl Fill<'_> {
    fn put(&mut self, s: &[u8]) -> &mut Self {
        for &b in s {
            if let Some(slot) = self.buf.get_mut(self.len) {
                *slot = b;
                self.len += 1;
            }
        }
        self
    }

    fn num(&mut self, v: u64) -> &mut Self {
        let mut n = itoa::Buffer::new();
        self.put(n.format(v).as_bytes())
    }
}

/// The document's head (JSON: the object up to its records' array) or
/// the CSV header line.
fn head(
    format: Format,
    query: Query,
    boot: u32,
    now: Instant,
    unix: Option<u32>,
    buf: &mut [u8],
) -> usize {
    let mut f = Fill { buf, len: 0 };
    match format {
        Format::Json => {
            f.put(b"{\"limit\":")
                .num(query.limit as u64)
                .put(b",\"before\":");
            match query.before {
                Some(b) => f.num(b.into()),
                None => f.put(b"null"),
            };
            f.put(b",\"boot\":")
                .num(boot.into())
                .put(b",\"now_ms\":")
                .num(now.as_millis())
                .put(b",\"now_unix\":");
            match unix {
                Some(u) => f.num(u.into()),
                None => f.put(b"null"),
            };
            f.put(b",\"records\":[");
        }
        Format::Csv => {
            f.put(b"seq,boot,uptime_ms,unix_time,time_utc,kind,actor,interface,from,detail\r\n");
        }
    }
    f.len
}

/// The JSON document's end: whether older records exist, and the next
/// page's `before`.
fn tail(next: Option<u32>, buf: &mut [u8]) -> usize {
    let mut f = Fill { buf, len: 0 };
    f.put(b"],\"older\":");
    match next {
        Some(n) => f.put(b"true,\"next_before\":").num(n.into()),
        None => f.put(b"false,\"next_before\":null"),
    };
    f.put(b",\"page_max\":").num(PAGE_MAX as u64).put(b"}");
    f.len
}

/// One record as a JSON object (with the comma before it unless `first`).
fn json_record(r: &Record, first: bool, buf: &mut [u8]) -> usize {
    let (sep, rest): (usize, &mut [u8]) = if first {
        (0, buf)
    } else {
        match buf.split_first_mut() {
            Some((comma, rest)) => {
                *comma = b',';
                (1, rest)
            }
            None => return 0,
        }
    };
    let mut out = Out::new(rest);
    out.value().object(|j| {
        j.key("seq").uint(r.seq.into());
        j.key("boot").uint(r.boot.into());
        j.key("uptime_ms").uint(r.uptime_ms);
        j.key("unix").opt(r.wall, |v, u| v.uint(u.into()));
        j.key("time").opt(r.wall, |v, u| v.str(utc(u).as_bytes()));
        j.key("kind").str(r.kind.as_str().as_bytes());
        j.key("actor").str(r.actor_str().as_bytes());
        j.key("interface").str(r.interface.as_str().as_bytes());
        j.key("from").opt(r.from, |v, ip| v.ip(ip));
        j.key("detail").str(r.detail.as_bytes());
    });
    match out.result() {
        Ok(n) => sep + n,
        // Cannot happen (the longest record fits: tested); left out whole
        // rather than sent broken.
        Err(_) => 0,
    }
}

/// One record as a CSV line.
fn csv_record(r: &Record, buf: &mut [u8]) -> usize {
    let mut f = Fill { buf, len: 0 };
    f.num(r.seq.into())
        .put(b",")
        .num(r.boot.into())
        .put(b",")
        .num(r.uptime_ms)
        .put(b",");
    if let Some(u) = r.wall {
        f.num(u.into()).put(b",").put(utc(u).as_bytes());
    } else {
        f.put(b",");
    }
    f.put(b",").put(r.kind.as_str().as_bytes()).put(b",");
    csv_text(&mut f, r.actor_str().as_bytes());
    f.put(b",").put(r.interface.as_str().as_bytes()).put(b",");
    if let Some(ip) = r.from {
        let mut a = Short::<16>::EMPTY;
        let _ = core::fmt::Write::write_fmt(&mut a, format_args!("{ip}"));
        f.put(a.as_bytes());
    }
    f.put(b",");
    csv_text(&mut f, r.detail.as_bytes());
    f.put(b"\r\n");
    f.len
}

/// A text field of CSV (RFC 4180): quoted, quotes doubled. A text that a
/// spreadsheet would take for a formula (it starts with `=`, `+`, `-` or
/// `@` and is more than that character: a login name tried, a trigger
/// text) gets a `'` in front, so that it shows as text (OWASP's advice).
fn csv_text(f: &mut Fill<'_>, s: &[u8]) {
    f.put(b"\"");
    if s.len() > 1 && matches!(s.first(), Some(b'=' | b'+' | b'-' | b'@')) {
        f.put(b"'");
    }
    for &b in s {
        if b == b'"' {
            f.put(b"\"\"");
        } else {
            f.put(&[b]);
        }
    }
    f.put(b"\"");
}

/// Unix seconds as UTC, `YYYY-MM-DDTHH:MM:SSZ` (RFC 3339).
fn utc(unix: u32) -> Short<20> {
    let secs = u64::from(unix);
    let (days, rem) = (secs / 86_400, secs % 86_400);
    // Days to a civil date (H. Hinnant's algorithm, for days >= 0).
    let z = days + 719_468;
    let (era, doe) = (z / 146_097, z % 146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + u64::from(month <= 2);
    let mut t = Short::<20>::EMPTY;
    let two = |t: &mut Short<20>, v: u64, sep: &[u8]| {
        t.push(&[b'0' + (v / 10 % 10) as u8, b'0' + (v % 10) as u8]);
        t.push(sep);
    };
    two(&mut t, year / 100, b"");
    two(&mut t, year % 100, b"-");
    two(&mut t, month, b"-");
    two(&mut t, day, b"T");
    two(&mut t, rem / 3600, b":");
    two(&mut t, rem / 60 % 60, b":");
    two(&mut t, rem % 60, b"Z");
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::audit::{Interface, Kind, ACTOR_MAX, DETAIL_MAX};
    use core::net::Ipv4Addr;

    #[test]
    fn utc_dates() {
        for (unix, text) in [
            (0, "1970-01-01T00:00:00Z"),
            (951_782_400, "2000-02-29T00:00:00Z"),
            (1_795_000_000, "2026-11-18T11:06:40Z"),
            (4_107_542_399, "2100-02-28T23:59:59Z"),
            (u32::MAX, "2106-02-07T06:28:15Z"),
        ] {
            assert_eq!(utc(unix).as_str(), text, "{unix}");
        }
    }

    fn longest() -> Record {
        Record {
            seq: u32::MAX,
            boot: u32::MAX,
            uptime_ms: u64::MAX,
            wall: Some(u32::MAX),
            kind: Kind::AccountPassword,
            actor: Short::new(&[b'"'; ACTOR_MAX]),
            interface: Interface::Button,
            from: Some(Ipv4Addr::new(255, 255, 255, 255)),
            detail: Short::new(&[b'\\'; DETAIL_MAX]),
        }
    }

    #[test]
    fn the_longest_record_fits_a_chunk_in_both_forms() {
        let mut buf = [0u8; CHUNK];
        let r = longest();
        let n = json_record(&r, false, &mut buf);
        assert!(n > 300, "{n}");
        let v: serde_json::Value = serde_json::from_slice(&buf[1..n]).unwrap();
        assert_eq!(v["actor"].as_str().unwrap(), "\"".repeat(ACTOR_MAX));
        assert_eq!(v["time"], "2106-02-07T06:28:15Z");
        let n = csv_record(&r, &mut buf);
        assert!(n < CHUNK);
        assert!(buf[..n].ends_with(b"\"\r\n"));
    }

    #[test]
    fn csv_quotes_texts_and_defuses_formulas() {
        let r = Record {
            seq: 3,
            boot: 2,
            uptime_ms: 1500,
            kind: Kind::LoginFailed,
            actor: Short::new(b"=HYPERLINK(\"x\")"),
            interface: Interface::Web,
            from: Some(Ipv4Addr::new(10, 0, 0, 9)),
            detail: Short::new(b"a, \"b\""),
            ..Record::EMPTY
        };
        let mut buf = [0u8; CHUNK];
        let n = csv_record(&r, &mut buf);
        assert_eq!(
            std::str::from_utf8(&buf[..n]).unwrap(),
            "3,2,1500,,,login-failed,\"'=HYPERLINK(\"\"x\"\")\",web,10.0.0.9,\"a, \"\"b\"\"\"\r\n"
        );
        // No account: "-" alone stays as it is.
        let n = csv_record(&Record::EMPTY, &mut buf);
        assert!(std::str::from_utf8(&buf[..n])
            .unwrap()
            .contains(",\"-\",system,,"));
    }

    #[test]
    fn the_head_is_the_start_of_a_document() {
        let mut buf = [0u8; CHUNK];
        let n = head(
            Format::Json,
            Query::NEWEST,
            4,
            Instant::from_millis(2500),
            None,
            &mut buf,
        );
        let mut end = [0u8; 64];
        let e = tail(Some(7), &mut end);
        let doc = [&buf[..n], &end[..e]].concat();
        let v: serde_json::Value = serde_json::from_slice(&doc).unwrap();
        assert_eq!(v["limit"], PAGE_MAX);
        assert!(v["before"].is_null());
        assert_eq!(v["older"], true);
        assert_eq!(v["next_before"], 7);
        assert_eq!(v["boot"], 4);
        assert_eq!(v["now_ms"], 2500);
        assert!(v["now_unix"].is_null());
        assert_eq!(v["records"].as_array().unwrap().len(), 0);
    }
}
