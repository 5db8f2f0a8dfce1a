"""Evaluating a design on a trace: ``evaluate(trace, design, level)``.

Level 0 is analytical (numpy): each visit costs its receive, process and send
cycles on the processor that runs its subtask (from the cost model's
``visit_costs``); a packet between two subtasks on the same processor costs
nothing, since the ray never leaves the processor.  Pixels go to PEs
interleaved.  Per PE, a processor's load is the sum of its visits' costs,
divided among its copies.  Model S (one processor) takes the sum.  A pipeline
takes its largest processor load plus a fill and drain estimate: at the start
the bottleneck waits for the first rays' work upstream of it, at the end the
last rays' work downstream of it remains, together about one pixel's work off
the bottleneck processor (the mean over the PE's pixels).

Levels 1 and up replay the trace on the machine model (``mprt.machine``)
where it is in the package; the fidelity ladder (issue 8) may replace level 0
with its own, behind this same function.
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field

import numpy as np

from .hwcost import UnitCosts, cost_breakdown
from .space import STAGE_NAMES, Design, processor_name, processors


def _cost_source():
    """The cost model's ``visit_costs`` with processors given as units dicts."""
    from ..cost import CostModel, ProcessorConfig

    cm = CostModel.default()

    def visit_costs(trace, procs):
        return cm.visit_costs(trace, {s: _processor_config(ProcessorConfig, u) for s, u in procs.items()})
    visit_costs.model = cm
    return "mprt.cost", visit_costs


def _processor_config(ProcessorConfig, units: dict):
    units = {k: int(v) for k, v in units.items() if v}
    if units == {"general": 1}:
        return ProcessorConfig.sequential()
    return ProcessorConfig(units=units)


class _LinearPricing:
    """Per-pixel sums of each stage's kernel runs and packet sizes, so a new
    processor is priced by a product over pixels instead of a pass over the
    visits: a visit's cycles are its kernel runs times the kernels' cycles
    (the cost model's definition).  It reads the cost model's per-visit
    counts; Level0 checks it against ``visit_costs`` on the first design and
    drops it on any difference."""

    def __init__(self, trace, cm, pix, npix, stage, src, dst, primaries, chunk=1 << 20):
        from ..cost.model import STAGE_KERNELS, _TraceContext

        self.cm, self.kernels = cm, STAGE_KERNELS
        ctx = _TraceContext(trace)
        self.runs = {s: np.zeros((len(STAGE_KERNELS[s]) + 1, npix)) for s in STAGE_NAMES}   # + visits
        self.rin = np.zeros((3, 2, 3, npix))       # stage, (packets, flits), source stage
        self.out = np.zeros((3, 2, 4, npix))       # stage, (packets, flits), destination stage (3: none)
        visits = trace.visits
        for a in range(0, len(visits), chunk):
            v = np.asarray(visits[a:a + chunk])
            counts, packets = ctx.visit_counts(v, a)
            p, st = pix[a:a + len(v)], stage[a:a + len(v)]
            sr, ds = src[a:a + len(v)], dst[a:a + len(v)] % 4
            for c, name in enumerate(STAGE_NAMES):
                m = st == c
                pm = p[m]
                for i, k in enumerate(STAGE_KERNELS[name]):
                    if k in counts[name]:
                        self.runs[name][i] += np.bincount(pm, weights=counts[name][k], minlength=npix)
                self.runs[name][-1] += np.bincount(pm, minlength=npix)
                for j, w in enumerate((np.ones(int(m.sum())), packets["in"][m])):
                    self.rin[c, j] += np.bincount(sr[m] * npix + pm, weights=w, minlength=3 * npix).reshape(3, npix)
                for j, w in enumerate((packets["out_packets"][m], packets["out"][m])):
                    self.out[c, j] += np.bincount(ds[m] * npix + pm, weights=w, minlength=4 * npix).reshape(4, npix)
        self.primaries = primaries

    def aggregate(self, c: int, proc) -> tuple:
        from ..cost.model import _FLITS

        name = STAGE_NAMES[c]
        cm = self.cm
        cyc = np.array([cm.kernel_cycles(k, proc) if k != "sc_primary" else 0 for k in self.kernels[name]]
                       + [cm.visit_overhead[name]], dtype=np.float64)
        process = cyc @ self.runs[name]
        sp, sf, rp, rf = (cm.kernel_cycles(k, proc) for k in ("send_packet", "send_flit", "receive_packet",
                                                              "receive_flit"))
        recv = rp * self.rin[c, 0] + rf * self.rin[c, 1]
        send = (sp * self.out[c, 0] + sf * self.out[c, 1])[:3].copy()
        if name == "SC":
            process = process + self.primaries * cm.kernel_cycles("sc_primary", proc)
            send[0] += self.primaries * (sp + int(_FLITS[2, 0, 0]) * sf)
        return process, recv, send


