"""A costed trace as the machine model reads it, page by page.

The machine needs, per stage visit: how long it takes (receive + process +
send cycles from the cost model), where its ray's packet goes next (the stage
of the ray's next visit), which rays an SC visit makes, and for the ring and
the memories the packet sizes and the data the visit reads.  These are
computed with numpy one page (2**14 visits) at a time, when the first ray
tree reaching into the page is admitted, and turned into Python lists (fast
to index); a page is dropped once all its visits have run.  So a trace
memory-mapped from a file replays in memory bounded by the rays in flight,
whatever its size.

A ray tree is a primary ray and all the rays made from it.  Traces made by
mprt store each tree's rays contiguously (parents before children) and its
visits contiguously (each ray's visits together, the primary's first; the
other rays in the order the tracer took them), trees in the primaries'
order; the replay checks this.
"""
from __future__ import annotations

import numpy as np

import dataclasses

from ..errors import TraceError
from ..trace import IC, PRIMARY, SC
from ..trace.tracevalid import mark_derived

PAGE_BITS = 14
PAGE = 1 << PAGE_BITS
PAGE_MASK = PAGE - 1
SCAN = 1 << 20          # visits (rays) per chunk when scanning a (memory-mapped) trace
COST_CHUNK = 1 << 18    # visits per cost-model call when costing lazily

RETIRE = -1             # dest: the ray ends here
CHILDREN = -2           # dest: the ray ends here and the visit made rays (SC)

def _fail(msg):
    raise TraceError(f"cannot replay this trace: {msg}")



def max_leaves(trace) -> int:
    """The most leaves (rays that make no rays) of any ray tree of a trace: a bound on the rays
    one tree has live at once (what the window rule ``window = "auto"`` is applied for)."""
    from ..trace import PRIMARY

    rays = trace.rays
    parent = np.asarray(rays["parent"]).astype(np.int64)
    if not len(parent):
        return 1
    has_child = np.zeros(len(parent), bool)
    has_child[parent[parent >= 0]] = True
    tree = np.cumsum(np.asarray(rays["kind"]) == PRIMARY) - 1
    return int(max(np.bincount(tree[~has_child]).max(initial=1), 1))

class Costs:
    """Per-visit cycles: ``process``, ``receive``, ``send`` and ``flits``
    (numpy arrays, one entry per visit), from arrays or from a cost model
    called on slices of the trace that start and end at ray-tree boundaries."""

    def __init__(self, trace, source, processors=None):
        self.trace = trace
        self.model = None
        self.tree_vstart = self.tree_rstart = None
        if hasattr(source, "visit_costs"):
            self.model, self.processors = source, processors
            self._chunk = (0, 0, None)
            # what SC spends making one primary ray (the same for every chunk)
            vc = self._costs(0, min(1, len(trace.visits)))
        else:
            vc = source
            self.arrays = tuple(np.asarray(getattr(source, k)) for k in ("process", "receive", "send", "flits"))
            n = len(trace.visits)
            for k, a in zip(("process", "receive", "send", "flits"), self.arrays):
                if a.shape != (n,):
                    raise ValueError(f"costs.{k} has shape {a.shape}, the trace has {n} visits")
        self.inject = tuple(int(getattr(vc, k, 0)) for k in ("inject_process", "inject_send", "inject_flits"))

    def _costs(self, a, b, ra=None, rb=None):
        """The cost model on visits [a, b); with the rays [ra, rb) of the same
        whole trees, on a self-contained copy of them (ids from 0), so that
        what the model computes per ray stays the size of the slice."""
        t = self.trace
        if ra is None:
            part = dataclasses.replace(t, visits=t.visits[a:b])
        else:
            v = np.array(t.visits[a:b])
            v["ray"] -= ra
            r = np.array(t.rays[ra:rb])
            r["id"] -= ra
            r["parent"] = np.where(r["parent"] >= 0, r["parent"] - ra, -1)
            part = dataclasses.replace(t, rays=r, visits=v)
        mark_derived(part, t)   # whole trees of a checked trace, ids from 0: in range too
        return self.model.visit_costs(part, self.processors)

    def slice(self, lo, hi):
        if self.model is None:
            return tuple(a[lo:hi] for a in self.arrays)
        a, b, arrs = self._chunk
        if not (a <= lo and hi <= b):
            tv, tr = self.tree_vstart, self.tree_rstart
            ka = int(np.searchsorted(tv, lo, "right")) - 1
            kb = min(int(np.searchsorted(tv, max(hi, lo + COST_CHUNK), "left")), len(tv) - 1)
            a, b = int(tv[ka]), int(tv[kb])
            vc = self._costs(a, b, int(tr[ka]), int(tr[kb]))
            arrs = tuple(np.asarray(getattr(vc, k)) for k in ("process", "receive", "send", "flits"))
            self._chunk = (a, b, arrs)
        return tuple(x[lo - a:hi - a] for x in arrs)


