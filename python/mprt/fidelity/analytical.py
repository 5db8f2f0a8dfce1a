"""Level 0: the machine's time from the costed trace alone (numpy, no replay).

Per tree (a primary ray and the rays made from it) the costed trace gives its
work on each subtask (the sum of its visits' cycles) and its critical path
(the longest chain of visits a ray and its descendants must run one after
another: a ray's visits in order, its children after its SC visit).  For a
configuration, each PE's trees (in the order its DIS takes them) are cut into
chunks of about as many trees as the window holds at once, and

    estimate = sum over chunks of max( the largest stage load in the chunk,
                                       the chunk's critical paths / window )
               + fill and drain,

a stage's load being its subtasks' work divided among its replicas (and, on
the stage running SC, the cycles of making the chunk's primary rays).  The sum
of per-chunk maxima follows the bottleneck as it moves from stage to stage
across the frame (a frame is IC-bound here and SC-bound there); the window term
is Little's law (a tree holds at least one of the window's places for its
whole critical path); fill and drain is the mean critical path's part off the
bottleneck (the first rays' work before the bottleneck has any, the last rays'
after it is done).  With one stage of one processor (model S) the estimate is
exact: the processor never waits.  Several PEs: each PE's estimate, the
largest taken; a dynamic DIS is treated as interleaved.

``lower_bound`` holds for any configuration: no stage can finish before its
load, no tree before its critical path, and a window of W rays runs at most W
trees at once.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..machine.config import SUBTASKS, SystemConfig
from ..trace import PRIMARY
from .views import REPLAY_NODE_DTYPE, REPLAY_PE_DTYPE, REPLAY_PROC_DTYPE, SystemView


CHUNK_WINDOWS = 1.0


@dataclass
class Estimate:
    """Level 0's figures for one configuration (cycles)."""

    cycles: int
    lower_bound: int
    loads: dict = field(default_factory=dict)       # stage name -> largest per-PE load per processor
    bottleneck: str = ""
    fill_drain: int = 0


