"""The prepass against full-resolution truth and against the fixed rules.

For each scene: the prepass's choice and its cost (searched at 1/16 of the
resolution, then with and without checking its three best predictions on a
sixty-fourth of the full-resolution tiles, and with the parabola step in
place of the golden section); then full-resolution traces over a
ladder of subdivisions (plus every pick and rule) replayed at level 1 (the
compiled exact replay of the machine model's 3MPPE without ring and memories)
give the true best; printed per scene: the choice, the true best, the regret
(time of the choice over the best's, minus one), the prepass's seconds as a
share of one full frame at the best subdivision (its grid built, traced on 2
threads and replayed, timed in the same run as the prepass) at the level the fidelity ladder
chooses for the 3MPPE on this scene at 1% (measured on a sixteenth of the best
frame's tiles: level 1 is the compiled replay's measured time, level 2 or 3
the SimPy model's measured visits per second on that sample times the frame's
visits), and the regret of each fixed rule: pbrt's 3 N^(1/3), our density 8,
and the paper's best of 20/50/100 per axis.

    .venv/bin/python studies/20_design_space/prepass_table.py [RES]
Writes studies/out/prepass_RES.csv and prints a Markdown table.
"""
import csv
import sys
import time
from pathlib import Path

import numpy as np

import mprt
from mprt.explore.distributed import DiskCache, cache_key
from mprt.explore.evaluate import TraceEvaluator, grid_dims
from mprt.explore.prepass import default_range, fixed_rule, prepass
from mprt.fidelity import Evaluator, measure, trace_sample
from mprt.machine.config import builtin

HERE = Path(__file__).resolve().parent
OUT = HERE.parents[1] / "studies" / "out"
# (fraction, candidates checked at full resolution, refinement of the bracket)
VARIANTS = ((16, 0, "golden"), (16, 3, "golden"), (16, 0, "parabola"))
CACHE = DiskCache(OUT / "prepass_truth")     # full-resolution truths (and their timings) are kept between runs


def stadium_nff() -> str:
    """A scene of another character: a wide floor and a few big spheres, with
    a dense cluster of 2000 tiny spheres in one corner (a 'teapot in a
    stadium': a uniform grid fits it badly)."""
    rng = np.random.default_rng(12345)
    lines = ["v", "from 0 -30 12", "at 0 0 0", "up 0 0 1", "angle 40", "hither 0.01", "resolution 512 512",
             "b 0.1 0.1 0.2", "l 20 -20 40", "l -30 -10 30", "f 0.8 0.8 0.7 0.7 0.3 20 0 1",
             "p 4", "-40 -40 0", "40 -40 0", "40 40 0", "-40 40 0",
             "f 0.6 0.2 0.2 0.6 0.4 30 0 1"]
    for x, y, r in ((-12, 5, 4), (10, 8, 5), (0, 18, 6)):
        lines.append(f"s {x} {y} {r} {r}")
    lines.append("f 0.2 0.5 0.8 0.8 0.2 10 0 1")
    c = rng.uniform(-1, 1, size=(2000, 3)) * [1.5, 1.5, 1.5] + [6, -6, 2]
    for x, y, z in c:
        lines.append(f"s {x:.5f} {y:.5f} {z:.5f} 0.06")
    return "\n".join(lines) + "\n"


def scenes():
    for name in mprt.SPD_SCENES:
        yield name, mprt.Scene.spd(name)
    yield "stadium (NFF)", mprt.Scene.from_text(stadium_nff(), "stadium")


def frame_cost(scene, dims, res, trace_s, l1_s, visits):
    """Seconds of one full frame traced and replayed at the ladder's level for the 3MPPE (1%),
    measured on a sixteenth of the frame's tiles."""
    cfg = builtin("3mppe")
    st = trace_sample(scene.grid(tuple(dims)), "stratified:16:1", res, res, threads=2)
    table = measure(st.trace, [cfg], levels=(1, 2, 3), sample=None)
    level = table.choose(0.01)
    if level <= 1:
        return level, trace_s + l1_s, None
    ev = Evaluator(st.trace)
    ev.costed(cfg)                                  # costing is part of the replay below as well
    t = time.perf_counter()
    ev.evaluate(cfg, level)
    rate = len(st.trace.visits) / (time.perf_counter() - t)
    return level, trace_s + visits / rate, rate


