"""Benchmark (make bench): intersect throughput against Embree, render and trace times, before and after.

For each SPD scene at its default size:
  1. finds the fastest grid subdivision for the scene's 512x512 primary rays
     among cubic and shape-following (pbrt-rule) candidates;
  2. measures rays per second of ``Grid.intersect`` on those primary rays and
     on random rays (each build as it walks by default), and the gain of
     empty-space jumps (MPRT_SKIP=1 against MPRT_NO_SKIP=1) there, on a fine
     256^3 grid and on the render,
     and, for the triangle scenes (tetra; mount's 8192 triangles without its
     4 spheres), Embree's single-ray ``rtcIntersect1`` loop (the embreex
     package) on the same rays, side by side; for the scenes of spheres and
     cones (tree, balls, rings), the whole scene against Embree on a
     tessellation of it (spheres as 80 triangles, cones as 32), primary rays;
  3. times 512x512 renders under both rule sets, on 1 and on 2 threads, and
     the cost of tracing: the untraced render, the tracer alone (every tile
     traced into reused buffers, records not kept) and the whole
     ``grid.trace``.
With --before DIR (a ``python`` folder holding another build of the mprt
package, e.g. main's: ``make bench`` builds one), every timing is also made
with that build in a worker process, interleaved with this one's, so each
before/after figure is a ratio measured in one run.  One-thread figures are
process CPU times, two-thread ones wall-clock times; each is the best of N.
Writes bench.csv to studies/out/03_bench/ (--quick: scenes at size 2, 32x32,
the default grid, one repeat; the work figures only (visits, bytes per
visit), to ref/).

    python studies/03_bench/run.py [--scenes balls,tetra] [--repeat 3] [--before DIR] [--quick]
"""
from __future__ import annotations

import argparse
import contextlib
import json
import os
import subprocess
import sys
import time

# numpy's BLAS threads would spin beside the timed calls and count in the process CPU time
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import mprt  # noqa: E402
from _common import log, md_rows, random_rays, study_args, write_csv  # noqa: E402
from mprt.grid import render_desc  # noqa: E402
from mprt.trace import RAY_DTYPE, VISIT_DTYPE  # noqa: E402

try:
    import embreex.mesh_construction as _emc
    import embreex.rtcore_scene as _ers
except ImportError:  # optional
    _ers = None

WORK = ("scene", "grid", "rays", "visits", "bytes_per_visit")  # the columns that do not depend on timing
RES, NRAND = 512, 262144
FINE = (256, 256, 256)  # a fine grid for the effect of jumps


# ---- the measurements (run in this process and, with --before, in the worker) ------------------

_cache: dict = {}


def cached(key, make):
    if key not in _cache:
        _cache[key] = make()
    return _cache[key]


def triangles(scene) -> np.ndarray:
    """The scene's triangles as an (N, 3, 3) array, from the library."""
    p = scene.primitives()["polygons"]
    tri = np.flatnonzero(np.diff(p["vstart"]) == 3)
    return p["vertices"][p["vstart"][tri][:, None] + np.arange(3)]


def _icosphere() -> np.ndarray:
    """The unit icosahedron subdivided once: (80, 3, 3) triangles on the unit sphere."""
    g = (1 + 5 ** 0.5) / 2
    v = np.array([(-1, g, 0), (1, g, 0), (-1, -g, 0), (1, -g, 0), (0, -1, g), (0, 1, g), (0, -1, -g), (0, 1, -g),
                  (g, 0, -1), (g, 0, 1), (-g, 0, -1), (-g, 0, 1)], float)
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6),
         (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
         (8, 6, 7), (9, 8, 1)]
    t = v[np.array(f)]
    a, b, c = t[:, 0], t[:, 1], t[:, 2]
    ab, bc, ca = (a + b) / 2, (b + c) / 2, (c + a) / 2
    t = np.concatenate([np.stack(x, 1) for x in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))])
    return t / np.linalg.norm(t, axis=2)[..., None]


TESS_SIDES = 16  # a cone's lateral surface as 2 * TESS_SIDES triangles


