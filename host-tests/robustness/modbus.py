"""A small blocking Modbus TCP client for the rig's PLC monitor and probes.

Only what the rig needs: FC 3 (read holding registers), FC 16 (write
multiple registers) and FC 23 (write, then read, in one round trip). Every
call has a deadline; a timeout, a closed connection or a reply that is not
the answer to the request raises `ModbusError`, after which the connection is
not used again (the caller reconnects).
"""

import socket
import struct
import time


class ModbusError(Exception):
    """The request failed: no answer in time, connection lost, bad answer."""


class Exception_(ModbusError):
    """The device answered with a Modbus exception."""

    def __init__(self, fc, code):
        super().__init__(f"exception {code} to FC {fc}")
        self.code = code


class Client:
    """One Modbus TCP connection (from `bind`, if given)."""

    def __init__(self, host, port=502, bind=None, timeout=1.0):
        self.timeout = timeout
        self.tid = 0
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            if bind:
                self.sock.bind((bind, 0))
            self.sock.settimeout(timeout)
            self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self.sock.connect((host, port))
        except OSError as e:
            self.sock.close()
            raise ModbusError(f"connect: {e}") from e

    def close(self):
        try:
            self.sock.close()
        except OSError:
            pass

    def local_port(self):
        return self.sock.getsockname()[1]

    def _recv_exact(self, n, deadline):
        buf = b""
        while len(buf) < n:
            left = deadline - time.monotonic()
            if left <= 0:
                raise ModbusError("timeout")
            self.sock.settimeout(left)
            try:
                chunk = self.sock.recv(n - len(buf))
            except socket.timeout as e:
                raise ModbusError("timeout") from e
            except OSError as e:
                raise ModbusError(f"recv: {e}") from e
            if not chunk:
                raise ModbusError("closed by the device")
            buf += chunk
        return buf

    def request(self, pdu):
        """Sends one PDU, returns the answer's PDU (function code first)."""
        self.tid = (self.tid + 1) & 0xFFFF
        adu = struct.pack(">HHHB", self.tid, 0, len(pdu) + 1, 1) + pdu
        deadline = time.monotonic() + self.timeout
        try:
            self.sock.settimeout(self.timeout)
            self.sock.sendall(adu)
        except OSError as e:
            raise ModbusError(f"send: {e}") from e
        head = self._recv_exact(7, deadline)
        tid, proto, length, _unit = struct.unpack(">HHHB", head)
        if proto != 0 or length < 2 or length > 254:
            raise ModbusError(f"bad MBAP header {head.hex()}")
        body = self._recv_exact(length - 1, deadline)
        if tid != self.tid:
            raise ModbusError(f"transaction {tid}, expected {self.tid}")
        if body[0] & 0x80:
            raise Exception_(body[0] & 0x7F, body[1] if len(body) > 1 else 0)
        if body[0] != pdu[0]:
            raise ModbusError(f"answer to FC {body[0]}, asked FC {pdu[0]}")
        return body

    def read(self, addr, n):
        body = self.request(struct.pack(">BHH", 3, addr, n))
        if len(body) != 2 + 2 * n or body[1] != 2 * n:
            raise ModbusError("FC 3: bad byte count")
        return list(struct.unpack(f">{n}H", body[2:]))

    def write(self, addr, values):
        values = list(values)
        pdu = struct.pack(">BHHB", 16, addr, len(values), 2 * len(values))
        pdu += struct.pack(f">{len(values)}H", *values)
        self.request(pdu)
        return True

    def write_read(self, waddr, values, raddr, n):
        """FC 23: writes `values` at `waddr`, then reads `n` from `raddr`."""
        values = list(values)
        pdu = struct.pack(">BHHHHB", 23, raddr, n, waddr, len(values), 2 * len(values))
        pdu += struct.pack(f">{len(values)}H", *values)
        body = self.request(pdu)
        if len(body) != 2 + 2 * n or body[1] != 2 * n:
            raise ModbusError("FC 23: bad byte count")
        return list(struct.unpack(f">{n}H", body[2:]))


def f32_words(v):
    """An f32 as two registers, high word first (CFG_FLOAT_WORD_ORDER 0)."""
    hi, lo = struct.unpack(">HH", struct.pack(">f", v))
    return [hi, lo]


def words_f32(w):
    return struct.unpack(">f", struct.pack(">HH", w[0], w[1]))[0]
