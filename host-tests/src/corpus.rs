//! The test-vector corpus (`host-tests/vectors/*.txt`): reader, evaluation
//! against the codec, and a rendition of what the codec does in the same
//! format. `host-tests/vectors/README.md` describes the format.

use std::fmt::Write;

use hans_codec::{CommandId, Reply, ReplyExpect, Request};

use crate::dump;

/// Largest message a vector may encode to.
const BUF: usize = 16 * 1024;

/// What a vector line is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A request, read with `Request::parse`.
    Req,
    /// A success reply, read with `Reply::parse` against the request.
    Ok,
    /// A failure reply.
    Fail,
    /// An `errorcmd` reply.
    ErrorCmd,
}

impl Kind {
    fn parse(s: &str) -> Option<Kind> {
        Some(match s {
            "req" => Kind::Req,
            "ok" => Kind::Ok,
            "fail" => Kind::Fail,
            "errorcmd" => Kind::ErrorCmd,
            _ => return None,
        })
    }

    /// The word used in the corpus.
    pub fn as_str(self) -> &'static str {
        match self {
            Kind::Req => "req",
            Kind::Ok => "ok",
            Kind::Fail => "fail",
            Kind::ErrorCmd => "errorcmd",
        }
    }
}

/// Where a vector line comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// An example line of chapter 4, verbatim (garbling included).
    Doc,
    /// A document line with its defect repaired: what the example meant.
    Fixed,
    /// Built from the document where it describes an example but prints no
    /// line (from the example's comment and the signature).
    Derived,
    /// A variant `NOTES.md` reports from SDKs and real controllers.
    Notes,
    /// Written for this corpus (edge cases).
    Made,
}

impl Source {
    fn parse(s: &str) -> Option<Source> {
        Some(match s {
            "doc" => Source::Doc,
            "fixed" => Source::Fixed,
            "derived" => Source::Derived,
            "notes" => Source::Notes,
            "made" => Source::Made,
            _ => return None,
        })
    }

    /// The word used in the corpus.
    pub fn as_str(self) -> &'static str {
        match self {
            Source::Doc => "doc",
            Source::Fixed => "fixed",
            Source::Derived => "derived",
            Source::Notes => "notes",
            Source::Made => "made",
        }
    }
}

/// One vector and what the corpus expects of it.
#[derive(Clone, Debug)]
pub struct Vector {
    /// Line number in the file (1-based).
    pub line: usize,
    /// Section of the current `@` header (`-` for none).
    pub section: String,
    /// Command of the current `@` header (`-` for unknown names).
    pub command: String,
    /// Which `@` header the vector follows (counting from 1; 0 before any):
    /// each header starts a block, even one that repeats the previous.
    pub block: usize,
    /// What the line is.
    pub kind: Kind,
    /// Where it comes from.
    pub source: Source,
    /// The message, verbatim.
    pub text: String,
    /// `=>`: the canonical encoding, when it differs from `text`.
    pub canonical: Option<String>,
    /// `!>`: the expected parse error (`Debug` of `ParseError`).
    pub error: Option<String>,
    /// `v:`: the expected typed values (see [`crate::dump`]; `-` for none).
    pub values: Option<String>,
    /// `range!>`: the expected `validate()` error of a request.
    pub range_error: Option<String>,
}

/// A line of the file, kept for the rendition.
#[derive(Clone, Debug)]
enum Item {
    Verbatim(String),
    Header { section: String, command: String },
    Vector(usize),
}

/// A parsed corpus file.
#[derive(Clone, Debug, Default)]
pub struct Corpus {
    items: Vec<Item>,
    /// The vectors, in file order.
    pub vectors: Vec<Vector>,
}

