"""Tracing: ``trace(grid, ...) -> (image, Trace)``, every stage visit of every ray.

The library traces one tile of samples at a time (``Grid.trace_tile``).  Here
tiles are chosen (all, a list, or a random, stratified or regular sample), traced on a
pool of threads through a bounded window of reusable buffers, renumbered into
global ray ids in tile order (so the result is the same bits for any thread
count) and gathered in memory or streamed to disk in bounded memory.

This module also gives ``Grid`` its ``trace`` method (a thin call of
``trace``), so that the grid layer below does not depend on tracing.
"""
from __future__ import annotations

import math
import os
import shutil
import tempfile
import zlib
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
from tqdm import tqdm

from . import tracefile
from ._lowlevel import KINDS, RAY_DTYPE, VISIT_DTYPE, Rules
from .errors import InvalidArgument
from .grid import CONVENTIONS, Grid, render_desc
from .trace import OUTCOMES, RAY_KINDS, STAGES, Trace, load_trace


# ---- sample specifications: one grammar for every --sample (trace, simulate, explore) -------------
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
        sel = np.unique(np.asarray(list(tiles), dtype=np.int64))
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


class _Sink:
    """Where traced tiles' records go: memory, or raw files on disk (bounded memory)."""

    def __init__(self, directory=None, samples=0):
        self.dir = directory
        # Reserve generously without touching: pages never written cost
        # nothing, so every record page is faulted in once (growing later
        # copies).  16 rays and 128 visits per sample is over twice what any
        # SPD scene needs at 512x512 (rings: 58 visits); if the system will
        # not reserve that much address space, reserve less.
        n = 0 if directory else samples
        per_ray, per_visit = 16, 128
        while True:
            try:
                self.arrays = {"rays": np.empty(max(n * per_ray, 1 << 12), dtype=RAY_DTYPE),
                               "visits": np.empty(max(n * per_visit, 1 << 14), dtype=VISIT_DTYPE)}
                break
            except MemoryError:
                if per_visit <= 4:
                    raise
                per_ray, per_visit = max(per_ray // 2, 1), per_visit // 2
        self.count = {"rays": 0, "visits": 0}
        self.files = {}
        self.crc = {"rays": 0, "visits": 0}
        if directory:
            for k in self.arrays:
                self.files[k] = open(self.file(k), "wb")

    def file(self, key):
        return os.path.join(self.dir, key + ".bin")

    def add(self, key, arr):
        self.count[key] += len(arr)
        if self.dir:
            b = memoryview(np.ascontiguousarray(arr)).cast("B")
            self.crc[key] = zlib.crc32(b, self.crc[key])
            self.files[key].write(b)
            return
        n0, n1 = self.count[key] - len(arr), self.count[key]
        a = self.arrays[key]
        if n1 > len(a):  # grow by doubling: each record is copied O(1) times
            bigger = np.empty(max(n1, 2 * len(a)), dtype=a.dtype)
            tracefile.as_bytes(bigger)[: tracefile.as_bytes(a[:n0]).size] = tracefile.as_bytes(a[:n0])
            self.arrays[key] = a = bigger
        # byte views: a memcpy (structured assignment goes field by field)
        tracefile.as_bytes(a[n0:n1])[:] = tracefile.as_bytes(arr)

    def result(self, key):
        return self.arrays[key][: self.count[key]]

    def streamed(self):
        """The record files as tracefile.write_streamed takes them."""
        dtypes = {"rays": RAY_DTYPE, "visits": VISIT_DTYPE}
        return {k: (self.file(k), dtypes[k], self.count[k], self.crc[k]) for k in dtypes}

    def close(self):
        for f in self.files.values():
            f.close()


def _trace_one(grid: Grid, desc: dict, t: int, rect, b: dict):
    """Trace tile t into buffer set b (reused; grown when a tile needs more)."""
    i0, j0, i1, j1 = rect
    buf = b["samples"][: (j1 - j0) * (i1 - i0) * 3]
    while True:
        nr, nv, fitted = grid.trace_tile(desc, t, buf, b["rays"], b["visits"])
        if fitted:
            return buf.reshape(j1 - j0, i1 - i0, 3), nr, nv
        b["rays"] = np.empty(max(len(b["rays"]), int(nr * 1.5)), dtype=RAY_DTYPE)
        b["visits"] = np.empty(max(len(b["visits"]), int(nv * 1.5)), dtype=VISIT_DTYPE)


def _run_tiles(grid, desc, sel, rects, sink, samples, covered, bar):
    """Trace the tiles ``sel`` (sample rectangles ``rects``) on desc['threads'] threads and hand
    them to the sink in tile order.

    A window of tiles is in flight, each with its own buffer set: results are consumed in tile
    order, and no tile ever waits for a buffer held by a later one.  Buffers are reused, so
    memory is touched once."""
    threads = desc["threads"]
    window = threads + 1
    ts = desc["tile"]
    free = [{"samples": np.empty(ts * ts * 3), "rays": np.empty(ts * ts * 8, dtype=RAY_DTYPE),
             "visits": np.empty(ts * ts * 64, dtype=VISIT_DTYPE)} for _ in range(window)]
    with ThreadPoolExecutor(max_workers=threads) as pool:
        pending = deque()
        todo = iter(zip(sel, rects))

        def submit():
            t, rect = next(todo, (None, None))
            if t is not None:
                b = free.pop()
                pending.append((pool.submit(_trace_one, grid, desc, int(t), rect, b), rect, b))

        for _ in range(window):
            submit()
        while pending:
            fut, (i0, j0, i1, j1), b = pending.popleft()
            buf, nr, nv = fut.result()
            offset = sink.count["rays"]
            rays, visits = b["rays"][:nr], b["visits"][:nv]
            rays["id"] += offset
            np.add(rays["parent"], offset, out=rays["parent"], where=rays["parent"] >= 0)
            visits["ray"] += offset
            sink.add("rays", rays)
            sink.add("visits", visits)
            samples[j0:j1, i0:i1] = buf
            covered[j0:j1, i0:i1] = True
            free.append(b)
            submit()
            if bar:
                bar.update(1)


def trace(grid: Grid, width=0, height=0, rules="paper", threshold=None, max_depth=0, mailbox=False, ambient=None,
          tile=None, threads=1, tiles=None, sample=None, path=None, progress=False, conventions=None,
          max_rays=None):
    """Trace (a subset of) the image recording every stage visit; returns (image, Trace).

    The render options are those of ``Grid.render``; ``tile`` is the tile edge in samples (the
    unit of subsets), ``tiles`` a list of tile numbers or ``sample`` (``SAMPLE_GRAMMAR``'s
    random, stratified or regular) traces a subset (other samples are NaN).  With ``path`` the records stream
    to disk tile batch by tile batch and the trace is saved there (memory stays bounded by the
    batch and the image); ``progress`` shows a progress bar."""
    desc = grid.resolve(render_desc(width, height, rules, threshold, max_depth, threads, tile, ambient, mailbox,
                                    conventions, max_rays))
    tiling = grid.tiling(desc)
    sw, sh, tx, ty = tiling
    sel = select_tiles(tx * ty, tiles, sample, tiles_x=tx)
    rects = [grid.tile_rect(desc, int(t)) for t in sel]
    samples = np.zeros((sh, sw, 3), dtype=np.float64)
    covered = np.zeros((sh, sw), dtype=bool)
    tmpdir = sink = bar = None
    try:
        if path:
            tmpdir = tempfile.mkdtemp(prefix="mprt-trace-", dir=os.path.dirname(os.path.abspath(path)))
        sink = _Sink(tmpdir, samples=sum((i1 - i0) * (j1 - j0) for i0, j0, i1, j1 in rects))
        if progress:
            bar = tqdm(total=len(sel), unit="tile", desc="trace", leave=False)
        _run_tiles(grid, desc, sel, rects, sink, samples, covered, bar)
        sink.close()
        meta = _meta(grid, desc, tiling, sel, tiles, sample)
        if not covered.all():
            samples[~covered] = np.nan
        arrays = grid_arrays(grid)
        arrays["samples"] = samples
        if path:
            tracefile.write_streamed(path, meta, sink.streamed(), arrays)
            result = load_trace(path, mmap=True, verify=False)
        else:
            arrays["rays"] = sink.result("rays")
            arrays["visits"] = sink.result("visits")
            result = Trace.from_arrays(meta, arrays)
    finally:
        if bar:
            bar.close()
        if sink:
            sink.close()
        if tmpdir:
            shutil.rmtree(tmpdir, ignore_errors=True)
    return result.image, result


def _meta(grid: Grid, desc: dict, tiling, sel, tiles, sample) -> dict:
    info = grid.scene.info()
    gs = grid.stats()
    sw, sh, tx, ty = tiling
    return {
        "format": tracefile.FORMAT,
        "version": tracefile.FORMAT_VERSION,
        "scene": grid.scene.name,
        "scene_sha256": grid.scene.content_hash(),
        "precision": grid.scene.precision,
        "grid": list(grid.n),
        "grid_lo": gs["lo"],
        "grid_hi": gs["hi"],
        "camera": {k: info[k] for k in ("from", "at", "up", "angle", "hither")},
        "width": desc["width"],
        "height": desc["height"],
        "samples_w": sw,
        "samples_h": sh,
        "rules": Rules(desc["rules"]).name.lower(),
        "threshold": desc["threshold"],
        "max_depth": desc["max_depth"],
        "max_rays": desc["max_rays"],
        "ambient": desc["ambient"],
        "mailbox": bool(desc["mailbox"]),
        "listing": grid.listing,
        "conventions": {k: CONVENTIONS[k][desc[k] - 1] for k in CONVENTIONS},
        "tile": desc["tile"],
        "tiles_total": int(tx * ty),
        "tiles": [int(t) for t in sel],
        "subset": None if tiles is None and sample is None else (str(sample) if sample else "tiles"),
        "lights": info["lights"],
        "kinds": list(KINDS),
        "stages": list(STAGES),
        "outcomes": list(OUTCOMES),
        "ray_kinds": list(RAY_KINDS),
    }


def grid_arrays(grid: Grid) -> dict:
    """What a trace carries of its grid and scene: the voxel lists (voxel_start, voxel_ids)
    and the primitive table (prim_kind, prim_words, prim_material)."""
    start, ids = grid.lists()
    prims = grid.scene.prim_table()
    return {"voxel_start": start, "voxel_ids": ids, "prim_kind": prims["kind"], "prim_words": prims["words"],
            "prim_material": prims["material"]}


def _grid_trace(self: Grid, width=0, height=0, rules="paper", threshold=None, **options):
    """Trace (a subset of) the image recording every stage visit; returns (image, Trace).
    See mprt.tracing.trace for the options (threads, tile, tiles, sample, path for streaming
    to disk, progress, mailbox, max_depth, ambient)."""
    return trace(self, width, height, rules, threshold, **options)


_grid_trace.__name__, _grid_trace.__qualname__ = "trace", "Grid.trace"
Grid.trace = _grid_trace
