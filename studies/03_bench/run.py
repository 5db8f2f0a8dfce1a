"""Benchmark (make bench): intersect throughput against Embree, render and trace times.

For each SPD scene at its default size, one thread:
  1. finds the fastest grid subdivision for the scene's 512x512 primary rays
     among cubic and shape-following (pbrt-rule) candidates;
  2. measures rays per second of ``Grid.intersect`` on those primary rays and
     on random rays, and, for the triangle scenes (tetra; mount's 8192
     triangles without its 4 spheres), Embree's single-ray ``rtcIntersect1``
     loop (via the embreex package) on the same rays, side by side;
  3. times full 512x512 renders under both rule sets with that grid, and the
     cost of tracing: the untraced render, the tracer alone (every tile traced
     into reused buffers, records not kept) and the whole ``grid.trace``.
Every figure is a best-of-N wall-clock time measured in this one run; the
ratios are the point, since the machine may be shared.  Writes bench.csv to
studies/out/03_bench/ (--quick: scenes at size 2, 32x32, the default grid,
one repeat; the work figures only (visits, bytes per visit), to ref/).

    python studies/03_bench/run.py [--scenes balls,tetra] [--repeat 3] [--quick]
"""
from __future__ import annotations

import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import mprt  # noqa: E402
from _common import best_time, log, random_rays, study_args, write_csv  # noqa: E402
from mprt.grid import render_desc  # noqa: E402
from mprt.trace import RAY_DTYPE, VISIT_DTYPE  # noqa: E402

try:
    import embreex.mesh_construction as _emc
    import embreex.rtcore_scene as _ers
except ImportError:  # optional
    _ers = None

WORK = ("scene", "grid", "rays", "visits", "bytes_per_visit")  # the columns that do not depend on timing


def triangles(scene) -> np.ndarray:
    """The scene's triangles as an (N, 3, 3) array, from the library."""
    p = scene.primitives()["polygons"]
    tri = np.flatnonzero(np.diff(p["vstart"]) == 3)
    return p["vertices"][p["vstart"][tri][:, None] + np.arange(3)]


def triangle_scene(tris):
    """A Scene holding only the given triangles (like-for-like with Embree)."""
    s = mprt.Scene()
    for t in tris:
        s.add_polygon(t)
    return s


def trace_cost(grid, res, repeat):
    """Traced/untraced time, side by side: (untraced, tracer alone, whole grid.trace, visits, rays)."""
    desc = grid.resolve(render_desc(res, res))
    ntiles = grid.tiling(desc)[2] * grid.tiling(desc)[3]
    smp = np.empty(desc["tile"] ** 2 * 3)
    rays = np.empty(1 << 16, dtype=RAY_DTYPE)
    visits = np.empty(1 << 20, dtype=VISIT_DTYPE)

    def c_only():
        total = 0
        for t in range(ntiles):
            nr, nv, fitted = grid.trace_tile(desc, t, smp, rays, visits)
            assert fitted, "bench buffers too small"
            total += nv
        return total

    t_render = t_c = t_py = float("inf")
    for _ in range(repeat):  # interleaved, so load changes hit all three alike
        t0 = time.perf_counter()
        grid.render(res, res)
        t1 = time.perf_counter()
        nvis = c_only()
        t2 = time.perf_counter()
        _, tr = grid.trace(res, res)
        t3 = time.perf_counter()
        t_render, t_c, t_py = min(t_render, t1 - t0), min(t_c, t2 - t1), min(t_py, t3 - t2)
    return t_render, t_c, t_py, nvis, len(tr.rays)


def candidates(scene):
    cands = [(n, n, n) for n in (16, 24, 32, 48, 64, 96, 128)]
    for density in (1, 2, 3, 4, 6, 8, 12):
        g = scene.default_grid(density=density, limit=512)
        if g not in cands:
            cands.append(g)
    return cands


def fastest_grid(scene, o, d, repeat):
    best = None
    for n in candidates(scene):
        t_build, grid = best_time(lambda: scene.grid(n), 1)
        t, _ = best_time(lambda: grid.intersect(o, d), repeat)
        if best is None or t < best[1]:
            best = (n, t, t_build)
    return best


