"""The whole ``mprt simulate TRACE`` command, phase by phase, on both engines,
side by side in one run: visits per second of the command (load the trace
file and verify its checksums, cost every visit, load the costed trace into
the replay and check it, replay, report), and where the time goes.

    python studies/11_replay_speed/whole_command.py TRACE.npz [--models M,3mppe]
           [--engines compiled,simpy] [--level 1] [--before PYTHONPATH [--before-engines compiled]]
           [--repeat N]

Each measurement is a fresh process running the real command
(``mprt.cli.main(["simulate", TRACE, "--engine", E, "--level", L, "--model", M])``)
with timers wrapped around the functions each phase is: ``load_trace``
(load), ``CostModel.visit_costs`` (cost, wherever it is called from; SimPy
costs page by page during its run), ``Compiled.__init__`` / ``System.__init__``
(prepare: the costed trace loaded into the C replay and checked, or the
SimPy machine built and the trace scanned), ``Compiled.result`` /
``System.run`` less the costing inside it (run), ``SimResult.report``
(report); ``other`` is the rest of the command's own time (``in all``, from
the configuration to the report).  ``process`` is the whole process, Python's
start and imports included; ``cpu`` its user + system seconds.  With
``--before`` (the ``python`` folder of another checkout with its extension
built, e.g. ``make bench``'s build/before/python) each row is also run on that
build, interleaved.  Visits/s are the trace's visits over the command's
``in all`` seconds.  Exit status 1 if the engines or builds disagree on the
cycles.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import re
import resource
import subprocess
import sys
import time

PHASES = ("load", "cost", "prepare", "run", "report")


def _child(trace: str, engine: str, model: str, level: str) -> None:
    """Run the command with phase timers; print its figures as JSON."""
    t_start = time.perf_counter()
    import mprt.cli
    import mprt.trace
    from mprt.cost.model import CostModel
    from mprt.fidelity.compiled import Compiled
    from mprt.machine.result import SimResult
    from mprt.machine.system import System

    spent = dict.fromkeys(PHASES, 0.0)
    inner = {"cost": 0.0}

    def timed(owner, name, phase, less_cost=False):
        f = getattr(owner, name)

        def wrapper(*a, **kw):
            t0, c0 = time.perf_counter(), inner["cost"]
            try:
                return f(*a, **kw)
            finally:
                dt = time.perf_counter() - t0
                if phase == "cost":
                    inner["cost"] += dt
                spent[phase] += dt - ((inner["cost"] - c0) if less_cost else 0.0)

        setattr(owner, name, wrapper)

    timed(mprt.trace, "load_trace", "load")
    timed(CostModel, "visit_costs", "cost")
    timed(Compiled, "__init__", "prepare", less_cost=True)
    timed(Compiled, "result", "run", less_cost=True)
    timed(System, "__init__", "prepare", less_cost=True)
    timed(System, "run", "run", less_cost=True)
    timed(SimResult, "report", "report")
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        rc = mprt.cli.main(["simulate", trace, "--engine", engine, "--level", level, "--model", model])
    text = out.getvalue()
    m = re.search(r"([\d.]+) s in all", text)
    cyc = re.search(r"\(level \d\): ([\d,]+) cycles, ([\d,]+) visits", text)
    if rc or not m or not cyc:
        print(text, file=sys.stderr)
        raise SystemExit(f"the command failed (status {rc})")
    print(json.dumps({"phases": spent, "in_all": float(m.group(1)), "cycles": int(cyc.group(1).replace(",", "")),
                      "visits": int(cyc.group(2).replace(",", "")), "child_wall": time.perf_counter() - t_start}))


def measure(trace, engine, model, level, pythonpath) -> dict:
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    from _common import command_env    # (here, not at the top: the child measured imports nothing of it)

    env = command_env(pythonpath)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", trace, "--engines", engine,
                        "--models", model, "--level", level], env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode:
        raise SystemExit(f"{engine} {model} ({pythonpath}): {p.stderr.strip()[-2000:]}")
    d = json.loads(p.stdout.strip().splitlines()[-1])
    d.update(process=wall, cpu=(after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime))
    return d


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("trace")
    ap.add_argument("--models", default="M,3mppe")
    ap.add_argument("--engines", default="compiled,simpy")
    ap.add_argument("--level", default="1")
    ap.add_argument("--before", default=None, metavar="PYTHONPATH")
    ap.add_argument("--before-engines", default="compiled", help="the engines also run on --before (default: compiled)")
    ap.add_argument("--repeat", type=int, default=1, help="runs of each compiled row (best kept; SimPy runs once)")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        _child(a.trace, a.engines, a.models, a.level)
        return 0
    here = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "python")
    builds = [("this", here)] + ([("before", os.path.abspath(a.before))] if a.before else [])
    print(f"trace {a.trace}; level {a.level}; {os.cpu_count()} cores, load average "
          f"{os.getloadavg()[0]:.1f} at the start")
    head = (f"{'build':7s} {'engine':9s} {'model':6s} " + " ".join(f"{p:>8s}" for p in PHASES)
            + f" {'other':>7s} {'in all':>8s} {'process':>8s} {'cpu':>7s} {'M visits/s':>10s}  cycles")
    print(head)
    cycles, bad = {}, False
    for model in a.models.split(","):
        for engine in a.engines.split(","):
            for name, path in builds:
                if name == "before" and engine not in a.before_engines.split(","):
                    continue
                runs = [measure(a.trace, engine, model, a.level, path)
                        for _ in range(a.repeat if engine != "simpy" else 1)]
                d = min(runs, key=lambda r: r["in_all"])
                other = d["in_all"] - sum(d["phases"].values())
                print(f"{name:7s} {engine:9s} {model:6s} " + " ".join(f"{d['phases'][p]:8.2f}" for p in PHASES)
                      + f" {other:7.2f} {d['in_all']:8.2f} {d['process']:8.2f} {d['cpu']:7.2f} "
                      f"{d['visits'] / d['in_all'] / 1e6:10.2f}  {d['cycles']:,}", flush=True)
                if cycles.setdefault(model, d["cycles"]) != d["cycles"]:
                    print(f"  cycles differ from the first row of model {model}", flush=True)
                    bad = True
    print(f"load average {os.getloadavg()[0]:.1f} at the end")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
