//! picoserve on the gateway's socket interface and clock.
//!
//! picoserve wants a socket it can split into a read half and a write
//! half, and a timer. The gateway's [`Socket`] is one object (the same
//! for tokio, embassy-net and the test network), so the halves share it
//! through a `RefCell`: picoserve reads a request, then writes the answer,
//! never both at once. Should it ever use both halves at the same moment,
//! the second gets [`IoError::Busy`] and the connection ends (no panic).
//! The write half collects small writes (picoserve writes a header line at
//! a time) into [`WRITE_BUF`] bytes before they go to the socket.
//!
//! The halves also keep the connection's [`Exchange`]: a read that brings
//! the first byte of a request marks the connection busy (in the server's
//! [`Slots`](super::Slots)); an answer must be written within
//! [`ANSWER_DEADLINE`] of its first write (a client that reads slowly
//! cannot hold a slot longer); and once the connection is asked to close
//! (a newcomer takes its slot, or the allow-list no longer permits its
//! client) nothing more is read ([`IoError::Asked`]).
//!
//! Every byte the read half hands on has passed the request grammar
//! ([`super::grammar`]): at a byte that breaks it, the bytes before it are
//! handed on and then the stream ends, so picoserve answers 400 and closes
//! the connection without a route seeing the request.
//!
//! An answer can close the connection (a request whose body cannot be
//! delimited, the last request a connection serves): the server sets the
//! exchange's `closing` flag, after which the read half sees the end of
//! the stream and the write half refuses ([`IoError::Closing`]), so that
//! picoserve ends the connection even when more bytes are already
//! buffered as a next request.

use core::cell::{Cell, RefCell};
use core::future::Future;

use embassy_futures::select::{select, Either};
use embassy_time::Instant;
use picoserve::io::embedded_io_async::{self, ErrorKind, ErrorType};
use picoserve::io::Read;
use picoserve::mem::{BorrowedBuffer, BorrowedCursor};

use super::grammar::Grammar;
use super::ANSWER_DEADLINE;
use crate::admission::{Close, Session};
use crate::clock::{with_deadline, Clock};
use crate::net::{NetError, Socket};

/// Bytes the write half collects before writing to the socket.
pub(crate) const WRITE_BUF: usize = 512;

/// Why a web connection's socket failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum IoError {
    /// The socket failed.
    Net(NetError),
    /// Both halves were used at once.
    Busy,
    /// The connection is closing: nothing more is written.
    Closing,
    /// The connection was asked to close, and why: nothing more is read.
    Asked(Close),
    /// An answer was not written within [`ANSWER_DEADLINE`].
    Slow,
}

impl core::fmt::Display for IoError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            IoError::Net(e) => f.write_str(e.as_str()),
            IoError::Busy => f.write_str("socket busy"),
            IoError::Closing => f.write_str("connection closing"),
            IoError::Asked(Close::Evicted) => f.write_str("closed for a new client"),
            IoError::Asked(Close::NotAllowed) => f.write_str("client no longer allowed"),
            IoError::Slow => f.write_str("answer not taken in time"),
        }
    }
}

impl core::error::Error for IoError {}

impl embedded_io_async::Error for IoError {
    fn kind(&self) -> ErrorKind {
        match self {
            IoError::Net(NetError::Reset) | IoError::Net(NetError::NotConnected) => {
                ErrorKind::ConnectionReset
            }
            IoError::Slow => ErrorKind::TimedOut,
            _ => ErrorKind::Other,
        }
    }
}

/// The marker of the gateway's runtime for picoserve's traits.
pub(crate) struct GatewayRuntime;

/// picoserve's timer over the gateway's [`Clock`] (virtual time in tests).
pub(crate) struct ClockTimer<'c, C: Clock>(pub &'c C);

impl<C: Clock> picoserve::Timer<GatewayRuntime> for ClockTimer<'_, C> {
    fn delay(&self, duration: picoserve::time::Duration) -> impl Future<Output = ()> {
        self.0
            .sleep(embassy_time::Duration::from_millis(duration.as_millis()))
    }
}

/// Where one connection is between its requests, shared by the socket's
/// halves and the server's routes.
pub(crate) struct Exchange<'a, C: Clock> {
    clock: &'a C,
    session: Session<'a>,
    /// Set once an answer closed the connection: nothing more on it is
    /// read or written (see the module documentation).
    pub closing: Cell<bool>,
    /// A request in progress (its first byte read).
    busy: Cell<bool>,
    /// When the answer in progress must be written by.
    answer_by: Cell<Option<Instant>>,
    /// Requests served on the connection.
    served: Cell<u32>,
    /// The request grammar's checker of the bytes read.
    grammar: Cell<Grammar>,
}

