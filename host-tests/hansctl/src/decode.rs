//! `hansctl decode`: protocol messages (one per line) to JSON objects.

use hans_codec::{CommandId, Decimal, Kind, RawMessage, Reply, ReplyExpect, Request, Visitor};
use serde_json::{json, Map, Value};

/// Collects a message's typed values as JSON (the codec's [`Visitor`]).
/// Numbers keep their exact decimal text as JSON numbers.
#[derive(Default)]
pub struct JsonFields {
    root: Map<String, Value>,
    /// Open lists: (name, elements).
    stack: Vec<(String, Vec<Value>)>,
}

impl JsonFields {
    fn put(&mut self, name: &str, v: Value) {
        match self.stack.last_mut() {
            Some((_, items)) => items.push(v),
            None => {
                self.root.insert(name.to_string(), v);
            }
        }
    }

    /// The collected fields.
    pub fn finish(mut self) -> Value {
        while !self.stack.is_empty() {
            self.end_list();
        }
        Value::Object(self.root)
    }
}

/// A decimal as a JSON number with its exact digits (`-0.000` stays as
/// written; values JSON cannot hold fall back to text).
pub fn number(d: Decimal) -> Value {
    let text = d.to_string();
    serde_json::from_str::<serde_json::Number>(&text)
        .map(Value::Number)
        .unwrap_or(Value::String(text))
}

impl Visitor for JsonFields {
    fn int(&mut self, name: &str, v: i32) {
        self.put(name, json!(v));
    }
    fn num(&mut self, name: &str, v: Decimal) {
        self.put(name, number(v));
    }
    fn text(&mut self, name: &str, v: &str) {
        self.put(name, json!(v));
    }
    fn begin_list(&mut self, name: &str) {
        self.stack.push((name.to_string(), Vec::new()));
    }
    fn end_list(&mut self) {
        if let Some((name, items)) = self.stack.pop() {
            self.put(&name, Value::Array(items));
        }
    }
}

/// Decodes one message (a request or a reply, as on the wire) into a JSON
/// object: `name`, `kind` (`request`, `ok`, `fail`, `errorcmd`), `known`,
/// then `fields` (typed values by parameter name; failures: `code`,
/// `code_name`, `detail`) or `error` (why it is not a valid message).
pub fn decode_line(line: &str) -> Value {
    let raw = match RawMessage::parse(line) {
        Ok(r) => r,
        Err(e) => {
            return json!({ "name": "", "kind": "invalid", "known": false, "error": e.to_string() })
        }
    };
    let name = raw.name();
    let known = CommandId::from_name(name).is_some();
    let mut out = Map::new();
    out.insert("name".into(), json!(name));
    match raw.kind() {
        Kind::Request => {
            out.insert("kind".into(), json!("request"));
            out.insert("known".into(), json!(known));
            match Request::parse(line) {
                Ok(req) => {
                    let mut f = JsonFields::default();
                    req.visit(&mut f);
                    out.insert("fields".into(), f.finish());
                    if let Err(e) = req.validate() {
                        out.insert("range_error".into(), json!(e.to_string()));
                    }
                }
                Err(e) => {
                    out.insert("error".into(), json!(e.to_string()));
                }
            }
        }
        kind => {
            let k = match kind {
                Kind::Ok => "ok",
                Kind::Fail => "fail",
                _ => "errorcmd",
            };
            out.insert("kind".into(), json!(k));
            out.insert("known".into(), json!(known));
            match Reply::parse(line, ReplyExpect::from_name(name)) {
                Ok(Reply::Ok(resp)) => {
                    let mut f = JsonFields::default();
                    resp.visit(&mut f);
                    out.insert("fields".into(), f.finish());
                }
                Ok(Reply::Fail(fail)) => {
                    out.insert("code".into(), json!(fail.code.code()));
                    if let Some(n) = fail.code.name() {
                        out.insert("code_name".into(), json!(n));
                    }
                    out.insert("detail".into(), json!(fail.detail));
                }
                Ok(Reply::ErrorCmd(raw)) => {
                    let fields: Vec<&str> = raw.fields().collect();
                    out.insert("fields".into(), json!(fields));
                }
                Err(e) => {
                    out.insert("error".into(), json!(e.to_string()));
                }
            }
        }
    }
    Value::Object(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_replies_and_errors() {
        let v = decode_line("ReadBoxDI,5,6,;");
        assert_eq!(v["kind"], "request");
        assert_eq!(v["fields"]["bits"], json!([5, 6]));
        let v = decode_line("ReadActPos,OK,10.759,0.000,37.828,0.000,37.828,0.000,400.581,76.115,970.143,0.000,75.655,10.759,0,0,0,0,0,0,0,0,0,0,0,0,;");
        assert_eq!(v["kind"], "ok");
        assert_eq!(v["fields"]["joints"][0], json!(10.759));
        let v = decode_line("GrpEnable,Fail,20018,robot busy,;");
        assert_eq!(
            (v["code"].clone(), v["code_name"].clone()),
            (json!(20018), json!("StateRefused"))
        );
        assert_eq!(v["detail"], "robot busy");
        let v = decode_line("WayPoint,0,1,;");
        assert!(v["error"].as_str().unwrap().contains("WayPoint"), "{v}");
        let v = decode_line("ReadVersion,0,;");
        assert_eq!(
            (v["known"].clone(), v["fields"]["0"].clone()),
            (json!(false), json!("0"))
        );
        let v = decode_line("GrpPowerOn,0,;");
        assert_eq!(v["known"], json!(true));
        let v = decode_line("errorcmd,20007,;");
        assert_eq!(v["kind"], "errorcmd");
        let v = decode_line("SetOverride,0,5,;");
        assert!(v["range_error"].is_string());
    }
}
