"""The OpenPLC (runtime v3) wiring: the generated adapter is its generator's
output, the slave-device plan covers exactly the transfer table within
OpenPLC's limits and the gateway's per-address cap, and HansOpenPlcMain runs
in the interpreter with its located variables moved the way OpenPLC's
runtime moves them (modbus_master.cpp: one connection per device, areas
polled in their order, the buffers mapped from %IX100.0 / %IW100 /
%QX100.0 / %QW100), against the real gateway."""

from __future__ import annotations

import re
import time

import pytest

import openplc
import stinterp
from rig import LIBRARY, PLC, ROOT, Modbus
from test_blocks import cell, outs, pose  # noqa: F401 (cell is a fixture)

ADAPTER = PLC / "adapters" / "OpenPlcAdapter.st"


def test_the_committed_openplc_adapter_is_the_generators_output():
    assert ADAPTER.read_text() == openplc.generate(), "run plc/tools/openplc.py"


def test_the_device_plan_covers_exactly_the_transfer_table():
    table = openplc.transfer_table()
    assert len(table) == 12
    wanted = [(reg, count, is_write) for reg, _, count, is_write in table]
    areas = [(name, area, start, size) for name, areas in openplc.DEVICES for area, (start, size) in areas.items()]
    got = []
    for name, area, start, size in areas:
        if area in ("di", "coils"):
            # A bit area stands for whole registers: 16 bits each, from bit 0.
            assert start % 16 == 0 and size % 16 == 0, (name, area)
            start, size = start // 16, size // 16
        got.append((start, size, area in ("coils", "hr_write")))
    assert sorted(got) == sorted(wanted)  # each block once, nothing more
    assert openplc.word_blocks() == set(wanted)


def test_each_device_keeps_openplc_limits_and_the_gateway_cap():
    text = (ROOT / "gateway" / "REGISTERS.md").read_text()
    cap = int(re.search(r"at most (\d+) from one address", text).group(1))
    assert len(openplc.DEVICES) <= cap, "one TCP connection per slave device"
    assert len({name for name, _ in openplc.DEVICES}) == len(openplc.DEVICES)
    totals = {"bits in": 0, "bits out": 0, "words in": 0, "words out": 0}
    for name, areas in openplc.DEVICES:
        # The page has one area of each kind per device.
        assert set(areas) <= {"di", "coils", "ir", "hr_read", "hr_write"}, name
        for area, (start, size) in areas.items():
            assert 0 < size <= openplc.LIMITS[area], (name, area, size)
            assert 0 <= start and start + size <= 65536, (name, area)
            totals[{"di": "bits in", "coils": "bits out", "ir": "words in", "hr_read": "words in",
                    "hr_write": "words out"}[area]] += size
    assert all(n <= openplc.MAX_MB_IO for n in totals.values()), totals


def test_the_readme_has_the_device_table():
    readme = (PLC / "README.md").read_text()
    assert openplc.device_table() in readme, "paste `plc/tools/openplc.py --table` into plc/README.md"


class Runtime:
    """OpenPLC runtime v3's slave-device side, after modbus_master.cpp: one
    connection per device; each poll walks the devices in order and, in each,
    reads the discrete inputs, writes the coils, reads the input registers,
    reads the holding registers, writes the holding registers; every area
    takes the next places of its buffer (bits in, bits out, words in, words
    out; 400 each); a failed request closes that device's connection (its
    places are skipped). The buffers meet the program's located variables at
    %IX100.0 + i (8 bits an address), %IW100 + i, %QX100.0 + i, %QW100 + i,
    before and after each scan."""

    def __init__(self, devices, port=None):
        self.devices = devices
        self.conns = [Modbus("127.0.0.1", port) for _ in devices] if port else []
        self.bool_in = [False] * openplc.MAX_MB_IO
        self.bool_out = [False] * openplc.MAX_MB_IO
        self.int_in = [0] * openplc.MAX_MB_IO
        self.int_out = [0] * openplc.MAX_MB_IO
        self.failures = 0

    def poll(self):
        bi = bo = wi = wo = 0
        for (name, areas), mb in zip(self.devices, self.conns):
            for area in ("di", "coils", "ir", "hr_read", "hr_write"):
                if area not in areas:
                    continue
                start, size = areas[area]
                try:
                    if area == "di":
                        self.bool_in[bi:bi + size] = mb.read_discrete_inputs(start, size)
                    elif area == "coils":
                        mb.write_coils(start, self.bool_out[bo:bo + size])
                    elif area == "ir":
                        self.int_in[wi:wi + size] = mb.read_input_registers(start, size)
                    elif area == "hr_read":
                        self.int_in[wi:wi + size] = mb.read(start, size)
                    else:
                        mb.write(start, self.int_out[wo:wo + size])
                except OSError:
                    self.failures += 1
                if area == "di":
                    bi += size
                elif area == "coils":
                    bo += size
                elif area in ("ir", "hr_read"):
                    wi += size
                else:
                    wo += size

    @staticmethod
    def place(where: str):
        m = re.fullmatch(r"%([IQ])([XW])(\d+)(?:\.(\d))?", where)
        assert m, where
        if m.group(2) == "X":
            return m.group(1), "X", (int(m.group(3)) - 100) * 8 + int(m.group(4))
        return m.group(1), "W", int(m.group(3)) - 100

    def buffers_in(self, inst, locations):
        for var, where in locations.items():
            io, size, i = self.place(where)
            if io == "I":
                inst.vars[var] = self.bool_in[i] if size == "X" else self.int_in[i]

    def buffers_out(self, inst, locations):
        for var, where in locations.items():
            io, size, i = self.place(where)
            if io == "Q":
                if size == "X":
                    self.bool_out[i] = bool(inst.vars[var])
                else:
                    self.int_out[i] = inst.vars[var]

    def close(self):
        for mb in self.conns:
            mb.close()


