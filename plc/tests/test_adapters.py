"""The platform adapters that are more than a copy: Siemens' (MB_CLIENT),
run scan by scan in the interpreter against the real gateway, with MB_CLIENT
emulated after its documented interface (tests/mbclient.py, the stricter
reading where the documentation leaves room)."""

from __future__ import annotations

import pytest

from mbclient import MbClient
from rig import PLC, Plc
from test_blocks import cell, drive, outs, pose, v  # noqa: F401 (cell is a fixture)

SIEMENS = [PLC / "tests" / "siemens_types.st", PLC / "adapters" / "SiemensMbClientAdapter.st"]


def siemens_plc(cell, client):
    p = Plc(cell, extra_sources=SIEMENS, natives={"MB_CLIENT": client},
            adapter=("HANS_MbClientAdapter", {"IpOctet1": 127, "IpOctet2": 0, "IpOctet3": 0, "IpOctet4": 1,
                                              "Port": cell.modbus_port}))
    # A round of the table takes 36 scans or more: the gateway's HEARTBEAT
    # moves in the image once a round (plc/README.md: GatewayTimeout above
    # two rounds; T#3S for MB_CLIENT).
    p.task.vars["GATEWAYTIMEOUT"] = 3.0
    return p


def test_the_mb_client_adapter_runs_the_blocks(cell):
    client = MbClient()
    p = siemens_plc(cell, client)
    try:
        p.run_until(lambda p: p.adapter.vars["ROUNDS"] >= 1, 80, "one round of the 12 blocks")
        assert client.jobs == 12 and p.task.vars["VALID"]
        p.block("enable", "MC_EnableRobot")
        p.logic.append(lambda p: p.call("enable", Enable=True))
        p.run_until(lambda p: v(p, "enable")["STATUS"] or v(p, "enable")["ERROR"], 4000, "enabled")
        assert v(p, "enable")["STATUS"], outs(v(p, "enable"), "ERROR", "ERRORID")
        drive(p, "mv", "MC_MoveLinearAbsolute", Execute=True, Position=pose(Y=50.0), Velocity=200.0)
        drive(p, "out", "MC_WriteDigitalOutput", Execute=True, OutputNumber=2, Value=True, ToolOutput=True)
        drive(p, "pos", "MC_ReadActualPosition", Enable=True)
        p.run_until(lambda p: not v(p, "mv")["BUSY"] and not v(p, "out")["BUSY"], 4000, "move and output ended")
        assert outs(v(p, "mv"), "DONE", "ERROR", "ERRORID") == {"DONE": True, "ERROR": False, "ERRORID": 0}
        assert outs(v(p, "out"), "DONE", "ERROR", "ERRORID") == {"DONE": True, "ERROR": False, "ERRORID": 0}
        # The position comes back through the adapter's reads.
        p.run_until(lambda p: v(p, "pos")["VALID"] and abs(v(p, "pos")["POSITION"]["Y"] - 50.0) < 0.01, 100,
                    "position read back")
        p.run_until(lambda p: p.group["IMAGE"][43] & 4, 100, "END_DO bit 2 reads 1")
        assert p.adapter.vars["STATUS"] == 0 and p.group["TRANSPORTOK"]
    finally:
        client.close()


def test_the_mb_client_adapter_reports_a_gateway_gone(cell):
    client = MbClient()
    p = siemens_plc(cell, client)
    try:
        p.run_until(lambda p: p.task.vars["VALID"], 80, "valid")
        cell.gateway.stop()
        p.run_until(lambda p: not p.group["TRANSPORTOK"], 100, "three failed jobs")
        assert p.adapter.vars["STATUS"] & 0xFF00 == 0x8000, hex(p.adapter.vars["STATUS"])
        assert p.group["TRANSPORTERROR"] == p.adapter.vars["STATUS"]
        p.scan()
        assert p.task.vars["ERROR"] and p.task.vars["ERRORID"] == 39700
    finally:
        client.close()