impl Corpus {
    /// Reads a corpus; errors name the offending line.
    pub fn parse(text: &str) -> Result<Corpus, String> {
        let mut c = Corpus::default();
        let (mut section, mut command) = ("-".to_string(), "-".to_string());
        let mut block = 0;
        for (i, line) in text.lines().enumerate() {
            let n = i + 1;
            let bad = |what: &str| format!("line {n}: {what}: {line:?}");
            if line.is_empty() || line.starts_with('#') {
                c.items.push(Item::Verbatim(line.to_string()));
            } else if let Some(rest) = line.strip_prefix("@ ") {
                let mut parts = rest.split_whitespace();
                match (parts.next(), parts.next(), parts.next()) {
                    (Some(s), Some(cmd), None) => {
                        section = s.to_string();
                        command = cmd.to_string();
                    }
                    _ => return Err(bad("a header is `@ <section> <command>`")),
                }
                block += 1;
                c.items.push(Item::Header {
                    section: section.clone(),
                    command: command.clone(),
                });
            } else if let Some((slot, value)) = expectation(line) {
                let v = c
                    .vectors
                    .last_mut()
                    .ok_or_else(|| bad("expectation before any vector"))?;
                let slot = match slot {
                    "=>" => &mut v.canonical,
                    "!>" => &mut v.error,
                    "v:" => &mut v.values,
                    _ => &mut v.range_error,
                };
                if slot.replace(value.to_string()).is_some() {
                    return Err(bad("expectation given twice"));
                }
            } else {
                let (head, text) = line
                    .split_once('|')
                    .ok_or_else(|| bad("a vector is `<kind> <source> |<line>`"))?;
                let mut parts = head.split_whitespace();
                let kind = parts.next().and_then(Kind::parse);
                let source = parts.next().and_then(Source::parse);
                let (Some(kind), Some(source), None) = (kind, source, parts.next()) else {
                    return Err(bad("unknown kind or source"));
                };
                c.items.push(Item::Vector(c.vectors.len()));
                c.vectors.push(Vector {
                    line: n,
                    section: section.clone(),
                    command: command.clone(),
                    block,
                    kind,
                    source,
                    text: text.to_string(),
                    canonical: None,
                    error: None,
                    values: None,
                    range_error: None,
                });
            }
        }
        for v in &c.vectors {
            if v.error.is_some() && (v.canonical.is_some() || v.values.is_some()) {
                return Err(format!(
                    "line {}: an error vector has no canonical form or values",
                    v.line
                ));
            }
        }
        Ok(c)
    }

    /// Reads a corpus file.
    pub fn load(path: &std::path::Path) -> Result<Corpus, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        Corpus::parse(&text).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// Runs every vector through the codec, in order (a reply is read
    /// against the latest request of its block that parsed).
    pub fn evaluate(&self) -> Vec<Outcome> {
        let mut out = Vec::with_capacity(self.vectors.len());
        let mut expect: Option<ReplyExpect> = None;
        let mut block = 0;
        for v in &self.vectors {
            if v.block != block {
                block = v.block;
                expect = None;
            }
            let o = match v.kind {
                Kind::Req => {
                    let (o, e) = evaluate_request(v);
                    if e.is_some() {
                        expect = e;
                    }
                    o
                }
                _ => {
                    let e = expect.unwrap_or_else(|| ReplyExpect::from_name(&v.command));
                    evaluate_reply(v, e)
                }
            };
            out.push(o);
        }
        out
    }

    /// The corpus as the codec sees it: the same file with every vector's
    /// expectations replaced by what the codec does. Comments are kept.
    pub fn render(&self, outcomes: &[Outcome]) -> String {
        let mut s = String::new();
        for item in &self.items {
            match item {
                Item::Verbatim(l) => s.push_str(l),
                Item::Header { section, command } => {
                    let _ = write!(s, "@ {section} {command}");
                }
                Item::Vector(i) => {
                    let v = &self.vectors[*i];
                    let o = &outcomes[*i];
                    let _ = write!(s, "{} {} |{}", v.kind.as_str(), v.source.as_str(), v.text);
                    if let Some(e) = &o.error {
                        let _ = write!(s, "\n!> {e}");
                    }
                    if let Some(c) = o.canonical.as_ref().filter(|c| **c != v.text) {
                        let _ = write!(s, "\n=> {c}");
                    }
                    if let Some(val) = &o.values {
                        let _ = write!(s, "\nv: {val}");
                    }
                    if let Some(r) = &o.range_error {
                        let _ = write!(s, "\nrange!> {r}");
                    }
                }
            }
            s.push('\n');
        }
        s
    }
}

/// Splits `=> x`, `!> x`, `v: x`, `range!> x`.
fn expectation(line: &str) -> Option<(&str, &str)> {
    ["=>", "!>", "v:", "range!>"].into_iter().find_map(|p| {
        line.strip_prefix(p)
            .and_then(|r| r.strip_prefix(' '))
            .map(|r| (p, r))
    })
}

/// What the codec does with one vector.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Outcome {
    /// The canonical encoding (when it parsed).
    pub canonical: Option<String>,
    /// The parse error (`Debug`).
    pub error: Option<String>,
    /// The typed values.
    pub values: Option<String>,
    /// The `validate()` error of a request.
    pub range_error: Option<String>,
    /// Broken invariants, whatever the corpus says: the canonical form does
    /// not read back to the same value, the reply is of another kind, ...
    pub problems: Vec<String>,
}

