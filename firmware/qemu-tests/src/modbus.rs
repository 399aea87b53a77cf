//! A minimal blocking Modbus TCP client (function codes 1, 3, 4, 5, 6, 16),
//! enough to drive the gateway the way a PLC does. Every call has a timeout.
//!
//! Written here rather than taken from tokio-modbus so the QEMU tests need no
//! async runtime and no dependency at all; the MBAP framing is 7 bytes.

use std::io::{self, Read, Write};
use std::net::TcpStream;
use std::time::Duration;

/// What went wrong with a request.
#[derive(Debug)]
pub enum Error {
    /// The socket failed or timed out.
    Io(io::Error),
    /// The server answered with a Modbus exception code.
    Exception(u8),
    /// The answer does not match the request.
    Protocol(&'static str),
}

impl From<io::Error> for Error {
    fn from(e: io::Error) -> Self {
        Error::Io(e)
    }
}

/// One Modbus TCP connection.
pub struct Client {
    stream: TcpStream,
    transaction: u16,
    unit: u8,
}

impl Client {
    /// Wraps a connected stream; every read waits at most `timeout`.
    pub fn new(stream: TcpStream, timeout: Duration) -> io::Result<Client> {
        stream.set_read_timeout(Some(timeout))?;
        stream.set_write_timeout(Some(timeout))?;
        stream.set_nodelay(true)?;
        Ok(Client {
            stream,
            transaction: 0,
            unit: 1,
        })
    }

    /// The underlying stream (to shut it down abruptly, for instance).
    pub fn stream(&self) -> &TcpStream {
        &self.stream
    }

    fn call(&mut self, pdu: &[u8]) -> Result<Vec<u8>, Error> {
        self.transaction = self.transaction.wrapping_add(1);
        let len = u16::try_from(pdu.len() + 1).map_err(|_| Error::Protocol("PDU too long"))?;
        let mut frame = Vec::with_capacity(7 + pdu.len());
        frame.extend_from_slice(&self.transaction.to_be_bytes());
        frame.extend_from_slice(&0u16.to_be_bytes());
        frame.extend_from_slice(&len.to_be_bytes());
        frame.push(self.unit);
        frame.extend_from_slice(pdu);
        self.stream.write_all(&frame)?;

        let mut header = [0u8; 7];
        self.stream.read_exact(&mut header)?;
        let tid = u16::from_be_bytes([header[0], header[1]]);
        let proto = u16::from_be_bytes([header[2], header[3]]);
        let rlen = usize::from(u16::from_be_bytes([header[4], header[5]]));
        if tid != self.transaction || proto != 0 || !(2..=254).contains(&rlen) {
            return Err(Error::Protocol("bad MBAP header"));
        }
        let mut body = vec![0u8; rlen - 1];
        self.stream.read_exact(&mut body)?;
        match body.first() {
            Some(&f) if f == pdu[0] | 0x80 => {
                Err(Error::Exception(body.get(1).copied().unwrap_or(0)))
            }
            Some(&f) if f == pdu[0] => Ok(body),
            _ => Err(Error::Protocol("function code mismatch")),
        }
    }

    fn read_words(&mut self, function: u8, addr: u16, count: u16) -> Result<Vec<u16>, Error> {
        let mut pdu = vec![function];
        pdu.extend_from_slice(&addr.to_be_bytes());
        pdu.extend_from_slice(&count.to_be_bytes());
        let body = self.call(&pdu)?;
        let n = usize::from(*body.get(1).ok_or(Error::Protocol("short answer"))?);
        if n != usize::from(count) * 2 || body.len() != 2 + n {
            return Err(Error::Protocol("byte count mismatch"));
        }
        Ok(body[2..]
            .chunks(2)
            .map(|c| u16::from_be_bytes([c[0], c[1]]))
            .collect())
    }

    /// FC 3: read holding registers.
    pub fn read_holding(&mut self, addr: u16, count: u16) -> Result<Vec<u16>, Error> {
        self.read_words(3, addr, count)
    }

    /// FC 4: read input registers.
    pub fn read_input(&mut self, addr: u16, count: u16) -> Result<Vec<u16>, Error> {
        self.read_words(4, addr, count)
    }

    /// FC 1: read coils.
    pub fn read_coils(&mut self, addr: u16, count: u16) -> Result<Vec<bool>, Error> {
        let mut pdu = vec![1];
        pdu.extend_from_slice(&addr.to_be_bytes());
        pdu.extend_from_slice(&count.to_be_bytes());
        let body = self.call(&pdu)?;
        let n = usize::from(*body.get(1).ok_or(Error::Protocol("short answer"))?);
        if n != usize::from(count).div_ceil(8) || body.len() != 2 + n {
            return Err(Error::Protocol("byte count mismatch"));
        }
        Ok((0..usize::from(count))
            .map(|i| body[2 + i / 8] & (1 << (i % 8)) != 0)
            .collect())
    }

    /// FC 5: write one coil.
    pub fn write_coil(&mut self, addr: u16, on: bool) -> Result<(), Error> {
        let mut pdu = vec![5];
        pdu.extend_from_slice(&addr.to_be_bytes());
        pdu.extend_from_slice(if on { &[0xff, 0x00] } else { &[0x00, 0x00] });
        let body = self.call(&pdu)?;
        if body != pdu {
            return Err(Error::Protocol("echo mismatch"));
        }
        Ok(())
    }

    /// FC 6: write one register.
    pub fn write_register(&mut self, addr: u16, value: u16) -> Result<(), Error> {
        let mut pdu = vec![6];
        pdu.extend_from_slice(&addr.to_be_bytes());
        pdu.extend_from_slice(&value.to_be_bytes());
        let body = self.call(&pdu)?;
        if body != pdu {
            return Err(Error::Protocol("echo mismatch"));
        }
        Ok(())
    }

    /// FC 16: write consecutive registers.
    pub fn write_registers(&mut self, addr: u16, values: &[u16]) -> Result<(), Error> {
        let count = u16::try_from(values.len()).map_err(|_| Error::Protocol("too many"))?;
        let mut pdu = vec![16];
        pdu.extend_from_slice(&addr.to_be_bytes());
        pdu.extend_from_slice(&count.to_be_bytes());
        pdu.push(u8::try_from(values.len() * 2).map_err(|_| Error::Protocol("too many"))?);
        for v in values {
            pdu.extend_from_slice(&v.to_be_bytes());
        }
        let body = self.call(&pdu)?;
        if body.len() != 5 || body[1..5] != pdu[1..5] {
            return Err(Error::Protocol("echo mismatch"));
        }
        Ok(())
    }
}

/// Two registers holding an f32, high word first (the gateway's default).
pub fn f32_from_words(hi: u16, lo: u16) -> f32 {
    f32::from_bits((u32::from(hi) << 16) | u32::from(lo))
}

/// An f32 as two registers, high word first.
pub fn f32_to_words(v: f32) -> [u16; 2] {
    let bits = v.to_bits();
    [(bits >> 16) as u16, bits as u16]
}
