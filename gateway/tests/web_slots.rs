//! The web server's connections under attack (issue 16, classes 4 and 5),
//! in virtual time: a request must be whole within 2 s of its first byte,
//! an idle keep-alive connection gives its slot to a newcomer, one address
//! gets at most 2 of the 3 slots, a connection serves at most 100 requests,
//! and applying an allow-list closes the connections it no longer permits
//! before they are served again.

use core::net::Ipv4Addr;

use embassy_time::{Duration, Instant};
use hans_gateway::registers as r;
use hans_gateway::testkit::net::SimStream;
use hans_gateway::testkit::world::{http_complete, World, WorldConfig};

/// `web::REQUEST_DEADLINE`.
const REQUEST_DEADLINE: Duration = Duration::from_secs(2);
/// `web::EVICT_IDLE`.
const EVICT_IDLE: Duration = Duration::from_secs(1);
/// `web::CLAIM_WAIT`.
const CLAIM_WAIT: Duration = Duration::from_secs(6);
/// `web::MAX_REQUESTS`.
const MAX_REQUESTS: usize = 100;

fn ms(v: u64) -> Duration {
    Duration::from_millis(v)
}

fn ip(last: u8) -> Ipv4Addr {
    Ipv4Addr::new(10, 0, 0, last)
}

/// A world serving the page (and one PLC, 10.0.0.10), its first status
/// round done.
fn world() -> World {
    let mut w = World::new(WorldConfig {
        web: true,
        ..WorldConfig::default()
    });
    w.run_for(ms(300));
    w
}

/// A keep-alive request (no `Connection` header: HTTP/1.1 keeps it open).
fn get(path: &str) -> Vec<u8> {
    format!("GET {path} HTTP/1.1\r\nHost: 10.0.0.1\r\n\r\n").into_bytes()
}

/// An answer: its status and its head.
#[derive(Debug)]
struct Answer {
    status: u16,
    head: String,
}

/// A web client on one connection.
struct Client {
    s: SimStream,
    got: Vec<u8>,
}

impl Client {
    fn connect(w: &mut World, from: Ipv4Addr) -> Client {
        let s = w.web_connect(from).expect("the web port is served");
        Client { s, got: Vec::new() }
    }

    fn open(&self) -> bool {
        self.s.is_open()
    }

    /// The answer received so far, if whole (taken).
    fn answer(&mut self) -> Option<Answer> {
        self.got.extend(self.s.read());
        if !http_complete(&self.got) {
            return None;
        }
        let end = self.got.windows(4).position(|x| x == b"\r\n\r\n")? + 4;
        let head = String::from_utf8_lossy(&self.got[..end]).to_string();
        let status = head.split(' ').nth(1)?.parse().ok()?;
        let len = head
            .to_ascii_lowercase()
            .lines()
            .find_map(|l| {
                l.strip_prefix("content-length:")
                    .map(|v| v.trim().to_string())
            })
            .and_then(|v| v.parse::<usize>().ok())
            .unwrap_or(0);
        self.got.drain(..(end + len).min(self.got.len()));
        Some(Answer { status, head })
    }

    /// Sends `request` and runs the world until the answer is whole, at
    /// most `limit`: the answer and when it came.
    fn ask(&mut self, w: &mut World, request: &[u8], limit: Duration) -> Option<(Answer, Instant)> {
        self.s.write(request);
        let end = w.now() + limit;
        loop {
            w.catch_up();
            if let Some(a) = self.answer() {
                return Some((a, w.now()));
            }
            if w.now() >= end || !self.open() {
                return None;
            }
            w.run_for(ms(10));
        }
    }

    /// As [`Self::ask`], for a status of 200 within 100 ms.
    fn ok(&mut self, w: &mut World, path: &str) -> bool {
        matches!(self.ask(w, &get(path), ms(100)), Some((a, _)) if a.status == 200)
    }
}

/// What a slow client sends, one byte at a time: a request whose headers
/// never end.
fn trickle(at: usize) -> u8 {
    let start = b"GET /api/status HTTP/1.1\r\nHost: 10.0.0.1\r\nX-Pad: ";
    start.get(at).copied().unwrap_or(b'a')
}

/// A slow client: its connection, the next byte to send, when its first
/// connection's first byte went out.
struct Slow {
    from: Ipv4Addr,
    c: Option<Client>,
    at: usize,
    first: Option<Instant>,
}

