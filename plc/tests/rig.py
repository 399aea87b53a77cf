"""The test rig: the real hans-sim and hans-gateway on 127.0.0.1 (free
ports), a small Modbus TCP client, and a PLC that runs the library's ST in
the interpreter scan by scan, moving the register image the way the
library's adapters do (HANS_TransferInfo: reads before the logic, writes
after it)."""

from __future__ import annotations

import os
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
PLC = HERE.parent
ROOT = PLC.parent
sys.path.insert(0, str(PLC / "tools"))

import stinterp  # noqa: E402

LIBRARY = [PLC / "src" / "HansTypes.st", PLC / "src" / "HansCore.st", PLC / "src" / "HansBlocks.st"]


def binary(name: str) -> str:
    env = {"hans-gateway": "HANS_GATEWAY", "hans-sim": "HANS_SIM"}[name]
    path = os.environ.get(env) or str(ROOT / "target" / "debug" / name)
    if not os.path.exists(path):
        raise RuntimeError(f"{path} missing: build it (scripts/plc-tests.sh does)")
    return path


class Proc:
    """A child process whose stderr and stdout lines are collected."""

    def __init__(self, args):
        self.args = args
        self.p = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        self.lines: list[str] = []
        self.cond = threading.Condition()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        for line in self.p.stdout:
            with self.cond:
                self.lines.append(line.rstrip("\n"))
                self.cond.notify_all()

    def wait_for(self, needle: str, timeout: float = 20.0) -> str:
        deadline = time.monotonic() + timeout
        with self.cond:
            while True:
                for line in self.lines:
                    if needle in line:
                        return line
                left = deadline - time.monotonic()
                if left <= 0 or self.p.poll() is not None:
                    raise RuntimeError(f"{self.args[0]}: no '{needle}' within {timeout} s:\n" + "\n".join(self.lines[-30:]))
                self.cond.wait(left)

    def stop(self):
        if self.p.poll() is None:
            self.p.send_signal(signal.SIGKILL)
            self.p.wait(timeout=10)


