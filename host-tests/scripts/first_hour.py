#!/usr/bin/env python3
"""The first hour, as written: runs the README's "The first ten minutes" and
gateway/REGISTERS.md's "Example" against the demo, line by line.

For each document this starts `bash scripts/demo.sh` (the README's own
line: the field-device firmware under QEMU, hans-sim, Mosquitto, on the
ports the documents name), waits for the demo to say it is ready, and runs
the document's shell lines exactly as they are written, in order, with
bash. Each document gets a demo of its own, as a reader who starts from the
beginning would.

What the documents say is what is checked:
- a line whose comment says `again until [R] reads V` is run again (at most
  WAIT seconds) until its output shows register R with value V, as the
  reader is told to do;
- such a comment's `FSM N` is then checked against FSM_STATE (register 6);
- a line whose comment is `NAME: v1, v2, ...` (a read) must print those
  values (angles compared modulo 360, to 0.01 of their unit);
- the README's page and setup steps (a browser's) are checked over HTTP:
  the page answers at the address the banner prints, and the setup code
  the banner prints creates the administrator (POST /api/setup);
- the README's fleet line (a live view until Ctrl-C) must show the demo's
  gateway ALIVE in StandBy with the move's command done; it is then ended
  with Ctrl-C (SIGINT), as the reader does.
Any line that fails (non-zero status) fails its document.

Bounds: the demo's start (builds included: in CI the firmware step built
everything before) BUILD_WAIT seconds, each line 20 s, each "again until"
WAIT seconds, the fleet view FLEET_WAIT seconds (its `cargo run` may
compile hansctl). Everything listens on 127.0.0.1; every process started
here is stopped by its id (the demo by its process group, which it leads:
its own trap stops QEMU, the simulator and the broker).

Ends with "N passed, M failed" (one per document); exit status 1 on any
failure.
"""

import gzip
import json
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from collections import deque

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
README = os.path.join(ROOT, "README.md")
REGISTERS = os.path.join(ROOT, "gateway", "REGISTERS.md")

# The demo's ports, as scripts/demo.sh has them by default and the
# documents name them.
PORTS = {"the web page": 8080, "Modbus": 5020, "the simulator": 10003,
         "the diagnostics": 5021, "the MQTT broker": 18830}
# The demo's start; in CI (test-all.sh) the firmware step built the
# firmware before, and the bound is lower (FIRST_HOUR_BUILD_WAIT).
BUILD_WAIT = int(os.environ.get("FIRST_HOUR_BUILD_WAIT", "1800"))
LINE_WAIT = 20
WAIT = 30
FLEET_WAIT = 600


def say(msg):
    print(f"first-hour: {msg}", flush=True)


class Failed(Exception):
    pass


def section(path, heading):
    """The text of the section of `path` that starts with `heading` (a
    `## ` line), up to the next `## ` heading."""
    text = open(path, encoding="utf-8").read()
    start = text.find("\n" + heading)
    if start < 0:
        raise Failed(f"{os.path.relpath(path, ROOT)}: no section {heading!r}")
    rest = text[start + 1:]
    end = re.search(r"^## ", rest[3:], re.M)
    return rest if end is None else rest[: end.start() + 3]


def sh_lines(text):
    """The lines of the ```sh blocks of `text`, in order (indented blocks of
    a list item included), without blank lines."""
    lines, inside = [], False
    for raw in text.splitlines():
        line = raw.strip()
        if line.startswith("```"):
            inside = (not inside) and line == "```sh"
            continue
        if inside and line:
            lines.append(line)
    return lines


def comment(line):
    """The `# ...` comment of a shell line ('' without one)."""
    m = re.search(r"\s#\s(.*)$", line)
    return m.group(1) if m else ""


def registers(output):
    """mbpoll's `[R]: value` lines, as {R: text}."""
    return {int(r): v for r, v in re.findall(r"^\[(\d+)\]:\s+(\S+)", output, re.M)}


def port_free(port):
    s = socket.socket()
    try:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        s.bind(("127.0.0.1", port))
        return True
    except OSError:
        return False
    finally:
        s.close()


