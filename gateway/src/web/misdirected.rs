//! The answer to a request whose `Host` is not a name of this device
//! (421, [`super::own_host`]: against DNS rebinding). A script gets the
//! JSON refusal every other refusal is; a browser (it asks for
//! `text/html`) gets a small page that says why nothing is shown and
//! which address to open instead. In front of the QEMU demo, whose device
//! sees forwarded connections come from QEMU's network rather than the
//! loopback, `http://localhost:8080/` is refused and the page links
//! `http://127.0.0.1:8080/`.
//!
//! The page is static text and two short values (the name asked for and
//! the address to use), each checked to be made of host-name characters
//! before it is written into it: nothing a request sends reaches the
//! page as markup. It is written piece by piece, without a buffer.

use core::fmt::Write;
use core::net::Ipv4Addr;

use picoserve::response::Content;

/// The refused name as the page shows it (`localhost:8080`).
type Name = heapless::String<72>;
/// The address to open instead (`http://127.0.0.1:8080/`).
type Url = heapless::String<40>;

/// The page for a browser (a body for [`super::Reply::Misdirected`]).
pub(crate) struct Page {
    /// The name asked for, with its port; empty if it was not made of
    /// host-name characters (then the page says "that name").
    name: Name,
    /// The address to open instead (`http://127.0.0.1:8080/`), or where
    /// the device does not know its own, the form of one
    /// (`http://ADDRESS:8080/`).
    to: Url,
    /// `to` is an address to follow (a link), not a form.
    known: bool,
    /// The name was `localhost`: no advice to configure a name.
    local: bool,
}

/// `true` if the request asks for HTML (a browser's navigation sends
/// `Accept: text/html,…`; `fetch` and scripts send `*/*` or JSON).
pub(crate) fn wants_html(accept: Option<&[u8]>) -> bool {
    accept.is_some_and(|a| a.windows(9).any(|w| w.eq_ignore_ascii_case(b"text/html")))
}

/// Host-name characters (and the port's colon, IPv6 brackets): what may be
/// written into the page.
fn plain(b: u8) -> bool {
    b.is_ascii_alphanumeric() || matches!(b, b'.' | b'-' | b'_' | b':' | b'[' | b']')
}

impl Page {
    /// The page for a request that asked for `host` (the `Host` header,
    /// refused), served over TLS if `secure`; `address` is the device's
    /// own address where it knows it (a board with a static address).
    pub(crate) fn new(host: &[u8], secure: bool, address: Option<Ipv4Addr>) -> Page {
        let mut name = Name::new();
        if host.iter().all(|&b| plain(b)) {
            if let Ok(text) = core::str::from_utf8(host) {
                let _ = name.push_str(text);
            }
        }
        // `name:port` (not `[::1]`): the port the browser used, which is
        // the one to use again (a forwarded port is not the device's own).
        let (bare, port) = match host.iter().rposition(|&b| b == b':') {
            Some(i) if !host.ends_with(b"]") => (
                host.get(..i).unwrap_or(&[]),
                core::str::from_utf8(host.get(i + 1..).unwrap_or(&[]))
                    .ok()
                    .and_then(|p| p.parse::<u16>().ok()),
            ),
            _ => (host, None),
        };
        // `localhost` (and a name under it, RFC 6761) is the browser's own
        // machine: the loopback address reaches the same place (a
        // forwarded port, a tunnel).
        let ends_with = |b: &[u8], end: &[u8]| {
            b.len() >= end.len()
                && b.get(b.len() - end.len()..)
                    .is_some_and(|t| t.eq_ignore_ascii_case(end))
        };
        let local = bare.eq_ignore_ascii_case(b"localhost")
            || ends_with(bare, b".localhost")
            || bare == b"[::1]";
        let to = if local {
            Some(Ipv4Addr::LOCALHOST)
        } else {
            address
        };
        let scheme = if secure { "https" } else { "http" };
        let mut url = Url::new();
        let _ = match to {
            Some(ip) => write!(url, "{scheme}://{ip}"),
            None => write!(url, "{scheme}://ADDRESS"),
        };
        let _ = match port {
            Some(p) => write!(url, ":{p}/"),
            None => url.push_str("/").map_err(|_| core::fmt::Error),
        };
        Page {
            name,
            to: url,
            known: to.is_some(),
            local,
        }
    }

