"""What limits Grid.intersect: its time per ray fitted to the work the uniform grid makes it do.

For each SPD scene at its default size (tetra and mount: their triangles alone, as the bench
compares them with Embree), on several subdivisions and on the scene's 512x512 eye rays and
262,144 random rays, measures the time per ray (best of N process CPU times, one thread) and
the work per ray the counters report: voxels the 3DDDA enters, IC visits, and tests of
polygons, spheres and cones or cylinders.  A non-negative least-squares fit over all points,

    time per ray = a * voxels + b * IC visits + c_polygon * polygon tests
                   + c_sphere * sphere tests + c_cone * cone tests + d,

per scene and ray set gives each unit of work its cost in ns, d being measured apart (the set's
directions from origins outside the grid's box, moving away: the batch loop, the ray's set-up
and the clip); at the bench's grid (the fastest for eye rays) the
time is split into walk (a * voxels), IC (b * visits + the tests) and per-ray set-up (d), and
set against Embree's single-ray time on the same rays (triangles; for tree, balls and rings a
tessellation, as in run.py).  Writes limits.csv, limits.md and limits.png to
studies/out/03_bench/ (--quick: size 1 scenes, 64x64 eye rays and 4,096 random rays).

    python studies/03_bench/limits.py [--scenes tetra,tree] [--repeat 3] [--quick]
"""
from __future__ import annotations

import os
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import numpy as np  # noqa: E402
from scipy.optimize import nnls  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import mprt  # noqa: E402
import run as bench  # noqa: E402
from _common import log, md_table, study_args, write_csv  # noqa: E402

TRIS = ("tetra", "mount")  # compared on their triangles alone
WORK = ("voxels", "ic_visits", "polygon_tests", "sphere_tests", "cone_tests")
TERMS = WORK + ("ray",)


def setup_ns(name, size, which, repeat, res, nrand) -> float:
    """Time per ray of the ray set's directions from origins outside the grid's box, moving away
    from it: the fixed cost of a ray (the batch loop, the ray's set-up, the clip against the box),
    with the branches as predictable as in the ray set itself."""
    g = bench.grid_of(name, size, (16, 16, 16), name in TRIS)
    info = bench.scene_of(name, size).info()
    lo, hi = np.array(info["lo"]), np.array(info["hi"])
    _, d = bench.rays_of(name, size, which, res, nrand)
    d = d / np.linalg.norm(d, axis=1)[:, None]
    o = (lo + hi) / 2 + d * 2 * np.linalg.norm(hi - lo)  # outside, moving away
    t = min(bench.cpu_clock(lambda: g.intersect(o, d))[0] for _ in range(repeat))
    assert not np.isfinite(g.intersect(o, d)[0]).any()
    bench._cache.pop(("grid", name, size, (16, 16, 16), name in TRIS, None))
    return t / len(d) * 1e9


def point(name, size, n, which, repeat, res, nrand) -> dict:
    """Time and work per ray of one (scene, grid, rays)."""
    tris = name in TRIS
    t = min(bench.t_intersect(name, size, n, which, tris, res=res, nrand=nrand)[0] for _ in range(repeat))
    o, d = bench.rays_of(name, size, which, res, nrand)
    c = bench.grid_of(name, size, n, tris).intersect(o, d, return_counters=True)[2]
    bench._cache.pop(("grid", name, size, tuple(n), tris, None))
    k = len(o)
    tests = c["tests"]
    return {"scene": name, "grid": "x".join(map(str, n)), "rays": which, "ns_per_ray": t / k * 1e9,
            "voxels": c["voxels_traversed"] / k, "ic_visits": c["ic_visits"] / k,
            "polygon_tests": tests["polygon"] / k, "sphere_tests": tests["sphere"] / k,
            "cone_tests": (tests["cone"] + tests["cylinder"]) / k}


def embree_ns(name, size, which, repeat, res, nrand):
    """Embree's single-ray time per ray on the same rays (None without embreex)."""
    if bench._ers is None:
        return None
    scene = bench.scene_of(name, size)
    tris = bench.triangles(scene) if name in TRIS else bench.tessellation(scene)
    o, d = bench.rays_of(name, size, which, res, nrand)
    return bench.t_embree(tris, o, d, repeat)[0] / len(o) * 1e9


TEST_KINDS = ("polygon_tests", "sphere_tests", "cone_tests")
MINOR = 0.1  # a kind of test making less than this share of the tests is fitted as the main kind


def fit(points, setup) -> tuple:
    """Non-negative least squares of ns per ray, less the measured set-up, on the work per ray:
    (coefficients, R^2 of the time per ray).  A kind of test the points rarely make (under MINOR of
    the tests: tree's and rings' ground polygon) is counted with the main kind and given its cost,
    since a few rows cannot fit a cost of its own."""
    total = {k: sum(p[k] for p in points) for k in TEST_KINDS}
    main = max(TEST_KINDS, key=total.get)
    minor = [k for k in TEST_KINDS if k != main and total[k] < MINOR * sum(total.values())]
    work = [w for w in WORK if w not in minor and any(p[w] > 0 for p in points)]
    A = np.array([[p[w] + (sum(p[k] for k in minor) if w == main else 0) for w in work] for p in points])
    y = np.array([p["ns_per_ray"] for p in points])
    coef, _ = nnls(A, y - setup)
    pred = A @ coef + setup
    r2 = 1 - np.sum((y - pred) ** 2) / np.sum((y - y.mean()) ** 2)
    out = dict.fromkeys(WORK, 0.0)
    out.update(zip(work, coef))
    for k in minor:
        out[k] = out[main] if total[k] > 0 else 0.0
    out["ray"] = setup
    return out, float(r2)