fn evaluate_request(v: &Vector) -> (Outcome, Option<ReplyExpect>) {
    let mut o = Outcome::default();
    let r = match Request::parse(&v.text) {
        Ok(r) => r,
        Err(e) => {
            o.error = Some(format!("{e:?}"));
            return (o, None);
        }
    };
    match (r.command(), CommandId::from_name(&v.command)) {
        (Some(id), Some(h)) if id == h => {
            // The header names the section of either document.
            if id.section_v5() != Some(&v.section) && id.section_v6() != Some(&v.section) {
                o.problems.push(format!(
                    "header section {} but {} is in {}",
                    v.section,
                    id.name(),
                    id.section()
                ));
            }
        }
        (None, _) if v.command == "-" => {}
        // A fragment of an example the page layout broke over lines, which
        // starts with digits: a message of an unknown name, not misfiled.
        (None, _)
            if v.source == Source::Doc && r.name().starts_with(|c: char| c.is_ascii_digit()) => {}
        (got, _) => o
            .problems
            .push(format!("read as {got:?}, the header says {}", v.command)),
    }
    round_trip(
        &mut o,
        |b| r.encode(b),
        |t| differs(Request::parse(t), &r, t),
    );
    o.values = Some(or_dash(dump::request(&r)));
    o.range_error = r.validate().err().map(|e| format!("{e:?}"));
    (o, Some(r.expect()))
}

/// Writes a message canonically into `o.canonical` and records a problem
/// if it does not encode, or (`reread`) if the text does not read back as
/// the same value.
fn round_trip(
    o: &mut Outcome,
    encode: impl FnOnce(&mut [u8]) -> Result<usize, hans_codec::EncodeError>,
    reread: impl FnOnce(&str) -> Option<String>,
) {
    let mut buf = vec![0u8; BUF];
    match encode(&mut buf) {
        Ok(n) => {
            let text = String::from_utf8_lossy(&buf[..n]).into_owned();
            o.problems.extend(reread(&text));
            o.canonical = Some(text);
        }
        Err(e) => o.problems.push(format!("does not encode: {e:?}")),
    }
}

/// The problem, if `again` (read from the canonical `text`) is not `value`.
fn differs<T: PartialEq + std::fmt::Debug, E: std::fmt::Debug>(
    again: Result<T, E>,
    value: &T,
    text: &str,
) -> Option<String> {
    match again {
        Ok(again) if again == *value => None,
        Ok(again) => Some(format!(
            "canonical form reads back as {again:?}, not {value:?}"
        )),
        Err(e) => Some(format!("canonical form {text:?} does not read back: {e:?}")),
    }
}

fn evaluate_reply(v: &Vector, expect: ReplyExpect) -> Outcome {
    let mut o = Outcome::default();
    let r = match Reply::parse(&v.text, expect) {
        Ok(r) => r,
        Err(e) => {
            o.error = Some(format!("{e:?}"));
            return o;
        }
    };
    let kind = match &r {
        Reply::Ok(_) => Kind::Ok,
        Reply::Fail(_) => Kind::Fail,
        Reply::ErrorCmd(_) => Kind::ErrorCmd,
    };
    if kind != v.kind {
        o.problems
            .push(format!("read as a {} reply", kind.as_str()));
    }
    if let Reply::Ok(resp) = &r {
        if resp.command() != expect.command {
            o.problems.push(format!(
                "answers {:?}, expected {:?}",
                resp.command(),
                expect.command
            ));
        }
    }
    round_trip(
        &mut o,
        |b| r.encode(b),
        |t| differs(Reply::parse(t, expect), &r, t),
    );
    o.values = Some(or_dash(dump::reply(&r)));
    o
}

/// `-` for a message without values, so that `v:` lines never end in a space.
fn or_dash(s: String) -> String {
    if s.is_empty() {
        "-".to_string()
    } else {
        s
    }
}

/// Compares a vector's expectations with the codec's outcome; one line per
/// difference, naming the vector.
pub fn differences(v: &Vector, o: &Outcome) -> Vec<String> {
    let at = format!(
        "line {} ({} {} {:?})",
        v.line,
        v.kind.as_str(),
        v.section,
        v.text
    );
    let mut d: Vec<String> = o.problems.iter().map(|p| format!("{at}: {p}")).collect();
    match (&v.error, &o.error) {
        (Some(want), Some(got)) if want != got => {
            d.push(format!("{at}: error\n   want {want}\n    got {got}"))
        }
        (Some(want), None) => d.push(format!(
            "{at}: expected error {want}, but it parsed as {:?}",
            o.values
        )),
        (None, Some(got)) => d.push(format!("{at}: does not parse: {got}")),
        _ => {}
    }
    if o.error.is_none() {
        let want = v.canonical.as_ref().unwrap_or(&v.text);
        if o.canonical.as_ref() != Some(want) {
            d.push(format!(
                "{at}: canonical form\n   want {want}\n    got {}",
                o.canonical.as_deref().unwrap_or("(none)")
            ));
        }
        if let Some(want) = &v.values {
            if o.values.as_ref() != Some(want) {
                d.push(format!(
                    "{at}: values\n   want {want}\n    got {}",
                    o.values.as_deref().unwrap_or("(none)")
                ));
            }
        }
        if v.range_error != o.range_error {
            d.push(format!(
                "{at}: validate()\n   want {:?}\n    got {:?}",
                v.range_error, o.range_error
            ));
        }
    }
    d
}
