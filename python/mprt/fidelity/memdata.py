"""Level 3's data for the compiled replay, computed with numpy once per trace and
memory configuration.

The SimPy model (``mprt.machine.memory``) works out, the first time a visit
reads a key (IC: a voxel, SC: a material), how many items it reads, how many
of them are resident and which lines it reads outside resident memory.  Here
the same is computed for every key at once, vectorised, and handed to the C
replay (``mprt_replay_set_memory``) with each visit's key; the resident set is
the SimPy model's own choice (``DataLayout.ic_resident``/``sc_resident``).

``MemoryData(trace)`` scans the trace once (reference counts, visit keys) and
keeps the per-key data of the last few (memory, resident size, line size)
asked for, so a search over cache sizes, ways, latencies or ports reuses it.
"""
from __future__ import annotations

import weakref

import numpy as np

from .._lowlevel import binding
from ..cost.fast import usable as fast_usable
from ..machine.memory import CELL_BYTES, MATERIAL_BYTES, DataLayout
from ..trace import IC, SC

SCAN = 1 << 22
KEEP = 6            # (memory, resident, line) entries kept


def visit_keys(trace) -> np.ndarray:
    """Per visit, the key of the data it reads, as the SimPy replay's pages hold it: an IC
    visit's voxel (>= 0), an SC visit that shades a hit -2 - its material, else -1 (int32)."""
    v = trace.visits
    mat = np.asarray(trace.prim_material, dtype=np.int64)
    out = np.full(len(v), -1, dtype=np.int32)
    stage, voxel, prim = v["stage"], v["voxel_id"], v["prim"]      # field views: only these are read
    for a in range(0, len(v), SCAN):
        st = np.asarray(stage[a:a + SCAN])
        pr = np.asarray(prim[a:a + SCAN]).astype(np.int64)
        k = np.where(st == IC, np.asarray(voxel[a:a + SCAN]), -1)
        scm = (st == SC) & (pr >= 0)
        k[scm] = -2 - mat[pr[scm]]
        if len(k) and (k.max() >= 1 << 31 or k.min() < -(1 << 31)):
            raise ValueError("memory keys: a voxel or material id does not fit 32 bits")
        out[a:a + len(k)] = k
    return out


def _lines(addr, size, owner, nkeys, line):
    """Per key (owner, sorted), the lines of its byte ranges in order: (line_start, lines)."""
    first = addr // line
    nl = (addr + size - 1) // line - first + 1
    total = int(nl.sum())
    starts = np.cumsum(nl) - nl
    lines = np.repeat(first - starts, nl) + np.arange(total, dtype=np.int64)
    per = np.zeros(nkeys, dtype=np.int64)
    np.add.at(per, owner, nl)
    return np.concatenate([[0], np.cumsum(per)]).astype(np.int64), lines


def ic_data(layout: DataLayout, items: dict, line: int) -> dict:
    """Per voxel: items read (its list, if not empty, and each primitive's shape), those
    resident, and the lines of the rest: the list's cells, then each shape in list order."""
    vs = layout.voxel_start
    ids = layout.voxel_ids
    nvox = len(vs) - 1
    ncell = int(vs[-1])
    lens = np.diff(vs)
    nonempty = lens > 0
    res_list = np.asarray(items["list"], dtype=bool)
    res_shape = np.asarray(items["shape"], dtype=bool)
    vox = np.repeat(np.arange(nvox, dtype=np.int64), lens)
    cell_res = res_shape[ids] if ncell else np.zeros(0, bool)
    resident = (nonempty & res_list).astype(np.int64) + np.bincount(vox, weights=cell_res, minlength=nvox).astype(
        np.int64)
    # ranges in reading order: voxel v's list at start[v] + v, its cells after it
    pos_list = vs[:-1] + np.arange(nvox)
    pos_cell = np.arange(ncell, dtype=np.int64) + vox + 1
    n = ncell + nvox
    addr = np.empty(n, np.int64)
    size = np.empty(n, np.int64)
    keep = np.empty(n, bool)
    owner = np.empty(n, np.int64)
    addr[pos_list] = layout.list_base + CELL_BYTES * vs[:-1]
    size[pos_list] = CELL_BYTES * lens
    keep[pos_list] = nonempty & ~res_list
    owner[pos_list] = np.arange(nvox)
    sb = layout.shape_bytes[ids] if ncell else np.zeros(0, np.int64)
    addr[pos_cell] = layout.shape_off[ids] if ncell else 0
    size[pos_cell] = sb
    keep[pos_cell] = ~cell_res & (sb > 0)
    owner[pos_cell] = vox
    line_start, lines = _lines(addr[keep], size[keep], owner[keep], nvox, line)
    return {"line": line, "items": (nonempty + lens).astype(np.int32), "resident": resident.astype(np.int32),
            "line_start": line_start, "lines": lines}


