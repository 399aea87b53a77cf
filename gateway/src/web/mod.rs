//! The web page and its JSON API, served by the gateway itself: a second
//! view of the typed state (the registers are the first).
//!
//! The HTTP server is [picoserve](https://crates.io/crates/picoserve)
//! (chosen over edge-http): it parses requests into a bounded buffer,
//! handles keep-alive and timeouts, writes chunked responses, takes the
//! timer as a trait (so the server runs on the gateway's [`Clock`], in
//! virtual time in tests) and needs no heap; edge-http takes its timeouts
//! from embassy-time directly and its sockets from edge-nal, a second
//! socket abstraction beside the gateway's. picoserve runs here on the
//! gateway's own [`Socket`] ([`io`]), so the page is the same code on
//! Linux (tokio) and on boards (embassy-net). Routing is one match in
//! `App` rather than picoserve's typed router: each route is one line
//! to read, and a fuzz target drives the whole request path.
//!
//! * [`WEB_SLOTS`] requests served at once, each slot with an
//!   [`HTTP_BUF`]-byte request buffer: a request (line, headers and body)
//!   longer than that gets 413 (body) or 400 and the connection closes.
//!   [`WEB_CONNECTIONS`] sockets: the one more accepts a newcomer while
//!   every slot is taken ([`Slots`]).
//! * Limits (see "Connections" below): a request whole within
//!   [`REQUEST_DEADLINE`] of its first byte, its answer written within
//!   [`ANSWER_DEADLINE`], [`IDLE_TIMEOUT`] between requests,
//!   [`MAX_REQUESTS`] on one connection, [`PER_ADDRESS`] slots for one
//!   address, and an idle connection gives its slot to a newcomer.
//! * The page is one static, gzip-compressed file in flash ([`assets`]);
//!   the answers of the API are JSON ([`api`], `gateway/WEB.md`).
//! * Access: `WEB_ALLOW` is checked when a client connects (refused:
//!   closed at once, counted), before each request, and when a
//!   configuration is applied (the connections it no longer permits are
//!   closed); every change needs a session opened with the password
//!   ([`crate::access`]).
//! * Before a route is looked at: the body's framing (no
//!   `Transfer-Encoding`, one `Content-Length`; else the answer closes
//!   the connection), a `Host` naming the device ([`own_host`], against
//!   DNS rebinding), and for a change the page's `Origin` and a JSON
//!   content type. Every answer forbids framing; `HEAD` has no body.
//!
//! # Connections
//!
//! Three keep-alive browsers, or three slow clients, must not take the
//! page away (issue 16, classes 4 and 5); the rules are those of every
//! listener (`crate::admission`, as for the Modbus sessions), with HTTP's
//! times and sizes:
//! * A request (line, headers and body) must be whole within
//!   [`REQUEST_DEADLINE`] of its first byte, and its answer written within
//!   [`ANSWER_DEADLINE`] of its first write, else the connection is closed:
//!   a client sending a byte a second, or reading its answer as slowly,
//!   holds a slot no longer than that.
//! * Between requests a connection is closed after [`IDLE_TIMEOUT`]
//!   (also before its first request); after [`MAX_REQUESTS`] answers it
//!   is closed (the last says `Connection: close`).
//! * A connection not in the middle of a request for [`EVICT_IDLE`] is
//!   idle: when every slot is taken, a newcomer the allow-list admits
//!   takes the slot of the longest-idle one, which is closed. With none
//!   idle it waits, at most [`CLAIM_WAIT`] (by then every connection that
//!   is not serving requests back to back was idle or closed), else it is
//!   closed unanswered.
//! * At most [`PER_ADDRESS`] slots per address: a newcomer whose address
//!   has them takes the slot of its own least recently active connection
//!   not in the middle of a request; if all are, it waits for the first to
//!   finish (within [`CLAIM_WAIT`]), unless another newcomer of its
//!   address waits already: then it is closed at once ([`LIMITS`]). A
//!   newcomer waiting for its own address's connections holds up no other
//!   client.
//! * The allow-list is checked at accept, before every request, and when a
//!   configuration is applied (the engine's `Hub::config_applied`): the
//!   connections it no longer permits are closed before anything more of
//!   theirs is read (an answer being written is finished).

pub(crate) mod api;
pub(crate) mod assets;
pub(crate) mod audit;
#[cfg(feature = "update")]
pub(crate) mod firmware;
pub(crate) mod grammar;
pub(crate) mod io;
pub(crate) mod json;
pub(crate) mod misdirected;
pub(crate) mod post;
pub(crate) mod routes;

use core::cell::{Cell, RefCell};
use core::convert::Infallible;
use core::net::SocketAddrV4;
use core::pin::pin;

use embassy_futures::join::{join5, join_array};
use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::channel::Channel;
use embassy_sync::signal::Signal;
use embassy_time::Duration;
use picoserve::io::Read;
use picoserve::request::{Path, Request, RequestParts};
use picoserve::response::{
    Body, Content, HeadersIter, IntoResponse, Response, ResponseWriter, StatusCode,
};
use picoserve::routing::PathRouterService;
use picoserve::{ResponseSent, Router};

use crate::access::accounts::{Role, UserName};
use crate::access::limit::Limiter;
use crate::access::session::{Sessions, Token, Who};
use crate::access::setup::SetupCode;
use crate::admission::{self, octets, Close, Limits, Refusal, Session};
use crate::audit::{Event, Who as AuditWho};
use crate::clock::Clock;
use crate::hub::Hub;
use crate::net::{Net, Socket};
use api::{Doc, Snapshot};
use io::{ClockTimer, Conn, Exchange};
use json::Json;
use routes::Route;

