//! The MQTT 3.1.1 packets the edge node uses, written and read in fixed
//! buffers (OASIS MQTT 3.1.1, section 2 and 3).
//!
//! Every packet is a fixed header (the type in the high nibble of byte 0,
//! flags in the low nibble, then the "remaining length" as a varint of 1 to
//! 4 bytes, 7 bits each, least significant first) followed by that many
//! bytes. Strings are a big-endian `u16` length and UTF-8 bytes.
//!
//! Out: CONNECT (clean session, a Will of QoS 1 not retained, keep-alive),
//! PUBLISH QoS 0, PUBACK (for a QoS 1 PUBLISH a broker might still send),
//! SUBSCRIBE, PINGREQ, DISCONNECT. In: CONNACK, SUBACK, PUBLISH, PINGRESP;
//! other types are returned as [`Packet::Other`] and ignored by the client.

/// The packet would not fit the buffer (or a field its 16-bit length).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TooLong;

/// The largest remaining length MQTT can express (4 varint bytes).
pub const REMAINING_MAX: usize = 268_435_455;

/// A writer into a fixed buffer.
struct Out<'a> {
    buf: &'a mut [u8],
    len: usize,
}

impl Out<'_> {
    fn bytes(&mut self, b: &[u8]) -> Result<(), TooLong> {
        let end = self.len.checked_add(b.len()).ok_or(TooLong)?;
        self.buf
            .get_mut(self.len..end)
            .ok_or(TooLong)?
            .copy_from_slice(b);
        self.len = end;
        Ok(())
    }
    fn u16(&mut self, v: u16) -> Result<(), TooLong> {
        self.bytes(&v.to_be_bytes())
    }
    fn str(&mut self, s: &[u8]) -> Result<(), TooLong> {
        self.u16(u16::try_from(s.len()).map_err(|_| TooLong)?)?;
        self.bytes(s)
    }
}

/// Writes a fixed header for `remaining` bytes into `out`; its length.
fn header(out: &mut [u8], first: u8, remaining: usize) -> Result<usize, TooLong> {
    if remaining > REMAINING_MAX {
        return Err(TooLong);
    }
    let mut o = Out { buf: out, len: 0 };
    o.bytes(&[first])?;
    let mut n = remaining;
    loop {
        let mut b = (n % 128) as u8;
        n /= 128;
        if n > 0 {
            b |= 0x80;
        }
        o.bytes(&[b])?;
        if n == 0 {
            return Ok(o.len);
        }
    }
}

/// Length of an MQTT string of `n` bytes.
const fn s(n: usize) -> usize {
    2 + n
}

/// The Will of a CONNECT.
#[derive(Clone, Copy, Debug)]
pub struct Will<'a> {
    /// Its topic.
    pub topic: &'a str,
    /// Its payload.
    pub payload: &'a [u8],
    /// Its QoS (0 or 1).
    pub qos: u8,
}

/// Writes a CONNECT (protocol level 4, clean session) into `buf`; its length.
pub fn connect(
    buf: &mut [u8],
    client_id: &str,
    keep_alive_s: u16,
    will: Option<Will<'_>>,
    user: Option<(&str, &[u8])>,
) -> Result<usize, TooLong> {
    let mut flags = 0x02u8;
    let mut rest = 10 + s(client_id.len());
    if let Some(w) = will {
        flags |= 0x04 | ((w.qos & 0x03) << 3);
        rest += s(w.topic.len()) + s(w.payload.len());
    }
    if let Some((u, p)) = user {
        flags |= 0x80 | 0x40;
        rest += s(u.len()) + s(p.len());
    }
    let h = header(buf, 0x10, rest)?;
    let mut o = Out { buf, len: h };
    o.str(b"MQTT")?;
    o.bytes(&[4, flags])?;
    o.u16(keep_alive_s)?;
    o.str(client_id.as_bytes())?;
    if let Some(w) = will {
        o.str(w.topic.as_bytes())?;
        o.str(w.payload)?;
    }
    if let Some((u, p)) = user {
        o.str(u.as_bytes())?;
        o.str(p)?;
    }
    Ok(o.len)
}

/// Writes the header of a PUBLISH QoS 0, not retained, of `topic` (the
/// payload of `payload_len` bytes follows it on the wire); its length.
pub fn publish_head(buf: &mut [u8], topic: &str, payload_len: usize) -> Result<usize, TooLong> {
    let h = header(buf, 0x30, s(topic.len()) + payload_len)?;
    let mut o = Out { buf, len: h };
    o.str(topic.as_bytes())?;
    Ok(o.len)
}

/// Writes a SUBSCRIBE (packet id `id`) of `topics`, each at QoS 0.
pub fn subscribe(buf: &mut [u8], id: u16, topics: &[&str]) -> Result<usize, TooLong> {
    let rest = 2 + topics.iter().map(|t| s(t.len()) + 1).sum::<usize>();
    let h = header(buf, 0x82, rest)?;
    let mut o = Out { buf, len: h };
    o.u16(id)?;
    for t in topics {
        o.str(t.as_bytes())?;
        o.bytes(&[0])?;
    }
    Ok(o.len)
}

/// PINGREQ.
pub const PINGREQ: [u8; 2] = [0xC0, 0];
/// DISCONNECT.
pub const DISCONNECT: [u8; 2] = [0xE0, 0];

/// A PUBACK for packet `id`.
pub fn puback(id: u16) -> [u8; 4] {
    let [a, b] = id.to_be_bytes();
    [0x40, 2, a, b]
}

