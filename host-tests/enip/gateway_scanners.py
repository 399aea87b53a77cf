#!/usr/bin/env python3
"""The real `hans-gateway` binary with its EtherNet/IP adapter on, hans-sim as
the robot, against scanners nobody here wrote, on loopback:

  * pycomm3 and cpppo: discovery (ListIdentity) and the Identity object;
  * ethernetip (PyPI): a class 1 exclusive-owner connection at 10 ms RPI for
    a bounded time (missed T->O datagrams counted by sequence number on the
    scanner's side, missed O->T datagrams by the gateway's own count:
    ENIP_MISSED and the owner connection's figures in its log), a
    MoveRelJ commanded through the output assembly and Done in the input
    assembly (Execute-to-Done measured), Forward_Close; then a second move
    whose scanner goes silent: the gateway's watchdog stops it (read over
    Modbus: WATCHDOG_TRIPS, the channel's Error).

Usage: gateway_scanners.py GATEWAY SIM --enip-port P --io-port Q [--io-seconds N]
Prints one line per check, "figures: ..." lines, and "N passed, M failed";
exit 1 on a failure. Every wait is bounded.
"""

import argparse
import os
import re
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time

RESULTS = []

# gateway/ENIP.md: byte offsets in the assemblies.
IN_CH0_STATUS, IN_CH0_SEQ, IN_CH0_ERROR, IN_OWNER = 96, 98, 100, 24
OUT_HEARTBEAT, OUT_CH0 = 0, 4
SIZE = 496
MOVE_REL_J = 13
ST_BUSY, ST_DONE, ST_ERROR = 1, 2, 4
# REGISTERS.md
WATCHDOG_TRIPS, CH0_STATUS, CH0_ERROR_ID = 48, 260, 262
ENIP_MISSED, ENIP_IO_DROPPED = 62, 63


def check(name, ok, detail=""):
    RESULTS.append(ok)
    print(f"{'ok  ' if ok else 'FAIL'} {name}{': ' + detail if detail else ''}", flush=True)
    return ok


def free_port(kind=socket.SOCK_STREAM):
    s = socket.socket(socket.AF_INET, kind)
    s.bind(("127.0.0.1", 0))
    p = s.getsockname()[1]
    s.close()
    return p


class Proc:
    """A child process whose output lines are collected."""

    def __init__(self, argv, env=None):
        self.proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                     bufsize=1, env=env)
        self.lines = []
        self.cv = threading.Condition()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        for line in self.proc.stdout:
            with self.cv:
                self.lines.append(line.rstrip())
                self.cv.notify_all()

    def wait_for(self, pattern, timeout, start=0):
        deadline = time.monotonic() + timeout
        with self.cv:
            while True:
                for line in self.lines[start:]:
                    m = re.search(pattern, line)
                    if m:
                        return m
                left = deadline - time.monotonic()
                if left <= 0:
                    return None
                self.cv.wait(left)

    def stop(self):
        self.proc.terminate()
        try:
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.proc.kill()


def modbus_read(port, addr, n):
    """Holding registers over Modbus TCP (function 3)."""
    with socket.create_connection(("127.0.0.1", port), timeout=3) as s:
        s.sendall(struct.pack(">HHHBBHH", 1, 0, 6, 1, 3, addr, n))
        head = s.recv(9)
        if len(head) < 9 or head[7] != 3:
            raise RuntimeError(f"modbus exception {head!r}")
        data = b""
        while len(data) < head[8]:
            data += s.recv(head[8] - len(data))
        return list(struct.unpack(f">{n}H", data))


def set_u16(bits, at, v):
    for i in range(16):
        bits[at * 8 + i] = bool((v >> i) & 1)


def set_real(bits, at, v):
    (u,) = struct.unpack("<I", struct.pack("<f", v))
    for i in range(32):
        bits[at * 8 + i] = bool((u >> i) & 1)


def get_u16(bits, at):
    return sum(1 << i for i in range(16) if bits[at * 8 + i])


