#!/usr/bin/env python3
"""Issue 25's attacks replayed against the Linux gateway after the fix, with
their figures (README.md beside this says what each case means).

Starts `hans-sim` (the robot) and `hans-gateway` (with a configuration file
whose access.plc_address is the PLC's address, an audit file beside it and
the page), each on free loopback ports, creates the administrator with the
setup code from its file, then runs:

  a  the slow PLC: polls every 3 s while four busy connections from two
     other addresses send ~20 requests a second; then it reconnects five
     times while they hold the slots;
  d  the gateway's CPU and a steady poller's latency, without and with a
     flood of unknown-name logins from rotating addresses;
  bc a guessing flood (unknown names and the administrator's name, rotating
     addresses) with Modbus setting toggles, for --flood-seconds (600 for
     the figure, 20 with --short), while the administrator logs in from
     their usual address every 3 s; then the audit file(s) read back.

Every client binds a 127.0.0.x source address and talks to 127.0.0.1 only;
every loop is bounded by a deadline and every rate by a pacer. The gateway
and the simulator are stopped by their process ids. The pass thresholds
are written below (THRESHOLDS); any one missed makes the exit status 1.
The table goes to --out (Markdown, generated: never edit it by hand).
"""

import argparse
import datetime
import glob
import http.client
import json
import os
import platform
import random
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, os.path.join(ROOT, "host-tests", "robustness"))
from modbus import Client, ModbusError  # noqa: E402  (the rig's client, one copy)

HOST = "127.0.0.1"              # where the gateway and the simulator listen
PLC = "127.0.0.10"              # access.plc_address: the PLC's reserved slot
BUSY = ["127.0.0.20", "127.0.0.21"]  # the busy clients of case a, two connections each
DESK = "127.0.0.2"              # the administrator's usual address
TOGGLER = "127.0.0.30"          # the Modbus client that toggles a setting
FLOOD = [f"127.0.0.{i}" for i in range(100, 250)]  # the guessers' rotating addresses
ADMIN, ADMIN_PW = "admin", "Replay-figures-7q!"
PLC_TIMEOUT = 2.0      # s: what the PLC (and the administrator's browser, for
                       # THRESHOLDS) waits for an answer
RECONNECT_WAIT = 10.0  # s: how long a reconnect or a login is waited for, to
                       # measure how late it comes

# Registers (gateway/REGISTERS.md).
STATUS = (0, 10)       # a PLC poll: the first ten status registers
CFG_POLL_MS = 105      # a setting every allowed client may change
CONFIG_COMMAND = 141   # 1 = apply and save

# Audit record kinds (gateway/src/audit/record.rs, stable codes).
KINDS = {1: "start", 2: "recovery", 3: "login", 4: "login-failed", 5: "logout",
         6: "account-created", 7: "account-removed", 8: "account-role",
         9: "account-password", 10: "config", 11: "config-loaded", 12: "refused",
         13: "restart", 14: "firmware", 15: "watchdog", 16: "lost", 17: "time",
         18: "config-refused"}
SECURITY = {"start", "login", "logout", "account-created", "account-removed",
            "account-role", "account-password", "config", "config-loaded",
            "firmware", "restart"}

# Pass thresholds. A PLC times out after about a second: every poll
# answered within one; the administrator's login answered 200 every time
# within the page's request deadline (2 s); not one security record lost.
THRESHOLDS = {
    "a_polls_unserved": 0,       # slow PLC's polls not answered
    "a_reconnects_refused": 0,   # of its five reconnects, not served within PLC_TIMEOUT
    "a_max_ms": 1000.0,          # its slowest poll
    "b_logins_failed": 0,        # the administrator's logins at their desk
    "b_max_ms": 2000.0,          # the slowest of them
    "c_security_missing": 0,     # security records written but not in the file(s)
    "c_late": 0,                 # logins answered before their record was in the file
    "d_polls_failed": 0,         # the steady poller's, in both halves
    "d_p99_ms": 100.0,           # its p99 during the flood: within one poll cycle
    "d_cpu_flood_pct": 50.0,     # the gateway's CPU during the flood, % of one core
}


