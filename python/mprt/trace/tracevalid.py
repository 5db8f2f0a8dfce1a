"""One validation of a trace, run by every reader (``load_trace``, ``Trace.validate``,
``stats``, ``simulate`` on both engines): a trace that passes holds only values every
model can index and price, and a trace that fails raises one ``TraceError`` naming the
member and the field.

- ``check_meta``: ``meta.json`` against a schema: types and ranges of every field the
  readers use (grid, width, height, samples, rules, lights, tiles, ...), before any array
  is read.  The grid's voxel count is bounded by the file's size (``voxel_budget``), so a
  number inside the file never decides how much memory a reader takes.
- ``check_arrays``: each array's dtype and shape, its consistency with the metadata (the
  voxel lists against the grid, the samples against their size), and every record
  field's range (ray ids, parents, pixels, lights, kinds, depths; visits' rays, voxels,
  primitives, stages, outcomes, steps, tests, vertices, children), read in chunks
  (``tracefile.chunks``: bounded memory, pages of a memory-mapped trace released).

The invariants between records (``mprt.tracecheck``) come after, streamed as well; where the
records are in the C layout the ranges and (when asked) the invariants are checked together in
one C pass (``mprt.recordcheck``), the checks here naming any fault it finds.
"""
from __future__ import annotations

import math
import sys

import numpy as np

from .._lowlevel import KINDS, RAY_DTYPE, RULES, VISIT_DTYPE, Outcome, RayKind, Stage
from ..errors import TraceError
from . import recordcheck
from ..util.pages import chunks, release

GRID_MAX = 1024             # voxels per axis (options.GRID_MAX)
RES_MAX = 65536             # width, height (options.RES_MAX)
SAMPLES_MAX = 2 * RES_MAX + 2   # samples per row or column
TILE_MAX = 1 << 16
LIGHTS_MAX = (1 << 15) - 1  # a ray's light is an int16
DEPTH_MAX = 255             # a ray's depth is a uint8
WORDS_MAX = 1 << 20         # a primitive's shape data, 32-bit words (4 MiB)
MATERIALS_MAX = 1 << 24
VOXELS_FREE = 1 << 24       # voxels any trace may have (64 MiB of list starts) ...
VOXELS_PER_BYTE = 16        # ... and more only in proportion to its file's size
CHUNK = 1 << 18             # records checked at a time

_STR = str
_NUM = (int, float)


def _where(member: str, field: str | None = None) -> str:
    return f"{member} field {field!r}" if field else member


def _fail(member: str, field: str | None, msg: str):
    raise TraceError(f"{_where(member, field)}: {msg}")


def _int(meta, key, lo, hi, required=True):
    if key not in meta:
        if required:
            _fail("meta.json", key, "is missing")
        return None
    v = meta[key]
    if not isinstance(v, int) or isinstance(v, bool) or not lo <= v <= hi:
        _fail("meta.json", key, f"must be an integer in {lo}..{hi}, not {_short(v)}")
    return v


def _short(v) -> str:
    text = repr(v) if not isinstance(v, (list, dict)) else f"a {type(v).__name__} of {len(v)}"
    return text if len(text) <= 60 else text[:57] + "..."


def voxel_budget(file_bytes: int | None) -> int:
    """The most voxels a trace file of this many bytes may have: a grid's list starts cost
    4 bytes a voxel in memory, so memory stays within a constant of the file's size."""
    return VOXELS_FREE + VOXELS_PER_BYTE * int(file_bytes or 0)


