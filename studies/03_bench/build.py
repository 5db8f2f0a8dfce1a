"""Grid build time, before and after, at the subdivisions the coarse prepass tries.

For each SPD scene at its default size: gears at (21,21,5) (67,67,17) (119,119,30) (212,212,53)
(378,378,94), tree at (203,203,6) (645,645,20), balls, mount, rings and tetra at
``default_grid(density=8)`` and ``density=24``.  Each figure is the best of --repeat process CPU
times of ``mprt.Grid(scene, dims)`` (the exact listing; ``--listing box`` for the bounding-box one).
With --before DIR (a ``python`` folder holding another build of the mprt package) every build is
also timed with that build in a worker process, interleaved with this one's, so each ratio comes
from one run; and each grid's contents are compared: a digest of its lists (start table and
primitive ids) and, with --skip (both builds make their grids under MPRT_SKIP=1, so that they mark
the voxels to jump from), its count of jump voxels (the empty flags and jump values follow from
the lists), which must be equal -- the script exits 1 if any differs.  Without --skip each build
makes the grid its default walk needs (builds since jumps became opt-in mark no jumps).

    git archive main | tar -x -C /tmp/before && (cd /tmp/before && python setup.py -q build_ext --inplace)
    python studies/03_bench/build.py --before /tmp/before/python [--scenes gears,tree] [--repeat 3] [--skip]
"""
from __future__ import annotations

import argparse
import hashlib
import os
import sys
import time

# numpy's BLAS threads would spin beside the timed builds and count in the process CPU time
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import mprt  # noqa: E402
from run import Before, serve  # noqa: E402  (the worker process of the other build)

PREPASS_DIMS = {
    "gears": [(21, 21, 5), (67, 67, 17), (119, 119, 30), (212, 212, 53), (378, 378, 94)],
    "tree": [(203, 203, 6), (645, 645, 20)],
}
DENSITIES = (8, 24)
SCENES = ("balls", "gears", "mount", "rings", "tetra", "tree")

_scenes: dict = {}


def scene(name):
    if name not in _scenes:
        _scenes[name] = mprt.Scene.spd(name)
    return _scenes[name]


def t_dims(name):
    """The subdivisions timed for scene `name`."""
    if name in PREPASS_DIMS:
        return PREPASS_DIMS[name]
    return [tuple(scene(name).default_grid(density=d, limit=1024)) for d in DENSITIES]


def t_build(name, dims, listing):
    """(CPU seconds of one build, digest of its lists, jump voxels, list entries)."""
    s = scene(name)
    t0 = time.process_time()
    g = mprt.Grid(s, tuple(dims), listing=listing)
    t = time.process_time() - t0
    start, ids = g.lists()
    st = g.stats()
    h = hashlib.sha256(start.tobytes())
    h.update(ids.tobytes())
    del g
    return t, h.hexdigest()[:16], int(st["jump_voxels"]), int(st["refs"])


MEASURES = {"t_build": t_build, "t_dims": t_dims,
            "t_version": lambda: os.path.dirname(mprt.__file__)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", help="a python folder holding the other build of mprt")
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--listing", default="exact", choices=("exact", "box"))
    ap.add_argument("--skip", action="store_true", help="both builds make their grids under MPRT_SKIP=1")
    a = ap.parse_args(argv)
    if a.skip:
        os.environ["MPRT_SKIP"] = "1"  # here and in the worker, which inherits the environment
    before = Before(a.before, __file__) if a.before else None
    print(f"after:  {os.path.dirname(mprt.__file__)}")
    if before:
        print(f"before: {before.version}")
    print(f"{'scene':6} {'subdivision':>14} {'voxels':>10} {'entries':>10} {'before s':>9} {'after s':>9}"
          f" {'speed-up':>8}  same", flush=True)
    bad = 0
    tot = [0.0, 0.0]
    for name in a.scenes.split(","):
        for dims in t_dims(name):
            here = there = None
            for _ in range(a.repeat):
                r = t_build(name, dims, a.listing)
                here = r if here is None or r[0] < here[0] else here
                if before:
                    r = before("t_build", name, dims, a.listing)
                    there = r if there is None or r[0] < there[0] else there
            keys = (1, 2, 3) if a.skip else (1, 3)  # digest, jump voxels, entries
            same = "" if not before else "yes" if all(there[k] == here[k] for k in keys) else "NO"
            bad += same == "NO"
            tot[1] += here[0]
            vox = dims[0] * dims[1] * dims[2]
            if before:
                tot[0] += there[0]
                print(f"{name:6} {'x'.join(map(str, dims)):>14} {vox:>10} {here[3]:>10} {there[0]:>9.4f}"
                      f" {here[0]:>9.4f} {there[0] / here[0]:>7.2f}x  {same}", flush=True)
            else:
                print(f"{name:6} {'x'.join(map(str, dims)):>14} {vox:>10} {here[3]:>10} {'':>9}"
                      f" {here[0]:>9.4f}", flush=True)
    if before:
        print(f"total  {'':>14} {'':>10} {'':>10} {tot[0]:>9.3f} {tot[1]:>9.3f} {tot[0] / tot[1]:>7.2f}x")
        before.close()
    if bad:
        print(f"{bad} grid(s) differ from the before build", file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(serve(MEASURES) if sys.argv[1:] == ["--serve"] else main())