/// Longest an answer waits for the records its request made to be kept on
/// the medium (a flash erase takes well under a second; a medium that
/// hangs longer gets the answer sent anyway).
const KEPT_WAIT: embassy_time::Duration = embassy_time::Duration::from_secs(5);
/// Requests served at once: slots, each with an [`HTTP_BUF`] and a
/// request handler.
pub(crate) const WEB_SLOTS: usize = 3;
/// Sockets of the web server (connections open at once; what a board's
/// stack reserves for the page): one more than [`WEB_SLOTS`], so that one
/// always accepts a newcomer, which may then take an idle connection's
/// slot. The one more costs its socket buffers ([`WEB_RX`] + [`WEB_TX`]),
/// not a slot.
pub(crate) const WEB_CONNECTIONS: usize = WEB_SLOTS + 1;
/// Slots one address may hold: one fewer than all, so that one address
/// (a scanner, a flood) always leaves a slot for another; a browser uses
/// one or two.
pub(crate) const PER_ADDRESS: usize = WEB_SLOTS - 1;
/// A request (line, headers and body) must be whole this long after its
/// first byte. The longest request ([`HTTP_BUF`], 6 KiB) is four or five
/// segments: well within this on any link a browser uses, a lost segment
/// included (sent again within a second).
pub(crate) const REQUEST_DEADLINE: Duration = crate::limits::WEB_REQUEST_DEADLINE;
/// An answer must be written this long after its first write (the page,
/// ~12 KiB, needs ~32 kbit/s); a client reading more slowly is closed.
pub(crate) const ANSWER_DEADLINE: Duration = Duration::from_secs(3);
/// A connection with no request for this long is closed (from when it is
/// given its slot for the first request, else from the last answer). The
/// page polls every 0.5 s, so it keeps its connection.
pub(crate) const IDLE_TIMEOUT: Duration = Duration::from_secs(3);
/// A connection not in the middle of a request for this long is idle: a
/// newcomer may take its slot. Twice the page's poll period, so that a
/// polling page is never taken for idle.
pub(crate) const EVICT_IDLE: Duration = Duration::from_secs(1);
/// The longest a newcomer waits for a slot: by then a connection that was
/// in the middle of a request has finished it (or was closed) and, unless
/// it sent another, has been idle for [`EVICT_IDLE`].
pub(crate) const CLAIM_WAIT: Duration = Duration::from_millis(
    EVICT_IDLE.as_millis() + REQUEST_DEADLINE.as_millis() + ANSWER_DEADLINE.as_millis(),
);
/// The connections' times. A newcomer whose address has its
/// [`PER_ADDRESS`] connections, all in the middle of a request, waits for
/// the first to finish (a browser opens another while its others are
/// busy), unless another newcomer of its address waits already.
pub(crate) const LIMITS: Limits = Limits {
    evict_idle: EVICT_IDLE,
    claim_wait: CLAIM_WAIT,
    waiting_per_address: 1,
};
/// The server's name in log lines.
pub(crate) const NAME: &str = "web";
/// Who the web server serves: its connections' table
/// ([`crate::admission`]).
pub(crate) type Slots = admission::Slots<WEB_CONNECTIONS, WEB_SLOTS, PER_ADDRESS>;
/// Requests served on one connection: the last answer says
/// `Connection: close` and the connection closes, so that no client keeps
/// a slot (and its place among the idle) for ever.
pub(crate) const MAX_REQUESTS: u32 = 100;
/// Bytes of a request: line, headers and body (a configuration import of
/// every setting and sixteen full trigger entries takes ~4.5 KiB).
pub(crate) const HTTP_BUF: usize = 6144;
/// Socket receive buffer of a web connection.
pub(crate) const WEB_RX: usize = 1024;
/// Socket send buffer of a web connection.
pub(crate) const WEB_TX: usize = 2048;
/// Bytes of the window a JSON document is sent through (see [`api`]).
pub(crate) const WINDOW: usize = 1024;
/// Name of the session cookie.
pub(crate) const COOKIE: &str = "hgw_session";

/// picoserve's duration of `d`.
const fn pico(d: Duration) -> picoserve::time::Duration {
    picoserve::time::Duration::from_millis(d.as_millis())
}

/// picoserve's timeouts: to the first byte of a request ([`IDLE_TIMEOUT`]),
/// from it to the end of its body ([`REQUEST_DEADLINE`]), and per write
/// (the whole answer is bounded by [`ANSWER_DEADLINE`] in [`io`]).
static CONFIG: picoserve::Config = picoserve::Config {
    timeouts: picoserve::Timeouts {
        start_read_request: pico(IDLE_TIMEOUT),
        persistent_start_read_request: pico(IDLE_TIMEOUT),
        read_request: pico(REQUEST_DEADLINE),
        write: pico(ANSWER_DEADLINE),
    },
    connection: picoserve::KeepAlive::KeepAlive,
};

/// What the web server keeps besides the gateway's state: the sessions,
/// the rate limit of guesses, the setup code and how to restart the
/// device.
pub(crate) struct Web {
    sessions: RefCell<Sessions>,
    limiter: RefCell<Limiter>,
    setup_code: Option<SetupCode>,
    restart: Option<fn()>,
}

impl Web {
    /// A web server whose tokens and salts come from `seed`, whose first
    /// administrator is created with `setup_code`, and which offers a
    /// restart if the platform gives one (boards).
    pub(crate) fn new(
        seed: [u8; 32],
        setup_code: Option<SetupCode>,
        restart: Option<fn()>,
    ) -> Self {
        Web {
            sessions: RefCell::new(Sessions::new(seed)),
            limiter: RefCell::new(Limiter::new()),
            setup_code,
            restart,
        }
    }
}

/// Serves the web page on `port` with [`WEB_CONNECTIONS`] sockets of
/// `net` and [`WEB_SLOTS`] slots, until the future is dropped.
pub(crate) async fn run<N: Net, C: Clock>(
    hub: &Hub,
    clock: &C,
    web: &Web,
    net: &N,
    port: u16,
) -> Infallible {
    let mut bufs = [const { SocketBufs::new() }; WEB_CONNECTIONS];
    let mut http = [const { [0u8; HTTP_BUF] }; WEB_SLOTS];
    let conns = Conns {
        socks: bufs
            .each_mut()
            .map(|b| RefCell::new(net.socket(&mut b.rx, &mut b.tx))),
        slots: Slots::new(NAME, &LIMITS),
        admitted: Channel::new(),
        done: [const { Signal::new() }; WEB_CONNECTIONS],
    };
    let accepts: [_; WEB_CONNECTIONS] =
        core::array::from_fn(|j| accept(hub, clock, &conns, port, j));
    // Each slot's future (~14 KiB) is built where it stays, in this
    // future: an array of them built by `map` went through the stack first
    // (54 KiB of the field device's stack). Hence one line per slot. The
    // accepting futures are small.
    const _: () = assert!(WEB_SLOTS == 3, "one line per slot below");
    let [h0, h1, h2] = http.each_mut();
    let s0 = pin!(slot(hub, clock, web, &conns, 0, h0));
    let s1 = pin!(slot(hub, clock, web, &conns, 1, h1));
    let s2 = pin!(slot(hub, clock, web, &conns, 2, h2));
    let accepts = pin!(join_array(accepts));
    let warden = pin!(warden(hub, &conns.slots));
    let _ = join5(s0, s1, s2, accepts, warden).await;
    core::future::pending().await
}

/// What the server's futures share: its sockets, who is served
/// ([`Slots`]), and how an admitted connection reaches a slot's future.
struct Conns<S> {
    socks: [RefCell<S>; WEB_CONNECTIONS],
    slots: Slots,
    /// Admitted connections (socket, peer) on their way from their
    /// socket's accepting future to a free slot's. At most [`WEB_SLOTS`]
    /// are admitted at once: it is never full.
    admitted: Channel<NoopRawMutex, (usize, Option<SocketAddrV4>), WEB_SLOTS>,
    /// Per socket: its slot's future is done with it (closed, released).
    done: [Signal<NoopRawMutex, ()>; WEB_CONNECTIONS],
}

