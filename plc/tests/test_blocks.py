"""The blocks run scan by scan against the real hans-gateway and hans-sim
over Modbus TCP: cases from PLCopen's state diagrams. Every wait is bounded
by a number of scans (10 ms cycle), never a sleep that hopes."""

from __future__ import annotations

import time

import pytest

from rig import Cell, Plc

HOME = {"X": 420.0, "Y": 0.0, "Z": 445.0, "RX": 180.0, "RY": 0.0, "RZ": 180.0}


def pose(**kw):
    p = dict(HOME)
    p.update({k.upper(): v for k, v in kw.items()})
    return p


def outs(v, *names):
    return {n: v[n] for n in names}


@pytest.fixture
def cell(request):
    marker = request.node.get_closest_marker("cell")
    kwargs = marker.kwargs if marker else {}
    c = Cell(**kwargs)
    yield c
    c.stop()


def enabled_plc(cell, **kw) -> Plc:
    """A PLC whose robot is powered and enabled by MC_EnableRobot (the sim
    starts powered off, as the demo does)."""
    p = Plc(cell, **kw)
    p.block("enable", "MC_EnableRobot")
    p.logic.append(lambda p: p.call("enable", Enable=True))
    p.run_until(lambda p: p.blocks["enable"].vars["STATUS"] or p.blocks["enable"].vars["ERROR"], 1500, "enabled")
    v = p.blocks["enable"].vars
    assert v["STATUS"] and not v["ERROR"], outs(v, "STATUS", "ERROR", "ERRORID")
    assert p.task.vars["GROUPSTATE"] == 1, "Standby"
    return p


class Inputs(dict):
    """A block's inputs the test changes between scans."""


def drive(p: Plc, name: str, fb_type: str, **inputs) -> Inputs:
    p.block(name, fb_type)
    ins = Inputs({k.upper(): v for k, v in inputs.items()})
    p.logic.append(lambda p: p.call(name, **ins))
    return ins


def v(p, name):
    return p.blocks[name].vars


def test_enable_then_move_done_with_the_position_read_back(cell):
    p = enabled_plc(cell)
    mv = drive(p, "mv", "MC_MoveLinearAbsolute", Execute=True, Position=pose(Y=60.0), Velocity=150.0)
    drive(p, "pos", "MC_ReadActualPosition", Enable=True)
    seen_active = []
    p.logic.append(lambda p: seen_active.append(v(p, "mv")["ACTIVE"]))
    p.run_until(lambda p: not v(p, "mv")["BUSY"], 1500, "move ended")
    assert outs(v(p, "mv"), "DONE", "ERROR", "COMMANDABORTED") == {"DONE": True, "ERROR": False, "COMMANDABORTED": False}
    assert any(seen_active), "Active while the robot moved"
    p.scan()
    assert v(p, "pos")["VALID"]
    assert abs(v(p, "pos")["POSITION"]["Y"] - 60.0) < 0.01
    # Done stays while Execute is held, clears when it falls.
    p.scan()
    assert v(p, "mv")["DONE"]
    mv["EXECUTE"] = False
    p.scan()
    assert not v(p, "mv")["DONE"]


@pytest.mark.cell(sim_args=["--fault", "fail=20018@WayPoint*1"])
def test_error_with_the_robots_error_id_its_text_then_reset(cell):
    p = enabled_plc(cell)
    mv = drive(p, "mv", "MC_MoveLinearAbsolute", Execute=True, Position=pose(Y=30.0), Velocity=150.0)
    drive(p, "msg", "MC_ReadMessages", Enable=True)
    p.run_until(lambda p: not v(p, "mv")["BUSY"], 500, "move ended")
    assert outs(v(p, "mv"), "DONE", "ERROR", "ERRORID") == {"DONE": False, "ERROR": True, "ERRORID": 20018}
    # The error text block explains the robot's code.
    p.run_until(lambda p: v(p, "msg")["MESSAGECODE"] == 20018, 300, "error text")
    assert v(p, "msg")["VALID"] and len(v(p, "msg")["MESSAGETEXT"]) > 3, v(p, "msg")["MESSAGETEXT"]
    assert v(p, "msg")["MESSAGESOURCE"] in (1, 2)
    # Reset after the error, then the move again: Done.
    mv["EXECUTE"] = False
    reset = drive(p, "reset", "MC_GroupReset", Execute=True)
    p.run_until(lambda p: v(p, "reset")["DONE"] or v(p, "reset")["ERROR"], 500, "reset")
    assert v(p, "reset")["DONE"], outs(v(p, "reset"), "ERROR", "ERRORID")
    reset["EXECUTE"] = False
    mv["EXECUTE"] = True
    p.run_until(lambda p: v(p, "mv")["DONE"] or v(p, "mv")["ERROR"], 1500, "move after reset")
    assert v(p, "mv")["DONE"]