@dataclass
class Result:
    """What one evaluation found: total cycles and per-processor figures."""
    cycles: float
    level: int
    cost: float
    loads: dict = field(default_factory=dict)         # processor -> cycles of work per copy (worst PE)
    utilisation: dict = field(default_factory=dict)   # processor -> busy share of the run (mean over PEs and copies)
    bottleneck: str = ""
    fill_drain: float = 0.0
    costs: str = ""                                   # which cost model priced the visits

    def to_dict(self) -> dict:
        return {"cycles": self.cycles, "level": self.level, "cost": self.cost, "loads": self.loads,
                "utilisation": self.utilisation, "bottleneck": self.bottleneck, "fill_drain": self.fill_drain,
                "costs": self.costs}

    @classmethod
    def from_dict(cls, d) -> "Result":
        return cls(**d)


def trace_key(trace) -> str:
    """A hash naming a trace by what made it (scene content, grid, image,
    rules, tiles): traces are deterministic, so equal keys mean equal traces."""
    meta = {k: v for k, v in trace.meta.items() if k not in ("path",)}
    text = json.dumps(meta, sort_keys=True, default=str) + f"|{len(trace.rays)}|{len(trace.visits)}"
    return hashlib.sha256(text.encode()).hexdigest()[:32]


class Level0:
    """The analytical level on one trace; reuses visit costs per processor configuration."""

    def __init__(self, trace, unit_costs: UnitCosts | None = None, visit_costs=None, linear: bool = True):
        from ..trace import HIT, IC, LATE_HIT, OS, RETURN, SC, TO_IC, TO_SC

        self.trace = trace
        self.unit_costs = unit_costs or UnitCosts()
        if visit_costs is None:
            self.cost_name, self._visit_costs = _cost_source()
        else:
            self.cost_name, self._visit_costs = "given", visit_costs
        v = trace.visits
        rays = trace.rays
        stage = np.asarray(v["stage"]).astype(np.int64)
        out = np.asarray(v["outcome"]).astype(np.int64)
        ray = np.asarray(v["ray"], dtype=np.int64)
        ids = np.asarray(rays["id"], dtype=np.int64)
        row = ray - ids[0] if len(ids) and np.array_equal(ids, np.arange(ids[0], ids[0] + len(ids))) \
            else np.searchsorted(ids, ray)
        pixel = np.asarray(rays["pixel"], dtype=np.int64)[row]
        self._pix = pixel                      # pixels index the per-pixel sums directly
        self.npix = int(pixel.max()) + 1 if len(pixel) else 1
        self.pixels = np.arange(self.npix)
        # where each visit's incoming packet comes from (the ray's previous visit, or SC, which makes rays)
        first = np.ones(len(v), dtype=bool)
        first[1:] = ray[1:] != ray[:-1]
        src = np.full(len(v), SC, dtype=np.int64)
        src[~first] = stage[np.flatnonzero(~first) - 1]
        # where its outgoing packet goes (-1: none)
        dst = np.full(len(v), -1, dtype=np.int64)
        dst[(stage == OS) & (out == TO_IC)] = IC
        dst[(stage == OS) & np.isin(out, (TO_SC, LATE_HIT))] = SC
        dst[(stage == IC) & (out == HIT)] = SC
        dst[(stage == IC) & (out == RETURN)] = OS
        dst[stage == SC] = OS                                  # children, if any (send is 0 otherwise)
        self._stage, self._src, self._dst = stage, src, dst
        kind = np.asarray(rays["kind"])
        rpix = np.asarray(rays["pixel"], dtype=np.int64)[kind == 0]
        self._primaries = np.bincount(rpix, minlength=self.npix).astype(np.float64)
        self._agg: dict = {}
        self.visits = len(v)
        self._allow_linear = linear
        self._linear = None
        self._linear_ok = None        # unknown until a second processor is priced

    def _aggregate(self, s: int, units: dict, design_units: dict):
        """Per pixel: process, receive by source stage, send by destination
        stage (cycles) of stage s's visits on a processor with ``units``.
        The first design is priced with the cost model's ``visit_costs``;
        from the second on, new processors are priced linearly where that
        reproduces the first design's figures exactly."""
        key = (s, json.dumps(units, sort_keys=True))
        if key in self._agg:
            return self._agg[key]
        if self._agg and self._linear_ok is None:
            self._linear_ok = self._build_linear()
        if self._linear_ok:
            from ..cost import ProcessorConfig
            self._agg[key] = self._linear.aggregate(s, _processor_config(ProcessorConfig, units))
            return self._agg[key]
        vc = self._visit_costs(self.trace, design_units)
        n = self.npix
        for c, name in enumerate(STAGE_NAMES):
            k = (c, json.dumps(design_units[name], sort_keys=True))
            m = self._stage == c
            pix = self._pix[m]
            proc = np.bincount(pix, weights=vc.process[m], minlength=n)
            # by (source or destination stage, pixel); no packet (-1) falls in a fourth row
            recv = np.bincount(self._src[m] * n + pix, weights=vc.receive[m], minlength=3 * n)
            recv = recv[:3 * n].reshape(3, n)
            send = np.bincount((self._dst[m] % 4) * n + pix, weights=vc.send[m], minlength=4 * n)
            send = send[:3 * n].reshape(3, n).copy()
            if name == "SC":          # SC makes the primary rays and sends them to OS
                proc = proc + self._primaries * vc.inject_process
                send[0] += self._primaries * vc.inject_send
            self._agg[k] = (proc, recv, send)
        return self._agg[key]

    def _build_linear(self) -> bool:
        model = getattr(self._visit_costs, "model", None)
        if not self._allow_linear or model is None:
            return False
        from ..cost import ProcessorConfig
        try:
            self._linear = _LinearPricing(self.trace, model, self._pix, self.npix, self._stage, self._src,
                                          self._dst, self._primaries)
        except (ImportError, AttributeError, KeyError, TypeError):
            return False
        for (c, units), exact in self._agg.items():
            lin = self._linear.aggregate(c, _processor_config(ProcessorConfig, json.loads(units)))
            if not all(np.array_equal(x, y) for x, y in zip(lin, exact)):
                return False          # the cost model counts differently: price every design in full
        return True

    def processor_work(self, design: Design) -> dict:
        """Per processor (name), cycles of work per pixel (all copies together)."""
        work = {}
        stage_units = {s: design.processor_units(g) for g in processors(design.mapping) for s in g}
        for g in processors(design.mapping):
            units = design.processor_units(g)
            codes = [STAGE_NAMES.index(s) for s in g]
            tot = np.zeros(self.npix)
            for c in codes:
                proc, recv, send = self._aggregate(c, units, stage_units)
                tot += proc
                for t in range(3):
                    if t not in codes:
                        tot += recv[t] + send[t]
            work[processor_name(g)] = tot
        return work

    def run(self, design: Design) -> Result:
        work = self.processor_work(design)
        groups = processors(design.mapping)
        copies = {processor_name(g): design.processor_copies(g) for g in groups}
        pe = self.pixels % design.pes
        per_pe = {p: np.bincount(pe, weights=w, minlength=design.pes) for p, w in work.items()}
        npix_pe = np.maximum(np.bincount(pe, weights=self._primaries > 0, minlength=design.pes), 1)
        load = {p: per_pe[p] / copies[p] for p in work}                  # cycles per copy, per PE
        if len(work) == 1:
            times = next(iter(load.values()))
            fill = np.zeros(design.pes)
            bott = np.array([0] * design.pes)
        else:
            names = list(work)
            L = np.stack([load[p] for p in names])                      # processors x PEs
            bott = np.argmax(L, axis=0)
            total = sum(per_pe.values())
            off = total - np.stack([per_pe[p] for p in names])[bott, np.arange(design.pes)]
            fill = off / npix_pe
            times = L[bott, np.arange(design.pes)] + fill
        T = float(times.max())
        worst = int(np.argmax(times))
        names = list(work)
        util = {p: float(np.mean(per_pe[p] / copies[p])) / T if T else 0.0 for p in names}
        return Result(
            cycles=float(round(T)), level=0,
            cost=float(sum(cost_breakdown(design, self.unit_costs).values())),
            loads={p: float(load[p][worst]) for p in names}, utilisation=util,
            bottleneck=names[int(bott[worst])], fill_drain=float(fill[worst]), costs=self.cost_name)


