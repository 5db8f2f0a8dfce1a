"""Tracing: ``trace(grid, ...) -> (image, Trace)``, every stage visit of every ray.

The library traces a run of tiles in one call (``Grid.trace_tiles``), writing
each record once, in place, numbered as one trace.  Here tiles are chosen (all,
a list, or a random, stratified or regular sample, ``sampling.py``) and traced
on one thread straight into the trace's arrays (kept for the next trace, so
their pages are touched once per process) or into a chunk written to the trace
file while tracing (bounded memory); on more threads, groups of tiles go through
a bounded window of reused buffers and are renumbered in tile order as they are
copied into the trace's arrays, or into the file by its writer, so the result is
the same bits for any thread count.

This module also gives ``Grid`` its ``trace`` method (a thin call of
``trace``), so that the grid layer below does not depend on tracing.
"""
from __future__ import annotations

import json
import sys
import threading
from collections import deque
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from . import tracefile, tracevalid, tracewriter
from .._lowlevel import KINDS, RAY_DTYPE, VISIT_DTYPE, Rules, binding
from ..errors import InvalidArgument
from ..grid import CONVENTIONS, Grid, render_desc
from .core import OUTCOMES, RAY_KINDS, STAGES, Trace
from .sampling import RUN_TREES, SAMPLE_GRAMMAR, Sampling, block_shape, blocks, choose, select_tiles  # noqa: F401


# Record arrays kept for the next trace in this process, so that a trace writes into pages it
# (or one before it) has touched already instead of having the kernel fault in and zero fresh
# ones: most of what tracing costs over rendering was that first touch.  A trace in memory
# returns views of its arrays; an entry is taken again only once nothing else refers to its
# arrays (the trace that held them is gone).  release_buffers() gives the memory back.
_POOL: list[dict] = []
_POOL_ENTRIES = 2
# Reserved per sample for a trace in memory (address space: pages never written cost nothing).
# 16 rays and 128 visits per sample is over twice what any SPD scene needs at 512x512 (rings:
# 58 visits); a trace needing more grows its arrays by doubling.
RESERVE_RAYS, RESERVE_VISITS = 16, 128
# The chunks a trace streamed to disk records into, one after the other, each written while the
# next ones fill (bounded memory: 22 MB); larger ones cost fewer thread switches, smaller ones
# fewer pages to touch (on a virtual machine a page touched first costs a host fault).
CHUNK_RAYS, CHUNK_VISITS, CHUNKS = 1 << 15, 1 << 17, 3
# Tiles per library call: progress is reported between calls.
TILES_PER_CALL = 64


_POOL_LOCK = threading.Lock()   # traces may run at once on several Python threads
_COPY = binding()               # the library's record copy (renumbering on the way)


def release_buffers() -> None:
    """Give back the record arrays kept for the next trace (see ``_POOL``)."""
    with _POOL_LOCK:
        _POOL.clear()
        _GROUP_BUFFERS.clear()


def _idle(entry: dict) -> bool:
    """Nothing but the pool refers to the entry's arrays (no trace holds a view of them)."""
    return all(sys.getrefcount(entry[k]) <= 2 for k in ("rays", "visits"))


