#!/usr/bin/env python3
"""The PLC monitor of the robustness rig: a PLC that polls the gateway and
moves the robot, writing what it sees as JSON lines (one event a line, with
`time.monotonic()` stamps, which every process of the machine shares).

What it does, over one Modbus TCP connection as a PLC does:
* every `--period` seconds one FC 23 request: PLC_HEARTBEAT (140) written
  with a new value, the status block 0-54 read (HEARTBEAT, LINK_STATE,
  LINK_CONNECTS, WATCHDOG, ...): event `poll` with its latency, or with
  `ok: false` and the error (then it reconnects: event `connect`);
* once a second CFG_WATCHDOG_MS (108): event `cfg` (a reset of the device
  brings back the factory 0);
* in turn, forever, on channel 0:
  - a motion: relative joint move (code 13) of 2 degrees on J1, Execute ->
    Done, Execute falls: event `motion` (`ok`, `ms`, the end it saw);
  - a watchdog check: a joint move (code 10) of J1 to +-25 degrees at
    10 deg/s; once it runs, PLC_HEARTBEAT stops changing, and the gateway
    must stop the motion (Error 39602, WATCHDOG bit 1) within
    CFG_WATCHDOG_MS: event `watchdog` (`ok`, `ms` from the last heartbeat
    change to the Error seen), then the heartbeat changes again.

At start it sets CFG_WATCHDOG_MS (`--watchdog-ms`, action 1: GrpStop) and
applies it (CONFIG_COMMAND 1), waits for the robot link, then writes the
event `ready`.
"""

import argparse
import json
import sys
import time

from modbus import Client, ModbusError, f32_words, words_f32

HEARTBEAT = 1
LINK_STATE = 3
LINK_CONNECTS = 4
ROBOT_FLAGS = 7
ACT_JOINTS = 14
MODBUS_SESSIONS = 46
WATCHDOG = 47
WATCHDOG_TRIPS = 48
STATUS_REGS = 55
CFG_WATCHDOG_MS = 108
CFG_WATCHDOG_ACTION = 109
PLC_HEARTBEAT = 140
CONFIG_COMMAND = 141
CONFIG_RESULT = 142
CH0 = 200
CH0_STATUS = 260
BUSY, DONE, ERROR, ABORTED, ACTIVE = 1, 2, 4, 8, 16
E_WATCHDOG = 39602
MOVE_J_JOINTS = 10
MOVE_REL_J = 13