class Demo:
    """`bash scripts/demo.sh`, started in a process group of its own."""

    def __init__(self, command):
        for what, port in PORTS.items():
            if not port_free(port):
                raise Failed(f"127.0.0.1:{port} ({what}) is taken: the documents' lines name it")
        self.tail = deque(maxlen=60)
        self.lines = []
        self.cond = threading.Condition()
        self.started = time.monotonic()
        self.proc = subprocess.Popen(
            ["bash", "-c", command], cwd=ROOT, stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, start_new_session=True)
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        for raw in self.proc.stdout:
            line = raw.decode("utf-8", "replace").rstrip("\n")
            with self.cond:
                self.lines.append(line)
                self.tail.append(line)
                self.cond.notify_all()
            if line.startswith("demo:"):
                say(f"  | {line}")
        with self.cond:
            self.cond.notify_all()

    def wait_for(self, pattern, timeout):
        """The first output line matching `pattern` (a regex); fails when
        the demo ends or `timeout` seconds pass first."""
        deadline = time.monotonic() + timeout
        with self.cond:
            while True:
                for line in self.lines:
                    if re.search(pattern, line):
                        return line
                left = deadline - time.monotonic()
                if left <= 0 or self.proc.poll() is not None:
                    break
                self.cond.wait(min(left, 1.0))
        raise Failed(f"the demo did not print /{pattern}/ within {timeout} s "
                     f"(status {self.proc.poll()}); its last lines:\n  " + "\n  ".join(self.tail))

    def banner(self):
        """The demo's banner: the page's address and the setup code."""
        self.wait_for(r"^demo: stage 4/4 done in .*; ready ", BUILD_WAIT)
        self.wait_for(r"Ctrl-C stops everything", 30)
        with self.cond:
            text = "\n".join(self.lines)
        page = re.search(r"Web page:\s+(http://\S+)", text)
        code = re.search(r"setup code ([2-9A-HJKMNP-Z_]{4}-[2-9A-HJKMNP-Z_]{4}-[2-9A-HJKMNP-Z_]{4})", text)
        if not page or not code:
            raise Failed("the banner has no page address or no setup code")
        say(f"demo ready after {time.monotonic() - self.started:.0f} s: page {page.group(1)}, setup code printed")
        return page.group(1), code.group(1)

    def stop(self):
        """Ctrl-C, as the reader does: SIGINT to the demo's process group."""
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGINT)
            try:
                self.proc.wait(20)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait(10)
        # Every port is free again: nothing of the demo is left behind.
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and not all(port_free(p) for p in PORTS.values()):
            time.sleep(0.2)
        left = [p for p in PORTS.values() if not port_free(p)]
        if left:
            raise Failed(f"after Ctrl-C ports {left} are still taken")


def run(line, timeout=LINE_WAIT):
    """Runs one document line with bash, as written; its output."""
    try:
        p = subprocess.run(["bash", "-c", line], cwd=ROOT, stdin=subprocess.DEVNULL,
                           capture_output=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise Failed(f"{line}\n  did not end within {timeout} s")
    out = p.stdout.decode("utf-8", "replace")
    if p.returncode != 0:
        raise Failed(f"{line}\n  exit status {p.returncode}: {p.stderr.decode('utf-8', 'replace').strip()}")
    return out


def mbpoll_read(register, count=1, kind=None):
    """Reads the demo's registers (for the checks, not a document line)."""
    t = f"-t {kind} -B " if kind else ""
    out = run(f"mbpoll -m tcp -p {PORTS['Modbus']} -0 {t}-r {register} -c {count} -1 127.0.0.1")
    return registers(out)


def close(a, b, angle):
    """Equal to 0.01 of their unit (angles modulo 360: -180 is 180)."""
    d = abs(a - b) % 360.0 if angle else abs(a - b)
    return min(d, 360.0 - d) <= 0.01 if angle else d <= 0.01


def is_read(line):
    """An mbpoll line that writes nothing: no values after the address."""
    return line.startswith("mbpoll ") and not line.split("#")[0].split("127.0.0.1", 1)[1].split()


def check_line(line):
    """Runs a document line and checks what its comment says."""
    note = comment(line)
    until = re.search(r"again until \[(\d+)\] reads (\S+)", note)
    if until:
        reg, want = int(until.group(1)), until.group(2).rstrip(".,:;)")
        deadline = time.monotonic() + WAIT
        while True:
            got = registers(run(line)).get(reg)
            if got == want:
                break
            if time.monotonic() > deadline:
                raise Failed(f"{line}\n  [{reg}] read {got}, not {want}, for {WAIT} s")
            time.sleep(0.2)
        fsm = re.search(r"FSM (\d+)", note)
        if fsm:
            got = mbpoll_read(6).get(6)
            if got != fsm.group(1):
                raise Failed(f"{line}\n  says FSM {fsm.group(1)}, FSM_STATE (6) reads {got}")
        return
    out = run(line)
    values = re.match(r"([A-Z_]+)( in thousandths)?: (-?[\d.]+(?:, -?[\d.]+)+)$", note)
    if values and is_read(line):
        want = [float(v) for v in values.group(3).split(", ")]
        got = [float(v) for _, v in sorted(registers(out).items())]
        scale = 1000.0 if values.group(2) else 1.0
        # Poses are X, Y, Z then three angles; joints are angles.
        angles = [i >= 3 for i in range(len(want))] if "POSE" in values.group(1) else [True] * len(want)
        if len(got) != len(want) or not all(
                close(g / scale, w / scale, a) for g, w, a in zip(got, want, angles)):
            raise Failed(f"{line}\n  says {want}, read {got}")


def http(url, body=None, origin=None):
    req = urllib.request.Request(url, data=None if body is None else json.dumps(body).encode())
    if body is not None:
        req.add_header("Content-Type", "application/json")
        req.add_header("Origin", origin)
    def text(r):
        # The page is served compressed (gzip) whatever the request asks.
        raw = r.read()
        if r.headers.get("Content-Encoding") == "gzip":
            raw = gzip.decompress(raw)
        return raw.decode("utf-8", "replace")
    try:
        with urllib.request.urlopen(req, timeout=10) as r:
            return r.status, text(r)
    except urllib.error.HTTPError as e:
        return e.code, text(e)


def fleet_view(line):
    """The README's live fleet view: started as written, read until it shows
    the demo's gateway, then ended with Ctrl-C (SIGINT to its group)."""
    p = subprocess.Popen(["bash", "-c", line], cwd=ROOT, stdin=subprocess.DEVNULL,
                         stdout=subprocess.PIPE, stderr=subprocess.STDOUT, start_new_session=True)
    found, tail = None, deque(maxlen=40)
    timer = threading.Timer(FLEET_WAIT, lambda: os.killpg(p.pid, signal.SIGINT))
    timer.start()
    try:
        for raw in p.stdout:
            row = raw.decode("utf-8", "replace").rstrip()
            tail.append(row)
            # One row: group, node, ALIVE, the robot link, the FSM, ...,
            # the last command and its result.
            if re.search(r"^cells\s+\S+\s+ALIVE\b.*\bStandBy\b.*\bdone\b", row):
                found = row
                break
    finally:
        timer.cancel()
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGINT)
        try:
            status = p.wait(20)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            status = p.wait(10)
    if not found:
        raise Failed(f"{line}\n  no row ALIVE, StandBy, done within {FLEET_WAIT} s; its last lines:\n  "
                     + "\n  ".join(tail))
    say(f"  fleet: {found}")
    # Ctrl-C ends the view with status 0 (cargo passes it on; 130 if cargo
    # itself took the signal first).
    if status not in (0, 130, -signal.SIGINT):
        raise Failed(f"{line}\n  ended with status {status} after Ctrl-C")