class Analytical:
    """A costed trace reduced to per-tree figures; ``estimate(config)`` is then
    a few numpy passes over the trees.  ``costs`` as the cost model's
    ``visit_costs`` gives them (process, receive, send, inject_process,
    inject_send)."""

    def __init__(self, trace, costs):
        rays, visits = trace.rays, trace.visits
        kind = np.asarray(rays["kind"])
        parent = np.asarray(rays["parent"]).astype(np.int64)
        nr, nv = len(kind), len(visits)
        prim = np.flatnonzero(kind == PRIMARY)
        self.ntrees = len(prim)
        dur = (np.asarray(costs.process, np.int64) + np.asarray(costs.receive, np.int64)
               + np.asarray(costs.send, np.int64))
        if dur.shape != (nv,):
            raise ValueError(f"costs have {dur.shape[0]} entries, the trace has {nv} visits")
        self.gen = int(getattr(costs, "inject_process", 0)) + int(getattr(costs, "inject_send", 0))
        vray = np.asarray(visits["ray"]).astype(np.int64)
        stage = np.asarray(visits["stage"]).astype(np.int64)
        tree_of_ray = np.searchsorted(prim, np.arange(nr), "right") - 1
        vtree = tree_of_ray[vray]
        # per tree and subtask: process and communication cycles, visits
        self.proc = np.zeros((self.ntrees, 3), np.int64)
        self.comm = np.zeros((self.ntrees, 3), np.int64)
        self.nvis = np.zeros((self.ntrees, 3), np.int64)
        np.add.at(self.proc, (vtree, stage), np.asarray(costs.process, np.int64))
        np.add.at(self.comm, (vtree, stage), dur - np.asarray(costs.process, np.int64))
        np.add.at(self.nvis, (vtree, stage), 1)
        self.work = self.proc + self.comm
        self.tree_rays = np.bincount(tree_of_ray, minlength=self.ntrees)
        self.trace = trace
        self.gen_process = int(getattr(costs, "inject_process", 0))
        self.gen_send = int(getattr(costs, "inject_send", 0))
        # critical path per tree: a ray's own visits, then its longest child chain
        own = np.bincount(vray, weights=dur, minlength=nr).astype(np.int64)
        # rays by generation (a primary's children are generation 1, ...), children after parents
        kids = np.flatnonzero(parent >= 0)
        level = np.zeros(nr, np.int64)
        for _ in range(nr + 1):
            nxt = level.copy()
            nxt[kids] = level[parent[kids]] + 1
            if np.array_equal(nxt, level):
                break
            level = nxt
        else:
            raise ValueError("ray parents form a cycle")
        chain = own.copy()
        best = np.zeros(nr, np.int64)
        order = kids[np.argsort(-level[kids], kind="stable")]
        bounds = np.flatnonzero(np.diff(level[order])) + 1
        for idx in np.split(order, bounds):
            chain[idx] = own[idx] + best[idx]
            np.maximum.at(best, parent[idx], chain[idx])
        chain[prim] = own[prim] + best[prim]
        self.critical = chain[prim] + self.gen
        self.rays_per_tree = nr / max(self.ntrees, 1)

    def _trees_of(self, config: SystemConfig):
        """Each PE's trees in its DIS's order (dynamic as interleaved)."""
        n, pes = self.ntrees, config.pes
        if config.dis == "blocks":
            return [np.arange(p * n // pes, (p + 1) * n // pes) for p in range(pes)]
        return [np.arange(p, n, pes) for p in range(pes)]

    def stage_work(self, config: SystemConfig) -> np.ndarray:
        """Per tree, each configured stage's work per processor (cycles; trees x stages)."""
        out = np.zeros((self.ntrees, len(config.stages)))
        for i, st in enumerate(config.stages):
            for t in st.subtasks:
                out[:, i] += self.work[:, SUBTASKS.index(t)]
            if "SC" in st.subtasks:
                out[:, i] += self.gen
            out[:, i] /= st.replicas
        return out

    def chunk(self, config: SystemConfig, windows: float | None = None) -> int:
        """Trees per chunk: about ``windows`` (default CHUNK_WINDOWS) windows of rays."""
        w = CHUNK_WINDOWS if windows is None else windows
        return max(1, int(round(w * config.window / self.rays_per_tree)))

    def estimate(self, config: SystemConfig, windows: float | None = None) -> Estimate:
        """Level 0's estimate (``windows``: chunks of that many windows instead of CHUNK_WINDOWS)."""
        return self._estimate(config, windows)[0]

    def _estimate(self, config: SystemConfig, windows: float | None = None):
        """(Estimate, each PE's trees, each PE's time)."""
        sw = self.stage_work(config)
        names = [s.name for s in config.stages]
        chunk = self.chunk(config, windows)
        best = (-1.0, 0.0, np.zeros(len(names)))
        lower = float(self.critical.max(initial=0))
        split = self._trees_of(config)
        ends = []
        for trees in split:
            w, c = sw[trees], self.critical[trees].astype(np.float64)
            loads = w.sum(axis=0)
            starts = np.arange(0, len(trees), chunk)
            per_chunk = np.maximum(np.add.reduceat(w, starts, axis=0).max(axis=1),
                                   np.add.reduceat(c, starts) / config.window) if len(trees) else np.zeros(0)
            b = int(np.argmax(loads)) if len(names) else 0
            fill = max(0.0, float(np.mean(c - w[:, b]))) if len(trees) else 0.0
            total = float(per_chunk.sum()) + fill
            ends.append(total)
            if total > best[0]:
                best = (total, fill, loads)
            lower = max(lower, float(loads.max(initial=0)), float(c.sum()) / config.window)
        if config.dis == "dynamic" and config.pes > 1:
            # any PE may take any tree: only the work shared among all PEs bounds the time
            lower = max(float(self.critical.max(initial=0)), float(sw.sum(axis=0).max(initial=0)) / config.pes,
                        float(self.critical.sum()) / (config.window * config.pes))
        total, fill, loads = best
        b = int(np.argmax(loads))
        est = Estimate(cycles=int(np.ceil(total)), lower_bound=int(np.floor(lower)),
                       loads={n: float(v) for n, v in zip(names, loads)}, bottleneck=names[b],
                       fill_drain=int(round(fill)))
        return est, split, ends

    def result(self, config: SystemConfig):
        """The estimate as the machine model's SimResult (level 0): each stage's processing and
        communication are the trace's (exact), its waiting the estimated time's rest; FIFO,
        occupancy and live-ray figures are not modelled (zero)."""
        est, split, ends = self._estimate(config)
        ns = len(config.stages)
        gen = self.gen_process + self.gen_send
        pes = np.zeros(config.pes, REPLAY_PE_DTYPE)
        nodes = np.zeros(config.pes * ns, REPLAY_NODE_DTYPE)
        procs = np.zeros(config.pes * sum(st.replicas for st in config.stages), REPLAY_PROC_DTYPE)
        procs["visit"] = -1
        first = 0
        for p, trees in enumerate(split):
            pr, co, nv = self.proc[trees].sum(axis=0), self.comm[trees].sum(axis=0), self.nvis[trees].sum(axis=0)
            end = int(np.ceil(ends[p]))
            for i, st in enumerate(config.stages):
                subs = [SUBTASKS.index(t) for t in st.subtasks]
                made = len(trees) if gen > 0 and "SC" in st.subtasks else 0
                busy = int(pr[subs].sum() + co[subs].sum()) + made * gen
                visits = int(nv[subs].sum()) + made
                r = st.replicas
                k = np.arange(r)
                procs["busy"][first:first + r] = busy // r + (k < busy % r)
                procs["visits"][first:first + r] = visits // r + (k < visits % r)
                nodes["generated"][p * ns + i] = made
                end = max(end, -(-busy // r))
                first += r
            pes[p]["admitted"], pes[p]["retired"] = len(trees), int(self.tree_rays[trees].sum())
            pes[p]["end"] = end
            pes[p]["processing"], pes[p]["communication"], pes[p]["visits"] = pr, co, nv
        view = SystemView(self.trace, config, int(pes["end"].max(initial=0)), int(pes["retired"].sum()), pes, procs,
                          nodes, self.gen_process, self.gen_send, len(self.trace.visits), len(self.trace.rays), 0)
        res = view.result()
        res.level = 0
        return res

    def _group_chunks(self, config: SystemConfig, tree_group: np.ndarray):
        """(first tree of each chunk, its time): trees chunked as they come, a chunk never
        spanning two runs of one group's trees."""
        sw = self.stage_work(config)
        c = self.critical.astype(np.float64)
        tt = np.asarray(tree_group)
        chunk = self.chunk(config)
        run0 = np.flatnonzero(np.concatenate([[True], tt[1:] != tt[:-1]]))
        pos = np.arange(len(tt)) - np.repeat(run0, np.diff(np.concatenate([run0, [len(tt)]])))
        cut = np.flatnonzero((pos % chunk) == 0)
        return cut, np.maximum(np.add.reduceat(sw, cut, axis=0).max(axis=1), np.add.reduceat(c, cut) / config.window)

    def tree_times(self, config: SystemConfig, tree_group: np.ndarray) -> np.ndarray:
        """Per tree, its share of level 0's time on one PE, chunked as ``tile_times`` chunks
        (runs of one group's trees): each chunk's time spread evenly over its trees."""
        if len(tree_group) == 0:
            return np.zeros(0)
        cut, per_chunk = self._group_chunks(config, tree_group)
        size = np.diff(np.append(cut, len(tree_group)))
        return np.repeat(per_chunk / size, size)

    def tile_times(self, config: SystemConfig, tree_tile: np.ndarray):
        """(tiles, times): the level-0 time of each tile's trees on one PE of the
        configuration, chunked as the trees come (runs of one tile's trees): the sizes a
        sampled replay scales by.  ``tree_tile``: each tree's tile; tiles sorted."""
        tt = np.asarray(tree_tile)
        if len(tt) == 0:
            return np.zeros(0, np.int64), np.zeros(0)
        cut, per_chunk = self._group_chunks(config, tt)
        tiles, idx = np.unique(tt[cut], return_inverse=True)
        return tiles, np.bincount(idx, weights=per_chunk, minlength=len(tiles))
