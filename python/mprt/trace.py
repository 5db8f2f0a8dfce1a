"""Per-ray cost traces of the 3MPRT stages.

A trace is the contract between the tracer and every machine model: what each
ray did (voxels walked, tests made, what it hit, which rays it spawned) does
not depend on timing, so one trace serves every machine configuration.

``rays`` and ``visits`` are numpy structured arrays with the layout of the C
records (``mprt_trace_ray``, ``mprt_trace_visit``).  Ray ids are global:
tiles are traced independently (in parallel) and numbered in tile order, so a
trace is the same bits whatever the thread count.  The visits are grouped by
ray, each ray's visits in order.  A trace also carries what a machine model
needs without the scene: the grid's voxel lists (CSR), each primitive's kind,
size in words and material, and the settings that made it.
"""
from __future__ import annotations

import io
import zlib
import json
import os
import shutil
import tempfile
import zipfile
from collections import deque
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ._core import KINDS, InvalidArgument, MprtError, _check

FORMAT_VERSION = 2
# Version 1 had the same layout with the visit fields 'voxel' (now 'voxel_id')
# and 'voxels' (now 'steps'); it is read by renaming them.
_V1_VISIT_NAMES = {"voxel": "voxel_id", "voxels": "steps"}

STAGES = ("OS", "IC", "SC")
RAY_KINDS = ("primary", "reflect", "refract", "shadow")
OUTCOMES = ("to_ic", "left", "to_sc", "hit", "blocked", "return", "shaded", "lit", "late_hit")
OS, IC, SC = 0, 1, 2
PRIMARY, REFLECT, REFRACT, SHADOW = 0, 1, 2, 3
TO_IC, LEFT, TO_SC, HIT, BLOCKED, RETURN, SHADED, LIT, LATE_HIT = range(9)

RAY_DTYPE = np.dtype(
    [("id", "<i8"), ("parent", "<i8"), ("pixel", "<i4"), ("light", "<i2"), ("kind", "u1"), ("depth", "u1"),
     ("contribution", "<f8")], align=True)
VISIT_DTYPE = np.dtype(
    [("ray", "<i8"), ("voxel_id", "<i8"), ("steps", "<i4"), ("tests", "<i4", (4,)), ("vertices", "<i4"),
     ("prim", "<i4"), ("stage", "u1"), ("outcome", "u1"), ("made", "u1"), ("suppressed", "u1")], align=True)

ARRAYS = ("rays", "visits", "voxel_start", "voxel_ids", "prim_kind", "prim_words", "prim_material", "samples")


class TraceError(MprtError, ValueError):
    """A trace file or trace object is malformed, truncated, tampered or of an unknown version."""


def _check_layout(ffi):
    for name, dt in (("mprt_trace_ray", RAY_DTYPE), ("mprt_trace_visit", VISIT_DTYPE)):
        if ffi.sizeof(name) != dt.itemsize:
            raise ImportError(f"{name} is {ffi.sizeof(name)} bytes in C but {dt.itemsize} in numpy")
        for field in dt.names:
            if ffi.offsetof(name, field) != dt.fields[field][1]:
                raise ImportError(f"{name}.{field} offset differs between C and numpy")


def select_tiles(ntiles: int, tiles=None, sample: str | None = None) -> np.ndarray:
    """The tiles to trace: all, an explicit list, or a sample 'regular:K'
    (every K-th tile) or 'random:N:SEED' (N tiles drawn without replacement)."""
    if tiles is not None and sample is not None:
        raise InvalidArgument("give tiles or sample, not both")
    if tiles is not None:
        sel = np.unique(np.asarray(list(tiles), dtype=np.int64))
        if sel.size == 0 or sel[0] < 0 or sel[-1] >= ntiles:
            raise InvalidArgument(f"tiles must be in 0..{ntiles - 1}")
        return sel
    if sample is None:
        return np.arange(ntiles, dtype=np.int64)
    parts = sample.split(":")
    try:
        if parts[0] == "regular" and len(parts) == 2 and int(parts[1]) >= 1:
            return np.arange(0, ntiles, int(parts[1]), dtype=np.int64)
        if parts[0] == "random" and len(parts) == 3 and int(parts[1]) >= 1:
            n = min(int(parts[1]), ntiles)
            rng = np.random.default_rng(int(parts[2]))
            return np.sort(rng.choice(ntiles, size=n, replace=False)).astype(np.int64)
    except ValueError:
        pass
    raise InvalidArgument(f"sample must be 'regular:K' or 'random:N:SEED', not {sample!r}")