/// The socket buffers of one web connection.
struct SocketBufs {
    rx: [u8; WEB_RX],
    tx: [u8; WEB_TX],
}

impl SocketBufs {
    const fn new() -> Self {
        SocketBufs {
            rx: [0; WEB_RX],
            tx: [0; WEB_TX],
        }
    }
}

/// A web client at `peer` connected: `true` if `WEB_ALLOW` permits it
/// ([`crate::config::AllowList::admits`]); a refusal is counted in
/// `WEB_REFUSED` (and the audit log).
fn admit(hub: &Hub, peer: Option<SocketAddrV4>) -> bool {
    hub.with(|m| {
        let ok = m.config.active.web_allow.admits(peer);
        if !ok {
            m.access.web_refused = m.access.web_refused.wrapping_add(1);
            hub.audit
                .refused(crate::audit::Interface::Web, peer.map(|p| *p.ip()));
        }
        ok
    })
}

/// Socket `j`: accepts a client, has it admitted (`WEB_ALLOW`) and given a
/// slot ([`Slots::claim`]), hands it to a free slot's future and waits
/// until that is done with it; forever.
// The socket's borrow is held while it accepts or closes: a slot's
// future borrows it only between the hand-over and `done`, while this
// one waits without it (a failed borrow ends that connection, no panic).
#[allow(clippy::await_holding_refcell_ref)]
async fn accept<S: Socket, C: Clock>(
    hub: &Hub,
    clock: &C,
    conns: &Conns<S>,
    port: u16,
    j: usize,
) -> Infallible {
    let (Some(sock), Some(done)) = (conns.socks.get(j), conns.done.get(j)) else {
        // Cannot happen: one accepting future per socket.
        return core::future::pending().await;
    };
    let slots = &conns.slots;
    loop {
        let accepted = match sock.try_borrow_mut() {
            // Nobody else holds the socket while its entry is free.
            Ok(mut s) => s.accept(port).await.map(|()| s.remote()),
            Err(_) => Err(crate::net::NetError::ListenFailed),
        };
        let Ok(peer) = accepted else {
            clock.sleep(Duration::from_millis(500)).await;
            continue;
        };
        let refused = if !admit(hub, peer) {
            slots.refused(Refusal::NotAllowed, peer);
            true
        } else {
            match slots.claim(j, peer, admission::Guard::NONE, clock).await {
                Ok(()) => {
                    // A slot's future serves it, closes it and releases it.
                    // At most WEB_SLOTS are admitted at once: never full.
                    let _ = conns.admitted.try_send((j, peer));
                    done.wait().await;
                    false
                }
                Err(why) => {
                    slots.refused(why, peer);
                    true
                }
            }
        };
        if refused {
            if let Ok(mut s) = sock.try_borrow_mut() {
                s.close().await;
            }
        }
    }
}

/// Slot `k`: serves each admitted connection it takes (with its request
/// buffer `http`), then closes and releases it; forever.
// The socket's borrow is held while serving: see `accept`.
#[allow(clippy::await_holding_refcell_ref)]
async fn slot<S: Socket, C: Clock>(
    hub: &Hub,
    clock: &C,
    web: &Web,
    conns: &Conns<S>,
    k: usize,
    http: &mut [u8],
) -> Infallible {
    let slots = &conns.slots;
    loop {
        let (j, peer) = conns.admitted.receive().await;
        // The socket is the slot's until it is released: its accepting
        // future waits meanwhile (a borrow that fails cannot happen).
        if let Some(Ok(mut sock)) = conns.socks.get(j).map(RefCell::try_borrow_mut) {
            let [a, b, c, d] = octets(peer);
            debug!("web: client {}.{}.{}.{} served in slot {}", a, b, c, d, k);
            let session = slots.session(j);
            if let Some(why) = serve_one(hub, clock, web, peer, &mut *sock, http, session).await {
                slots.closed(why, peer);
            }
            sock.close().await;
        }
        slots.release(j);
        if let Some(done) = conns.done.get(j) {
            done.signal(());
        }
    }
}

/// Closes the connections an applied configuration's `WEB_ALLOW` no
/// longer permits, at each apply.
async fn warden(hub: &Hub, slots: &Slots) -> Infallible {
    let Some(mut applied) = hub.config_applied.receiver() else {
        // Cannot happen (the watch has a receiver for the page).
        warn!("web: applied allow-lists are checked at the next request only");
        return core::future::pending().await;
    };
    loop {
        let list = applied.changed().await.web_allow;
        slots.close_unless(|peer| list.admits(peer));
    }
}

/// Serves one connection (its requests, kept alive) until it ends: the
/// client leaves, a limit is reached, or it is asked to close
/// (`session`: then why).
async fn serve_one<S: Socket, C: Clock>(
    hub: &Hub,
    clock: &C,
    web: &Web,
    peer: Option<SocketAddrV4>,
    sock: &mut S,
    http: &mut [u8],
    session: Session<'_>,
) -> Option<Close> {
    let ex = Exchange::new(clock, session);
    let app = Router::from_service(Served {
        app: App {
            hub,
            clock,
            web,
            peer,
            secure: sock.encrypted(),
            closing: &ex.closing,
        },
        ex: &ex,
    });
    let server = picoserve::Server::custom(&app, ClockTimer(clock), &CONFIG, http);
    match server.serve(Conn::new(sock, &ex)).await {
        Ok(_) => None,
        Err(picoserve::Error::Read(io::IoError::Asked(why))) => Some(why),
        Err(_) => {
            debug!("web: connection ended on an error (timeout, reset, malformed request)");
            None
        }
    }
}

/// The routes, as each request reaches them: the request counted (the
/// connection marked busy if its bytes were all read before), the
/// allow-list checked again, the last request's answer closing the
/// connection.
struct Served<'a, C: Clock> {
    app: App<'a, C>,
    ex: &'a Exchange<'a, C>,
}

impl<C: Clock> PathRouterService<()> for Served<'_, C> {
    async fn call_path_router_service<R: Read, W: ResponseWriter<Error = R::Error>>(
        &self,
        state: &(),
        params: (),
        path: Path<'_>,
        request: Request<'_, R>,
        w: W,
    ) -> Result<ResponseSent, W::Error> {
        self.ex.started();
        let app = &self.app;
        let allowed = app.hub.peek(|m| m.config.active.web_allow.admits(app.peer));
        if self.ex.check(allowed).is_some() {
            // Closed unanswered, as at accept: the route is never looked
            // at, and the write fails (the connection is closing), which
            // ends it. (The same writer type as the routes': no code of
            // its own.)
            self.ex.closing.set(true);
            let c = request.body_connection.finalize().await?;
            let w = Answer { w, last: false };
            return Response::empty(StatusCode::BAD_REQUEST)
                .write_to(c, w)
                .await;
        }
        // The count includes this request.
        let last = self.ex.served() + 1 >= MAX_REQUESTS;
        let w = Answer { w, last };
        let sent = app
            .call_path_router_service(state, params, path, request, w)
            .await;
        if last {
            self.ex.closing.set(true);
        }
        self.ex.answered();
        sent
    }
}

