//! `hansctl decode`: protocol messages, one per line as they appear on the
//! wire, to JSON objects (one per non-blank line).
//!
//! What each object holds is documented on the `decode` subcommand (see
//! `hansctl decode --help`) and in the crate's README. In short: `name`,
//! `kind` (`request`, `ok`, `fail`, `errorcmd`, `invalid`), `known`, then
//! `fields` (typed values by parameter name, numbers exactly as the codec
//! holds them) or, for `Fail`, `code`/`code_name`/`detail`; `error` when
//! the line is not a valid message; `range_error`, `warnings` and
//! `against_request` when they apply.

use hans_codec::number::NumberError;
use hans_codec::{CommandId, Decimal, Kind, RawMessage, Reply, ReplyExpect, Request, Visitor};

use crate::json::{Json, Obj};

/// The longest input line `decode` reads (bytes, line end excluded). A
/// longer line is skipped to its end and reported as an `error` object;
/// the lines after it are decoded as usual. 1 MiB is sixteen times the
/// simulator's (and gateway's) 64 KiB message buffer.
pub const MAX_LINE: usize = 1 << 20;

/// The `error` of a line that does not end with `;`.
const NO_TERMINATOR: &str =
    "no ';' at the end: on the wire this is an incomplete message (a controller answers \
     errorcmd after a pause); fields show how the codec reads the body";

/// Collects a message's typed values as JSON (the codec's [`Visitor`]).
/// Numbers are [`Json::Num`]: the codec's exact decimal, digit for digit.
#[derive(Default)]
struct JsonFields {
    root: Obj,
    /// Open lists: (name, elements).
    stack: Vec<(String, Vec<Json>)>,
    /// Number fields whose text holds more than the codec keeps.
    lossy: Vec<Lossy>,
    /// One line per lossy number met.
    warnings: Vec<String>,
}

/// A number field the codec could not hold exactly.
struct Lossy {
    /// Index of the field (0-based, after the name, and after `OK` for
    /// replies: the codec's own numbering).
    index: usize,
    text: String,
    read: Decimal,
}

impl JsonFields {
    /// A collector that warns when one of `fields` (the values as
    /// written, in order) is a number the codec could not hold exactly.
    fn with_fields<'a>(fields: impl Iterator<Item = &'a str>) -> JsonFields {
        let lossy = fields
            .enumerate()
            .filter_map(|(index, text)| {
                let read = Decimal::parse(text).ok()?;
                let dropped = Decimal::parse_exact(text) == Err(NumberError::Inexact);
                dropped.then(|| Lossy {
                    index,
                    text: text.to_string(),
                    read,
                })
            })
            .collect();
        JsonFields {
            lossy,
            ..JsonFields::default()
        }
    }

    fn put(&mut self, name: &str, v: Json) {
        match self.stack.last_mut() {
            Some((_, items)) => items.push(v),
            None => self.root.insert(name, v),
        }
    }

    /// The collected fields and the warnings about them.
    fn finish(mut self) -> (Json, Vec<String>) {
        while !self.stack.is_empty() {
            self.end_list();
        }
        (Json::Obj(self.root), self.warnings)
    }
}

impl Visitor for JsonFields {
    fn int(&mut self, name: &str, v: i32) {
        self.put(name, v.into());
    }
    fn num(&mut self, name: &str, v: Decimal) {
        if let Some(pos) = self.lossy.iter().position(|l| l.read.is_identical(&v)) {
            let l = self.lossy.remove(pos);
            let param = self.stack.last().map_or(name, |(list, _)| list.as_str());
            self.warnings.push(format!(
                "{param} (field {}): {:?} has more digits than the codec keeps; read as {}",
                l.index, l.text, l.read
            ));
        }
        self.put(name, v.into());
    }
    fn text(&mut self, name: &str, v: &str) {
        self.put(name, v.into());
    }
    fn begin_list(&mut self, name: &str) {
        self.stack.push((name.to_string(), Vec::new()));
    }
    fn end_list(&mut self) {
        if let Some((name, items)) = self.stack.pop() {
            self.put(&name, Json::Arr(items));
        }
    }
}

/// Decodes a stream of lines, reading a reply against the request on the
/// line before it when the names match (see [`Decoder::line`]).
#[derive(Default)]
pub struct Decoder {
    /// What the reply to the previous line must look like, if that line
    /// was a valid request of a known command.
    previous: Option<ReplyExpect>,
}

impl Decoder {
    /// A decoder with no previous line.
    pub fn new() -> Decoder {
        Decoder::default()
    }

