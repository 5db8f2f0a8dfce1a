"""Samples of a frame's tiles: one grammar for every ``--sample`` (trace, simulate, explore).

``Sampling`` is a parsed specification (random, stratified, regular, or runs of trees, which
sample a replay rather than the tiles to trace); ``blocks`` cuts the tiling into blocks of
about K tiles, ``choose`` picks the tiles and what each stands for, and ``select_tiles`` the
tiles a trace traces.  ``mprt.trace.tracing`` re-exports these names.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InvalidArgument

RUN_TREES = 1024        # runs: trees per run (several windows of model M's 256 rays)
SAMPLE_GRAMMAR = ("random:N:SEED (N tiles at random), stratified:K:SEED (one tile at random in each block of "
                  "about K tiles), regular:K (the tile nearest each block's centre), runs:K:SEED[:R] (runs of "
                  "consecutive trees holding a K-th of a whole frame's visits: a replay's sample)")


@dataclass(frozen=True)
class Sampling:
    """A parsed sample specification."""

    method: str          # "random", "stratified", "regular" or "runs"
    k: int               # random: tiles drawn; runs: one in k trees; otherwise: tiles per block
    seed: int | None
    run: int = RUN_TREES  # runs: trees per run

    @classmethod
    def parse(cls, text: str) -> "Sampling":
        parts = str(text).split(":")
        try:
            if parts[0] in ("random", "stratified") and len(parts) == 3 and int(parts[1]) >= 1:
                return cls(parts[0], int(parts[1]), int(parts[2]))
            if parts[0] == "regular" and len(parts) == 2 and int(parts[1]) >= 1:
                return cls("regular", int(parts[1]), None)
            if (parts[0] == "runs" and len(parts) in (3, 4) and int(parts[1]) >= 1
                    and (len(parts) == 3 or int(parts[3]) >= 1)):
                return cls("runs", int(parts[1]), int(parts[2]), int(parts[3]) if len(parts) == 4 else RUN_TREES)
        except ValueError:
            pass
        raise InvalidArgument(f"sample must be 'random:N:SEED', 'stratified:K:SEED', 'regular:K' or "
                              f"'runs:K:SEED[:R]' (N, K, R whole numbers >= 1), not {text!r}")

    def __str__(self) -> str:
        tail = f":{self.run}" if self.method == "runs" and self.run != RUN_TREES else ""
        return f"{self.method}:{self.k}" + (f":{self.seed}" if self.seed is not None else "") + tail


def block_shape(tiles_x: int, tiles_y: int, k: int) -> tuple:
    """(bx, by): blocks of bx x by tiles, bx * by about k, as square as the tiling allows."""
    by = max(1, min(tiles_y, int(round(math.sqrt(k)))))
    bx = max(1, min(tiles_x, int(round(k / by))))
    return bx, by


def blocks(tiles_x: int, tiles_y: int, k: int) -> list:
    """The blocks of about k tiles, in serpentine order (neighbours adjacent), each a list
    of tile numbers."""
    bx, by = block_shape(tiles_x, tiles_y, k)
    out = []
    for j, y0 in enumerate(range(0, tiles_y, by)):
        xs = list(range(0, tiles_x, bx))
        for x0 in (xs if j % 2 == 0 else xs[::-1]):
            out.append([y * tiles_x + x for y in range(y0, min(y0 + by, tiles_y))
                        for x in range(x0, min(x0 + bx, tiles_x))])
    return out


def choose(sampling: Sampling, tiles_x: int, tiles_y: int) -> tuple:
    """(tiles chosen, sorted; weights: the tiles each stands for; strata: block index per
    chosen tile, or None under random sampling)."""
    n = tiles_x * tiles_y
    if sampling.method == "random":
        m = min(sampling.k, n)
        rng = np.random.default_rng(sampling.seed)
        sel = np.sort(rng.choice(n, size=m, replace=False)).astype(np.int64)
        return sel, np.full(m, n / m), None
    bl = blocks(tiles_x, tiles_y, sampling.k)
    rng = np.random.default_rng(sampling.seed) if sampling.method == "stratified" else None
    pick = []
    for b in bl:
        pick.append(b[int(rng.integers(len(b)))] if rng is not None else b[(len(b) - 1) // 2])
    pick = np.asarray(pick, np.int64)
    order = np.argsort(pick, kind="stable")
    return pick[order], np.asarray([len(bl[i]) for i in order], float), order


def select_tiles(ntiles: int, tiles=None, sample=None, tiles_x: int | None = None) -> np.ndarray:
    """The tiles to trace: all, an explicit list, or a sample of the tiles (a ``Sampling`` or
    its text: random, stratified or regular, chosen by ``choose`` on a tiling ``tiles_x``
    tiles wide; default one row)."""
    if tiles is not None and sample is not None:
        raise InvalidArgument("give tiles or sample, not both")
    if tiles is not None:
        sel = np.array(sorted({int(t) for t in tiles}), dtype=np.int64)
        if sel.size == 0 or sel[0] < 0 or sel[-1] >= ntiles:
            raise InvalidArgument(f"tiles must be in 0..{ntiles - 1}")
        return sel
    if sample is None:
        return np.arange(ntiles, dtype=np.int64)
    s = Sampling.parse(sample) if isinstance(sample, str) else sample
    if s.method == "runs":
        raise InvalidArgument(f"sample {s}: runs sample the replay of a whole frame's trace, not the tiles to "
                              "trace; use random, stratified or regular")
    tx = int(tiles_x or ntiles)
    return choose(s, tx, ntiles // tx)[0]
