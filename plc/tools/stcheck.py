"""The portable-subset check (plc/README.md, "The ST subset"): every file
must parse with both parsers (blark, and tree-sitter's IEC 61131-3 ST
grammar), and the library may use none of what some target refuses.

Usage: stcheck.py [--library|--adapter] FILE...   (exit 1 on the first problem)
"""

from __future__ import annotations

import re
import sys

import tree_sitter
import tree_sitter_iec61131_3_st as ts_st

import stinterp

# Refused everywhere in the library; each with the reason.
RULES = [
    (r"\bPOINTER\s+TO\b|\bADR\s*\(|\^", "pointers / ADR (not in TIA SCL, matiec, OpenPLC)"),
    (r"\bREFERENCE\s+TO\b|\bREF\s*\(", "REFERENCE TO (CODESYS/TwinCAT only)"),
    (r"\bMETHOD\b|\bPROPERTY\b|\bINTERFACE\b|\bEXTENDS\b|\bIMPLEMENTS\b|\bTHIS\b|\bSUPER\b",
     "methods, properties, interfaces, inheritance (IEC 3rd edition OOP: not in matiec, TIA, OpenPLC)"),
    (r"\bARRAY\s*\[[^\]]*\]\s*OF\b", "an inline ARRAY in a variable: declare a named array type (TYPE X : ARRAY ...)"),
    (r"\bAT\s+%", "located variables (only in the adapters)"),
    (r"//", "// comments (use (* *): matiec and older targets)"),
    (r"\bVAR_GLOBAL\b|\bVAR_EXTERNAL\b|\bVAR_STAT\b|\bVAR_INST\b", "global/external/static variables"),
    (r"\{[^}]*\}", "pragmas and attributes"),
    (r"\b(UNION|__NEW|__DELETE|__ISVALIDREF|__QUERYINTERFACE|ANY_[A-Z]+|CONTINUE|JMP)\b",
     "vendor or 3rd-edition-only constructs"),
    (r"\b(LREAL|LWORD|LINT|ULINT|WSTRING|CHAR|WCHAR|LTIME|DATE_AND_TIME|DT|TOD)\b",
     "64-bit and wide types (not on every target)"),
    (r"\b(SIZEOF|BITADR|INI|TO_[A-Z]+|ANY)\s*\(", "vendor functions"),
    (r"\b(?:WORD|DWORD|BYTE)#?\w*\s*[\+\-\*/]|(?:16#[0-9A-Fa-f_]+)\s*[\*/]\s*\w", None),
]

# Arithmetic on bit strings: an operand of + - * / MOD declared WORD/DWORD/BYTE.
BITSTRING_DECL = re.compile(r"^\s*(\w+)\s*:\s*(WORD|DWORD|BYTE)\b", re.M)


def strip_comments_and_strings(text: str) -> str:
    text = re.sub(r"\(\*.*?\*\)", lambda m: " " * len(m.group(0)) if "\n" not in m.group(0)
                  else "\n" * m.group(0).count("\n"), text, flags=re.S)
    text = re.sub(r"'(?:\$.|[^'$])*'", "''", text)
    return text


