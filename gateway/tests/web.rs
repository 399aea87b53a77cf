//! The web page and its API in virtual time: the real gateway future with
//! its web server on the simulated network (`hans_gateway::testkit`), an
//! HTTP client written out by hand (requests as bytes, answers read
//! back), and the Modbus view of the same state to check against.

use core::net::Ipv4Addr;

use embassy_time::Duration;
use hans_gateway::registers as r;
use hans_gateway::testkit::world::{World, WorldConfig};
use serde_json::Value;

const PC: Ipv4Addr = Ipv4Addr::new(10, 0, 0, 50);
const OTHER: Ipv4Addr = Ipv4Addr::new(10, 0, 0, 51);

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

fn world() -> World {
    let mut w = World::new(WorldConfig {
        web: true,
        ..WorldConfig::default()
    });
    w.run_for(ms(300));
    w
}

/// An answer: status, headers (lower-case names), body (chunks joined).
struct Answer {
    status: u16,
    headers: Vec<(String, String)>,
    body: Vec<u8>,
}

impl Answer {
    fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }

    fn json(&self) -> Value {
        serde_json::from_slice(&self.body)
            .unwrap_or_else(|e| panic!("not JSON ({e}): {}", String::from_utf8_lossy(&self.body)))
    }

    /// The session token the answer sets.
    fn token(&self) -> String {
        let c = self.header("set-cookie").expect("a session cookie");
        c.split(';')
            .next()
            .and_then(|kv| kv.strip_prefix("hgw_session="))
            .expect("hgw_session=")
            .to_string()
    }
}

fn parse(raw: &[u8]) -> Option<Answer> {
    let end = raw.windows(4).position(|w| w == b"\r\n\r\n")?;
    let head = String::from_utf8_lossy(&raw[..end]).to_string();
    let mut lines = head.split("\r\n");
    let status = lines.next()?.split(' ').nth(1)?.parse().ok()?;
    let headers: Vec<(String, String)> = lines
        .filter_map(|l| l.split_once(':'))
        .map(|(n, v)| (n.trim().to_ascii_lowercase(), v.trim().to_string()))
        .collect();
    let mut rest = &raw[end + 4..];
    let chunked = headers
        .iter()
        .any(|(n, v)| n == "transfer-encoding" && v == "chunked");
    let body = if chunked {
        let mut body = Vec::new();
        loop {
            let line_end = rest.windows(2).position(|w| w == b"\r\n")?;
            let size =
                usize::from_str_radix(std::str::from_utf8(&rest[..line_end]).ok()?, 16).ok()?;
            rest = &rest[line_end + 2..];
            if size == 0 {
                break;
            }
            body.extend_from_slice(rest.get(..size)?);
            rest = rest.get(size + 2..)?;
        }
        body
    } else {
        rest.to_vec()
    };
    Some(Answer {
        status,
        headers,
        body,
    })
}

fn request(method: &str, path: &str, headers: &[(&str, &str)], body: &[u8]) -> Vec<u8> {
    let mut r = format!("{method} {path} HTTP/1.1\r\nHost: gw\r\nConnection: close\r\n");
    for (n, v) in headers {
        r.push_str(&format!("{n}: {v}\r\n"));
    }
    r.push_str(&format!("Content-Length: {}\r\n\r\n", body.len()));
    let mut r = r.into_bytes();
    r.extend_from_slice(body);
    r
}

fn send(w: &mut World, from: Ipv4Addr, raw: &[u8]) -> Option<Answer> {
    let got = w.http(from, raw, Duration::from_secs(10));
    parse(&got)
}

fn get(w: &mut World, path: &str) -> Answer {
    send(w, PC, &request("GET", path, &[], b"")).expect("an answer")
}

fn post(w: &mut World, path: &str, token: Option<&str>, body: &[u8]) -> Answer {
    let auth = token.map(|t| format!("hgw_session={t}"));
    let headers: Vec<(&str, &str)> = auth.iter().map(|c| ("Cookie", c.as_str())).collect();
    send(w, PC, &request("POST", path, &headers, body)).expect("an answer")
}

