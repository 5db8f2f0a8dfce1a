"""Grid shape: how did the paper divide balls' flat box, and how were its voxel lists made?

balls' box is flat (24 x 24 x 1.33).  At each subdivision n, `paper` rules,
one render each: n^3 voxels over the box (ours) against cubic voxels (n along
x and y, z in proportion), with voxels traversed, tests and list entries; and
for n^3, the list entries if every sphere were listed in each voxel its
bounding box overlaps (the other primitives' entries as ours), from the
spheres' centres and radii as the library holds them.

Writes grid_shape.csv to studies/out/08_grid_shape/ (--quick: 64x64,
subdivisions 8 and 16, balls at size 2, to ref/).

    python studies/08_grid_shape/run.py [--quick] [--out DIR] [--threads 2]
"""
from __future__ import annotations

import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import mprt  # noqa: E402
from _common import quick_or_full, study_args, write_table  # noqa: E402


def bbox_refs(prims, grid) -> int:
    """List entries if every sphere were listed in each voxel its bounding box overlaps (the
    other primitives' entries as the grid's)."""
    gs = grid.stats()
    lo, hi, n = np.array(gs["lo"]), np.array(gs["hi"]), np.array(gs["n"])
    vs = (hi - lo) / n
    c, r = prims["spheres"]["center"], prims["spheres"]["radius"][:, None]
    a = np.clip(np.floor((c - r - lo) / vs), 0, n - 1)
    b = np.clip(np.floor((c + r - lo) / vs), 0, n - 1)
    _, ids = grid.lists()
    return int(np.prod(b - a + 1, axis=1).sum()) + int(np.sum(prims["kind"][ids] != mprt.Kind.SPHERE))


def main(argv=None) -> int:
    a, out = study_args(__file__, "balls: n^3 voxels over the box against cubic voxels; list construction",
                        "64x64, subdivisions 8 and 16, balls at size 2", argv)
    res, size, subdivisions = quick_or_full(a.quick)
    scene = mprt.Scene.spd("balls", size)
    info, prims = scene.info(), scene.primitives()
    ext = np.subtract(info["hi"], info["lo"])
    rows = []
    for n in subdivisions:
        nz = max(1, int(round(n * ext[2] / ext[:2].max())))
        for shape, dims in (("n^3 over the box", (n, n, n)), ("cubic voxels", (n, n, nz))):
            g = scene.grid(dims)
            _, c = g.render(res, res, rules="paper", threads=a.threads)
            rows.append({"subdivision": n, "grid": "x".join(map(str, dims)), "shape": shape,
                         "voxels_traversed": c["voxels_traversed"], "tests": sum(c["tests"].values()),
                         "refs": g.stats()["refs"],
                         "refs_sphere_bboxes": bbox_refs(prims, g) if shape.startswith("n^3") else ""})
    write_table(out, "grid_shape.csv", rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
