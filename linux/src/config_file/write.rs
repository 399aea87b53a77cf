//! Writing the file: every key with a comment naming its register and
//! what it takes, the password's hash, the trigger entries.

extern crate std;

use std::format;
use std::string::{String, ToString};
use std::vec::Vec;

use super::{register_name, takes, Contents, ACCOUNTS, SCHEME};
use hans_gateway::config::{Kind, Setting, Value, SETTINGS};
use hans_gateway::state::inputs::{TRIGGERS, TRIGGER_TEXT};

fn hex(bytes: &[u8]) -> String {
    let mut out = vec![0u8; bytes.len() * 2];
    hans_gateway::hex::encode(bytes, &mut out)
        .unwrap_or_default()
        .to_owned()
}

/// A TOML basic string: `"` and `\` escaped, control characters as
/// `\uXXXX` (TOML allows every other character as it is).
pub(super) fn toml_string(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\t' => out.push_str("\\t"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            c if c.is_control() => {
                out.push_str(&format!("\\u{:04X}", u32::from(c)));
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// The first lines of a saved file.
const HEADER: &str = "\
# hans-gateway configuration (TOML): the settings, the trigger table and the web
# password's salted hash. Each key's comment names its register (REGISTERS.md) and
# what it takes.
#
# Written whole by hans-gateway at each save (CONFIG_COMMAND 1 over Modbus, or the
# web page): comments added by hand are not kept. Edit it while the gateway is
# stopped. A key left out takes its factory default; an unknown key or a value out
# of range is refused with its line, and the gateway does not start on the file.
";

/// The file's text for `contents`: every key, with a comment naming its
/// register and what it takes; empty trigger entries are left out.
pub fn render(contents: &Contents) -> String {
    let config = &contents.stored.config;
    let mut out = String::from(HEADER);
    let mut table = "";
    for s in SETTINGS {
        if s.group() != table {
            if table == "access" {
                password(contents, &mut out);
            }
            table = s.group();
            out.push_str(&format!("\n[{table}]\n"));
        }
        let about = match s.kind {
            Kind::AllowList => "clients allowed",
            _ => s.help,
        };
        out.push_str(&format!(
            "# {}: {about}; takes {}\n",
            register_name(s),
            takes(s)
        ));
        out.push_str(&format!(
            "{} = {}\n",
            s.name(),
            value_text(s, &s.get(config))
        ));
    }
    if table == "access" {
        password(contents, &mut out);
    }
    out.push_str(&format!(
        "\n[triggers]\n# TRIGn_TEXT: entry n (0-{}), fired by bit n of TRIG_BITS: one protocol message,\n\
         # at most {TRIGGER_TEXT} bytes. Empty entries are left out.\n",
        TRIGGERS - 1
    ));
    for (n, e) in contents.triggers.iter().enumerate() {
        if e.is_empty() {
            continue;
        }
        let value = match core::str::from_utf8(e.bytes()) {
            Ok(s) => toml_string(s),
            Err(_) => {
                let bytes: Vec<String> = e.bytes().iter().map(|b| b.to_string()).collect();
                format!("[{}]  # not UTF-8: its bytes", bytes.join(", "))
            }
        };
        out.push_str(&format!("{n} = {value}\n"));
    }
    out
}

/// The accounts' lines, in `[access]`.
fn password(contents: &Contents, out: &mut String) {
    out.push_str(&format!(
        "# The web page's accounts (at most 8): name, role (viewer, operator, admin) and the\n\
         # password as a salted hash, never the password itself: \"{SCHEME}$ROUNDS$SALT$HASH\"\n\
         # (PBKDF2-HMAC-SHA256; salt and hash in hex), and the addresses each last logged in\n\
         # from (trusted: the rate limit of guesses never makes the owner wait there). Manage\n\
         # them on the web page; the first administrator is created there with the setup code.\n"
    ));
    let accounts = &contents.stored.accounts;
    if accounts.is_empty() {
        out.push_str(&format!("# {ACCOUNTS} = [] (none yet)\n"));
        return;
    }
    out.push_str(&format!("{ACCOUNTS} = [\n"));
    for (i, a) in
        (0..hans_gateway::access::accounts::ACCOUNTS).filter_map(|i| accounts.at(i).map(|a| (i, a)))
    {
        let trusted: Vec<String> = accounts
            .trusted(i)
            .iter()
            .flatten()
            .map(|ip| format!("\"{ip}\""))
            .collect();
        let trusted = match trusted.is_empty() {
            true => String::new(),
            false => format!(", trusted = [{}]", trusted.join(", ")),
        };
        out.push_str(&format!(
            "  {{ name = \"{}\", role = \"{}\", password = \"{SCHEME}${}${}${}\"{trusted} }},\n",
            a.name.as_str(),
            a.role.as_str(),
            a.hash.iterations,
            hex(&a.hash.salt),
            hex(&a.hash.hash)
        ));
    }
    out.push_str("]\n");
}

/// A key's value as written in the file.
fn value_text(s: &Setting, v: &Value) -> String {
    match v {
        Value::Number(n) => n.to_string(),
        Value::Flag(b) => b.to_string(),
        Value::Choice(_) | Value::Host(_) => {
            let mut t = String::new();
            let _ = s.kind.format(v, &mut t);
            toml_string(&t)
        }
        Value::Address(ip) => format!("\"{ip}\""),
        Value::AllowList(l) => {
            let used: Vec<String> =
                l.0.iter()
                    .filter(|e| e.prefix != 0)
                    .map(|e| format!("\"{}/{}\"", e.ip, e.prefix))
                    .collect();
            format!("[{}]", used.join(", "))
        }
    }
}