/// An answer, which says `Connection: close` if it is the connection's
/// last. (One writer type for every answer: the routes are compiled once.)
struct Answer<W> {
    w: W,
    last: bool,
}

impl<W: ResponseWriter> ResponseWriter for Answer<W> {
    type Error = W::Error;

    // The inner writer's future itself: no state of its own.
    fn write_response<R: Read<Error = Self::Error>, H: HeadersIter, B: Body>(
        self,
        connection: picoserve::response::Connection<'_, R>,
        response: Response<H, B>,
    ) -> impl core::future::Future<Output = Result<ResponseSent, Self::Error>> {
        let close = self.last.then_some(("Connection", "close"));
        self.w
            .write_response(connection, response.with_headers(close))
    }
}

/// The routes (see `gateway/WEB.md`).
struct App<'a, C: Clock> {
    hub: &'a Hub,
    clock: &'a C,
    web: &'a Web,
    peer: Option<SocketAddrV4>,
    /// The connection is TLS: the session cookie is `Secure`.
    secure: bool,
    /// Set once an answer closed the connection: nothing more on it is
    /// served (see [`io`]).
    closing: &'a Cell<bool>,
}

/// A body of bytes with its content type.
pub(crate) struct Bytes<'a> {
    /// `Content-Type`.
    pub ty: &'static str,
    /// The bytes.
    pub data: &'a [u8],
}

impl Content for Bytes<'_> {
    fn content_type(&self) -> &'static str {
        self.ty
    }

    fn content_length(&self) -> usize {
        self.data.len()
    }

    async fn write_content<W: picoserve::io::Write>(self, mut writer: W) -> Result<(), W::Error> {
        writer.write_all(self.data).await
    }
}

/// A JSON answer held in one part.
fn json_body(j: &Json) -> Bytes<'_> {
    Bytes {
        ty: "application/json",
        data: j.as_bytes(),
    }
}

/// A document's body: its snapshot, rendered window by window (each
/// window rendered again from the unchanging snapshot, see [`api`]).
struct DocBody<'a> {
    snap: &'a Snapshot,
    len: usize,
}

impl Content for DocBody<'_> {
    fn content_type(&self) -> &'static str {
        "application/json"
    }

    fn content_length(&self) -> usize {
        self.len
    }

    async fn write_content<W: picoserve::io::Write>(self, mut writer: W) -> Result<(), W::Error> {
        let mut window = [0; WINDOW];
        let mut sent = 0;
        while sent < self.len {
            let n = self.snap.window(sent, &mut window);
            if n == 0 {
                // Cannot happen (the snapshot does not change between
                // the measure and the windows); the length was promised.
                break;
            }
            writer.write_all(window.get(..n).unwrap_or(&[])).await?;
            sent += n;
        }
        Ok(())
    }
}

/// Why a document is answered with 500 (see [`doc_body`]).
const DOC_FAILED: &str = "the document could not be written";

/// A document's body, or `None` if a value in it cannot be written (cannot
/// happen: every document at its longest is tested): then it is answered
/// with 500 and [`DOC_FAILED`] as JSON, before anything of it is sent.
fn doc_body(snap: &Snapshot) -> Option<DocBody<'_>> {
    let len = snap.measure().ok()?;
    Some(DocBody { snap, len })
}

/// More than one session token in a request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Duplicate;

/// The session token a request carries (cookie or `Authorization:
/// Bearer`); `Err` if it carries more than one: two session cookies (in
/// one `Cookie` header or in two), two `Authorization` headers, or a
/// cookie and a bearer token. Which one counts would depend on who reads
/// the request (a proxy, a browser's cookie jar with a cookie planted for
/// a wider path or domain): the request is refused, not guessed at.
fn token(parts: &RequestParts<'_>) -> Result<Option<Token>, Duplicate> {
    let mut found: Option<Option<Token>> = None;
    let mut one = |t: Option<Token>| match found.replace(t) {
        Some(_) => Err(Duplicate),
        None => Ok(()),
    };
    for (name, value) in parts.headers().iter() {
        let (name, value) = (name.as_raw(), value.as_raw());
        if named(name, "Authorization") {
            let bearer = value.strip_prefix(b"Bearer ");
            one(bearer.and_then(|t| Token::from_hex(t.trim_ascii())))?;
        } else if named(name, "Cookie") {
            for c in value.split(|&b| b == b';') {
                let c = c.trim_ascii();
                if let Some(t) = c
                    .strip_prefix(COOKIE.as_bytes())
                    .and_then(|rest| rest.strip_prefix(b"="))
                {
                    one(Token::from_hex(t.trim_ascii()))?;
                }
            }
        }
    }
    Ok(found.flatten())
}

/// `name` (a header's name) is `want`, ignoring case.
fn named(name: &[u8], want: &str) -> bool {
    name.eq_ignore_ascii_case(want.as_bytes())
}

/// How the body of a request is delimited, checked as RFC 9112 § 6 asks
/// of a server: a `Transfer-Encoding` (chunked or any other) is not
/// supported (501), and a `Content-Length` must be one header of digits
/// (a duplicate, a list or a sign: 400). Either way the end of the body is
/// unknown, so the connection closes after the answer.
fn framing(parts: &RequestParts<'_>) -> Result<(), (StatusCode, &'static str)> {
    let mut lengths = 0;
    for (name, value) in parts.headers().iter() {
        let (name, value) = (name.as_raw(), value.as_raw().trim_ascii());
        if named(name, "Transfer-Encoding") {
            return Err((
                StatusCode::NOT_IMPLEMENTED,
                "Transfer-Encoding is not supported: send Content-Length",
            ));
        }
        if named(name, "Content-Length") {
            lengths += 1;
            let digits =
                !value.is_empty() && value.len() <= 9 && value.iter().all(u8::is_ascii_digit);
            if !digits || lengths > 1 {
                return Err((
                    StatusCode::BAD_REQUEST,
                    "one Content-Length of digits is needed",
                ));
            }
        }
    }
    Ok(())
}

/// The one `Host` header of a request (none, or two: `None`).
fn host<'r>(parts: &RequestParts<'r>) -> Option<&'r [u8]> {
    let mut found = None;
    for (name, value) in parts.headers().iter() {
        if named(name.as_raw(), "Host") {
            if found.is_some() {
                return None;
            }
            found = Some(value.as_raw().trim_ascii());
        }
    }
    found
}

