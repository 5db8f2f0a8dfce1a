"""The compiled replay per design, this checkout against another build, interleaved in fresh
processes: CPU (process) time of ``Compiled.cycles(config)`` on one costed trace, best of
--runs per process, --rounds rounds alternating the builds; the cycles must agree.

    python studies/11_replay_speed/before_after.py TRACE.npz --before build/before/python
        [--model 3mppe] [--level 3] [--pes 2] [--runs 3] [--rounds 5]

``--before``: the ``python`` folder of another checkout with its extension built in place
(``make bench`` builds one in build/before).  Prints each round's M visits/s of CPU and
the ratio, then the best of each; exit status 1 if the cycles differ.  Nothing written.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

CHILD = """
import json, sys, time
import mprt
from mprt.cost import CostModel
from mprt.fidelity import Compiled, at_level
from mprt.machine import builtin
path, model, level, pes, runs = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5])
trace = mprt.load_trace(path)
cfg = at_level(builtin(model).replace(pes=pes), level)
comp = Compiled(trace, CostModel.default().visit_costs(trace, cfg.processors()))
cycles = comp.cycles(cfg)
best = min((lambda c: (comp.cycles(cfg), time.process_time() - c)[1])(time.process_time()) for _ in range(runs))
print(json.dumps({"cycles": cycles, "cpu": best, "visits": len(trace.visits)}))
"""


def one(pythonpath, a):
    env = dict(os.environ)
    if pythonpath:
        env["PYTHONPATH"] = pythonpath
    out = subprocess.run([sys.executable, "-c", CHILD, a.trace, a.model, str(a.level), str(a.pes), str(a.runs)],
                         env=env, capture_output=True, text=True, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("trace")
    ap.add_argument("--before", required=True, metavar="PYTHONPATH")
    ap.add_argument("--model", default="3mppe")
    ap.add_argument("--level", type=int, default=3)
    ap.add_argument("--pes", type=int, default=2)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--rounds", type=int, default=5)
    a = ap.parse_args(argv)
    here = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "python")
    best = {"before": float("inf"), "this": float("inf")}
    cycles = set()
    print(f"{a.trace}: {a.model} at level {a.level}, {a.pes} PE(s); M visits/s of CPU, best of {a.runs} a process")
    for k in range(a.rounds):
        got = {name: one(path, a) for name, path in (("before", a.before), ("this", os.path.normpath(here)))}
        n = got["this"]["visits"]
        for name, g in got.items():
            best[name] = min(best[name], g["cpu"])
            cycles.add(g["cycles"])
        print(f"  round {k + 1}: before {n / got['before']['cpu'] / 1e6:6.2f}  this {n / got['this']['cpu'] / 1e6:6.2f}"
              f"  ratio {got['before']['cpu'] / got['this']['cpu']:.2f}")
    print(f"  best:    before {n / best['before'] / 1e6:6.2f}  this {n / best['this'] / 1e6:6.2f}  ratio "
          f"{best['before'] / best['this']:.2f}; cycles {', '.join(f'{c:,}' for c in sorted(cycles))}")
    return 0 if len(cycles) == 1 else 1


if __name__ == "__main__":
    sys.exit(main())
