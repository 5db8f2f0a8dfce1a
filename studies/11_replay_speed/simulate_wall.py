"""``mprt simulate TRACE --engine compiled`` as a whole command, wall clock from the process's
start to its end, of two builds side by side in one run (interleaved rounds, best of N):

    python studies/11_replay_speed/simulate_wall.py TRACE.npz BEFORE_MPRT AFTER_MPRT [--repeat 3]
           [--case "level 1=" --case "level 3=--model 3mppe --level 3 --pes 2"]

Prints a Markdown table: per build and case the best wall, its visits/s (the trace's visits
over the wall), the median wall, the best CPU (user + system of the process) and the cycles
(exit 1 if the builds disagree on them)."""
from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from _common import command_env  # noqa: E402

CASES = ("level 1=", "level 3=--model 3mppe --level 3 --pes 2")


def run(mprt: str, trace: str, extra: list) -> tuple:
    """(wall s, cpu s, cycles, visits) of one command in a fresh process."""
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "r.json")
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        p = subprocess.run([mprt, "simulate", trace, "--engine", "compiled", *extra, "--json", out],
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=command_env())
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if p.returncode:
            sys.exit(f"{mprt} failed ({p.returncode}): {p.stderr[-2000:]}")
        with open(out) as f:
            res = json.load(f)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, res["cycles"], res["visits"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("trace")
    ap.add_argument("before")
    ap.add_argument("after")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--case", action="append", default=None, metavar="NAME=ARGS")
    a = ap.parse_args(argv)
    cases = [c.split("=", 1) for c in (a.case or CASES)]
    builds = {"before": a.before, "after": a.after}
    got = {(b, name): [] for name, _ in cases for b in builds}
    for r in range(a.repeat):
        for name, extra in cases:
            for b, mprt in builds.items():
                got[b, name].append(run(mprt, a.trace, extra.split()))
                w, c, cyc, _ = got[b, name][-1]
                print(f"round {r + 1}: {b} {name}: wall {w:.2f} s, cpu {c:.2f} s, {cyc:,} cycles", file=sys.stderr,
                      flush=True)
    print("| case | build | wall, best | M visits/s | wall, median | cpu, best | cycles |")
    print("|---|---|---|---|---|---|---|")
    rc = 0
    for name, _ in cases:
        for b in builds:
            runs = got[b, name]
            best = min(w for w, *_ in runs)
            visits = runs[0][3]
            print(f"| {name} | {b} | {best:.2f} s | {visits / best / 1e6:.2f} | "
                  f"{statistics.median(w for w, *_ in runs):.2f} s | {min(c for _, c, *_ in runs):.2f} s | "
                  f"{runs[0][2]:,} |")
        if len({r[2] for b in builds for r in got[b, name]}) != 1:
            rc = 1
            print(f"{name}: the builds disagree on the cycles", file=sys.stderr)
    return rc


if __name__ == "__main__":
    sys.exit(main())