def _reserve(rays: int, visits: int) -> dict:
    """Record arrays of at least rays and visits entries: an idle pooled pair when one is large
    enough, else a new pair (pooled while there is room, or in place of an idle smaller pair)."""
    for entry in _POOL:
        if len(entry["rays"]) >= rays and len(entry["visits"]) >= visits and _idle(entry):
            return entry
    while True:
        try:
            entry = {"rays": np.empty(rays, dtype=RAY_DTYPE), "visits": np.empty(visits, dtype=VISIT_DTYPE)}
            break
        except MemoryError:   # the system will not reserve that much address space: reserve less
            if visits <= 1 << 14:
                raise
            rays, visits = max(rays // 2, 1 << 12), visits // 2
    idle = [k for k, e in enumerate(_POOL) if _idle(e)]
    if len(_POOL) < _POOL_ENTRIES:
        _POOL.append(entry)
    elif idle:
        _POOL[idle[0]] = entry
    return entry


class _Records:
    """Where a trace's records go: straight into the trace's arrays in memory, or (``writer``, a
    tracewriter.TraceWriter) into a ring of ``CHUNKS`` reused chunks: each time one fills, the
    writer writes it to the file in the background while the next ones fill.  With ``direct``
    (records made on threads, in buffer sets of their own: see ``add``) a writer takes them
    from those sets, no chunk between."""

    def __init__(self, samples: int, writer=None, direct: bool = False):
        self.writer = writer
        self.direct = bool(writer and direct)
        self.held: deque = deque()             # direct: buffer sets the writer may still read
        with _POOL_LOCK:   # taken (referred to here) before another trace looks for idle arrays
            if self.direct:
                self.arrays = {"rays": np.empty(0, RAY_DTYPE), "visits": np.empty(0, VISIT_DTYPE)}
            elif writer:   # the ring: parts of one pooled pair (pages a trace before may have touched)
                whole = _reserve(CHUNKS * CHUNK_RAYS, CHUNKS * CHUNK_VISITS)
                self.chunks = [{k: whole[k][i * size:(i + 1) * size]
                                for k, size in (("rays", CHUNK_RAYS), ("visits", CHUNK_VISITS))}
                               for i in range(CHUNKS)]
                self.arrays = self.chunks[0]
            else:
                self.arrays = dict(_reserve(max(samples * RESERVE_RAYS, CHUNK_RAYS),
                                            max(samples * RESERVE_VISITS, CHUNK_VISITS)))
        self.n = {"rays": 0, "visits": 0}        # in the arrays
        self.first_ray = 0                        # the number of the arrays' first ray

    def room(self):
        """The free ends of the arrays."""
        return self.arrays["rays"][self.n["rays"]:], self.arrays["visits"][self.n["visits"]:]

    def commit(self, nrays: int, nvisits: int) -> None:
        """The library recorded nrays and nvisits more into room()."""
        self.n["rays"] += nrays
        self.n["visits"] += nvisits

    def make_room(self, rays: int = 0, visits: int = 0) -> None:
        """Room for at least rays and visits more records (the sizes a tile needs), or with none
        given, room after a call that stopped short: the chunk handed to the writer, or the
        arrays grown by doubling (each record is copied O(1) times)."""
        if self.writer and (self.n["rays"] or self.n["visits"]):
            self.flush()
        for key, need in (("rays", rays), ("visits", visits)):
            a, n = self.arrays[key], self.n[key]
            if len(a) - n < need or not (self.writer or rays or visits):
                bigger = np.empty(max(n + need, 2 * len(a)), dtype=a.dtype)
                tracefile.as_bytes(bigger[:n])[:] = tracefile.as_bytes(a[:n])
                self.arrays[key] = bigger

    @property
    def holds(self) -> int:
        """The buffer sets ``add`` may keep at a time (held for the writer)."""
        return self.writer.depth if self.direct else 0

    def add(self, rays: np.ndarray, visits: np.ndarray, owner=None) -> list:
        """Append records numbered from 0 (one thread's tiles, in buffer set ``owner``),
        renumbered to follow the others as they are copied (in C, other threads running).
        Returns the buffer sets free again: ``owner`` at once, or with ``direct`` the sets the
        writer has let go (it reads them in the background; ``settle`` frees the rest)."""
        if self.direct:
            self.writer.write(rays, visits, self.first_ray)
            self.first_ray += len(rays)
            self.held.append(owner)
            return [self.held.popleft() for _ in range(len(self.held) - self.holds)]
        if len(self.arrays["rays"]) - self.n["rays"] < len(rays) or \
                len(self.arrays["visits"]) - self.n["visits"] < len(visits):
            self.make_room(len(rays), len(visits))
        offset = self.first_ray + self.n["rays"]
        r, v = self.room()
        _COPY.records_shift(rays, r, offset)
        _COPY.records_shift(visits, v, offset)
        self.commit(len(rays), len(visits))
        return [owner]

    def settle(self) -> list:
        """Wait for the writer to let go of the buffer sets it holds: returns them."""
        if self.held:
            self.writer.settle()
        out = list(self.held)
        self.held.clear()
        return out

    def flush(self) -> None:
        """Hand the chunk to the writer and go on in the next one (whose write the writer has
        finished: it has CHUNKS - 1 writes in flight at most); with ``direct``, nothing to do."""
        if self.direct:
            return
        self.writer.write(self.arrays["rays"][:self.n["rays"]], self.arrays["visits"][:self.n["visits"]])
        self.first_ray += self.n["rays"]
        self.n = {"rays": 0, "visits": 0}
        self.chunks.append(self.chunks.pop(0))
        self.arrays = self.chunks[0]

    def result(self, key):
        return self.arrays[key][: self.n[key]]


def _trace_group(grid: Grid, desc: dict, tiles: np.ndarray, samples: np.ndarray, b: dict):
    """Trace a group of tiles into buffer set b (reused; grown when the group needs more), rays
    numbered from 0: (nrays, nvisits)."""
    done = nr = nv = 0
    while True:
        n, r, v = grid.trace_tiles(desc, tiles[done:], samples, nr, b["rays"][nr:], b["visits"][nv:])
        if n:
            done, nr, nv, r, v = done + n, nr + r, nv + v, 0, 0
            if done == len(tiles):
                return nr, nv
        for key, have, need in (("rays", nr, r), ("visits", nv, v)):
            a = b[key]
            b[key] = np.empty(max(2 * len(a), have + need), dtype=a.dtype)
            tracefile.as_bytes(b[key][:have])[:] = tracefile.as_bytes(a[:have])


def _run_tiles(grid, desc, tiles: np.ndarray, records: _Records, samples: np.ndarray, bar):
    """Trace the tiles in order, their records handed to ``records`` in tile order.

    On one thread the library writes each record once, in place, into the trace's arrays (or
    the chunk streamed to disk), numbered as it goes.  On more, groups of tiles are traced into
    reused buffer sets, a bounded window of them in flight, and copied over in tile order (to a
    file, by the writer, from the sets themselves), so the records are the same bits for any
    thread count."""
    threads = desc["threads"]
    if threads == 1:
        i = 0
        while i < len(tiles):
            part = tiles[i:i + TILES_PER_CALL]
            rays, visits = records.room()
            n, nr, nv = grid.trace_tiles(desc, part, samples, records.first_ray + records.n["rays"], rays, visits)
            if n == 0:
                records.make_room(nr, nv)
                continue
            records.commit(nr, nv)
            if n < len(part):
                records.make_room()
            i += n
            if bar:
                bar.update(n)
        return
    window = threads + 1
    size = max(1, min(TILES_PER_CALL // 4, len(tiles) // (8 * threads)))
    groups = [tiles[i:i + size] for i in range(0, len(tiles), size)]
    ts = desc["tile"]
    sets = _take_buffer_sets(window + records.holds, size * ts * ts)
    try:
        _run_groups(grid, desc, groups, records, samples, bar, threads, list(sets), window)
    finally:   # the workers are done (the pool waits for them), the writer too: the sets are free
        records.settle()
        _give_back(sets)


def _run_groups(grid, desc, groups, records, samples, bar, threads, free, window):
    """The groups on threads, a window of them in flight, handed to records in order (buffer
    sets from ``free``: the window's, and those records may hold)."""
    with ThreadPoolExecutor(max_workers=threads) as pool:
        pending = deque()
        todo = iter(groups)

        def submit():
            group = next(todo, None)
            if group is not None:
                b = free.pop()
                pending.append((pool.submit(_trace_group, grid, desc, group, samples, b), b, len(group)))

        for _ in range(window):
            submit()
        while pending:
            fut, b, n = pending.popleft()
            nr, nv = fut.result()
            free.extend(records.add(b["rays"][:nr], b["visits"][:nv], b))
            submit()
            if bar:
                bar.update(n)


_GROUP_BUFFERS: list[dict] = []


_GROUP_SETS_KEPT = 16


def _take_buffer_sets(n: int, samples: int) -> list:
    """n buffer sets for groups of tiles on threads: those kept from an earlier trace (their
    pages touched already), new ones for the rest."""
    with _POOL_LOCK:
        sets = [_GROUP_BUFFERS.pop() for _ in range(min(n, len(_GROUP_BUFFERS)))]
    while len(sets) < n:
        sets.append({"rays": np.empty(max(samples * 8, 1 << 12), dtype=RAY_DTYPE),
                     "visits": np.empty(max(samples * 64, 1 << 14), dtype=VISIT_DTYPE)})
    return sets


def _give_back(sets: list) -> None:
    """Keep buffer sets for the next trace (a few)."""
    with _POOL_LOCK:
        _GROUP_BUFFERS.extend(sets[:max(0, _GROUP_SETS_KEPT - len(_GROUP_BUFFERS))])


def _setup(grid: Grid, width, height, rules, threshold, max_depth, mailbox, ambient, tile, threads, tiles, sample,
           conventions, max_rays, fill=True):
    """(desc, tiling, selected tiles, sample image (NaN where not traced, unless not ``fill``),
    samples traced)."""
    desc = grid.resolve(render_desc(width, height, rules, threshold, max_depth, threads, tile, ambient, mailbox,
                                    conventions, max_rays))
    tiling = grid.tiling(desc)
    sw, sh, tx, ty = tiling
    sel = select_tiles(tx * ty, tiles, sample, tiles_x=tx)
    subset = len(sel) < tx * ty
    samples = np.full((sh, sw, 3), np.nan) if subset and fill else np.empty((sh, sw, 3))
    nsamples = sum((i1 - i0) * (j1 - j0) for i0, j0, i1, j1 in (grid.tile_rect(desc, int(t)) for t in sel)) \
        if subset else sw * sh
    return desc, tiling, sel, samples, nsamples


def trace_records(grid: Grid, tiles, width=0, height=0, rules="paper", threshold=None, max_depth=0, mailbox=False,
                  ambient=None, tile=None, threads=1, conventions=None, max_rays=None):
    """The records alone (rays, visits) of the given tiles, as ``trace`` would record them (for a
    quick look at a trace's size: no image, grid tables or metadata).  The arrays are pooled: a
    trace after this one writes into their pages (touched already) once they are let go."""
    desc, _, sel, samples, nsamples = _setup(grid, width, height, rules, threshold, max_depth, mailbox, ambient,
                                             tile, threads, tiles, None, conventions, max_rays, fill=False)
    records = _Records(nsamples)
    _run_tiles(grid, desc, sel.astype(np.intc), records, samples, None)
    return records.result("rays"), records.result("visits")


def trace(grid: Grid, width=0, height=0, rules="paper", threshold=None, max_depth=0, mailbox=False, ambient=None,
          tile=None, threads=1, tiles=None, sample=None, path=None, progress=False, conventions=None,
          max_rays=None, compress=False):
    """Trace (a subset of) the image recording every stage visit; returns (image, Trace).

    The render options are those of ``Grid.render``; ``tile`` is the tile edge in samples (the
    unit of subsets), ``tiles`` a list of tile numbers or ``sample`` (``SAMPLE_GRAMMAR``'s
    random, stratified or regular) traces a subset (other samples are NaN).  With ``path`` the trace file is
    written while tracing, a bounded chunk of records at a time (memory stays bounded by the
    chunk and the image), beside ``path`` and moved onto it only when whole: an error or an
    interrupt leaves ``path`` as it was and no file beside it; with ``compress`` the records
    are deflated in it (streamed beside it first, then deflated into it: room for both is
    needed).  ``progress`` shows a progress bar."""
    if compress and not path:
        raise InvalidArgument("compress applies to a trace written to a file (path)")
    desc, tiling, sel, samples, nsamples = _setup(grid, width, height, rules, threshold, max_depth, mailbox, ambient,
                                                  tile, threads, tiles, sample, conventions, max_rays)
    writer = bar = None
    # the metadata and the grid's tables (the scene's content hash, a copy of the voxel lists, and
    # for a file their members) are made on a thread of their own while the tiles are traced
    side = ThreadPoolExecutor(max_workers=1)

    def made_aside():
        meta, arrays = _meta(grid, desc, tiling, sel, tiles, sample), grid_arrays(grid)
        # to disk: the file's members of the grid and scene, stored compactly and deflated, too
        return meta, arrays, tracewriter.StaticMembers(meta, arrays) if path else None
    static = side.submit(made_aside)
    try:
        if path:
            writer = tracewriter.TraceWriter(path, depth=CHUNKS - 1, compress=compress)
        records = _Records(nsamples, writer, direct=desc["threads"] > 1)
        if progress:
            from tqdm import tqdm      # (here: importing it costs tens of ms, paid only where a bar is shown)

            bar = tqdm(total=len(sel), unit="tile", desc="trace", leave=False)
        _run_tiles(grid, desc, sel.astype(np.intc), records, samples, bar)
        meta, arrays, members = static.result()
        arrays["samples"] = samples
        if path:
            records.flush()
            meta = writer.finish(meta, arrays, members)
            # the tracer's own records, mapped from the file as written (not read back, nor checked
            # again: like the trace in memory below); the metadata as a reader gets it
            arrays.update(writer.records())
            writer = None
            result = Trace.from_arrays(json.loads(json.dumps(meta, sort_keys=True)), arrays, path)
            tracevalid.mark_checked(result)
        else:
            arrays["rays"] = records.result("rays")
            arrays["visits"] = records.result("visits")
            result = Trace.from_arrays(meta, arrays)
            tracevalid.mark_checked(result)     # the tracer's own records
    finally:
        side.shutdown()
        if bar:
            bar.close()
        if writer:
            writer.abort()
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