def discovery_checks(port):
    from pycomm3 import CIPDriver
    ident = CIPDriver.list_identity(f"127.0.0.1:{port}")
    check("pycomm3 ListIdentity finds hans-gateway", ident is not None and ident["product_name"] == "hans-gateway"
          and ident["product_code"] == 1, repr(ident))
    with CIPDriver(f"127.0.0.1:{port}") as d:
        r = d.generic_message(service=0x01, class_code=0x01, instance=1, connected=False, route_path=False)
        v = r.value or b""
        check("pycomm3 Get_Attributes_All (Identity)", not r.error and struct.unpack_from("<HHH", v) == (0xFFFE, 0x0C, 1)
              and v[15:15 + v[14]] == b"hans-gateway", f"{v.hex()} {r.error}")
        r = d.generic_message(service=0x0E, class_code=0x04, instance=100, attribute=3, connected=False,
                              route_path=False)
        check("pycomm3 Get_Attribute_Single of the input assembly (496 bytes)",
              not r.error and len(r.value) == SIZE, f"{len(r.value or b'')} bytes {r.error}")
    from cpppo.server.enip import client
    with client.connector(host="127.0.0.1", port=port, timeout=5) as conn:
        conn.list_identity(timeout=5)
        rsp, _ = client.await_response(conn, timeout=5)
        ident = rsp.enip.CIP.list_identity.CPF.item[0].identity_object if rsp else None
        check("cpppo ListIdentity (its parser)", ident is not None and ident.product_name == "hans-gateway"
              and ident.vendor_id == 0xFFFE and ident.sin_port == port)


