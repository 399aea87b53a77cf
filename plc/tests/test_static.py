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
    "in-out call as an argument": "FUNCTION F : INT\nVAR_IN_OUT\n    a : INT;\nEND_VAR\nF := a;\nEND_FUNCTION\n"
                                  "FUNCTION_BLOCK X\nVAR\n    i : INT;\nEND_VAR\n"
                                  "i := ABS(IN := F(a := i));\nEND_FUNCTION_BLOCK\n",
}


@pytest.mark.parametrize("what", sorted(BAD))
def test_a_construct_outside_the_subset_fails_the_check(what, tmp_path):
    f = tmp_path / "bad.st"
    f.write_text(BAD[what])
    assert stcheck.check(str(f)) != [], f"the check let {what} through"


def test_the_committed_scl_is_the_generators_output():
    for out, text in st2scl.outputs().items():
        assert out.read_text() == text, f"{out} is not the generator's output: run plc/tools/st2scl.py"


SCL_FILES = {"HansRobot.scl": st2scl.SOURCES, "HansMbClientAdapter.scl": st2scl.ADAPTER}


def _scl_code(scl: str) -> str:
    code = re.sub(r"//[^\n]*", "", scl)
    code = re.sub(r"\(\*.*?\*\)", "", code, flags=re.S)
    return re.sub(r"'(?:\$.|[^'$])*'", "''", code)


@pytest.mark.parametrize("name", sorted(SCL_FILES))
def test_the_scl_is_balanced_and_names_what_the_st_declares(name):
    scl = (PLC / "scl" / name).read_text()
    code = _scl_code(scl)
    for a, b in [("FUNCTION_BLOCK", "END_FUNCTION_BLOCK"), ("IF", "END_IF"), ("CASE", "END_CASE"),
                 ("FOR", "END_FOR"), ("STRUCT", "END_STRUCT"), ("TYPE", "END_TYPE"), ("VAR\\w*", "END_VAR")]:
        opens = len(re.findall(rf"(?<![\w\"]){a}\b", code))
        closes = len(re.findall(rf"\b{b}\b", code))
        assert opens == closes, f"{a} / {b} unbalanced"
        assert opens > 0 or a in ("CASE", "STRUCT", "TYPE"), f"no {a} at all"
    fbs = re.findall(r'(?m)^FUNCTION_BLOCK "(\w+)"', scl)
    fcs = re.findall(r'(?m)^FUNCTION "(\w+)"', scl)
    assert len(re.findall(r"(?m)^BEGIN$", scl)) == len(fbs) + len(fcs)
    st = "\n".join(p.read_text() for p in SCL_FILES[name])
    st_fbs = re.findall(r"(?m)^FUNCTION_BLOCK (\w+)", st)
    st_fcs = re.findall(r"(?m)^FUNCTION (\w+)", st)
    assert sorted(fbs) == sorted(st_fbs) and sorted(fcs) == sorted(st_fcs)
    structs = re.findall(r"(?m)^TYPE (\w+) :\s*\n?\s*STRUCT", st)
    assert sorted(re.findall(r'(?m)^TYPE "(\w+)"', scl)) == sorted(structs)
    # Every variable the ST declares is declared in the SCL too.
    scl_vars = set(re.findall(r"(?m)^\s+(\w+) :", scl))
    st_vars = set(re.findall(r"(?m)^\s+(\w+) :(?!=)", re.sub(r"\(\*.*?\*\)", "", st, flags=re.S)))
    assert st_vars - scl_vars == set()


def _scl_blocks(scl: str):
    """(name, declared names, body) of each FUNCTION / FUNCTION_BLOCK."""
    code = _scl_code(scl)
    for m in re.finditer(r'(?ms)^(FUNCTION_BLOCK|FUNCTION) "(\w+)"(.*?)^BEGIN$(.*?)^END_\1$', code):
        declared = set(re.findall(r"(?m)^\s+(\w+) :", m.group(3)))
        if m.group(1) == "FUNCTION":
            declared.add(m.group(2))   # the return value
        yield m.group(2), declared, m.group(4)


@pytest.mark.parametrize("name", sorted(SCL_FILES))
def test_the_scl_writes_every_local_with_its_hash_and_only_locals(name):
    """TIA reads a bare name as a global tag: a local written without '#'
    compiles to something else, or not at all; '#' on an undeclared name is
    an error."""
    scl = (PLC / "scl" / name).read_text()
    blocks = list(_scl_blocks(scl))
    assert blocks
    for block, declared, body in blocks:
        hashed = set(re.findall(r"(?<![\w])#([A-Za-z_]\w*)", body))
        assert hashed <= declared, f"{block}: #{sorted(hashed - declared)} not declared"
        for m in re.finditer(r"(?<![#.\w\"])([A-Za-z_]\w*)\b", body):
            word = m.group(1)
            if word not in declared:
                continue
            before = body[:m.start()]
            in_call = before.count("(") > before.count(")")
            formal = in_call and body[m.end():m.end() + 4].lstrip().startswith(":=")
            assert formal, f"{block}: {word} without '#' (only a formal parameter in a call may be)"