impl<'a, C: Clock> Exchange<'a, C> {
    /// A new connection, its entry in the server's table being `session`.
    pub(crate) fn new(clock: &'a C, session: Session<'a>) -> Self {
        Exchange {
            clock,
            session,
            closing: Cell::new(false),
            busy: Cell::new(false),
            answer_by: Cell::new(None),
            served: Cell::new(0),
            grammar: Cell::new(Grammar::NEW),
        }
    }

    /// A request started (its first byte came, or it was whole in what
    /// was read before).
    pub(crate) fn started(&self) {
        if !self.busy.replace(true) {
            self.session.started();
        }
    }

    /// Its answer is written.
    pub(crate) fn answered(&self) {
        self.busy.set(false);
        self.answer_by.set(None);
        self.session.answered(self.clock.now());
        self.served.set(self.served.get().saturating_add(1));
    }

    /// Requests the connection has served.
    pub(crate) fn served(&self) -> u32 {
        self.served.get()
    }

    /// Why the connection may not be served another request, if it may
    /// not: asked to close, or its client not `permitted` by the
    /// allow-list in use.
    pub(crate) fn check(&self, permitted: bool) -> Option<Close> {
        self.session.check(permitted)
    }

    /// When the answer in progress must be written by (from its first
    /// write).
    fn answer_deadline(&self) -> Instant {
        match self.answer_by.get() {
            Some(t) => t,
            None => {
                let t = self.clock.now() + ANSWER_DEADLINE;
                self.answer_by.set(Some(t));
                t
            }
        }
    }
}

/// A connected socket, as picoserve sees it.
pub(crate) struct Conn<'s, S: Socket, C: Clock> {
    sock: RefCell<&'s mut S>,
    ex: &'s Exchange<'s, C>,
}

impl<'s, S: Socket, C: Clock> Conn<'s, S, C> {
    /// Wraps a connected socket, whose connection is `ex`.
    pub(crate) fn new(sock: &'s mut S, ex: &'s Exchange<'s, C>) -> Self {
        Conn {
            sock: RefCell::new(sock),
            ex,
        }
    }
}

/// The read half.
pub(crate) struct ReadHalf<'c, 's, S: Socket, C: Clock> {
    sock: &'c RefCell<&'s mut S>,
    ex: &'s Exchange<'s, C>,
}

/// The write half, with its buffer.
pub(crate) struct WriteHalf<'c, 's, S: Socket, C: Clock> {
    sock: &'c RefCell<&'s mut S>,
    ex: &'s Exchange<'s, C>,
    buf: [u8; WRITE_BUF],
    len: usize,
}

impl<S: Socket, C: Clock> ErrorType for ReadHalf<'_, '_, S, C> {
    type Error = IoError;
}

impl<S: Socket, C: Clock> ErrorType for WriteHalf<'_, '_, S, C> {
    type Error = IoError;
}

impl<S: Socket, C: Clock> Read for ReadHalf<'_, '_, S, C> {
    // The borrow is held while the socket reads: see the module
    // documentation for why the other half cannot want it meanwhile.
    #[allow(clippy::await_holding_refcell_ref)]
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, IoError> {
        // Closing, or the grammar broken: the stream ends here (at once,
        // not when the client sends more).
        if self.ex.closing.get() || self.ex.grammar.get().broken() {
            return Ok(0);
        }
        let mut sock = self.sock.try_borrow_mut().map_err(|_| IoError::Busy)?;
        // Asked to close: that comes first, even with bytes waiting.
        match select(self.ex.session.closing(), sock.read(buf)).await {
            Either::First(why) => Err(IoError::Asked(why)),
            Either::Second(Ok(n)) => {
                // The grammar first: what breaks it is not handed on, and
                // the stream ends there (picoserve answers 400).
                let mut g = self.ex.grammar.get();
                let n = match g.feed(buf.get(..n).unwrap_or(&[])) {
                    Ok(()) => n,
                    Err(good) => {
                        warn!("web: a request breaks the HTTP grammar: refused, connection closed");
                        good
                    }
                };
                self.ex.grammar.set(g);
                if n > 0 {
                    self.ex.started();
                }
                Ok(n)
            }
            Either::Second(Err(e)) => Err(IoError::Net(e)),
        }
    }
}

impl<S: Socket, C: Clock> WriteHalf<'_, '_, S, C> {
    #[allow(clippy::await_holding_refcell_ref)]
    async fn drain(&mut self) -> Result<(), IoError> {
        if self.ex.closing.get() {
            return Err(IoError::Closing);
        }
        if self.len == 0 {
            return Ok(());
        }
        let by = self.ex.answer_deadline();
        let mut sock = self.sock.try_borrow_mut().map_err(|_| IoError::Busy)?;
        let data = self.buf.get(..self.len).unwrap_or(&[]);
        with_deadline(self.ex.clock, by, sock.write_all(data))
            .await
            .map_err(|_| IoError::Slow)?
            .map_err(IoError::Net)?;
        self.len = 0;
        Ok(())
    }
}