def tessellation(scene) -> np.ndarray:
    """The scene as triangles for Embree: spheres as 80-triangle icospheres, cones and cylinders as
    32-triangle prisms, polygons as fans (an approximation: its hits differ near silhouettes)."""
    p = scene.primitives()
    out = [triangles(scene)]
    pg = p["polygons"]
    for i in np.flatnonzero(np.diff(pg["vstart"]) > 3):
        v = pg["vertices"][pg["vstart"][i]:pg["vstart"][i + 1]]
        out.append(np.stack([np.repeat(v[:1], len(v) - 2, 0), v[1:-1], v[2:]], 1))
    sp = p["spheres"]
    if len(sp["radius"]):
        out.append((_icosphere()[None] * sp["radius"][:, None, None, None] + sp["center"][:, None, None]).reshape(-1, 3, 3))
    c = p["cones"]
    if len(c["base_radius"]):
        w = c["apex"] - c["base"]
        w /= np.linalg.norm(w, axis=1)[:, None]
        u = np.cross(w, np.where(np.abs(w[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]]))
        u /= np.linalg.norm(u, axis=1)[:, None]
        v = np.cross(w, u)
        ang = 2 * np.pi * np.arange(TESS_SIDES + 1) / TESS_SIDES
        ring = np.cos(ang)[None, :, None] * u[:, None] + np.sin(ang)[None, :, None] * v[:, None]
        lo = c["base"][:, None] + c["base_radius"][:, None, None] * ring
        hi = c["apex"][:, None] + c["apex_radius"][:, None, None] * ring
        q = np.stack([lo[:, :-1], lo[:, 1:], hi[:, 1:], hi[:, :-1]], 2)  # quads (cones, sides, 4, 3)
        out.append(np.concatenate([q[:, :, [0, 1, 2]], q[:, :, [0, 2, 3]]], 1).reshape(-1, 3, 3))
    return np.concatenate(out)


def scene_of(name, size, tris_only=False):
    def make():
        s = mprt.Scene.spd(name, size)
        if not tris_only:
            return s
        t = mprt.Scene()  # the triangles alone (like-for-like with Embree)
        for tri in triangles(s):
            t.add_polygon(tri)
        return t
    return cached(("scene", name, size, tris_only), make)


@contextlib.contextmanager
def skipping(on):
    """Grids made inside jump over empty space (on: MPRT_SKIP=1), walk voxel by voxel (False:
    MPRT_NO_SKIP=1) or do what the build does by default (None: no variable; this build walks voxel
    by voxel, builds before it jumped)."""
    names = ("MPRT_SKIP", "MPRT_NO_SKIP", "MPRT_JUMP_MIN")
    old = {k: os.environ.pop(k) for k in names if k in os.environ}
    if on is not None:
        os.environ["MPRT_SKIP" if on else "MPRT_NO_SKIP"] = "1"
    try:
        yield
    finally:
        for k in names:
            os.environ.pop(k, None)
        os.environ.update(old)


def grid_of(name, size, n, tris_only=False, skip=None):
    def make():
        with skipping(skip):
            return scene_of(name, size, tris_only).grid(tuple(n))
    return cached(("grid", name, size, tuple(n), tris_only, skip), make)


def rays_of(name, size, which, res=RES, nrand=NRAND):
    """The scene's primary rays (its view, res x res) or random rays; the same in every build."""
    def make():
        s = scene_of(name, size)
        return s.grid(1).camera_rays(res, res) if which == "primary" else random_rays(s, nrand)
    return cached(("rays", name, size, which, res, nrand), make)


def cpu_clock(fn):
    """(process CPU time of fn(), its result): immune to other processes' load, and it counts the
    helper threads grid.trace uses even on one thread."""
    t = time.process_time()
    out = fn()
    return time.process_time() - t, out


def t_intersect(name, size, n, which, tris_only=False, skip=None, res=RES, nrand=NRAND):
    """CPU time of one intersect call; and the hit count."""
    g = grid_of(name, size, n, tris_only, skip)
    o, d = rays_of(name, size, which, res, nrand)
    t, (_, prim) = cpu_clock(lambda: g.intersect(o, d))
    return t, int(np.count_nonzero(prim >= 0))


def t_render(name, size, n, res, rules, threads=0, skip=None):
    """CPU time of one render on this thread; with threads, [wall-clock time, process CPU time] on that
    many (the CPU time grows with the threads only when they get in each other's way)."""
    g = grid_of(name, size, n, skip=skip)
    if not threads:
        return cpu_clock(lambda: g.render(res, res, rules=rules))[0]
    t = time.perf_counter()
    cpu = cpu_clock(lambda: g.render(res, res, rules=rules, threads=threads))[0]
    return [time.perf_counter() - t, cpu]