def _bytes(a):
    """A contiguous array's bytes as a uint8 view."""
    return a.view(np.uint8).reshape(-1)


class _Sink:
    """Where traced tiles go: memory, or raw files on disk (bounded memory)."""

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
                self.files[k] = open(os.path.join(directory, k + ".bin"), "wb")

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
            _bytes(bigger)[: _bytes(a[:n0]).size] = _bytes(a[:n0])
            self.arrays[key] = a = bigger
        # byte views: a memcpy (structured assignment goes field by field)
        _bytes(a[n0:n1])[:] = _bytes(arr)

    def result(self, key):
        return self.arrays[key][: self.count[key]]

    def close(self):
        for f in self.files.values():
            f.close()


class Trace:
    """A trace: rays, visits, voxel lists, primitive table, samples and metadata."""

    def __init__(self, meta: dict, arrays: dict, path: str | None = None):
        self.meta = meta
        self._arrays = arrays
        self.path = path

    # rays, visits, voxel_start, ... read as attributes of the trace
    def __getattr__(self, name):
        arrays = self.__dict__.get("_arrays")
        if arrays is not None and name in ARRAYS:
            return arrays[name]
        raise AttributeError(name)

    @property
    def image(self) -> np.ndarray:
        return samples_to_image(self.samples, self.meta["rules"], self.meta["width"], self.meta["height"])

    # -- persistence ----------------------------------------------------------
    def save(self, path, compress: bool = False) -> None:
        """Write the trace as .npz with its format version and checksums
        (deflate-compressed when ``compress``)."""
        meta = dict(self.meta)
        meta["crc32"] = {k: _crc(self._arrays[k]) for k in ARRAYS}
        mode = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
        with zipfile.ZipFile(path, "w", compression=mode, allowZip64=True) as z:
            z.writestr("meta.json", json.dumps(meta, sort_keys=True))
            for k in ARRAYS:
                with z.open(k + ".npy", "w", force_zip64=True) as f:
                    np.lib.format.write_array(f, np.ascontiguousarray(self._arrays[k]), allow_pickle=False)
        self.meta = meta
        self.path = os.fspath(path)

    # -- validation -----------------------------------------------------------
    def check(self) -> dict:
        """Validate the invariants; raise TraceError naming the first broken one.

        Every ray's visits form a legal 3MPRT path; children start after
        their parent's SC visit, and each SC visit's 'made' equals its
        children; visit and ray counts add up.  Returns the stats."""
        check_trace(self)
        return self.stats()

    def stats(self) -> dict:
        """The paper's table rows for this trace, tests by kind and per-ray distributions."""
        return trace_stats(self)


def samples_to_image(samples, rules, width, height) -> np.ndarray:
    """Pixels from samples exactly as the C renderer makes them."""
    s = np.asarray(samples, dtype=np.float64)
    if rules == "spd":
        img = 0.25 * (((s[:-1, :-1] + s[:-1, 1:]) + s[1:, :-1]) + s[1:, 1:])
    else:
        img = s
    return img.astype(np.float32)