    /// Decodes one input line (bytes as read; a trailing `\n` and `\r` are
    /// ignored). `None` for a blank line, which is skipped and does not
    /// separate a request from its reply. What the object holds (bytes
    /// that are not UTF-8, a missing `;`, a reply read against the request
    /// before it) is described once, on the `decode` subcommand: see
    /// `hansctl decode --help`.
    pub fn line(&mut self, bytes: &[u8]) -> Option<Json> {
        let bytes = bytes.strip_suffix(b"\n").unwrap_or(bytes);
        let bytes = bytes.strip_suffix(b"\r").unwrap_or(bytes);
        if bytes.iter().all(u8::is_ascii_whitespace) {
            return None;
        }
        let previous = self.previous.take();
        let text = match std::str::from_utf8(bytes) {
            Ok(t) => t,
            Err(e) => {
                let at = e.valid_up_to();
                let byte = bytes.get(at).copied().unwrap_or(0);
                return Some(invalid(format!(
                    "not UTF-8: byte 0x{byte:02x} at offset {at} of the line"
                )));
            }
        };
        let terminated = text.trim_end_matches([' ', '\t']).ends_with(';');
        let (mut out, expect) = message(text, previous);
        if terminated {
            self.previous = expect;
        } else {
            let why = match out.get("error") {
                Some(Json::Str(e)) => format!("{NO_TERMINATOR}; and: {e}"),
                _ => NO_TERMINATOR.to_string(),
            };
            out.insert("error", why);
        }
        Some(Json::Obj(out))
    }

    /// The object for a line longer than [`MAX_LINE`] (`len` bytes), which
    /// was skipped.
    pub fn too_long(&mut self, len: usize) -> Json {
        self.previous = None;
        invalid(format!(
            "line of {len} bytes is longer than {MAX_LINE} bytes: skipped"
        ))
    }
}

/// The object of a line that is not a message: `kind` `invalid` and why.
fn invalid_obj(error: String) -> Obj {
    let mut o = Obj::new();
    o.insert("name", "");
    o.insert("kind", "invalid");
    o.insert("known", false);
    o.insert("error", error);
    o
}

fn invalid(error: String) -> Json {
    Json::Obj(invalid_obj(error))
}

/// Decodes a reply read against its request (`expect`), as `send --json`
/// and the other client subcommands print it.
pub fn reply(text: &str, expect: ReplyExpect) -> Json {
    let (mut out, _) = message(text, Some(expect));
    if out.get("against_request").is_none() && out.get("error").is_none() {
        // Not a reply of that command: say so, not only what it reads as
        // by its own name.
        if let Err(e) = Reply::parse(text, expect) {
            out.insert("error", e.to_string());
        }
    }
    Json::Obj(out)
}

/// Decodes one message. `previous`: what the reply to the line before must
/// look like, applied if this is a reply of that command. Returns the
/// object and, for a valid request of a known command, what its reply must
/// look like.
fn message(text: &str, previous: Option<ReplyExpect>) -> (Obj, Option<ReplyExpect>) {
    let raw = match RawMessage::parse(text) {
        Ok(r) => r,
        Err(e) => return (invalid_obj(e.to_string()), None),
    };
    let mut out = Obj::new();
    let name = raw.name();
    let command = CommandId::from_name(name);
    out.insert("name", name);
    let kind = raw.kind();
    out.insert(
        "kind",
        match kind {
            Kind::Request => "request",
            Kind::Ok => "ok",
            Kind::Fail => "fail",
            _ => "errorcmd",
        },
    );
    out.insert("known", command.is_some());
    let mut next = None;
    match kind {
        Kind::Request => match Request::parse(text) {
            Ok(req) => {
                let mut f = JsonFields::with_fields(raw.fields());
                req.visit(&mut f);
                put_fields(&mut out, f);
                if let Err(e) = req.validate() {
                    out.insert("range_error", e.to_string());
                }
                next = command.map(|_| req.expect());
            }
            Err(e) => out.insert("error", e.to_string()),
        },
        _ => {
            let against = previous.filter(|p| {
                matches!(kind, Kind::Ok | Kind::Fail) && command.is_some() && p.command == command
            });
            let expect = against.unwrap_or_else(|| ReplyExpect::from_name(name));
            match Reply::parse(text, expect) {
                Ok(Reply::Ok(resp)) => {
                    // The values after `OK`, numbered as the codec does.
                    let mut f = JsonFields::with_fields(raw.fields().skip(1));
                    resp.visit(&mut f);
                    put_fields(&mut out, f);
                }
                Ok(Reply::Fail(fail)) => {
                    out.insert("code", fail.code.code());
                    if let Some(n) = fail.code.name() {
                        out.insert("code_name", n);
                    }
                    out.insert("detail", fail.detail);
                }
                Ok(Reply::ErrorCmd(raw)) => {
                    out.insert("fields", raw.fields().collect::<Vec<_>>());
                }
                Err(e) => out.insert("error", e.to_string()),
            }
            if against.is_some() {
                out.insert("against_request", true);
            }
        }
    }
    (out, next)
}

