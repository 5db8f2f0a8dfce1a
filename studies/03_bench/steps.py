"""What each step of issue 21's tests several at a time gives Grid.intersect, and Embree beside it.

In one process, grids of the same scene made under each setting of the environment (c/src/ic_pack.h),
timed interleaved (best of N process CPU times, one thread), with Embree's rtcIntersect1 loop on
the same rays (embreex; triangles for tetra and mount, a tessellation for the rest, as run.py):
  one      MPRT_IC_PACK=0: one primitive at a time (the walk before the issue);
  records  MPRT_IC_BLOCKS=0: triangles four at a time from IC's records (gathered, transposed),
           spheres, cylinders and cones through the ball filter four at a time;
  blocks   the default: the same, with each voxel's triangles in blocks where they fit 4 MiB.
Every setting's hits, distances and counters are checked equal first.

    python studies/03_bench/steps.py tetra:24x24x24:primary mount:20x20x16:random tree:512x512x20:primary
"""
from __future__ import annotations

import os
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import run as bench  # noqa: E402

MODES = {"one": {"MPRT_IC_PACK": "0"}, "records": {"MPRT_IC_BLOCKS": "0"}, "blocks": {}}
VARIABLES = ("MPRT_IC_PACK", "MPRT_IC_SIMD", "MPRT_IC_BLOCKS")


def step(name, n, which, repeat):
    tris = name in ("tetra", "mount")
    scene = bench.scene_of(name, None, tris)
    grids = {}
    for label, env in MODES.items():
        for v in VARIABLES:
            os.environ.pop(v, None)
        os.environ.update(env)
        grids[label] = scene.grid(n)
    for v in VARIABLES:
        os.environ.pop(v, None)
    o, d = bench.rays_of(name, None, which)
    ref = grids["one"].intersect(o, d, return_counters=True)
    for label, g in grids.items():
        t, p, c = g.intersect(o, d, return_counters=True)
        assert np.array_equal(t, ref[0]) and np.array_equal(p, ref[1]) and c == ref[2], label
    best = {label: 1e9 for label in grids}
    if bench._ers is not None:
        tri = bench.triangles(bench.scene_of(name, None)) if tris else bench.tessellation(bench.scene_of(name, None))
        es = bench._ers.EmbreeScene()
        bench._emc.TriangleMesh(es, tri.astype(np.float32))
        of, df = o.astype(np.float32), d.astype(np.float32)
        es.run(of[:1], df[:1])
        best["embree"] = 1e9
    for _ in range(repeat):
        for label, g in grids.items():
            best[label] = min(best[label], bench.cpu_clock(lambda: g.intersect(o, d))[0])
        if "embree" in best:
            best["embree"] = min(best["embree"], bench.cpu_clock(lambda: es.run(of, df))[0])
    k = len(o)
    row = {"scene": name, "grid": "x".join(map(str, n)), "rays": which}
    row.update({f"{label}_ns": round(t / k * 1e9, 1) for label, t in best.items()})
    row["records_vs_one"] = round(best["one"] / best["records"], 3)
    row["blocks_vs_one"] = round(best["one"] / best["blocks"], 3)
    if "embree" in best:
        row.update({f"{label}_vs_embree": round(best["embree"] / best[label], 3) for label in grids})
    return row


def main(argv=None) -> int:
    args = sys.argv[1:] if argv is None else argv
    repeat = 5
    if args and args[0].startswith("--repeat="):
        repeat = int(args.pop(0).split("=")[1])
    rows = []
    for spec in args:
        name, n, which = spec.split(":")
        rows.append(step(name, tuple(int(x) for x in n.split("x")), which, repeat))
        print(" ".join(f"{k}={v}" for k, v in rows[-1].items()), flush=True)
    print(bench.md_rows(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
