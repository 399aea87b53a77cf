"""Static checks: both parsers on every file, the subset rules (and that
they catch what they forbid), the SCL file against the ST."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

PLC = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(PLC / "tools"))

import stcheck  # noqa: E402
import st2scl  # noqa: E402

LIBRARY = sorted((PLC / "src").glob("*.st")) + sorted((PLC / "examples").glob("*.st"))
ADAPTERS = sorted((PLC / "adapters").glob("*.st"))


@pytest.mark.parametrize("path", LIBRARY, ids=lambda p: p.name)
def test_library_files_parse_with_both_parsers_and_keep_the_subset(path):
    assert stcheck.check(str(path)) == []


@pytest.mark.parametrize("path", ADAPTERS, ids=lambda p: p.name)
def test_adapters_parse_with_both_parsers(path):
    assert stcheck.check(str(path), adapter=True) == []


BAD = {
    "pointer": "FUNCTION_BLOCK X\nVAR\n    p : POINTER TO INT;\nEND_VAR\np := ADR(p);\nEND_FUNCTION_BLOCK\n",
    "reference": "FUNCTION_BLOCK X\nVAR_INPUT\n    r : REFERENCE TO INT;\nEND_VAR\nEND_FUNCTION_BLOCK\n",
    "method": "FUNCTION_BLOCK X\nMETHOD M : BOOL\nM := TRUE;\nEND_METHOD\nEND_FUNCTION_BLOCK\n",
    "inline array": "FUNCTION_BLOCK X\nVAR\n    a : ARRAY[0..3] OF INT;\nEND_VAR\nEND_FUNCTION_BLOCK\n",
    "located": "PROGRAM X\nVAR\n    a AT %IW0 : WORD;\nEND_VAR\nEND_PROGRAM\n",
    "word arithmetic": "FUNCTION_BLOCK X\nVAR\n    w : WORD;\nEND_VAR\nw := w + 1;\nEND_FUNCTION_BLOCK\n",
    "line comment": "FUNCTION_BLOCK X\nVAR\n    i : INT; // count\nEND_VAR\nEND_FUNCTION_BLOCK\n",
    "syntax": "FUNCTION_BLOCK X\nVAR\n    i : INT\nEND_VAR\ni := ;\nEND_FUNCTION_BLOCK\n",
}


@pytest.mark.parametrize("what", sorted(BAD))
def test_a_construct_outside_the_subset_fails_the_check(what, tmp_path):
    f = tmp_path / "bad.st"
    f.write_text(BAD[what])
    assert stcheck.check(str(f)) != [], f"the check let {what} through"


def test_the_committed_scl_is_the_generators_output():
    assert (PLC / "scl" / "HansRobot.scl").read_text() == st2scl.generate()


def test_the_scl_is_balanced_and_names_what_the_st_declares():
    scl = (PLC / "scl" / "HansRobot.scl").read_text()
    code = re.sub(r"//[^\n]*", "", scl)
    code = re.sub(r"\(\*.*?\*\)", "", code, flags=re.S)
    code = re.sub(r"'(?:\$.|[^'$])*'", "''", code)
    for a, b in [("FUNCTION_BLOCK", "END_FUNCTION_BLOCK"), ("IF", "END_IF"), ("CASE", "END_CASE"),
                 ("FOR", "END_FOR"), ("STRUCT", "END_STRUCT"), ("TYPE", "END_TYPE"), ("VAR\\w*", "END_VAR")]:
        opens = len(re.findall(rf"(?<![\w\"]){a}\b", code))
        assert opens > 0 and opens == len(re.findall(rf"\b{b}\b", code)), f"{a} / {b} unbalanced"
    fbs = re.findall(r'(?m)^FUNCTION_BLOCK "(\w+)"', scl)
    fcs = re.findall(r'(?m)^FUNCTION "(\w+)"', scl)
    assert len(re.findall(r"(?m)^BEGIN$", scl)) == len(fbs) + len(fcs)
    st = "\n".join(p.read_text() for p in sorted((PLC / "src").glob("*.st")))
    st_fbs = re.findall(r"(?m)^FUNCTION_BLOCK (\w+)", st)
    st_fcs = re.findall(r"(?m)^FUNCTION (\w+)", st)
    assert sorted(fbs) == sorted(st_fbs) and sorted(fcs) == sorted(st_fcs)
    structs = re.findall(r"(?m)^TYPE (\w+) :\s*\n?\s*STRUCT", st)
    assert sorted(re.findall(r'(?m)^TYPE "(\w+)"', scl)) == sorted(structs)
    # Every variable the ST declares is declared in the SCL too.
    scl_vars = set(re.findall(r"(?m)^\s+(\w+) :", scl))
    st_vars = set(re.findall(r"(?m)^\s+(\w+) :(?!=)", re.sub(r"\(\*.*?\*\)", "", st, flags=re.S)))
    assert st_vars - scl_vars == set()
