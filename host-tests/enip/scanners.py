#!/usr/bin/env python3
"""The hans-enip adapter (examples/loopback_adapter.rs) against EtherNet/IP
implementations nobody here wrote, on loopback:

  * pycomm3: ListIdentity, Get_Attributes_All of the Identity, generic
    messages on the assemblies, the TCP/IP and Ethernet Link objects, both
    unconnected and over a class 3 connection (its Large_Forward_Open is
    refused for its 4000-byte size, and it falls back to a Forward_Open of
    500 bytes, as against any small device);
  * cpppo: its client (ListIdentity, ListServices, get_attribute) and so its
    own encapsulation parser on every reply;
  * ethernetip (PyPI): class 1 I/O, Forward_Open, cyclic UDP at the RPI,
    Forward_Close, then a second connection whose scanner stops, which the
    adapter must report as a timeout.

Usage: scanners.py ADAPTER_BINARY [--io-seconds N] [--rpi-ms N] [--ports-file F]
Prints one line per check and "N passed, M failed" at the end; exit 1 on a
failure. Every wait is bounded.
"""

import argparse
import re
import socket
import struct
import subprocess
import sys
import threading
import time

RESULTS = []


def check(name, ok, detail=""):
    RESULTS.append(ok)
    print(f"{'ok  ' if ok else 'FAIL'} {name}{': ' + detail if detail else ''}", flush=True)
    return ok


class Adapter:
    """The runner as a child process; its output lines are collected."""

    def __init__(self, binary, seconds):
        self.proc = subprocess.Popen(
            [binary, "--bind", "127.0.0.1", "--port", "0", "--io-port", "0", "--seconds", str(seconds)],
            stdout=subprocess.PIPE, text=True, bufsize=1)
        first = self.proc.stdout.readline()
        m = re.match(r"listening tcp=(\d+) udp=(\d+) io=(\d+)", first)
        if not m:
            raise SystemExit(f"adapter did not start: {first!r}")
        self.port, self.io_port = int(m.group(1)), int(m.group(3))
        self.lines = []
        self.cv = threading.Condition()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        for line in self.proc.stdout:
            with self.cv:
                self.lines.append(line.strip())
                self.cv.notify_all()

    def wait_for(self, pattern, timeout, start=0):
        """The first line from index `start` matching `pattern`, waiting up to `timeout` s."""
        deadline = time.monotonic() + timeout
        with self.cv:
            while True:
                for i, line in enumerate(self.lines[start:], start):
                    m = re.search(pattern, line)
                    if m:
                        return m, i
                left = deadline - time.monotonic()
                if left <= 0:
                    return None, len(self.lines)
                self.cv.wait(left)

    def stop(self):
        self.proc.terminate()
        try:
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.proc.kill()