def say(msg):
    print(f"replay: {msg}", flush=True)


def free_port():
    s = socket.socket()
    s.bind((HOST, 0))
    port = s.getsockname()[1]
    s.close()
    return port


def wait_port(port, proc, timeout):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"{proc.args[0]} ended with status {proc.returncode}")
        try:
            socket.create_connection((HOST, port), 0.5).close()
            return
        except OSError:
            time.sleep(0.1)
    raise RuntimeError(f"nothing listens on {HOST}:{port} after {timeout} s")


def pct(values, p):
    if not values:
        return float("nan")
    v = sorted(values)
    return v[min(len(v) - 1, int(round(p / 100.0 * (len(v) - 1))))]


def cpu_ticks(pid):
    """utime + stime of a process, in clock ticks (proc(5))."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return int(fields[11]) + int(fields[12])


class Rig:
    """The simulator and the gateway, in a temporary directory."""

    def __init__(self, bins, work):
        self.work = work
        self.sim_port, self.modbus, self.web = free_port(), free_port(), free_port()
        self.config = os.path.join(work, "gateway.toml")
        self.code_file = os.path.join(work, "setup-code")
        with open(self.config, "w") as f:
            f.write(f'[robot]\naddress = "{HOST}"\nport = {self.sim_port}\n\n'
                    '[watchdog]\nperiod_ms = 0\n\n'
                    f'[access]\nplc_address = "{PLC}"\n')
        self.procs = []
        sim_log = open(os.path.join(work, "sim.log"), "w")
        self.sim = self._start([os.path.join(bins, "hans-sim"), "--host", HOST,
                                "--command-port", str(self.sim_port), "--datasheet-ports",
                                ",".join(str(free_port()) for _ in range(3)),
                                "--no-fast-port", "--ready"], sim_log)
        wait_port(self.sim_port, self.sim, 30)
        gw_log = open(os.path.join(work, "gateway.log"), "w")
        self.gw = self._start([os.path.join(bins, "hans-gateway"), "--config", self.config,
                               "--modbus-listen", f"{HOST}:{self.modbus}",
                               "--web-listen", f"{HOST}:{self.web}",
                               "--setup-code-file", self.code_file], gw_log)
        wait_port(self.modbus, self.gw, 30)
        wait_port(self.web, self.gw, 30)

    def _start(self, argv, log):
        p = subprocess.Popen(argv, cwd=self.work, stdin=subprocess.DEVNULL, stdout=log,
                             stderr=subprocess.STDOUT,
                             env=dict(os.environ, RUST_LOG=os.environ.get("RUST_LOG", "warn")))
        self.procs.append(p)
        return p

    def stop(self):
        """SIGTERM, then SIGKILL after 10 s, to each process started here."""
        for p in reversed(self.procs):
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
                try:
                    p.wait(10)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait(10)

    def audit(self):
        """Every record that reads in the audit file(s) beside the
        configuration (gateway.toml.audit and whatever rotation keeps
        beside it), in (boot, seq) order, each once."""
        seen = {}
        for path in glob.glob(self.config + ".audit*"):
            with open(path, "rb") as f:
                for r in parse_records(f.read()):
                    seen[(r["boot"], r["seq"])] = r
        return [seen[k] for k in sorted(seen)]

    def audit_bytes(self):
        return {os.path.basename(p): os.path.getsize(p)
                for p in sorted(glob.glob(self.config + ".audit*"))}


def parse_records(data):
    """Records in the stored form of gateway/src/audit/record.rs (version 1):
    damaged bytes are skipped up to the next record whose CRC checks."""
    out, at = [], 0
    while at + 33 <= len(data):
        a, d = data[at + 27], data[at + 28]
        end = at + 29 + a + d
        if (data[at] != 1 or a > 16 or d > 79 or end + 4 > len(data)
                or zlib.crc32(data[at:end]) != int.from_bytes(data[end:end + 4], "little")):
            at += 1
            continue
        out.append({"seq": int.from_bytes(data[at + 1:at + 5], "little"),
                    "boot": int.from_bytes(data[at + 5:at + 9], "little"),
                    "kind": KINDS.get(data[at + 21], f"code {data[at + 21]}"),
                    "from": ".".join(str(b) for b in data[at + 23:at + 27]),
                    "actor": data[at + 29:at + 29 + a].decode("ascii", "replace"),
                    "detail": data[at + 29 + a:end].decode("ascii", "replace")})
        at = end + 4
    return out


def post(rig, path, body, source, cookie=None, timeout=5.0):
    """POST a JSON body from `source` as the page does (Origin = Host);
    returns (status or 'error: ...', the session cookie or None)."""
    c = http.client.HTTPConnection(HOST, rig.web, timeout=timeout, source_address=(source, 0))
    headers = {"Content-Type": "application/json", "Connection": "close",
               "Origin": f"http://{HOST}:{rig.web}"}
    if cookie:
        headers["Cookie"] = cookie
    try:
        c.request("POST", path, body=json.dumps(body), headers=headers)
        r = c.getresponse()
        r.read()
        set_cookie = r.getheader("Set-Cookie") or ""
        return r.status, (set_cookie.split(";")[0] or None)
    except (OSError, http.client.HTTPException) as e:
        return f"error: {type(e).__name__}", None
    finally:
        c.close()


class Pacer:
    """Hands out send times at most `rate` a second, until `end`."""

    def __init__(self, rate, end):
        self.gap, self.end, self.next = 1.0 / rate, end, time.monotonic()
        self.lock = threading.Lock()

    def take(self):
        with self.lock:
            t = max(self.next, time.monotonic())
            self.next = t + self.gap
        if t >= self.end:
            return False
        time.sleep(max(0.0, t - time.monotonic()))
        return True


class Flood:
    """Wrong logins from rotating addresses: `admin_share` of them for the
    administrator's name, the rest for unknown names. At most `rate` a
    second, `threads` at a time, until `seconds` have passed."""

    threads = 16  # --flood-threads

    def __init__(self, rig, rate, seconds, admin_share):
        self.rig, self.admin_share = rig, admin_share
        self.pacer = Pacer(rate, time.monotonic() + seconds)
        self.counts, self.lock, self.n = {}, threading.Lock(), 0
        self.threads = [threading.Thread(target=self._run, daemon=True)
                        for _ in range(Flood.threads)]
        self.started = time.monotonic()
        for t in self.threads:
            t.start()

    def _run(self):
        rnd = random.Random()
        while self.pacer.take():
            with self.lock:
                self.n += 1
                source = FLOOD[self.n % len(FLOOD)]
            admin = rnd.random() < self.admin_share
            name = ADMIN if admin else f"guess{rnd.randrange(10**6)}"
            status, _ = post(self.rig, "/api/login",
                             {"name": name, "password": f"wrong{rnd.randrange(10**9)}"},
                             source, timeout=3.0)
            key = ("admin " if admin else "unknown ") + str(status)
            with self.lock:
                self.counts[key] = self.counts.get(key, 0) + 1

    def join(self):
        for t in self.threads:
            t.join(self.pacer.end - time.monotonic() + 10)
        self.seconds = time.monotonic() - self.started
        self.total = sum(self.counts.values())
        return self

    def summary(self):
        parts = ", ".join(f"{k}: {v}" for k, v in sorted(self.counts.items()))
        return f"{self.total} in {self.seconds:.0f} s ({self.total / self.seconds:.0f}/s): {parts}"


class Looper(threading.Thread):
    """Calls `step()` every `period` s until `end` (or stop()); counts."""

    def __init__(self, period, end, step):
        super().__init__(daemon=True)
        self.period, self.end, self.step = period, end, step
        self.ok = self.failed = 0
        self.halt = threading.Event()
        self.start()

    def run(self):
        t = time.monotonic()
        while not self.halt.is_set() and t < self.end:
            if self.step():
                self.ok += 1
            else:
                self.failed += 1
            t = max(t + self.period, time.monotonic())
            self.halt.wait(max(0.0, t - time.monotonic()))

    def stop(self):
        self.halt.set()
        self.join(15)


class ModbusLoop:
    """One Modbus client from `source` that reconnects after an error
    (0.2 s later) and runs `action(client)` each step."""

    def __init__(self, rig, source, action):
        self.rig, self.source, self.action, self.client = rig, source, action, None
        self.errors = 0

    def __call__(self):
        try:
            if self.client is None:
                self.client = Client(HOST, self.rig.modbus, bind=self.source, timeout=1.0)
            self.action(self.client)
            return True
        except ModbusError:
            self.errors += 1
            if self.client:
                self.client.close()
            self.client = None
            time.sleep(0.2)
            return False

    def close(self):
        if self.client:
            self.client.close()


def timed(f):
    t0 = time.monotonic()
    r = f()
    return r, (time.monotonic() - t0) * 1000.0


def setup_admin(rig):
    deadline = time.monotonic() + 20
    while not os.path.exists(rig.code_file) and time.monotonic() < deadline:
        time.sleep(0.1)
    code = open(rig.code_file).read().strip()
    status, _ = post(rig, "/api/setup", {"code": code, "name": ADMIN, "password": ADMIN_PW}, DESK)
    if status != 200:
        raise RuntimeError(f"POST /api/setup with the file's code: {status}")
    return admin_login(rig)[0]


class Desk:
    """The administrator's logins answered 200, and how many of them did
    not have their `login` record in the audit file when the answer came
    (issue 25: a record is on disk when the request that caused it is
    answered; read through the page cache, so "in the file")."""
    ok = 0
    late = 0


def admin_login(rig):
    """The administrator at their desk: log in, check that the login's
    record is in the file, log out. (ok, ms, status)."""
    t0 = time.monotonic()
    status, cookie = post(rig, "/api/login", {"name": ADMIN, "password": ADMIN_PW}, DESK,
                          timeout=RECONNECT_WAIT)
    ms = (time.monotonic() - t0) * 1000.0
    if status == 200:
        Desk.ok += 1
        on_file = sum(1 for r in rig.audit() if r["kind"] == "login" and r["actor"] == ADMIN)
        Desk.late += on_file < Desk.ok
    if status == 200 and cookie:
        post(rig, "/api/logout", {}, DESK, cookie=cookie)
    return status == 200, ms, status


# ---------------------------------------------------------------- case a
def case_a(rig, polls):
    say(f"a: slow PLC ({polls} polls every 3 s, then 5 reconnects) against 4 busy connections")
    plc = Client(HOST, rig.modbus, bind=PLC, timeout=PLC_TIMEOUT)
    plc.read(*STATUS)
    # The busy clients go on until stopped, after the last reconnect (this
    # deadline only bounds them: the polls, then five reconnects of up to
    # RECONNECT_WAIT + 3 s each).
    end = time.monotonic() + 3 * polls + 5 * (RECONNECT_WAIT + 3) + 30
    # A busy client waits 1 s for an answer and reconnects 0.2 s after an
    # error (a refused connection), as a client library does.
    busy = [ModbusLoop(rig, BUSY[i % 2], lambda c: c.read(0, 2)) for i in range(4)]
    loops = [Looper(0.2, end, b) for b in busy]  # 4 x 5 = 20 requests a second
    time.sleep(1.0)
    served, lat, errors = 0, [], []
    for _ in range(polls):
        time.sleep(3.0)
        try:
            _, ms = timed(lambda: plc.read(*STATUS))
            served += 1
            lat.append(ms)
        except ModbusError as e:
            errors.append(str(e))
            plc.close()
            try:
                plc = Client(HOST, rig.modbus, bind=PLC, timeout=PLC_TIMEOUT)
            except ModbusError as e2:
                errors.append(str(e2))
    # Each reconnect: close, connect, poll. The poll is waited for up to
    # RECONNECT_WAIT s to measure how long the PLC is kept out; it counts
    # as admitted if answered within PLC_TIMEOUT (what a PLC waits).
    admitted, rlat = 0, []
    before, t_before = [l.ok for l in loops], time.monotonic()
    for _ in range(5):
        plc.close()
        try:
            t0 = time.monotonic()
            plc = Client(HOST, rig.modbus, bind=PLC, timeout=RECONNECT_WAIT)
            plc.read(*STATUS)
            ms = (time.monotonic() - t0) * 1000.0
            rlat.append(ms)
            admitted += ms <= PLC_TIMEOUT * 1000.0
        except ModbusError as e:
            rlat.append(float("inf"))
            errors.append(f"reconnect: {e}")
        time.sleep(3.0)
    busy_rate = (sum(l.ok for l in loops) - sum(before)) / (time.monotonic() - t_before)
    for l in loops:
        l.stop()
    for b in busy:
        b.close()
    plc.close()
    r = {"polls": polls, "served": served, "lat": lat, "admitted": admitted, "rlat": rlat,
         "errors": errors, "busy_rate": busy_rate,
         "busy_ok": sum(l.ok for l in loops), "busy_failed": sum(l.failed for l in loops)}
    say(f"a: polls {served}/{polls}, reconnects {admitted}/5 within {PLC_TIMEOUT} s, poll max "
        f"{max(lat, default=0):.1f} ms, reconnects {', '.join(f'{v:.0f}' for v in rlat)} ms, "
        f"busy clients served {busy_rate:.1f} req/s during the reconnects; errors {errors}")
    return r


# ---------------------------------------------------------------- case d
def steady(rig, seconds, flood_rate):
    poller = ModbusLoop(rig, PLC, lambda c: lat.append(timed(lambda: c.read(*STATUS))[1]))
    lat = []
    tick = os.sysconf("SC_CLK_TCK")
    c0, t0 = cpu_ticks(rig.gw.pid), time.monotonic()
    flood = Flood(rig, flood_rate, seconds, 0.0) if flood_rate else None
    loop = Looper(0.1, time.monotonic() + seconds, poller)
    loop.join(seconds + 15)
    if flood:
        flood.join()
    cpu = (cpu_ticks(rig.gw.pid) - c0) / tick / (time.monotonic() - t0) * 100.0
    poller.close()
    return {"ok": loop.ok, "failed": loop.failed, "p50": pct(lat, 50), "p99": pct(lat, 99),
            "max": max(lat, default=float("nan")), "cpu": cpu, "flood": flood}


def case_d(rig, seconds, rate):
    say(f"d: steady poller (10/s) for {seconds} s without, then {seconds} s with an "
        f"unknown-name flood (up to {rate}/s)")
    quiet = steady(rig, seconds, 0)
    # The flood's limiter entries from case a's neighbours are gone by now;
    # a pause lets the hash budget fill as it would before an attack.
    time.sleep(2.0)
    loud = steady(rig, seconds, rate)
    for name, r in (("without", quiet), ("with", loud)):
        say(f"d: {name} flood: CPU {r['cpu']:.1f} % of a core, polls {r['ok']} ok {r['failed']} "
            f"failed, p50 {r['p50']:.2f} p99 {r['p99']:.2f} max {r['max']:.2f} ms")
    say(f"d: flood {loud['flood'].summary()}")
    return quiet, loud


# ---------------------------------------------------------------- cases b and c
def case_bc(rig, seconds, rate):
    say(f"b+c: {seconds} s of wrong logins (up to {rate}/s, 1 in 4 for {ADMIN!r}) from "
        f"{len(FLOOD)} rotating addresses, Modbus setting toggles, {ADMIN!r} logging in every 3 s")
    quiet = [admin_login(rig) for _ in range(3)]  # the same logins before the flood
    time.sleep(1.0)  # the records of those logins, in the file by now
    before = rig.audit()
    kept_before = [r for r in before if r["kind"] in ("start", "account-created", "login")]
    end = time.monotonic() + seconds
    flood = Flood(rig, rate, seconds, 0.25)
    value = [50]

    def toggle(c):
        value[0] = 150 - value[0]      # 50, 100, 50, ...
        c.write(CFG_POLL_MS, [value[0]])
        c.write(CONFIG_COMMAND, [1])
    toggler = ModbusLoop(rig, TOGGLER, toggle)
    toggles = Looper(0.05, end, toggler)  # up to 20 applied changes a second
    logins = []

    def admin():
        ok, ms, status = admin_login(rig)
        logins.append((ok, ms, status))
        return ok
    admins = Looper(3.0, end, admin)
    flood.join()
    toggles.join(seconds + 15)
    admins.join(seconds + 15)
    toggler.close()
    lat = [ms if ok else float("inf") for ok, ms, _ in logins]
    r = {"seconds": seconds, "flood": flood, "toggles": toggles.ok, "toggle_failed": toggles.failed,
         "logins": len(logins), "logins_ok": sum(1 for ok, _, _ in logins if ok),
         "statuses": sorted({str(s) for ok, _, s in logins if not ok}),
         "p50": pct(lat, 50), "p90": pct(lat, 90), "max": max(lat, default=float("nan")),
         "kept_before": kept_before, "quiet_ms": [ms for _, ms, _ in quiet],
         "quiet_ok": sum(1 for ok, _, _ in quiet if ok)}
    say(f"b: admin logins {r['logins_ok']}/{r['logins']} (failed: {r['statuses']}), "
        f"p50 {r['p50']:.1f} p90 {r['p90']:.1f} max {r['max']:.1f} ms")
    say(f"c: flood {flood.summary()}; {toggles.ok} toggles applied ({toggles.failed} failed)")
    return r


def audit_figures(rig, bc, admin_logins_ok):
    records = rig.audit()
    by_kind = {}
    for r in records:
        by_kind[r["kind"]] = by_kind.get(r["kind"], 0) + 1
    keys = {(r["boot"], r["seq"]) for r in records}
    missing_before = [r for r in bc["kept_before"] if (r["boot"], r["seq"]) not in keys]
    admin_logins = sum(1 for r in records if r["kind"] == "login" and r["actor"] == ADMIN)
    # Every login that answered 200 wrote its record before the answer.
    missing = len(missing_before) + max(0, admin_logins_ok - admin_logins)
    say(f"c: {len(records)} records in {rig.audit_bytes()}: {by_kind}")
    say(f"c: written before the flood: {len(bc['kept_before'])}, missing now {len(missing_before)}; "
        f"{ADMIN} login records {admin_logins} for {admin_logins_ok} logins answered 200")
    return {"records": len(records), "by_kind": by_kind, "files": rig.audit_bytes(),
            "missing_before": missing_before, "admin_logins": admin_logins, "missing": missing,
            "admin_logins_ok": admin_logins_ok,
            "aggregates": [f"{r['kind']} ({r['from']}): {r['detail'] or r['actor']}" for r in records
                           if r["kind"] in ("login-failed", "config", "config-refused", "refused",
                                            "lost")]}


def machine():
    with open("/proc/loadavg") as f:
        load = " ".join(f.read().split()[:3])
    try:
        commit = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"],
                                capture_output=True, text=True, timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "-C", ROOT, "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        commit, dirty = "?", ""
    return {"cores": os.cpu_count(), "load": load, "commit": commit + (" (modified)" if dirty else ""),
            "kernel": platform.release()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--short", action="store_true",
                    help="the short form (~2 min): fewer polls, 10 s halves in d, 20 s flood in b+c")
    ap.add_argument("--flood-seconds", type=int, help="b+c's flood (default 600, 20 with --short)")
    ap.add_argument("--rate", type=int, default=500, help="login attempts a second at most (500)")
    ap.add_argument("--flood-threads", type=int, default=16,
                    help="the flood's connections at a time (16)")
    ap.add_argument("--bin-dir", default=os.path.join(ROOT, "target", "release"),
                    help="where hans-gateway and hans-sim are (target/release: a debug "
                         "build's PBKDF2 is some 20 times slower)")
    ap.add_argument("--out", help="the Markdown table (default: RESULTS.md beside this for the "
                                  "full form; none for --short)")
    args = ap.parse_args()
    flood_s = args.flood_seconds or (20 if args.short else 600)
    polls = 6 if args.short else 10
    d_s = 10 if args.short else 30
    rate = max(1, min(args.rate, 500))
    Flood.threads = max(1, min(args.flood_threads, 64))
    out = args.out or (None if args.short else os.path.join(HERE, "RESULTS.md"))
    args.bin_dir = os.path.abspath(args.bin_dir)
    for b in ("hans-gateway", "hans-sim"):
        if not os.access(os.path.join(args.bin_dir, b), os.X_OK):
            say(f"no {b} in {args.bin_dir}: cargo build -p hans-gateway-linux -p hans-sim")
            return 2
    m0 = machine()
    started = time.monotonic()
    work = tempfile.mkdtemp(prefix="hans-replay-")
    rig = None

    def terminated(signum, _frame):
        raise KeyboardInterrupt(f"signal {signum}")
    signal.signal(signal.SIGTERM, terminated)
    try:
        rig = Rig(args.bin_dir, work)
        say(f"gateway pid {rig.gw.pid} (Modbus {rig.modbus}, page {rig.web}), simulator "
            f"pid {rig.sim.pid}, files in {work}")
        setup_admin(rig)
        a = case_a(rig, polls)
        quiet, loud = case_d(rig, d_s, rate)
        bc = case_bc(rig, flood_s, rate)
        # The records are read back after the gateway has stopped (SIGTERM):
        # what the files hold, as an investigator finds them.
        rig.stop()
        c = audit_figures(rig, bc, Desk.ok)
    finally:
        if rig:
            rig.stop()
    m1 = machine()
    elapsed = time.monotonic() - started

    checks = [
        ("a: every slow-PLC poll served", a["polls"] - a["served"], THRESHOLDS["a_polls_unserved"]),
        ("a: reconnects not served within 2 s", 5 - a["admitted"], THRESHOLDS["a_reconnects_refused"]),
        ("a: slowest PLC poll (ms)", max(a["lat"], default=1e9), THRESHOLDS["a_max_ms"]),
        ("b: administrator logins failed", bc["logins"] - bc["logins_ok"], THRESHOLDS["b_logins_failed"]),
        ("b: slowest administrator login (ms)", bc["max"], THRESHOLDS["b_max_ms"]),
        ("c: security records missing", c["missing"], THRESHOLDS["c_security_missing"]),
        ("c: logins answered before their record was in the file", Desk.late, THRESHOLDS["c_late"]),
        ("d: steady polls failed", quiet["failed"] + loud["failed"], THRESHOLDS["d_polls_failed"]),
        ("d: poller p99 during the flood (ms)", loud["p99"], THRESHOLDS["d_p99_ms"]),
        ("d: gateway CPU during the flood (% of a core)", loud["cpu"], THRESHOLDS["d_cpu_flood_pct"]),
    ]
    failed = [(n, v, t) for n, v, t in checks if not v <= t]
    for n, v, t in checks:
        say(f"{'ok  ' if v <= t else 'FAIL'} {n}: {v:.1f} (at most {t})")
    say(f"{len(checks) - len(failed)} passed, {len(failed)} failed, in {elapsed:.0f} s")
    if out:
        write_table(out, args, m0, m1, elapsed, a, quiet, loud, bc, c, checks)
        say(f"table written to {os.path.relpath(out, ROOT)}")
    if not failed:
        subprocess.run(["rm", "-rf", "--", work], timeout=60)
    else:
        say(f"files kept in {work} (gateway.log, sim.log, the audit file)")
    return 1 if failed else 0


def write_table(out, args, m0, m1, elapsed, a, quiet, loud, bc, c, checks):
    cmd = "python3 host-tests/attacks/replay.py" + "".join(
        f" {a_}" for a_ in sys.argv[1:])
    f1 = lambda v: f"{v:.1f}"  # noqa: E731
    lines = [
        "# Issue 25's attacks replayed after the fix: figures",
        "",
        "Generated by `host-tests/attacks/replay.py` (README.md beside it says what each case",
        "means); do not edit by hand.",
        "",
        f"- Command: `{cmd}` (binaries: `{os.path.relpath(args.bin_dir, ROOT)}`)",
        f"- Commit: {m0['commit']}; run {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, "
        f"{elapsed:.0f} s",
        f"- Machine: {m0['cores']} cores, Linux {m0['kernel']}; load average (1, 5, 15 min) "
        f"{m0['load']} at the start, {m1['load']} at the end",
        "",
        "| case | figure | value |",
        "|---|---|---|",
        f"| a slow PLC | polls served / attempted (every 3 s, 4 busy connections from 2 addresses) | "
        f"{a['served']} / {a['polls']} |",
        f"| a slow PLC | reconnects served within {PLC_TIMEOUT:.0f} s while the 4 hold the slots | "
        f"{a['admitted']} / 5 |",
        f"| a slow PLC | poll latency p50 / max (ms) | {f1(pct(a['lat'], 50))} / "
        f"{f1(max(a['lat'], default=float('nan')))} |",
        f"| a slow PLC | each reconnect, connect to first answer (ms; inf = none in "
        f"{RECONNECT_WAIT:.0f} s) | " + ", ".join(f"{v:.0f}" for v in a["rlat"]) + " |",
        f"| a slow PLC | busy clients' requests served during the reconnects | {a['busy_rate']:.1f}/s |",
        f"| b admin login | logins succeeded / tried at their desk, every 3 s during a "
        f"{bc['seconds']} s flood | {bc['logins_ok']} / {bc['logins']} |",
        "| b admin login | latency before the flood (3 logins, ms) | "
        + ", ".join(f"{v:.0f}" for v in bc["quiet_ms"]) + " |",
        f"| b admin login | latency p50 / p90 / max (ms; inf = no answer in {RECONNECT_WAIT:.0f} s) | "
        f"{f1(bc['p50'])} / {f1(bc['p90'])} / {f1(bc['max'])} |",
        f"| b+c flood | wrong logins sent ({Flood.threads} at a time, address: 1 of {len(FLOOD)}; "
        f"by name and answer) | {bc['flood'].summary()} |",
        f"| c Modbus toggles | CFG_POLL_MS changed and applied | {bc['toggles']} "
        f"({bc['toggle_failed']} failed) |",
        f"| c audit | records in the file(s) after the flood | {c['records']} in "
        + ", ".join(f"`{k}` {v} B" for k, v in c["files"].items()) + " |",
        "| c audit | records by kind | " + ", ".join(f"{k} {v}" for k, v in sorted(c["by_kind"].items()))
        + " |",
        "| c audit | the failure and change records (first of a period as it happened, then "
        "the period's count), in order | " + "; ".join(c["aggregates"]).replace("|", "/") + " |",
        f"| c audit | records from before the flood (start, account created, login) still there | "
        f"{len(bc['kept_before']) - len(c['missing_before'])} / {len(bc['kept_before'])} |",
        f"| c audit | administrator login records / logins answered 200 | {c['admin_logins']} / "
        f"{c['admin_logins_ok']} |",
        f"| c audit | administrator logins answered before their record was in the file | "
        f"{Desk.late} / {Desk.ok} |",
        f"| d CPU | gateway CPU, % of one core: without / with the unknown-name flood | "
        f"{f1(quiet['cpu'])} / {f1(loud['cpu'])} |",
        f"| d Modbus | steady poller (10/s) p50 / p99 / max, without the flood (ms) | "
        f"{quiet['p50']:.2f} / {quiet['p99']:.2f} / {quiet['max']:.2f} |",
        f"| d Modbus | the same during the flood (ms) | "
        f"{loud['p50']:.2f} / {loud['p99']:.2f} / {loud['max']:.2f} |",
        f"| d Modbus | polls answered / failed, without + with | {quiet['ok'] + loud['ok']} / "
        f"{quiet['failed'] + loud['failed']} |",
        f"| d flood | unknown-name logins sent | {loud['flood'].summary()} |",
        "",
        "## Pass thresholds",
        "",
        "| check | value | at most | |",
        "|---|---|---|---|",
    ]
    for n, v, t in checks:
        lines.append(f"| {n} | {v:.1f} | {t} | {'ok' if v <= t else 'FAIL'} |")
    with open(out, "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    sys.exit(main())