def t_trace(name, size, n, res):
    """Untraced render, the tracer alone (tiles into reused buffers) and the whole grid.trace, one each:
    (times..., visits, rays)."""
    g = grid_of(name, size, n)
    desc = g.resolve(render_desc(res, res))
    tiling = g.tiling(desc)
    smp = np.empty(desc["tile"] ** 2 * 3)
    rays = np.empty(1 << 16, dtype=RAY_DTYPE)
    visits = np.empty(1 << 20, dtype=VISIT_DTYPE)

    def c_only():
        total = 0
        for tile in range(tiling[2] * tiling[3]):
            _, nv, fitted = g.trace_tile(desc, tile, smp, rays, visits)
            assert fitted, "bench buffers too small"
            total += nv
        return total

    t_u = cpu_clock(lambda: g.render(res, res))[0]
    t_c, nvis = cpu_clock(c_only)
    t_p, (_, tr) = cpu_clock(lambda: g.trace(res, res))
    return t_u, t_c, t_p, nvis, len(tr.rays)


MEASURES = {f.__name__: f for f in (t_intersect, t_render, t_trace)}


def serve(measures=None) -> int:
    """Worker mode: one JSON request per line on stdin ([name, args]), one JSON answer per line."""
    measures = MEASURES if measures is None else measures
    out = sys.stdout
    sys.stdout = sys.stderr  # nothing else may write to the answers
    for line in sys.stdin:
        name, args = json.loads(line)
        out.write(json.dumps(measures[name](*args)) + "\n")
        out.flush()
    return 0


