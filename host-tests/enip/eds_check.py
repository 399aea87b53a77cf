#!/usr/bin/env python3
"""Reads the EDS that hans-enip writes (loopback_adapter --eds FILE) with
eds_pie, an EDS parser and semantic checker nobody here wrote, and checks
that what it reads is what the adapter serves.

Usage: eds_check.py FILE. Prints one line per check and "N passed, M failed".

eds_pie's reference library for EtherNet/IP has no entries for the [Port]
section, so it warns about Port1 as an unknown entry; that warning is
expected and the only one allowed.
"""

import logging
import sys

from eds_pie.eds_pie import CIP_EDS

records = []


class Keep(logging.Handler):
    def emit(self, record):
        records.append(record)


logging.getLogger().addHandler(Keep())
logging.getLogger().setLevel(logging.WARNING)
results = []


def check(name, ok, detail=""):
    results.append(ok)
    print(f"{'ok  ' if ok else 'FAIL'} {name}{': ' + detail if detail else ''}")


eds = CIP_EDS(open(sys.argv[1]).read())
eds.validate()
unknown = [(sk, ek) for sk, sec in eds.sections.items() for ek in sec.entries
           if eds.ref_db.get_entry_name(sk, ek) is None]
# eds_pie's "Unknown Entry" message is not formatted (a missing f-prefix):
# which entries it means is computed above instead.
problems = [r.getMessage() for r in records
            if r.levelno >= logging.ERROR
            or not (r.getMessage().startswith("Unknown Field [Port].Port1.")
                    or r.getMessage().startswith("Unknown Entry ["))]
problems += [f"unknown entry [{sk}].{ek}" for sk, ek in unknown if (sk, ek) != ("Port", "Port1")]
check("eds_pie reads the EDS as EtherNet/IP", eds.protocol == "EtherNetIP", str(eds.protocol))
check("eds_pie finds no error (only its known [Port] gap)", not problems, "; ".join(problems[:5]))
v = eds.get_value
check("[Device] identity", (v("Device", "VendCode"), v("Device", "ProdType"), v("Device", "ProdCode"),
                            v("Device", "MajRev"), v("Device", "MinRev"), v("Device", "ProdName"))
      == (0xFFFE, 12, 1, 1, 1, "hans-enip loopback"))
check("[Assembly] sizes", v("Assembly", "Assem100", 2) == 32 and v("Assembly", "Assem150", 2) == 32)
conns = [(v("Connection Manager", f"Connection{i}", 0), v("Connection Manager", f"Connection{i}", 14))
         for i in (1, 2, 3)]
check("[Connection Manager] exclusive owner, input only, listen only",
      [c[0] for c in conns] == [0x04010002, 0x02010002, 0x01010002], repr(conns))
check("[Connection Manager] paths name the adapter's connection points",
      [str(c[1]).upper().replace(" ", "") for c in conns]
      == ["200424012C962C64", "200424012CC62C64", "200424012CC72C64"],
      repr([c[1] for c in conns]))
passed = sum(results)
print(f"{passed} passed, {len(results) - passed} failed")
sys.exit(0 if all(results) else 1)
