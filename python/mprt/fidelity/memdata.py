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
from ..machine.memory import CELL_BYTES, MATERIAL_BYTES, DataLayout, cell_index
from ..util.pages import sparse_zeros
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
    lines = cell_index(first, nl)
    per = np.zeros(nkeys, dtype=np.int64)
    np.add.at(per, owner, nl)
    return np.concatenate([[0], np.cumsum(per)]).astype(np.int64), lines


def ic_data(layout: DataLayout, items: dict, line: int, used=None) -> dict:
    """Per voxel: items read (its list, if not empty, and each primitive's shape), those
    resident, and the lines of the rest: the list's cells, then each shape in list order.
    ``used`` (sorted voxel ids): only those voxels, as keys 0, 1, ... in that order (the
    lines are the same: addresses are the whole layout's)."""
    vs = layout.voxel_start
    ids = layout.voxel_ids
    vox = np.arange(len(vs) - 1, dtype=np.int64) if used is None else np.asarray(used, dtype=np.int64)
    nk = len(vox)
    start = np.asarray(vs[vox], dtype=np.int64)
    lens = np.asarray(vs[vox + 1], dtype=np.int64) - start
    ncell = int(lens.sum())
    nonempty = lens > 0
    res_list = np.asarray(items["list"], dtype=bool)[vox]
    res_shape = np.asarray(items["shape"], dtype=bool)
    first = np.cumsum(lens) - lens                       # each key's first cell among the keys' cells
    key = np.repeat(np.arange(nk, dtype=np.int64), lens)
    cids = ids[cell_index(start, lens)] if ncell else np.zeros(0, np.int64)
    cell_res = res_shape[cids] if ncell else np.zeros(0, bool)
    resident = (nonempty & res_list).astype(np.int64) + np.bincount(key, weights=cell_res, minlength=nk).astype(
        np.int64)
    # ranges in reading order: key k's list at first[k] + k, its cells after it
    pos_list = first + np.arange(nk)
    pos_cell = np.arange(ncell, dtype=np.int64) + key + 1
    n = ncell + nk
    addr = np.empty(n, np.int64)
    size = np.empty(n, np.int64)
    keep = np.empty(n, bool)
    owner = np.empty(n, np.int64)
    addr[pos_list] = layout.list_base + CELL_BYTES * start
    size[pos_list] = CELL_BYTES * lens
    keep[pos_list] = nonempty & ~res_list
    owner[pos_list] = np.arange(nk)
    sb = layout.shape_bytes[cids] if ncell else np.zeros(0, np.int64)
    addr[pos_cell] = layout.shape_off[cids] if ncell else 0
    size[pos_cell] = sb
    keep[pos_cell] = ~cell_res & (sb > 0)
    owner[pos_cell] = key
    line_start, lines = _lines(addr[keep], size[keep], owner[keep], nk, line)
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
        self._used = None       # the voxels visited, when only those have IC data (else all: False)
        self._replay_keys = None

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

    @property
    def replay_keys(self) -> np.ndarray:
        """The visits' keys as the C replay reads them with ``get``'s data: an IC key numbers the
        voxel among those the trace visits, where fewer than half the grid's are and the grid has
        more than one voxel for every 8 visits (a small trace on a fine grid: the data of the
        rest, never read, is neither made nor copied; renumbering costs a pass over the visits,
        40 ns each, which the data of a grid's unvisited voxels repays only where it is large)."""
        self._restrict()
        return self._replay_keys

    def _restrict(self) -> None:
        if self._used is not None:
            return
        refs = self.layout.voxel_refs
        used = self.layout.used
        if 2 * len(used) >= len(refs) or 8 * len(refs) < len(self.keys):
            self._used, self._replay_keys = False, self.keys
            return
        dense = sparse_zeros(len(refs), np.int32)
        dense[used] = np.arange(len(used), dtype=np.int32)
        keys = self.keys
        ic = keys >= 0
        rk = keys.copy()
        rk[ic] = dense[keys[ic]]
        self._used, self._replay_keys = used, rk

    def reads(self, tag: str, per: np.ndarray) -> int:
        """Lines read by all the trace's visits from memory ``tag`` whose keys read ``per`` lines
        each (``get``'s keys): the sum over its visits' keys."""
        layout = self.layout
        refs = layout.voxel_refs if tag == "ic" else layout.material_refs
        if tag == "ic":
            self._restrict()
            if self._used is not False:
                refs = refs[self._used]
        if len(refs) == len(per):
            return int(np.dot(per.astype(np.int64), refs))
        keys = self.replay_keys
        sel = keys[keys >= 0] if tag == "ic" else -2 - keys[keys <= -2].astype(np.int64)
        return int(per[sel].sum(dtype=np.int64))

    def get(self, tag: str, resident: int, line: int):
        """(data dict for mprt_replay_set_memory, ResidentMemory) of memory ``tag`` ("ic", "sc"),
        its keys ``replay_keys``'."""
        key = (tag, resident, line)
        if key in self._data:
            got = self._data.pop(key)
        else:
            L = self.layout
            if tag == "ic":
                self._restrict()
                rm = L.ic_resident(resident)
                got = (ic_data(L, rm.items, line, None if self._used is False else self._used), rm)
            else:
                rm = L.sc_resident(resident)
                got = (sc_data(L, rm.items, line), rm)
            while len(self._data) >= KEEP:
                self._data.pop(next(iter(self._data)))
        self._data[key] = got
        return got