_LEVEL0: dict = {}


def level0(trace, unit_costs: UnitCosts | None = None) -> Level0:
    """The (cached) level-0 evaluator of a trace."""
    key = (id(trace), unit_costs)
    ev = _LEVEL0.get(key)
    if ev is None or ev.trace is not trace:
        if len(_LEVEL0) > 8:
            _LEVEL0.clear()
        ev = _LEVEL0[key] = Level0(trace, unit_costs)
    return ev


def evaluate(trace, design: Design, level: int = 0, unit_costs: UnitCosts | None = None) -> Result:
    """Cycles and per-processor figures of ``design`` replaying ``trace`` at a fidelity level."""
    if level == 0:
        return level0(trace, unit_costs).run(design)
    from . import machine_adapter
    return machine_adapter.simulate(trace, design, level, unit_costs or UnitCosts())


def grid_dims(scene, subdivision, shape: str = "cube") -> tuple:
    """Voxels per axis of a subdivision: (nx, ny, nz) as given; one n as n
    per axis ('cube', the paper's n^3) or n along the scene box's longest axis
    and the others in proportion ('proportional'), at least 1 each."""
    sub = tuple(int(v) for v in subdivision)
    if len(sub) == 3:
        return sub
    n = sub[0]
    if shape == "cube":
        return (n, n, n)
    info = scene.info()
    ext = np.maximum(np.subtract(info["hi"], info["lo"]), 0.0)
    longest = float(ext.max()) or 1.0
    return tuple(int(max(round(n * e / longest), 1)) for e in ext)


