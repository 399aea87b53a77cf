//! Writing the file: every key with a comment naming its register and
//! what it takes, the password's hash, the trigger entries.

extern crate std;

use std::borrow::ToOwned;
use std::format;
use std::string::{String, ToString};
use std::vec::Vec;

use super::{field_of_key, takes, Contents, Form, Key, KEYS, PASSWORD, SCHEME};
use crate::config::{ipv4, Field, Words, CONFIG_WORDS};
use crate::state::inputs::{TRIGGERS, TRIGGER_TEXT};

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
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
    let words: Words = contents.stored.config.to_words();
    let mut out = String::from(HEADER);
    let mut table = "";
    for k in &KEYS {
        let Some(f) = field_of_key(k) else { continue };
        if k.table != table {
            table = k.table;
            out.push_str(&format!("\n[{table}]\n"));
        }
        let register = match k.form {
            Form::Bit(b) => format!("{} bit {b}", f.name),
            _ => f.name.to_owned(),
        };
        let about = match k.form {
            Form::AllowList => String::from("clients allowed"),
            _ => f.help.to_owned(),
        };
        out.push_str(&format!("# {register}: {about}; takes {}\n", takes(k, f)));
        out.push_str(&format!("{} = {}\n", k.key, value_text(k, f, &words)));
    }
    // `[access]` is the last table of KEYS: the password goes in it.
    out.push_str(&format!(
        "# The web password as a salted hash, never the password itself: \"{SCHEME}$ROUNDS$SALT$HASH\"\n\
         # (PBKDF2-HMAC-SHA256; salt and hash in hex). Set it on the web page; without it the page\n\
         # asks for one before any change.\n"
    ));
    match &contents.stored.password {
        Some(h) => out.push_str(&format!(
            "{PASSWORD} = \"{SCHEME}${}${}${}\"\n",
            h.iterations,
            hex(&h.salt),
            hex(&h.hash)
        )),
        None => out.push_str(&format!("# {PASSWORD} = (none set)\n")),
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

/// A key's value as written in the file.
fn value_text(k: &Key, f: &Field, words: &Words) -> String {
    let s = usize::from(f.slot);
    let regs = words
        .get(s..(s + usize::from(f.len)).min(CONFIG_WORDS))
        .unwrap_or(&[]);
    let w = regs.first().copied().unwrap_or(0);
    match k.form {
        Form::Number => w.to_string(),
        Form::Flag => (w != 0).to_string(),
        Form::Bit(b) => (w >> b & 1 != 0).to_string(),
        Form::Word(names) => match names.get(usize::from(w)) {
            Some(name) => format!("\"{name}\""),
            None => w.to_string(),
        },
        Form::Address => format!("\"{}\"", ipv4(regs)),
        Form::AllowList => {
            let used: Vec<String> = regs
                .chunks(3)
                .filter(|e| e.get(2).copied().unwrap_or(0) != 0)
                .map(|e| format!("\"{}/{}\"", ipv4(e), e.get(2).copied().unwrap_or(0)))
                .collect();
            format!("[{}]", used.join(", "))
        }
    }
}