def io_checks(gw, port, io_port, modbus_port, seconds):
    import ethernetip
    mod = sys.modules["ethernetip.ethernetip"]
    mod.ENIP_TCP_PORT = port
    mod.ENIP_UDP_PORT = io_port
    seen = []
    orig = mod.UdpRecvDataPacket

    class Recording(orig):
        def __init__(self, *args, **kw):
            super().__init__(*args, **kw)
            seen.append((time.monotonic(), self.seq_num))

    mod.UdpRecvDataPacket = Recording
    scanner_port = free_port(socket.SOCK_DGRAM)

    class LoopbackEnip(ethernetip.EtherNetIP):
        def startIO(self, udp_port=None):
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
    inp = enip.registerAssembly(ethernetip.EtherNetIP.ENIP_IO_TYPE_INPUT, SIZE, 100, conn)
    out = enip.registerAssembly(ethernetip.EtherNetIP.ENIP_IO_TYPE_OUTPUT, SIZE, 150, conn)
    enip.startIO(udp_port=scanner_port)
    beat = [0]

    def heartbeat():
        beat[0] = (beat[0] + 1) & 0xFFFF
        set_u16(out, OUT_HEARTBEAT, beat[0])

    def open_conn(label, multiplier):
        start = len(gw.lines)
        r = conn.sendFwdOpenReq(100, 150, 1, torpi=10, otrpi=10, multiplier=multiplier,
                                originator_udp_port=scanner_port)
        check(f"ethernetip Forward_Open ({label}, exclusive owner, 10 ms RPI, timeout x{4 << multiplier})", r == 0,
              f"returned {r}")
        m = gw.wait_for(r"enip: connection \d+ opened", 5, start)
        check(f"the gateway logs the connection opened ({label})", m is not None)
        conn.produce()

    def fire(seq, degrees):
        set_u16(out, OUT_CH0, 0)
        set_u16(out, OUT_CH0 + 2, MOVE_REL_J)
        set_u16(out, OUT_CH0 + 4, seq)
        set_real(out, OUT_CH0 + 8, 0.0)
        set_real(out, OUT_CH0 + 12, degrees)
        for _ in range(5):
            heartbeat()
            time.sleep(0.02)
        set_u16(out, OUT_CH0, 1)

    # The minute's connection: timeout 10 ms x 128 = 1.28 s, so that a
    # scheduler stall on a loaded machine (CI's two cores) delays datagrams
    # without ending the connection; the sequence numbers still count every
    # datagram missed, and the longest interval is reported.
    open_conn("first", 5)
    t0 = time.monotonic()
    owner = False
    while time.monotonic() - t0 < 3 and not owner:
        heartbeat()
        owner = get_u16(inp, IN_OWNER) == 1
        time.sleep(0.02)
    check("COMMAND_OWNER in the input assembly says EtherNet/IP (1)", owner)
    fire(7, 2.0)
    t_exec = time.monotonic()
    status, busy_seen = 0, False
    while time.monotonic() - t_exec < 20:
        heartbeat()
        status = get_u16(inp, IN_CH0_STATUS)
        busy_seen |= bool(status & ST_BUSY)
        if status & (ST_DONE | ST_ERROR) and not status & ST_BUSY:
            break
        time.sleep(0.005)
    exec_to_done = time.monotonic() - t_exec
    check("a MoveRelJ through the assemblies: Busy then Done, sequence echoed",
          busy_seen and status == ST_DONE and get_u16(inp, IN_CH0_SEQ) == 7,
          f"status {status:#x} after {exec_to_done * 1000:.0f} ms")
    set_u16(out, OUT_CH0, 0)
    # The rest of the bounded run: I/O only, the heartbeat going.
    while time.monotonic() - t0 < seconds:
        heartbeat()
        time.sleep(0.05)
    conn.stopProduce()
    conn.prod_thread.join(timeout=2)
    t_end = time.monotonic()
    start = len(gw.lines)
    r = conn.sendFwdCloseReq(100, 150, 1)
    check("ethernetip Forward_Close", r == 0, f"returned {r}")
    check("the gateway logs the Forward_Close", gw.wait_for(r"closed \(Forward_Close", 5, start) is not None)
    # O->T as the gateway counted it: the owner connection's figures (its
    # log line at the close) and ENIP_MISSED over Modbus.
    m = gw.wait_for(r"owner connection \d+: (\d+) O->T datagrams received, (\d+) missed", 5, start)
    o_t_received, o_t_missed = (int(m.group(1)), int(m.group(2))) if m else (0, -1)
    missed_reg, dropped_reg = modbus_read(modbus_port, ENIP_MISSED, 2)
    o_t_expected = (t_end - t0) / 0.010
    check("O->T: the gateway missed none (its count for the owner connection, ENIP_MISSED)",
          m is not None and o_t_missed == 0 and missed_reg == 0 and o_t_received > 0,
          f"{o_t_received} received, {o_t_missed} missed, ENIP_MISSED {missed_reg}, ENIP_IO_DROPPED {dropped_reg}")
    check("O->T at the 10 ms RPI (received within 0.67-1.1 x what the RPI gives)",
          0.67 * o_t_expected <= o_t_received <= 1.1 * o_t_expected + 5,
          f"{o_t_received} received, {o_t_expected:.0f} by the RPI")
    run = [s for s in seen if t0 <= s[0] <= t_end]
    seqs = [s[1] for s in run]
    missed = sum(b - a - 1 for a, b in zip(seqs, seqs[1:]) if b > a)
    dts = [b[0] - a[0] for a, b in zip(run, run[1:])]
    mean = sum(dts) / len(dts) * 1000 if dts else 0
    worst = max(dts) * 1000 if dts else 0
    check("T->O: sequence numbers increase, none missed", len(run) > 0 and missed == 0
          and all(b > a for a, b in zip(seqs, seqs[1:])), f"{len(run)} datagrams, {missed} missed")
    check("T->O at the 10 ms RPI (mean interval within 0.9-1.5 x)", 9 <= mean <= 15,
          f"mean {mean:.2f} ms, longest {worst:.2f} ms")
    print(f"figures: rpi_ms=10 seconds={t_end - t0:.1f} t_o_received={len(run)} t_o_missed={missed} "
          f"t_o_mean_ms={mean:.3f} t_o_max_ms={worst:.3f} o_t_received={o_t_received} "
          f"o_t_by_rpi={o_t_expected:.0f} o_t_missed={o_t_missed} enip_missed={missed_reg} "
          f"enip_io_dropped={dropped_reg} execute_to_done_ms={exec_to_done * 1000:.0f}", flush=True)

    # The connection dropped during a motion: the watchdog's stop.
    trips0 = modbus_read(modbus_port, WATCHDOG_TRIPS, 1)[0]
    seen.clear()
    open_conn("second", 3)
    time.sleep(0.3)
    fire(8, 90.0)
    t_fire = time.monotonic()
    while time.monotonic() - t_fire < 3 and not get_u16(inp, IN_CH0_STATUS) & ST_BUSY:
        heartbeat()
        time.sleep(0.01)
    check("the second move is Busy", bool(get_u16(inp, IN_CH0_STATUS) & ST_BUSY))
    start = len(gw.lines)
    conn.stopProduce()  # the PLC goes silent: no Forward_Close
    t_drop = time.monotonic()
    m = gw.wait_for(r"heartbeat lost", 5, start)
    took = time.monotonic() - t_drop
    check("the silent connection times out during the motion: heartbeat lost", m is not None,
          f"after {took * 1000:.0f} ms (timeout 10 ms x 32 = 320 ms)")
    trips, status, err = None, None, None
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline:
        trips = modbus_read(modbus_port, WATCHDOG_TRIPS, 1)[0]
        status = modbus_read(modbus_port, CH0_STATUS, 1)[0]
        if trips > trips0 and not status & ST_BUSY:
            break
        time.sleep(0.05)
    e = modbus_read(modbus_port, CH0_ERROR_ID, 2)
    err = struct.unpack(">i", struct.pack(">HH", *e))[0]
    check("the watchdog stopped the motion (WATCHDOG_TRIPS + 1, CH0 Error)",
          trips == trips0 + 1 and status == ST_ERROR, f"trips {trips0}->{trips}, status {status}, ErrorID {err}")
    print(f"figures: connection_drop_to_stop_ms={took * 1000:.0f}", flush=True)
    enip.stopIO()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("gateway")
    ap.add_argument("sim")
    ap.add_argument("--enip-port", type=int, required=True)
    ap.add_argument("--io-port", type=int, required=True)
    ap.add_argument("--io-seconds", type=float, default=20)
    ap.add_argument("--ready-file", help="wait for this file before testing (e.g. a capture started)")
    args = ap.parse_args()
    robot_port, modbus_port = free_port(), free_port()
    tmp = tempfile.mkdtemp(prefix="enip-gw-")
    cfg = os.path.join(tmp, "gateway.toml")
    with open(cfg, "w") as f:
        f.write('[enip]\nenabled = true\n\n[watchdog]\nperiod_ms = 5000\naction = "stop"\n')
    sim = Proc([args.sim, "--host", "127.0.0.1", "--command-port", str(robot_port), "--datasheet-ports", "",
                "--ready"])
    time.sleep(0.5)
    env = dict(os.environ, RUST_LOG="info")
    gw = Proc([args.gateway, "--robot", f"127.0.0.1:{robot_port}", "--modbus-listen", f"127.0.0.1:{modbus_port}",
               "--enip-listen", f"127.0.0.1:{args.enip_port}", "--enip-io-port", str(args.io_port),
               "--config", cfg, "--setup-code-file", os.path.join(tmp, "setup-code")], env=env)
    try:
        up = gw.wait_for(r"enip: EtherNet/IP adapter on", 15)
        check("hans-gateway serves EtherNet/IP with enip.enabled", up is not None,
              "" if up else "\n".join(gw.lines[-5:]))
        if args.ready_file:
            deadline = time.monotonic() + 30
            while not os.path.exists(args.ready_file) and time.monotonic() < deadline:
                time.sleep(0.05)
        for name, f in (("discovery", lambda: discovery_checks(args.enip_port)),
                        ("class 1", lambda: io_checks(gw, args.enip_port, args.io_port, modbus_port,
                                                      args.io_seconds))):
            try:
                f()
            except Exception as e:  # a crash of a check is a failed check; the others still run
                import traceback
                traceback.print_exc()
                check(f"{name} checks ran to the end", False, repr(e))
    finally:
        gw.stop()
        sim.stop()
        with open(os.path.join(tmp, "gateway.log"), "w") as f:
            f.write("\n".join(gw.lines))
        print(f"(gateway log: {tmp}/gateway.log)")
    passed = sum(RESULTS)
    failed = len(RESULTS) - passed
    print(f"{passed} passed, {failed} failed")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
