"""Benchmark (make bench): intersect throughput against Embree, render times.

For each SPD scene at its default size, one thread:
  1. finds the fastest grid subdivision for the scene's 512x512 primary rays
     among cubic and shape-following (pbrt-rule) candidates;
  2. measures rays per second of ``Grid.intersect`` on those primary rays and
     on random rays, and, for the triangle scenes (tetra; mount's 8192
     triangles without its 4 spheres), Embree's single-ray ``rtcIntersect1``
     loop (via the embreex package) on the same rays, side by side;
  3. times full 512x512 renders under both rule sets with that grid.
Every figure is a best-of-N wall-clock time measured in this one run; the
ratios are the point, since the machine may be shared.

    python studies/bench.py [--scenes balls,tetra] [--repeat 3] [--quick]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

import mprt  # noqa: E402

try:
    import embreex.mesh_construction as _emc
    import embreex.rtcore_scene as _ers
except ImportError:  # pragma: no cover - optional
    _ers = None


def random_rays(scene, n, seed=1):
    """Origins uniform in the scene box, directions uniform on the sphere."""
    info = scene.info()
    lo, hi = np.array(info["lo"]), np.array(info["hi"])
    rng = np.random.default_rng(seed)
    o = lo + (hi - lo) * rng.random((n, 3))
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    return o, d


def best_time(fn, repeat):
    best = float("inf")
    out = None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def triangles(scene):
    """The scene's triangles as an (N, 3, 3) array, from its NFF text."""
    lines = scene.to_nff().splitlines()
    tris, i = [], 0
    while i < len(lines):
        p = lines[i].split()
        if p and p[0] == "p" and int(p[1]) == 3:
            tris.append([[float(v) for v in lines[i + 1 + k].split()] for k in range(3)])
            i += 4
        else:
            i += 1
    return np.array(tris)


def triangle_scene(tris):
    """A Scene holding only the given triangles (like-for-like with Embree)."""
    s = mprt.Scene()
    for t in tris:
        s.add_polygon(t)
    return s


def trace_cost(grid, res, repeat):
    """Traced/untraced time, side by side: the untraced render; the tracer
    alone (every tile traced into reused buffers, records not kept); and the
    whole grid.trace (records assembled into the Trace's arrays)."""
    from mprt.trace import RAY_DTYPE, VISIT_DTYPE

    ext = grid._ext
    ffi, lib = ext.ffi, ext.lib
    d = ffi.new("mprt_render_desc *")
    lib.mprt_render_desc_init(d)
    d.width = d.height = res
    sw, sh, tx, ty = (ffi.new("int *") for _ in range(4))
    lib.mprt_grid_tiling(grid._h, d, sw, sh, tx, ty)
    smp = np.empty(16 * 16 * 3)
    rays = np.empty(1 << 16, dtype=RAY_DTYPE)
    visits = np.empty(1 << 20, dtype=VISIT_DTYPE)
    nr, nv = ffi.new("size_t *"), ffi.new("size_t *")
    args = (ffi.cast("double *", ffi.from_buffer(smp)), smp.size, ffi.cast("mprt_trace_ray *", ffi.from_buffer(rays)),
            len(rays), nr, ffi.cast("mprt_trace_visit *", ffi.from_buffer(visits)), len(visits), nv, ffi.NULL)

    def c_only():
        total = 0
        for t in range(tx[0] * ty[0]):
            rc = lib.mprt_grid_trace_tile(grid._h, d, t, *args)
            assert rc == 0, rc
            total += nv[0]
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
    return t_render, t_c, t_py, nvis, RAY_DTYPE.itemsize, VISIT_DTYPE.itemsize, len(tr.rays)


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


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", default=",".join(mprt.SPD_SCENES))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--random", type=int, default=262144, help="random rays per scene")
    ap.add_argument("--quick", action="store_true", help="renders at 128x128, one repeat")
    a = ap.parse_args(argv)
    repeat = 1 if a.quick else a.repeat
    res = 128 if a.quick else 512
    print(f"mprt {mprt.__version__}; one thread; best of {repeat}; Embree: "
          + ("embreex" if _ers else "not installed (pip install embreex)"))
    rows = []
    for name in a.scenes.split(","):
        scene = mprt.Scene.spd(name)
        po, pd = scene.camera_rays(512, 512)
        ro, rd = random_rays(scene, a.random)
        n, t_prim, t_build = fastest_grid(scene, po, pd, repeat)
        grid = scene.grid(n)
        t_rand, _ = best_time(lambda: grid.intersect(ro, rd), repeat)
        row = {"scene": name, "grid": "x".join(map(str, n)), "build_s": t_build,
               "primary_Mrays": len(po) / t_prim / 1e6, "random_Mrays": len(ro) / t_rand / 1e6}
        tris = triangles(scene)
        if _ers is not None and len(tris) and name in ("tetra", "mount"):
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
            agree = float(np.mean((ep >= 0) == (tp >= 0)))
            row.update({"tri_grid": "x".join(map(str, tn)),
                        "tri_primary_Mrays": len(po) / tt_prim / 1e6, "embree_primary_Mrays": len(po) / te_prim / 1e6,
                        "tri_random_Mrays": len(ro) / tt_rand / 1e6, "embree_random_Mrays": len(ro) / te_rand / 1e6,
                        "hit_agreement": agree})
        for rules in ("paper", "spd"):
            t_r, (_, c) = best_time(lambda: grid.render(res, res, rules=rules), 1)
            row[f"render_{rules}_s"] = t_r
        t_u, t_c, t_p, nvis, rsz, vsz, nrays = trace_cost(grid, res, repeat)
        row.update({"trace_c_ratio": t_c / t_u, "trace_ratio": t_p / t_u, "visits": nvis,
                    "bytes_per_visit": (nrays * rsz + nvis * vsz) / nvis})
        rows.append(row)
        print(f"{name:6s} grid {row['grid']:>11s} (build {t_build:.2f} s)  "
              f"intersect: primary {row['primary_Mrays']:.2f} Mrays/s, random {row['random_Mrays']:.2f} Mrays/s;  "
              f"render {res}^2: paper {row['render_paper_s']:.2f} s, spd {row['render_spd_s']:.2f} s", flush=True)
        print(f"       trace {res}^2 (paper): {nvis} visits, {row['bytes_per_visit']:.1f} bytes per visit (rays included); "
              f"traced/untraced time: tracer alone {row['trace_c_ratio']:.2f}, whole grid.trace {row['trace_ratio']:.2f}",
              flush=True)
        if "embree_primary_Mrays" in row:
            print(f"       triangles only, grid {row['tri_grid']}: primary mprt {row['tri_primary_Mrays']:.2f} vs "
                  f"Embree {row['embree_primary_Mrays']:.2f} Mrays/s (ratio {row['tri_primary_Mrays'] / row['embree_primary_Mrays']:.2f}); "
                  f"random mprt {row['tri_random_Mrays']:.2f} vs Embree {row['embree_random_Mrays']:.2f} "
                  f"(ratio {row['tri_random_Mrays'] / row['embree_random_Mrays']:.2f}); hit/miss agreement {row['hit_agreement']:.5f}",
                  flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