class SceneEvaluator:
    """Evaluates points (subdivision + design) on one scene at one resolution:
    one trace per grid, kept (with its level-0 evaluator) while the traces
    held stay under ``max_visits`` visits in all."""

    def __init__(self, scene, width: int, height: int, level: int = 0, shape: str = "cube",
                 unit_costs: UnitCosts | None = None, max_visits: int = 30_000_000, rules: str = "paper",
                 threads: int = 1):
        self.scene, self.width, self.height = scene, int(width), int(height)
        self.level, self.shape, self.rules, self.threads = level, shape, rules, threads
        self.unit_costs = unit_costs or UnitCosts()
        self.max_visits = max_visits
        self._held: dict = {}             # dims -> Level0 (which holds the trace)
        self.trace_seconds = 0.0
        self.traces_made = 0

    def level0(self, dims) -> Level0:
        import time

        dims = tuple(dims)
        if dims in self._held:
            self._held[dims] = self._held.pop(dims)      # most recent last
            return self._held[dims]
        t0 = time.perf_counter()
        _, tr = self.scene.grid(dims).trace(self.width, self.height, rules=self.rules, threads=self.threads)
        self.trace_seconds += time.perf_counter() - t0
        self.traces_made += 1
        while self._held and sum(e.visits for e in self._held.values()) + len(tr.visits) > self.max_visits:
            self._held.pop(next(iter(self._held)))
        ev = self._held[dims] = Level0(tr, self.unit_costs)
        return ev

    def trace(self, dims):
        return self.level0(dims).trace

    def __call__(self, points) -> list[Result]:
        # grouped by grid so each trace is made once per batch
        dims = [grid_dims(self.scene, p.subdivision, self.shape) for p in points]
        res = [None] * len(points)
        for i in sorted(range(len(points)), key=lambda i: dims[i]):
            if self.level == 0:
                res[i] = self.level0(dims[i]).run(points[i].design)
            else:
                res[i] = evaluate(self.trace(dims[i]), points[i].design, self.level, self.unit_costs)
        return res
