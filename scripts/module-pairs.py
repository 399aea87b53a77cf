#!/usr/bin/env python3
"""Lists the pairs of the gateway's top-level modules that import each other.

Reads every `use crate::MODULE...` line (and `crate::MODULE::` paths in
code) of gateway/src, maps each file to its top-level module (state/,
registers/, engine/, ...), and prints every pair A <-> B where A uses B and
B uses A. Exit status 1 if there is one: a module pair that imports each
other is two modules that cannot be understood, tested or changed alone.

    python3 scripts/module-pairs.py [--list]    (--list: every edge too)

Test code (`#[cfg(test)] mod tests` at the end of a file, tests.rs files)
and the testkit are left out: a test may use whatever it checks.
"""
import os
import re
import sys

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "gateway", "src")
USE = re.compile(r"\bcrate::([a-z_]+)")
# `use crate::{a, b::c}` groups.
GROUP = re.compile(r"use crate::\{([^;]*)\}", re.S)


def top_module(path):
    rel = os.path.relpath(path, ROOT)
    first = rel.split(os.sep)[0]
    return first[:-3] if first.endswith(".rs") else first


def code_without_tests(text):
    # An inline test module (`mod tests {`) ends the file's code; a
    # declaration of one in its own file (`mod tests;`) does not.
    i = text.find("#[cfg(test)]\nmod tests {")
    text = text if i < 0 else text[:i]
    # Comments (documentation links included) are not imports.
    return re.sub(r"//[^\n]*", "", text)


def edges():
    out = {}
    for d, _, files in os.walk(ROOT):
        for f in files:
            if not f.endswith(".rs") or f == "tests.rs":
                continue
            path = os.path.join(d, f)
            src = top_module(path)
            if src in ("testkit", "bin", "lib"):
                continue
            text = code_without_tests(open(path, encoding="utf-8").read())
            names = set(USE.findall(text))
            for g in GROUP.findall(text):
                names.update(re.findall(r"(?:^|,)\s*([a-z_]+)", g))
            for n in names:
                is_module = os.path.exists(os.path.join(ROOT, n + ".rs")) or os.path.isdir(
                    os.path.join(ROOT, n)
                )
                if n != src and is_module:
                    out.setdefault(src, set()).add(n)
    return out


def main():
    e = edges()
    if "--list" in sys.argv:
        for a in sorted(e):
            print(f"{a} -> {', '.join(sorted(e[a]))}")
    pairs = sorted({tuple(sorted((a, b))) for a in e for b in e[a] if a in e.get(b, ())})
    for a, b in pairs:
        print(f"{a} <-> {b}")
    print(f"{len(pairs)} module pairs import each other")
    return 1 if pairs else 0


if __name__ == "__main__":
    sys.exit(main())
