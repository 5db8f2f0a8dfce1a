"""Grid.intersect against Embree's rtcIntersect1 on one thread and on two, this build and another.

For tetra and mount (their triangles alone) and tree (the whole scene against Embree on a
tessellation, as run.py compares them), on the scene's 512x512 eye rays (and, for the triangle
scenes, 262,144 random rays), at the grid given (default: the fastest for eye rays that run.py picked for this build, read
from its bench.csv where it ran before, else GRIDS, its picks before issue 21):
  - one thread: best of N process CPU times of one call over all the rays, in worker processes,
    interleaved: this build, the build in --before, Embree;
  - two threads: the rays split in two halves, each traced by a worker process of its own at the
    same time (both requests sent before either answer is read); the pair's time is the two
    workers' process CPU times added (what the rays cost with two cores busy, sharing caches and
    memory; on a shared machine wall-clock times measure the other users' load); best of N.
    Processes, not threads: embreex holds the GIL in its loop, so two Python threads would not
    run two Embree loops at once.
Prints one line per (scene, rays) and writes embree.csv to studies/out/03_bench/.

    python studies/03_bench/embree.py [--before DIR] [--repeat 5] [--scenes tetra,mount,tree]
                                      [--grids tetra=24x24x24,mount=40x40x33,tree=512x512x20]
"""
from __future__ import annotations

import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import run as bench  # noqa: E402
from _common import log, md_rows, study_args, write_csv  # noqa: E402

TRIS = ("tetra", "mount")
GRIDS = {"tetra": (24, 24, 24), "mount": (40, 40, 33), "tree": (512, 512, 20)}
HERE = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "python")


def _part(a, part, parts):
    k = len(a)
    return a[part * k // parts:(part + 1) * k // parts]


def m_mprt(name, n, which, part, parts):
    """(wall-clock, process CPU) seconds of one Grid.intersect over part `part` of `parts` of the rays."""
    g = bench.grid_of(name, None, tuple(n), name in TRIS)
    o, d = (_part(x, part, parts) for x in bench.rays_of(name, None, which))
    w, c = time.perf_counter(), time.process_time()
    g.intersect(o, d)
    return time.perf_counter() - w, time.process_time() - c


_embree: dict = {}


def m_embree(name, which, part, parts):
    """The same for Embree's single-ray loop (embreex) on the same rays, the BVH built beforehand."""
    key = (name, which, part, parts)
    if key not in _embree:
        scene = bench.scene_of(name, None)
        tris = bench.triangles(scene) if name in TRIS else bench.tessellation(scene)
        es = bench._ers.EmbreeScene()
        bench._emc.TriangleMesh(es, tris.astype(np.float32))
        o, d = (_part(x, part, parts).astype(np.float32) for x in bench.rays_of(name, None, which))
        es.run(o[:1], d[:1])
        _embree[key] = es, o, d
    es, o, d = _embree[key]
    w, c = time.perf_counter(), time.process_time()
    es.run(o, d)
    return time.perf_counter() - w, time.process_time() - c


MEASURES = {"m_mprt": m_mprt, "m_embree": m_embree, "t_version": bench.t_version}


def together(workers, name, args_of):
    """Send one request to each worker, then read the answers: the workers run at the same time."""
    for i, w in enumerate(workers):
        w.proc.stdin.write(bench.json.dumps([name, list(args_of(i))]) + "\n")
        w.proc.stdin.flush()
    return [bench.json.loads(w.proc.stdout.readline()) for w in workers]


def options(ap):
    ap.add_argument("--scenes", default="tetra,mount,tree")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--before", default=None, help="python folder of another mprt build to compare with")
    ap.add_argument("--grids", default="", help="scene=NXxNYxNZ,... (default: " +
                    ",".join(f"{k}={'x'.join(map(str, v))}" for k, v in GRIDS.items()) + ")")
    ap.add_argument("--serve", action="store_true")


def main(argv=None) -> int:
    if "--serve" in (sys.argv[1:] if argv is None else argv):
        return bench.serve(MEASURES)
    a, out = study_args(__file__, __doc__.splitlines()[0], "(no quick mode)", argv, options)
    if bench._ers is None:
        log("embreex is not installed (make bench installs it): nothing to compare")
        return 1
    grids = dict(GRIDS)
    picked = os.path.join(out, "bench.csv")  # run.py's fastest grids, where it ran before
    if os.path.exists(picked):
        import csv
        for r in csv.DictReader(open(picked)):
            g = r.get("tri_grid") or r.get("grid") if r["scene"] in TRIS else r.get("grid")
            if g:
                grids[r["scene"]] = tuple(int(x) for x in g.split("x"))
    for item in filter(None, a.grids.split(",")):
        k, v = item.split("=")
        grids[k] = tuple(int(x) for x in v.split("x"))
    builds = {"after": [bench.Before(HERE, __file__) for _ in range(2)]}
    if a.before:
        builds["before"] = [bench.Before(a.before, __file__) for _ in range(2)]
    log("builds: " + "; ".join(f"{k}: {w[0].version}" for k, w in builds.items()) + f"; best of {a.repeat}")
    rows = []
    try:
        for name in a.scenes.split(","):
            n = list(grids[name])
            for which in (("primary", "random") if name in TRIS else ("primary",)):
                k = len(bench.rays_of(name, None, which)[0])
                best: dict = {}
                for ws in builds.values():  # grids built, rays made, pages touched: outside the timings
                    ws[0]("m_mprt", name, n, which, 0, 1)
                    together(ws, "m_mprt", lambda i: (name, n, which, i, 2))
                ws = builds["after"]
                ws[0]("m_embree", name, which, 0, 1)
                together(ws, "m_embree", lambda i: (name, which, i, 2))
                for _ in range(a.repeat):
                    for label, ws in builds.items():
                        t1 = ws[0]("m_mprt", name, n, which, 0, 1)[1]
                        t2 = sum(r[1] for r in together(ws, "m_mprt", lambda i: (name, n, which, i, 2)))
                        best[label] = [min(x, y) for x, y in zip(best.get(label, [1e9, 1e9]), (t1, t2))]
                    ws = builds["after"]
                    t1 = ws[0]("m_embree", name, which, 0, 1)[1]
                    t2 = sum(r[1] for r in together(ws, "m_embree", lambda i: (name, which, i, 2)))
                    best["embree"] = [min(x, y) for x, y in zip(best.get("embree", [1e9, 1e9]), (t1, t2))]
                row = {"scene": name, "rays": which, "grid": "x".join(map(str, n))}
                for th in (1, 2):
                    for label, t in best.items():
                        row[f"{label}_{th}t_ns"] = t[th - 1] / k * 1e9  # CPU (thread) time per ray
                    for label in builds:
                        row[f"{label}_{th}t_vs_embree"] = best["embree"][th - 1] / best[label][th - 1]
                    if "before" in builds:
                        row[f"speedup_{th}t"] = best["before"][th - 1] / best["after"][th - 1]
                log(" ".join(f"{k}={round(v, 3) if isinstance(v, float) else v}" for k, v in row.items()))
                rows.append(row)
    finally:
        for ws in builds.values():
            for w in ws:
                w.close()
    write_csv(os.path.join(out, "embree.csv"), rows)
    log(md_rows([{k: (round(v, 3) if isinstance(v, float) else v) for k, v in r.items()} for r in rows]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
