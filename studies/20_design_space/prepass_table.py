"""The prepass against full-resolution truth and against the fixed rules.

For each scene: the prepass's choice and its cost; then full-resolution
traces over a ladder of subdivisions (plus every rule's pick) replayed at
level 0 on the paper's 3MPPE give the true best; printed per scene: the
prepass's choice, the true best, the regret (time of the choice over the
best's, minus one), the prepass's seconds as a share of tracing the full
frame once plus replaying it (level 0 and, for the SimPy model, an estimate
at the issue-7 target of 100,000 visits/s), and the regret of each fixed
rule: pbrt's 3 N^(1/3), our density 8, and the paper's best of 20/50/100
per axis.

    .venv/bin/python studies/20_design_space/prepass_table.py [RES] [FRACTION ...]
Writes studies/out/prepass_RES.csv and prints a Markdown table.
"""
import csv
import sys
import time
from pathlib import Path

import numpy as np

import mprt
from mprt.explore import paper_3mppe
from mprt.explore.distributed import DiskCache, cache_key
from mprt.explore.evaluate import Level0, grid_dims
from mprt.explore.prepass import default_range, fixed_rule, prepass

HERE = Path(__file__).resolve().parent
OUT = HERE.parents[1] / "studies" / "out"
SIMPY_VISITS_PER_S = 1e5
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


def main(res=512, *fractions):
    fractions = fractions or (8, 16, 32)
    OUT.mkdir(parents=True, exist_ok=True)
    design = paper_3mppe()
    rows = []
    for name, scene in scenes():
        truth, cost = {}, {}

        h = scene.content_hash()

        def full(dims):
            dims = tuple(dims)
            if dims not in truth:
                key = cache_key("prepass-truth", h, dims, res, design.to_dict())
                hit = CACHE.get(key)
                if hit is None:
                    t = time.perf_counter()
                    _, tr = scene.grid(dims).trace(res, res, threads=2)
                    t1 = time.perf_counter()
                    hit = [Level0(tr, linear=False).run(design).cycles, t1 - t, time.perf_counter() - t1,
                           len(tr.visits)]
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
        for fr in fractions:
            t0 = time.perf_counter()
            pre = prepass(scene, res, res, fraction=fr, threads=2)
            pres[fr] = (pre, time.perf_counter() - t0)
            full(tuple(pre["subdivision"]))
        rules = {"pbrt": fixed_rule(scene, "pbrt"), "density8": fixed_rule(scene, "density8")}
        for r in rules.values():
            full(r)
        paper = min(((n, n, n) for n in (20, 50, 100)), key=full)
        rules["paper-best"] = paper
        # the true best: the ladder, the picks, and a local refinement around the best rung at full resolution
        best = min(truth, key=truth.get)
        for k in (-2, -1, 1, 2):
            n = max(max(best) + k * max(1, max(best) // 20), 1)
            full(grid_dims(scene, (n,), "proportional"))
        best = min(truth, key=truth.get)
        tr_s, rp_s, visits = cost[best]
        frame = tr_s + rp_s
        frame_simpy = tr_s + visits / SIMPY_VISITS_PER_S
        row = {"scene": name, "best": "x".join(map(str, best)), "frame_s_level0": frame,
               "frame_s_simpy_est": frame_simpy}
        for fr, (pre, pre_s) in pres.items():
            choice = tuple(pre["subdivision"])
            row.update({f"choice_{fr}": "x".join(map(str, choice)), f"regret_{fr}": truth[choice] / truth[best] - 1,
                        f"prepass_s_{fr}": pre_s, f"candidates_{fr}": len(pre["candidates"]),
                        f"share_level0_{fr}": pre_s / frame, f"share_simpy_est_{fr}": pre_s / frame_simpy})
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
    print(f"{res}x{res}, level 0, paper 3MPPE.  Per fraction F: choice, regret, prepass seconds, share of "
          f"(trace + level-0 replay) and of (trace + SimPy replay at 1e5 visits/s, estimated)")
    head = "| scene | best | " + " | ".join(f"1/{fr}: choice, regret, s, share L0, share SimPy" for fr in fractions)
    print(head + " | pbrt 3N^1/3 | density 8 | paper 20/50/100 |")
    print("|---" * (2 + len(fractions) + 3) + "|")
    for r in rows:
        cells = [f"{r[f'choice_{fr}']}, {r[f'regret_{fr}']:.1%}, {r[f'prepass_s_{fr}']:.2f} s, "
                 f"{r[f'share_level0_{fr}']:.1%}, {r[f'share_simpy_est_{fr}']:.2%}" for fr in fractions]
        print(f"| {r['scene']} | {r['best']} | " + " | ".join(cells)
              + f" | {r['pbrt']} ({r['pbrt_regret']:+.0%}) | {r['density8']} ({r['density8_regret']:+.0%}) "
              f"| {r['paper-best']} ({r['paper-best_regret']:+.0%}) |")
    print(f"wrote {path}")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:]))
