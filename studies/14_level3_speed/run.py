"""Level 3 (memories on the ideal network) in the compiled replay against SimPy, side by side.

    .venv/bin/python studies/14_level3_speed/run.py [TRACE.npz ...] [--pes 2] [--repeat 5] [--simpy-max N]
        [--only 3mppe-ideal-net|3mppe-small]

For each trace: the 3MPPE's memories with the ring taken out (and the same machine with
small memories, so the golden scenes miss), SimPy's simulate() and the compiled replay's
whole replay() (load, memory data, run, result) and, once loaded, one design's run
(Compiled.cycles, best of --repeat), in visits per second of wall time, and of CPU time
(process time: what a loaded shared machine does not take away); the cycles must agree.
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
    print(f"{'trace':22} {'config':16} {'visits':>9} {'cycles':>10} {'SimPy v/s':>10} {'whole v/s':>10} "
          f"{'run v/s':>11} {'run/SimPy':>9} | CPU: {'SimPy v/s':>10} {'run v/s':>11} {'run/SimPy':>9} {'data s':>7}")
    for path in a.traces:
        t = mprt.load_trace(path)
        n = len(t.visits)
        md = MemoryData(t)
        for cfg in configs(a.pes):
            if a.only and cfg.name != a.only:
                continue
            vc = cm.visit_costs(t, cfg.processors())
            if n <= a.simpy_max:
                t0, c0 = time.perf_counter(), time.process_time()
                ref = simulate(t, cfg, costs=vc)
                ts, cs = time.perf_counter() - t0, time.process_time() - c0
            else:
                ref, ts, cs = None, float("nan"), float("nan")
            t0 = time.perf_counter()
            whole = replay(t, cfg, costs=vc)
            tw = time.perf_counter() - t0
            c = Compiled(t, vc, md)
            t0 = time.perf_counter()
            c.cycles(cfg)                       # memory data made (cached in md) and handed over
            td = time.perf_counter() - t0
            best = cbest = float("inf")
            for _ in range(a.repeat):
                t0, c0 = time.perf_counter(), time.process_time()
                cyc = c.cycles(cfg)
                best = min(best, time.perf_counter() - t0)
                cbest = min(cbest, time.process_time() - c0)
            assert cyc == whole.cycles and (ref is None or ref.cycles == cyc), (cyc, whole.cycles)
            print(f"{path.split('/')[-1]:22} {cfg.name:16} {n:9d} {cyc:10d} {n / ts:10.0f} {n / tw:10.0f} "
                  f"{n / best:11.0f} {ts / best:9.0f} |      {n / cs:10.0f} {n / cbest:11.0f} {cs / cbest:9.0f} "
                  f"{td:7.2f}")


if __name__ == "__main__":
    main()