fn put_fields(out: &mut Obj, f: JsonFields) {
    let (fields, warnings) = f.finish();
    out.insert("fields", fields);
    if !warnings.is_empty() {
        out.insert("warnings", warnings);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::{json, Value};

    /// Decodes lines in order; each output parsed back as JSON, with its
    /// text.
    fn decode(lines: &[&[u8]]) -> Vec<(Value, String)> {
        let mut d = Decoder::new();
        lines
            .iter()
            .filter_map(|l| d.line(l))
            .map(|j| {
                let text = j.to_string();
                (serde_json::from_str(&text).unwrap(), text)
            })
            .collect()
    }

    fn one(line: &str) -> (Value, String) {
        decode(&[line.as_bytes()]).remove(0)
    }

    #[test]
    fn requests_replies_and_errors() {
        let (v, _) = one("ReadBoxDI,5,6,;");
        assert_eq!(v["kind"], "request");
        assert_eq!(v["fields"]["bits"], json!([5, 6]));
        let (v, _) = one("ReadActPos,OK,10.759,0.000,37.828,0.000,37.828,0.000,400.581,76.115,970.143,0.000,75.655,10.759,0,0,0,0,0,0,0,0,0,0,0,0,;");
        assert_eq!(v["kind"], "ok");
        assert_eq!(v["fields"]["joints"][0], json!(10.759));
        let (v, _) = one("GrpEnable,Fail,20018,robot busy,;");
        assert_eq!(
            (v["code"].clone(), v["code_name"].clone()),
            (json!(20018), json!("StateRefused"))
        );
        assert_eq!(v["detail"], "robot busy");
        let (v, _) = one("WayPoint,0,1,;");
        assert!(v["error"].as_str().unwrap().contains("WayPoint"), "{v}");
        let (v, _) = one("ReadVersion,0,;");
        assert_eq!(
            (v["known"].clone(), v["fields"]["0"].clone()),
            (json!(false), json!("0"))
        );
        let (v, _) = one("GrpPowerOn,0,;");
        assert_eq!(v["known"], json!(true));
        let (v, _) = one("errorcmd,20007,;");
        assert_eq!(v["kind"], "errorcmd");
        let (v, _) = one("SetOverride,0,5,;");
        assert!(v["range_error"].is_string());
    }

    #[test]
    fn invalid_utf8_names_the_byte_and_its_offset_and_decoding_goes_on() {
        let v = decode(&[
            b"ReadCurFSM,0,;\n",
            b"\xff\xfe\x00\x01;\n",
            b"ReadCurFSM,OK,33,;\n",
            b"ReadCurFSM,0\xc3(,;\r\n",
            b"ReadCurFSM,0,\xe2\x82",
        ]);
        assert_eq!(v.len(), 5);
        assert_eq!(v[0].0["fields"]["rbt_id"], 0);
        assert_eq!(
            (v[1].0["kind"].as_str(), v[1].0["error"].as_str()),
            (
                Some("invalid"),
                Some("not UTF-8: byte 0xff at offset 0 of the line")
            )
        );
        assert_eq!(v[2].0["fields"]["state"], 33);
        assert_eq!(
            v[3].0["error"],
            "not UTF-8: byte 0xc3 at offset 12 of the line"
        );
        // A sequence cut off at the end of the line.
        assert_eq!(
            v[4].0["error"],
            "not UTF-8: byte 0xe2 at offset 13 of the line"
        );
    }

    #[test]
    fn numbers_are_written_exactly_as_the_codec_holds_them() {
        let (v, text) = one("ReadActPos,OK,10.759,-0.000,37.828,0.000,37.828,0.000,400.581,76.115,970.143,0.000,75.655,10.759,0,0,0,0,0,0,0,0,0,0,0,0,;");
        assert!(
            text.contains(r#""joints":[10.759,-0.000,37.828,0.000,37.828,0.000]"#),
            "{text}"
        );
        assert!(text.contains(r#""tcp":[0,0,0,0,0,0]"#), "{text}");
        assert!(v.get("warnings").is_none(), "{text}");
        let (v, text) = one("SetOverride,0,0.123456789012345678,;");
        assert!(text.contains(r#""ratio":0.123456789012345678"#), "{text}");
        assert!(v.get("warnings").is_none(), "{text}");
        let (_, text) = one("ReadCurFSM,OK,33,;");
        assert!(text.contains(r#""state":33"#), "{text}");
        // Exponent forms are the same number as a plain decimal.
        let (v, text) = one("SetOverride,0,1.0E-1,;");
        assert!(text.contains(r#""ratio":0.10"#), "{text}");
        assert!(v.get("warnings").is_none(), "{text}");
        // Wider than the codec: the value it reads, and a warning saying so.
        let long = "0.1234567890123456789012345678901234567890";
        let (v, text) = one(&format!("SetOverride,0,{long},;"));
        assert!(text.contains(r#""ratio":0.12345678901234"#), "{text}");
        assert!(!text.contains(&format!("\"ratio\":{long}")), "{text}");
        let w = v["warnings"][0].as_str().unwrap();
        assert!(
            w.starts_with("ratio (field 1)") && w.contains(&format!("{long:?}")),
            "{w}"
        );
        let (v, _) = one(
            "ReadActPos,OK,1,2,3,4,5,6.000000000000000000000000000001,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,;",
        );
        let w = v["warnings"][0].as_str().unwrap();
        assert!(w.starts_with("joints (field 5)"), "{w}");
    }

    #[test]
    fn a_line_without_terminator_is_an_error_with_its_body_decoded() {
        let (v, _) = one("garbage");
        assert_eq!(v["kind"], "request");
        assert!(v["error"].as_str().unwrap().starts_with("no ';'"), "{v}");
        let (v, _) = one("ReadCurFSM,0,");
        assert!(v["error"].as_str().unwrap().starts_with("no ';'"), "{v}");
        assert_eq!(v["fields"]["rbt_id"], 0);
        let (v, _) = one("WayPoint,0,1");
        let e = v["error"].as_str().unwrap();
        assert!(e.starts_with("no ';'") && e.contains("WayPoint:"), "{e}");
        // Spaces after the `;` are not part of the message.
        let (v, _) = one("ReadCurFSM,0,; \t");
        assert!(v.get("error").is_none(), "{v}");
        // The codec's own error for a body that is no message stays.
        let (v, _) = one(",;");
        assert_eq!(v["kind"], "invalid");
        assert!(v["error"].is_string());
    }

    #[test]
    fn a_reply_is_read_against_the_request_on_the_line_before() {
        let v = decode(&[
            b"ReadBoxDI,5,6,;",
            b"ReadBoxDI,OK,0,1,1,1,1,1,1,1,;",
            b"ReadBoxDI,5,6,;",
            b"",
            b"ReadBoxDI,OK,0,1,;",
            // Read by name: no request before it.
            b"ReadBoxDI,OK,0,1,1,1,1,1,1,1,;",
            // Another command's request in between.
            b"ReadBoxDI,5,6,;",
            b"ReadCurFSM,0,;",
            b"ReadBoxDI,OK,0,1,1,1,1,1,1,1,;",
            // A request line without `;` does not pair.
            b"ReadBoxDI,5,6,",
            b"ReadBoxDI,OK,0,1,1,1,1,1,1,1,;",
            // A Fail reply pairs too; an alias answers under its name.
            b"GrpPowerOn,0,;",
            b"GrpPowerOn,Fail,20018,;",
        ]);
        assert!(v[1].0["error"].is_string(), "{}", v[1].1);
        assert_eq!(v[1].0["against_request"], true);
        assert_eq!(v[3].0["fields"]["values"], json!([0, 1]));
        assert_eq!(v[3].0["against_request"], true);
        assert!(v[4].0.get("error").is_none(), "{}", v[4].1);
        assert!(v[4].0.get("against_request").is_none());
        assert!(v[7].0.get("error").is_none(), "{}", v[7].1);
        assert!(v[9].0.get("error").is_none(), "{}", v[9].1);
        assert_eq!(v[11].0["against_request"], true);
        assert_eq!(v[11].0["code"], 20018);
    }

    #[test]
    fn reply_reads_against_the_request_sent() {
        let expect = Request::parse("ReadBoxDI,5,6,;").unwrap().expect();
        let v: Value =
            serde_json::from_str(&reply("ReadBoxDI,OK,0,1,;", expect).to_string()).unwrap();
        assert_eq!(v["fields"]["values"], json!([0, 1]));
        let v: Value =
            serde_json::from_str(&reply("ReadCurFSM,OK,33,;", expect).to_string()).unwrap();
        assert!(v["error"].is_string(), "{v}");
        let v: Value =
            serde_json::from_str(&reply("errorcmd,20007,;", expect).to_string()).unwrap();
        assert_eq!(v["kind"], "errorcmd");
        assert!(v.get("error").is_none(), "{v}");
    }

    #[test]
    fn too_long_lines_are_reported_and_break_a_pair() {
        let mut d = Decoder::new();
        d.line(b"ReadBoxDI,5,6,;");
        let v: Value = serde_json::from_str(&d.too_long(MAX_LINE + 5).to_string()).unwrap();
        assert_eq!(v["kind"], "invalid");
        assert!(v["error"].as_str().unwrap().contains("longer than"));
        let v = d.line(b"ReadBoxDI,OK,0,1,1,1,1,1,1,1,;").unwrap();
        assert!(!v.to_string().contains("error"), "{v}");
    }
}
