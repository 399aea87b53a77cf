#!/usr/bin/env python3
"""Writes seed inputs for the fuzz targets into corpus/<target>/, from the
test vectors (host-tests/vectors): one file per seed, named by its hash, so
running it again changes nothing. The vectors, not these files, are kept in
git."""
import hashlib
import os
import re
import struct
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
VECTORS = os.path.join(HERE, "..", "vectors")
LINE = re.compile(r"^(req|ok|fail|errorcmd) \w+ \|(.*)$")


def put(target, data):
    d = os.path.join(HERE, "corpus", target)
    os.makedirs(d, exist_ok=True)
    name = hashlib.sha1(data).hexdigest()
    path = os.path.join(d, name)
    if not os.path.exists(path):
        with open(path, "wb") as f:
            f.write(data)


def packet(payload):
    # DataSheet header (chapter 5.2, NOTES.md): "LTBR", total = 12 + payload, payload length.
    return b"LTBR" + struct.pack("<II", 12 + len(payload), len(payload)) + payload


def main():
    blocks = {}
    # The top level and the V6 and V5-only corpora (the fuzz targets build
    # the codec with `v6`; the V5-only lines are good seeds all the same).
    files = []
    for sub in ("", "v6", "v5-only"):
        d = os.path.join(VECTORS, sub)
        files += [os.path.join(sub, n) for n in sorted(os.listdir(d)) if n.endswith(".txt")]
    for name in files:
        block = None
        with open(os.path.join(VECTORS, name), encoding="utf-8") as f:
            for line in f:
                line = line.rstrip("\n")
                if line.startswith("@ "):
                    block = (name, line)
                    continue
                m = LINE.match(line)
                if not m:
                    continue
                text = m.group(2).encode("utf-8")
                put("request", text)
                put("reply", b"\x02" + text)
                blocks.setdefault(block, []).append(text)
    # The framer sees whole exchanges: a block's messages back to back,
    # with and without line ends, behind a seed byte for the read sizes.
    for i, msgs in enumerate(blocks.values()):
        put("framer", bytes([i % 256]) + b"".join(msgs))
        put("framer", bytes([(i * 7) % 256]) + b"\r\n".join(msgs) + b"\r\n")
    sheets = os.path.join(VECTORS, "datasheet")
    payloads = []
    if os.path.isdir(sheets):
        for name in sorted(os.listdir(sheets)):
            if name.endswith(".json"):
                with open(os.path.join(sheets, name), "rb") as f:
                    payloads.append(f.read())
    if not payloads:
        payloads.append(b'{"StateAndError":{"robotState":33,"robotMoving":0}}')
    for i, p in enumerate(payloads):
        put("datasheet", bytes([i]) + packet(p))
        # Two packets with garbage and a false magic between them.
        put("datasheet", bytes([i + 100]) + packet(p) + b"\x00LTB\xffLTBR\x01\x00" + packet(p))
    return 0


if __name__ == "__main__":
    sys.exit(main())