def test_stop_aborts_the_running_and_the_waiting_and_holds_the_group(cell):
    p = enabled_plc(cell)
    a = drive(p, "a", "MC_MoveLinearAbsolute", Execute=True, Position=pose(Y=150.0), Velocity=20.0)
    p.run_until(lambda p: v(p, "a")["ACTIVE"], 500, "a active")
    # b waits in the gateway's queue (channel 1), c in the library (no lane).
    drive(p, "b", "MC_MoveLinearAbsolute", Execute=True, Position=pose(Y=0.0), Velocity=20.0)
    drive(p, "c", "MC_MoveAxesAbsolute", Execute=True, Position=[0.0, 0.0, 90.0, 0.0, 90.0, 0.0])
    p.run_until(lambda p: v(p, "b")["BUSY"] and v(p, "c")["BUSY"], 50, "b, c waiting")
    for _ in range(5):
        p.scan()
    assert v(p, "a")["ACTIVE"] and not v(p, "b")["ACTIVE"] and not v(p, "c")["ACTIVE"]
    stop = drive(p, "stop", "MC_GroupStop", Execute=True)
    p.run_until(lambda p: v(p, "stop")["DONE"], 300, "stop done")
    p.run_until(lambda p: not (v(p, "a")["BUSY"] or v(p, "b")["BUSY"] or v(p, "c")["BUSY"]), 300, "all ended")
    for n in "abc":
        assert outs(v(p, n), "COMMANDABORTED", "DONE", "ERROR") == {"COMMANDABORTED": True, "DONE": False, "ERROR": False}, n
    # While the stop's Execute is held the group is Stopping: a new motion
    # is refused (PLCopen).
    assert p.task.vars["GROUPSTATE"] == 3
    d = drive(p, "d", "MC_MoveLinearAbsolute", Execute=True, Position=pose(Y=10.0), Velocity=150.0)
    p.run_until(lambda p: v(p, "d")["ERROR"], 20, "refused while stopping")
    assert v(p, "d")["ERRORID"] == 39702
    # Released: motions run again.
    stop["EXECUTE"] = False
    d["EXECUTE"] = False
    p.scan()
    d["EXECUTE"] = True
    p.run_until(lambda p: v(p, "d")["DONE"] or v(p, "d")["ERROR"], 1500, "d after the stop")
    assert v(p, "d")["DONE"], outs(v(p, "d"), "ERROR", "ERRORID")


def test_buffered_moves_run_in_the_order_of_their_edges(cell):
    p = enabled_plc(cell)
    targets = [pose(Y=20.0), pose(Y=40.0), pose(Y=60.0), pose(Y=80.0)]
    order = []
    for i, t in enumerate(targets):
        drive(p, f"m{i}", "MC_MoveLinearAbsolute", Execute=True, Position=t, Velocity=200.0)

    def watch(p):
        for i in range(len(targets)):
            if v(p, f"m{i}")["ACTIVE"] and (not order or order[-1] != i):
                order.append(i)
            if v(p, f"m{i}")["DONE"] and i not in done:
                done.append(i)
    done = []
    p.logic.append(watch)
    p.run_until(lambda p: len(done) == len(targets) or any(v(p, f"m{i}")["ERROR"] for i in range(4)), 3000, "all done")
    assert done == [0, 1, 2, 3]
    assert order == [0, 1, 2, 3], "never two active at once, in order"
    drive(p, "pos", "MC_ReadActualPosition", Enable=True)
    p.scan()
    assert abs(v(p, "pos")["POSITION"]["Y"] - 80.0) < 0.01


