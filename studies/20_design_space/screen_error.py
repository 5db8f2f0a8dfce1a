"""How well the search's low-resolution replay ranks the full-resolution polish's designs
(the margin of ``explore.refine.SCREEN_MARGIN``): for each SPD scene, the best design any
512x512 run found (explore README) and its lattice neighbourhood as the full-resolution
polish sees it (single steps and trades under 800 kGE), each replayed at level 3 on the
search's 64x64 trace and on the 512x512 sample (stratified:16:1); the screen predicts a
neighbour's full-resolution cycles as its 64x64 cycles times the start's ratio.  Prints per
scene the neighbours, the error of that prediction (full over predicted, less one: the
worst below zero is the margin needed), and how many neighbours a margin would screen out
(their prediction less the margin slower than the start) against how many level-1 bounds
(less 10%) rule out.

    .venv/bin/python studies/20_design_space/screen_error.py [SCENE ...]
"""
import sys
import time

import numpy as np

import mprt
from mprt.explore.evaluate import DEADLOCK_CYCLES, SceneEvaluator
from mprt.explore.hwcost import UnitCosts, hardware_cost
from mprt.explore.problem import Problem
from mprt.explore.search import _neighbours
from mprt.explore.space import default_space

ANSWERS = {     # the best designs of the README's tables (subdivision n, design)
    "balls": (256, dict(mapping="OS+IC+SC", os=(2, 2, 3), cache=(4, 4), pes=2)),
    "gears": (256, dict(mapping="OS+IC+SC", os=(2, 2, 2), cache=(4, 0), pes=3)),
    "mount": (64, dict(mapping="OS+IC+SC", os=(2, 2, 3), cache=(4, 4), pes=2)),
    "rings": (96, dict(mapping="OS+IC+SC", os=(2, 3, 3), cache=(4, 4), pes=2)),
    "tetra": (48, dict(mapping="OS|IC+SC", os=(3, 2, 3), ic=(3, 2, 3), feed="shortest-queue", fifo=16,
                       cache=(4, 0), pes=1)),
    "tree": (256, dict(mapping="OS+IC+SC", os=(2, 3, 3), cache=(4, 4), pes=2)),
}


def index(space, n, a):
    want = {"subdivision.n": n, "mapping": a["mapping"], "replication.OS": a["os"][0], "units.OS.int": a["os"][1],
            "units.OS.fp": a["os"][2], "cache.IC": a["cache"][0], "cache.SC": a["cache"][1], "pes": a["pes"],
            "fifo": a.get("fifo", 16), "replication.feed": a.get("feed", "shared")}
    if "ic" in a:
        want.update({"replication.IC": a["ic"][0], "units.IC.int": a["ic"][1], "units.IC.fp": a["ic"][2]})
    return space.canonical([v.values.index(want[v.name]) if v.name in want else 0 for v in space.variables])


def main(*names):
    print("| scene | neighbours | live | worst error below | worst above | median abs | screened 5% | 10% | 15% "
          "| level-1 ruled out | seconds |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for name in names or ANSWERS:
        t0 = time.perf_counter()
        scene = mprt.Scene.spd(name)
        n, a = ANSWERS[name]
        space = default_space().with_subdivision((n,))
        uc = UnitCosts.from_table(space.cost)
        cost_of = lambda p: hardware_cost(p.design, uc)  # noqa: E731
        pb = Problem(space, None, "time", 800.0, cost_of=cost_of)
        start = index(space, n, a)
        keys = [start] + [k for k in dict.fromkeys(_neighbours(pb, start, False) + _neighbours(pb, start, True))
                          if k != start and not pb.over_budget(k)]
        pts = [space.point(k) for k in keys]
        low = SceneEvaluator(scene, 64, 64, level=3, shape=space.shape, unit_costs=uc, threads=2)
        full = SceneEvaluator(scene, 512, 512, level=3, shape=space.shape, unit_costs=uc, threads=2,
                              sample="stratified:16:1")
        lo = np.array([low.run(p).cycles for p in pts])
        fu = np.array([full.run(p).cycles for p in pts])
        l1 = np.array([full.run(p, 1).cycles for p in pts])
        live = (lo < DEADLOCK_CYCLES) & (fu < DEADLOCK_CYCLES)
        ratio = fu[0] / lo[0]
        err = fu[live] / (lo[live] * ratio) - 1
        inc = fu[0]
        screened = {m: int(np.sum((lo * ratio * (1 - m) > inc) & (lo < DEADLOCK_CYCLES))) for m in (0.05, 0.10, 0.15)}
        wrong = {m: int(np.sum((lo * ratio * (1 - m) > inc) & (lo < DEADLOCK_CYCLES) & (fu < inc)))
                 for m in (0.05, 0.10, 0.15)}
        ruled = int(np.sum((l1 < DEADLOCK_CYCLES) & (np.floor(l1 * 0.9) > inc)))
        print(f"| {name} | {len(pts) - 1} | {int(live.sum()) - 1} | {100 * err.min():+.1f}% | {100 * err.max():+.1f}% "
              f"| {100 * np.median(np.abs(err)):.1f}% | {screened[0.05]} ({wrong[0.05]} wrong) "
              f"| {screened[0.10]} ({wrong[0.10]} wrong) | {screened[0.15]} ({wrong[0.15]} wrong) | {ruled} "
              f"| {time.perf_counter() - t0:.0f} |", flush=True)


if __name__ == "__main__":
    main(*sys.argv[1:])
