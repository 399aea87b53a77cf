"""What a PLC cycle sees, measured in the rig (not a test: numbers for
plc/README.md, "Timing"). Runs hans-sim at real speed and hans-gateway on
127.0.0.1, the library in the interpreter on a fixed PLC cycle, and reports
in PLC scans and milliseconds:

* the adapter's transfers per scan (7 reads + 5 writes, one connection);
* a command that is not a motion (MC_WriteDigitalOutput): from the scan
  whose writes carry the rising edge to the first scan that reads Busy,
  and to the first that reads Done;
* a motion (MC_MoveLinearAbsolute, 20 mm at 200 mm/s): from the scan that
  writes the rising edge to the first that reads Done;
* the scan period the rig holds;
* the same output command through an adapter that moves one block of the
  table per scan (TwinCAT's and MB_CLIENT's way).

Usage (after scripts/plc-tests.sh has built the binaries and the venv):
  target/plc-venv/bin/python plc/tests/measure_timing.py [--cycle MS] [--runs N]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tools"))

from rig import Cell, Plc  # noqa: E402

HOME = {"X": 420.0, "Y": 0.0, "Z": 445.0, "RX": 180.0, "RY": 0.0, "RZ": 180.0}


def summary(xs):
    xs = sorted(xs)
    p90 = xs[min(len(xs) - 1, int(round(0.9 * (len(xs) - 1))))]
    return f"median {statistics.median(xs):6.1f}  p90 {p90:6.1f}  max {max(xs):6.1f}  (n={len(xs)})"


class Timed(Plc):
    """The rig's PLC, timing its transfers."""

    def __init__(self, *a, **kw):
        super().__init__(*a, **kw)
        self.transfer_ms = []

    def transfer(self, writes):
        t = time.perf_counter()
        ok = super().transfer(writes)
        if not writes:
            self._t_read = time.perf_counter() - t
        else:
            self.transfer_ms.append((self._t_read + time.perf_counter() - t) * 1000)
        return ok


def enable(p):
    p.run_until(lambda p: p.task.vars["VALID"], 100, "valid")
    p.block("enable", "MC_EnableRobot")
    p.logic.append(lambda p: p.call("enable", Enable=True))
    p.run_until(lambda p: p.blocks["enable"].vars["STATUS"] or p.blocks["enable"].vars["ERROR"], 3000, "enabled")
    if not p.blocks["enable"].vars["STATUS"]:
        raise RuntimeError(f"enable: Error {p.blocks['enable'].vars['ERRORID']}")


def output_command(p, runs):
    """Scans from the scan that writes the rising edge to Busy read, and to
    Done read; and the milliseconds to Done."""
    ins = {"EXECUTE": False, "OUTPUTNUMBER": 1, "VALUE": False, "TOOLOUTPUT": True}
    p.block("out", "MC_WriteDigitalOutput")
    p.logic.append(lambda p: p.call("out", **ins))
    busy, done, ms = [], [], []
    for i in range(runs):
        ins["EXECUTE"] = False
        for _ in range(3):
            p.scan()
        ins["VALUE"] = not ins["VALUE"]
        ins["EXECUTE"] = True
        p.scan()            # this scan's writes carry the rising edge
        s0, t0 = p.scans, time.monotonic()
        seen_busy = None
        while not p.blocks["out"].vars["DONE"]:
            p.scan()
            if seen_busy is None and p.blocks["out"].vars["BUSY"]:
                seen_busy = p.scans - s0
            if p.scans - s0 > 2000:
                raise RuntimeError("no Done")
        busy.append(seen_busy if seen_busy is not None else p.scans - s0)
        done.append(p.scans - s0)
        ms.append((time.monotonic() - t0) * 1000)
    p.logic.pop()
    return busy, done, ms


def move(p, runs):
    """A 20 mm linear move: scans and milliseconds from the scan that
    writes the rising edge to Done read (the robot's own motion included:
    the PLC cannot see the robot's end before the gateway does, which shows
    ROBOT_FLAGS and Done in the same update)."""
    ins = {"EXECUTE": False, "POSITION": dict(HOME), "VELOCITY": 200.0}
    p.block("mv", "MC_MoveLinearAbsolute")
    p.logic.append(lambda p: p.call("mv", **ins))
    scans, ms = [], []
    for i in range(runs):
        ins["EXECUTE"] = False
        for _ in range(3):
            p.scan()
        ins["POSITION"] = dict(HOME, Y=20.0 if i % 2 == 0 else 0.0)
        ins["EXECUTE"] = True
        p.scan()
        s0, t0 = p.scans, time.monotonic()
        while not (p.blocks["mv"].vars["DONE"] or p.blocks["mv"].vars["ERROR"]):
            p.scan()
            if p.scans - s0 > 5000:
                raise RuntimeError("no Done")
        if p.blocks["mv"].vars["ERROR"]:
            raise RuntimeError(f"move: Error {p.blocks['mv'].vars['ERRORID']}")
        scans.append(p.scans - s0)
        ms.append((time.monotonic() - t0) * 1000)
    p.logic.pop()
    return scans, ms


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cycle", type=float, default=10.0, help="PLC cycle [ms]")
    ap.add_argument("--runs", type=int, default=30)
    a = ap.parse_args()
    cycle = a.cycle / 1000.0
    print(f"PLC cycle {a.cycle:g} ms; hans-sim --speed 1; hans-gateway defaults (poll 100 ms idle, 10 ms moving); "
          f"{os.cpu_count()} CPUs, load {os.getloadavg()[0]:.1f}")
    cell = Cell(speed="1")
    try:
        p = Timed(cell, cycle=cycle)
        enable(p)
        busy, done, ms = output_command(p, a.runs)
        print(f"transfers per scan [ms]:            {summary(p.transfer_ms)}")
        print(f"output: edge written -> Busy read [scans]: {summary(busy)}")
        print(f"output: edge written -> Done read [scans]: {summary(done)}")
        print(f"output: edge written -> Done read [ms]:    {summary(ms)}")
        scans, ms = move(p, max(4, a.runs // 3))
        print(f"move 20 mm: edge written -> Done read [scans]: {summary(scans)}")
        print(f"move 20 mm: edge written -> Done read [ms]:    {summary(ms)}")
        t0, s0 = time.monotonic(), p.scans
        for _ in range(100):
            p.scan()
        print(f"scan period (target {a.cycle:g} ms) [ms]: {(time.monotonic() - t0) * 1000 / (p.scans - s0):.1f}")
        p.close()
    finally:
        cell.stop()
    cell = Cell(speed="1")
    try:
        p = Plc(cell, cycle=cycle, one_block_per_scan=True)
        enable(p)
        busy, done, ms = output_command(p, max(5, a.runs // 3))
        print(f"one block per scan: output edge -> Done read [scans]: {summary(done)}")
        print(f"one block per scan: output edge -> Done read [ms]:    {summary(ms)}")
        p.close()
    finally:
        cell.stop()


if __name__ == "__main__":
    main()
