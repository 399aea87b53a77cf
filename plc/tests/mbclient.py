"""An emulation of Siemens MB_CLIENT's interface, for running the TIA
adapter (adapters/SiemensMbClientAdapter.st, the source of
scl/HansMbClientAdapter.scl) scan by scan against the real gateway.

What it keeps of the instruction, from its documentation: REQ, DISCONNECT,
MB_MODE, MB_DATA_ADDR, MB_DATA_LEN, MB_DATA_PTR (the words moved), CONNECT
(a TCON_IP_v4: TCP, active, remote address and port) in; DONE, BUSY, ERROR
(each for one call when a job ends) and STATUS out; one job at a time per
instance; the parameters taken when a job starts. Where the documentation
leaves room it takes the stricter reading, so that an adapter that works
here does not lean on the lenient one:
* a job starts only at a call whose REQ is TRUE after a call with REQ FALSE
  (a rising edge; the adapter must let REQ fall between jobs);
* a job started at one call ends at the next call at the earliest (BUSY in
  between), as the real one, whose reply arrives in a later cycle;
* MB_MODE 103 (FC 3, MB_DATA_ADDR the 0-based register address, 1-125
  words) and 116 (FC 16, 1-123 words) only; anything else, a buffer shorter
  than MB_DATA_LEN or a CONNECT that is not an active TCP connection ends
  in ERROR.
STATUS here: 16#0000 after DONE, 16#7001 while BUSY, 16#8xxx after ERROR
(16#8380 + the Modbus exception code, 16#80A1 no connection, 16#8188 a bad
mode, 16#8189 a bad length); the adapter only copies it."""

from __future__ import annotations

import stinterp
from rig import Modbus


def t(name: str) -> stinterp.Type:
    return stinterp.Type("bool", name) if name == "BOOL" else stinterp.Type("int", name)


class MbClient(stinterp.Native):
    def __init__(self):
        self.meta = {
            "REQ": ("in", t("BOOL")), "DISCONNECT": ("in", t("BOOL")), "MB_MODE": ("in", t("USINT")),
            "MB_DATA_ADDR": ("in", t("UDINT")), "MB_DATA_LEN": ("in", t("UINT")),
            "MB_DATA_PTR": ("inout", None), "CONNECT": ("inout", None),
            "DONE": ("out", t("BOOL")), "BUSY": ("out", t("BOOL")), "ERROR": ("out", t("BOOL")),
            "STATUS": ("out", t("WORD")),
            "LASTREQ": ("var", t("BOOL")), "JOB": ("var", t("INT")),
        }
        self.clients: dict[int, Modbus] = {}   # per instance
        self.results: dict[int, tuple] = {}
        self.jobs = 0                           # jobs started, all instances

    def call(self, program, inst):
        v = inst.vars
        key = id(inst)
        v["DONE"] = v["ERROR"] = False
        req = bool(v["REQ"])
        if v["DISCONNECT"]:
            if key in self.clients:
                self.clients.pop(key).close()
        if key in self.results:
            # The job started at an earlier call ends now.
            ok, status = self.results.pop(key)
            v["BUSY"] = False
            v["DONE"], v["ERROR"], v["STATUS"] = ok, not ok, status
        elif req and not v["LASTREQ"] and not v["BUSY"]:
            self.results[key] = self.job(v, key)
            self.jobs += 1
            v["BUSY"], v["STATUS"] = True, 0x7001
        v["LASTREQ"] = req

    def job(self, v, key) -> tuple:
        conn = v["CONNECT"].get()
        if conn["CONNECTIONTYPE"] != 0x0B or not conn["ACTIVEESTABLISHED"]:
            return False, 0x80A1
        mode, addr, n = v["MB_MODE"], v["MB_DATA_ADDR"], v["MB_DATA_LEN"]
        buf = v["MB_DATA_PTR"].get()
        if mode not in (103, 116):
            return False, 0x8188
        if n < 1 or n > (125 if mode == 103 else 123) or n > len(buf.items) or addr > 65535:
            return False, 0x8189
        host = ".".join(str(conn["REMOTEADDRESS"]["ADDR"][i]) for i in range(1, 5))
        if key not in self.clients:
            self.clients[key] = Modbus(host, conn["REMOTEPORT"])
        mb = self.clients[key]
        try:
            if mode == 103:
                words = mb.read(addr, n)
                for k, w in enumerate(words):
                    buf.items[k] = w
            else:
                mb.write(addr, buf.items[:n])
        except OSError as e:
            text = str(e)
            if text.startswith("exception "):
                return False, 0x8380 + int(text.split()[1])
            return False, 0x80A1
        return True, 0x0000

    def close(self):
        for mb in self.clients.values():
            mb.close()
        self.clients.clear()