def test_execute_falling_while_busy_shows_done_for_one_scan(cell):
    p = enabled_plc(cell)
    mv = drive(p, "mv", "MC_MoveLinearAbsolute", Execute=True, Position=pose(Y=40.0), Velocity=100.0)
    p.scan()
    mv["EXECUTE"] = False
    p.scan()
    assert v(p, "mv")["BUSY"], "the command goes on"
    p.run_until(lambda p: v(p, "mv")["DONE"], 1500, "Done")
    p.scan()
    assert not v(p, "mv")["DONE"] and not v(p, "mv")["BUSY"], "Done for one scan only"


# At real speed: the controller drops a long jog 200 ms (its time) after the
# last LongMoveEvent, which the gateway sends every 100 ms (real time).
@pytest.mark.cell(speed="1")
def test_jog_moves_while_held_and_stops_when_released(cell):
    p = enabled_plc(cell)
    jog = drive(p, "jog", "MC_GroupJog", JogForward=True, Axis=1)
    drive(p, "pos", "MC_ReadActualPosition", Enable=True)
    p.run_until(lambda p: v(p, "jog")["ACTIVE"], 300, "jog active")
    j0 = v(p, "pos")["JOINTS"][0]
    p.run_until(lambda p: v(p, "pos")["JOINTS"][0] > j0 + 2.0, 500, "J1 turns while held")
    assert v(p, "jog")["BUSY"]
    jog["JOGFORWARD"] = False
    p.run_until(lambda p: not v(p, "jog")["BUSY"], 500, "jog ended")
    assert v(p, "jog")["DONE"], outs(v(p, "jog"), "ERROR", "ERRORID", "COMMANDABORTED")
    # It stands still: the joint no longer changes.
    p.run_until(lambda p: p.task.vars["GROUPSTATE"] == 1, 300, "standstill")
    j1 = v(p, "pos")["JOINTS"][0]
    for _ in range(30):
        p.scan()
    assert v(p, "pos")["JOINTS"][0] == j1


@pytest.mark.cell(gateway_toml="[watchdog]\nperiod_ms = 300\naction = \"stop\"\n")
def test_the_gateway_stops_a_motion_when_the_plc_heartbeat_stops(cell):
    p = enabled_plc(cell)
    drive(p, "mv", "MC_MoveLinearAbsolute", Execute=True, Position=pose(Y=150.0), Velocity=20.0)
    p.run_until(lambda p: v(p, "mv")["ACTIVE"], 500, "moving")
    # The PLC stalls: no scan, no heartbeat for twice the watchdog period.
    stalled = time.monotonic() + 0.6
    while time.monotonic() < stalled:
        time.sleep(0.05)
    p.run_until(lambda p: not v(p, "mv")["BUSY"], 300, "ended")
    assert outs(v(p, "mv"), "ERROR", "ERRORID") == {"ERROR": True, "ERRORID": 39602}


def test_the_robot_link_lost_mid_move_ends_it_in_error(cell):
    p = enabled_plc(cell)
    drive(p, "mv", "MC_MoveLinearAbsolute", Execute=True, Position=pose(Y=150.0), Velocity=20.0)
    p.run_until(lambda p: v(p, "mv")["ACTIVE"], 500, "moving")
    cell.sim.stop()
    p.run_until(lambda p: not v(p, "mv")["BUSY"], 600, "ended")
    assert outs(v(p, "mv"), "ERROR", "ERRORID") == {"ERROR": True, "ERRORID": 39601}
    p.run_until(lambda p: not p.task.vars["LINKUP"], 300, "link down")
    assert p.task.vars["GROUPSTATE"] == 0


def test_the_gateway_lost_ends_what_runs_with_39700(cell):
    p = enabled_plc(cell)
    drive(p, "mv", "MC_MoveLinearAbsolute", Execute=True, Position=pose(Y=150.0), Velocity=20.0)
    p.run_until(lambda p: v(p, "mv")["ACTIVE"], 500, "moving")
    cell.gateway.stop()
    p.run_until(lambda p: not v(p, "mv")["BUSY"], 300, "ended")
    assert outs(v(p, "mv"), "ERROR", "ERRORID") == {"ERROR": True, "ERRORID": 39700}
    assert p.task.vars["ERROR"] and p.task.vars["ERRORID"] == 39700


