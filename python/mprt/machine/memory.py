"""Cache, ResidentMemory and GlobalMemory for the IC and SC data.

Data layout (bytes).  IC data, in ICGM: the primitive lists, one 8-byte cell
per entry (pointer to the shape data, pointer to the next cell), voxel after
voxel in the trace's CSR order; then every primitive's shape data
(``prim_words`` 32-bit words), primitive after primitive.  SC data, in SCGM:
one 32-byte shading record per material (colour, Kd, Ks, shine, T, index).

An IC visit of voxel v reads v's list and the shape data of every primitive
in it; an SC visit that shades a hit reads the hit primitive's material.
The base costs assume every access hits (the paper's 100%), so a resident or
cached access adds nothing; each line that misses adds the global memory's
latency and the line's transfer time, misses of one visit one after the
other, all computed when the visit starts.  A global memory port serves
transfers first come, first served (in the order visits start); with
contention the PEs share one port, else each has its own.

The resident set is chosen before the run by reference frequency (the
paper's preprocessing pass): every item (a voxel's list, a primitive's
shape data, a material) counted over the whole trace, taken in decreasing
order of references (ties: lists before shapes, lower id first) while it
fits; an item that does not fit is skipped.
"""
from __future__ import annotations

from collections import defaultdict

import numpy as np

from ..util.pages import sparse_zeros
from ..trace import IC, SC

CELL_BYTES = 8
WORD_BYTES = 4
MATERIAL_BYTES = 32
SCAN = 1 << 22


class Cache:
    """A set-associative cache with LRU replacement."""

    def __init__(self, cfg):
        self.line = cfg.line
        self.ways = cfg.ways
        self.nsets = cfg.size // (cfg.line * cfg.ways)
        self.sets = defaultdict(list)     # set index -> lines, least recently used first (made when used)
        self.accesses = 0
        self.hits = 0

    def access(self, line: int) -> bool:
        """Look up a line (address // line size); True on a hit.  The line
        becomes the most recently used of its set."""
        self.accesses += 1
        s = self.sets[line % self.nsets]
        if line in s:
            self.hits += 1
            if s[-1] != line:
                s.remove(line)
                s.append(line)
            return True
        s.append(line)
        if len(s) > self.ways:
            del s[0]
        return False


class ResidentMemory:
    """The items chosen for resident memory (replicated in every PE)."""

    def __init__(self, size: int, items: dict):
        self.size = size
        self.items = items           # kind -> boolean array over ids
        self.used = 0
        self.accesses = 0
        self.hits = 0