def embree_row(scene, po, pd, ro, rd, repeat) -> dict:
    """mprt on the scene's triangles alone against Embree on the same triangles and rays."""
    tris = triangles(scene)
    tscene = triangle_scene(tris)
    tn, tt_prim, _ = fastest_grid(tscene, po, pd, repeat)
    tgrid = tscene.grid(tn)
    tt_rand, (tt, tp) = best_time(lambda: tgrid.intersect(ro, rd), repeat)
    es = _ers.EmbreeScene()
    _emc.TriangleMesh(es, tris.astype(np.float32))
    po32, pd32, ro32, rd32 = (x.astype(np.float32) for x in (po, pd, ro, rd))
    es.run(po32[:1], pd32[:1])  # commit (BVH build) outside the timing
    te_prim, _ = best_time(lambda: es.run(po32, pd32), repeat)
    te_rand, ep = best_time(lambda: es.run(ro32, rd32), repeat)
    row = {"tri_grid": "x".join(map(str, tn)),
           "tri_primary_Mrays": len(po) / tt_prim / 1e6, "embree_primary_Mrays": len(po) / te_prim / 1e6,
           "tri_random_Mrays": len(ro) / tt_rand / 1e6, "embree_random_Mrays": len(ro) / te_rand / 1e6,
           "hit_agreement": float(np.mean((ep >= 0) == (tp >= 0)))}
    log(f"       triangles only, grid {row['tri_grid']}: primary mprt {row['tri_primary_Mrays']:.2f} vs "
        f"Embree {row['embree_primary_Mrays']:.2f} Mrays/s; random mprt {row['tri_random_Mrays']:.2f} vs Embree "
        f"{row['embree_random_Mrays']:.2f}; hit/miss agreement {row['hit_agreement']:.5f}")
    return row


def bench_scene(name, size, res, nrand, repeat, quick) -> dict:
    scene = mprt.Scene.spd(name, size)
    probe = scene.grid(1)
    po, pd = probe.camera_rays(res, res)
    ro, rd = random_rays(scene, nrand)
    if quick:
        n, t_build = scene.default_grid(), best_time(lambda: scene.grid(scene.default_grid()), 1)[0]
    else:
        n, _, t_build = fastest_grid(scene, po, pd, repeat)
    grid = scene.grid(n)
    t_prim, _ = best_time(lambda: grid.intersect(po, pd), repeat)
    t_rand, _ = best_time(lambda: grid.intersect(ro, rd), repeat)
    row = {"scene": name, "grid": "x".join(map(str, n)), "build_s": t_build,
           "primary_Mrays": len(po) / t_prim / 1e6, "random_Mrays": len(ro) / t_rand / 1e6}
    for rules in ("paper", "spd"):
        row[f"render_{rules}_s"], _ = best_time(lambda: grid.render(res, res, rules=rules), 1)
    t_u, t_c, t_p, nvis, nrays = trace_cost(grid, res, repeat)
    row.update({"rays": nrays, "visits": nvis, "trace_c_ratio": t_c / t_u, "trace_ratio": t_p / t_u,
                "bytes_per_visit": round((nrays * RAY_DTYPE.itemsize + nvis * VISIT_DTYPE.itemsize) / nvis, 2)})
    log(f"{name:6s} grid {row['grid']:>11s} (build {t_build:.2f} s)  intersect: primary {row['primary_Mrays']:.2f} "
        f"Mrays/s, random {row['random_Mrays']:.2f} Mrays/s;  render {res}^2: paper {row['render_paper_s']:.2f} s, "
        f"spd {row['render_spd_s']:.2f} s")
    log(f"       trace {res}^2 (paper): {nvis} visits, {row['bytes_per_visit']:.1f} bytes per visit (rays included); "
        f"traced/untraced time: tracer alone {row['trace_c_ratio']:.2f}, whole grid.trace {row['trace_ratio']:.2f}")
    if _ers is not None and not quick and name in ("tetra", "mount"):
        row.update(embree_row(scene, po, pd, ro, rd, repeat))
    return row


def options(ap):
    ap.add_argument("--scenes", default=",".join(mprt.SPD_SCENES))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--random", type=int, default=262144, help="random rays per scene")


def main(argv=None) -> int:
    a, out = study_args(__file__, __doc__.splitlines()[0],
                        "scenes at size 2, 32x32, default grid, one repeat, work figures only", argv, options)
    size, res, repeat, nrand = (2, 32, 1, 2000) if a.quick else (None, 512, a.repeat, a.random)
    log(f"mprt {mprt.__version__}; one thread; best of {repeat}; Embree: "
        + ("embreex" if _ers else "not installed (pip install embreex)"))
    rows = [bench_scene(name, size, res, nrand, repeat, a.quick) for name in a.scenes.split(",")]
    if a.quick:  # timings are not reproducible: the reference keeps the work figures
        rows = [{k: r[k] for k in WORK} for r in rows]
    write_csv(os.path.join(out, "bench.csv"), rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
