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
//! An answer can close the connection (a request whose body cannot be
//! delimited): the server sets the shared `closing` flag, after which the
//! read half sees the end of the stream and the write half refuses
//! ([`IoError::Closing`]), so that picoserve ends the connection even when
//! more bytes are already buffered as a next request.

use core::cell::{Cell, RefCell};
use core::future::Future;

use picoserve::io::embedded_io_async::{self, ErrorKind, ErrorType};
use picoserve::io::Read;
use picoserve::mem::{BorrowedBuffer, BorrowedCursor};

use crate::clock::Clock;
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
}

impl core::fmt::Display for IoError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            IoError::Net(e) => f.write_str(e.as_str()),
            IoError::Busy => f.write_str("socket busy"),
            IoError::Closing => f.write_str("connection closing"),
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

/// A connected socket, as picoserve sees it.
pub(crate) struct Conn<'s, S: Socket> {
    sock: RefCell<&'s mut S>,
    closing: &'s Cell<bool>,
}

impl<'s, S: Socket> Conn<'s, S> {
    /// Wraps a connected socket; once `closing` is set, the connection
    /// ends (see the module documentation).
    pub(crate) fn new(sock: &'s mut S, closing: &'s Cell<bool>) -> Self {
        Conn {
            sock: RefCell::new(sock),
            closing,
        }
    }
}

/// The read half.
pub(crate) struct ReadHalf<'c, 's, S: Socket> {
    sock: &'c RefCell<&'s mut S>,
    closing: &'s Cell<bool>,
}

/// The write half, with its buffer.
pub(crate) struct WriteHalf<'c, 's, S: Socket> {
    sock: &'c RefCell<&'s mut S>,
    closing: &'s Cell<bool>,
    buf: [u8; WRITE_BUF],
    len: usize,
}

impl<S: Socket> ErrorType for ReadHalf<'_, '_, S> {
    type Error = IoError;
}

impl<S: Socket> ErrorType for WriteHalf<'_, '_, S> {
    type Error = IoError;
}

impl<S: Socket> Read for ReadHalf<'_, '_, S> {
    // The borrow is held while the socket reads: see the module
    // documentation for why the other half cannot want it meanwhile.
    #[allow(clippy::await_holding_refcell_ref)]
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, IoError> {
        if self.closing.get() {
            return Ok(0);
        }
        let mut sock = self.sock.try_borrow_mut().map_err(|_| IoError::Busy)?;
        sock.read(buf).await.map_err(IoError::Net)
    }
}

impl<S: Socket> WriteHalf<'_, '_, S> {
    #[allow(clippy::await_holding_refcell_ref)]
    async fn drain(&mut self) -> Result<(), IoError> {
        if self.closing.get() {
            return Err(IoError::Closing);
        }
        if self.len == 0 {
            return Ok(());
        }
        let mut sock = self.sock.try_borrow_mut().map_err(|_| IoError::Busy)?;
        let data = self.buf.get(..self.len).unwrap_or(&[]);
        sock.write_all(data).await.map_err(IoError::Net)?;
        self.len = 0;
        Ok(())
    }
}

impl<S: Socket> embedded_io_async::Write for WriteHalf<'_, '_, S> {
    async fn write(&mut self, data: &[u8]) -> Result<usize, IoError> {
        if self.closing.get() {
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

impl<S: Socket> picoserve::io::Write for WriteHalf<'_, '_, S> {
    async fn write_with<F: FnOnce(BorrowedCursor<'_>) -> R, R>(
        &mut self,
        f: F,
    ) -> Result<R, IoError> {
        if self.closing.get() {
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

impl<'s, S: Socket> picoserve::io::Socket<GatewayRuntime> for Conn<'s, S> {
    type Error = IoError;
    type ReadHalf<'c>
        = ReadHalf<'c, 's, S>
    where
        Self: 'c;
    type WriteHalf<'c>
        = WriteHalf<'c, 's, S>
    where
        Self: 'c;

    fn split(&mut self) -> (Self::ReadHalf<'_>, Self::WriteHalf<'_>) {
        (
            ReadHalf {
                sock: &self.sock,
                closing: self.closing,
            },
            WriteHalf {
                sock: &self.sock,
                closing: self.closing,
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