/// Sets the first password and returns the session it opens.
fn set_password(w: &mut World) -> String {
    let a = post(w, "/api/password", None, b"\ncorrect horse");
    assert_eq!(a.status, 200, "{}", String::from_utf8_lossy(&a.body));
    a.token()
}

#[test]
fn the_page_is_served_compressed_and_the_status_is_the_state() {
    let mut w = world();
    let page = get(&mut w, "/");
    assert_eq!(page.status, 200);
    assert_eq!(page.header("content-encoding"), Some("gzip"));
    assert!(page
        .header("content-type")
        .unwrap()
        .starts_with("text/html"));
    assert_eq!(&page.body[..2], &[0x1f, 0x8b], "gzip magic");
    let s = get(&mut w, "/api/status").json();
    assert_eq!(s["map"], "1.2");
    assert_eq!(s["link"]["state"], "connected");
    assert_eq!(s["robot"]["fsm"]["code"], w.reg(r::STATUS_FSM));
    assert_eq!(s["channels"].as_array().unwrap().len(), 2);
    assert_eq!(s["triggers"].as_array().unwrap().len(), 16);
    assert_eq!(s["modbus"]["sessions"], 1);
    assert_eq!(s["modbus"]["clients"][0], "10.0.0.10:50000");
    assert_eq!(get(&mut w, "/nope").status, 404);
    assert_eq!(
        send(&mut w, PC, &request("DELETE", "/api/status", &[], b""))
            .unwrap()
            .status,
        405
    );
}

#[test]
fn a_fresh_device_asks_for_a_password_before_any_change() {
    let mut w = world();
    let a = post(
        &mut w,
        "/api/config",
        None,
        br#"{"settings":{"link.poll_ms":"50"}}"#,
    );
    assert_eq!(a.status, 403);
    assert_eq!(a.json()["error"], "set a password first");
    let s = get(&mut w, "/api/session").json();
    assert_eq!(s["password_set"], false);
    assert_eq!(post(&mut w, "/api/password", None, b"\nshort").status, 400);
    let token = set_password(&mut w);
    assert_ne!(w.reg(r::STATUS_ACCESS) & r::ACCESS_PASSWORD_SET, 0);
    // Now a second "first" password needs the current one.
    assert_eq!(
        post(&mut w, "/api/password", None, b"\nsomeone else").status,
        401
    );
    // Without a session: refused.
    let a = post(
        &mut w,
        "/api/config",
        None,
        br#"{"settings":{"link.poll_ms":"50"}}"#,
    );
    assert_eq!(a.status, 401);
    let a = post(
        &mut w,
        "/api/config",
        Some(&token),
        br#"{"settings":{"link.poll_ms":"50"}}"#,
    );
    assert_eq!(a.status, 200, "{}", String::from_utf8_lossy(&a.body));
    assert_eq!(
        w.reg(r::CONFIG_POLL_MS),
        50,
        "applied, read back over Modbus"
    );
    // The hash was saved with the configuration: a restart keeps it.
    w.restart();
    w.run_for(ms(300));
    assert_eq!(get(&mut w, "/api/session").json()["password_set"], true);
    let a = post(&mut w, "/api/login", None, b"correct horse");
    assert_eq!(a.status, 200);
}

#[test]
fn an_invalid_value_is_refused_with_its_reason_and_nothing_changes() {
    let mut w = world();
    let token = set_password(&mut w);
    let before = get(&mut w, "/api/config").json();
    let a = post(
        &mut w,
        "/api/config",
        Some(&token),
        br#"{"settings":{"link.poll_ms":"60","watchdog.period_ms":"10","network.mask":"255.0.255.0"}}"#,
    );
    assert_eq!(a.status, 400);
    let e = a.json();
    assert_eq!(e["errors"]["watchdog.period_ms"], "out of range");
    assert_eq!(
        e["errors"]["network.mask"],
        "not a network mask (e.g. 255.255.255.0)"
    );
    assert!(e["errors"].get("link.poll_ms").is_none());
    assert_eq!(get(&mut w, "/api/config").json(), before);
    assert_eq!(w.reg(r::CONFIG_POLL_MS), 100);
}

