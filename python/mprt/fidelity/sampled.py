"""Sampled replay: trace and replay a subset of the frame's tiles, scale up,
and give a 95% confidence interval from the spread between tiles.

Tiles are squares of ``tile`` x ``tile`` samples, numbered row by row as the
tracer numbers them.  A sample specification is one of

    random:N:SEED       N tiles drawn without replacement (simple random sampling)
    stratified:K:SEED   the frame cut into blocks of about K tiles (as square as
                        the tiling allows), one tile drawn at random in each
    regular:K           the same blocks, the tile nearest each block's centre

    runs:K:SEED[:R]     runs of R consecutive trees (default 1024) in the trace's
                        order, one run placed at random in each stretch of K x R trees
                        (needs the whole frame's trace: only the replay is sampled)

so ``stratified:16:SEED`` and ``runs:16:SEED`` replay about a sixteenth of the frame.

Estimator.  Each sampled tile t gets a size y_t: its level-0 time (the
analytical estimate of its trees alone, see ``analytical.py``).  The frame's
total size Y is estimated from the sample (each tile standing for its block, or
for N/n tiles under random sampling), the sample is replayed (its own time
T_s), and the frame's time is T = T_s x Y / y_s, y_s being the sample's size:
the ratio estimator, which keeps the replay's pipeline effects and lets the
tiles' spread set the uncertainty.  The interval is T +- 1.96 x (T / Y) x
sqrt(v), v the estimated variance of Y: for random sampling the usual one, for one tile per block the successive differences of
neighbouring blocks (blocks taken in a serpentine order), both with the
finite-population correction (a sample of every tile has no uncertainty).

Runs (the explorer's case: one trace of the whole frame, many designs) use the whole
frame's level-0 estimate L as the known total: T = T_s x L / L_s, L_s being level 0's
estimate of the sample (its runs strung together, as replayed), both in chunks of
RUN_SCALE_WINDOWS windows.  Runs keep the frame's
order (a run is a stretch of the trace, several windows long, so only its ends mix with
other parts of the frame), and level 0 of the whole frame removes the spread between
runs.  The interval comes from the spread of the runs' own ratios (each run's replayed
time, from the admission of its first tree to that of the next run's, against its level-0
time), with Student's t for the few runs there are.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InvalidArgument
from ..trace import PRIMARY, Trace
# The sample specifications and the choice of tiles are the tracer's (mprt trace --sample takes
# the same ones): re-exported here, where they began.
from ..trace.tracing import RUN_TREES, Sampling, block_shape, blocks, choose  # noqa: F401

RUN_SCALE_WINDOWS = 3   # runs: level 0's chunks when scaling (windows; smooths like the FIFOs do)
_EXTRA = ("voxel_start", "voxel_ids", "prim_kind", "prim_words", "prim_material", "samples")


def tree_tiles(trace, tile: int) -> np.ndarray:
    """The tile (edge ``tile`` samples) of each tree of a trace, by its primary's sample."""
    rays = trace.rays
    kind = np.asarray(rays["kind"])
    pix = np.asarray(rays["pixel"])[kind == PRIMARY].astype(np.int64)
    w = int(trace.meta["samples_w"])
    tiles_x = -(-w // tile)
    return (pix // w) // tile * tiles_x + (pix % w) // tile


def subset(trace, keep_trees: np.ndarray) -> Trace:
    """The trace of the trees where ``keep_trees`` (bool per tree) is true, renumbered (ray
    ids 0..n-1, parents and visits following), in the same order."""
    rays, visits = np.asarray(trace.rays), np.asarray(trace.visits)
    kind = rays["kind"]
    prim = np.flatnonzero(kind == PRIMARY)
    tree = np.cumsum(kind == PRIMARY) - 1
    keep_ray = np.asarray(keep_trees, bool)[tree]
    new_id = np.cumsum(keep_ray) - 1
    r = rays[keep_ray].copy()
    r["id"] = np.arange(len(r))
    par = r["parent"]
    r["parent"] = np.where(par >= 0, new_id[np.maximum(par, 0)], -1)
    vr = visits["ray"]
    keep_v = keep_ray[vr]
    v = visits[keep_v].copy()
    v["ray"] = new_id[v["ray"]]
    del prim
    arrays = {k: getattr(trace, k) for k in _EXTRA}
    arrays["rays"], arrays["visits"] = r, v
    meta = dict(trace.meta)
    return Trace.from_arrays(meta, arrays)


@dataclass
class Scaled:
    """A sampled replay's estimate of the whole frame's time."""

    cycles: int                 # estimated cycles of the whole frame
    interval: tuple             # (low, high) at 95%
    sample_cycles: int          # the sample's own replay
    fraction: float             # samples replayed / samples in the frame
    tiles: int                  # tiles replayed
    tiles_total: int
    scale: float                # cycles / sample_cycles


def scale(sample_cycles: int, sizes: np.ndarray, weights: np.ndarray, strata_order, tiles_total: int,
          fraction: float) -> Scaled:
    """The frame's time from the sample's replay: ``sizes`` per sampled tile (level-0 time),
    ``weights`` the tiles each stands for, ``strata_order`` the blocks' serpentine positions of
    the sampled tiles (None: random sampling)."""
    y = np.asarray(sizes, float)
    w = np.asarray(weights, float)
    n = len(y)
    ys = float(y.sum())
    Y = float((w * y).sum())
    if strata_order is None:
        f = n / tiles_total
        var = tiles_total ** 2 * (1 - f) * (float(np.var(y, ddof=1)) if n > 1 else 0.0) / n
    else:
        est = (w * y)[np.argsort(strata_order)]           # per block, in serpentine order
        d = np.diff(est)
        var = (1 - n / tiles_total) * (n / (2 * (n - 1))) * float((d * d).sum()) if n > 1 else 0.0
    ratio = sample_cycles / ys if ys > 0 else float(tiles_total) / max(n, 1)
    cycles = ratio * Y if ys > 0 else sample_cycles * ratio
    half = 1.96 * ratio * math.sqrt(var)
    return Scaled(cycles=int(round(cycles)), interval=(int(math.floor(cycles - half)), int(math.ceil(cycles + half))),
                  sample_cycles=int(sample_cycles), fraction=fraction, tiles=n, tiles_total=tiles_total,
                  scale=cycles / sample_cycles if sample_cycles else 0.0)


@dataclass
class SampledTrace:
    """The trace of a sample of a frame's tiles, and what scaling it up needs."""

    trace: Trace
    sampling: Sampling
    tile: int                   # tile edge, samples
    tiles: np.ndarray           # the tiles in the sample, sorted
    weights: np.ndarray         # tiles of the frame each stands for
    strata_order: object        # block position of each (None: random sampling)
    tiles_total: int
    fraction: float             # samples in the sample / samples in the frame
    visits: np.ndarray | None = None    # sample_trace: which of the source's visits the sample holds
    run_of: np.ndarray | None = None    # runs: each sampled tree's run (0, 1, ...)


def _tiling(meta, tile):
    w, h = int(meta["samples_w"]), int(meta["samples_h"])
    return -(-w // tile), -(-h // tile), w * h


def choose_runs(sampling: Sampling, tree_visits: np.ndarray) -> tuple:
    """(first tree, end tree) of each run: the frame's trees cut into about
    ntrees / (k x run) stretches (at least 2) of equal visits, and in each a run of consecutive trees
    holding at most a k-th of the stretch's visits (at least one tree), placed at random
    (seeded): the sample replays about a k-th of the frame's visits, no more."""
    v = np.asarray(tree_visits, np.int64)
    ntrees = len(v)
    n = max(min(2, ntrees), min(ntrees, int(round(ntrees / (sampling.k * sampling.run)))))   # 2: a spread
    cum = np.concatenate([[0], np.cumsum(v)])
    total = int(cum[-1])
    edges = np.searchsorted(cum, np.arange(n + 1) * total / n, "left")
    edges[0], edges[-1] = 0, ntrees
    u = np.random.default_rng(sampling.seed).random(n)
    starts, ends = np.zeros(n, np.int64), np.zeros(n, np.int64)
    for i in range(n):
        lo, hi = int(edges[i]), int(max(edges[i + 1], edges[i] + 1))
        want = (cum[hi] - cum[lo]) / sampling.k
        # the latest start that still leaves a k-th of the stretch's visits before hi
        last = max(lo, int(np.searchsorted(cum, cum[hi] - want, "right")) - 1)
        a = lo + int(u[i] * (last - lo + 1))
        b = int(np.searchsorted(cum, cum[a] + want, "right")) - 1     # at most a k-th
        starts[i], ends[i] = a, min(max(b, a + 1), hi)
    return starts, ends


def _sample_runs(trace, sampling: Sampling) -> SampledTrace:
    kind = np.asarray(trace.rays["kind"])
    tree_of_ray = np.cumsum(kind == PRIMARY) - 1
    ntrees = int((kind == PRIMARY).sum())
    vray = np.asarray(trace.visits["ray"])
    starts, ends = choose_runs(sampling, np.bincount(tree_of_ray[vray], minlength=ntrees))
    keep = np.zeros(ntrees, bool)
    run = np.full(ntrees, -1, np.int64)
    for i, (a, b) in enumerate(zip(starts, ends)):
        keep[a:b] = True
        run[a:b] = i
    sub = subset(trace, keep)
    sub.meta["sampled"] = {"sample": str(sampling), "runs": [[int(a), int(b)] for a, b in zip(starts, ends)]}
    keep_v = keep[tree_of_ray[vray]]
    return SampledTrace(sub, sampling, 0, starts, np.full(len(starts), float(sampling.k)), None,
                        ntrees, int(keep.sum()) / ntrees, keep_v, run[keep])


def sample_trace(trace, sampling: Sampling | str, tile: int | None = None) -> SampledTrace:
    """A sample of a whole frame's trace: the chosen tiles' trees (edge ``tile``, default
    the trace's own), or runs of its trees, in the trace's order.  A visit's costs depend
    on its ray's own visits and children only, so the source's visit costs sliced by
    ``.visits`` are the sample's."""
    sampling = Sampling.parse(sampling) if isinstance(sampling, str) else sampling
    meta = trace.meta
    tiles_done, total = meta.get("tiles"), meta.get("tiles_total")
    if tiles_done is not None and total is not None and len(tiles_done) != total:
        raise InvalidArgument(f"the trace holds {len(tiles_done)} of {total} tiles; sample a whole frame's trace")
    if sampling.method == "runs":
        return _sample_runs(trace, sampling)
    tile = int(tile or meta.get("tile") or 16)
    tx, ty, nsamples = _tiling(meta, tile)
    sel, weights, order = choose(sampling, tx, ty)
    tt = tree_tiles(trace, tile)
    keep = np.isin(tt, sel)
    sub = subset(trace, keep)
    sub.meta["sampled"] = {"sample": str(sampling), "tile": tile, "tiles": sel.tolist()}
    kind = np.asarray(trace.rays["kind"])
    keep_ray = keep[np.cumsum(kind == PRIMARY) - 1]
    return SampledTrace(sub, sampling, tile, sel, weights, order, tx * ty, int(keep.sum()) / nsamples,
                        keep_ray[np.asarray(trace.visits["ray"])])


def trace_sample(grid, sampling: Sampling | str, width: int = 0, height: int = 0, tile: int = 16,
                 **options) -> SampledTrace:
    """Trace only the chosen tiles of a frame (``options`` as ``Grid.trace``'s)."""
    from ..grid import render_desc
    from ..trace.tracing import trace as trace_grid

    sampling = Sampling.parse(sampling) if isinstance(sampling, str) else sampling
    if sampling.method == "runs":
        raise InvalidArgument(f"sample {sampling}: runs sample the replay of a whole frame's trace; trace the "
                              "frame (or sample its tiles: random, stratified, regular)")
    desc = grid.resolve(render_desc(width, height, options.get("rules", "paper"), options.get("threshold"),
                                    options.get("max_depth", 0), options.get("threads", 1), tile,
                                    options.get("ambient"), options.get("mailbox", False)))
    sw, sh, tx, ty = grid.tiling(desc)
    sel, weights, order = choose(sampling, tx, ty)
    _, tr = trace_grid(grid, width, height, tile=tile, tiles=sel.tolist(), **options)
    tr.meta["sampled"] = {"sample": str(sampling), "tile": tile, "tiles": sel.tolist()}
    return SampledTrace(tr, sampling, tile, sel, weights, order, tx * ty, len(tr.rays[tr.rays["kind"] == PRIMARY])
                        / (sw * sh))


def estimate_runs(st: SampledTrace, sample_cycles: int, analytical, frame, config, admitted) -> Scaled:
    """The frame's time from a replay of runs: T_s x L / L_s (L, L_s: level 0 of the whole
    frame, ``frame``, and of the sample, ``analytical``), its interval from the runs'
    ratios (``admitted``: when the sample replay admitted each of its trees)."""
    from scipy.stats import t as student

    L, Ls = frame.estimate(config, RUN_SCALE_WINDOWS).cycles, analytical.estimate(config, RUN_SCALE_WINDOWS).cycles
    ratio = sample_cycles / Ls if Ls > 0 else 1.0
    cycles = ratio * L
    n = len(st.tiles)
    half = 0.0
    if n > 1 and st.fraction < 1:
        x = np.concatenate([[0.0], np.cumsum(analytical.tree_times(config, st.run_of))])
        first = np.flatnonzero(np.concatenate([[True], st.run_of[1:] != st.run_of[:-1]]))
        a = np.asarray(admitted, float)
        m = np.append(a[first[1:]], float(sample_cycles)) - a[first]
        # a tree is admitted when rays about a window ahead of it retire: its run's interval
        # times the trees a window of rays earlier
        rays = np.concatenate([[0], np.cumsum(analytical.tree_rays)])
        back = np.searchsorted(rays, rays[first] - config.window * config.pes, "right") - 1
        lo = np.maximum(back, 0)
        hi = np.append(lo[1:], len(st.run_of))
        sizes = x[hi] - x[lo]
        e = m - sizes * (m.sum() / sizes.sum())
        var = (1 - st.fraction) * float((e * e).sum()) / (n * (n - 1)) / float(sizes.mean()) ** 2
        half = float(student.ppf(0.975, n - 1)) * L * math.sqrt(var)
    lo, hi = ((max(0, int(math.floor(cycles - half))), int(math.ceil(cycles + half))) if half
              else (int(round(cycles)),) * 2)
    return Scaled(cycles=int(round(cycles)), interval=(lo, hi), sample_cycles=int(sample_cycles),
                  fraction=st.fraction, tiles=n, tiles_total=st.tiles_total,
                  scale=cycles / sample_cycles if sample_cycles else 0.0)


def estimate(st: SampledTrace, evaluation, analytical, config, frame=None, admitted=None) -> Scaled:
    """The frame's time from a sampled replay (``evaluation``: its Evaluation at some level)
    with ``analytical`` (the sample's level-0 form) sizing its tiles for ``config``.  Runs
    (``runs:K:SEED``) also need ``frame``, the whole frame's level-0 form with the same
    costs, and ``admitted``, when a replay of the sample admitted each tree (``Compiled.
    admissions()``)."""
    if st.sampling.method == "runs":
        if frame is None or admitted is None:
            raise InvalidArgument("a sample of runs is scaled by the whole frame's level 0 (frame=) and its runs' "
                                  "admissions (admitted=)")
        return estimate_runs(st, evaluation.cycles, analytical, frame, config, admitted)
    tiles, sizes = analytical.tile_times(config, tree_tiles(st.trace, st.tile))
    if not np.array_equal(tiles, st.tiles):
        raise InvalidArgument("the sampled trace does not hold the tiles it was chosen with")
    return scale(evaluation.cycles, sizes, st.weights, st.strata_order, st.tiles_total, st.fraction)


def scaled_result(result, scaled: Scaled):
    """A copy of the sample's SimResult standing for the frame: cycles the estimate, every
    cycle figure of the stages scaled by the same factor (shares unchanged); counts stay
    the sample's."""
    import copy

    r = copy.deepcopy(result)
    f = scaled.scale
    r.cycles = scaled.cycles
    for d in list(r.stages.values()) + list(r.nodes.values()):
        for k in ("processing", "communication", "waiting", "memory_stall", "busy", "blocked", "idle"):
            if k in d:
                d[k] = int(round(d[k] * f))
    return r