# MB_CLIENT's and TCON_IP_v4's names as Siemens documents them (S7-1200/1500,
# instruction MB_CLIENT, V5 and later: CONNECT replaces the IP parameters).
MB_CLIENT_PARAMETERS = {"REQ", "DISCONNECT", "MB_MODE", "MB_DATA_ADDR", "MB_DATA_LEN", "MB_DATA_PTR", "CONNECT"}
MB_CLIENT_OUTPUTS = {"DONE", "BUSY", "ERROR", "STATUS"}
TCON_IP_V4 = {"InterfaceId", "ID", "ConnectionType", "ActiveEstablished", "RemoteAddress", "RemotePort",
              "LocalPort"}


def test_the_mb_client_adapter_uses_mb_client_and_the_library_by_their_names():
    scl = (PLC / "scl" / "HansMbClientAdapter.scl").read_text()
    ((block, declared, body),) = list(_scl_blocks(scl))
    decls = _scl_code(scl)
    assert re.search(r"(?m)^\s+Client : MB_CLIENT;", decls) and re.search(r"(?m)^\s+Connection : TCON_IP_v4;", decls)
    call = re.search(r"#Client\((.*?)\);", body, re.S).group(1)
    assert set(re.findall(r"(\w+)\s*:=", call)) == MB_CLIENT_PARAMETERS, "every parameter, by its name"
    assert set(re.findall(r"#Client\.(\w+)", body)) <= MB_CLIENT_OUTPUTS
    members = set(re.findall(r"#Connection\.(\w+)", body))
    assert members == TCON_IP_V4, members ^ TCON_IP_V4
    assert re.search(r"#Connection\.RemoteAddress\.ADDR\[[1-4]\]", body)
    assert set(re.findall(r"MB_MODE := #?(\w+)", call)) == {"Mode"}
    assert {int(x) for x in re.findall(r"#Mode := (\d+);", body)} == {103, 116}
    # What it takes from the library is declared there, with those members.
    library = (PLC / "scl" / "HansRobot.scl").read_text()
    for quoted in set(re.findall(r'"(\w+)"', _scl_code(scl))) - {block}:
        assert re.search(rf'(?m)^(TYPE|FUNCTION_BLOCK|FUNCTION) "{quoted}"', library), quoted
    info = re.search(r'(?ms)^FUNCTION_BLOCK "HANS_TransferInfo"(.*?)^BEGIN$', library).group(1)
    for member in set(re.findall(r"#Info\.(\w+)", body)):
        assert re.search(rf"(?m)^\s+{member} :", info), member
    group = re.search(r'(?ms)^TYPE "HANS_AXES_GROUP"(.*?)^END_TYPE', library).group(1)
    for member in set(re.findall(r"#AxesGroup\.(\w+)", body)):
        assert re.search(rf"(?m)^\s+{member} :", group), member


ROOT = PLC.parent


def _readme_error_table() -> dict:
    readme = (PLC / "README.md").read_text()
    section = readme.split("## ErrorIDs, by name", 1)[1].split("\n## ", 1)[0]
    return {int(code): name for code, name in re.findall(r"(?m)^\| (\d{5}) \| (\w+) \|", section)}


def test_the_readme_names_every_error_id_as_the_gateway_and_the_library_do():
    table = _readme_error_table()
    # The gateway's codes: REGISTERS.md's table, named as gateway/src/error.rs names them.
    registers = (ROOT / "gateway" / "REGISTERS.md").read_text()
    codes = registers.split("## Error codes", 1)[1].split("\n## ", 1)[0]
    gateway_codes = {int(c) for c in re.findall(r"(?m)^\| (\d{5}) \|", codes)}
    names = dict((int(c), n) for n, c in re.findall(r"(?m)^\s+(\w+) = (\d{5}),", (
        ROOT / "gateway" / "src" / "error.rs").read_text()))
    assert gateway_codes and gateway_codes <= set(names)
    for code in gateway_codes:
        assert table.get(code) == names[code], f"{code}: README {table.get(code)}, gateway {names[code]}"
    # The library's own: every 397xx the ST sets, and nothing else.
    st = "\n".join(p.read_text() for p in sorted((PLC / "src").glob("*.st")))
    library = {int(c) for c in re.findall(r"\b(397\d\d)\b", st)}
    assert library == {39700, 39701, 39702}
    assert set(table) == gateway_codes | library


def test_the_readme_lists_every_scl_dialect_difference():
    readme = (PLC / "README.md").read_text()
    for d in st2scl.DIALECT:
        assert f"- {d}\n" in readme, d