impl<S: Socket, C: Clock> embedded_io_async::Write for WriteHalf<'_, '_, S, C> {
    async fn write(&mut self, data: &[u8]) -> Result<usize, IoError> {
        if self.ex.closing.get() {
            return Err(IoError::Closing);
        }
        if data.is_empty() {
            return Ok(0);
        }
        if self.len == WRITE_BUF {
            self.drain().await?;
        }
        let free = self.buf.get_mut(self.len..).unwrap_or(&mut []);
        let n = free.len().min(data.len());
        if let (Some(dst), Some(src)) = (free.get_mut(..n), data.get(..n)) {
            dst.copy_from_slice(src);
        }
        self.len += n;
        Ok(n)
    }

    async fn flush(&mut self) -> Result<(), IoError> {
        self.drain().await
    }
}

impl<S: Socket, C: Clock> picoserve::io::Write for WriteHalf<'_, '_, S, C> {
    async fn write_with<F: FnOnce(BorrowedCursor<'_>) -> R, R>(
        &mut self,
        f: F,
    ) -> Result<R, IoError> {
        if self.ex.closing.get() {
            return Err(IoError::Closing);
        }
        if self.len == WRITE_BUF {
            self.drain().await?;
        }
        let free = self.buf.get_mut(self.len..).unwrap_or(&mut []);
        let mut b = BorrowedBuffer::new(free);
        let r = f(b.unfilled());
        self.len += b.len();
        Ok(r)
    }
}

impl<'s, S: Socket, C: Clock> picoserve::io::Socket<GatewayRuntime> for Conn<'s, S, C> {
    type Error = IoError;
    type ReadHalf<'c>
        = ReadHalf<'c, 's, S, C>
    where
        Self: 'c;
    type WriteHalf<'c>
        = WriteHalf<'c, 's, S, C>
    where
        Self: 'c;

    fn split(&mut self) -> (Self::ReadHalf<'_>, Self::WriteHalf<'_>) {
        (
            ReadHalf {
                sock: &self.sock,
                ex: self.ex,
            },
            WriteHalf {
                sock: &self.sock,
                ex: self.ex,
                buf: [0; WRITE_BUF],
                len: 0,
            },
        )
    }

    async fn abort<T: picoserve::Timer<GatewayRuntime>>(
        self,
        _timeouts: &picoserve::Timeouts,
        _timer: &T,
    ) -> Result<(), picoserve::Error<IoError>> {
        self.sock.into_inner().close().await;
        Ok(())
    }

    async fn shutdown<T: picoserve::Timer<GatewayRuntime>>(
        self,
        _timeouts: &picoserve::Timeouts,
        _timer: &T,
    ) -> Result<(), picoserve::Error<IoError>> {
        self.sock.into_inner().close().await;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::net::SocketAddrV4;
    use core::pin::pin;
    use core::task::{Context, Poll, Waker};

    use embassy_time::Duration;
    use picoserve::io::embedded_io_async::Write as _;
    use picoserve::io::Socket as _;

    use crate::testkit::clock::VirtualClock;
    use crate::web::{Slots, LIMITS, NAME};

    /// A client that takes its answer a write a second: each write ends
    /// well within picoserve's timeout for one write.
    struct SlowReader<'c>(&'c VirtualClock);

    impl Socket for SlowReader<'_> {
        async fn connect(&mut self, _: SocketAddrV4) -> Result<(), NetError> {
            Ok(())
        }
        async fn accept(&mut self, _: u16) -> Result<(), NetError> {
            Ok(())
        }
        async fn read(&mut self, _: &mut [u8]) -> Result<usize, NetError> {
            core::future::pending().await
        }
        async fn write_all(&mut self, _: &[u8]) -> Result<(), NetError> {
            self.0.sleep(Duration::from_secs(1)).await;
            Ok(())
        }
        async fn close(&mut self) {}
        fn remote(&self) -> Option<SocketAddrV4> {
            None
        }
    }

    #[test]
    fn an_answer_taken_slowly_ends_at_the_answer_deadline() {
        let clock = VirtualClock::new();
        let slots = Slots::new(NAME, &LIMITS);
        let ex = Exchange::new(&clock, slots.session(0));
        let mut sock = SlowReader(&clock);
        let mut conn = Conn::new(&mut sock, &ex);
        let (_, mut w) = conn.split();
        // The page is ~12 KiB: 24 writes, 24 s at this pace.
        let page = [b'x'; 12 * 1024];
        let mut write = pin!(w.write_all(&page));
        let mut cx = Context::from_waker(Waker::noop());
        let got = loop {
            if let Poll::Ready(r) = write.as_mut().poll(&mut cx) {
                break r;
            }
            let next = clock.next_deadline().expect("a write waits for time");
            clock.advance_to(next);
        };
        assert_eq!(got, Err(IoError::Slow));
        assert_eq!(clock.now(), Instant::from_ticks(0) + ANSWER_DEADLINE);
    }
}