#[test]
fn export_then_import_gives_the_same_configuration() {
    let mut w = world();
    let token = set_password(&mut w);
    let a = post(
        &mut w,
        "/api/config",
        Some(&token),
        br#"{"settings":{"link.poll_ms":"40","access.web_allow":"10.0.0.0/24","watchdog.period_ms":"500"},"triggers":["SetBoxDO,2,1,;","","GrpStop,0,;"]}"#,
    );
    assert_eq!(a.status, 200, "{}", String::from_utf8_lossy(&a.body));
    let exported = get(&mut w, "/api/config");
    let doc = exported.json();
    assert_eq!(doc["settings"]["access.web_allow"], "10.0.0.0/24");
    assert_eq!(doc["triggers"][2], "GrpStop,0,;");
    // Change things, then import the export: all back.
    let a = post(
        &mut w,
        "/api/config",
        Some(&token),
        br#"{"settings":{"link.poll_ms":"90"},"triggers":["","","","GrpReset,0,;"]}"#,
    );
    assert_eq!(a.status, 200);
    assert_ne!(get(&mut w, "/api/config").json(), doc);
    let a = post(&mut w, "/api/config", Some(&token), &exported.body);
    assert_eq!(a.status, 200, "{}", String::from_utf8_lossy(&a.body));
    assert_eq!(get(&mut w, "/api/config").json(), doc);
}

#[test]
fn a_trigger_entry_stored_from_the_page_fires_from_its_bit() {
    let mut w = world();
    let token = set_password(&mut w);
    let a = post(
        &mut w,
        "/api/trigger/5",
        Some(&token),
        b"Not a protocol message",
    );
    assert_eq!(a.status, 400);
    let a = post(&mut w, "/api/trigger/5", Some(&token), b"SetBoxDO,3,1,;");
    assert_eq!(a.status, 200, "{}", String::from_utf8_lossy(&a.body));
    assert_eq!(
        post(&mut w, "/api/trigger/16", Some(&token), b"GrpStop,0,;").status,
        404
    );
    w.set(r::TRIG_BITS, &[1 << 5]);
    let done = w.run_until_cond(Duration::from_secs(2), |w| {
        w.reg(r::TRIG_DONE) & (1 << 5) != 0
    });
    assert!(done, "entry 5 Done");
    assert!(w
        .robot
        .log
        .iter()
        .any(|m| m.text.starts_with("SetBoxDO,3,1")));
    // The log shows it, with the text sent and the reply.
    let log = get(&mut w, "/api/log").json();
    let last = log["entries"]
        .as_array()
        .unwrap()
        .iter()
        .rev()
        .find(|e| e["kind"] == "command")
        .cloned()
        .unwrap();
    assert_eq!(last["source"], "trigger");
    assert_eq!(last["index"], 5);
    assert_eq!(last["sent"], "SetBoxDO,3,1,;");
    assert_eq!(last["outcome"]["result"], "done");
    assert!(last["reply"].as_str().unwrap().starts_with("SetBoxDO,OK"));
}

#[test]
fn wrong_passwords_are_rate_limited() {
    let mut w = world();
    set_password(&mut w);
    for _ in 0..3 {
        assert_eq!(post(&mut w, "/api/login", None, b"guess one").status, 401);
    }
    assert_eq!(post(&mut w, "/api/login", None, b"guess two").status, 401);
    let a = post(&mut w, "/api/login", None, b"correct horse");
    assert_eq!(a.status, 429, "even the right one waits");
    assert!(a.json()["retry_after_s"].as_u64().unwrap() >= 1);
    w.run_for(Duration::from_secs(2));
    assert_eq!(post(&mut w, "/api/login", None, b"guess three").status, 401);
    let a = post(&mut w, "/api/login", None, b"correct horse");
    assert_eq!(a.status, 429, "the wait doubled");
    w.run_for(Duration::from_secs(3));
    assert_eq!(
        post(&mut w, "/api/login", None, b"correct horse").status,
        200
    );
}

#[test]
fn the_web_allow_list_refuses_other_clients_and_counts_them() {
    let mut w = world();
    let token = set_password(&mut w);
    let a = post(
        &mut w,
        "/api/config",
        Some(&token),
        br#"{"settings":{"access.web_allow":"10.0.0.50"}}"#,
    );
    assert_eq!(a.status, 200);
    assert!(send(&mut w, OTHER, &request("GET", "/api/status", &[], b"")).is_none());
    assert_eq!(w.reg(r::STATUS_WEB_REFUSED), 1);
    assert_eq!(get(&mut w, "/api/status").status, 200);
}

