#!/usr/bin/env python3
"""Checks that the gateway's modules import only modules of lower layers.

The layer order is declared once, in the crate's documentation
(gateway/src/lib.rs, section "Layers": a table whose rows are
`| N | `mod`, `mod` | what |`). This reads every top-level module's files,
finds what they use of the crate (`crate::x`, `use crate::{x, y::z}`, `super::`
paths that reach the crate root, and names the crate root re-exports, which it
follows to the module that defines them: `crate::MAX_SESSIONS` is an import of
the module that defines it), and fails when a module imports one of its own
layer or a higher one, or when a module is missing from the table.

    python3 scripts/layers.py [--list] [--src gateway/src]
    python3 scripts/layers.py --self-test

--list prints every edge with its layers. --self-test checks the checker: on
a copy of the crate it adds an upward import (the state using the
composition root), once by path and once through a name the crate root
re-exports (the way `crate::MAX_SESSIONS` once hid a cycle through 14
modules), and expects each to fail. Test code (an inline
`#[cfg(test)] mod tests {` to the end of its file, `tests.rs` files) and the
testkit are left out: a test may use whatever it checks. Exit status 1 on a
violation, 2 when the table cannot be read.
"""
import os
import re
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_SRC = os.path.join(HERE, "..", "gateway", "src")
# What is not a layer: the root itself, and test code.
SKIP = {"lib", "testkit"}

