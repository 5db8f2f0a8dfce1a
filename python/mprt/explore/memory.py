"""Memory estimates of ``mprt sweep`` and ``mprt explore`` before any work
(``mprt.memory_estimate``): every worker traces frames in memory, so the least each holds (a
sample's colour, a ray and a visit a pixel, the grid at the largest subdivision) times the
workers must fit the memory available; else one line with the figures (exit 2)."""
from __future__ import annotations

import numpy as np

from ..memory_estimate import COMPILED, COSTS, RAY, VISIT, Estimate, for_frames, workers_of


def check_sweep(spec: dict, workers: int | None) -> Estimate:
    """A sweep's workers each hold one traced frame (scene, subdivision) at a time; the largest
    scene and subdivision bound it.  Refuses (MemoryRefused) what cannot fit."""
    from ..scene import Scene
    from .evaluate import grid_dims

    prims, voxels = 0, 0
    for sc in spec["scenes"]:
        scene = Scene.load(sc)
        prims = max(prims, scene.info()["prims"])
        for sub in spec["subdivisions"]:
            voxels = max(voxels, int(np.prod(grid_dims(scene, sub, spec["shape"]))))
    e = for_frames("", [(spec["width"], spec["height"], (voxels,), prims)], workers_of(workers))
    e.check()
    return e


PROBE_PIXELS = 64         # the memory probe's frame: about this many pixels across


def check_workload(workload, workers: int, grid=None) -> Estimate:
    """Before any work: the explorer's processes each hold, at the full-resolution phase, one
    scene's whole frame traced (records, costs, the compiled replay's state) beside the search's
    low-resolution traces.  The records a frame makes are measured, not guessed: each scene is
    traced whole at about PROBE_PIXELS across at the subdivision the search starts from, and its
    visits and rays per sample scaled to the frame.  The largest scene, held by every worker
    (and the explorer), must fit the memory available; else MemoryRefused with the figures."""
    from .prepass import low_resolution
    from .subdivision import start_dims

    worst, worst_name = None, ""
    for e in workload:
        scene = e.load()
        w, h = e.res or scene.info()["resolution"]
        dims = tuple(grid) if grid is not None else start_dims(scene)
        lw, lh = low_resolution(w, h, max(1, min(w, h) // PROBE_PIXELS))
        _, tr = scene.grid(dims).trace(lw, lh, **e.trace_options())
        scale = (w * h) / (lw * lh)                   # records per sample as the probe's
        visits, rays = len(tr.visits) * scale, len(tr.rays) * scale
        est = Estimate(f"for {e.name}'s {w}x{h} frame", floor=False)
        est.add("visits", visits * VISIT).add("rays", rays * RAY).add("costs", visits * (COSTS + COMPILED))
        est.add("samples", w * h * 24)
        est.add("grid", int(np.prod(dims)) * 8 + scene.info()["prims"] * 12)
        if worst is None or est.total > worst.total:
            worst, worst_name = est, e.name
    n = workers_of(workers)
    out = worst.scaled(n + 1, f"for {worst_name}'s frame held by {n} worker(s) and the explorer") if n > 1 else worst
    out.check()
    return out
