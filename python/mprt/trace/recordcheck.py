"""A trace's records checked in C in one pass (``mprt_trace_checker_*``, ``c/src/tracecheck.c``):
every field's range (``tracevalid.check_arrays``'s rules for the rays and the visits) and, when
asked, the invariants between records (``tracecheck``'s rules), read where they lie (a
memory-mapped trace in place, its pages let go after each chunk: ``pages.release``), in
memory of 9 bytes a ray.

C only says whether the records pass (and a short reason); the Python checkers, run on a
trace that does not, name the first fault in their words, so every message stays theirs.
``sound`` is False for records C cannot read in place (another layout or byte order): the
caller then checks them in Python.

``check(..., keys=...)`` makes level 3's memory keys in the same pass (``memory_keys``: the
arrays ``mprt_visit_keys`` gives, for ``fidelity.memdata``), one pass over the visits fewer.
"""
from __future__ import annotations

import os
import sys
import threading

import numpy as np

from .._lowlevel import RAY_DTYPE, VISIT_DTYPE, binding
from ..util.pages import release

CHUNK = 1 << 20     # visits a call (48 MB of records): their pages are let go after each
SOUND, RANGE, INVARIANT, REDO = 0, 1, 2, 3     # mprt_trace_checker's fault kinds (REDO: check in one part)
SPLIT_MIN = 1 << 21     # visits: this many or more are checked in two halves at once (threads 2)
THREADS_ENV = "MPRT_CHECK_THREADS"      # 1: the records checked on one thread


def usable(rays, visits) -> bool:
    """Whether C reads these records in place: contiguous arrays of the C layouts."""
    return sys.byteorder == "little" and all(
        isinstance(a, np.ndarray) and a.ndim == 1 and a.dtype == dt and a.flags.c_contiguous
        for a, dt in ((rays, RAY_DTYPE), (visits, VISIT_DTYPE)))


def limits(meta: dict, arrays: dict, invariants: bool) -> dict:
    """mprt_trace_limits for a trace with this (valid) metadata and (checked) small arrays:
    tracevalid.check_arrays's bounds."""
    grid = meta["grid"]
    return {"pixels": meta["samples_w"] * meta["samples_h"], "lights": meta["lights"],
            "max_depth": meta.get("max_depth", 255), "voxels": grid[0] * grid[1] * grid[2],
            "prims": len(arrays["prim_kind"]), "steps": sum(grid), "tests": len(arrays["voxel_ids"]),
            "vertices": int(np.sum(arrays["prim_words"], dtype=np.int64)), "invariants": int(bool(invariants))}


def memory_keys(prim_material: np.ndarray, nvoxels: int) -> dict:
    """What ``check(..., keys=)`` fills for a trace of these materials and voxels: ``prim_material``
    (int64), ``nvoxels`` and ``nmaterials`` (the most material + 1, as ``fidelity.memdata`` counts
    them); after a check that made every visit's key, also ``keys`` (int32 per visit),
    ``voxel_refs`` and ``material_refs`` (int64), as ``binding.visit_keys`` gives them."""
    mat = np.ascontiguousarray(prim_material, dtype=np.int64)
    return {"prim_material": mat, "nvoxels": int(nvoxels), "nmaterials": int(mat.max()) + 1 if len(mat) else 1}


def check(lim: dict, rays: np.ndarray, visits: np.ndarray, chunk: int = CHUNK, keys: dict | None = None,
          threads: int | None = None, split_min: int = SPLIT_MIN, split_at: int | None = None) -> tuple[int, str]:
    """(fault kind, reason) of the records under ``lim`` (``limits``): SOUND, RANGE (a field
    outside its range) or INVARIANT (a broken invariant, when ``lim`` asks for them).
    ``keys`` (``memory_keys``'s dict): the visits' memory keys made in the same pass, added to it
    as ``keys``, ``voxel_refs``, ``material_refs`` when every visit got one and the records pass
    (else left out: ``binding.visit_keys`` makes them, naming the visit it refuses).
    ``threads`` (default: the cores, at most 2; ``$MPRT_CHECK_THREADS``): 2 checks the visits'
    halves at once where there are ``split_min`` or more (``mprt_trace_checker_split``), the same
    answer as one pass: a fault in the second half or across the halves is found again in one
    (``split_at``: where the second part starts, default the middle)."""
    if threads is None:
        env = os.environ.get(THREADS_ENV, "").strip()
        threads = int(env) if env.isdigit() and int(env) > 0 else min(os.cpu_count() or 1, 2)
    split = threads >= 2 and len(visits) >= max(2, split_min)
    mid = len(visits) // 2 if split_at is None else max(1, min(int(split_at), len(visits) - 1))
    rc, reason = _check(lim, rays, visits, chunk, keys, mid if split else 0)
    if rc == REDO:
        rc, reason = _check(lim, rays, visits, chunk, keys, 0)
    return rc, reason