impl Slow {
    /// One more byte if its connection is open; else it connects again
    /// and sends its first byte. When its first connection (served at
    /// once) closes, how long it lasted from its first byte goes to
    /// `held`. (Later ones may wait for a slot with their bytes unread.)
    fn step(&mut self, w: &mut World, held: &mut Vec<Duration>) {
        match &mut self.c {
            Some(c) if c.open() => {
                c.s.write(&[trickle(self.at)]);
                self.at += 1;
            }
            _ => {
                if self.c.take().is_some() {
                    if let Some(first) = self.first.take() {
                        held.push(w.now() - first);
                    }
                }
                let mut c = Client::connect(w, self.from);
                c.s.write(&[trickle(0)]);
                if self.at == 0 {
                    self.first = Some(w.now());
                }
                self.c = Some(c);
                self.at = 1;
            }
        }
        w.settle();
    }
}

#[test]
fn a_byte_a_second_on_every_slot_keeps_a_client_out_no_longer_than_the_request_deadline() {
    let mut w = world();
    // Three clients from three addresses each send a request a byte a
    // second (each byte well within the idle time, the request never
    // whole); whichever is closed connects again at once and starts over.
    let mut slow: Vec<Slow> = (60..63)
        .map(|k| Slow {
            from: ip(k),
            c: None,
            at: 0,
            first: None,
        })
        .collect();
    let mut held = Vec::new();
    for s in slow.iter_mut() {
        s.step(&mut w, &mut held);
    }
    w.run_for(ms(300));
    assert!(slow.iter().all(|s| s.c.as_ref().is_some_and(Client::open)));

    // A browser comes and asks for the status.
    let mut page = Client::connect(&mut w, ip(50));
    let came = w.now();
    page.s.write(&get("/api/status"));
    let mut served = None;
    for step in 0..100 {
        w.run_for(ms(100));
        if let Some(a) = page.answer() {
            served = Some((a, w.now()));
            break;
        }
        for s in slow.iter_mut() {
            let closed = !s.c.as_ref().is_some_and(Client::open);
            if step % 10 == 6 || closed {
                s.step(&mut w, &mut held);
            }
        }
    }
    let (answer, at) = served.expect("the browser is served while the trickle goes on");
    assert_eq!(answer.status, 200);
    assert!(
        at - came <= REQUEST_DEADLINE,
        "served {} ms after it came, not within the request deadline",
        (at - came).as_millis()
    );
    // It stays served, polling every half second, while the trickle goes
    // on; and no slow request holds its slot longer than the deadline.
    for _ in 0..10 {
        for _ in 0..5 {
            w.run_for(ms(100));
            for s in slow.iter_mut() {
                if !s.c.as_ref().is_some_and(Client::open) || s.at % 3 == 0 {
                    s.step(&mut w, &mut held);
                }
            }
        }
        assert!(
            page.ok(&mut w, "/api/status"),
            "the browser is still served"
        );
    }
    assert_eq!(held.len(), slow.len());
    for d in &held {
        assert!(
            *d <= REQUEST_DEADLINE + ms(150),
            "a slow request held its slot {} ms",
            d.as_millis()
        );
    }
}

#[test]
fn a_newcomer_takes_the_slot_of_the_longest_idle_keep_alive_connection() {
    let mut w = world();
    // Three browsers on kept-alive connections; their last requests: 2,
    // then 0, then 1, 300 ms apart.
    let mut c: Vec<Client> = (50..53).map(|k| Client::connect(&mut w, ip(k))).collect();
    for i in [2, 0, 1] {
        assert!(c[i].ok(&mut w, "/api/status"));
        w.run_for(ms(300));
    }
    w.run_for(EVICT_IDLE);
    assert!(c.iter().all(Client::open));
    let mut newcomer = Client::connect(&mut w, ip(53));
    assert!(
        newcomer.ok(&mut w, "/api/status"),
        "the newcomer is served at once"
    );
    let open: Vec<bool> = c.iter().map(Client::open).collect();
    assert_eq!(open, [true, true, false], "browser 2, idle longest, went");

    // None idle: all three ask now; a newcomer waits until the first has
    // been idle for EVICT_IDLE, no longer.
    c.truncate(2);
    c.push(newcomer);
    for x in c.iter_mut() {
        assert!(x.ok(&mut w, "/api/status"));
    }
    let asked = w.now();
    let mut late = Client::connect(&mut w, ip(54));
    let got = late.ask(&mut w, &get("/api/status"), EVICT_IDLE + ms(500));
    let (a, at) = got.expect("the newcomer is served once a connection is idle");
    assert_eq!(a.status, 200);
    assert!(
        at - asked <= EVICT_IDLE + ms(50),
        "{} ms",
        (at - asked).as_millis()
    );
    assert_eq!(c.iter().filter(|x| x.open()).count(), 2);

    // Three browsers that keep polling are never idle: a newcomer is
    // turned away (closed, no answer) within CLAIM_WAIT, and they are
    // served throughout.
    let mut c: Vec<Client> = c.into_iter().filter(Client::open).collect();
    c.push(late);
    for x in c.iter_mut() {
        assert!(x.ok(&mut w, "/api/status"));
    }
    let mut last = Client::connect(&mut w, ip(55));
    last.s.write(&get("/api/status"));
    let came = w.now();
    let mut gone = None;
    for _ in 0..(CLAIM_WAIT.as_millis() / 250 + 8) {
        for x in c.iter_mut() {
            assert!(x.ok(&mut w, "/api/status"), "a polling browser is served");
        }
        w.run_for(ms(200));
        if !last.open() && gone.is_none() {
            gone = Some(w.now());
        }
    }
    let gone = gone.expect("the newcomer is turned away");
    assert!(
        gone - came <= CLAIM_WAIT + ms(300),
        "{} ms",
        (gone - came).as_millis()
    );
    assert!(last.answer().is_none(), "and not served");
}

