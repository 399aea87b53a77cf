#!/usr/bin/env python3
"""Runs the host workspace's tests as `cargo test` would, in two lanes.

    python3 scripts/host-tests.py [cargo test options, e.g. --exclude PKG]

`cargo test` builds every test binary, then runs them one after another;
on two cores most of that time is one binary waiting (headless Chromium,
a QEMU-free simulation bounded in wall time) while the other core idles.
Here: one `cargo test --no-run --all-targets` builds them (one build, the
same feature resolution as `cargo test --workspace`; the benchmarks are
built, not run), then two workers run the
binaries, longest first, each in its package's directory and with the
`[env]` of .cargo/config.toml as cargo runs them, each binary's output
printed whole when it ends (with its time);
then `cargo test --doc` runs the documentation tests (its libraries are
already built). Every test binary already runs its own tests in parallel
threads, so the tests are written for concurrency (free ports, temporary
directories): running two binaries at once adds nothing new to that.

Exit status: 0 when every binary and the doc tests passed, 1 otherwise (the
failing binaries are named last). Each binary runs under a 15-minute
timeout.
"""

import json
import os
import subprocess
import sys
import threading
import time
import tomllib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# Binaries known to take long (seconds on 2 cores, measured 2026-11-29):
# they start first so that the short ones fill the other lane.
LONG = {"web_browser": 150, "bounded": 56, "update": 52, "fleet": 14, "mqtt": 11}
TIMEOUT = 900


def build(extra):
    # --all-targets: the benchmarks are built too (not run: they measure,
    # `cargo bench`), so that this build is the whole workspace's clippy
    # run when scripts/test-all.sh has set clippy-driver as the compiler of
    # the workspace's crates.
    cmd = ["cargo", "test", "--workspace", "--all-targets", "--locked", "--no-run",
           "--message-format=json-render-diagnostics", *extra]
    print("==> " + " ".join(cmd), flush=True)
    proc = subprocess.run(cmd, cwd=ROOT, stdout=subprocess.PIPE, text=True)
    if proc.returncode != 0:
        sys.exit(proc.returncode)
    runs = []
    for line in proc.stdout.splitlines():
        try:
            msg = json.loads(line)
        except ValueError:
            continue
        if msg.get("reason") != "compiler-artifact" or not msg.get("profile", {}).get("test"):
            continue
        exe = msg.get("executable")
        if not exe:
            continue
        target = msg["target"]
        if "bench" in target["kind"]:
            continue
        runs.append({
            "name": f"{msg['package_id'].split('#')[0].rsplit('/', 1)[-1]} {target['kind'][0]} {target['name']}",
            "target": target["name"],
            "exe": exe,
            "cwd": os.path.dirname(msg["manifest_path"]),
        })
    return runs


def cargo_env():
    """The environment cargo gives the tests: ours plus the `[env]` table
    of .cargo/config.toml (RUST_MIN_STACK)."""
    env = dict(os.environ)
    with open(os.path.join(ROOT, ".cargo", "config.toml"), "rb") as f:
        for name, value in tomllib.load(f).get("env", {}).items():
            if isinstance(value, dict):
                value = value["value"]
            env.setdefault(name, str(value))
    return env


def main():
    extra = sys.argv[1:]
    runs = build(extra)
    env = cargo_env()
    runs.sort(key=lambda r: -LONG.get(r["target"], 0))
    queue = list(runs)
    lock = threading.Lock()
    failed = []
    started = time.monotonic()

    def worker():
        while True:
            with lock:
                if not queue:
                    return
                run = queue.pop(0)
            t0 = time.monotonic()
            try:
                proc = subprocess.run([run["exe"]], cwd=run["cwd"], env=env, stdout=subprocess.PIPE,
                                      stderr=subprocess.STDOUT, timeout=TIMEOUT)
                out, code = proc.stdout.decode(errors="replace"), proc.returncode
            except subprocess.TimeoutExpired as e:
                out = (e.stdout or b"").decode(errors="replace") + f"\nTIMEOUT after {TIMEOUT} s\n"
                code = -1
            secs = time.monotonic() - t0
            with lock:
                print(f"     Running {run['name']} ({os.path.relpath(run['exe'], ROOT)}): {secs:.1f} s",
                      flush=True)
                sys.stdout.write(out)
                sys.stdout.flush()
                if code != 0:
                    failed.append(f"{run['name']} (exit {code})")

    lanes = [threading.Thread(target=worker) for _ in range(2)]
    for t in lanes:
        t.start()
    for t in lanes:
        t.join()
    print(f"==> {len(runs)} test binaries in {time.monotonic() - started:.0f} s (two lanes)", flush=True)

    doc = subprocess.run(["cargo", "test", "--workspace", "--locked", "--doc", *extra], cwd=ROOT)
    if doc.returncode != 0:
        failed.append("doc tests")
    if failed:
        print("FAILED: " + ", ".join(failed), flush=True)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
