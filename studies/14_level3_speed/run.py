"""Level 3 (memories on the ideal network) in the compiled replay against SimPy, side by side.

For each trace: the 3MPPE's memories with the ring taken out, and the same machine with small
memories (so the golden scenes miss), on --pes PEs: SimPy's simulate(), the compiled replay's
whole replay() (load, memory data, run, result) and, once loaded, one design's run
(Compiled.cycles, best of --repeat), in visits per second of wall time and of CPU time
(process time: what a loaded shared machine does not take away); the cycles must agree.

    python studies/14_level3_speed/run.py [--trace T.npz ...] [--pes 2] [--repeat 5]
                                          [--simpy-max N] [--only 3mppe-ideal-net|3mppe-small]
    python studies/14_level3_speed/run.py --quick     # balls-g9 (golden): work figures to ref/

Writes level3_speed.csv to studies/out/14_level3_speed/; --quick writes only the figures that do
not depend on timing (visits, cycles, memory figures) and checks.
"""
from __future__ import annotations

import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import mprt  # noqa: E402
from _common import log, study_args, write_checks, write_table  # noqa: E402
from mprt.cost import CostModel  # noqa: E402
from mprt.fidelity import Compiled, replay  # noqa: E402
from mprt.fidelity.memdata import MemoryData  # noqa: E402
from mprt.machine import builtin, simulate  # noqa: E402
from mprt.machine.config import CacheConfig, LocalMemoryConfig  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
GOLDEN = os.path.join(ROOT, "tests", "data", "golden", "balls-g9.npz")


def configs(pes):
    three = builtin("3mppe").replace(ring=None, pes=pes)
    small = three.replace(name="3mppe-small", ic_memory=LocalMemoryConfig(64, CacheConfig(256, 16, 2)),
                          sc_memory=LocalMemoryConfig(0, CacheConfig(128, 32, 2)))
    return [three.replace(name="3mppe-ideal-net"), small]


def timed(fn):
    t0, c0 = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - t0, time.process_time() - c0


def main(argv=None) -> int:
    def extra(ap):
        ap.add_argument("--trace", action="append", default=None, help="trace file (repeatable; default balls-g9)")
        ap.add_argument("--pes", type=int, default=2)
        ap.add_argument("--repeat", type=int, default=5)
        ap.add_argument("--simpy-max", type=int, default=50_000_000, help="skip SimPy above this many visits")
        ap.add_argument("--only", help="only the configuration of this name")

    a, out = study_args(__file__, "level 3 in the compiled replay against SimPy", "balls-g9, 2 PEs", argv, extra)
    cm = CostModel.default()
    rows, work, checks = [], [], {"compiled = SimPy on every configuration": True,
                                  "the small memories miss and stall": False}
    for path in a.trace or [GOLDEN]:
        t = mprt.load_trace(path)
        n = len(t.visits)
        md = MemoryData(t)
        for cfg in configs(a.pes):
            if a.only and cfg.name != a.only:
                continue
            vc = cm.visit_costs(t, cfg.processors())
            ref, ts, cs = timed(lambda: simulate(t, cfg, costs=vc)) if n <= a.simpy_max else (None, 0.0, 0.0)
            whole, tw, _ = timed(lambda: replay(t, cfg, costs=vc))
            c = Compiled(t, vc, memory=md)
            _, td, _ = timed(lambda: c.cycles(cfg))      # memory data made (kept in md) and handed over
            best = cbest = float("inf")
            for _ in range(1 if a.quick else a.repeat):
                cyc, w, p = timed(lambda: c.cycles(cfg))
                best, cbest = min(best, w), min(cbest, p)
            checks["compiled = SimPy on every configuration"] &= cyc == whole.cycles and (
                ref is None or (ref.cycles == cyc and ref.to_dict()["memory"] == whole.to_dict()["memory"]))
            if cfg.name == "3mppe-small":
                checks["the small memories miss and stall"] = whole.stages["IC"]["memory_stall"] > 0
            w = {"trace": os.path.basename(path), "config": cfg.name, "pes": a.pes, "visits": n, "cycles": cyc,
                 "ic_stall": whole.stages["IC"]["memory_stall"], "sc_stall": whole.stages["SC"]["memory_stall"],
                 "icgm_reads": whole.memory["icgm"]["accesses"]}
            work.append(w)
            rows.append({**w, "simpy_visits_per_s": n / ts if ts else None, "whole_visits_per_s": n / tw,
                         "run_visits_per_s": n / best, "run_over_simpy": ts / best if ts else None,
                         "simpy_cpu_visits_per_s": n / cs if cs else None, "run_cpu_visits_per_s": n / cbest,
                         "run_over_simpy_cpu": cs / cbest if cs else None, "first_run_with_data_s": td})
            r = rows[-1]
            log(f"{w['trace']} {cfg.name}: {n:,} visits, {cyc:,} cycles; SimPy {r['simpy_visits_per_s'] or 0:,.0f} "
                f"visits/s, whole replay {r['whole_visits_per_s']:,.0f}, one design's run {r['run_visits_per_s']:,.0f} "
                f"({r['run_over_simpy'] or 0:.0f}x); CPU: SimPy {r['simpy_cpu_visits_per_s'] or 0:,.0f}, run "
                f"{r['run_cpu_visits_per_s']:,.0f} ({r['run_over_simpy_cpu'] or 0:.0f}x)")
    write_table(out, "level3.csv" if a.quick else "level3_speed.csv", work if a.quick else rows)
    write_checks(os.path.join(out, "checks.csv"), checks)
    return 0 if all(checks.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