def _visits(lib, h, visits: np.ndarray, step: int, since=None) -> int:
    """Check visits a chunk at a time on checker h (their pages let go after each): its answer."""
    rc, i = SOUND, 0
    while not rc and i < len(visits):
        part = visits[i:i + step]
        rc = lib.lib.mprt_trace_checker_visits(h, lib._in("mprt_trace_visit", part), len(part))
        release(part, since)
        i += step
    return rc


def _check(lim: dict, rays: np.ndarray, visits: np.ndarray, chunk: int, keys: dict | None, mid: int):
    """check's pass: in two parts at once when ``mid`` (the second's first visit) is not 0."""
    lib = binding("double")
    ffi, c_lib = lib.ffi, lib.lib
    ray_buf = lib._in("mprt_trace_ray", rays) if len(rays) else ffi.NULL    # (kept alive: C holds it)
    h = c_lib.mprt_trace_checker_create(ffi.new("mprt_trace_limits *", lim), ray_buf, len(rays))
    if h == ffi.NULL:
        raise MemoryError(f"out of memory checking a trace of {len(rays)} rays")
    h = ffi.gc(h, c_lib.mprt_trace_checker_destroy)
    made = key_bufs = part = None
    if keys is not None:
        mat = keys["prim_material"]
        made = (np.empty(len(visits), np.int32), np.empty(keys["nvoxels"], np.int64),
                np.empty(keys["nmaterials"], np.int64))
        key_bufs = (lib._in("int64_t", mat), lib._out("int32_t", made[0]), lib._out("int64_t", made[1]),
                    lib._out("int64_t", made[2]))      # (kept alive: C holds them)
        if c_lib.mprt_trace_checker_keys(h, key_bufs[0], len(mat), key_bufs[1], len(made[0]), key_bufs[2],
                                         len(made[1]), key_bufs[3], len(made[2])):
            made = None
    try:
        step = max(1, int(chunk))
        rc = SOUND
        for i in range(0, len(rays), step):
            rc = c_lib.mprt_trace_checker_rays(h, i, min(i + step, len(rays)))
            release(rays[i:i + step])
            if rc:
                break
        if not rc and mid:
            part = c_lib.mprt_trace_checker_split(h, lib._in("mprt_trace_visit", visits[mid - 1:mid]), mid)
        if not rc and part is not None and part != ffi.NULL:
            part = ffi.gc(part, c_lib.mprt_trace_checker_destroy)
            second = {}
            t = threading.Thread(target=lambda: second.update(rc=_visits(lib, part, visits[mid:], step,
                                                                           visits[mid:])),
                                 name="mprt-check", daemon=True)
            t.start()
            try:
                _visits(lib, h, visits[:mid], step)
            finally:
                t.join()
            if "rc" not in second:      # (the thread met an error of Python's: one pass)
                return REDO, ""
            rc = c_lib.mprt_trace_checker_join(h, part)
            if rc == REDO:
                return REDO, ""
        elif not rc:
            rc = _visits(lib, h, visits, step)
        if not rc:
            rc = c_lib.mprt_trace_checker_finish(h)
        if made is not None and c_lib.mprt_trace_checker_keys_done(h):
            keys.update(keys=made[0], voxel_refs=made[1], material_refs=made[2])
        return int(rc), ffi.string(c_lib.mprt_trace_checker_errmsg(h)).decode(errors="replace")
    finally:
        if part is not None and part != ffi.NULL:
            ffi.release(part)
        ffi.release(h)
        del ray_buf
        key_bufs = None