#[test]
fn write_protection_is_lifted_only_from_the_page() {
    let mut w = world();
    let token = set_password(&mut w);
    w.set(r::CONFIG_WRITE_PROTECT, &[1]);
    w.set(r::CONTROL_CONFIG_COMMAND, &[1]);
    assert_eq!(w.write(r::CONFIG_POLL_MS, &[20]), Err(1));
    let a = post(
        &mut w,
        "/api/config",
        Some(&token),
        br#"{"settings":{"link.poll_ms":"20"}}"#,
    );
    assert_eq!(a.status, 200, "the page still changes it");
    assert_eq!(w.reg(r::CONFIG_POLL_MS), 20);
    let a = post(
        &mut w,
        "/api/config",
        Some(&token),
        br#"{"settings":{"access.write_protect":"0"}}"#,
    );
    assert_eq!(a.status, 200);
    assert_eq!(w.write(r::CONFIG_POLL_MS, &[30]), Ok(()));
}

#[test]
fn malformed_and_oversized_requests_get_4xx_and_the_connection_closes() {
    let mut w = world();
    let a = send(&mut w, PC, b"GARBAGE\r\n\r\n").expect("an answer");
    assert_eq!(a.status, 400);
    let a = send(&mut w, PC, b"GET / HTTP/1.1\r\nNo colon here\r\n\r\n").expect("an answer");
    assert_eq!(a.status, 400);
    let token = set_password(&mut w);
    let big = vec![b'x'; 7000];
    let auth = format!("hgw_session={token}");
    let a = send(
        &mut w,
        PC,
        &request("POST", "/api/config", &[("Cookie", &auth)], &big),
    );
    assert!(matches!(a.map(|a| a.status), Some(413) | Some(400) | None));
    // A header section longer than the buffer: no panic, the gateway
    // still serves the next client.
    let mut long = b"GET / HTTP/1.1\r\nX: ".to_vec();
    long.extend(vec![b'a'; 8000]);
    long.extend_from_slice(b"\r\n\r\n");
    let _ = send(&mut w, PC, &long);
    assert_eq!(get(&mut w, "/api/status").status, 200);
    // A cross-site POST is refused.
    let a = send(
        &mut w,
        PC,
        &request(
            "POST",
            "/api/logout",
            &[("Origin", "http://evil.example")],
            b"",
        ),
    )
    .unwrap();
    assert_eq!(a.status, 403);
}

#[test]
fn a_recovery_start_lets_a_forgotten_password_be_replaced() {
    let mut w = world();
    set_password(&mut w);
    let token = post(&mut w, "/api/login", None, b"correct horse").token();
    // Lock out the web page (an allow-list without this PC) and protect the
    // registers: then forget the password.
    let a = post(
        &mut w,
        "/api/config",
        Some(&token),
        br#"{"settings":{"access.web_allow":"10.9.9.9","access.write_protect":"1"}}"#,
    );
    assert_eq!(a.status, 200);
    assert!(send(&mut w, PC, &request("GET", "/api/session", &[], b"")).is_none());
    // Without the old password: refused, until the board starts in
    // recovery (factory network and access settings, the old password
    // not needed).
    w.config.recovery = true;
    w.restart();
    w.run_for(ms(300));
    assert_ne!(w.reg(r::STATUS_ACCESS) & r::ACCESS_RECOVERY, 0);
    assert_eq!(w.reg(r::CONFIG_WRITE_PROTECT), 0, "factory access settings");
    let s = get(&mut w, "/api/session").json();
    assert_eq!(s["recovery"], true);
    let a = post(&mut w, "/api/password", None, b"\nbattery staple");
    assert_eq!(a.status, 200, "{}", String::from_utf8_lossy(&a.body));
    w.config.recovery = false;
    w.restart();
    w.run_for(ms(300));
    assert_eq!(
        post(&mut w, "/api/login", None, b"battery staple").status,
        200
    );
}