class Modbus:
    """A minimal Modbus TCP client: FC 3 and FC 16 (and FC 2, 4 and 15, as
    OpenPLC's slave devices use them), one request at a time, every wait
    bounded."""

    def __init__(self, host: str, port: int, timeout: float = 0.5):
        self.addr = (host, port)
        self.timeout = timeout
        self.sock = None
        self.tid = 0

    def close(self):
        if self.sock is not None:
            self.sock.close()
            self.sock = None

    def _connect(self):
        if self.sock is None:
            self.sock = socket.create_connection(self.addr, timeout=self.timeout)
            self.sock.settimeout(self.timeout)

    def _request(self, pdu: bytes) -> bytes:
        try:
            self._connect()
            self.tid = (self.tid + 1) & 0xFFFF
            self.sock.sendall(struct.pack(">HHHB", self.tid, 0, len(pdu) + 1, 1) + pdu)
            head = self._exact(7)
            tid, _, length, _ = struct.unpack(">HHHB", head)
            body = self._exact(length - 1)
            if tid != self.tid:
                raise OSError("transaction id mismatch")
            if body[0] & 0x80:
                raise OSError(f"exception {body[1]}")
            return body
        except OSError:
            self.close()
            raise

    def _exact(self, n: int) -> bytes:
        out = b""
        while len(out) < n:
            chunk = self.sock.recv(n - len(out))
            if not chunk:
                raise OSError("closed")
            out += chunk
        return out

    def read(self, addr: int, count: int) -> list[int]:
        body = self._request(struct.pack(">BHH", 3, addr, count))
        return list(struct.unpack(f">{count}H", body[2:2 + 2 * count]))

    def write(self, addr: int, values: list[int]) -> None:
        data = struct.pack(f">{len(values)}H", *values)
        self._request(struct.pack(">BHHB", 16, addr, len(values), len(data)) + data)

    def read_input_registers(self, addr: int, count: int) -> list[int]:
        body = self._request(struct.pack(">BHH", 4, addr, count))
        return list(struct.unpack(f">{count}H", body[2:2 + 2 * count]))

    def read_discrete_inputs(self, addr: int, count: int) -> list[bool]:
        body = self._request(struct.pack(">BHH", 2, addr, count))
        return [bool(body[2 + i // 8] >> (i % 8) & 1) for i in range(count)]

    def write_coils(self, addr: int, values: list[bool]) -> None:
        data = bytearray((len(values) + 7) // 8)
        for i, on in enumerate(values):
            if on:
                data[i // 8] |= 1 << (i % 8)
        self._request(struct.pack(">BHHB", 15, addr, len(values), len(data)) + bytes(data))


def free_port() -> int:
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


class Cell:
    """hans-sim and hans-gateway, started for one test and stopped after it."""

    def __init__(self, sim_args=(), gateway_toml="", speed="4"):
        self.tmp = tempfile.TemporaryDirectory(prefix="plc-cell-")
        self.sim_args = list(sim_args)
        self.speed = speed
        self.sim = None
        self.start_sim()
        cfg = Path(self.tmp.name) / "gateway.toml"
        cfg.write_text('[registers]\nnumber_format = "thousandths"\n' + gateway_toml)
        self.gateway = Proc([
            binary("hans-gateway"), "--robot", f"127.0.0.1:{self.sim_port}",
            "--modbus-listen", "127.0.0.1:0", "--config", str(cfg),
            "--setup-code-file", str(Path(self.tmp.name) / "setup-code"),
        ])
        line = self.gateway.wait_for("modbus server on ")
        self.modbus_port = int(line.rsplit(":", 1)[1])

    def start_sim(self, port: int = 0):
        self.sim = Proc([binary("hans-sim"), "--command-port", str(port), "--datasheet-ports", "",
                         "--no-fast-port", "--speed", self.speed] + self.sim_args)
        line = self.sim.wait_for("command port listening on ")
        self.sim_port = int(line.rsplit(":", 1)[1])

    def stop(self):
        for p in (getattr(self, "gateway", None), self.sim):
            if p is not None:
                p.stop()
        self.tmp.cleanup()


class Plc:
    """A PLC running the library: the interpreter, the register image moved
    over Modbus TCP, scan by scan on a fixed cycle."""

    def __init__(self, cell: Cell, extra_sources=(), cycle: float = 0.01, run_task: bool = True,
                 one_block_per_scan: bool = False, adapter=None, natives=None):
        self.clock0 = time.monotonic()
        self.prog = stinterp.Program(LIBRARY + list(extra_sources), clock=self.now, natives=natives)
        self.cell = cell
        self.mb = Modbus("127.0.0.1", cell.modbus_port)
        self.cycle = cycle
        self.run_task = run_task
        # The adapters whose client does one transaction at a time (TwinCAT's
        # FB_MBReadRegs/FB_MBWriteRegs, Siemens MB_CLIENT) move one block of
        # the transfer table per scan, in the table's order, at the start of
        # the scan: the image is refreshed block by block, 12 scans a round.
        self.one_block_per_scan = one_block_per_scan
        self.next_block = 0
        # Or an adapter of the library's own, in ST, called first in every
        # scan with these inputs (and the axes group): it moves the image.
        self.adapter = None
        if adapter is not None:
            name, self.adapter_inputs = adapter
            self.adapter = self.prog.instantiate(name)
        self.group = self.prog.default(self.prog.resolve_type("HANS_AXES_GROUP"))
        self.task = self.prog.instantiate("MC_RobotTask")
        self.info = self.prog.instantiate("HANS_TransferInfo")
        self.table = []
        for i in range(12):
            self.prog.call_fb(self.info, {"INDEX": i})
            v = self.info.vars
            assert v["VALID"]
            self.table.append((v["REGISTER"], v["IMAGEINDEX"], v["COUNT"], v["ISWRITE"]))
        self.scans = 0
        self.blocks: dict[str, stinterp.Instance] = {}
        self.logic = []        # callables run each scan after MC_RobotTask
        self.frozen = False    # the PLC stalls: no scans, nothing written
        self.last = time.monotonic()

    def now(self) -> float:
        return time.monotonic() - self.clock0

    def block(self, name: str, fb_type: str) -> stinterp.Instance:
        inst = self.prog.instantiate(fb_type)
        self.blocks[name] = inst
        return inst

    def group_ref(self):
        return stinterp.Ref({"G": self.group}, "G")

    def call(self, name: str, **inputs):
        """Calls a block this scan with these inputs (and the axes group)."""
        inst = self.blocks[name]
        args = {k.upper(): v for k, v in inputs.items()}
        args["AXESGROUP"] = self.group_ref()
        self.prog.call_fb(inst, args)
        return inst.vars

    def transfer(self, writes: bool) -> bool:
        image = self.group["IMAGE"]
        ok = True
        for reg, idx, count, is_write in self.table:
            if is_write != writes:
                continue
            try:
                if is_write:
                    self.mb.write(reg, [image[idx + k] for k in range(count)])
                else:
                    words = self.mb.read(reg, count)
                    for k, w in enumerate(words):
                        image[idx + k] = w
            except OSError:
                ok = False
                break
        return ok

    def scan(self):
        """One PLC cycle: read, MC_RobotTask, the test's logic, write."""
        # Hold the cycle time (a PLC's task period).
        wait = self.last + self.cycle - time.monotonic()
        if wait > 0:
            time.sleep(wait)
        self.last = time.monotonic()
        if self.adapter is not None:
            args = {k.upper(): v for k, v in self.adapter_inputs.items()}
            args["AXESGROUP"] = self.group_ref()
            self.prog.call_fb(self.adapter, args)
        elif self.one_block_per_scan:
            self.group["TRANSPORTOK"] = self.transfer_one()
        else:
            ok = self.transfer(writes=False)
            self.group["TRANSPORTOK"] = ok
        if self.run_task:
            self.prog.call_fb(self.task, {"AXESGROUP": self.group_ref()})
        for f in self.logic:
            f(self)
        if self.adapter is None and not self.one_block_per_scan and ok:
            self.group["TRANSPORTOK"] = self.transfer(writes=True)
        self.scans += 1

    def transfer_one(self) -> bool:
        """One block of the table (the next in turn): read into the image,
        or written from it as the last scan left it."""
        reg, idx, count, is_write = self.table[self.next_block]
        self.next_block = (self.next_block + 1) % len(self.table)
        image = self.group["IMAGE"]
        try:
            if is_write:
                self.mb.write(reg, [image[idx + k] for k in range(count)])
            else:
                for k, w in enumerate(self.mb.read(reg, count)):
                    image[idx + k] = w
        except OSError:
            return False
        return True

    def run_until(self, cond, scans: int = 2000, what: str = "condition"):
        """Scans until cond(self) holds; fails after `scans` scans."""
        for _ in range(scans):
            self.scan()
            if cond(self):
                return
        raise AssertionError(f"{what}: not reached within {scans} scans")

    def close(self):
        self.mb.close()