def pycomm3_checks(a):
    from pycomm3 import CIPDriver
    # route_path=False on unconnected messages: pycomm3 otherwise appends its
    # (empty) route path after the request data, for targets that route;
    # this adapter does not route and, as the specification says, answers
    # surplus request data with "too much data".
    path = f"127.0.0.1:{a.port}"
    ident = CIPDriver.list_identity(path)
    check("pycomm3 ListIdentity", ident is not None and ident["product_name"] == "hans-enip loopback"
          and ident["vendor"] is not None and ident["serial"] == "00c0ffee", repr(ident))
    with CIPDriver(path) as d:
        r = d.generic_message(service=0x01, class_code=0x01, instance=1, connected=False, route_path=False, name="gaa")
        v = r.value or b""
        ok = (not r.error and len(v) >= 15 and struct.unpack_from("<HHH", v) == (0xFFFE, 0x0C, 1)
              and v[6:8] == b"\x01\x01" and struct.unpack_from("<I", v, 10)[0] == 0x00C0FFEE
              and v[15:15 + v[14]] == b"hans-enip loopback")
        check("pycomm3 Get_Attributes_All (Identity)", ok, f"{v.hex()} {r.error}")
        for connected in (False, True):
            kind = "class 3" if connected else "unconnected"
            data = bytes(range(1, 33))
            w = d.generic_message(service=0x10, class_code=0x04, instance=150, attribute=3,
                                  request_data=data, connected=connected, route_path=False, name="set")
            check(f"pycomm3 Set_Attribute_Single assembly 150 ({kind})", not w.error, str(w.error))
            r = d.generic_message(service=0x0E, class_code=0x04, instance=100, attribute=3,
                                  connected=connected, route_path=False, name="get")
            check(f"pycomm3 Get_Attribute_Single assembly 100 echoes ({kind})",
                  not r.error and r.value[:31] == data[:31] and len(r.value) == 32, f"{r.value!r} {r.error}")
            r = d.generic_message(service=0x10, class_code=0x04, instance=100, attribute=3,
                                  request_data=data, connected=connected, route_path=False, name="set input")
            check(f"pycomm3 Set on the input assembly is refused ({kind})",
                  bool(r.error) and "not settable" in str(r.error).lower(), str(r.error))
        check("pycomm3 class 3 connection open (Large_Forward_Open refused, Forward_Open of 500 accepted)",
              d._target_is_connected and d.connection_size == 500, f"size {d.connection_size}")
        r = d.generic_message(service=0x0E, class_code=0xF5, instance=1, attribute=5, connected=False, route_path=False)
        check("pycomm3 TCP/IP Interface attribute 5", not r.error and r.value[:4] == bytes([1, 0, 0, 127]),
              repr(r.value))
        r = d.generic_message(service=0x0E, class_code=0xF5, instance=1, attribute=6, connected=False, route_path=False)
        check("pycomm3 TCP/IP Interface attribute 6 (host name)", r.value == b"\x08\x00loopback", repr(r.value))
        r = d.generic_message(service=0x0E, class_code=0xF6, instance=1, attribute=3, connected=False, route_path=False)
        check("pycomm3 Ethernet Link attribute 3 (MAC)", r.value == bytes([2, 0, 0, 0, 0, 1]), repr(r.value))
    # Leaving the with-block sent Forward_Close and UnRegisterSession.
    m, _ = a.wait_for(r"closed .*kind=Explicit reason=ForwardClose", 5)
    check("pycomm3 Forward_Close closes its class 3 connection", m is not None)


def cpppo_checks(a):
    from cpppo.server import enip
    from cpppo.server.enip import client
    with client.connector(host="127.0.0.1", port=a.port, timeout=5) as conn:
        conn.list_identity(timeout=5)
        rsp, _ = client.await_response(conn, timeout=5)
        ident = rsp.enip.CIP.list_identity.CPF.item[0].identity_object if rsp else None
        check("cpppo ListIdentity (its parser)", ident is not None
              and ident.product_name == "hans-enip loopback" and ident.vendor_id == 0xFFFE
              and ident.sin_port == a.port, enip.enip_format(rsp) if rsp else "no reply")
        conn.list_services(timeout=5)
        rsp, _ = client.await_response(conn, timeout=5)
        item = rsp.enip.CIP.list_services.CPF.item[0] if rsp else None
        check("cpppo ListServices", item is not None
              and item.communications_service.service_name == "Communications",
              enip.enip_format(rsp) if rsp else "no reply")
    base = [sys.executable, "-m", "cpppo.server.enip.get_attribute", "-a", f"127.0.0.1:{a.port}", "-S",
            "-t", "5"]
    tags = ["@1/1/1", "@1/1/7", "@4/100/3", "@0xF6/1/1"]
    out = subprocess.run(base + tags, capture_output=True, text=True, timeout=30)
    text = out.stdout + out.stderr
    values = dict(re.findall(r"(@\S+) == (\[[^\]]*\])", text))
    name = "".join(chr(c) for c in eval(values.get("@0x0001/1/7", "[0]"))[1:])
    check("cpppo get_attribute (Identity, Assembly, Ethernet Link)",
          out.returncode == 0 and values.get("@0x0001/1/1") == "[254, 255]" and name == "hans-enip loopback"
          and len(eval(values.get("@0x0004/100/3", "[]"))) == 32 and values.get("@0x00F6/1/1") == "[232, 3, 0, 0]",
          text.strip()[-400:])
    out = subprocess.run(base + ["@4/150/3=(USINT)" + ",".join(str(i) for i in range(32)), "@4/100/3"],
                         capture_output=True, text=True, timeout=30)
    text = out.stdout + out.stderr
    values = dict(re.findall(r"(@\S+) == (\[[^\]]*\]|True|False)", text))
    echoed = eval(values.get("@0x0004/100/3", "[]"))
    check("cpppo Set_Attribute_Single then Get (echo)",
          out.returncode == 0 and values.get("@0x0004/150/3") == "True" and echoed[:31] == list(range(31)),
          text.strip()[-400:])