def main(res=512):
    OUT.mkdir(parents=True, exist_ok=True)
    machine = builtin("3mppe")
    rows = []
    for name, scene in scenes():
        truth, cost = {}, {}

        h = scene.content_hash()

        def full(dims):
            dims = tuple(dims)
            if dims not in truth:
                key = cache_key("prepass-truth-level1", h, dims, res, "3mppe")
                hit = CACHE.get(key)
                if hit is None:
                    t = time.perf_counter()
                    _, tr = scene.grid(dims).trace(res, res, threads=2)
                    t1 = time.perf_counter()
                    hit = [TraceEvaluator(tr, counted=False).run_config(machine, 1).cycles, t1 - t,
                           time.perf_counter() - t1, len(tr.visits)]
                    del tr
                    CACHE.put(key, hit)
                truth[dims] = hit[0]
                cost[dims] = tuple(hit[1:])
            return truth[dims]

        lo, hi = default_range(scene, density=(1.0, 24.0), limit=512)
        ladder = sorted({grid_dims(scene, (int(round(n)),), "proportional") for n in np.geomspace(lo, hi, 10)})
        for d in ladder:
            full(d)
        pres = {}
        for fr, check, refine in VARIANTS:
            t0 = time.perf_counter()
            pre = prepass(scene, res, res, fraction=fr, threads=2, check=check, refine=refine)
            pres[fr, check, refine] = (pre, time.perf_counter() - t0)
            for c in pre["candidates"]:
                if "sampled_cycles" in c:
                    full(tuple(c["subdivision"]))
            full(tuple(pre["subdivision"]))
        rules = {"pbrt": fixed_rule(scene, "pbrt"), "density8": fixed_rule(scene, "density8")}
        for r in rules.values():
            full(r)
        paper = min(((n, n, n) for n in (20, 50, 100)), key=full)
        rules["paper-best"] = paper
        # the true best: the ladder, the picks, and a local refinement around the best at full resolution
        best = min(truth, key=truth.get)
        for k in (-2, -1, 1, 2):
            n = max(max(best) + k * max(1, max(best) // 20), 1)
            full(grid_dims(scene, (n,), "proportional"))
        best = min(truth, key=truth.get)
        # the frame's seconds measured now, beside the prepass runs above (the cache's are from other runs)
        t = time.perf_counter()
        _, tr = scene.grid(best).trace(res, res, threads=2)
        t1 = time.perf_counter()
        TraceEvaluator(tr, counted=False).run_config(machine, 1)
        tr_s, rp_s, visits = t1 - t, time.perf_counter() - t1, len(tr.visits)
        del tr
        level, frame, rate = frame_cost(scene, best, res, tr_s, rp_s, visits)
        row = {"scene": name, "best": "x".join(map(str, best)), "frame_level": level, "frame_s": frame,
               "frame_s_level1": tr_s + rp_s, "simpy_visits_per_s": rate, "visits": visits}
        for (fr, check, refine), (pre, pre_s) in pres.items():
            choice = tuple(pre["subdivision"])
            k = f"{fr}_{check}_{refine}"
            row.update({f"choice_{k}": "x".join(map(str, choice)), f"regret_{k}": truth[choice] / truth[best] - 1,
                        f"prepass_s_{k}": pre_s, f"candidates_{k}": len(pre["candidates"]),
                        f"share_{k}": pre_s / frame, f"share_level1_{k}": pre_s / (tr_s + rp_s)})
        for k, d in rules.items():
            row[f"{k}"] = "x".join(map(str, d))
            row[f"{k}_regret"] = truth[tuple(d)] / truth[best] - 1
        rows.append(row)
        print(f"{name}: {row}", file=sys.stderr, flush=True)
    path = OUT / f"prepass_{res}.csv"
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"{res}x{res}, the machine model's 3MPPE, truth at level 1.  Per variant (1/F of the resolution, K best "
          f"checked at full resolution on 1/64 of the tiles): choice, regret, prepass seconds, share of one frame "
          f"traced and replayed at the ladder's level (and at level 1)")
    head = "| scene | best | frame (level, s) | " + " | ".join(f"1/{fr}, K={c}, {rf}: choice, regret, s, share"
                                                                 for fr, c, rf in VARIANTS)
    print(head + " | pbrt 3N^1/3 | density 8 | paper 20/50/100 |")
    print("|---" * (3 + len(VARIANTS) + 3) + "|")
    for r in rows:
        cells = [f"{r[f'choice_{k}']}, {r[f'regret_{k}']:.1%}, {r[f'prepass_s_{k}']:.2f} s, {r[f'share_{k}']:.2%} "
                 f"({r[f'share_level1_{k}']:.0%})" for k in (f"{fr}_{c}_{rf}" for fr, c, rf in VARIANTS)]
        print(f"| {r['scene']} | {r['best']} | {r['frame_level']}, {r['frame_s']:.0f} s | " + " | ".join(cells)
              + f" | {r['pbrt']} ({r['pbrt_regret']:+.0%}) | {r['density8']} ({r['density8_regret']:+.0%}) "
              f"| {r['paper-best']} ({r['paper-best_regret']:+.0%}) |")
    print(f"wrote {path}")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:]))
