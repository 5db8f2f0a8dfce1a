"""The compiled replay against the SimPy machine model at one level, side by side:
stage visits per second of each on the same costed trace and machine, interleaved,
best of --repeat, and the two engines' cycles (which must be equal).

    python studies/11_replay_speed/compiled.py [--trace tests/data/golden/balls-g9.npz]
        [--scene balls --res 128 --grid 20] [--model 3mppe] [--level 2] [--pes 2] [--repeat 3]

The compiled replay's figures: `load` (once per costed trace: `Compiled(trace, costs)`),
per design `run` (`.cycles(config)`: the replay alone) and `result` (`.result(config)`: the
replay and the SimResult), best of 10 per round; SimPy's: `System(trace, config,
costs=costs).run()`, all per design, one per round.  Wall time and CPU (process) time.  Costing the trace (shared by both) is not timed.  Prints a table; nothing written.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
import mprt  # noqa: E402
from mprt.cost import CostModel  # noqa: E402
from mprt.fidelity import Compiled, at_level  # noqa: E402
from mprt.machine import builtin  # noqa: E402
from mprt.machine.system import System  # noqa: E402


CPU = {}     # the same figures in CPU (process) time: what a loaded shared machine does not take away


def best(fn, repeat, key=None):
    out, secs, cpus = None, [], []
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        out = fn()
        secs.append(time.perf_counter() - t)
        cpus.append(time.process_time() - c)
    if key:
        CPU[key] = min(CPU.get(key, float("inf")), min(cpus))
    return out, min(secs)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trace", default=None, help="a trace file (default: trace --scene)")
    ap.add_argument("--scene", default=None)
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--grid", type=int, default=20)
    ap.add_argument("--model", default="3mppe")
    ap.add_argument("--level", type=int, default=2)
    ap.add_argument("--pes", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args(argv)
    if a.scene:
        from mprt.tracing import trace as trace_grid

        grid = mprt.Grid.build(mprt.Scene.from_spd(a.scene), a.grid)
        trace = trace_grid(grid, a.res, a.res)
        what = f"{a.scene} {a.res}x{a.res} grid {a.grid}"
    else:
        path = a.trace or os.path.join(HERE, "..", "..", "tests", "data", "golden", "balls-g9.npz")
        trace = mprt.load_trace(path)
        what = os.path.basename(path)
    cfg = at_level(builtin(a.model).replace(pes=a.pes), a.level)
    costs = CostModel.default().visit_costs(trace, cfg.processors())
    n = len(trace.visits)
    comp, load = best(lambda: Compiled(trace, costs), a.repeat, "compiled load (once)")
    rows = []
    simpy_s = run_s = result_s = float("inf")
    for _ in range(a.repeat):           # interleaved: both engines see the same load on the machine
        r_simpy, s = best(lambda: System(trace, cfg, costs=costs).run(), 1, "simpy (per design)")
        simpy_s = min(simpy_s, s)
        cyc, s = best(lambda: comp.cycles(cfg), 10, "compiled run (per design)")   # (short: best of 10 a round)
        run_s = min(run_s, s)
        r_comp, s = best(lambda: comp.result(cfg), 10, "compiled result (per design)")
        result_s = min(result_s, s)
    assert r_simpy.cycles == cyc == r_comp.cycles, (r_simpy.cycles, cyc, r_comp.cycles)
    rows.append(("simpy (per design)", simpy_s))
    rows.append(("compiled load (once)", load))
    rows.append(("compiled run (per design)", run_s))
    rows.append(("compiled result (per design)", result_s))
    print(f"{what}: {n:,} visits, {a.model} at level {a.level}, {a.pes} PE(s), {cyc:,} cycles "
          f"(both engines), best of {a.repeat}")
    simpy_c = CPU["simpy (per design)"]
    print(f"  {'':30s} {'wall':>9s}    {'wall M visits/s':>15s} {'x simpy':>9s}   {'CPU M visits/s':>14s} {'x simpy':>9s}")
    for name, s in rows:
        c = CPU[name]
        print(f"  {name:30s} {s:9.4f} s  {n / s / 1e6:15.3f} {simpy_s / s:8.1f}x   {n / c / 1e6:14.3f} "
              f"{simpy_c / c:8.1f}x")


if __name__ == "__main__":
    main()