#[test]
fn one_address_gets_at_most_two_connections() {
    let mut w = world();
    // 10.0.0.66 opens four connections, each asking at once: the newest
    // connection of an address wins, its least recently active one goes.
    let mut from_66: Vec<Client> = Vec::new();
    for _ in 0..4 {
        let mut c = Client::connect(&mut w, ip(66));
        assert!(c.ok(&mut w, "/api/status"), "each is served");
        from_66.push(c);
    }
    let open: Vec<bool> = from_66.iter().map(Client::open).collect();
    assert_eq!(open, [false, false, true, true]);

    // Its two in the middle of a request (a byte a second, say): a third
    // from 66 waits, a fourth is closed at once, and another address is
    // served at once meanwhile.
    for c in from_66.iter_mut().skip(2) {
        c.s.write(b"GET /api/status HTTP/1.1\r\n");
    }
    let started = w.now();
    w.run_for(ms(10));
    let mut third = Client::connect(&mut w, ip(66));
    third.s.write(&get("/api/status"));
    w.run_for(ms(50));
    let fourth = Client::connect(&mut w, ip(66));
    w.run_for(ms(50));
    assert!(!fourth.open(), "a fourth is closed at once");
    let mut other = Client::connect(&mut w, ip(50));
    assert!(
        other.ok(&mut w, "/api/status"),
        "another address is served at once"
    );
    assert!(third.open() && third.answer().is_none(), "the third waits");
    // Once its two are closed (their requests not whole by the deadline),
    // the third is served.
    let mut served = None;
    while served.is_none() && w.now() - started < REQUEST_DEADLINE + ms(500) {
        w.run_for(ms(10));
        served = third.answer().map(|a| (a, w.now()));
    }
    let (a, at) = served.expect("the third is served");
    assert_eq!(a.status, 200);
    assert!(
        at - started <= REQUEST_DEADLINE + ms(50),
        "{} ms",
        (at - started).as_millis()
    );
    assert!(!from_66[2].open() && !from_66[3].open());
    assert!(other.ok(&mut w, "/api/status"));
}

#[test]
fn applying_an_allow_list_closes_the_connections_it_no_longer_permits() {
    let mut w = world();
    let mut pc = Client::connect(&mut w, ip(50));
    let mut other = Client::connect(&mut w, ip(51));
    assert!(pc.ok(&mut w, "/api/status") && other.ok(&mut w, "/api/status"));
    // The PLC allows only 10.0.0.50 on the page, and applies.
    w.add_admin(); // a commissioned device
    w.allow_modbus_config(); // whose access settings may change over Modbus
    w.set(r::WEB_ALLOW, &[0x0A00, 50, 32]);
    w.set(r::CONTROL_CONFIG_COMMAND, &[1]);
    w.run_for(ms(10));
    assert!(!other.open(), "10.0.0.51 is closed after the apply");
    assert!(pc.open());
    // What it sends on its connection is not answered, nor on a new one.
    assert!(other.ask(&mut w, &get("/api/status"), ms(500)).is_none());
    let mut again = Client::connect(&mut w, ip(51));
    assert!(again.ask(&mut w, &get("/api/status"), ms(500)).is_none());
    assert!(!again.open());
    assert!(pc.ok(&mut w, "/api/status"), "10.0.0.50 is served on");
}

#[test]
fn a_connection_serves_at_most_a_hundred_requests() {
    let mut w = world();
    let mut c = Client::connect(&mut w, ip(50));
    for n in 1..=MAX_REQUESTS {
        let (a, _) = c
            .ask(&mut w, &get("/api/session"), ms(100))
            .unwrap_or_else(|| panic!("request {n} is answered"));
        assert_eq!(a.status, 200);
        let close = a.head.to_ascii_lowercase().contains("connection: close");
        assert_eq!(close, n == MAX_REQUESTS, "request {n}: {}", a.head);
    }
    w.run_for(ms(10));
    assert!(!c.open(), "closed after the last answer");
}