/// `true` if `host` (a `Host` header: name, then `:port` or not) names
/// this device, so that the request cannot come from a page whose name
/// was rebound to the device's address (DNS rebinding):
/// * an IPv4 address `a.b.c.d`: a browser sends an address only when it
///   connected to that address, and no name is involved to rebind;
/// * `localhost` (or `[::1]`) when the client is on the loopback
///   network itself (Linux `--web-listen 127.0.0.1:PORT`).
///
/// Any other name is refused (421). The port is checked to be a port,
/// not to be the one served: forwarded ports (a NAT, QEMU) change it, and
/// the name alone decides who may answer.
pub(crate) fn own_host(host: &[u8], peer: Option<SocketAddrV4>, configured: &[u8]) -> bool {
    let (name, port) = match host.iter().rposition(|&b| b == b':') {
        // `[::1]:8080`, `[::1]` or `name:port`.
        Some(i) if !host.ends_with(b"]") => (
            host.get(..i).unwrap_or(&[]),
            Some(host.get(i + 1..).unwrap_or(&[])),
        ),
        _ => (host, None),
    };
    let port_ok = port.is_none_or(|p| {
        !p.is_empty()
            && p.len() <= 5
            && p.iter().all(u8::is_ascii_digit)
            && core::str::from_utf8(p).is_ok_and(|p| p.parse::<u16>().is_ok())
    });
    if !port_ok || name.is_empty() {
        return false;
    }
    if core::str::from_utf8(name).is_ok_and(|n| n.parse::<core::net::Ipv4Addr>().is_ok()) {
        return true;
    }
    // The name configured for the device (setting `web.host_name`).
    if !configured.is_empty() && name.eq_ignore_ascii_case(configured) {
        return true;
    }
    let loopback = peer.is_some_and(|p| p.ip().is_loopback());
    loopback && (name.eq_ignore_ascii_case(b"localhost") || name == b"[::1]")
}

/// `true` if a state-changing request comes from the device's own page:
/// its `Origin` is `http://` (or `https://`) and exactly its `Host`, or,
/// without an `Origin`, `Sec-Fetch-Site` says `same-origin`.
fn same_origin(parts: &RequestParts<'_>, host: &[u8]) -> bool {
    let h = parts.headers();
    match h.get("Origin") {
        Some(origin) => {
            let o = origin.as_raw().trim_ascii();
            o.strip_prefix(b"http://")
                .or_else(|| o.strip_prefix(b"https://"))
                .is_some_and(|o| o.eq_ignore_ascii_case(host))
        }
        None => h
            .get("Sec-Fetch-Site")
            .is_some_and(|s| s.as_raw().trim_ascii() == b"same-origin"),
    }
}

/// `true` if the body is declared JSON (`application/json`, parameters
/// such as `; charset=utf-8` allowed): a form of another site cannot send
/// that type without the browser asking first (CORS), which the device
/// never allows.
fn json_type(parts: &RequestParts<'_>) -> bool {
    media_type(parts, b"application/json")
}

/// `true` if the body is declared `application/octet-stream` (an upload).
fn octet_type(parts: &RequestParts<'_>) -> bool {
    media_type(parts, b"application/octet-stream")
}

fn media_type(parts: &RequestParts<'_>, want: &[u8]) -> bool {
    parts.headers().get("Content-Type").is_some_and(|t| {
        let t = t.as_raw();
        let media = t.split(|&b| b == b';').next().unwrap_or(&[]).trim_ascii();
        media.eq_ignore_ascii_case(want)
    })
}

impl<C: Clock> App<'_, C> {
    /// Who sends the request (its session), counting as a use.
    fn who(&self, parts: &RequestParts<'_>) -> Option<Who> {
        let now = self.clock.now();
        let t = token(parts).ok().flatten()?;
        self.web.sessions.borrow_mut().check(&t, now)
    }

    /// As [`Self::who`], without counting as a use of the session.
    fn peek_who(&self, parts: &RequestParts<'_>) -> Option<Who> {
        let now = self.clock.now();
        let t = token(parts).ok().flatten()?;
        self.web.sessions.borrow().peek(&t, now)
    }

    /// The session of the request if its role is `role` or above; else
    /// the answer: 403 before an administrator exists, 401 without a
    /// session, 403 with a lesser role.
    // The error is the answer (built once, written by the caller).
    #[allow(clippy::result_large_err)]
    fn require(&self, parts: &RequestParts<'_>, role: Role) -> Result<Who, Reply> {
        if !self.admin_exists() {
            return Err(error(
                StatusCode::FORBIDDEN,
                "create the administrator first (with the setup code)",
            ));
        }
        match self.who(parts) {
            None => Err(error(StatusCode::UNAUTHORIZED, "log in first")),
            Some(w) if w.role < role => Err(error(
                StatusCode::FORBIDDEN,
                match role {
                    Role::Admin => "an administrator's session is needed",
                    _ => "an operator's session is needed",
                },
            )),
            Some(w) => Ok(w),
        }
    }

    /// May the request read the status, configuration and logs?
    // The error is the answer (built once, written by the caller).
    #[allow(clippy::result_large_err)]
    fn may_read(&self, parts: &RequestParts<'_>) -> Result<(), Reply> {
        if self.hub.with(|m| m.config.active.read_without_login) {
            return Ok(());
        }
        self.require(parts, Role::Viewer).map(|_| ())
    }

    /// The name of the account of session `who` (gone if it was removed
    /// meanwhile).
    pub(crate) fn name_of(&self, who: Who) -> Option<UserName> {
        self.hub
            .with(|m| m.access.accounts.at(who.account).map(|a| a.name))
    }

    fn admin_exists(&self) -> bool {
        self.hub.with(|m| m.access.accounts.admin_exists())
    }
}

impl<C: Clock> App<'_, C> {
    /// May the device restart now: no motion runs, or the body says
    /// `{"during_motion":true}` (the person was told and confirmed).
    async fn restart_confirmed<R: Read>(&self, request: &mut Request<'_, R>) -> bool {
        #[derive(serde::Deserialize)]
        struct Doc {
            #[serde(default)]
            during_motion: bool,
        }
        if self.hub.with(|m| m.active_motion.is_none()) {
            return true;
        }
        let confirmed = match request.body_connection.body().read_all().await {
            Ok(body) => {
                serde_json_core::from_slice::<Doc>(body).is_ok_and(|(d, _)| d.during_motion)
            }
            Err(_) => false,
        };
        if confirmed {
            warn!(
                "web: restart confirmed during a motion: the robot link closes in the middle of it"
            );
        }
        confirmed
    }
}

