"""The trace records' C calls (cost.c, memkeys.c, crc32.c, record.c): each visit's price on a
processor configuration, level 3's memory keys, CRC-32, and records copied with their ray
numbers moved on."""
from __future__ import annotations

import numpy as np

from ..errors import InvalidArgument
from ..util.pages import sparse_zeros
from .core import RAY_DTYPE, VISIT_DTYPE, Calls, Status, _plain, error_class


class RecordCalls(Calls):
    """Trace records (RAY_DTYPE, VISIT_DTYPE): mprt_cost_*, mprt_visit_keys, mprt_crc32_copy,
    mprt_trace_records_shift."""

    def _cost_errmsg(self):
        return self.ffi.new("char[]", 512)

    def _cost_check(self, rc: int, msg) -> None:
        if rc != Status.OK:
            raise error_class(rc)(self.ffi.string(msg).decode(errors="replace") or self.status_str(rc))

    def cost_children(self, rays: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """Children of every ray by kind (int64[len(rays), 4], into ``out`` if given);
        InvalidArgument naming a ray of an unknown kind or with a parent that is not a ray."""
        rays = np.ascontiguousarray(self._records("rays", rays, RAY_DTYPE))
        if out is None:
            out = np.empty((len(rays), 4), dtype=np.int64)
        elif out.shape != (len(rays), 4) or out.dtype != np.int64 or not out.flags.c_contiguous:
            raise InvalidArgument(f"cost_children: out must be int64[{len(rays)}, 4]")
        msg = self._cost_errmsg()
        self._cost_check(self.lib.mprt_cost_children(self._in("mprt_trace_ray", rays, len(rays)), len(rays),
                                                     self._out("int64_t", out, 4 * len(rays)), msg, len(msg)), msg)
        return out

    def cost_visits(self, table: dict, rays: np.ndarray, children: np.ndarray, prim_kind: np.ndarray,
                    visits: np.ndarray, prev_ray: int = -1, prev_outcome: int = 0, *, process=None, receive=None,
                    send=None, flits=None, runs=None, packets=None, threads: int = 1) -> None:
        """mprt_cost_visits: ``table`` holds mprt_cost_table's fields by name; the records are
        RAY_DTYPE, VISIT_DTYPE, ``children`` as cost_children gives it, ``prim_kind`` int32;
        the outputs given (int64 process, receive, send; int32 flits, runs (visits x 10) and
        packets (visits x 3)) are filled, by up to ``threads`` threads (the same results)."""
        ffi = self.ffi
        t = ffi.new("mprt_cost_table *", table)
        rays = np.ascontiguousarray(self._records("rays", rays, RAY_DTYPE))
        visits = np.ascontiguousarray(self._records("visits", visits, VISIT_DTYPE))
        n = len(visits)
        outs = []
        for name, a, ctype, width in (("process", process, "int64_t", 1), ("receive", receive, "int64_t", 1),
                                      ("send", send, "int64_t", 1), ("flits", flits, "int32_t", 1),
                                      ("runs", runs, "int32_t", 10), ("packets", packets, "int32_t", 3)):
            if a is None:
                outs.append(ffi.NULL)
                continue
            if a.dtype != np.dtype(ctype[:-2]) or not a.flags.c_contiguous or a.size != n * width:
                raise InvalidArgument(f"cost_visits: {name} must be a contiguous {ctype[:-2]} array of "
                                      f"{n * width} entries")
            outs.append(self._out(ctype, a, n * width))
        if children.shape != (len(rays), 4) or children.dtype != np.int64 or not children.flags.c_contiguous:
            raise InvalidArgument(f"cost_visits: children must be int64[{len(rays)}, 4] as cost_children makes it")
        pk = _plain(prim_kind, np.int32)
        msg = self._cost_errmsg()
        self._cost_check(self.lib.mprt_cost_visits(t, self._in("mprt_trace_ray", rays, len(rays)),
                                                   self._in("int64_t", children, 4 * len(rays)),
                                                   len(rays), self._in("int32_t", pk, len(pk)), len(pk),
                                                   self._in("mprt_trace_visit", visits, n), n, int(prev_ray),
                                                   int(prev_outcome), *outs, int(threads), msg, len(msg)), msg)

    def visit_keys(self, visits: np.ndarray, prim_material: np.ndarray, nvoxels: int, nmaterials: int):
        """mprt_visit_keys: (keys int32 per visit, voxel_refs int64[nvoxels], material_refs
        int64[nmaterials]); ValueError naming a visit whose key does not fit."""
        visits = self._records("visits", visits, VISIT_DTYPE)
        mat = _plain(prim_material, np.int64)
        keys = np.empty(len(visits), np.int32)
        vref, mref = sparse_zeros(int(nvoxels), np.int64), np.zeros(int(nmaterials), np.int64)  # (see memkeys.c)
        msg = self._cost_errmsg()
        if self.lib.mprt_visit_keys(self._in("mprt_trace_visit", np.ascontiguousarray(visits), len(visits)),
                                    len(visits), self._in("int64_t", mat), len(mat), self._out("int32_t", keys),
                                    self._out("int64_t", vref), len(vref), self._out("int64_t", mref), len(mref),
                                    msg, len(msg)) != Status.OK:
            raise ValueError(self.ffi.string(msg).decode(errors="replace"))
        return keys, vref, mref

    def crc32_copy(self, src, crc: int = 0, dst=None) -> int:
        """zlib.crc32(src, crc) of a contiguous bytes-like object, and src's bytes copied to the
        start of dst (a writable bytes-like object at least as long, not overlapping src) in the
        same pass when dst is given; the library folds with carry-less multiplications where it
        can (several times zlib's speed) and lets other threads run meanwhile."""
        ffi = self.ffi
        s = ffi.from_buffer("char[]", src)
        d = ffi.NULL
        if dst is not None:
            d = ffi.from_buffer("char[]", dst, require_writable=True)
            if len(d) < len(s):
                raise InvalidArgument(f"crc32_copy: dst holds {len(d)} bytes, src {len(s)}")
        return int(self.lib.mprt_crc32_copy(d, s, len(s), int(crc) & 0xFFFFFFFF))

    def records_shift(self, src: np.ndarray, dst, offset: int, crc: int | None = None) -> int | None:
        """Copy the trace records src (a contiguous RAY_DTYPE or VISIT_DTYPE array) to the start of
        dst (a writable bytes-like object or array at least as long), their ray numbers moved on by
        offset (rays: id and parent unless negative; visits: ray), letting other threads run.
        With crc (zlib's running value) given, returns the CRC-32 of the bytes written, on from it."""
        if src.dtype not in (RAY_DTYPE, VISIT_DTYPE) or not src.flags.c_contiguous:
            raise InvalidArgument(f"records_shift: a contiguous array of trace records, not {src.dtype}")
        ffi = self.ffi
        s = ffi.from_buffer("char[]", src)
        d = ffi.from_buffer("char[]", dst, require_writable=True)
        if len(d) < len(s):
            raise InvalidArgument(f"records_shift: dst holds {len(d)} bytes, src {len(s)}")
        out = ffi.NULL if crc is None else ffi.new("uint32_t *", int(crc) & 0xFFFFFFFF)
        self.lib.mprt_trace_records_shift(int(src.dtype == VISIT_DTYPE), d, s, len(src), int(offset), out)
        return None if crc is None else int(out[0])