def subset_problems(path: str, text: str, adapter: bool = False) -> list[str]:
    probs = []
    raw = re.sub(r"\(\*.*?\*\)", " ", text, flags=re.S)
    if "//" in re.sub(r"'(?:\$.|[^'$])*'", "''", raw):
        probs.append(f"{path}: // comments (use (* *): matiec and older targets)")
    code = strip_comments_and_strings(text)
    for pat, why in RULES:
        if why is None or why.startswith("// comments"):
            continue
        if adapter and any(w in why for w in ("located", "pointers", "vendor functions")):
            continue  # platform code: the adapters may use their platform's means
        for m in re.finditer(pat, code, flags=re.I):
            if "inline ARRAY" in why:
                # allowed only as the right side of a TYPE declaration
                line_start = code.rfind("\n", 0, m.start()) + 1
                line = code[line_start:code.find("\n", m.start())]
                if re.match(r"\s*TYPE\b", line, re.I):
                    continue
            line = code.count("\n", 0, m.start()) + 1
            probs.append(f"{path}:{line}: {why}: {m.group(0).strip()}")
            break
    # Arithmetic on bit strings (WORD/DWORD/BYTE variables in + - * / MOD).
    bitvars = {m.group(1).upper() for m in BITSTRING_DECL.finditer(code)}
    for m in re.finditer(r"(\w+(?:\.\w+|\[[^\]]*\])*)\s*(\+|-|\*|/|\bMOD\b)\s*(\w+)", code):
        left = m.group(1).split(".")[-1].split("[")[0].upper()
        right = m.group(3).upper()
        if left in bitvars or right in bitvars:
            line = code.count("\n", 0, m.start()) + 1
            probs.append(f"{path}:{line}: arithmetic on a bit string ({m.group(0).strip()}): convert to an integer type first")
            break
    return probs + nested_in_out_calls(path, code)


LIBRARY_DIR = __import__("pathlib").Path(__file__).resolve().parent.parent / "src"


def in_out_functions(code: str) -> set[str]:
    """The FUNCTIONs (not blocks) that declare a VAR_IN_OUT."""
    return {m.group(1).upper() for m in re.finditer(r"(?ms)^\s*FUNCTION\s+(\w+)\s*:.*?^\s*END_FUNCTION\b", code)
            if re.search(r"\bVAR_IN_OUT\b", m.group(0), re.I)}


def nested_in_out_calls(path: str, code: str) -> list[str]:
    """A FUNCTION with a VAR_IN_OUT called inside another call's arguments:
    matiec emits no C body for such a call (the program does not link).
    The functions are those of this file and of the library (plc/src)."""
    names = in_out_functions(code)
    for lib in sorted(LIBRARY_DIR.glob("*.st")):
        names |= in_out_functions(strip_comments_and_strings(lib.read_text(encoding="utf-8")))
    stack = []  # for each open parenthesis: is it a call's?
    for m in re.finditer(r"(\w+)\s*\(|\(|\)", code):
        if m.group(0) == ")":
            if stack:
                stack.pop()
            continue
        callee = (m.group(1) or "").upper()
        if callee in names and any(stack):
            line = code.count("\n", 0, m.start()) + 1
            return [f"{path}:{line}: {m.group(1)} (it has a VAR_IN_OUT) called inside another call's "
                    "arguments: matiec cannot compile that; assign it to a variable first"]
        stack.append(bool(callee) and callee not in ("IF", "WHILE", "UNTIL", "AND", "OR", "XOR", "NOT", "MOD"))
    return []


def treesitter_problems(path: str, text: str) -> list[str]:
    parser = tree_sitter.Parser(tree_sitter.Language(ts_st.language()))
    tree = parser.parse(text.encode())
    out = []

    def walk(n):
        if n.type == "ERROR" or n.is_missing:
            out.append(f"{path}:{n.start_point[0] + 1}:{n.start_point[1] + 1}: tree-sitter: syntax error near "
                       f"{n.text[:40]!r}")
        for c in n.children:
            walk(c)
    walk(tree.root_node)
    return out[:5]


def blark_problems(path: str) -> list[str]:
    try:
        stinterp.parsed_items(path)
    except stinterp.StError as e:
        return [f"blark: {e}"]
    return []


def check(path: str, adapter: bool = False) -> list[str]:
    text = open(path, encoding="utf-8").read()
    return treesitter_problems(path, text) + blark_problems(path) + subset_problems(path, text, adapter)


def main(argv):
    adapter = "--adapter" in argv
    files = [a for a in argv if not a.startswith("--")]
    bad = 0
    for f in files:
        for p in check(f, adapter):
            print(p)
            bad += 1
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