class Before:
    """The other build, in a worker process running this file (or `script`, which serves its own
    measures with ``--serve``) with its package first on the path."""

    def __init__(self, python_dir: str, script: str = __file__):
        env = dict(os.environ, PYTHONPATH=os.path.abspath(python_dir))
        self.proc = subprocess.Popen([sys.executable, os.path.abspath(script), "--serve"], env=env,
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        self.version = self("t_version")

    def __call__(self, name, *args):
        self.proc.stdin.write(json.dumps([name, list(args)]) + "\n")
        self.proc.stdin.flush()
        return json.loads(self.proc.stdout.readline())

    def close(self):
        self.proc.stdin.close()
        self.proc.wait()


def t_version():
    return f"{mprt.__version__} from {os.path.dirname(mprt.__file__)}"


MEASURES["t_version"] = t_version


def best_of(a, b):
    """The smaller of two measurements; of tuples, item by item (times; counts are equal anyway)."""
    if a is None:
        return b
    if isinstance(a, (int, float)):
        return min(a, b)
    return [min(x, y) for x, y in zip(a, b)]


def side_by_side(before, repeat, name, *args):
    """Best of repeat runs of measure `name` here and (if given) in the before build, interleaved."""
    here = there = None
    for _ in range(repeat):
        here = best_of(here, MEASURES[name](*args))
        if before is not None:
            there = best_of(there, before(name, *args))
    return here, there


# ---- per scene ------------------------------------------------------------------------------------

MAX_CANDIDATE_VOXELS = 1 << 23  # finer shape-following grids pay only for flat scenes (tree)


def candidates(scene):
    cands = [(n, n, n) for n in (16, 24, 32, 48, 64, 96, 128)]
    for density in (1, 2, 3, 4, 6, 8, 12, 16, 24, 32):
        g = tuple(scene.default_grid(density=density, limit=512))
        if g not in cands and (density <= 12 or g[0] * g[1] * g[2] <= MAX_CANDIDATE_VOXELS):
            cands.append(g)
    return cands


def fastest_grid(name, size, tris_only=False):
    """The candidate subdivision with the fastest primary rays (this build), and its build time."""
    best = None
    for n in candidates(scene_of(name, size, tris_only)):
        t_build = cpu_clock(lambda: grid_of(name, size, n, tris_only))[0]
        t = min(t_intersect(name, size, n, "primary", tris_only)[0] for _ in range(2))
        if best is None or t < best[1]:
            best = (n, t, t_build)
        _cache.pop(("grid", name, size, n, tris_only, None))
    return best[0], best[2]


def ratio(a, b):
    return a / b if a and b else None


def t_embree(tris, o, d, repeat):
    """Best of repeat process CPU times of Embree's single-ray ``rtcIntersect1`` loop (embreex) over the
    rays, on the triangles (tris: (N, 3, 3)), the BVH built outside the timing; and its primitive ids."""
    es = _ers.EmbreeScene()
    _emc.TriangleMesh(es, tris.astype(np.float32))
    o, d = o.astype(np.float32), d.astype(np.float32)
    es.run(o[:1], d[:1])  # commit (BVH build)
    return min(cpu_clock(lambda: es.run(o, d))[0] for _ in range(repeat)), es.run(o, d)


def embree_row(name, size, before, repeat) -> dict:
    """mprt on the scene's triangles alone against Embree on the same triangles and rays."""
    tris = triangles(scene_of(name, size))
    n, _ = fastest_grid(name, size, tris_only=True)
    row = {"tri_grid": "x".join(map(str, n))}
    for which in ("primary", "random"):
        o, d = rays_of(name, size, which)
        t_e, ep = t_embree(tris, o, d, repeat)
        (t_m, hits), there = side_by_side(before, repeat, "t_intersect", name, size, n, which, True)
        rows = len(o)
        row[f"tri_{which}_Mrays"] = rows / t_m / 1e6
        row[f"embree_{which}_Mrays"] = rows / t_e / 1e6
        row[f"tri_{which}_vs_embree"] = t_e / t_m
        if there:
            row[f"tri_{which}_before_vs_embree"] = t_e / there[0]
        row[f"tri_{which}_hit_agreement"] = 1 - abs(hits - int(np.count_nonzero(ep >= 0))) / rows
    _log_tri(row)
    return row


def embree_tess_row(name, size, n, before, repeat) -> dict:
    """mprt on the whole scene (analytic shapes, grid n) against Embree on a tessellation of it."""
    tris = tessellation(scene_of(name, size))
    row = {"tess_triangles": len(tris)}
    o, d = rays_of(name, size, "primary")
    t_e, ep = t_embree(tris, o, d, repeat)
    (t_m, hits), there = side_by_side(before, repeat, "t_intersect", name, size, n, "primary")
    row["embree_tess_primary_Mrays"] = len(o) / t_e / 1e6
    row["primary_vs_embree_tess"] = t_e / t_m
    if there:
        row["primary_before_vs_embree_tess"] = t_e / there[0]
    row["tess_hit_agreement"] = 1 - abs(hits - int(np.count_nonzero(ep >= 0))) / len(o)
    log(f"       whole scene, grid {'x'.join(map(str, n))}: primary mprt {len(o) / t_m / 1e6:.2f} vs Embree on "
        f"{len(tris)} triangles {row['embree_tess_primary_Mrays']:.2f} Mrays/s ({row['primary_vs_embree_tess']:.2f}x"
        + (f", before {row['primary_before_vs_embree_tess']:.2f}x" if there else "") + ")")
    return row


def _log_tri(row):
    log(f"       triangles only, grid {row['tri_grid']}: primary mprt {row['tri_primary_Mrays']:.2f} vs Embree "
        f"{row['embree_primary_Mrays']:.2f} Mrays/s ({row['tri_primary_vs_embree']:.2f}x); random mprt "
        f"{row['tri_random_Mrays']:.2f} vs Embree {row['embree_random_Mrays']:.2f} "
        f"({row['tri_random_vs_embree']:.2f}x)"
        + (f"; before {row['tri_primary_before_vs_embree']:.2f}x and {row['tri_random_before_vs_embree']:.2f}x"
           if "tri_primary_before_vs_embree" in row else ""))


def bench_scene(name, size, before, repeat) -> dict:
    n, t_build = fastest_grid(name, size)
    row = {"scene": name, "grid": "x".join(map(str, n)), "build_s": t_build}
    for which in ("primary", "random"):
        (t, _), there = side_by_side(before, repeat, "t_intersect", name, size, n, which)
        t_on = min(t_intersect(name, size, n, which, skip=True)[0] for _ in range(repeat))
        t_off = min(t_intersect(name, size, n, which, skip=False)[0] for _ in range(repeat))
        rays = len(rays_of(name, size, which)[0])
        row[f"{which}_Mrays"] = rays / t / 1e6
        row[f"{which}_jumps_gain"] = t_off / t_on  # >1: jumping over empty space (MPRT_SKIP=1) pays
        if there:
            row[f"{which}_before_Mrays"] = rays / there[0] / 1e6
            row[f"{which}_speedup"] = there[0] / t
    # jumps on a fine grid, where empty blocks are many voxels wide
    t_on = min(t_intersect(name, size, FINE, "primary", skip=True)[0] for _ in range(repeat))
    t_off = min(t_intersect(name, size, FINE, "primary", skip=False)[0] for _ in range(repeat))
    row["fine_primary_jumps_gain"] = t_off / t_on
    for skip in (True, False):
        _cache.pop(("grid", name, size, FINE, False, skip))
    # and on the render (eye, shadow and secondary rays), the work a trace records
    t_on = min(t_render(name, size, n, RES, "paper", skip=True) for _ in range(repeat))
    t_off = min(t_render(name, size, n, RES, "paper", skip=False) for _ in range(repeat))
    row["render_jumps_gain"] = t_off / t_on
    for rules in ("paper", "spd"):
        t, there = side_by_side(before, repeat, "t_render", name, size, n, RES, rules)
        row[f"render_{rules}_s"] = t
        if there:
            row[f"render_{rules}_before_s"], row[f"render_{rules}_speedup"] = there, there / t
    wall = {}
    for threads in (1, 2):  # wall-clock and CPU times, interleaved
        wall[threads] = side_by_side(before, repeat, "t_render", name, size, n, RES, "paper", threads)
    row["threads2_speedup"] = wall[1][0][0] / wall[2][0][0]
    row["threads2_cpu_ratio"] = wall[2][0][1] / wall[1][0][1]  # 1: the second thread adds no work
    if wall[1][1]:
        row["threads2_before_speedup"] = wall[1][1][0] / wall[2][1][0]
    (t_u, t_c, t_p, nvis, nrays), there = side_by_side(before, repeat, "t_trace", name, size, n, RES)
    row.update({"rays": nrays, "visits": nvis, "tracer_alone_vs_render": t_c / t_u, "trace_vs_render": t_p / t_u,
                "bytes_per_visit": round((nrays * RAY_DTYPE.itemsize + nvis * VISIT_DTYPE.itemsize) / nvis, 2)})
    if there:
        row["trace_before_vs_render"] = there[2] / there[0]
        row["trace_speedup"] = there[2] / t_p
    log(f"{name:6s} grid {row['grid']:>11s}: primary {row['primary_Mrays']:.2f} Mrays/s "
        f"(x{row.get('primary_speedup', 0):.2f} before), random {row['random_Mrays']:.2f} "
        f"(x{row.get('random_speedup', 0):.2f}); render paper {row['render_paper_s']:.2f} s "
        f"(x{row.get('render_paper_speedup', 0):.2f}), spd {row['render_spd_s']:.2f} s; 2 threads "
        f"x{row['threads2_speedup']:.2f} (CPU time x{row['threads2_cpu_ratio']:.3f}); grid.trace/render {row['trace_vs_render']:.2f}")
    if _ers is not None and name in ("tetra", "mount"):
        row.update(embree_row(name, size, before, repeat))
    if _ers is not None and name in ("tree", "balls", "rings"):
        row.update(embree_tess_row(name, size, n, before, repeat))
    _cache.clear()
    return row


def quick_row(name) -> dict:
    """Work figures at size 2, 32x32, the default grid (deterministic)."""
    n = tuple(scene_of(name, 2).default_grid())
    _, _, _, nvis, nrays = t_trace(name, 2, n, 32)
    return {"scene": name, "grid": "x".join(map(str, n)), "rays": nrays, "visits": nvis,
            "bytes_per_visit": round((nrays * RAY_DTYPE.itemsize + nvis * VISIT_DTYPE.itemsize) / nvis, 2)}


SUMMARY = ("scene", "grid", "primary_Mrays", "primary_speedup", "random_Mrays", "random_speedup", "primary_jumps_gain",
           "random_jumps_gain", "fine_primary_jumps_gain", "render_jumps_gain",
           "render_paper_s", "render_paper_speedup", "render_spd_speedup", "threads2_speedup",
           "threads2_cpu_ratio", "threads2_before_speedup", "tracer_alone_vs_render", "trace_vs_render", "trace_speedup",
           "tri_primary_vs_embree", "tri_primary_before_vs_embree", "tri_random_vs_embree",
           "tri_random_before_vs_embree", "primary_vs_embree_tess", "primary_before_vs_embree_tess")


def options(ap):
    ap.add_argument("--scenes", default=",".join(mprt.SPD_SCENES))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--before", default=None, help="python folder of another mprt build to compare with")
    ap.add_argument("--serve", action="store_true", help=argparse.SUPPRESS)


def main(argv=None) -> int:
    if "--serve" in (sys.argv[1:] if argv is None else argv):
        return serve()
    a, out = study_args(__file__, __doc__.splitlines()[0],
                        "scenes at size 2, 32x32, default grid, one repeat, work figures only", argv, options)
    names = a.scenes.split(",")
    if a.quick:  # timings are not reproducible: the reference keeps the work figures
        write_csv(os.path.join(out, "bench.csv"), [quick_row(name) for name in names])
        return 0
    before = Before(a.before) if a.before else None
    log(f"mprt {t_version()}; before: {before.version if before else 'none'}; best of {a.repeat}; Embree: "
        + ("embreex" if _ers else "UNAVAILABLE, embreex is not installed (pip install embreex): no Embree columns"))
    try:
        rows = [bench_scene(name, None, before, a.repeat) for name in names]
    finally:
        if before:
            before.close()
    write_csv(os.path.join(out, "bench.csv"), rows)
    log(md_rows([{k: (round(r[k], 2) if isinstance(r[k], float) else r[k]) for k in SUMMARY if k in r}
                 for r in rows]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
