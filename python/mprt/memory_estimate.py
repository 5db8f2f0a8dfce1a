"""Memory estimates before long work: ``simulate``, ``explore`` and ``sweep`` refuse, with the
figures, what cannot fit.

Each estimate adds up the parts a run holds at its peak, from what is known before the work:

- the trace as loaded (visits, rays, samples, voxel lists, primitive table): from a trace
  file's array headers (read without its records) or, for a scene, from the resolution and
  the grid (a frame traced in memory has at least one primary ray and one visit a sample);
- the cost arrays (process, receive, send, flits: ``COSTS`` bytes a visit; counted for every
  engine, though the compiled replay of the default cost model prices the visits as it loads
  them and holds none of them unless a level 0 or a sample's estimate asks for them);
- the trace's check (``mprt.recordcheck``: 9 bytes a ray, freed before the costs are made);
- the engine's state: the compiled replay's visit infos (``COMPILED`` bytes a visit), its
  caches (sets x ways per PE, 8 bytes an entry, limited by the lines the data can fill, as
  ``c/src/replay_memory.c`` sizes them) and level 3's per-visit keys; SimPy's objects (per
  visit, per processor, per cached line); the timeline's event log (``--plot``, ``--report``);
- the fan-out: every worker of a sweep or an explorer holds its own trace.

The figures per record were measured with ``resource.getrusage`` (ru_maxrss) on traces of
balls:2 at 128x128 to 512x512 (README, "Bad input").  ``available()`` is ``MPRT_MEMORY_LIMIT``
when set (bytes, or with a unit: 512M, 8G, 1.5GiB), else MemAvailable from /proc/meminfo.
``Estimate.check`` raises ``MemoryRefused`` (a UsageError: exit 2) with one line, e.g.
``needs about 96.0 GiB (visits 64.0 GiB, caches 32.0 GiB), 7.2 GiB available``.
"""
from __future__ import annotations

import os
import re
import zipfile

import numpy as np

from .trace import tracefile, tracevalid
from ._lowlevel import RAY_DTYPE, VISIT_DTYPE
from .errors import UsageError

ENV = "MPRT_MEMORY_LIMIT"
GiB = 1 << 30

VISIT = VISIT_DTYPE.itemsize            # 48: a visit record as loaded
RAY = RAY_DTYPE.itemsize                # 32: a ray record
SAMPLE = 24                             # a sample's colour (float64 x 3)
COSTS = 28                              # process, receive, send (int64) and flits (int32) a visit
COMPILED = 25                           # the C replay's visit infos (8 packed; 16 + 8 when a visit lasts 2^24 cycles or more) and its children
COMPILED_RAY = 40                       # ... per ray while loading (ray_first, child_start, tree_of, child)
COMPILED_MEMORY = 12                    # level 3: the visits' memory keys (here and in C) and their lines
SIMPY = 16                              # SimPy's per-visit arrays (Replay: orders, next visits)
SIMPY_PROC = 4096                       # a SimPy processor: Stage, Fifo stores, processes, events
SIMPY_LINE = 100                        # a line held in a SimPy cache (int in a list in a dict)
SIMPY_SET = 150                         # a SimPy cache set that was used (list, dict entry)
TIMELINE = 600                          # the event log as a timeline: two events a visit as tuples
TIMELINE_VISITS = 1 << 22               # the compiled replay logs events for traces up to this size
LOAD_COPY = 256 << 20                   # traces above this size are memory-mapped, not read through a copy
VOXEL = 8                               # a voxel's list start, in the C grid and in the trace
ENTRY = 8                               # a list entry, in the C grid and in the trace
MARGIN = 1.1                            # allocator slack, temporaries
TRACE_PARTS = ("visits", "rays", "samples", "grid")


