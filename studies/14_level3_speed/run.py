"""Level 3 (memories on the ideal network) in the compiled replay against SimPy, side by side.

    .venv/bin/python studies/14_level3_speed/run.py [TRACE.npz ...] [--pes 2] [--repeat 5] [--simpy-max N]
        [--only 3mppe-ideal-net|3mppe-small]

For each trace: the 3MPPE's memories with the ring taken out (and the same machine with
small memories, so the golden scenes miss), SimPy's simulate() and the compiled replay's
whole replay() (load, memory data, run, result) and, once loaded, one design's run
(Compiled.cycles, best of --repeat), in visits per second; the cycles must agree.
"""
import argparse
import time

import mprt
from mprt.cost import CostModel
from mprt.fidelity import Compiled, replay
from mprt.fidelity.memdata import MemoryData
from mprt.machine import builtin, simulate
from mprt.machine.config import CacheConfig, GlobalMemoryConfig, LocalMemoryConfig


def configs(pes):
    three = builtin("3mppe").replace(ring=None, pes=pes)
    small = three.replace(name="3mppe-small", ic_memory=LocalMemoryConfig(1024, CacheConfig(2048, 32, 2)),
                          sc_memory=LocalMemoryConfig(0, CacheConfig(128, 32, 2)))
    return [three.replace(name="3mppe-ideal-net"), small]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("traces", nargs="*", default=["tests/data/golden/balls-g9.npz"])
    ap.add_argument("--pes", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--simpy-max", type=int, default=50_000_000, help="skip SimPy above this many visits")
    ap.add_argument("--only", help="only the configuration of this name")
    a = ap.parse_args()
    cm = CostModel.default()
    print(f"{'trace':28} {'config':16} {'visits':>10} {'cycles':>12} {'SimPy v/s':>11} {'whole v/s':>11} "
          f"{'run v/s':>12} {'run/SimPy':>9} {'data s':>7}")
    for path in a.traces:
        t = mprt.load_trace(path)
        n = len(t.visits)
        md = MemoryData(t)
        for cfg in configs(a.pes):
            if a.only and cfg.name != a.only:
                continue
            vc = cm.visit_costs(t, cfg.processors())
            if n <= a.simpy_max:
                t0 = time.perf_counter()
                ref = simulate(t, cfg, costs=vc)
                ts = time.perf_counter() - t0
            else:
                ref, ts = None, float("nan")
            t0 = time.perf_counter()
            whole = replay(t, cfg, costs=vc)
            tw = time.perf_counter() - t0
            c = Compiled(t, vc, md)
            t0 = time.perf_counter()
            c.cycles(cfg)                       # memory data made (cached in md) and handed over
            td = time.perf_counter() - t0
            best = float("inf")
            for _ in range(a.repeat):
                t0 = time.perf_counter()
                cyc = c.cycles(cfg)
                best = min(best, time.perf_counter() - t0)
            assert cyc == whole.cycles and (ref is None or ref.cycles == cyc), (cyc, whole.cycles)
            print(f"{path.split('/')[-1]:28} {cfg.name:16} {n:10d} {cyc:12d} {n / ts:11.0f} {n / tw:11.0f} "
                  f"{n / best:12.0f} {ts / best:9.0f} {td:7.2f}")


if __name__ == "__main__":
    main()