def test_two_blocks_on_two_channels_at_once(cell):
    p = enabled_plc(cell)
    drive(p, "mv", "MC_MoveLinearAbsolute", Execute=True, Position=pose(Y=100.0), Velocity=10.0)
    p.run_until(lambda p: v(p, "mv")["ACTIVE"], 500, "moving")
    # A tool output while the move runs: the gateway sends ordinary commands
    # that are not motions while a motion runs.
    drive(p, "out", "MC_WriteDigitalOutput", Execute=True, OutputNumber=1, Value=True, ToolOutput=True)
    lanes = []
    p.logic.append(lambda p: lanes.append((p.group["LANES"][0]["OWNER"] != 0, p.group["LANES"][1]["OWNER"] != 0)))
    p.run_until(lambda p: v(p, "out")["DONE"] or v(p, "out")["ERROR"], 300, "output")
    assert v(p, "out")["DONE"], outs(v(p, "out"), "ERROR", "ERRORID")
    assert v(p, "mv")["BUSY"], "the output is Done while the move runs"
    assert (True, True) in lanes, "both channels held at once"
    p.run_until(lambda p: p.group["IMAGE"][43] & 2, 100, "END_DO bit 1 reads 1")
    drive(p, "stop", "MC_GroupStop", Execute=True)
    p.run_until(lambda p: v(p, "mv")["COMMANDABORTED"], 300, "move stopped")


def test_the_example_cell_runs_a_pick_and_place_cycle(cell):
    from rig import PLC
    p = Plc(cell, extra_sources=[PLC / "examples" / "PickAndPlace.st"], run_task=False)
    main = p.prog.instantiate("PickAndPlace")
    # The program owns its axes group and calls its own MC_RobotTask; the
    # rig is its platform: it moves that group's image.
    p.group = main.vars["CELLGROUP"]
    seen_grip = set()

    def run(p):
        p.prog.call_fb(main, {"START": True})
        seen_grip.add(p.group["IMAGE"][43] & 1)
    p.logic.append(run)
    p.run_until(lambda p: main.vars["CYCLES"] >= 2 or main.vars["FAULT"], 4000, "two cycles")
    assert main.vars["CYCLES"] >= 2 and not main.vars["FAULT"], main.vars["LASTERRORID"]
    assert seen_grip == {0, 1}, "the gripper closed and opened (END_DO bit 0)"


def test_the_blocks_over_an_adapter_that_moves_one_block_per_scan(cell):
    """TwinCAT's and Siemens' clients do one Modbus transaction at a time:
    their adapters move one block of the transfer table per scan, and a
    lane's Execute written low reaches the gateway some scans later. The
    next command on that lane must wait for the gateway to have seen it
    (else its rising edge is lost): enable (two commands on one lane),
    buffered moves and an output, one after the other."""
    p = Plc(cell, one_block_per_scan=True)
    p.run_until(lambda p: p.task.vars["VALID"], 50, "MC_RobotTask valid (one round)")
    p.block("enable", "MC_EnableRobot")
    p.logic.append(lambda p: p.call("enable", Enable=True))
    p.run_until(lambda p: v(p, "enable")["STATUS"] or v(p, "enable")["ERROR"], 3000, "enabled")
    assert v(p, "enable")["STATUS"], outs(v(p, "enable"), "ERROR", "ERRORID")
    done = []
    for i, y in enumerate((20.0, 40.0, 60.0)):
        drive(p, f"m{i}", "MC_MoveLinearAbsolute", Execute=True, Position=pose(Y=y), Velocity=200.0)
    drive(p, "out", "MC_WriteDigitalOutput", Execute=True, OutputNumber=1, Value=True, ToolOutput=True)

    def watch(p):
        for n in ("m0", "m1", "m2", "out"):
            if v(p, n)["DONE"] and n not in done:
                done.append(n)
    p.logic.append(watch)
    names = ("m0", "m1", "m2", "out")
    p.run_until(lambda p: all(not v(p, n)["BUSY"] for n in names), 4000, "all ended")
    for n in names:
        assert outs(v(p, n), "DONE", "ERROR", "ERRORID") == {"DONE": True, "ERROR": False, "ERRORID": 0}, n
    # The output is no motion: the gateway may run it while m2 moves.
    assert [n for n in done if n.startswith("m")] == ["m0", "m1", "m2"], "the moves in the order of their edges"