def trace_grid(grid, width=0, height=0, rules="paper", threshold=None, max_depth=0, mailbox=False, ambient=None,
               tile=16, threads=1, tiles=None, sample=None, path=None, progress=False):
    """Trace (a subset of) the image; returns (image, Trace).  With ``path``
    the records stream to disk tile batch by tile batch and the trace is
    saved there (memory stays bounded by the batch and the image)."""
    from ._core import RULES

    ext = grid._ext
    ffi, lib = ext.ffi, ext.lib
    _check_layout(ffi)
    if rules not in RULES:
        raise InvalidArgument(f"rules must be 'paper' or 'spd', not {rules!r}")
    if threads < 1 or threads > 64:
        raise InvalidArgument(f"threads {threads} is not in 1..64")
    d = ffi.new("mprt_render_desc *")
    lib.mprt_render_desc_init(d)
    d.width, d.height, d.rules = int(width), int(height), RULES[rules]
    if threshold is not None:
        d.threshold = float(threshold)
    if ambient is not None:
        d.ambient = float(ambient)
    d.max_depth, d.mailbox, d.tile = int(max_depth), 1 if mailbox else 0, int(tile)
    sw, sh, tx, ty = (ffi.new("int *") for _ in range(4))
    _check(ext, lib.mprt_grid_tiling(grid._h, d, sw, sh, tx, ty), lib.mprt_grid_errmsg(grid._h))
    sw, sh, tx, ty = sw[0], sh[0], tx[0], ty[0]
    ts = d.tile
    sel = select_tiles(tx * ty, tiles, sample)
    info = grid.scene.info()
    w = int(width) or info["resolution"][0]
    h = int(height) or info["resolution"][1]

    samples = np.zeros((sh, sw, 3), dtype=np.float64)
    covered = np.zeros((sh, sw), dtype=bool)

    def one(t, b):
        """Trace tile t into buffer set b (reused; grown when a tile needs more)."""
        i0, j0 = (t % tx) * ts, (t // tx) * ts
        i1, j1 = min(i0 + ts, sw), min(j0 + ts, sh)
        buf = b["samples"][: (j1 - j0) * (i1 - i0) * 3]
        nr, nv = ffi.new("size_t *"), ffi.new("size_t *")
        c = ffi.new("mprt_counters *")
        while True:
            rays, visits = b["rays"], b["visits"]
            rc = lib.mprt_grid_trace_tile(
                grid._h, d, int(t), ffi.cast("double *", ffi.from_buffer(buf)), buf.size,
                ffi.cast("mprt_trace_ray *", ffi.from_buffer(rays)), len(rays), nr,
                ffi.cast("mprt_trace_visit *", ffi.from_buffer(visits)), len(visits), nv, c)
            if rc == lib.MPRT_ERR_CAPACITY and (nr[0] > len(rays) or nv[0] > len(visits)):
                b["rays"] = np.empty(max(len(rays), int(nr[0] * 1.5)), dtype=RAY_DTYPE)
                b["visits"] = np.empty(max(len(visits), int(nv[0] * 1.5)), dtype=VISIT_DTYPE)
                continue
            _check(ext, rc, lib.mprt_grid_errmsg(grid._h))
            return (i0, j0, i1, j1), buf.reshape(j1 - j0, i1 - i0, 3), nr[0], nv[0]

    # A window of tiles in flight, each with its own buffer set: results are
    # consumed in tile order, and no tile ever waits for a buffer held by a
    # later one.  Buffers are reused, so memory is touched once.
    window = threads + 1
    free = [{"samples": np.empty(ts * ts * 3), "rays": np.empty(ts * ts * 8, dtype=RAY_DTYPE),
             "visits": np.empty(ts * ts * 64, dtype=VISIT_DTYPE)} for _ in range(window)]
    tmpdir = tempfile.mkdtemp(prefix="mprt-trace-", dir=os.path.dirname(os.path.abspath(path)) if path else None) \
        if path else None
    sink = _Sink(tmpdir, samples=sum(min(ts, sw - (t % tx) * ts) * min(ts, sh - (t // tx) * ts) for t in sel))
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(sel), unit="tile", desc="trace", leave=False)
    try:
        with ThreadPoolExecutor(max_workers=threads) as pool:
            pending = deque()
            todo = iter(sel)

            def submit():
                t = next(todo, None)
                if t is not None:
                    b = free.pop()
                    pending.append((pool.submit(one, t, b), b))

            for _ in range(window):
                submit()
            while pending:
                fut, b = pending.popleft()
                (i0, j0, i1, j1), buf, nr, nv = fut.result()
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
        sink.close()
        meta = _meta(grid, rules, d, w, h, sw, sh, ts, sel, tx * ty, tiles, sample)
        if not covered.all():
            samples[~covered] = np.nan
        static = _static_arrays(grid)
        static["samples"] = samples
        if path:
            _write_streamed(path, meta, sink, static)
            trace = load_trace(path, mmap=True, verify=False)
        else:
            static["rays"] = sink.result("rays")
            static["visits"] = sink.result("visits")
            trace = Trace(meta, static)
    finally:
        if bar:
            bar.close()
        if tmpdir:
            shutil.rmtree(tmpdir, ignore_errors=True)
    return trace.image, trace


def _meta(grid, rules, d, w, h, sw, sh, ts, sel, ntiles, tiles, sample):
    info = grid.scene.info()
    return {
        "format": "mprt-trace",
        "version": FORMAT_VERSION,
        "scene": grid.scene.name,
        "scene_sha256": grid.scene.content_hash(),
        "precision": grid.scene.precision,
        "grid": list(grid.n),
        "grid_lo": grid.stats()["lo"],
        "grid_hi": grid.stats()["hi"],
        "camera": {k: info[k] for k in ("from", "at", "up", "angle", "hither")},
        "width": w,
        "height": h,
        "samples_w": sw,
        "samples_h": sh,
        "rules": rules,
        "threshold": d.threshold,
        "max_depth": d.max_depth or (5 if rules == "spd" else 64),
        "ambient": d.ambient,
        "mailbox": bool(d.mailbox),
        "tile": ts,
        "tiles_total": int(ntiles),
        "tiles": [int(t) for t in sel],
        "subset": None if tiles is None and sample is None else (sample or "tiles"),
        "lights": info["lights"],
        "kinds": list(KINDS),
        "stages": list(STAGES),
        "outcomes": list(OUTCOMES),
        "ray_kinds": list(RAY_KINDS),
    }


def _static_arrays(grid):
    ext = grid._ext
    ffi, lib = ext.ffi, ext.lib
    st = grid.stats()
    start = np.zeros(st["voxels"] + 1, dtype=np.uint32)
    ids = np.zeros(max(st["refs"], 1), dtype=np.int32)
    _check(ext, lib.mprt_grid_get_lists(grid._h, ffi.cast("uint32_t *", ffi.from_buffer(start)), start.size,
                                        ffi.cast("int32_t *", ffi.from_buffer(ids)), ids.size),
           lib.mprt_grid_errmsg(grid._h))
    n = grid.scene.info()["prims"]
    kind, words, mat = (np.zeros(n, dtype=np.int32) for _ in range(3))
    _check(ext, lib.mprt_scene_get_prims(grid.scene._h, ffi.cast("int32_t *", ffi.from_buffer(kind)),
                                         ffi.cast("int32_t *", ffi.from_buffer(words)),
                                         ffi.cast("int32_t *", ffi.from_buffer(mat)), n),
           lib.mprt_scene_errmsg(grid.scene._h))
    return {"voxel_start": start, "voxel_ids": ids[: st["refs"]], "prim_kind": kind, "prim_words": words,
            "prim_material": mat}


def _write_npy_from_file(z, name, src, dtype, count):
    with z.open(name, "w", force_zip64=True) as f:
        header = {"descr": np.lib.format.dtype_to_descr(dtype), "fortran_order": False, "shape": (count,)}
        np.lib.format.write_array_header_2_0(f, header)
        with open(src, "rb") as s:
            shutil.copyfileobj(s, f, 1 << 22)


def _write_streamed(path, meta, sink, static):
    meta = dict(meta)
    meta["crc32"] = {"rays": sink.crc["rays"], "visits": sink.crc["visits"]}
    for k, v in static.items():
        meta["crc32"][k] = _crc(v)
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_STORED, allowZip64=True) as z:
        z.writestr("meta.json", json.dumps(meta, sort_keys=True))
        _write_npy_from_file(z, "rays.npy", os.path.join(sink.dir, "rays.bin"), RAY_DTYPE, sink.count["rays"])
        _write_npy_from_file(z, "visits.npy", os.path.join(sink.dir, "visits.bin"), VISIT_DTYPE,
                             sink.count["visits"])
        for k, v in static.items():
            with z.open(k + ".npy", "w", force_zip64=True) as f:
                np.lib.format.write_array(f, np.ascontiguousarray(v), allow_pickle=False)


def _member_offset(f, info) -> int:
    """Offset of a stored zip member's data in the file."""
    f.seek(info.header_offset)
    head = f.read(30)
    if head[:4] != b"PK\x03\x04":
        raise TraceError("bad zip local header")
    name_len = int.from_bytes(head[26:28], "little")
    extra_len = int.from_bytes(head[28:30], "little")
    return info.header_offset + 30 + name_len + extra_len


def _mmap_npy(path, f, info):
    """Memory-map an uncompressed .npy member (no copy, bounded memory)."""
    off = _member_offset(f, info)
    f.seek(off)
    version = np.lib.format.read_magic(f)
    read_header = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}
    if version not in read_header:
        raise TraceError(f"unsupported .npy version {version}")
    shape, fortran, dtype = read_header[version](f)
    if fortran:
        raise TraceError("Fortran-ordered arrays are not expected in a trace")
    count = int(np.prod(shape))
    if f.tell() - off + count * dtype.itemsize > info.file_size:
        raise TraceError("array is truncated")
    if count == 0:
        return np.zeros(shape, dtype=dtype)
    return np.memmap(path, dtype=dtype, mode="r", offset=f.tell(), shape=shape)


def _crc(a, chunk=1 << 26) -> int:
    """CRC-32 of an array's bytes, read in chunks (a memory-mapped array is
    not read whole): detects damaged or edited data."""
    b = _bytes(np.ascontiguousarray(a)) if a.size else np.zeros(0, np.uint8)
    crc = 0
    for i in range(0, b.size, chunk):
        crc = zlib.crc32(memoryview(np.ascontiguousarray(b[i:i + chunk])), crc)
    return crc


def load_trace(path, mmap: bool | None = None, verify: bool = True) -> Trace:
    """Read a trace saved by Trace.save or streamed by trace(); checks the
    format version, that every array is present and whole, and (``verify``)
    the checksums.  Uncompressed traces are memory-mapped (``mmap``; default:
    when the file is over 256 MB), so a trace of any size opens in bounded
    memory."""
    path = os.fspath(path)
    try:
        z = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError) as e:
        raise TraceError(f"{path}: not a readable trace file ({e})") from None
    if mmap is None:
        mmap = os.path.getsize(path) > (256 << 20)
    with z, open(path, "rb") as raw:
        names = set(z.namelist())
        if "meta.json" not in names:
            raise TraceError(f"{path}: no meta.json: not an mprt trace")
        try:
            meta = json.loads(z.read("meta.json"))
        except (ValueError, zipfile.BadZipFile) as e:
            raise TraceError(f"{path}: meta.json is unreadable ({e})") from None
        if meta.get("format") != "mprt-trace":
            raise TraceError(f"{path}: not an mprt trace (format {meta.get('format')!r})")
        if meta.get("version") not in (1, FORMAT_VERSION):
            raise TraceError(f"{path}: trace format version {meta.get('version')!r} is not supported "
                             f"(this mprt reads versions 1 and {FORMAT_VERSION}); regenerate it with "
                             "'mprt trace SCENE --grid N --res WxH -o FILE'")
        arrays = {}
        for k in ARRAYS:
            if k + ".npy" not in names:
                raise TraceError(f"{path}: array {k!r} is missing")
            info = z.getinfo(k + ".npy")
            try:
                if mmap and info.compress_type == zipfile.ZIP_STORED:
                    arrays[k] = _mmap_npy(path, raw, info)
                else:
                    with z.open(info) as f:
                        data = f.read()
                    arrays[k] = np.lib.format.read_array(io.BytesIO(data), allow_pickle=False)
            except (ValueError, EOFError, zipfile.BadZipFile, OSError, TraceError) as e:
                raise TraceError(f"{path}: array {k!r} is truncated or corrupt ({e})") from None
            if verify and meta.get("crc32", {}).get(k) != _crc(arrays[k]):
                raise TraceError(f"{path}: array {k!r} does not match its checksum (tampered or damaged)")
    if meta["version"] == 1:  # same bytes, older field names
        v = arrays["visits"]
        if v.dtype.names is not None:
            arrays["visits"] = v.view(np.dtype({"names": [_V1_VISIT_NAMES.get(n, n) for n in v.dtype.names],
                                                "formats": [v.dtype.fields[n][0] for n in v.dtype.names],
                                                "offsets": [v.dtype.fields[n][1] for n in v.dtype.names],
                                                "itemsize": v.dtype.itemsize}))
        meta["version"] = FORMAT_VERSION
    if arrays["rays"].dtype != RAY_DTYPE or arrays["visits"].dtype != VISIT_DTYPE:
        raise TraceError(f"{path}: rays/visits have an unexpected layout")
    return Trace(meta, arrays, path)


# ---- invariants -------------------------------------------------------------

# allowed (stage, outcome) of a visit followed by the next visit of the same ray
_NEXT = {
    (OS, TO_IC): {(IC, HIT), (IC, BLOCKED), (IC, RETURN)},
    (IC, RETURN): {(OS, TO_IC), (OS, LEFT), (OS, TO_SC), (OS, LATE_HIT)},
    (IC, HIT): {(SC, SHADED)},
    (OS, TO_SC): {(SC, LIT)},
    (OS, LATE_HIT): {(SC, SHADED)},
}
_LAST = {(OS, LEFT), (IC, BLOCKED), (SC, SHADED), (SC, LIT)}


def _fail(msg):
    raise TraceError(f"trace invariant broken: {msg}")


def check_trace(t: Trace) -> None:
    rays, v = t.rays, t.visits
    n = len(rays)
    if not np.array_equal(rays["id"], np.arange(n)):
        _fail("ray ids are not 0..n-1 in order")
    if len(v) == 0:
        if n:
            _fail("rays without visits")
        return
    code = v["stage"].astype(np.int64) * 16 + v["outcome"]
    same = v["ray"][1:] == v["ray"][:-1]
    # grouped by ray: each ray's visits form one run
    starts = np.flatnonzero(np.concatenate([[True], ~same]))
    run_rays = v["ray"][starts]
    if len(np.unique(run_rays)) != len(run_rays):
        _fail("a ray's visits are not contiguous")
    if len(run_rays) != n or not np.array_equal(np.sort(run_rays), np.arange(n)):
        _fail("every ray must have visits, and every visit a ray")
    # first visit of each ray is OS
    if np.any(v["stage"][starts] != OS):
        _fail(f"ray {int(run_rays[np.argmax(v['stage'][starts] != OS)])} does not start at OS")
    # transitions within a ray
    allowed = np.zeros((64, 64), dtype=bool)
    for (s0, o0), nxt in _NEXT.items():
        for s1, o1 in nxt:
            allowed[s0 * 16 + o0, s1 * 16 + o1] = True
    bad = same & ~allowed[code[:-1], code[1:]]
    if bad.any():
        i = int(np.argmax(bad))
        _fail(f"ray {int(v['ray'][i])}: {STAGES[v['stage'][i]]}/{OUTCOMES[v['outcome'][i]]} followed by "
              f"{STAGES[v['stage'][i + 1]]}/{OUTCOMES[v['outcome'][i + 1]]}")
    ends = np.concatenate([starts[1:] - 1, [len(v) - 1]])
    last_ok = np.zeros(64, dtype=bool)
    for s, o in _LAST:
        last_ok[s * 16 + o] = True
    if not last_ok[code[ends]].all():
        i = ends[np.argmax(~last_ok[code[ends]])]
        _fail(f"ray {int(v['ray'][i])} ends with {STAGES[v['stage'][i]]}/{OUTCOMES[v['outcome'][i]]}")
    # shadow rays never reach SC through a hit, other rays never through 'lit' or 'blocked'
    kind_of_visit = rays["kind"][v["ray"]]
    shadow = kind_of_visit == SHADOW
    if np.any(shadow & ((code == IC * 16 + HIT) | (code == SC * 16 + SHADED) | (code == OS * 16 + LEFT))):
        _fail("a shadow ray was shaded or left the space as a primary/secondary ray")
    if np.any(~shadow & ((code == IC * 16 + BLOCKED) | (code == SC * 16 + LIT) | (code == OS * 16 + TO_SC))):
        _fail("a primary or secondary ray was blocked or lit like a shadow ray")
    # parents: primary rays have none; a child's first visit comes after its parent's SC visit
    prim_mask = rays["kind"] == PRIMARY
    if np.any(prim_mask != (rays["parent"] < 0)):
        _fail("primary rays and only they have no parent")
    sc_idx = np.full(n, -1, dtype=np.int64)
    sc_pos = np.flatnonzero(v["stage"] == SC)
    sc_idx[v["ray"][sc_pos]] = sc_pos
    first = np.empty(n, dtype=np.int64)
    first[run_rays] = starts
    kids = np.flatnonzero(~prim_mask)
    parents = rays["parent"][kids]
    if np.any(sc_idx[parents] < 0) or np.any(first[kids] <= sc_idx[parents]):
        _fail("a child ray starts before its parent's SC visit")
    if np.any(rays["depth"][kids] < rays["depth"][parents]):
        _fail("a child is shallower than its parent")
    made = np.bincount(parents, minlength=n)
    sc_made = np.zeros(n, dtype=np.int64)
    sc_made[v["ray"][sc_pos]] = v["made"][sc_pos]
    if not np.array_equal(made, sc_made):
        _fail("an SC visit's 'made' differs from its number of children")
    if np.any(rays["pixel"][kids] != rays["pixel"][parents]):
        _fail("a child belongs to another pixel than its parent")
    # counts add up: every OS->IC is an IC visit, IC tests only in IC visits, voxels only in OS
    if np.sum(code == OS * 16 + TO_IC) != np.sum(v["stage"] == IC):
        _fail("OS->IC handoffs and IC visits differ")
    if np.any(v["tests"][v["stage"] != IC] != 0) or np.any(v["steps"][v["stage"] != OS] != 0):
        _fail("tests outside IC or voxels outside OS")


def trace_stats(t: Trace, chunk: int = 1 << 22) -> dict:
    """The statistics, computed over the visits in chunks (bounded memory)."""
    rays, visits = t.rays, t.visits
    kinds = np.bincount(np.asarray(rays["kind"]), minlength=4) if len(rays) else np.zeros(4, np.int64)
    n_primary = int(kinds[PRIMARY])
    n_new = int(len(rays) - n_primary)
    cnt = np.zeros((3, 16), dtype=np.int64)     # visits by (stage, outcome)
    tests_by_kind = np.zeros(4, dtype=np.int64)
    sums = {"suppressed": 0, "voxels": 0, "vertices": 0}
    h_vox, h_tests, h_ret = [], [], []
    carry_ray, carry_ret = -1, 0                # a ray's returns may straddle chunks

    def add_hist(acc, counts):
        if len(counts) > len(acc):
            acc.extend([0] * (len(counts) - len(acc)))
        for i, c in enumerate(counts):
            acc[i] += int(c)

    for a in range(0, len(visits), chunk):
        v = np.asarray(visits[a:a + chunk])
        stage, out = v["stage"].astype(np.int64), v["outcome"].astype(np.int64)
        cnt += np.bincount(stage * 16 + out, minlength=48).reshape(3, 16)
        tests_by_kind += v["tests"].sum(axis=0, dtype=np.int64)
        sums["suppressed"] += int(v["suppressed"].sum(dtype=np.int64))
        sums["voxels"] += int(v["steps"].sum(dtype=np.int64))
        sums["vertices"] += int(v["vertices"].sum(dtype=np.int64))
        add_hist(h_vox, np.bincount(v["steps"][stage == OS]))
        add_hist(h_tests, np.bincount(v["tests"][stage == IC].sum(axis=1)))
        # returns per ray: visits are grouped by ray, so count per run of ray ids
        ray = v["ray"]
        starts = np.flatnonzero(np.concatenate([[True], ray[1:] != ray[:-1]]))
        ret = np.add.reduceat(((stage == IC) & (out == RETURN)).astype(np.int64), starts)
        if ray[0] == carry_ray:
            ret[0] += carry_ret
        elif carry_ray >= 0:
            add_hist(h_ret, np.bincount([carry_ret]))
        carry_ray, carry_ret = int(ray[starts[-1]]), int(ret[-1])
        add_hist(h_ret, np.bincount(ret[:-1]))
    if carry_ray >= 0:
        add_hist(h_ret, np.bincount([carry_ret]))
    returns = int(cnt[IC, RETURN])
    return {
        "rays": int(len(rays)),
        "visits": int(len(visits)),
        "os_input": n_primary + returns + n_new,
        "os_input_primary": n_primary,
        "os_input_returns": returns,
        "os_input_new": n_new,
        "os_kills": int(cnt[OS, LEFT]),
        "os_to_ic": int(cnt[OS, TO_IC]),
        "os_to_sc": int(cnt[OS, TO_SC] + cnt[OS, LATE_HIT]),
        "os_to_sc_late_hits": int(cnt[OS, LATE_HIT]),
        "ic_input": int(cnt[IC].sum()),
        "ic_kills": int(cnt[IC, BLOCKED]),
        "ic_to_os": returns,
        "ic_to_sc": int(cnt[IC, HIT]),
        "sc_input": int(cnt[SC].sum()),
        "sc_input_from_ic": int(cnt[IC, HIT]),
        "sc_input_from_os": int(cnt[OS, TO_SC] + cnt[OS, LATE_HIT]),
        "sc_made_secondary": int(kinds[REFLECT] + kinds[REFRACT]),
        "sc_made_reflect": int(kinds[REFLECT]),
        "sc_made_refract": int(kinds[REFRACT]),
        "sc_made_shadow": int(kinds[SHADOW]),
        "suppressed": sums["suppressed"],
        "voxels_traversed": sums["voxels"],
        "tests": int(tests_by_kind.sum()),
        "tests_by_kind": {k: int(tests_by_kind[i]) for i, k in enumerate(KINDS)},
        "polygon_vertices": sums["vertices"],
        "returns_per_ray": returns / (n_primary + n_new) if n_primary + n_new else 0.0,
        "hist_voxels_per_os_visit": h_vox,
        "hist_tests_per_ic_visit": h_tests,
        "hist_returns_per_ray": h_ret,
    }
