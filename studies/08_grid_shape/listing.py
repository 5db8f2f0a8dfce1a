"""Listings: every voxel a primitive's closed, padded box test touches ('exact', the default)
against only the voxels whose interior its surface meets ('occupied', issue 21 item 3).

For every SPD scene at its default size and three subdivisions (16^3, the library's default
subdivision and half of it on each axis), one render each way at --res under `paper` rules:
list entries, tests per ray (tests over eye, reflection, refraction and shadow rays) and
voxels per ray, and whether the image and the grid-independent counts stay those of the exact
listing.  Then the watertightness cases of tests/listing_cases.py (rays exactly through voxel
corners, edges, faces and tangent points, and along voxel planes; hand-made scenes and SPD
tetra at size 4, whose vertices lie on voxel planes): rays whose closest hit differs from the
one-voxel grid's (brute force), and pixels that differ.  Prints the tables (Markdown) and
writes listing.csv and listing_cases.csv to --out (default studies/out/08_grid_shape).

    python studies/08_grid_shape/listing.py [--res 256] [--threads 2] [--out DIR]
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(HERE)), "tests"))
import mprt  # noqa: E402
import listing_cases as L  # noqa: E402
from _common import md_rows, write_csv  # noqa: E402

GRID_INDEPENDENT = ("eye_rays", "eye_hits", "reflect_rays", "refract_rays", "shadow_rays", "suppressed_rays", "hits",
                    "sc_visits")


def rays(c) -> int:
    return c["eye_rays"] + c["reflect_rays"] + c["refract_rays"] + c["shadow_rays"]


def grids(scene):
    d = tuple(scene.default_grid())
    return [(16, 16, 16), tuple(max(1, (k + 1) // 2) for k in d), d]


def spd_rows(res: int, threads: int) -> list:
    rows = []
    for name in mprt.SPD_SCENES:
        scene = mprt.Scene.spd(name)
        for n in grids(scene):
            out = {}
            for listing in ("exact", "occupied"):
                g = scene.grid(n, listing=listing)
                img, c = g.render(res, res, rules="paper", threads=threads)
                out[listing] = (g.stats()["refs"], sum(c["tests"].values()), c["voxels_traversed"], rays(c), img, c)
            (re, te, ve, ne, ie, ce), (ro, to, vo, no, io, co) = out["exact"], out["occupied"]
            rows.append({
                "scene": name, "grid": "x".join(map(str, n)),
                "refs exact": re, "refs occupied": ro, "refs ratio": round(ro / re, 3),
                "tests/ray exact": round(te / ne, 3), "tests/ray occupied": round(to / no, 3),
                "tests ratio": round(to / te, 3),
                "voxels/ray": round(ve / ne, 2), "voxels/ray occupied": round(vo / no, 2),
                "pixels differing": int(np.sum(np.any(ie != io, axis=2))),
                "counts differing": ",".join(k for k in GRID_INDEPENDENT if ce[k] != co[k]) or "none",
            })
            print(f"  {name} {rows[-1]['grid']}: refs {re} -> {ro}, tests/ray {te / ne:.3f} -> {to / no:.3f}",
                  file=sys.stderr, flush=True)
    return rows


def case_rows() -> list:
    rows = []
    for name in L.CASES:
        s, pts = L.scene(name)
        o, d = L.rays(pts)
        ref = s.grid(1).intersect(o, d)
        ref_img, _ = s.grid(1).render()
        for n in L.GRIDS:
            row = {"case": name, "grid": "x".join(map(str, n)) if isinstance(n, tuple) else f"{n}^3",
                   "rays": len(o), "hits": int(np.isfinite(ref[0]).sum())}
            for listing in ("exact", "occupied"):
                t, p = s.grid(n, listing=listing).intersect(o, d)
                img, _ = s.grid(n, listing=listing).render()
                row[f"refs {listing}"] = s.grid(n, listing=listing).stats()["refs"]
                row[f"rays differing {listing}"] = int(np.sum((t != ref[0]) | (p != ref[1])))
                row[f"leaks {listing}"] = int(np.sum(np.isfinite(ref[0]) & ~np.isfinite(t)))
                row[f"pixels differing {listing}"] = int(np.sum(np.any(img != ref_img, axis=2)))
            rows.append(row)
    s, o, d = L.tetra_rays()
    ref = s.grid(1).intersect(o, d)
    for n in (8, 16, 32, (8, 16, 32), 13):
        row = {"case": "SPD tetra:4 vertices, edge midpoints",
               "grid": "x".join(map(str, n)) if isinstance(n, tuple) else f"{n}^3",
               "rays": len(o), "hits": int(np.isfinite(ref[0]).sum())}
        for listing in ("exact", "occupied"):
            t, p = s.grid(n, listing=listing).intersect(o, d)
            row[f"refs {listing}"] = s.grid(n, listing=listing).stats()["refs"]
            row[f"rays differing {listing}"] = int(np.sum((t != ref[0]) | (p != ref[1])))
            row[f"leaks {listing}"] = int(np.sum(np.isfinite(ref[0]) & ~np.isfinite(t)))
        rows.append(row)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--res", type=int, default=256, help="image size of the SPD renders, square (default 256)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", default=os.path.join(os.path.dirname(HERE), "out", "08_grid_shape"))
    a = ap.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    t0 = time.perf_counter()
    spd = spd_rows(a.res, a.threads)
    cases = case_rows()
    write_csv(os.path.join(a.out, "listing.csv"), spd)
    write_csv(os.path.join(a.out, "listing_cases.csv"), cases)
    print(f"SPD scenes at their default sizes, {a.res}x{a.res}, paper rules: exact -> occupied listing\n")
    print(md_rows([{"scene": r["scene"], "grid": r["grid"],
                    "refs": f"{r['refs exact']:,} -> {r['refs occupied']:,} ({r['refs ratio']:.3f}x)",
                    "tests/ray": f"{r['tests/ray exact']:.2f} -> {r['tests/ray occupied']:.2f} ({r['tests ratio']:.3f}x)",
                    "voxels/ray": f"{r['voxels/ray']:.2f} -> {r['voxels/ray occupied']:.2f}",
                    "pixels, counts differing": f"{r['pixels differing']}, {r['counts differing']}"} for r in spd]))
    print("Rays exactly through voxel corners, edges, faces and tangent points, against the one-voxel grid:\n"
          "rays whose hit differs (of them leaks: brute force hits, the grid misses) and pixels differing\n")
    print(md_rows([{"case": r["case"], "grid": r["grid"], "rays (hits)": f"{r['rays']} ({r['hits']})",
                    "refs": f"{r['refs exact']:,} -> {r['refs occupied']:,}",
                    "exact: rays, leaks, pixels": f"{r['rays differing exact']}, {r['leaks exact']}, "
                                                  f"{r.get('pixels differing exact', '-')}",
                    "occupied: rays, leaks, pixels": f"{r['rays differing occupied']}, {r['leaks occupied']}, "
                                                     f"{r.get('pixels differing occupied', '-')}"} for r in cases]))
    print(f"({time.perf_counter() - t0:.0f} s; tables in {a.out})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