# The robot refuses the first gripper command (SetEndDO: Fail 20018, as a
# controller that is not ready for it answers): an error in the middle of
# the first cycle, after the approach and the descent.
@pytest.mark.cell(sim_args=["--fault", "fail=20018@SetEndDO*1"])
def test_the_example_cell_faults_waits_for_acknowledge_resets_and_goes_on(cell):
    from rig import PLC
    p = Plc(cell, extra_sources=[PLC / "examples" / "PickAndPlace.st"], run_task=False)
    main = p.prog.instantiate("PickAndPlace")
    p.group = main.vars["CELLGROUP"]
    inputs = {"START": True, "ACKNOWLEDGE": False}
    grips = []    # END_DO bit 0 (the gripper) as the cell saw it, on each change
    phases = []   # the sequence's steps, on each change
    resets = []   # the example's MC_GroupReset: Done seen

    def run(p):
        p.prog.call_fb(main, dict(inputs))
        bit = p.group["IMAGE"][43] & 1
        if not grips or grips[-1] != bit:
            grips.append(bit)
        if not phases or phases[-1] != main.vars["PHASE"]:
            phases.append(main.vars["PHASE"])
        if main.vars["RESET"].vars["DONE"]:
            resets.append(p.scans)
    p.logic.append(run)
    m = main.vars
    p.run_until(lambda p: m["FAULT"], 3000, "the fault")
    # The sequence stopped where the error came, with the robot's code and
    # its text; nothing moves on until the operator acknowledges.
    assert m["PHASE"] == 900 and m["LASTERRORID"] == 20018 and m["CYCLES"] == 0
    p.run_until(lambda p: len(m["LASTERRORTEXT"]) > 3, 300, "the error's text")
    for _ in range(50):
        p.scan()
    assert m["PHASE"] == 900 and m["FAULT"] and grips == [0], "waiting, the gripper never closed"
    assert phases == [10, 20, 30, 40, 900], "the error came at the gripper (40), after the descent"
    assert not resets
    # Acknowledge (a rising edge): MC_GroupReset, then the cycle goes on
    # from the approach and completes, the gripper closing and opening.
    inputs["ACKNOWLEDGE"] = True
    p.run_until(lambda p: not m["FAULT"], 500, "reset done")
    assert m["PHASE"] == 20
    inputs["ACKNOWLEDGE"] = False
    p.run_until(lambda p: m["CYCLES"] >= 1 or m["FAULT"], 4000, "a cycle after the reset")
    assert m["CYCLES"] == 1 and not m["FAULT"], (m["PHASE"], m["LASTERRORID"])
    assert grips == [0, 1, 0], "closed at the pick, opened at the place"
    assert resets, "MC_GroupReset was Done"
    assert phases[4:] == [900, 910, 20, 30, 40, 50, 20, 30, 40, 50, 20], phases
    assert m["LASTERRORID"] == 20018, "the last error stays shown for the operator"


# The robot is enabled already (from the teach pendant, or a PLC restart).
@pytest.mark.cell(sim_args=["--ready"])
def test_enable_robot_sends_nothing_while_enable_stays_low_and_disables_at_its_fall(cell):
    p = Plc(cell)
    en = drive(p, "enable", "MC_EnableRobot", Enable=False)
    # A PLC that starts with Enable low leaves the robot as it is (an F_TRIG
    # would see a falling edge at the first call and send Disable: Error
    # 39500 while the robot link comes up, or a disabled robot after).
    p.run_until(lambda p: p.task.vars["ROBOTENABLED"] or v(p, "enable")["ERROR"], 1000, "the robot's state")
    for _ in range(30):
        p.scan()
    assert outs(v(p, "enable"), "BUSY", "ERROR") == {"BUSY": False, "ERROR": False}
    assert p.task.vars["GROUPSTATE"] == 1 and p.task.vars["ROBOTENABLED"], "still enabled"
    en["ENABLE"] = True
    p.run_until(lambda p: v(p, "enable")["STATUS"] or v(p, "enable")["ERROR"], 1500, "enabled")
    assert v(p, "enable")["STATUS"]
    en["ENABLE"] = False
    p.run_until(lambda p: not p.task.vars["ROBOTENABLED"] or v(p, "enable")["ERROR"], 1500, "disabled")
    assert not v(p, "enable")["ERROR"] and not v(p, "enable")["STATUS"]