def parse_size(text: str) -> int:
    """Bytes from '123456', '512M', '8G', '1.5GiB', '2 TB' (units of 1024)."""
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+)\s*([kKmMgGtT]?)(i?[bB])?\s*", str(text))
    if not m:
        raise UsageError(f"{ENV}={text!r}: give bytes, or a number with K, M, G or T (e.g. 8G)")
    scale = 1 << (10 * " KMGT".index(m.group(2).upper() or " "))
    return int(float(m.group(1)) * scale)


def available() -> tuple[int, str]:
    """(bytes this process may still take, where that figure comes from)."""
    env = os.environ.get(ENV)
    if env:
        return parse_size(env), ENV
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024, "MemAvailable"
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"), "free pages"
    except (ValueError, OSError, AttributeError):
        return 1 << 62, "unknown"


def size_text(n: float) -> str:
    for unit, scale in (("TiB", 1 << 40), ("GiB", GiB), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if n >= scale:
            return f"{n / scale:.1f} {unit}"
    return f"{int(n)} bytes"


class MemoryRefused(UsageError):
    """A run refused before its work: it would need more memory than is available."""


class Estimate:
    """Named parts in bytes; ``total`` with the margin."""

    def __init__(self, what: str = "", parts: dict | None = None, floor: bool = False):
        self.what = what               # after the figures: "for 4 workers"
        self.parts = {k: v for k, v in (parts or {}).items() if v}
        self.floor = floor             # a lower bound (records per sample unknown before tracing)

    def add(self, name: str, nbytes: float) -> "Estimate":
        if nbytes:
            self.parts[name] = self.parts.get(name, 0) + int(nbytes)
        return self

    def scaled(self, k: int, why: str) -> "Estimate":
        """The same parts held ``k`` times over (``why``: by whom)."""
        return Estimate(why, {n: v * k for n, v in self.parts.items()}, self.floor)

    @property
    def total(self) -> int:
        """The peak: what the trace holds, then the larger of its reading copy (gone once read)
        and what the work after it holds, with the margin."""
        held = sum(v for k, v in self.parts.items() if k in TRACE_PARTS)
        work = sum(v for k, v in self.parts.items() if k not in TRACE_PARTS and k != "reading")
        return int((held + max(self.parts.get("reading", 0), work)) * MARGIN)

    def text(self) -> str:
        work = sum(v for k, v in self.parts.items() if k not in TRACE_PARTS and k != "reading")
        shown = {k: v for k, v in self.parts.items() if k != "reading"} \
            if self.parts.get("reading", 0) <= work else {k: v for k, v in self.parts.items() if k in TRACE_PARTS
                                                           or k == "reading"}
        big = sorted(shown.items(), key=lambda kv: -kv[1])
        shown = ", ".join(f"{k} {size_text(v)}" for k, v in big[:4] if v >= 0.01 * self.total)
        return f"{'at least ' if self.floor else ''}about {size_text(self.total)}" + (f" ({shown})" if shown else "")

    def check(self, avail: tuple[int, str] | None = None) -> None:
        """Raise MemoryRefused with the figures when the estimate exceeds what is available."""
        have, source = avail or available()
        if self.total > have:
            where = source if source == ENV else f"{source}; {ENV}=SIZE overrides"
            raise MemoryRefused(f"needs {self.text()}{' ' + self.what if self.what else ''}, {size_text(have)} "
                                f"available ({where})")


# ---- traces ---------------------------------------------------------------------------------

def file_counts(path) -> dict | None:
    """Counts of a trace file's records from its members' .npy headers (no records read):
    visits, rays, voxel_ids, prims, and whether it loads into memory (compressed or small);
    None when the file cannot be read so (its reader then names the fault)."""
    try:
        size = os.path.getsize(path)
        with zipfile.ZipFile(path) as z:
            meta = tracefile._read_meta(path, z, set(z.namelist()))
            tracevalid.check_meta(meta, size)
            g = meta["grid"]
            out = {"file_bytes": size, "voxels": g[0] * g[1] * g[2]}
            for name, key in (("visits", "visits"), ("rays", "rays"), ("voxel_ids", "voxel_ids"),
                              ("prim_kind", "prims"), ("samples", "samples")):
                info = z.getinfo(name + ".npy")
                with z.open(info) as f:
                    read = {(1, 0): np.lib.format.read_array_header_1_0,
                            (2, 0): np.lib.format.read_array_header_2_0}[np.lib.format.read_magic(f)]
                    shape = read(f, max_header_size=1 << 16)[0]
                out[key] = int(np.prod(shape[:1])) if key != "samples" else int(np.prod(shape[:2]))
                if name == "visits":
                    out["in_memory"] = info.compress_type != zipfile.ZIP_STORED or size <= LOAD_COPY
        return out
    except Exception:       # noqa: BLE001  any fault is the reader's to name
        return None


def trace_counts(trace) -> dict:
    m = trace.meta
    g = m.get("grid") or [0, 0, 0]
    return {"visits": len(trace.visits), "rays": len(trace.rays), "voxel_ids": len(trace.voxel_ids),
            "prims": len(trace.prim_kind), "samples": int(np.prod(np.shape(trace.samples)[:2])),
            "voxels": int(np.prod(g)), "in_memory": True, "loaded": True}


def frame_counts(width: int, height: int, dims, prims: int) -> dict:
    """The least a frame traced in memory holds: a primary ray and a visit a sample."""
    px = int(width) * int(height)
    return {"visits": px, "rays": px, "voxel_ids": prims, "prims": prims, "samples": px,
            "voxels": int(np.prod([int(d) for d in dims])), "in_memory": True, "loaded": True, "floor": True}


def _trace_parts(e: Estimate, c: dict) -> None:
    records = c["visits"] * VISIT + c["rays"] * RAY
    e.add("visits", c["visits"] * VISIT).add("rays", c["rays"] * RAY)
    e.add("samples", c["samples"] * SAMPLE)
    e.add("grid", c.get("voxels", 0) * VOXEL + c.get("voxel_ids", 0) * ENTRY + c.get("prims", 0) * 12)
    if c.get("in_memory") and not c.get("loaded"):
        e.add("reading", records)     # read through a copy (a compressed or small file)


# ---- the replay -----------------------------------------------------------------------------

def memory_figures(memory, tag: str, mc) -> tuple[int, int]:
    """(span, reads) of a local memory's data in a trace (``memory``: its fidelity MemoryData):
    the lines its data spans outside resident memory, as the C replay counts them (the highest
    line + 1), and the lines the trace's visits read from it in all."""
    data = memory.get(tag, mc.resident, mc.cache.line if mc.cache is not None else 32)[0]
    lines, per = data["lines"], np.diff(data["line_start"])
    return (int(lines.max()) + 1 if len(lines) else 0), memory.reads(tag, per)


def cache_entries(cache, span: int) -> tuple[int, int]:
    """(sets, entries) of one PE's cache as the C replay sizes it (replay_memory.c cache_shape)."""
    nsets = cache.size // (cache.line * cache.ways)
    nsets = min(nsets, max(span, 1))
    ways = min(cache.ways, -(-max(span, 1) // nsets))
    return nsets, nsets * ways


def replay_parts(e: Estimate, config, engine: str, visits: int, rays: int, figures=None,
                 timeline: bool = False) -> None:
    """The cost arrays and the engine's state for one configuration.  ``figures(tag, mc)``:
    (span, reads) of a local memory's data (``memory_figures``); without it (the trace not yet
    read) the caches are not counted: both engines size them by the data, not the configuration."""
    e.add("costs", visits * COSTS)
    procs = config.pes * sum(s.replicas for s in config.stages)
    level3 = config.ic_memory is not None or config.sc_memory is not None
    if engine == "compiled":
        e.add("replay", visits * COMPILED + rays * COMPILED_RAY + procs * 256)
        if timeline and visits <= TIMELINE_VISITS:
            e.add("timeline", visits * TIMELINE)
    elif engine == "simpy":
        e.add("replay", visits * SIMPY + procs * SIMPY_PROC)
        if timeline:
            e.add("timeline", visits * TIMELINE)
    if not level3 or engine not in ("compiled", "simpy"):
        return
    e.add("memory data", visits * COMPILED_MEMORY)
    for tag in ("ic", "sc"):
        mc = getattr(config, f"{tag}_memory")
        if mc is None or mc.cache is None:
            continue
        if figures is None:
            continue
        span, reads = figures(tag, mc)
        nsets, entries = cache_entries(mc.cache, span)
        if engine == "compiled":
            e.add("caches", config.pes * (entries * 8 + nsets * 8))
        else:     # sets made when used, lines filled when read: at most the reads over all PEs
            lines = min(config.pes * min(entries, span), reads)
            e.add("caches", lines * SIMPY_LINE + min(config.pes * nsets, lines) * SIMPY_SET)


def for_replay(counts: dict, config, engine: str, figures=None, timeline: bool = False,
               what: str = "") -> Estimate:
    """Peak memory of replaying a trace (counts from ``file_counts``, ``trace_counts`` or
    ``frame_counts``) on a configuration with an engine (compiled, simpy, analytical)."""
    e = Estimate(what, floor=bool(counts.get("floor")))
    _trace_parts(e, counts)
    replay_parts(e, config, engine, counts["visits"], counts["rays"], figures, timeline)
    return e


def check_replay(counts: dict, config, engine: str, figures=None, timeline: bool = False,
                 what: str = "") -> Estimate:
    e = for_replay(counts, config, engine, figures, timeline, what)
    e.check()
    return e


# ---- sweep and explore ----------------------------------------------------------------------

def for_frames(what: str, frames, workers: int) -> Estimate:
    """``frames``: (width, height, dims, prims) each a worker may hold at once (the largest
    counts); the whole held by each of ``workers`` processes."""
    e = Estimate(what, floor=True)
    for w, h, dims, prims in frames:
        c = frame_counts(w, h, dims, prims)
        _trace_parts(e, c)
        e.add("costs", c["visits"] * (COSTS + COMPILED))
    return e.scaled(workers, f"for {workers} workers") if workers > 1 else e


# ---- the commands ---------------------------------------------------------------------------

CACHE_LIMIT = 1 << 28                   # the compiled replay's cache entries over all PEs (mprt.h)


def compiled_cache_overflow(config, figures) -> str | None:
    """Why the compiled replay refuses this configuration's caches (None: it does not):
    ``figures(tag, memory_config)``: (span, reads) of memory ``tag``'s data (``memory_figures``)."""
    for tag in ("ic", "sc"):
        mc = getattr(config, f"{tag}_memory")
        if mc is None or mc.cache is None or config.pes * (mc.cache.size // mc.cache.line) <= CACHE_LIMIT:
            continue            # (sets x ways <= size / line: no data needed to know it fits)
        per = cache_entries(mc.cache, figures(tag, mc)[0])[1]
        if per * config.pes > CACHE_LIMIT:
            return (f"the {tag.upper()} caches would hold {config.pes} PEs x {per} entries per PE (sets x ways the "
                    f"data can fill), more than the compiled replay's 2^28 in all")
    return None


def check_simulate(counts: dict | None, plan, timeline: bool = False, loaded: bool = False) -> None:
    """Refuse (MemoryRefused) a simulate that cannot fit: before reading a trace file (its
    headers' counts, ``file_counts``) or tracing a scene (``frame_counts``), and again with the
    trace in hand (``loaded``: the trace itself already held).  ``plan``: (configuration at the
    level run, engine, figures of its memories' data or None), or None when the run will name a
    fault of its own."""
    if counts is None or plan is None:
        return
    cfg, engine, figures = plan
    e = Estimate(floor=bool(counts.get("floor")))
    if not loaded:
        _trace_parts(e, counts)
    replay_parts(e, cfg, engine, counts["visits"], counts["rays"], figures, timeline)
    e.check()


def workers_of(n: int | None) -> int:
    return max(int(n if n else os.cpu_count() or 1), 1)