def program(clock=None):
    prog = stinterp.Program(LIBRARY + [ADAPTER], clock=clock, located=True)
    return prog, prog.instantiate("HansOpenPlcMain"), prog.locations["HANSOPENPLCMAIN"]


def test_the_program_puts_every_word_where_the_plan_and_the_table_say():
    """Each register's value, set where OpenPLC's buffers put it, lands at its
    image index; each image word to write reaches the places of its register."""
    prog, main, locations = program()
    rt = Runtime(openplc.DEVICES)
    # Fill the input buffers as a poll would, with a value per register.
    mark = lambda r: (r * 7919 + 13) & 0xFFFF  # noqa: E731
    bi = wi = 0
    for _, areas in openplc.DEVICES:
        for area in ("di", "ir", "hr_read"):
            if area in areas:
                start, size = areas[area]
                for k in range(size):
                    if area == "di":
                        r, b = divmod(start + k, 16)
                        rt.bool_in[bi + k] = bool(mark(r) >> b & 1)
                    else:
                        rt.int_in[wi + k] = mark(start + k)
                if area == "di":
                    bi += size
                else:
                    wi += size
    rt.buffers_in(main, locations)
    prog.call_fb(main, {})
    image = main.vars["GROUP"]["IMAGE"]
    table = openplc.transfer_table()
    for reg, idx, count, is_write in table:
        if not is_write:
            assert [image[idx + k] for k in range(count)] == [mark(reg + k) for k in range(count)], reg
    # The outputs: a word per register in the image, then one more scan
    # (the program copies the image out at its end).
    for reg, idx, count, is_write in table:
        if is_write:
            for k in range(count):
                image[idx + k] = mark(reg + k)
    # MC_RobotTask counts PLC_HEARTBEAT (image 320) on in each scan: let it
    # count to the heartbeat's mark.
    main.vars["ROBOTTASK"]["BEAT"] = mark(140) - 1
    prog.call_fb(main, {})
    rt.buffers_out(main, locations)
    bo = wo = 0
    seen = {}
    for _, areas in openplc.DEVICES:
        for area in ("coils", "hr_write"):
            if area in areas:
                start, size = areas[area]
                for k in range(size):
                    if area == "coils":
                        r, b = divmod(start + k, 16)
                        seen[r] = seen.get(r, 0) | (int(rt.bool_out[bo + k]) << b)
                    else:
                        seen[start + k] = rt.int_out[wo + k]
                if area == "coils":
                    bo += size
                else:
                    wo += size
    want = {reg + k: mark(reg + k) for reg, _, count, is_write in table if is_write for k in range(count)}
    assert seen == want


@pytest.mark.parametrize("poll_every", [1, 3])
def test_openplc_wiring_drives_a_move_to_done(cell, poll_every):
    """Three connections to the gateway, polled after every scan or every
    third (the runtime's thread has its own period, 100 ms by default, longer
    than a scan), HansOpenPlcMain in the interpreter: the robot is enabled
    and a linear move ends Done with the position read back."""
    t0 = time.monotonic()
    prog, main, locations = program(clock=lambda: time.monotonic() - t0)
    rt = Runtime(openplc.DEVICES, port=cell.modbus_port)
    group = stinterp.Ref(main.vars, "GROUP")
    blocks = {}
    inputs = {}
    scans = [0]

    def use(name, fb_type, **ins):
        blocks[name] = prog.instantiate(fb_type)
        inputs[name] = {k.upper(): v for k, v in ins.items()}

    def scan():
        rt.buffers_in(main, locations)
        prog.call_fb(main, {})
        # The cell's blocks, after the program (their writes go out with the
        # next scan's copy: the library waits for the gateway to show them).
        for name, inst in blocks.items():
            prog.call_fb(inst, dict(inputs[name], AXESGROUP=group))
        rt.buffers_out(main, locations)
        scans[0] += 1
        if scans[0] % poll_every == 0:
            rt.poll()

    def until(cond, scans, what):
        for _ in range(scans):
            scan()
            if cond():
                return
        raise AssertionError(f"{what}: not within {scans} scans")

    try:
        until(lambda: main.vars["ROBOTTASK"]["VALID"], 50 * poll_every, "MC_RobotTask valid")
        # MODBUS_SESSIONS (46): the three devices' connections (the first
        # device reads it before the others connect in the first poll).
        until(lambda: main.vars["GROUP"]["IMAGE"][46] == 3, 3 * poll_every, "three sessions")
        use("enable", "MC_EnableRobot", Enable=True)
        until(lambda: blocks["enable"].vars["STATUS"] or blocks["enable"].vars["ERROR"], 1500, "enabled")
        assert outs(blocks["enable"].vars, "STATUS", "ERROR") == {"STATUS": True, "ERROR": False}
        use("mv", "MC_MoveLinearAbsolute", Execute=True, Position=pose(Y=40.0), Velocity=150.0)
        use("pos", "MC_ReadActualPosition", Enable=True)
        until(lambda: not blocks["mv"].vars["BUSY"], 1500, "move ended")
        assert outs(blocks["mv"].vars, "DONE", "ERROR", "ERRORID") == {"DONE": True, "ERROR": False, "ERRORID": 0}
        until(lambda: blocks["pos"].vars["VALID"] and abs(blocks["pos"].vars["POSITION"]["Y"] - 40.0) < 0.01,
              20, "position read back")
        assert rt.failures == 0
    finally:
        rt.close()
