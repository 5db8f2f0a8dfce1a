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


def check_explore(scene, width: int, height: int, space, grid, fraction, sample, workers) -> Estimate:
    """An explorer's processes each hold the search's low-resolution frame and the full
    resolution's (the samples of the whole frame; records of the sampled tiles, or of the
    frame), at the largest subdivision of the space (or ``grid``)."""
    from .evaluate import grid_dims
    from .prepass import low_resolution

    subs = [grid if isinstance(grid, tuple) else (grid,)] if grid is not None else space.subdivisions()
    voxels = max(int(np.prod(grid_dims(scene, s, space.shape))) for s in subs)
    prims = scene.info()["prims"]
    f = max(1, min(width, height) // 64) if fraction is None else fraction
    if sample == "auto":
        sample = "stratified:16:1" if width * height > 256 * 256 and f > 1 else None
    frames = [(*low_resolution(width, height, f), (voxels,), prims)] if f > 1 else []
    e = for_frames("", frames + [(width, height, (voxels,), prims)], 1)
    if f > 1 and sample:      # the full frame's samples, only a few tiles' records
        traced = min(width * height, 16 * 16 * 16)
        e.parts["visits"] -= (width * height - traced) * VISIT
        e.parts["rays"] -= (width * height - traced) * RAY
        e.parts["costs"] -= (width * height - traced) * (COSTS + COMPILED)
    n = workers_of(workers)
    e = e.scaled(n + 1, f"for {n} workers and the explorer") if n > 1 else e
    e.check()
    return e
