import os
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
PLC = HERE.parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(PLC / "tools"))


def pytest_configure(config):
    config.addinivalue_line("markers", "cell(**kwargs): arguments of the test's Cell (hans-sim, hans-gateway)")


def pytest_sessionstart(session):
    """Every ST file of plc/ parsed once, up front, in parallel (blark is
    the slow part of a cold run): the tests then take the parses from this
    process (and from PLC_PARSE_CACHE, when set, in later runs)."""
    import stinterp
    jobs = int(os.environ.get("PLC_PARSE_JOBS") or min(2, os.cpu_count() or 1))
    t0 = time.monotonic()
    n = stinterp.preparse(sorted(PLC.glob("*/*.st")), jobs=jobs)
    if n:
        print(f"\nblark: {n} declarations parsed in {time.monotonic() - t0:.1f} s ({jobs} processes)")