/// What a request is answered with: built first, written with one await
/// at the end (so that one JSON buffer lives in the connection's future,
/// not one per route).
pub(crate) enum Reply {
    /// The page.
    Page,
    /// A document of the API, from one snapshot of the state.
    Doc(Doc),
    /// A small JSON answer.
    Json(StatusCode, Json),
    /// A JSON answer that opens a session (sets the cookie).
    Session(StatusCode, Json, Token),
    /// A JSON answer that ends the session (clears the cookie).
    Logout(Json),
    /// A request refused before its route was looked at, whose framing
    /// cannot be trusted: answered, then the connection closes (what
    /// follows on it is never read as a request).
    Close(StatusCode, Json),
    /// Answer, then restart the device.
    Restart(Json),
    /// The audit log's export ([`audit`]).
    Audit(audit::Format, crate::audit::page::Query),
    /// 405: the path does not take the request's method; the `Allow`
    /// header names those it takes ([`routes`]).
    NotAllowed(&'static str),
    /// 421 to a browser: a page naming the address to use
    /// ([`misdirected`]).
    Misdirected(misdirected::Page),
}

/// `{"error":"..."}`, the text cut to fit: always valid JSON (an escaped
/// byte takes up to 6, so the cut is tried shorter until it fits).
fn error_json(text: &str) -> Json {
    let text = text.as_bytes();
    for cut in [json::ANSWER, json::ANSWER / 2, json::ANSWER / 6 - 16] {
        let fit = text.get(..cut).unwrap_or(text);
        if let Ok(j) = Json::value(|v| v.object(|j| j.key("error").str(fit))) {
            return j;
        }
    }
    // Five bytes always fit.
    Json::value(|v| v.object(|j| j.key("error").str(b"error"))).unwrap_or_else(|_| Json::new())
}

fn error(status: StatusCode, text: &str) -> Reply {
    Reply::Json(status, error_json(text))
}

impl<C: Clock> App<'_, C> {
    /// `/api/session`: who is logged in, and what the page should offer.
    fn session_json(&self, who: Option<Who>) -> Json {
        let now = self.clock.now();
        let ip = self.peer.map(|p| *p.ip());
        // The address's wait, or, where it is an account's own address
        // (counted apart, `access::limit`), the longest of those accounts'
        // waits: what a login from here would be told.
        let wait = self.hub.with(|m| {
            let limiter = self.web.limiter.borrow();
            (0..crate::access::accounts::ACCOUNTS)
                .filter_map(|a| {
                    let o = m.access.accounts.own_address(a, ip)?;
                    limiter.wait_own(a, o, now)
                })
                .chain(limiter.wait(ip, now))
                .max()
                .map_or(0, |d| d.as_secs() + 1)
        });
        let (admin, recovery, open, name) = self.hub.with(|m| {
            let name = who
                .and_then(|w| m.access.accounts.at(w.account))
                .map(|a| a.name);
            (
                m.access.accounts.admin_exists(),
                m.access.recovery,
                m.config.active.read_without_login,
                name,
            )
        });
        let name = name.as_ref().map(|n| n.as_bytes());
        let setup = recovery || (!admin && self.web.setup_code.is_some());
        Json::value(|v| {
            v.object(|j| {
                j.key("authorized").bool(who.is_some());
                j.key("name").opt(name, |v, n| v.str(n));
                j.key("role")
                    .opt(who, |v, w| v.str(w.role.as_str().as_bytes()));
                j.key("admin_exists").bool(admin);
                j.key("setup").bool(setup);
                j.key("setup_code_needed")
                    .bool(self.web.setup_code.is_some());
                j.key("read_without_login").bool(open);
                j.key("min_password")
                    .uint(crate::access::password::MIN_LEN as u64);
                j.key("retry_after_s").uint(wait);
                j.key("restart").bool(self.web.restart.is_some());
                j.key("recovery").bool(recovery);
            })
        })
        .unwrap_or_else(|_| error_json("session"))
    }

    /// A document of the API (role: viewer, unless reading without login
    /// is on).
    fn doc<R: Read>(&self, route: Route, request: &Request<'_, R>) -> Reply {
        if let Err(r) = self.may_read(&request.parts) {
            return r;
        }
        Reply::Doc(match route {
            Route::Status => Doc::Status,
            Route::Config => Doc::Config,
            Route::Fields => Doc::Fields,
            _ => Doc::Log,
        })
    }