def check_meta(meta, file_bytes: int | None = None) -> None:
    """Raise TraceError naming the field when ``meta`` is not a trace's metadata."""
    if not isinstance(meta, dict):
        _fail("meta.json", None, f"must be a JSON object, not {type(meta).__name__}")
    grid = meta.get("grid")
    if "grid" not in meta:
        _fail("meta.json", "grid", "is missing")
    if not (isinstance(grid, list) and len(grid) == 3
            and all(isinstance(n, int) and not isinstance(n, bool) and 1 <= n <= GRID_MAX for n in grid)):
        _fail("meta.json", "grid", f"must be three integers in 1..{GRID_MAX}, not {_short(grid)}")
    voxels = grid[0] * grid[1] * grid[2]
    if voxels > voxel_budget(file_bytes):
        _fail("meta.json", "grid", f"{grid} has {voxels} voxels, more than a file of {file_bytes} bytes can "
                                   f"describe (at most {voxel_budget(file_bytes)})")
    w = _int(meta, "width", 1, RES_MAX)
    h = _int(meta, "height", 1, RES_MAX)
    sw = _int(meta, "samples_w", w, SAMPLES_MAX)
    sh = _int(meta, "samples_h", h, SAMPLES_MAX)
    if not isinstance(meta.get("rules"), str) or meta["rules"] not in RULES:     # (a list is unhashable)
        _fail("meta.json", "rules", f"must be one of {', '.join(RULES)}, not {_short(meta.get('rules'))}")
    _int(meta, "lights", 0, LIGHTS_MAX)
    _int(meta, "max_depth", 0, DEPTH_MAX, required=False)
    for key in ("threshold", "ambient"):
        v = meta.get(key, 0.0)
        if not isinstance(v, _NUM) or isinstance(v, bool) or not math.isfinite(v) or v < 0:
            _fail("meta.json", key, f"must be a finite number >= 0, not {_short(v)}")
    for key in ("scene", "scene_sha256", "precision"):
        if key in meta and not isinstance(meta[key], _STR):
            _fail("meta.json", key, f"must be a string, not {_short(meta[key])}")
    if "scene" not in meta:
        _fail("meta.json", "scene", "is missing")
    if "mailbox" in meta and not isinstance(meta["mailbox"], bool):
        _fail("meta.json", "mailbox", f"must be true or false, not {_short(meta['mailbox'])}")
    tile = _int(meta, "tile", 1, TILE_MAX, required=False)
    total = _int(meta, "tiles_total", 1, sw * sh)
    if tile is not None and total != -(-sw // tile) * -(-sh // tile):
        _fail("meta.json", "tiles_total", f"{total} is not the number of {tile}-sample tiles of {sw}x{sh} samples")
    tiles = meta.get("tiles")
    if not isinstance(tiles, list) or not tiles or len(tiles) > total \
            or not all(isinstance(t, int) and not isinstance(t, bool) and 0 <= t < total for t in tiles) \
            or any(a >= b for a, b in zip(tiles, tiles[1:])):
        _fail("meta.json", "tiles", f"must be increasing tile numbers in 0..{total - 1}, not {_short(tiles)}")
    for key, names in (("kinds", list(KINDS)), ("stages", [s.name for s in Stage]),
                       ("outcomes", [o.name.lower() for o in Outcome]),
                       ("ray_kinds", [k.name.lower() for k in RayKind])):
        if key in meta and meta[key] != names:
            _fail("meta.json", key, f"must be {names}, not {_short(meta[key])}")
    for key in ("grid_lo", "grid_hi"):
        v = meta.get(key)
        if key in meta and not (isinstance(v, list) and len(v) == 3 and all(
                isinstance(x, _NUM) and not isinstance(x, bool) and math.isfinite(x) for x in v)):
            _fail("meta.json", key, f"must be three finite numbers, not {_short(v)}")
    for key in ("crc32", "sha256", "camera"):
        if key in meta and not isinstance(meta[key], dict):
            _fail("meta.json", key, f"must be a JSON object, not {_short(meta[key])}")


def _dtype(member: str, a, dtype: np.dtype | None, ndim: int, kind: str | None = None) -> None:
    if not isinstance(a, np.ndarray):
        _fail(member, None, f"must be a numpy array, not {type(a).__name__}")
    if a.dtype.hasobject:
        _fail(member, None, "holds Python objects; a trace holds numbers only")
    if dtype is not None and a.dtype != dtype:
        _fail(member, None, f"has dtype {a.dtype}, expected {dtype}")
    if kind is not None and a.dtype.kind != kind:
        _fail(member, None, f"has dtype {a.dtype}, expected an integer type")
    if a.ndim != ndim:
        _fail(member, None, f"has shape {a.shape}, expected {ndim} dimension{'s' if ndim > 1 else ''}")
    if not a.flags.c_contiguous:
        _fail(member, None, "is not contiguous")


def _range(member: str, field: str | None, x: np.ndarray, lo: int, hi: int, offset: int = 0) -> None:
    """Every value of x in lo..hi, or TraceError naming the first one outside."""
    if not x.size:
        return
    if x.ndim > 1:
        x = x.reshape(len(x), -1)
    xmin, xmax = x.min(), x.max()
    if xmin >= lo and xmax <= hi:
        return
    bad = (x < lo) | (x > hi)
    i = int(np.argmax(bad.reshape(len(x), -1).any(axis=1)))
    value = x[i] if x.ndim == 1 else x[i][np.argmax(bad[i])]
    _fail(member, field, f"record {offset + i} holds {int(value)}, outside {lo}..{hi}")




def check_arrays(meta: dict, arrays: dict, chunk: int = CHUNK, invariants: bool = False,
                 keys: dict | None = None) -> str | None:
    """Raise TraceError naming the member and field of the first array or value a trace with
    this (valid) metadata cannot hold.  Reads the records in chunks of ``chunk``.  The records'
    ranges (and with ``invariants`` the invariants between them, ``mprt.tracecheck``'s rules) are
    checked in one pass in C where it reads them in place (``mprt.recordcheck``), a fault named
    by the Python checks below.  Returns None when the invariants were not checked, "" when they
    hold, else C's reason for the broken one (``tracecheck.settle`` names it).  ``keys`` (a dict):
    level 3's memory keys made in the same pass where C checks the records (``recordcheck.check``:
    its ``keys``, ``voxel_refs`` and ``material_refs`` added to the dict)."""
    voxels = meta["grid"][0] * meta["grid"][1] * meta["grid"][2]
    for k in ("voxel_start", "voxel_ids", "prim_kind", "prim_words", "prim_material", "samples", "rays", "visits"):
        if k not in arrays:
            _fail(k, None, "is missing")
    start, ids = arrays["voxel_start"], arrays["voxel_ids"]
    _dtype("voxel_start", start, np.dtype(np.uint32), 1)
    if len(start) != voxels + 1:
        _fail("voxel_start", None, f"has {len(start)} entries for a grid of {voxels} voxels (expected {voxels + 1})")
    _dtype("voxel_ids", ids, np.dtype(np.int32), 1)
    if start[0] != 0 or start[-1] != len(ids) or np.any(np.diff(start.astype(np.int64)) < 0):
        _fail("voxel_start", None, f"is not the starts of {len(ids)} list entries (from 0, never decreasing)")
    nprim = len(arrays["prim_kind"])
    for k, lo, hi in (("prim_kind", 0, len(KINDS) - 1), ("prim_words", 1, WORDS_MAX),
                      ("prim_material", 0, MATERIALS_MAX)):
        _dtype(k, arrays[k], np.dtype(np.int32), 1)
        if len(arrays[k]) != nprim:
            _fail(k, None, f"has {len(arrays[k])} entries, prim_kind {nprim}")
        _range(k, None, arrays[k], lo, hi)
    _range("voxel_ids", None, ids, 0, nprim - 1)
    s = arrays["samples"]
    _dtype("samples", s, np.dtype(np.float64), 3)
    if s.shape != (meta["samples_h"], meta["samples_w"], 3):
        _fail("samples", None, f"has shape {s.shape}, meta says ({meta['samples_h']}, {meta['samples_w']}, 3)")
    rays, visits = arrays["rays"], arrays["visits"]
    _dtype("rays", rays, RAY_DTYPE, 1)
    _dtype("visits", visits, VISIT_DTYPE, 1)
    if recordcheck.usable(rays, visits):
        want = None if keys is None else recordcheck.memory_keys(arrays["prim_material"], voxels)
        fault, reason = recordcheck.check(recordcheck.limits(meta, arrays, invariants), rays, visits, keys=want)
        if want is not None and "keys" in want:
            keys.update(want)
        if fault == recordcheck.SOUND:
            return "" if invariants else None
        if fault == recordcheck.INVARIANT:
            return reason
        _record_ranges(meta, arrays, chunk)       # names the fault C found
        _fail("rays or visits", None, reason)
    _record_ranges(meta, arrays, chunk)
    return None


def _record_ranges(meta: dict, arrays: dict, chunk: int) -> None:
    """The records' ranges in numpy, a chunk at a time: TraceError naming the first fault."""
    rays, visits = arrays["rays"], arrays["visits"]
    ids = arrays["voxel_ids"]
    voxels = meta["grid"][0] * meta["grid"][1] * meta["grid"][2]
    nprim = len(arrays["prim_kind"])
    n, lights = len(rays), meta["lights"]
    pixels = meta["samples_w"] * meta["samples_h"]
    depth = meta.get("max_depth", DEPTH_MAX)
    for i, r in chunks(rays, chunk):
        if not np.array_equal(r["id"], np.arange(i, i + len(r))):
            j = int(np.argmax(r["id"] != np.arange(i, i + len(r))))
            _fail("rays", "id", f"record {i + j} holds {int(r['id'][j])}: ids must be 0..n-1 in order")
        _range("rays", "parent", r["parent"], -1, n - 1, i)
        _range("rays", "pixel", r["pixel"], 0, pixels - 1, i)
        _range("rays", "light", r["light"], -1, lights - 1, i)
        _range("rays", "kind", r["kind"], 0, len(RayKind) - 1, i)
        _range("rays", "depth", r["depth"], 0, depth, i)
        if not np.all(np.isfinite(r["contribution"])):
            _fail("rays", "contribution", f"record {i + int(np.argmax(~np.isfinite(r['contribution'])))} "
                                          "is not a finite number")
    steps = sum(meta["grid"])              # a walk crosses at most nx + ny + nz voxels
    vertices = int(np.sum(arrays["prim_words"], dtype=np.int64))
    bounds = {"ray": (0, n - 1), "voxel_id": (-1, voxels - 1), "prim": (-1, nprim - 1), "steps": (0, steps),
              "tests": (0, len(ids)), "vertices": (0, vertices), "stage": (0, len(Stage) - 1),
              "outcome": (0, len(Outcome) - 1), "made": (0, lights + 2), "suppressed": (0, lights + 2)}
    fast = _VisitBounds(bounds) if _VisitBounds.usable(n) else None
    for i in range(0, len(visits), chunk):
        part = visits[i:i + chunk]
        if fast is None or not fast.ok(part):
            _visit_ranges(np.array(part), i, bounds)
        release(part)


class _VisitBounds:
    """The visits' ranges checked a block at a time on its 32-bit words, transposed (one pass
    over the records, then contiguous reductions in cache): about four times faster than a
    pass per field.  A block that fails is checked again field by field, for the message."""

    BLOCK = 1 << 14

    @staticmethod
    def usable(n: int) -> bool:
        return sys.byteorder == "little" and VISIT_DTYPE.itemsize == 48 and n < (1 << 31) and \
            [VISIT_DTYPE.fields[k][1] for k in ("ray", "voxel_id", "steps", "tests", "vertices", "prim",
                                                 "stage", "outcome", "made", "suppressed")] == \
            [0, 8, 16, 20, 36, 40, 44, 45, 46, 47]

    def __init__(self, b: dict):
        big = np.iinfo(np.int32)
        self.lo = np.array([b["ray"][0], 0, -1, -1, b["steps"][0], *[b["tests"][0]] * 4, b["vertices"][0],
                            b["prim"][0], big.min], dtype=np.int64)
        self.hi = np.array([b["ray"][1], 0, min(b["voxel_id"][1], big.max), 0, b["steps"][1],
                            *[min(b["tests"][1], big.max)] * 4, min(b["vertices"][1], big.max), b["prim"][1],
                            big.max], dtype=np.int64)
        self.bytes_hi = np.array([min(b[k][1], 255) for k in ("stage", "outcome", "made", "suppressed")])

    def ok(self, part: np.ndarray) -> bool:
        for j in range(0, len(part), self.BLOCK):
            w = np.ascontiguousarray(part[j:j + self.BLOCK].view(np.int32).reshape(-1, 12).T)
            if np.any(w.min(axis=1) < self.lo) or np.any(w.max(axis=1) > self.hi) \
                    or np.any(w[3] != (w[2] >> 31)):        # voxel_id: -1 or 0..voxels-1
                return False
            u = w[11].view(np.uint32)
            if any(int(((u >> np.uint32(8 * k)) & np.uint32(255)).max()) > self.bytes_hi[k] for k in range(4)):
                return False
        return True


def _visit_ranges(v: np.ndarray, i: int, bounds: dict) -> None:
    for field, (lo, hi) in bounds.items():
        _range("visits", field, v[field], lo, hi, i)


def validate(meta, arrays: dict, file_bytes: int | None = None, chunk: int = CHUNK,
             invariants: bool = False) -> str | None:
    """``check_meta`` then ``check_arrays`` (its answer on the invariants)."""
    check_meta(meta, file_bytes)
    return check_arrays(meta, arrays, chunk, invariants)


_META_KEYS = ("grid", "width", "height", "samples_w", "samples_h", "lights", "max_depth", "rules")


def _key(trace):
    arrays = tuple(getattr(trace, k, None) for k in ("rays", "visits", "voxel_start", "voxel_ids", "prim_kind",
                                                      "prim_words", "prim_material", "samples"))
    meta = trace.meta if isinstance(trace.meta, dict) else {}
    return arrays, repr([meta.get(k) for k in _META_KEYS])


def _same(a, b) -> bool:
    return a is not None and b is not None and a[1] == b[1] and all(x is y for x, y in zip(a[0], b[0]))


def mark_checked(trace) -> None:
    """Record that ``trace`` (its arrays, as they are now) passed ``validate``: a reader that
    validated it (``load_trace``) or the tracer that made it."""
    trace._validated = _key(trace)


def mark_derived(part, whole) -> None:
    """Mark ``part`` (whole ray trees cut from ``whole``, ids renumbered from 0) as checked when
    ``whole`` is: its values lie in the same ranges."""
    if _same(getattr(whole, "_validated", None), _key(whole)):
        mark_checked(part)


def check_trace(trace) -> None:
    """The validation of a Trace however it was made (a file, the tracer, or arrays built in
    memory and handed to the Python API): ``validate`` on its metadata and arrays, so a record
    ``mprt stats --check`` rejects gets the same one-line TraceError before the cost model or
    an engine reads it.  Run by every entry point (``System``, ``Compiled``, ``costs_for``,
    ``Evaluator``; ``CostModel.visit_costs`` has checks of its own); once per trace and set of arrays (ranges and dtypes: about
    60 ns a visit; the arrays are compared by identity, so arrays changed in place after a
    check are not checked again)."""
    if getattr(trace, "meta", None) is None or not hasattr(trace, "visits"):
        raise TraceError(f"not a trace: {type(trace).__name__} has no meta or visits")
    if _same(getattr(trace, "_validated", None), _key(trace)):
        return
    arrays = {k: getattr(trace, k, None) for k in ("voxel_start", "voxel_ids", "prim_kind", "prim_words",
                                                   "prim_material", "samples", "rays", "visits")}
    missing = [k for k, a in arrays.items() if a is None]
    if missing:
        _fail(missing[0], None, "is missing")
    size = sum(int(getattr(a, "nbytes", 0)) for a in arrays.values())
    check_meta(trace.meta, size)
    check_arrays(trace.meta, arrays)
    mark_checked(trace)