class GlobalMemory:
    """ICGM or SCGM: latency, bandwidth (bytes per cycle), ports."""

    def __init__(self, name, cfg, pes: int):
        self.name = name
        self.latency = cfg.latency
        self.bandwidth = cfg.bandwidth
        self.contention = cfg.contention
        self.port_free = [0] * (1 if cfg.contention else pes)
        self.accesses = 0
        self.busy = 0
        self.queued = 0              # cycles transfers waited for the port

    def read(self, t: int, nbytes: int, pe: int) -> int:
        """A read of nbytes issued at t; returns when its data is back."""
        port = 0 if self.contention else pe
        start = max(t, self.port_free[port])
        xfer = -(-nbytes // self.bandwidth)
        self.port_free[port] = start + xfer
        self.accesses += 1
        self.busy += xfer
        self.queued += start - t
        return start + xfer + self.latency

    def read_lines(self, t: int, nbytes: int, pe: int, n: int) -> int:
        """n reads of nbytes one after another, each issued when the last one's data is back:
        the same as n calls of ``read``.  After the first, the port is free again by the time
        the next read is issued (its transfer ended ``latency`` cycles before), so each later
        read takes its transfer and the latency, and none waits."""
        if n <= 0:
            return t
        done = self.read(t, nbytes, pe)
        if n > 1:
            xfer = -(-nbytes // self.bandwidth)
            done += (n - 1) * (xfer + self.latency)
            self.port_free[0 if self.contention else pe] = done - self.latency
            self.accesses += n - 1
            self.busy += (n - 1) * xfer
        return done


def cell_index(start: np.ndarray, lens: np.ndarray) -> np.ndarray:
    """The positions start[k] .. start[k] + lens[k] - 1 of each k in turn (int64 arrays)."""
    total = int(lens.sum())
    return np.repeat(start - (np.cumsum(lens) - lens), lens) + np.arange(total, dtype=np.int64)


def _greedy(nbytes, size: int) -> np.ndarray:
    """Which items, in the given order, are taken when each is taken if it still fits
    (boolean array).  Vectorised: a prefix that fits is taken, the next item is not, and
    items larger than what is left can never be; repeated on the rest."""
    nbytes = np.asarray(nbytes, dtype=np.int64)
    take = np.zeros(len(nbytes), dtype=bool)
    idx = np.arange(len(nbytes))
    b = nbytes
    rem = int(size)
    rounds = 0
    while len(idx):
        rounds += 1
        if rounds > 64:                       # a long tail of near misses: one by one
            for i, n in zip(idx.tolist(), b.tolist()):
                if n <= rem:
                    take[i] = True
                    rem -= n
            break
        cs = np.cumsum(b)
        k = int(np.searchsorted(cs, rem, "right"))
        take[idx[:k]] = True
        if k == len(idx):
            break
        if k:
            rem -= int(cs[k - 1])
        keep = b[k + 1:] <= rem
        idx, b = idx[k + 1:][keep], b[k + 1:][keep]
    return take


class DataLayout:
    """Addresses and reference counts of the IC and SC data of a trace."""

    def __init__(self, trace, refs: tuple | None = None):
        """``refs``: (voxel_refs, material_refs) when already counted (``fidelity.memdata``,
        in C); else counted here over the trace's visits.

        Only the voxels the trace visits are gone through (``used``, their lists' ``used_start``
        and ``used_lens``): a small trace on a fine grid (the explorer's 64x64 searches reach
        256x256x256, 16 M voxels) costs what it visits, not the grid's size."""
        self.voxel_start = np.asarray(trace.voxel_start)         # as stored: read where used
        self.voxel_ids = np.asarray(trace.voxel_ids)
        words = np.asarray(trace.prim_words, dtype=np.int64)
        self.material = np.asarray(trace.prim_material, dtype=np.int64)
        self.list_base = 0
        self.shape_base = CELL_BYTES * int(self.voxel_start[-1])
        self.shape_off = self.shape_base + WORD_BYTES * np.concatenate([[0], np.cumsum(words)[:-1]])
        self.shape_bytes = WORD_BYTES * words
        nvox = len(self.voxel_start) - 1
        nmat = int(self.material.max()) + 1 if len(self.material) else 1
        # reference counts over the trace (chunked: a memory-mapped trace stays on disk)
        v = trace.visits
        if refs is not None:                          # (shared, not copied: neither is written)
            self.voxel_refs = np.asarray(refs[0], dtype=np.int64).reshape(nvox)
            self.material_refs = np.asarray(refs[1], dtype=np.int64).reshape(nmat)
            v = v[:0]
        else:
            self.voxel_refs = sparse_zeros(nvox, np.int64)
            self.material_refs = np.zeros(nmat, dtype=np.int64)
        for a in range(0, len(v), SCAN):
            c = np.asarray(v[a:a + SCAN])
            st = c["stage"]
            vox = c["voxel_id"][st == IC]
            self.voxel_refs += np.bincount(vox[vox >= 0], minlength=nvox)
            pr = c["prim"][(st == SC) & (c["prim"] >= 0)]
            self.material_refs += np.bincount(self.material[pr], minlength=nmat)
        self.used = np.flatnonzero(self.voxel_refs)
        self.used_start = self.voxel_start[self.used].astype(np.int64)
        self.used_lens = self.voxel_start[self.used + 1].astype(np.int64) - self.used_start
        # each primitive's references: those of the voxels listing it (the unvisited add none)
        cells = cell_index(self.used_start, self.used_lens)
        self.prim_refs = np.bincount(self.voxel_ids[cells], weights=np.repeat(self.voxel_refs[self.used],
                                     self.used_lens), minlength=len(words)).astype(np.int64)

    def ic_resident(self, size: int) -> ResidentMemory:
        lens = self.used_lens
        vox = self.used[lens > 0]
        lens = lens[lens > 0]
        prim = np.flatnonzero(self.prim_refs > 0)
        refs = np.concatenate([self.voxel_refs[vox], self.prim_refs[prim]])
        kind = np.concatenate([np.zeros(len(vox), np.int64), np.ones(len(prim), np.int64)])
        ids = np.concatenate([vox, prim])
        nbytes = np.concatenate([CELL_BYTES * lens, self.shape_bytes[prim]])
        order = np.lexsort((ids, kind, -refs))        # most referenced first; lists first; lower id
        take = np.zeros(len(order), bool)
        take[order] = _greedy(nbytes[order], size)
        items = {"list": sparse_zeros(len(self.voxel_refs), bool), "shape": np.zeros(len(self.shape_bytes), bool)}
        items["list"][vox[take[:len(vox)]]] = True
        items["shape"][prim[take[len(vox):]]] = True
        rm = ResidentMemory(size, items)
        rm.used = int(nbytes[take].sum())
        return rm

    def sc_resident(self, size: int) -> ResidentMemory:
        mat = np.flatnonzero(self.material_refs > 0)
        order = np.lexsort((mat, -self.material_refs[mat]))
        take = np.zeros(len(mat), bool)
        take[order] = _greedy(np.full(len(mat), MATERIAL_BYTES), size)
        items = {"material": np.zeros(len(self.material_refs), bool)}
        items["material"][mat[take]] = True
        rm = ResidentMemory(size, items)
        rm.used = MATERIAL_BYTES * int(take.sum())
        return rm


class LocalMemory:
    """One PE's local memory for IC (or SC) data: resident part, cache, and
    the global memory behind them; ``stall`` gives a visit's extra cycles."""

    def __init__(self, kind, layout: DataLayout, resident: ResidentMemory, cache: Cache | None,
                 gm: GlobalMemory, pe: int):
        self.kind, self.layout, self.resident, self.cache, self.gm, self.pe = kind, layout, resident, cache, gm, pe
        self._lines = {}             # key -> (resident items, items, lines outside resident memory)
        self.stall_cycles = 0
        self.line = cache.line if cache is not None else 32

    def _ranges(self, key):
        L = self.layout
        r = self.resident.items
        if self.kind == "ic":
            v = key
            a, b = int(L.voxel_start[v]), int(L.voxel_start[v + 1])
            ranges = []
            nres = 0
            nitems = (1 if b > a else 0) + (b - a)
            if b > a:
                if r["list"][v]:
                    nres += 1
                else:
                    ranges.append((L.list_base + CELL_BYTES * a, CELL_BYTES * (b - a)))
            for p in L.voxel_ids[a:b].tolist():
                if r["shape"][p]:
                    nres += 1
                elif L.shape_bytes[p]:
                    ranges.append((int(L.shape_off[p]), int(L.shape_bytes[p])))
        else:
            m = -2 - key
            nitems = 1
            if r["material"][m]:
                nres, ranges = 1, []
            else:
                nres, ranges = 0, [(MATERIAL_BYTES * m, MATERIAL_BYTES)]
        lines = []
        for addr, n in ranges:
            lines.extend(range(addr // self.line, (addr + n - 1) // self.line + 1))
        out = (nres, nitems, tuple(lines))
        self._lines[key] = out
        return out

    def stall(self, key: int, t: int) -> int:
        got = self._lines.get(key)
        nres, nitems, lines = got if got is not None else self._ranges(key)
        self.resident.accesses += nitems
        self.resident.hits += nres
        cache = self.cache
        if cache is None:
            misses = len(lines)
        else:                       # Cache.access, inlined (the hot loop of level 3)
            misses = 0
            sets, nsets, ways = cache.sets, cache.nsets, cache.ways
            hits = 0
            for line in lines:
                st = sets[line % nsets]
                if line in st:
                    hits += 1
                    if st[-1] != line:
                        st.remove(line)
                        st.append(line)
                else:
                    st.append(line)
                    if len(st) > ways:
                        del st[0]
                    misses += 1
            cache.accesses += len(lines)
            cache.hits += hits
        done = self.gm.read_lines(t, self.line, self.pe, misses)
        s = done - t
        self.stall_cycles += s
        return s


class StageMemory:
    """The local memories a stage's visits read: IC keys are voxel ids
    (>= 0), SC keys -2 - material."""

    def __init__(self, ic: LocalMemory | None, sc: LocalMemory | None):
        self.ic, self.sc = ic, sc

    def stall(self, key: int, t: int) -> int:
        m = self.ic if key >= 0 else self.sc
        return 0 if m is None else m.stall(key, t)