    /// Reads the request (its body where the route has one) and decides
    /// the answer.
    async fn route<R: Read>(&self, path: &str, request: &mut Request<'_, R>) -> Reply {
        // Checked before anything is read or changed.
        if let Err((status, why)) = framing(&request.parts) {
            return Reply::Close(status, error_json(why));
        }
        let Some(host) = host(&request.parts) else {
            return error(StatusCode::BAD_REQUEST, "one Host header is needed");
        };
        let configured = self.hub.with(|m| m.config.active.web_host);
        if !own_host(host, self.peer, configured.as_bytes()) {
            let accept = request.parts.headers().get("Accept");
            if misdirected::wants_html(accept.map(|a| a.as_raw())) {
                // The device's own address where it sets it (a board with
                // a static address); with DHCP or on Linux it is not known.
                let address = self.hub.with(|m| {
                    let a = &m.access;
                    (a.network_managed && !a.running.dhcp).then_some(a.running.ip)
                });
                return Reply::Misdirected(misdirected::Page::new(host, self.secure, address));
            }
            return error(
                StatusCode::MISDIRECTED_REQUEST,
                "this device does not answer to that host name: use its address",
            );
        }
        if token(&request.parts).is_err() {
            return error(
                StatusCode::BAD_REQUEST,
                "more than one session token: send one session cookie (or one bearer token)",
            );
        }
        let method = request.parts.method();
        let get = method == "GET" || method == "HEAD";
        let post = method == "POST";
        if post && !same_origin(&request.parts, host) {
            return error(StatusCode::FORBIDDEN, "cross-site request refused");
        }
        // An upload is bytes, declared so: like JSON, a type no form of
        // another site may send without the browser asking first.
        #[cfg(feature = "update")]
        let upload = post && path == "/api/firmware";
        #[cfg(not(feature = "update"))]
        let upload = false;
        if upload && !octet_type(&request.parts) {
            return error(
                StatusCode::UNSUPPORTED_MEDIA_TYPE,
                "an upload needs Content-Type: application/octet-stream",
            );
        }
        if post && !upload && !json_type(&request.parts) {
            return error(
                StatusCode::UNSUPPORTED_MEDIA_TYPE,
                "a change needs Content-Type: application/json",
            );
        }
        let Some((route, methods)) = routes::lookup(path) else {
            return error(StatusCode::NOT_FOUND, "not found");
        };
        if !methods.allow(method) {
            return Reply::NotAllowed(methods.header());
        }
        match route {
            Route::Page => Reply::Page,
            Route::Status | Route::Fields | Route::Log => self.doc(route, request),
            Route::Config if get => self.doc(route, request),
            // role: viewer, always.
            Route::Audit => self.audit(&request.parts),
            Route::Session => Reply::Json(
                StatusCode::OK,
                self.session_json(self.peek_who(&request.parts)),
            ),
            Route::Setup => self.setup(request).await,
            Route::Login => self.login(request).await,
            Route::Logout => {
                if let Some(who) = self.peek_who(&request.parts) {
                    let name = self.name_of(who);
                    let from = self.peer.map(|p| *p.ip());
                    self.hub.audit(Event::Logout {
                        name: name.as_ref().map_or(&[][..], |n| n.as_bytes()),
                        from,
                    });
                }
                if let Ok(Some(t)) = token(&request.parts) {
                    self.web.sessions.borrow_mut().close(&t);
                }
                Reply::Logout(post::ok_json())
            }
            // role: any account (its own password).
            Route::Password => match self.require(&request.parts, Role::Viewer) {
                Ok(who) => self.set_password(who, request).await,
                Err(r) => r,
            },
            // role: admin.
            Route::Accounts => match self.require(&request.parts, Role::Admin) {
                Ok(_) if get => Reply::Json(StatusCode::OK, self.accounts_json()),
                Ok(who) => self.post_accounts(who, request).await,
                Err(r) => r,
            },
            // role: admin.
            Route::Firmware => match self.require(&request.parts, Role::Admin) {
                #[cfg(feature = "update")]
                Ok(who) => {
                    let downgrade = request
                        .parts
                        .query()
                        .is_some_and(|q| q.0.split('&').any(|kv| kv == "downgrade=allow"));
                    self.post_firmware(who, downgrade, request).await
                }
                #[cfg(not(feature = "update"))]
                Ok(_) => error(
                    StatusCode::NOT_IMPLEMENTED,
                    "this gateway installs no firmware",
                ),
                Err(r) => r,
            },
            // role: admin (the settings' change; their GET is above).
            Route::Config | Route::Restart | Route::Trigger => {
                let who = match self.require(&request.parts, Role::Admin) {
                    Ok(w) => w,
                    Err(r) => return r,
                };
                match route {
                    Route::Config => self.post_config(who, request).await,
                    Route::Restart => match self.web.restart {
                        Some(_) if !self.restart_confirmed(request).await => error(
                            StatusCode::CONFLICT,
                            "a motion is running: the restart cuts the robot link in the middle of it. \
                             Wait for it to end, or confirm with {\"during_motion\":true}",
                        ),
                        Some(_) => {
                            let name = self.name_of(who);
                            let actor = name.as_ref().map_or(&[][..], |n| n.as_bytes());
                            let from = self.peer.map(|p| *p.ip());
                            self.hub.audit(Event::Restart {
                                who: AuditWho::web(actor, from),
                            });
                            Reply::Restart(post::ok_json())
                        }
                        None => error(
                            StatusCode::NOT_IMPLEMENTED,
                            "this gateway cannot restart itself (restart the service)",
                        ),
                    },
                    _ => {
                        let n = path
                            .strip_prefix("/api/trigger/")
                            .and_then(|n| n.parse::<usize>().ok());
                        self.post_trigger(who, n, request).await
                    }
                }
            }
        }
    }
}

/// The session cookie; `Secure` (sent over HTTPS only) when the page is
/// served over TLS.
fn session_cookie(t: &Token, secure: bool) -> impl core::fmt::Display {
    struct Cookie([u8; crate::access::session::TOKEN_CHARS], bool);
    impl core::fmt::Display for Cookie {
        fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
            let hex = core::str::from_utf8(&self.0).unwrap_or("");
            let secure = if self.1 { "; Secure" } else { "" };
            write!(
                f,
                "{COOKIE}={hex}; Path=/; HttpOnly; SameSite=Strict{secure}"
            )
        }
    }
    Cookie(t.to_hex(), secure)
}

/// Headers of every answer: no other site may frame the page or the API
/// (clickjacking), and no answer is sniffed as another type.
const SECURITY_HEADERS: [(&str, &str); 3] = [
    ("X-Frame-Options", "DENY"),
    ("Content-Security-Policy", "frame-ancestors 'none'"),
    ("X-Content-Type-Options", "nosniff"),
];

/// The header of every answer over HTTPS: the browser uses HTTPS only for
/// this device from now on, for a year (RFC 6797), so that nobody on the
/// way can turn a later visit into plain HTTP and read the session.
const HSTS: (&str, &str) = ("Strict-Transport-Security", "max-age=31536000");

/// [`HSTS`] on a connection over TLS (`secure`), nothing on plain HTTP
/// (where a browser ignores it anyway).
pub(crate) fn hsts(secure: bool) -> Option<(&'static str, &'static str)> {
    secure.then_some(HSTS)
}

/// A body, or for `HEAD` only its type and length (RFC 9110 § 9.3.2: the
/// same header fields as `GET`, no content).
struct Head<B: Content> {
    body: B,
    head: bool,
}

impl<B: Content> Content for Head<B> {
    fn content_type(&self) -> &'static str {
        self.body.content_type()
    }

    fn content_length(&self) -> usize {
        self.body.content_length()
    }

    async fn write_content<W: picoserve::io::Write>(self, writer: W) -> Result<(), W::Error> {
        if self.head {
            return Ok(());
        }
        self.body.write_content(writer).await
    }
}