def free_udp_port():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    p = s.getsockname()[1]
    s.close()
    return p


def io_checks(a, seconds, rpi_ms, multiplier):
    import ethernetip
    mod = sys.modules["ethernetip.ethernetip"]
    # The scanner's ports are module constants: point them at the runner.
    mod.ENIP_TCP_PORT = a.port
    mod.ENIP_UDP_PORT = a.io_port
    # Record every T->O datagram the scanner takes: its sequence numbers and arrival times.
    seen = []
    orig = mod.UdpRecvDataPacket

    class Recording(orig):
        def __init__(self, *args, **kw):
            super().__init__(*args, **kw)
            seen.append((time.monotonic(), self.conn_id, self.seq_num, bytes(self.data)))

    mod.UdpRecvDataPacket = Recording
    scanner_port = free_udp_port()

    class LoopbackEnip(ethernetip.EtherNetIP):
        def startIO(self, udp_port=None):  # bind loopback only (the library binds 0.0.0.0)
            with self._io_state_lock:
                if self.io_state == 0:
                    self.udpsock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                    self.udpsock.bind(("127.0.0.1", udp_port))
                    self.originator_udp_port = udp_port
                    self.udpthread = mod.EthernetIOThread(1, self)
                    self.io_state = 1
                    self.udpthread.start()

    enip = LoopbackEnip("127.0.0.1")
    conn = enip.explicit_conn("127.0.0.1")
    check("ethernetip RegisterSession", conn.registerSession() == 0)
    inp = enip.registerAssembly(ethernetip.EtherNetIP.ENIP_IO_TYPE_INPUT, 32, 100, conn)
    out = enip.registerAssembly(ethernetip.EtherNetIP.ENIP_IO_TYPE_OUTPUT, 32, 150, conn)
    enip.startIO(udp_port=scanner_port)
    start_line = len(a.lines)
    r = conn.sendFwdOpenReq(100, 150, 1, torpi=rpi_ms, otrpi=rpi_ms, multiplier=multiplier,
                            originator_udp_port=scanner_port)
    check(f"ethernetip Forward_Open (class 1, exclusive owner, {rpi_ms} ms RPI)", r == 0, f"returned {r}")
    m, _ = a.wait_for(r"opened id=(\S+) kind=ExclusiveOwner rpi_us=(\d+)", 5, start_line)
    check("adapter reports the connection opened", m is not None and int(m.group(2)) == rpi_ms * 1000)
    conn.produce()
    # Write a pattern into the output bits; the input must echo it.
    pattern = [1, 0, 1, 1, 0, 0, 1, 0] * 31
    t0 = time.monotonic()
    for i, bit in enumerate(pattern):
        out[i] = bool(bit)
    echoed = False
    while time.monotonic() - t0 < 5:
        if [1 if b else 0 for b in inp[:len(pattern)]] == pattern:
            echoed = True
            break
        time.sleep(0.01)
    check("class 1: the input assembly echoes the output assembly", echoed,
          f"after {time.monotonic() - t0:.3f} s")
    time.sleep(max(0, seconds - (time.monotonic() - t0)))
    conn.stopProduce()
    # The library's producer thread ends after its current sleep; one that
    # is still asleep when produce() is called again carries on beside the
    # new one (a race in the scanner), so wait for it.
    conn.prod_thread.join(timeout=2)
    t_end = time.monotonic()
    first_line = len(a.lines)
    r = conn.sendFwdCloseReq(100, 150, 1)
    check("ethernetip Forward_Close", r == 0, f"returned {r}")
    m, _ = a.wait_for(r"closed id=\S+ kind=ExclusiveOwner reason=ForwardClose received=(\d+) missed=(\d+) produced=(\d+)",
                      5, first_line)
    check("adapter reports the Forward_Close", m is not None)
    # T->O as the scanner saw it during the run.
    run = [s for s in seen if s[0] <= t_end]
    seqs = [s[2] for s in run]
    gaps = sum(b - a_ - 1 for a_, b in zip(seqs, seqs[1:]) if b > a_)
    dts = [b[0] - a_[0] for a_, b in zip(run, run[1:])]
    mean = sum(dts) / len(dts) * 1000 if dts else 0
    worst = max(dts) * 1000 if dts else 0
    in_order = all(b > a_ for a_, b in zip(seqs, seqs[1:]))
    check("T->O: sequence numbers increase, none missed", in_order and gaps == 0 and len(run) > 0,
          f"{len(run)} datagrams, {gaps} missed")
    # The interval is a figure (printed below), not a speed goal: the bound
    # only catches a wrong rate (a unit error, a doubled or skipped RPI),
    # not the jitter of a loaded machine.
    check(f"T->O: produced at the {rpi_ms} ms RPI (mean interval within 0.9-1.5 x)",
          rpi_ms * 0.9 <= mean <= rpi_ms * 1.5, f"mean {mean:.2f} ms, longest {worst:.2f} ms")
    if m:
        received, missed, produced = (int(x) for x in m.groups())
        check("O->T: none missed (by the adapter's sequence numbers)", missed == 0 and received > 0,
              f"received {received}, missed {missed}, produced {produced}")
    print(f"figures: rpi_ms={rpi_ms} seconds={seconds} t_o_received={len(run)} t_o_missed={gaps} "
          f"t_o_mean_ms={mean:.3f} t_o_max_ms={worst:.3f}"
          + (f" o_t_received={m.group(1)} o_t_missed={m.group(2)}" if m else ""), flush=True)

    # A second connection whose scanner stops: the adapter closes it at RPI x 4 << multiplier.
    start_line = len(a.lines)
    r = conn.sendFwdOpenReq(100, 150, 1, torpi=rpi_ms, otrpi=rpi_ms, multiplier=multiplier,
                            originator_udp_port=scanner_port)
    check("ethernetip Forward_Open again", r == 0, f"returned {r}")
    conn.produce()
    time.sleep(1.0)
    conn.stopProduce()
    stopped = time.monotonic()
    timeout_s = rpi_ms * (4 << multiplier) / 1000
    m, _ = a.wait_for(r"closed id=\S+ kind=ExclusiveOwner reason=TimedOut", timeout_s + 3, start_line)
    took = time.monotonic() - stopped
    check(f"a scanner that stops is detected as a timeout (RPI x {4 << multiplier} = {timeout_s * 1000:.0f} ms)",
          m is not None and took >= timeout_s * 0.5, f"after {took * 1000:.0f} ms")
    print(f"figures: timeout_expected_ms={timeout_s * 1000:.0f} timeout_detected_after_ms={took * 1000:.0f}",
          flush=True)
    enip.stopIO()
    conn.unregisterSession() if hasattr(conn, "unregisterSession") else None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("adapter")
    ap.add_argument("--io-seconds", type=float, default=20)
    ap.add_argument("--rpi-ms", type=int, default=10)
    ap.add_argument("--multiplier", type=int, default=3)
    ap.add_argument("--ports-file", help="write 'tcp io' ports here once the adapter listens")
    ap.add_argument("--ready-file", help="wait for this file before testing (e.g. a capture started)")
    args = ap.parse_args()
    a = Adapter(args.adapter, seconds=int(args.io_seconds) + 90)
    try:
        if args.ports_file:
            with open(args.ports_file, "w") as f:
                f.write(f"{a.port} {a.io_port}\n")
        if args.ready_file:
            import os
            deadline = time.monotonic() + 30
            while not os.path.exists(args.ready_file) and time.monotonic() < deadline:
                time.sleep(0.05)
        for name, f in (("pycomm3", lambda: pycomm3_checks(a)), ("cpppo", lambda: cpppo_checks(a)),
                        ("ethernetip", lambda: io_checks(a, args.io_seconds, args.rpi_ms, args.multiplier))):
            try:
                f()
            except Exception as e:  # a crash of a check is a failed check, and the others still run
                import traceback
                traceback.print_exc()
                check(f"{name} checks ran to the end", False, repr(e))
        dropped = [l for l in a.lines if l.startswith("io dropped")]
        check("the adapter dropped no O->T datagram", not dropped, "; ".join(dropped[:3]))
    finally:
        a.stop()
    passed = sum(RESULTS)
    failed = len(RESULTS) - passed
    print(f"{passed} passed, {failed} failed")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