class Replay:
    """Pages of per-visit lists for the machine (see the module text).

    ``stage_of``: for subtasks OS, IC, SC the index of the stage running it.
    ``kid_flits``: flits of an SC->OS packet per ray kind (for the ring).
    ``memory``: also build each visit's memory key (IC: voxel; SC: material)."""

    def __init__(self, trace, costs: Costs, stage_of, kid_flits=None, memory=False):
        self.trace = trace
        self.costs = costs
        self.stage_of = np.asarray(stage_of, dtype=np.int64)
        self.kid_flits = None if kid_flits is None else np.asarray(kid_flits, dtype=np.int64)
        self.memory = memory
        rays, visits = trace.rays, trace.visits
        self.n_rays, self.n_visits = len(rays), len(visits)
        self._scan()
        costs.tree_vstart, costs.tree_rstart = self.tree_vstart, self.tree_rstart
        npages = (self.n_visits + PAGE - 1) >> PAGE_BITS
        self.dur = [None] * npages
        self.dest = [None] * npages
        self.kids = [None] * npages
        self.flits = [None] * npages
        self.memk = [None] * npages
        self.left = [0] * npages
        self.loaded = bytearray(npages)
        # per tree and subtask: processing, communication cycles and visits
        P = self.n_trees
        self.tree_process = np.zeros((P, 3), dtype=np.int64)
        self.tree_comm = np.zeros((P, 3), dtype=np.int64)
        self.tree_visits = np.zeros((P, 3), dtype=np.int64)
        self.pages_loaded = 0
        self.max_pages_held = 0
        self._held = 0

    # -- the scan: trees and their first visits ------------------------------
    def _scan(self):
        rays, visits = self.trace.rays, self.trace.visits
        prim = []
        for a in range(0, self.n_rays, SCAN):
            r = np.asarray(rays[a:a + SCAN])
            if not np.array_equal(r["id"], np.arange(a, a + len(r))):
                _fail("ray ids are not 0..n-1 in order")
            p = np.flatnonzero(r["kind"] == PRIMARY) + a
            prim.append(p)
        prim = np.concatenate(prim) if prim else np.zeros(0, np.int64)
        if self.n_rays and (len(prim) == 0 or prim[0] != 0):
            _fail("the first ray is not a primary ray")
        # every ray's parent lies in its own tree (trees contiguous)
        for a in range(0, self.n_rays, SCAN):
            r = np.asarray(rays[a:a + SCAN])
            ids = np.arange(a, a + len(r))
            root = prim[np.searchsorted(prim, ids, "right") - 1]
            par = r["parent"]
            bad = (r["kind"] != PRIMARY) & ((par < root) | (par >= ids))
            if bad.any():
                _fail(f"ray {int(ids[np.argmax(bad)])} is not stored after its parent within its primary's "
                      "tree (traces made by mprt are)")
        # first visit of every tree: a tree's visits are contiguous, its
        # primary's first (each ray's visits are contiguous; within a tree the
        # rays need not be in id order)
        tv = np.full(len(prim) + 1, self.n_visits, dtype=np.int64)
        prev_tree = -1
        kinds = rays["kind"]
        for a in range(0, self.n_visits, SCAN):
            vr = np.asarray(visits[a:a + SCAN]["ray"]).astype(np.int64)
            if len(vr) and (vr.min() < 0 or vr.max() >= self.n_rays):
                _fail("a visit names a ray that does not exist")
            tree = np.searchsorted(prim, vr, "right") - 1
            dt = np.diff(np.concatenate([[prev_tree], tree]))
            if np.any(dt < 0) or np.any(dt > 1):
                _fail("the visits of each primary ray's tree are not contiguous, in the primaries' order "
                      "(traces made by mprt are)")
            starts = np.flatnonzero(dt == 1)
            if np.any(vr[starts] != prim[tree[starts]]):
                _fail("a tree's first visit is not its primary ray's")
            tv[tree[starts]] = starts + a
            prev_tree = int(tree[-1])
        if prev_tree != len(prim) - 1:
            _fail("some primary rays have no visits")
        del kinds
        # the most leaves of any tree: a bound on the rays a tree has live at once
        leaves = 0
        for a in range(0, len(prim), max(1, SCAN // 16)):
            r0 = int(prim[a])
            b = min(a + max(1, SCAN // 16), len(prim))
            r1 = int(prim[b]) if b < len(prim) else self.n_rays
            r = np.asarray(rays[r0:r1])
            par = r["parent"]
            is_parent = np.zeros(r1 - r0, bool)
            is_parent[par[par >= 0] - r0] = True
            tree = np.searchsorted(prim[a:b], np.arange(r0, r1), "right") - 1
            leaves = max(leaves, int(np.bincount(tree, weights=~is_parent).max()))
        self.max_leaves = leaves
        self.prim_rays = prim
        self.tree_vstart = tv
        self.n_trees = len(prim)
        self.tree_rstart = np.concatenate([prim, [self.n_rays]]).astype(np.int64)
        self.tree_first = tv[:-1].tolist()

    # -- pages ------------------------------------------------------------------
    def ensure_tree(self, k: int) -> int:
        """Load the pages of tree k; returns its first visit."""
        v0, v1 = int(self.tree_vstart[k]), int(self.tree_vstart[k + 1])
        for p in range(v0 >> PAGE_BITS, ((v1 - 1) >> PAGE_BITS) + 1):
            if not self.loaded[p]:
                self._load(p)
        return v0

    def drop(self, p: int) -> None:
        """Every visit of page p has run (the caller counts them in ``left``)."""
        self.dur[p] = self.dest[p] = self.kids[p] = self.flits[p] = self.memk[p] = None
        self._held -= 1

    def _load(self, p):
        lo, hi = p << PAGE_BITS, min((p + 1) << PAGE_BITS, self.n_visits)
        tv = self.tree_vstart
        k0 = int(np.searchsorted(tv, lo, "right")) - 1
        k1 = int(np.searchsorted(tv, hi, "left"))          # first tree starting at or after hi
        va, vb = int(tv[k0]), int(tv[k1]) if k1 <= self.n_trees else self.n_visits
        r0, r1 = int(self.tree_rstart[k0]), int(self.tree_rstart[min(k1, self.n_trees)])
        vis = np.asarray(self.trace.visits[va:vb])
        ray = vis["ray"]
        stage = vis["stage"].astype(np.int64)
        # first visit (global index) of each ray of these trees
        starts = np.flatnonzero(np.concatenate([[True], ray[1:] != ray[:-1]]))
        first = np.empty(r1 - r0, dtype=np.int64)
        first[ray[starts] - r0] = starts + va
        a, b = lo - va, hi - va
        # the next visit (none after the last visit of the last tree here)
        m = min(b + 1, len(ray))
        nray = np.full(b - a, -1, dtype=np.int64)
        nray[:m - a - 1] = ray[a + 1:m]
        nstage = np.zeros(b - a, dtype=np.int64)
        nstage[:m - a - 1] = stage[a + 1:m]
        same = nray == ray[a:b]
        st = stage[a:b]
        made = vis["made"][a:b].astype(np.int64)
        dest = np.where(same, self.stage_of[nstage], np.where((st == SC) & (made > 0), CHILDREN, RETIRE))
        proc, recv, send, flits = self.costs.slice(lo, hi)
        proc = np.asarray(proc, dtype=np.int64)
        comm = np.asarray(recv, dtype=np.int64) + np.asarray(send, dtype=np.int64)
        dur = proc + comm
        if len(dur) and (dur.min() < 1 or proc.min() < 0 or comm.min() < 0):
            i = int(np.argmax((dur < 1) | (proc < 0) | (comm < 0)))
            raise ValueError(f"visit {lo + i}: costs must be >= 0 and a visit must last at least 1 cycle "
                             f"(process {int(proc[i])}, communication {int(comm[i])})")
        # per-tree sums by subtask
        tree = np.searchsorted(tv, np.arange(lo, hi), "right") - 1
        np.add.at(self.tree_process, (tree, st), proc)
        np.add.at(self.tree_comm, (tree, st), comm)
        np.add.at(self.tree_visits, (tree, st), 1)
        # children of SC visits: their first visits, in ray-id order
        kids = {}
        kflits = {}
        sel = np.flatnonzero(dest == CHILDREN)
        if len(sel):
            rays = np.asarray(self.trace.rays[r0:r1])
            par = rays["parent"]
            child = np.flatnonzero(par >= 0)
            order = child[np.argsort(par[child], kind="stable")]
            cpar = par[order]
            for o in sel.tolist():
                r = int(ray[a + o])
                i0, i1 = np.searchsorted(cpar, r, "left"), np.searchsorted(cpar, r, "right")
                cs = order[i0:i1]
                if i1 - i0 != made[o]:
                    _fail(f"visit {lo + o} made {int(made[o])} rays but {i1 - i0} have it as parent")
                kids[o] = tuple(first[cs].tolist())
                if self.kid_flits is not None:
                    kflits[o] = tuple(self.kid_flits[rays["kind"][cs]].tolist())
        self.dur[p] = dur.tolist()
        self.dest[p] = dest.tolist()
        self.kids[p] = kids
        if self.kid_flits is not None:
            f = np.asarray(flits, dtype=np.int64).copy()
            self.flits[p] = (f.tolist(), kflits)
        if self.memory:
            mat = np.asarray(self.trace.prim_material)
            pr = vis["prim"][a:b].astype(np.int64)
            key = np.full(b - a, -1, dtype=np.int64)
            ic = st == IC
            key[ic] = vis["voxel_id"][a:b][ic]
            scm = (st == SC) & (pr >= 0)
            key[scm] = -2 - mat[pr[scm]]
            self.memk[p] = key.tolist()
        self.left[p] = hi - lo
        self.loaded[p] = 1
        self.pages_loaded += 1
        self._held += 1
        self.max_pages_held = max(self.max_pages_held, self._held)


def dis_orders(n_trees: int, pes: int, policy: str):
    """The trees each PE's DIS admits, in order: static blocks, interleaved,
    or (dynamic) one shared sequence that every PE draws from."""
    if policy == "blocks":
        return [range(p * n_trees // pes, (p + 1) * n_trees // pes) for p in range(pes)]
    if policy == "interleaved":
        return [range(p, n_trees, pes) for p in range(pes)]
    shared = iter(range(n_trees))
    return [shared] * pes