def readme():
    lines = sh_lines(section(README, "## The first ten minutes"))
    if not lines or lines[0] != "bash scripts/demo.sh":
        raise Failed("README's first ten minutes do not start with `bash scripts/demo.sh`")
    demo = Demo(lines[0])
    try:
        page, code = demo.banner()
        # Step 2: the page.
        status, body = http(page)
        if status != 200 or not re.match(r"\s*<!doctype html>", body, re.I):
            raise Failed(f"GET {page}: {status}, not the page")
        # Step 3: the administrator, with the banner's setup code.
        status, body = http(page + "api/session")
        if status != 200 or not json.loads(body).get("setup"):
            raise Failed(f"GET {page}api/session: {status} {body}: setup is not open")
        origin = page.rstrip("/")
        status, body = http(page + "api/setup", {"code": code, "name": "admin",
                                                 "password": "first-hour-pw"}, origin)
        if status != 200:
            raise Failed(f"POST {page}api/setup with the banner's code: {status} {body}")
        say("  the page answers; the banner's setup code created the administrator")
        # Steps 4 and 5: the lines.
        start = mbpoll_read(26, 6, "4:float")
        for line in lines[1:]:
            if " fleet " in line:
                fleet_view(line)
            else:
                check_line(line)
            say(f"  ok: {line.split('#')[0].strip()}")
        end = mbpoll_read(26, 6, "4:float")
        moved = max(abs(float(end[r]) - float(start[r])) for r in (26, 28, 30))
        if moved < 50:
            raise Failed(f"the pose moved {moved:.1f} mm: nothing to see (from {start} to {end})")
        say(f"  the robot moved {moved:.1f} mm")
    finally:
        demo.stop()


def registers_example():
    lines = sh_lines(section(REGISTERS, "## Example"))
    if not lines:
        raise Failed("REGISTERS.md's example has no shell lines")
    demo = Demo("bash scripts/demo.sh")
    try:
        demo.banner()
        start = mbpoll_read(26, 6, "4:float")
        for line in lines:
            check_line(line)
            say(f"  ok: {line.split('#')[0].strip()}")
        fmt = mbpoll_read(117).get(117)
        end = mbpoll_read(26, 6, "4:int" if fmt == "1" else "4:float")
        scale = 1000.0 if fmt == "1" else 1.0
        say(f"  pose at the start {[start[r] for r in sorted(start)]}, at the end "
            f"{[float(end[r]) / scale for r in sorted(end)]}")
    finally:
        demo.stop()


def terminated(signum, _frame):
    """SIGTERM (an outer `timeout`): fail the running document, whose
    `finally` stops its demo (which runs in a session of its own)."""
    raise Failed(f"stopped by signal {signum}")


def main():
    signal.signal(signal.SIGTERM, terminated)
    passed = failed = 0
    for name, test in [("README.md, The first ten minutes", readme),
                       ("gateway/REGISTERS.md, Example", registers_example)]:
        say(f"{name}: against the demo")
        t0 = time.monotonic()
        try:
            test()
            passed += 1
            say(f"ok   {name} ({time.monotonic() - t0:.0f} s)")
        except Failed as e:
            failed += 1
            say(f"FAIL {name}: {e}")
    print(f"{passed} passed, {failed} failed", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