def sc_data(layout: DataLayout, items: dict, line: int) -> dict:
    """Per material: one item (its shading record), resident or read in lines."""
    res = np.asarray(items["material"], dtype=bool)
    nmat = len(res)
    m = np.flatnonzero(~res)
    line_start, lines = _lines(MATERIAL_BYTES * m, np.full(len(m), MATERIAL_BYTES, np.int64), m, nmat, line)
    return {"line": line, "items": np.ones(nmat, np.int32), "resident": res.astype(np.int32),
            "line_start": line_start, "lines": lines}


class MemoryData:
    """A trace's memory keys and layout, and per (memory, resident bytes, line bytes) the
    data the C replay reads with the resident memory chosen (``ResidentMemory``).
    ``MemoryData.of(trace)`` shares one per trace while anything holds it."""

    _live = weakref.WeakValueDictionary()     # id(trace) -> MemoryData (which keeps its trace alive)

    @classmethod
    def of(cls, trace) -> "MemoryData":
        md = cls._live.get(id(trace))
        if md is None or md.trace is not trace:
            md = cls(trace)
            cls._live[id(trace)] = md
        return md

    def __init__(self, trace):
        self.trace = trace
        self._layout = None
        self._keys = None
        self._refs = None       # (voxel_refs, material_refs) when counted in C with the keys
        self._data = {}

    @property
    def layout(self) -> DataLayout:
        if self._layout is None:
            self._scan()
            self._layout = DataLayout(self.trace, self._refs)
        return self._layout

    @property
    def keys(self) -> np.ndarray:
        self._scan()
        return self._keys

    def _scan(self) -> None:
        """The keys, and with them in C the references to each (one pass over the records)."""
        if self._keys is not None:
            return
        t = self.trace
        made = getattr(t, "memory_keys", None)      # made by load_trace as it checked the records
        if made is not None and fast_usable(t) and len(made[0]) == len(t.visits):
            self._keys, vref, mref = made
            self._refs = (vref, mref)
            return
        mat = np.asarray(t.prim_material, dtype=np.int64)
        if fast_usable(t):
            nmat = int(mat.max()) + 1 if len(mat) else 1
            self._keys, vref, mref = binding("double").visit_keys(t.visits, mat, len(t.voxel_start) - 1, nmat)
            self._refs = (vref, mref)
        else:
            self._keys = visit_keys(t)

    def reads(self, tag: str, per: np.ndarray) -> int:
        """Lines read by all the trace's visits from memory ``tag`` whose keys read ``per`` lines
        each: the sum over its visits' keys."""
        layout = self.layout
        refs = layout.voxel_refs if tag == "ic" else layout.material_refs
        if len(refs) == len(per):
            return int(np.dot(per.astype(np.int64), refs))
        keys = self.keys
        sel = keys[keys >= 0] if tag == "ic" else -2 - keys[keys <= -2].astype(np.int64)
        return int(per[sel].sum(dtype=np.int64))

    def get(self, tag: str, resident: int, line: int):
        """(data dict for mprt_replay_set_memory, ResidentMemory) of memory ``tag`` ("ic", "sc")."""
        key = (tag, resident, line)
        if key in self._data:
            got = self._data.pop(key)
        else:
            L = self.layout
            rm = L.ic_resident(resident) if tag == "ic" else L.sc_resident(resident)
            got = ((ic_data if tag == "ic" else sc_data)(L, rm.items, line), rm)
            while len(self._data) >= KEEP:
                self._data.pop(next(iter(self._data)))
        self._data[key] = got
        return got