ROW = re.compile(r"^//!\s*\|\s*(\d+)\s*\|([^|]*)\|")
TICK = re.compile(r"`([a-z_][a-z0-9_]*)`")
IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def strip_comments(text):
    """Removes comments (documentation included) and string literals, which
    may mention paths that are not imports."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            depth, i = 1, i + 2
            while i < n and depth:
                if text.startswith("/*", i):
                    depth, i = depth + 1, i + 2
                elif text.startswith("*/", i):
                    depth, i = depth - 1, i + 2
                else:
                    i += 1
        elif c == '"':
            i += 1
            while i < n and text[i] != '"':
                i += 2 if text[i] == "\\" else 1
            i += 1
            out.append('""')
        elif c == "r" and re.match(r'r#*"', text[i:i + 10] or ""):
            m = re.match(r'r(#*)"', text[i:])
            end = '"' + m.group(1)
            j = text.find(end, i + len(m.group(0)))
            i = n if j < 0 else j + len(end)
            out.append('""')
        elif c == "'" and re.match(r"'(\\.|[^\\'])'", text[i:i + 4] or ""):
            # A char literal ('"' would start a string otherwise).
            m = re.match(r"'(\\.|[^\\'])'", text[i:])
            i += len(m.group(0))
        else:
            out.append(c)
            i += 1
    return "".join(out)


def without_tests(text):
    i = text.find("#[cfg(test)]\nmod tests {")
    return text if i < 0 else text[:i]


def module_path(src, path):
    """The module path of a file: src/a.rs -> [a], src/a/mod.rs -> [a],
    src/a/b.rs -> [a, b]."""
    rel = os.path.relpath(path, src)[:-3].split(os.sep)
    if rel[-1] == "mod":
        rel = rel[:-1]
    return rel


def layers_of(lib_text):
    layers = {}
    for line in lib_text.splitlines():
        m = ROW.match(line)
        if not m:
            continue
        for name in TICK.findall(m.group(2)):
            if name in layers:
                raise ValueError(f"`{name}` is in two layers")
            layers[name] = int(m.group(1))
    return layers


def root_reexports(lib_text, modules):
    """Names the crate root re-exports, and the module each comes from."""
    found = {}
    code = strip_comments(lib_text)
    for m in re.finditer(r"\bpub\s+use\s+([^;]+);", code):
        body = m.group(1).strip()
        first = IDENT.match(body)
        if not first or first.group(0) not in modules:
            continue
        owner = first.group(0)
        if "{" in body:
            inner = body[body.index("{") + 1 : body.rindex("}")]
            names = []
            for part in split_top(inner):
                part = part.strip()
                if " as " in part:
                    names.append(part.split(" as ")[1].strip())
                elif part:
                    names.append(re.split(r"::", part)[-1].strip())
        elif " as " in body:
            names = [body.split(" as ")[1].strip()]
        else:
            names = [body.split("::")[-1].strip()]
        for name in names:
            if name not in ("self", "*"):
                found[name] = owner
    return found


def split_top(inner):
    """Splits `a, b::{c, d}, e` at the commas outside braces."""
    parts, depth, cur = [], 0, []
    for ch in inner:
        if ch == "{":
            depth += 1
        elif ch == "}":
            depth -= 1
        if ch == "," and depth == 0:
            parts.append("".join(cur))
            cur = []
        else:
            cur.append(ch)
    parts.append("".join(cur))
    return parts


def group_heads(inner):
    """The first names of the paths in a `use crate::{...}` group."""
    heads = []
    for part in split_top(inner):
        m = IDENT.match(part.strip())
        if m:
            heads.append(m.group(0))
    return heads


def inline_modules(code):
    """The spans of inline `mod name { ... }` blocks: a `super::` inside
    one climbs one level less far."""
    spans = []
    for m in re.finditer(r"\bmod\s+[A-Za-z_][A-Za-z0-9_]*\s*\{", code):
        depth, i = 1, m.end()
        while i < len(code) and depth:
            depth += {"{": 1, "}": -1}.get(code[i], 0)
            i += 1
        spans.append((m.end(), i))
    return spans


def root_names(code, here):
    """Names this file reaches at the crate root: `crate::x`, the heads of
    `use crate::{...}` groups, and `super::` paths that climb to the root."""
    names = set(re.findall(r"\bcrate::([A-Za-z_][A-Za-z0-9_]*)", code))
    for m in re.finditer(r"\bcrate::\{", code):
        depth, i = 1, m.end()
        while i < len(code) and depth:
            depth += {"{": 1, "}": -1}.get(code[i], 0)
            i += 1
        names.update(group_heads(code[m.end() : i - 1]))
    inline = inline_modules(code)
    for m in re.finditer(r"\b((?:super::)+)(\{|[A-Za-z_][A-Za-z0-9_]*)", code):
        ups = m.group(1).count("super::")
        nested = sum(1 for a, b in inline if a <= m.start() < b)
        if ups != len(here) + nested:
            continue  # stays inside this top-level module
        if m.group(2) == "{":
            depth, i = 1, m.end()
            while i < len(code) and depth:
                depth += {"{": 1, "}": -1}.get(code[i], 0)
                i += 1
            names.update(group_heads(code[m.end() : i - 1]))
        else:
            names.add(m.group(2))
    return names


def edges(src):
    lib_text = open(os.path.join(src, "lib.rs"), encoding="utf-8").read()
    modules = set()
    for entry in os.listdir(src):
        path = os.path.join(src, entry)
        if entry.endswith(".rs"):
            modules.add(entry[:-3])
        elif os.path.isdir(path):
            modules.add(entry)
    modules -= {"lib"}
    reexports = root_reexports(lib_text, modules)
    out = {}
    for d, _, files in os.walk(src):
        for f in files:
            if not f.endswith(".rs") or f == "tests.rs":
                continue
            path = os.path.join(d, f)
            here = module_path(src, path)
            top = here[0]
            if top in SKIP:
                continue
            text = without_tests(open(path, encoding="utf-8").read())
            code = strip_comments(text)
            for name in root_names(code, here):
                target = name if name in modules else reexports.get(name)
                if target and target != top and target not in SKIP:
                    out.setdefault(top, set()).add(target)
    return modules, out, lib_text


def self_test():
    import shutil
    import subprocess
    import tempfile

    here = os.path.abspath(__file__)
    results = []
    for line in ("use crate::gateway::Options;\n", "use crate::Options;\n"):
        with tempfile.TemporaryDirectory() as tmp:
            copy = os.path.join(tmp, "src")
            shutil.copytree(DEFAULT_SRC, copy)
            target = os.path.join(copy, "state", "mod.rs")
            text = open(target, encoding="utf-8").read()
            # After the module's docs, before its first item.
            at = text.find("\nuse ")
            open(target, "w", encoding="utf-8").write(text[: at + 1] + line + text[at + 1 :])
            run = subprocess.run(
                [sys.executable, here, "--src", copy], capture_output=True, text=True
            )
            caught = run.returncode == 1 and "state (layer" in run.stdout
            results.append(caught)
            print(f"{'caught' if caught else 'MISSED'}: {line.strip()} in state/mod.rs")
    return 0 if all(results) else 1


def main(argv):
    if "--self-test" in argv:
        return self_test()
    src = DEFAULT_SRC
    if "--src" in argv:
        src = argv[argv.index("--src") + 1]
    modules, graph, lib_text = edges(src)
    try:
        layers = layers_of(lib_text)
    except ValueError as e:
        print(f"layers: {e}", file=sys.stderr)
        return 2
    if not layers:
        print("layers: no layer table in lib.rs (section Layers)", file=sys.stderr)
        return 2
    bad = []
    for m in sorted(modules - SKIP):
        if m not in layers:
            bad.append(f"`{m}` is in no layer of the table in lib.rs")
    for m in sorted(set(layers) - modules):
        bad.append(f"`{m}` is in the table but is no module")
    for a in sorted(graph):
        for b in sorted(graph[a]):
            la, lb = layers.get(a), layers.get(b)
            if "--list" in argv:
                print(f"{a} ({la}) -> {b} ({lb})")
            if la is not None and lb is not None and lb >= la:
                way = "sideways" if lb == la else "upward"
                bad.append(f"{a} (layer {la}) imports {b} (layer {lb}): {way}")
    for line in bad:
        print(line)
    if bad:
        print(f"{len(bad)} violation(s) of the layer order declared in {os.path.join(src, 'lib.rs')}")
        return 1
    print(f"{sum(len(v) for v in graph.values())} imports between {len(modules - SKIP)} modules, all downward")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