class Monitor:
    def __init__(self, args, out):
        self.a = args
        self.out = out
        self.conn = None
        self.hb = 0
        self.hb_frozen = False
        self.hb_changed = time.monotonic()
        self.status = None
        self.seq = 0
        self.last_cfg = 0.0
        self.rel_sign = 1.0

    def emit(self, ev, **kv):
        kv["t"] = round(time.monotonic(), 4)
        kv["ev"] = ev
        self.out.write(json.dumps(kv) + "\n")
        self.out.flush()

    # --- the connection: polls keep it; a failure reconnects
    def client(self):
        while self.conn is None:
            t0 = time.monotonic()
            try:
                self.conn = Client(self.a.device, 502, bind=self.a.bind, timeout=self.a.timeout)
                self.emit("connect", ok=True, ms=round((time.monotonic() - t0) * 1000, 1),
                          port=self.conn.local_port())
            except ModbusError as e:
                self.emit("connect", ok=False, err=str(e))
                time.sleep(0.2)
        return self.conn

    def drop(self, err):
        if self.conn is not None:
            self.conn.close()
            self.conn = None

    def call(self, f):
        """Runs `f(client)`; on a failure drops the connection, returns None."""
        c = self.client()
        try:
            return f(c)
        except ModbusError as e:
            self.emit("error", err=str(e))
            self.drop(e)
            return None

    def poll(self):
        if not self.hb_frozen:
            self.hb = (self.hb + 1) & 0xFFFF
        hb = self.hb
        c = self.client()
        t0 = time.monotonic()
        try:
            s = c.write_read(PLC_HEARTBEAT, [hb], 0, STATUS_REGS)
        except ModbusError as e:
            self.emit("poll", ok=False, err=str(e), ms=round((time.monotonic() - t0) * 1000, 1))
            self.drop(e)
            self.status = None
            return False
        t1 = time.monotonic()
        if not self.hb_frozen:
            self.hb_changed = t0
        self.status = s
        self.emit("poll", ok=True, ms=round((t1 - t0) * 1000, 2), hb=s[HEARTBEAT],
                  link=s[LINK_STATE], conn=s[LINK_CONNECTS], wd=s[WATCHDOG],
                  trips=s[WATCHDOG_TRIPS], sessions=s[MODBUS_SESSIONS], flags=s[ROBOT_FLAGS])
        if t1 - self.last_cfg >= 1.0:
            v = self.call(lambda c: c.read(CFG_WATCHDOG_MS, 1))
            if v is not None:
                self.last_cfg = t1
                self.emit("cfg", watchdog_ms=v[0])
        return True

    def tick(self):
        """One poll period: a poll, then sleep to the next period."""
        start = time.monotonic()
        self.poll()
        left = self.a.period - (time.monotonic() - start)
        if left > 0:
            time.sleep(left)

    def wait(self, what, cond, timeout):
        """Polls until `cond(status)`; returns the time it held, or None."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            self.tick()
            if self.status is not None and cond(self.status):
                return time.monotonic()
        return None

    def ch0_status(self):
        v = self.call(lambda c: c.read(CH0_STATUS, 5))
        return v

    def execute(self, code, params):
        """Writes channel 0's inputs with Execute 0, then raises Execute."""
        self.seq = (self.seq + 1) & 0xFFFF
        words = [0, code, self.seq, 0]
        for p in params:
            words += f32_words(p)
        # As a PLC does: a write whose answer was lost is sent again on the
        # new connection (both writes can be repeated: Execute rises once).
        for regs in (words, [1]):
            if not any(self.call(lambda c: c.write(CH0, regs)) is not None for _ in range(3)):
                return False
        return True

    def release(self):
        """Execute falls; waits (up to 5 s) for the outputs to clear."""
        end = time.monotonic() + 5
        while time.monotonic() < end:
            if self.call(lambda c: c.write(CH0, [0])) is not None:
                st = self.ch0_status()
                if st is not None and st[0] == 0:
                    return True
            self.tick()
        return False

    def robot_still(self, timeout=8):
        return self.wait("robot still", lambda s: s[ROBOT_FLAGS] & 1 == 0, timeout) is not None

    def run_until_end(self, timeout, on_active=None):
        """Polls channel 0 until Done, Error or CommandAborted."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            self.tick()
            st = self.ch0_status()
            if st is None:
                continue
            if st[0] & ACTIVE and on_active:
                on_active()
                on_active = None
            if st[0] & (DONE | ERROR | ABORTED):
                err = (st[2] << 16) | st[3]
                return st[0], err
        return None, None

    def motion(self):
        self.robot_still()
        t0 = time.monotonic()
        self.rel_sign = -self.rel_sign
        if not self.execute(MOVE_REL_J, [0.0, 2.0 * self.rel_sign]):
            self.emit("motion", ok=False, why="execute not written", ms=None)
            self.release()
            return
        st, err = self.run_until_end(self.a.motion_timeout)
        ms = round((time.monotonic() - t0) * 1000, 1)
        ok = st is not None and st & DONE != 0
        why = "done" if ok else ("no end" if st is None else f"status {st} error {err}")
        self.emit("motion", ok=ok, ms=ms, why=why)
        self.release()

    def watchdog(self):
        self.robot_still()
        if self.status is None:
            return
        joints = [words_f32(self.status[ACT_JOINTS + 2 * i: ACT_JOINTS + 2 * i + 2]) for i in range(6)]
        joints[0] = -25.0 if joints[0] >= 0 else 25.0
        t0 = time.monotonic()
        if not self.execute(MOVE_J_JOINTS, joints + [10.0, 90.0, 0.0]):
            self.emit("watchdog", ok=False, why="execute not written", ms=None)
            self.release()
            return
        frozen = {}

        def freeze():
            self.hb_frozen = True
            frozen["at"] = self.hb_changed

        st, err = self.run_until_end(self.a.motion_timeout, on_active=freeze)
        seen = time.monotonic()
        was_frozen = self.hb_frozen
        self.hb_frozen = False
        if not was_frozen:
            self.emit("watchdog", ok=False, why="the motion never ran", ms=None)
        elif st is not None and st & ERROR and err == E_WATCHDOG:
            ms = round((seen - frozen["at"]) * 1000, 1)
            self.emit("watchdog", ok=ms <= self.a.watchdog_ms + self.a.watchdog_slack_ms, ms=ms,
                      why="stopped")
        else:
            self.emit("watchdog", ok=False, ms=round((seen - t0) * 1000, 1),
                      why="no end" if st is None else f"status {st} error {err}")
        self.release()

    def setup(self):
        while True:
            r = self.call(lambda c: (c.write(CFG_WATCHDOG_MS, [self.a.watchdog_ms, 1]),
                                     c.write(CONFIG_COMMAND, [1]),
                                     c.read(CONFIG_RESULT, 1))[2])
            if r is not None and r[0] in (0, 3):
                break
            time.sleep(0.5)
        if self.wait("link", lambda s: s[LINK_STATE] == 3, 60) is None:
            self.emit("fatal", why="the robot link never came up")
            sys.exit(1)
        self.release()
        self.emit("ready")

    def run(self):
        self.setup()
        while True:
            self.motion()
            self.watchdog()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", default="10.0.2.15")
    ap.add_argument("--bind", default=None, help="source address of the PLC")
    ap.add_argument("--events", required=True, help="JSON-lines file to append events to")
    ap.add_argument("--period", type=float, default=0.05, help="poll period [s]")
    ap.add_argument("--timeout", type=float, default=1.0, help="one request's deadline [s]")
    ap.add_argument("--watchdog-ms", type=int, default=1000)
    ap.add_argument("--watchdog-slack-ms", type=int, default=500)
    ap.add_argument("--motion-timeout", type=float, default=6.0)
    a = ap.parse_args()
    with open(a.events, "a", buffering=1) as out:
        try:
            Monitor(a, out).run()
        except KeyboardInterrupt:
            pass


if __name__ == "__main__":
    main()
