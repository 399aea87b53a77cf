#!/usr/bin/env python3
"""Example lines of chapter 4 of the protocol document, and the corpus check.

  chapter4.py extract [SPEC]          print every example line of chapter 4 as
                                      a corpus skeleton (`@` headers and
                                      `<kind> doc |<line>` vectors)
  chapter4.py check CORPUS [SPEC]     fail unless the `doc` vectors of CORPUS
                                      are exactly the document's example
                                      lines, section by section (as multisets)

SPEC defaults to $HANS_SPEC or ../shared/spec/HR-TCP-V1.0.0.3.zh.txt next to
the repository. The V6 document ("Huayan Robot V6", recognised by its title)
works the same way: its example lines are indented and its pages carry a
header and a footer inside the example blocks, so for it the indentation is
dropped and the page furniture skipped. The corpus, not this script, is what
the tests read; the check keeps the corpus honest ("every example line,
verbatim").
"""
import collections
import os
import re
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_SPEC = os.environ.get(
    "HANS_SPEC",
    os.path.join(HERE, "..", "..", "..", "shared", "spec", "HR-TCP-V1.0.0.3.zh.txt"),
)

EXAMPLE = re.compile(r"^(4\.\d+\.\d+)\.2\.\s*示例")
HEADING = re.compile(r"^(4\.\d+\.\d+)\.?\s*(?:\*\*)?\s*([A-Za-z][A-Za-z0-9 ]*)")


def is_v6(spec_path):
    """`True` for the V6 document (its title is on its first page)."""
    with open(spec_path, encoding="utf-8") as f:
        return "Huayan Robot V6" in f.read(4000)


# Page furniture of the V6 document: footer and running header (the
# non-ASCII test below drops the Chinese ones too).
V6_FURNITURE = re.compile(r"^\s*(www\.huayan-robotics\.com\b.*|通信协议命令)\s*$")


def example_lines(spec_path):
    """Yields (section, line) for every example line of chapter 4, verbatim
    (for the V6 document without its indentation)."""
    section = None
    seen = False
    v6 = is_v6(spec_path)
    with open(spec_path, encoding="utf-8") as f:
        for raw in f:
            line = raw.rstrip("\n")
            m = EXAMPLE.match(line.lstrip())
            if m:
                section = m.group(1)
                seen = True
                continue
            # The table of contents also names chapter 5: stop only after
            # the examples.
            if seen and line.lstrip().startswith("第五章"):
                return
            if section is None:
                continue
            if v6:
                # Page furniture, and the second lines of wrapped comments
                # (example messages are ASCII).
                if V6_FURNITURE.match(line) or not line.isascii():
                    continue
                line = line.strip()
            # Any other numbered heading ends the example block.
            if re.match(r"^\s*4\.\d+", line):
                section = None
                continue
            s = line.strip()
            if (
                not s
                or s.startswith("//")
                or s.startswith("*")
                or s.startswith("```")
                or s.startswith("${\\bf")
            ):
                continue
            yield section, line


def kind_of(line):
    l = line.replace(" ", "")
    if ",OK," in l or l.endswith(",OK;"):
        return "ok"
    if ",Fail," in l:
        return "fail"
    return "req"


def command_names(spec_path):
    names = {}
    with open(spec_path, encoding="utf-8") as f:
        for line in f:
            m = re.match(r"^\s*(4\.\d+\.\d+)\.\s*(?:\*\*)?([A-Za-z][A-Za-z0-9 ]+?)(?:\*\*|\.|\(|\s*$)", line)
            if m and m.group(1) not in names:
                names[m.group(1)] = m.group(2).replace(" ", "")
    return names


def extract(spec_path):
    names = command_names(spec_path)
    current = None
    for section, line in example_lines(spec_path):
        if section != current:
            print()
            print(f"@ {section} {names.get(section, '?')}")
            current = section
        print(f"{kind_of(line)} doc |{line}")


def corpus_doc_lines(corpus_path):
    section = None
    out = collections.defaultdict(collections.Counter)
    with open(corpus_path, encoding="utf-8") as f:
        for n, raw in enumerate(f, 1):
            line = raw.rstrip("\n")
            if line.startswith("@ "):
                section = line.split()[1]
                continue
            m = re.match(r"^(req|ok|fail|errorcmd) (\w+) \|(.*)$", line)
            if m and m.group(2) == "doc":
                out[section][m.group(3)] += 1
    return out


def check(corpus_path, spec_path):
    want = collections.defaultdict(collections.Counter)
    for section, line in example_lines(spec_path):
        want[section][line] += 1
    have = corpus_doc_lines(corpus_path)
    bad = 0
    for section in sorted(set(want) | set(have), key=lambda s: [int(p) for p in s.split(".")]):
        missing = want[section] - have[section]
        extra = have[section] - want[section]
        for line in missing:
            print(f"{section}: missing from corpus: {line!r}")
            bad += 1
        for line in extra:
            print(f"{section}: not an example line of the document: {line!r}")
            bad += 1
    total = sum(sum(c.values()) for c in want.values())
    sections = len(want)
    if bad:
        print(f"FAIL: {bad} differences")
        return 1
    print(f"ok: {total} example lines of {sections} sections, all in the corpus verbatim")
    return 0


def spec_or_explain(path):
    """`path` if the document is there, else None after saying where it was looked for."""
    if os.path.isfile(path):
        return path
    print(f"chapter4.py: no protocol document at {path}; "
          "set HANS_SPEC or pass SPEC", file=sys.stderr)
    return None


def main(argv):
    if len(argv) >= 2 and argv[1] == "extract":
        spec = spec_or_explain(argv[2] if len(argv) > 2 else DEFAULT_SPEC)
        if spec is None:
            return 2
        extract(spec)
        return 0
    if len(argv) >= 3 and argv[1] == "check":
        spec = spec_or_explain(argv[3] if len(argv) > 3 else DEFAULT_SPEC)
        return 2 if spec is None else check(argv[2], spec)
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv))