/// A packet from the broker.
#[derive(Debug, PartialEq, Eq)]
pub enum Packet<'a> {
    /// CONNACK: the return code (0 accepted; 1-5 refused).
    ConnAck {
        /// The return code.
        code: u8,
    },
    /// SUBACK: the packet id and whether every topic was granted.
    SubAck {
        /// Its packet id.
        id: u16,
        /// No topic answered 0x80 (failure).
        granted: bool,
    },
    /// PUBLISH.
    Publish {
        /// Its topic (not UTF-8: empty).
        topic: &'a str,
        /// Its QoS.
        qos: u8,
        /// Its packet id (QoS 1 and 2).
        id: Option<u16>,
        /// Its payload.
        payload: &'a [u8],
    },
    /// PINGRESP.
    PingResp,
    /// Any other type (the first byte).
    Other(u8),
}

/// What the framer found at the start of a buffer.
#[derive(Debug, PartialEq, Eq)]
pub enum Frame {
    /// More bytes are needed.
    Incomplete,
    /// A whole packet of `len` bytes.
    Whole {
        /// Header and body.
        len: usize,
    },
    /// A packet of `len` bytes, longer than the buffer of `max`.
    TooLong {
        /// Its whole length.
        len: usize,
    },
    /// The remaining length has more than 4 bytes.
    Malformed,
}

/// Frames the bytes at the start of `b`, for a buffer of `max` bytes.
pub fn frame(b: &[u8], max: usize) -> Frame {
    let mut n = 0usize;
    let mut mult = 1usize;
    for i in 1..=4usize {
        let Some(&byte) = b.get(i) else {
            return Frame::Incomplete;
        };
        n += usize::from(byte & 0x7f) * mult;
        mult *= 128;
        if byte & 0x80 == 0 {
            let len = i + 1 + n;
            return if len > max {
                Frame::TooLong { len }
            } else if b.len() >= len {
                Frame::Whole { len }
            } else {
                Frame::Incomplete
            };
        }
    }
    Frame::Malformed
}

/// Reads a whole packet `p` (as framed by [`frame`]); `None` if its body
/// is short for its type.
pub fn parse(p: &[u8]) -> Option<Packet<'_>> {
    let first = *p.first()?;
    let mut i = 1;
    while p.get(i)? & 0x80 != 0 {
        i += 1;
    }
    let body = p.get(i + 1..)?;
    let u16_at =
        |k: usize| -> Option<u16> { Some(u16::from_be_bytes([*body.get(k)?, *body.get(k + 1)?])) };
    Some(match first >> 4 {
        2 => Packet::ConnAck {
            code: *body.get(1)?,
        },
        9 => Packet::SubAck {
            id: u16_at(0)?,
            granted: body.get(2..)?.iter().all(|c| *c != 0x80),
        },
        3 => {
            let qos = (first >> 1) & 0x03;
            let tl = usize::from(u16_at(0)?);
            let topic = core::str::from_utf8(body.get(2..2 + tl)?).unwrap_or("");
            let mut k = 2 + tl;
            let id = if qos > 0 {
                let id = u16_at(k)?;
                k += 2;
                Some(id)
            } else {
                None
            };
            Packet::Publish {
                topic,
                qos,
                id,
                payload: body.get(k..)?,
            }
        }
        13 => Packet::PingResp,
        _ => Packet::Other(first),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn connect_with_will_is_the_specifications_bytes() {
        let mut b = [0u8; 64];
        let will = Will {
            topic: "t",
            payload: b"xy",
            qos: 1,
        };
        let n = connect(&mut b, "id", 30, Some(will), None).unwrap();
        assert_eq!(
            &b[..n],
            &[
                0x10, 21, 0, 4, b'M', b'Q', b'T', b'T', 4, 0x0E, 0, 30, 0, 2, b'i', b'd', 0, 1,
                b't', 0, 2, b'x', b'y'
            ]
        );
    }

    #[test]
    fn remaining_length_takes_more_bytes_past_127() {
        let mut b = [0u8; 8];
        let n = publish_head(&mut b, "ab", 200).unwrap();
        // 2 + 2 + 200 = 204 = 0x4C + 1 * 128
        assert_eq!(&b[..n], &[0x30, 0xCC, 0x01, 0, 2, b'a', b'b']);
        let mut whole = [0u8; 211];
        whole[..n].copy_from_slice(&b[..n]);
        assert_eq!(frame(&whole, 256), Frame::Whole { len: 207 });
        assert_eq!(frame(&whole[..100], 256), Frame::Incomplete);
        assert_eq!(frame(&whole, 100), Frame::TooLong { len: 207 });
        assert_eq!(
            frame(&[0x30, 0xff, 0xff, 0xff, 0xff, 1], 9),
            Frame::Malformed
        );
    }

    #[test]
    fn reads_the_brokers_packets() {
        assert_eq!(parse(&[0x20, 2, 0, 5]), Some(Packet::ConnAck { code: 5 }));
        assert_eq!(
            parse(&[0x90, 4, 0, 7, 0, 0x80]),
            Some(Packet::SubAck {
                id: 7,
                granted: false
            })
        );
        assert_eq!(
            parse(&[0x32, 7, 0, 1, b'a', 0, 9, 1, 2]),
            Some(Packet::Publish {
                topic: "a",
                qos: 1,
                id: Some(9),
                payload: &[1, 2]
            })
        );
        assert_eq!(parse(&[0xD0, 0]), Some(Packet::PingResp));
        assert_eq!(parse(&[0x30, 3, 0, 5, b'a']), None);
        let mut b = [0u8; 40];
        let n = subscribe(&mut b, 1, &["a/b", "c"]).unwrap();
        assert_eq!(
            &b[..n],
            &[0x82, 12, 0, 1, 0, 3, b'a', b'/', b'b', 0, 0, 1, b'c', 0]
        );
        assert_eq!(connect(&mut b[..10], "id", 1, None, None), Err(TooLong));
    }
}
