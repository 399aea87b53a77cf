//! `GET /api/audit`: the audit log's newest records (the RAM ring of
//! `crate::audit`, oldest first), as JSON or, with `?format=csv`, as a CSV
//! file to download (`gateway/WEB.md`).
//!
//! The answer is chunked: each record is copied out of the ring under the
//! log's lock, one at a time, and written as one chunk from a small buffer
//! ([`CHUNK`]), so neither the ring nor a snapshot of it is held for the
//! network. The records shown are those in the ring when the answer
//! starts (up to the newest then); one pushed out of the ring meanwhile is
//! left out (its sequence number shows the gap).

use embassy_time::Instant;
use picoserve::io::{Read, Write};
use picoserve::request::RequestParts;
use picoserve::response::chunked::{ChunkWriter, ChunkedResponse, Chunks, ChunksWritten};
use picoserve::response::{Connection, IntoResponse, Response, ResponseWriter, StatusCode};
use picoserve::ResponseSent;

use super::json::Out;
use super::{error, App, Reply, SECURITY_HEADERS};
use crate::audit::{Record, Short, RING};
use crate::clock::Clock;
use crate::hub::Hub;

/// Bytes of the buffer a record is written into (the longest record, every
/// text character escaped, takes ~400 as JSON: tested).
pub(crate) const CHUNK: usize = 512;

/// The form of the export.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Format {
    /// JSON (the default).
    Json,
    /// CSV with a header line, as a download.
    Csv,
}

impl<C: Clock> App<'_, C> {
    /// The answer to `GET /api/audit`: for whoever may read the
    /// configuration (see [`reply`]).
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

/// The answer to `GET /api/audit[?format=json|csv]` (other query
/// parameters are ignored; another format is 400).
pub(crate) fn reply(parts: &RequestParts<'_>) -> Reply {
    let query = parts.query().map_or("", |q| q.0);
    let format = query
        .split('&')
        .find_map(|p| p.strip_prefix("format="))
        .unwrap_or("json");
    match format {
        "json" => Reply::Audit(Format::Json),
        "csv" => Reply::Audit(Format::Csv),
        _ => error(StatusCode::BAD_REQUEST, "format is json or csv"),
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
    format: Format,
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
            .write_to(c, w)
            .await;
    }
    ChunkedResponse::new(Export { hub, clock, format })
        .into_response()
        .with_headers(format.disposition())
        .with_headers(headers)
        .with_headers(SECURITY_HEADERS)
        .write_to(c, w)
        .await
}

/// The export's chunks.
struct Export<'a, C: Clock> {
    hub: &'a Hub,
    clock: &'a C,
    format: Format,
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
        let (newest, boot, _) = log.summary();
        let mut buf = [0u8; CHUNK];
        let n = head(
            self.format,
            boot,
            self.clock.now(),
            log.wall_at(self.clock.now()),
            &mut buf,
        );
        w.write_chunk(buf.get(..n).unwrap_or(&[])).await?;
        if let Some(last) = newest {
            let mut next = 0;
            let mut first = true;
            while let Some(r) = log.copy(next, last) {
                let n = match self.format {
                    Format::Json => json_record(&r, first, &mut buf),
                    Format::Csv => csv_record(&r, &mut buf),
                };
                w.write_chunk(buf.get(..n).unwrap_or(&[])).await?;
                first = false;
                if r.seq >= last {
                    break;
                }
                next = r.seq + 1;
            }
        }
        if self.format == Format::Json {
            w.write_chunk(b"]}").await?;
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
fn head(format: Format, boot: u32, now: Instant, unix: Option<u32>, buf: &mut [u8]) -> usize {
    let mut f = Fill { buf, len: 0 };
    match format {
        Format::Json => {
            f.put(b"{\"capacity\":")
                .num(RING as u64)
                .put(b",\"boot\":")
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
        let n = head(Format::Json, 4, Instant::from_millis(2500), None, &mut buf);
        let doc = [&buf[..n], b"]}"].concat();
        let v: serde_json::Value = serde_json::from_slice(&doc).unwrap();
        assert_eq!(v["capacity"], RING);
        assert_eq!(v["boot"], 4);
        assert_eq!(v["now_ms"], 2500);
        assert!(v["now_unix"].is_null());
        assert_eq!(v["records"].as_array().unwrap().len(), 0);
    }
}
