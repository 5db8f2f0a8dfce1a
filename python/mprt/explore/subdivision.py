"""The subdivision, free per axis: a scene's (nx, ny, nz) for one machine.

The subdivision is software: chosen per scene, for the machine at hand.  The time of a
scene against its subdivision is a valley along each axis (too few voxels: many tests per
ray; too many: many empty voxels walked), and scenes with a ground plane or a flat shape
want very different counts per axis (tree: 512x512x64; balls: 256x256x32).  ``descend``
finds the bottom in two moves:

1. along the rule's line: n voxels along the box's longest axis and the others in proportion
   (``Scene.default_grid``'s shape), stepping n one rung of ``values`` at a time from the start
   while the time falls (one rung past the best);
2. then per axis: each axis one rung up and down while the time falls, every axis in turn,
   until no move improves (a coordinate descent on the per-axis lattice ``values``).

It evaluates a few tens of grids, not the lattice's thousands; ``scan`` (every nx = ny and
nz of two lists) is what it is checked against.
"""
from __future__ import annotations

import numpy as np

# The per-axis values of the built-in space: about 1.5x apart (4, 6, 8, 12, ...), up to 512.
AXIS_VALUES = (1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128, 192, 256, 384, 512)
MAX_ROUNDS = 8


def lattices(values) -> tuple:
    """Three sorted per-axis lists from ``values``: one list for every axis, or three (nx, ny, nz)."""
    if len(values) == 3 and all(isinstance(v, (tuple, list)) for v in values):
        return tuple(tuple(sorted(int(x) for x in v)) for v in values)
    one = tuple(sorted(int(x) for x in values))
    return (one, one, one)


def proportional(extent, n: int, values=AXIS_VALUES) -> tuple:
    """Per axis, the rung of its lattice nearest (in ratio) n x the extent over the longest."""
    ext = np.maximum(np.asarray(extent, float), 0.0)
    longest = float(ext.max()) or 1.0
    out = []
    for e, vals in zip(ext, lattices(values)):
        want = max(n * e / longest, 1.0)
        out.append(min(vals, key=lambda v: (abs(np.log(v / want)), v)))
    return tuple(int(v) for v in out)


def start_dims(scene, values=AXIS_VALUES) -> tuple:
    """Where the descent starts: the library's default grid (about 8 N^(1/3) along the longest
    axis, the others in proportion), on the lattice."""
    info = scene.info()
    ext = np.subtract(info["hi"], info["lo"])
    n = max(scene.default_grid())
    return proportional(ext, n, values)


def descend(cycles_of, start, extent, values=AXIS_VALUES, say=None) -> tuple:
    """(dims, cycles, evaluated): the bottom ``descend`` finds from ``start`` (a point of the
    lattice: ``values`` for every axis, or one list per axis).  ``cycles_of(list of dims) -> list
    of cycles`` evaluates a batch (the neighbours of a step together, so they may run in
    parallel); ``evaluated`` maps every dims tried to its cycles."""
    axes = lattices(values)
    line = tuple(sorted(set().union(*axes)))
    seen: dict = {}

    def run(cands):
        new = [c for c in dict.fromkeys(cands) if c not in seen]
        if new:
            for c, y in zip(new, cycles_of(new)):
                seen[c] = float(y)
        return min(cands, key=lambda c: (seen[c], c))

    start = tuple(int(v) for v in start)
    best = run([start])
    # 1. the rule's line: n along the longest axis, up and down from the start
    longest = max(start)
    rung = int(np.argmin([abs(np.log(v / longest)) for v in line]))
    for step in (1, -1):
        r = rung
        while 0 <= r + step < len(line):
            r += step
            cand = proportional(extent, line[r], axes)
            if cand in seen and seen[cand] > seen[best]:
                break
            if run([best, cand]) != cand:
                break
            best = cand
    # 2. per axis, one rung at a time, until no axis moves
    for _ in range(MAX_ROUNDS):
        moved = False
        for axis in range(3):
            vals = axes[axis]
            while True:
                if best[axis] not in vals:
                    break
                i = vals.index(best[axis])
                cands = []
                for j in (i - 1, i + 1):
                    if 0 <= j < len(vals):
                        c = list(best)
                        c[axis] = vals[j]
                        cands.append(tuple(c))
                nxt = run([best] + cands)
                if nxt == best:
                    break
                best, moved = nxt, True
        if not moved:
            break
    if say:
        say(best, seen[best], len(seen))
    return best, seen[best], dict(seen)


def scan(cycles_of, xy_values, z_values) -> tuple:
    """(dims, cycles) of the best of every nx = ny in ``xy_values`` and nz in ``z_values``."""
    cands = [(a, a, b) for a in xy_values for b in z_values]
    got = cycles_of(cands)
    k = min(range(len(cands)), key=lambda i: (got[i], cands[i]))
    return cands[k], float(got[k])


__all__ = ["AXIS_VALUES", "descend", "lattices", "proportional", "scan", "start_dims"]
