"""A developer-machine check of the OpenPLC program under matiec (not in CI:
matiec is in no registry): joins the library, the OpenPLC adapter and a
configuration as plc/README.md says, compiles it with matiec's iec2c and gcc,
links a small harness that plays the runtime's buffers (every located input
set to a value per Modbus register, the way the device plan places it), runs
scans, and checks that each register's value is at its image index and that
PLC_HEARTBEAT, written as 16 coils, counts the scans.

Usage: openplc_matiec.py MATIEC_DIR [WORK_DIR] (MATIEC_DIR holds iec2c and
lib/; WORK_DIR defaults to target/openplc-matiec)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import openplc

PLC = Path(__file__).resolve().parent.parent
SOURCES = [PLC / "src" / "HansTypes.st", PLC / "src" / "HansCore.st", PLC / "src" / "HansBlocks.st",
           PLC / "adapters" / "OpenPlcAdapter.st"]
CONFIG = """
CONFIGURATION Config0
  RESOURCE Res0 ON PLC
    TASK Main(INTERVAL := T#20ms, PRIORITY := 0);
    PROGRAM Inst0 WITH Main : HansOpenPlcMain;
  END_RESOURCE
END_CONFIGURATION
"""
SCANS = 5


def mark(reg: int) -> int:
    return (reg * 7919 + 13) & 0xFFFF


def harness() -> str:
    """C that sets the located inputs, runs SCANS scans and prints the image
    and the heartbeat's coils."""
    loc = openplc.located()
    sets = []
    for i, reg in enumerate(loc["iw"]):
        sets.append(f"  __IW{100 + i}_v = {mark(reg)};")
    for i, bit in enumerate(loc["ix"]):
        r, b = divmod(bit, 16)
        sets.append(f"  __IX{100 + i // 8}_{i % 8}_v = {mark(r) >> b & 1};")
    beat = [i for i, bit in enumerate(loc["qx"]) if bit // 16 == 140]
    gets = " | ".join(f"((unsigned)__QX{100 + i // 8}_{i % 8}_v << {loc['qx'][i] % 16})" for i in beat)
    return "\n".join([
        '#include <stdio.h>', '#include "iec_std_lib.h"', '#include "accessor.h"', '#include "POUS.h"',
        "#define __LOCATED_VAR(type, name, ...) type name##_v; type *name = &name##_v;",
        '#include "LOCATED_VARIABLES.h"', "#undef __LOCATED_VAR",
        "TIME __CURRENT_TIME;", "extern HANSOPENPLCMAIN RES0__INST0;",
        "void config_init__(void);", "void config_run__(unsigned long tick);",
        "int main(void) {", "  config_init__();", *sets,
        f"  for (unsigned long t = 0; t < {SCANS}; t++) {{",
        "    __CURRENT_TIME.tv_nsec += 20000000; if (__CURRENT_TIME.tv_nsec >= 1000000000) "
        "{ __CURRENT_TIME.tv_nsec -= 1000000000; __CURRENT_TIME.tv_sec++; }",
        "    config_run__(t);", "  }",
        "  for (int i = 0; i < 410; i++) printf(\"IMAGE %d %u\\n\", i, "
        "(unsigned)RES0__INST0.GROUP.value.IMAGE.table[i]);",
        f"  printf(\"BEAT %u\\n\", {gets});", "  return 0;", "}", ""])


def main(argv) -> int:
    matiec = Path(argv[0]).resolve()
    work = Path(argv[1] if len(argv) > 1 else PLC.parent / "target" / "openplc-matiec").resolve()
    work.mkdir(parents=True, exist_ok=True)
    (work / "hans.st").write_text("\n".join(p.read_text() for p in SOURCES) + CONFIG)
    subprocess.run([str(matiec / "iec2c"), "-I", str(matiec / "lib"), "hans.st"], cwd=work, check=True)
    (work / "harness.c").write_text(harness())
    subprocess.run(["gcc", "-w", "-I", str(matiec / "lib" / "C"), "-I", ".", "-o", "harness",
                    "harness.c", "Config0.c", "Res0.c", "-lm"], cwd=work, check=True)
    out = subprocess.run([str(work / "harness")], cwd=work, check=True, capture_output=True, text=True).stdout
    image = {}
    beat = None
    for line in out.splitlines():
        f = line.split()
        if f[0] == "IMAGE":
            image[int(f[1])] = int(f[2])
        elif f[0] == "BEAT":
            beat = int(f[1])
    bad = [(reg + k, idx + k) for reg, idx, count, is_write in openplc.transfer_table() if not is_write
           for k in range(count) if image[idx + k] != mark(reg + k)]
    words = sum(c for _, _, c, w in openplc.transfer_table() if not w)
    print(f"matiec + gcc: {words - len(bad)} of {words} read words at their image index; "
          f"PLC_HEARTBEAT coils {beat} after {SCANS} scans")
    return 0 if not bad and beat == SCANS else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
