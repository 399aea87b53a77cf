//! A PLC: a Modbus TCP client on the simulated network. It writes frames
//! and reads answers; the world runs the gateway in between.

use std::vec::Vec;

use super::net::SimStream;

/// What a request got.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Answer {
    /// The response PDU (function code first).
    Pdu(Vec<u8>),
    /// A Modbus exception: its code.
    Exception(u8),
}

/// A Modbus TCP client.
pub struct Plc {
    stream: SimStream,
    tid: u16,
    rx: Vec<u8>,
}

impl Plc {
    /// A client on `stream`.
    pub fn new(stream: SimStream) -> Self {
        Plc {
            stream,
            tid: 0,
            rx: Vec::new(),
        }
    }

    /// Sends `pdu` (unit id 1); returns its transaction id.
    pub fn send(&mut self, pdu: &[u8]) -> u16 {
        self.tid = self.tid.wrapping_add(1);
        let mut f = Vec::with_capacity(7 + pdu.len());
        f.extend_from_slice(&self.tid.to_be_bytes());
        f.extend_from_slice(&[0, 0]);
        f.extend_from_slice(&((pdu.len() + 1) as u16).to_be_bytes());
        f.push(1);
        f.extend_from_slice(pdu);
        self.stream.write(&f);
        self.tid
    }

    /// Sends raw bytes (malformed frames).
    pub fn send_raw(&mut self, bytes: &[u8]) {
        self.stream.write(bytes);
    }

    /// The connection is open.
    pub fn is_open(&self) -> bool {
        self.stream.is_open()
    }

    /// Closes the connection.
    pub fn close(&mut self) {
        self.stream.close();
    }

    /// The answer to transaction `tid`, once whole (answers to other
    /// transactions are dropped).
    pub fn answer(&mut self, tid: u16) -> Option<Answer> {
        self.rx.extend(self.stream.read());
        loop {
            if self.rx.len() < 7 {
                return None;
            }
            let len = usize::from(u16::from_be_bytes([self.rx[4], self.rx[5]]));
            if self.rx.len() < 6 + len {
                return None;
            }
            let adu: Vec<u8> = self.rx.drain(..6 + len).collect();
            if u16::from_be_bytes([adu[0], adu[1]]) != tid {
                continue;
            }
            let pdu = adu.get(7..).unwrap_or(&[]).to_vec();
            return Some(match pdu.first() {
                Some(fc) if fc & 0x80 != 0 => Answer::Exception(pdu.get(1).copied().unwrap_or(0)),
                _ => Answer::Pdu(pdu),
            });
        }
    }
}

/// PDU builders.
pub mod pdu {
    use std::vec::Vec;

    /// FC 3: read holding registers.
    pub fn read(addr: u16, count: u16) -> Vec<u8> {
        let mut p = std::vec![3];
        p.extend_from_slice(&addr.to_be_bytes());
        p.extend_from_slice(&count.to_be_bytes());
        p
    }

    /// FC 16: write multiple registers.
    pub fn write(addr: u16, values: &[u16]) -> Vec<u8> {
        let mut p = std::vec![16];
        p.extend_from_slice(&addr.to_be_bytes());
        p.extend_from_slice(&(values.len() as u16).to_be_bytes());
        p.push((values.len() * 2) as u8);
        for v in values {
            p.extend_from_slice(&v.to_be_bytes());
        }
        p
    }

    /// FC 6: write single register.
    pub fn write_one(addr: u16, value: u16) -> Vec<u8> {
        let mut p = std::vec![6];
        p.extend_from_slice(&addr.to_be_bytes());
        p.extend_from_slice(&value.to_be_bytes());
        p
    }

    /// FC 5: write single coil (`on`: 0xFF00, else 0x0000).
    pub fn coil(bit: u16, on: bool) -> Vec<u8> {
        let mut p = std::vec![5];
        p.extend_from_slice(&bit.to_be_bytes());
        p.extend_from_slice(&[if on { 0xFF } else { 0 }, 0]);
        p
    }

    /// The registers of an FC 3 / FC 4 response.
    pub fn registers(pdu: &[u8]) -> Vec<u16> {
        pdu.get(2..)
            .unwrap_or(&[])
            .chunks_exact(2)
            .map(|c| u16::from_be_bytes([c[0], c[1]]))
            .collect()
    }
}