    /// The page's pieces, in order.
    fn pieces(&self) -> heapless::Vec<&str, 10> {
        let mut p = heapless::Vec::new();
        let name = match self.name.as_str() {
            "" => "that name",
            n => n,
        };
        let to = self.to.as_str();
        let parts: &[&str] = if self.known {
            &["<p>Open <a href=\"", to, "\">", to, "</a> instead.</p>"]
        } else {
            &[
                "<p>Open it by its IP address instead: <code>",
                to,
                "</code> (the address its network settings or the network's DHCP server gave it).</p>",
            ]
        };
        // Ten places: at most 3 + 5 + 2 are used.
        for piece in [HEAD, name, WHY].iter().chain(parts) {
            let _ = p.push(*piece);
        }
        if !self.local {
            let _ = p.push(ADVICE);
        }
        let _ = p.push("</body></html>");
        p
    }
}

impl Content for Page {
    fn content_type(&self) -> &'static str {
        "text/html; charset=utf-8"
    }

    fn content_length(&self) -> usize {
        self.pieces().iter().map(|p| p.len()).sum()
    }

    async fn write_content<W: picoserve::io::Write>(self, mut writer: W) -> Result<(), W::Error> {
        for piece in self.pieces() {
            writer.write_all(piece.as_bytes()).await?;
        }
        Ok(())
    }
}

const HEAD: &str = "<!doctype html><html lang=\"en\"><head><meta charset=\"utf-8\">\
<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\
<title>hans-gateway: open it by its address</title><style>\
body{font:16px/1.5 system-ui,sans-serif;max-width:42em;margin:2em auto;padding:0 1em;color:#1b1b1b}\
a{color:#0a58a8;font-weight:600}code{background:#eef1f5;padding:0 .25em}</style></head><body>\
<h1>Open this gateway by its address</h1><p>This gateway does not answer to the name <code>";

const WHY: &str = "</code>: a page reached through a name the gateway does not know could \
belong to another site that made its name point here (DNS rebinding), so it shows nothing \
there.</p>";

const ADVICE: &str = "<p>To open it by a name, an administrator enters that name in the \
setting <code>web.host_name</code> (Configuration: Page's DNS name).</p>";

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::string::String;

    fn text(p: &Page) -> String {
        let t: String = p.pieces().concat();
        assert_eq!(t.len(), p.content_length());
        t
    }

    #[test]
    fn localhost_is_sent_to_the_loopback_address_with_its_port() {
        let t = text(&Page::new(b"localhost:8080", false, None));
        assert!(t.contains("the name <code>localhost:8080</code>"), "{t}");
        assert!(
            t.contains("<a href=\"http://127.0.0.1:8080/\">http://127.0.0.1:8080/</a>"),
            "{t}"
        );
        assert!(!t.contains("web.host_name"), "{t}");
        let t = text(&Page::new(b"LOCALHOST", true, None));
        assert!(t.contains("href=\"https://127.0.0.1/\""), "{t}");
        let t = text(&Page::new(b"gw.localhost:81", false, None));
        assert!(t.contains("href=\"http://127.0.0.1:81/\""), "{t}");
    }

    #[test]
    fn another_name_gets_the_device_address_where_it_is_known() {
        let addr = Some(Ipv4Addr::new(192, 168, 1, 50));
        let t = text(&Page::new(b"gw.plant.local", false, addr));
        assert!(t.contains("href=\"http://192.168.1.50/\""), "{t}");
        assert!(t.contains("web.host_name"), "{t}");
        let t = text(&Page::new(b"gw.plant.local:81", false, None));
        assert!(t.contains("<code>http://ADDRESS:81/</code>"), "{t}");
        assert!(!t.contains("<a "), "{t}");
    }

    #[test]
    fn nothing_but_host_name_characters_reaches_the_page() {
        let t = text(&Page::new(b"<script>x</script>", false, None));
        assert!(!t.contains("<script>"), "{t}");
        assert!(t.contains("the name <code>that name</code>"), "{t}");
        let t = text(&Page::new(b"a\"onmouseover=x", false, None));
        assert!(!t.contains("onmouseover"), "{t}");
    }

    #[test]
    fn a_browser_asks_for_html_and_a_script_does_not() {
        assert!(wants_html(Some(
            b"text/html,application/xhtml+xml,*/*;q=0.8"
        )));
        assert!(wants_html(Some(b"TEXT/HTML")));
        assert!(!wants_html(Some(b"*/*")));
        assert!(!wants_html(Some(b"application/json")));
        assert!(!wants_html(None));
    }
}