impl<C: Clock> PathRouterService<()> for App<'_, C> {
    async fn call_path_router_service<R: Read, W: ResponseWriter<Error = R::Error>>(
        &self,
        _state: &(),
        _params: (),
        path: Path<'_>,
        mut request: Request<'_, R>,
        w: W,
    ) -> Result<ResponseSent, W::Error> {
        if self.closing.get() {
            // Bytes after an answer that closed the connection (a chunked
            // body, say), already buffered and parsed as a request: never
            // served. The write fails (the socket is closing, see `io`),
            // which ends the connection.
            let c = request.body_connection.finalize().await?;
            return Response::empty(StatusCode::BAD_REQUEST)
                .write_to(c, w)
                .await;
        }
        let head = request.parts.method() == "HEAD";
        let made_from = self.hub.audit.next_seq();
        let reply = self.route(path.encoded(), &mut request).await;
        // A change's records (login, logout, accounts, settings, firmware,
        // a restart) are on the medium before its answer goes: an answer
        // the client saw is evidence that survives a crash right after.
        // Only a request that made records waits (failures are counted,
        // not recorded one by one: a flood of them waits for no medium),
        // and at most KEPT_WAIT (a medium that hangs).
        let made_to = self.hub.audit.next_seq();
        if made_to != made_from {
            let kept = self.hub.audit.wait_kept(made_to);
            embassy_futures::select::select(kept, self.clock.sleep(KEPT_WAIT)).await;
        }
        let c = request.body_connection.finalize().await?;
        match reply {
            Reply::Page => {
                let page = Bytes {
                    ty: "text/html; charset=utf-8",
                    data: assets::INDEX_HTML_GZ,
                };
                Response::new(StatusCode::OK, Head { body: page, head })
                    .with_headers([("Content-Encoding", "gzip"), ("Cache-Control", "no-cache")])
                    .with_headers(SECURITY_HEADERS)
                    .with_headers(hsts(self.secure))
                    .write_to(c, w)
                    .await
            }
            Reply::Doc(doc) => {
                // The one moment the document shows: the state's lock is
                // taken once, for the copy.
                let now = self.clock.now();
                let mut snap = Snapshot::Fields;
                self.hub.with(|m| snap.take(doc, m, now));
                #[cfg(feature = "mqtt")]
                snap.set_mqtt(self.hub.mqtt.get());
                match doc_body(&snap) {
                    Some(body) => {
                        Response::new(StatusCode::OK, Head { body, head })
                            .with_header("Cache-Control", "no-store")
                            .with_headers(SECURITY_HEADERS)
                            .with_headers(hsts(self.secure))
                            .write_to(c, w)
                            .await
                    }
                    None => {
                        warn!("web: a document could not be written");
                        let j = error_json(DOC_FAILED);
                        let body = json_body(&j);
                        Response::new(StatusCode::INTERNAL_SERVER_ERROR, Head { body, head })
                            .with_header("Cache-Control", "no-store")
                            .with_headers(SECURITY_HEADERS)
                            .with_headers(hsts(self.secure))
                            .write_to(c, w)
                            .await
                    }
                }
            }
            Reply::NotAllowed(allow) => {
                Response::new(
                    StatusCode::METHOD_NOT_ALLOWED,
                    Head {
                        body: json_body(&error_json("method not allowed")),
                        head,
                    },
                )
                .with_header("Allow", allow)
                .with_header("Cache-Control", "no-store")
                .with_headers(SECURITY_HEADERS)
                .with_headers(hsts(self.secure))
                .write_to(c, w)
                .await
            }
            Reply::Json(status, j) => {
                Response::new(
                    status,
                    Head {
                        body: json_body(&j),
                        head,
                    },
                )
                .with_header("Cache-Control", "no-store")
                .with_headers(SECURITY_HEADERS)
                .with_headers(hsts(self.secure))
                .write_to(c, w)
                .await
            }
            Reply::Close(status, j) => {
                warn!("web: request refused (its body's framing), connection closed");
                let sent = Response::new(
                    status,
                    Head {
                        body: json_body(&j),
                        head,
                    },
                )
                .with_header("Cache-Control", "no-store")
                .with_header("Connection", "close")
                .with_headers(SECURITY_HEADERS)
                .with_headers(hsts(self.secure))
                .write_to(c, w)
                .await?;
                self.closing.set(true);
                Ok(sent)
            }
            Reply::Session(status, j, t) => {
                // The token goes in the cookie only (HttpOnly): no page
                // script, and so no injected one, ever holds it.
                Response::new(status, json_body(&j))
                    .with_header("Set-Cookie", session_cookie(&t, self.secure))
                    .with_header("Cache-Control", "no-store")
                    .with_headers(SECURITY_HEADERS)
                    .with_headers(hsts(self.secure))
                    .write_to(c, w)
                    .await
            }
            Reply::Logout(j) => {
                Response::new(StatusCode::OK, json_body(&j))
                    .with_header(
                        "Set-Cookie",
                        "hgw_session=; Max-Age=0; Path=/; HttpOnly; SameSite=Strict",
                    )
                    .with_header("Cache-Control", "no-store")
                    .with_headers(SECURITY_HEADERS)
                    .with_headers(hsts(self.secure))
                    .write_to(c, w)
                    .await
            }
            Reply::Misdirected(page) => {
                Response::new(StatusCode::MISDIRECTED_REQUEST, Head { body: page, head })
                    .with_header("Cache-Control", "no-store")
                    .with_headers(SECURITY_HEADERS)
                    .write_to(c, w)
                    .await
            }
            Reply::Audit(f, q) => {
                audit::write(self.hub, self.clock, (f, q, self.secure), head, c, w).await
            }
            Reply::Restart(j) => {
                let sent = Response::new(StatusCode::ACCEPTED, json_body(&j))
                    .with_headers(SECURITY_HEADERS)
                    .with_headers(hsts(self.secure))
                    .write_to(c, w)
                    .await?;
                warn!("web: restart requested");
                // Let the answer leave before the device goes.
                self.clock.sleep(Duration::from_millis(500)).await;
                // What the audit log's periods counted is kept, not lost
                // with the RAM (the restart's own record is kept already).
                crate::audit::keep::closing(&self.hub.audit, self.clock, None).await;
                if let Some(restart) = self.web.restart {
                    restart();
                }
                Ok(sent)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::net::Ipv4Addr;

    crate::admission::tests::admission_suite!(Slots::new(NAME, &LIMITS));

    #[test]
    fn own_host_names_the_device() {
        let lan = Some(SocketAddrV4::new(Ipv4Addr::new(10, 0, 0, 50), 40000));
        let lo = Some(SocketAddrV4::new(Ipv4Addr::LOCALHOST, 40000));
        for (host, peer, ok) in [
            (&b"192.168.1.50"[..], lan, true),
            (b"192.168.1.50:80", lan, true),
            (b"127.0.0.1:8080", lo, true),
            (b"localhost:8080", lo, true),
            (b"LOCALHOST", lo, true),
            (b"[::1]:8080", lo, true),
            (b"localhost:8080", lan, false),
            (b"[::1]", lan, false),
            (b"evil.example", lo, false),
            (b"gw.plant.local:8080", lan, true),
            (b"GW.PLANT.LOCAL", lan, true),
            (b"gw.plant.local.evil.example", lan, false),
            (b"evil.example:80", lan, false),
            (b"192.168.1.50.evil.example", lan, false),
            (b"192.168.1.50:", lan, false),
            (b"192.168.1.50:65536", lan, false),
            (b"192.168.1.50:+80", lan, false),
            (b":80", lan, false),
            (b"", lan, false),
            (b"localhost.", lo, false),
        ] {
            assert_eq!(
                own_host(host, peer, b"gw.plant.local"),
                ok,
                "{}",
                String::from_utf8_lossy(host)
            );
        }
    }

    #[test]
    fn a_document_that_cannot_be_written_is_answered_with_json() {
        assert!(doc_body(&Snapshot::Failing).is_none());
        let v: serde_json::Value =
            serde_json::from_slice(error_json(DOC_FAILED).as_bytes()).unwrap();
        assert_eq!(v["error"], DOC_FAILED);
        let long = r#"\"x"#.repeat(2000);
        let v: serde_json::Value = serde_json::from_slice(error_json(&long).as_bytes()).unwrap();
        assert!(v["error"].as_str().unwrap().starts_with(r#"\"x"#));
    }
}