def split(p, coef) -> dict:
    """The fitted time per ray of point p, by part."""
    walk = coef["voxels"] * p["voxels"]
    ic = sum(coef[w] * p[w] for w in WORK[1:])
    return {"walk": walk, "ic": ic, "setup": coef["ray"], "fitted": walk + ic + coef["ray"]}


def plot(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    labels = [f"{r['scene']}\n{r['rays']}" for r in rows]
    x = np.arange(len(rows))
    fig, ax = plt.subplots(figsize=(max(6, 1.1 * len(rows)), 4.2))
    bottom = np.zeros(len(rows))
    for part, colour in (("setup", "#bbbbbb"), ("walk", "#4878a8"), ("ic", "#d88c3a")):
        v = np.array([r[part] for r in rows])
        ax.bar(x, v, 0.6, bottom=bottom, color=colour, label={"setup": "per-ray set-up", "walk": "3DDDA walk",
                                                               "ic": "IC (visits and tests)"}[part])
        bottom += v
    ax.plot(x, [r["ns_per_ray"] for r in rows], "k_", ms=22, mew=2, label="measured")
    emb = [(i, r["embree_ns"]) for i, r in enumerate(rows) if r.get("embree_ns")]
    if emb:
        ax.plot(*zip(*emb), "r*", ms=11, label="Embree rtcIntersect1")
    ax.set_xticks(x, labels, fontsize=8)
    ax.set_ylabel("ns per ray (one core)")
    ax.set_title("Grid.intersect at the bench's grid: fitted cost by part")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def options(ap):
    ap.add_argument("--scenes", default=",".join(mprt.SPD_SCENES))
    ap.add_argument("--repeat", type=int, default=3)


def main(argv=None) -> int:
    a, out = study_args(__file__, __doc__.splitlines()[0], "size 1 scenes, 64x64 eye rays, 4,096 random rays",
                        argv, options)
    if a.quick and a.out is None:  # timings: never into ref/
        out = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "out", "03_bench")
        os.makedirs(out, exist_ok=True)
    size, res, nrand, repeat = (1, 64, 4096, 1) if a.quick else (None, bench.RES, bench.NRAND, a.repeat)
    points, rows, fits = [], [], []
    for name in a.scenes.split(","):
        scene = bench.scene_of(name, size, name in TRIS)
        mine = [point(name, size, n, which, repeat, res, nrand)
                for n in bench.candidates(scene) for which in ("primary", "random")]
        # the bench's choice: the candidate grid with the fastest eye rays
        grid = min((p for p in mine if p["rays"] == "primary"), key=lambda p: p["ns_per_ray"])["grid"]
        for which in ("primary", "random"):
            these = [p for p in mine if p["rays"] == which]
            coef, r2 = fit(these, setup_ns(name, size, which, repeat, res, nrand))
            fits.append([name, which] + [f"{coef[k]:.2f}" for k in TERMS] + [f"{r2:.3f}"])
            for p in these:
                p.update({f"fit_{k}": v for k, v in split(p, coef).items()})
            log(f"{name} {which}: {len(these)} grids, fastest for eye rays {grid}; ns per unit of work: "
                + ", ".join(f"{k} {v:.2f}" for k, v in coef.items()) + f"; R^2 {r2:.3f}")
            p = next(q for q in these if q["grid"] == grid)
            r = dict(p, **split(p, coef))
            r["embree_ns"] = embree_ns(name, size, which, repeat, res, nrand)
            rows.append(r)
        points += mine
    write_csv(os.path.join(out, "limits.csv"), points)
    header = ["scene", "rays", "grid", "ns/ray", "fitted", "walk", "IC", "set-up", "voxels", "IC visits", "tests",
              "Embree ns/ray", "walk / Embree"]
    table = [[r["scene"], r["rays"], r["grid"], f"{r['ns_per_ray']:.0f}", f"{r['fitted']:.0f}", f"{r['walk']:.0f}",
              f"{r['ic']:.0f}", f"{r['setup']:.0f}", f"{r['voxels']:.1f}", f"{r['ic_visits']:.2f}",
              f"{r['polygon_tests'] + r['sphere_tests'] + r['cone_tests']:.1f}",
              f"{r['embree_ns']:.0f}" if r["embree_ns"] else "-",
              f"{r['walk'] / r['embree_ns']:.2f}" if r["embree_ns"] else "-"] for r in rows]
    text = ("ns per unit of work, per scene and ray set (the set-up measured on the set's directions from "
            "origins outside the box, the rest a non-negative least-squares fit over the candidate grids):\n\n"
            + md_table(["scene", "rays", "voxel", "IC visit", "polygon test", "sphere test", "cone test", "set-up",
                        "R^2"], fits) + "\nAt the fastest grid for eye rays:\n\n" + md_table(header, table))
    with open(os.path.join(out, "limits.md"), "w") as f:
        f.write(text + "\n")
    log(text)
    plot(rows, os.path.join(out, "limits.png"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
