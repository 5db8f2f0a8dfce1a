"""Evaluating a design on a trace through the fidelity ladder (``mprt.fidelity``).

A design becomes one machine configuration (``machine_config``): one stage per
processor of its mapping with its units, copies and FIFOs (the design's words
in packets of the largest ray packet), the ring when there is more than one
processor, and IC and SC memories of the design's resident and cache sizes over
ICGM and SCGM shared by the PEs.  The fidelity ladder models that machine at a
level: 0 analytical, 1 the compiled exact replay of it without ring and
memories, 2 with its ring, 3 as written (ring and memories), all compiled; see
``python/mprt/fidelity/README.md``.  ``TraceEvaluator`` keeps a trace's kernel
counts (``CostModel.counted``) so that each new set of processors is priced in
milliseconds, and a few ``fidelity.Evaluator``s, one per set of processors
(each holds that set's costed, analytical and compiled forms).

The DIS's window is kept small enough that the FIFOs cannot deadlock on the
trace's largest ray tree (``window``; that bound is the ideal network's).  A
machine that deadlocks all the same (on the ring) is run again with half the
window, down to 1; one that deadlocks even then is reported with
``bottleneck = "deadlock"`` and a cycle count no search prefers.
"""
from __future__ import annotations

import time
from collections import OrderedDict
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from .hwcost import UnitCosts, cost_breakdown
from .space import STAGE_NAMES, Design, processors

DEADLOCK_CYCLES = 1e30
GLOBAL_MEMORY = {"latency": 20, "bandwidth": 8, "contention": True}
CACHE_LINE, CACHE_WAYS = 32, 4
WINDOW_PER_COPY = 4        # primary rays in flight per PE, per copy of its most replicated processor (at most)
LEVELS = (0, 1, 2, 3)
KEEP_PROCESSORS = 8        # sets of processors whose costed trace a SceneEvaluator keeps per grid


def is_deadlock(x) -> bool:
    """The one test of a deadlock, for what the explorer and the sweep hold: a cycle count
    (DEADLOCK_CYCLES or more, the stand-in that ranks a deadlocked design last), a ``Result``
    or a row of one as a dict (its bottleneck "deadlock"), an evaluation (its ``result``); None
    (nothing run) is no deadlock."""
    if x is None:
        return False
    if isinstance(x, dict):
        return x.get("bottleneck") == "deadlock"
    if isinstance(x, (int, float, np.integer, np.floating)):
        return x >= DEADLOCK_CYCLES
    if hasattr(x, "bottleneck"):
        return x.bottleneck == "deadlock"
    return is_deadlock(getattr(x, "result", None))


@dataclass
class Result:
    """What one evaluation found: total cycles and per-processor figures."""
    cycles: float
    level: int
    cost: float
    loads: dict = field(default_factory=dict)         # processor -> busy cycles per copy (mean over PEs)
    utilisation: dict = field(default_factory=dict)   # processor -> busy share of the run (mean over PEs and copies)
    bottleneck: str = ""
    engine: str = ""
    costs: str = "mprt.cost"                          # which cost model priced the visits

    @property
    def deadlocked(self) -> bool:
        """The design deadlocked, even with one ray tree in flight: ``cycles`` is DEADLOCK_CYCLES,
        the stand-in that ranks it last, not a count (reports give it none)."""
        return is_deadlock(self)

    def to_dict(self) -> dict:
        return {"cycles": self.cycles, "level": self.level, "cost": self.cost, "loads": self.loads,
                "utilisation": self.utilisation, "bottleneck": self.bottleneck, "engine": self.engine,
                "costs": self.costs}

    @classmethod
    def from_dict(cls, d) -> "Result":
        return cls(**d)


@lru_cache(maxsize=1)
def _words_per_packet() -> int:
    from ..cost import CostModelError, packet_flits

    best = 1
    for s, d in ((0, 1), (1, 0), (1, 2), (2, 0), (0, 2)):
        for k in range(4):
            try:
                best = max(best, packet_flits(s, d, k))
            except CostModelError:
                pass
    return best


def max_leaves(trace) -> int:
    """The most leaves of any ray tree of a trace (``machine.replay.max_leaves``)."""
    from ..machine.replay import max_leaves as leaves

    return leaves(trace)


def window(design: Design, leaves: int | None = None) -> int:
    """How many primary rays a PE's DIS keeps in flight: the machine file's rule ``window =
    "auto"`` (``machine.config.auto_window``) for the design's machine and trees of up to
    ``leaves`` leaves: WINDOW_PER_COPY per copy of the most replicated processor, but with finite
    FIFOs no more than cannot deadlock (window x leaves below the smallest sum of two stages'
    capacities, which depend on the feed: the machine model's ``cycle_capacity``)."""
    return machine_config(design, leaves).window


def _feed(design: Design, group) -> str:
    """The feed of a processor's copies: the design's, when it has more than one."""
    return design.feed if design.processor_copies(group) > 1 else "shared"


def _fifo_packets(design: Design) -> int:
    return max(design.fifo // _words_per_packet(), 1)


def machine_fields(design: Design, leaves: int | None = None, dis_window: int | None = None) -> dict:
    """The machine-configuration fields (a machine TOML file's) of a design, as the
    machine is: FIFOs and ring when it has several processors, memories always; the
    window ``dis_window``, or by default the rule ``"auto"`` (``machine.config.auto_window``:
    applied for a trace's trees when it is run; ``leaves`` is not used)."""
    groups = processors(design.mapping)
    stages = []
    for g in groups:
        st = {"subtasks": list(g), "processor": {"units": design.processor_units(g)},
              "replicas": design.processor_copies(g)}
        if _feed(design, g) != "shared":
            st["feed"] = design.feed
        if len(groups) > 1:
            st["send_fifo"] = st["receive_fifo"] = _fifo_packets(design)
        stages.append(st)
    cfg = {"name": "explored", "stage": stages, "pes": design.pes, "dis": "dynamic",
           "window": dis_window or "auto"}
    if len(groups) > 1:
        cfg["ring"] = {"flit_time": 1, "buffer_classes": len(groups)}
    for s in ("IC", "SC"):
        mem = {"resident": design.resident[s] << 10}
        if design.cache[s]:
            mem["cache"] = {"size": design.cache[s] << 10, "line": CACHE_LINE, "ways": CACHE_WAYS}
        cfg[f"{s.lower()}_memory"] = mem
        cfg[f"{s.lower()}gm"] = dict(GLOBAL_MEMORY)
    return cfg


def machine_config(design: Design, leaves: int | None = None, dis_window: int | None = None):
    """The design as a machine (``SystemConfig``), its DIS window ``dis_window`` if given;
    the fidelity levels take parts of it away.  Kept for the designs asked for last (a
    configuration is frozen; building and checking one took a third of a search's Python
    time outside the replay: a design's level-1 bound and its level-3 replay share one)."""
    return _machine_config(design, leaves, dis_window)


@lru_cache(maxsize=4096)
def _machine_config(design: Design, leaves: int | None, dis_window: int | None):
    from ..machine.config import config_from_dict, with_window_for

    cfg = config_from_dict(machine_fields(design, leaves, dis_window), source="explored design")
    return cfg if dis_window else with_window_for(cfg, leaves)


class TraceEvaluator:
    """Designs on one trace at any fidelity level.  The trace's kernel runs are
    counted once (unless ``counted`` is false: for a trace that sees one set of
    processors); ``keep`` sets of processors keep their costed forms."""

    def __init__(self, trace, unit_costs: UnitCosts | None = None, cost_model=None, keep: int = 4,
                 counted: bool = True):
        from ..cost import CostModel

        self.trace = trace
        self.visits = len(trace.visits)
        self.unit_costs = unit_costs or UnitCosts()
        self.cost_model = cost_model or CostModel.default()
        if counted:             # worth it from the second set of processors on
            self.cost_model = self.cost_model.counted(trace)
        self.keep = keep
        self.leaves = max_leaves(trace)
        self._evaluators: OrderedDict = OrderedDict()

    def evaluator(self, config):
        """The ``fidelity.Evaluator`` for the configuration's processors (a few kept)."""
        from ..fidelity import Evaluator

        key = tuple((t, repr(p)) for t, p in sorted(config.processors().items()))
        ev = self._evaluators.pop(key, None)
        if ev is None:
            ev = Evaluator(self.trace, self.cost_model)
            while len(self._evaluators) >= self.keep:
                self._evaluators.popitem(last=False)
        self._evaluators[key] = ev
        return ev

    def run(self, design: Design, level: int = 1, scale: float = 1.0) -> Result:
        """The design at a level; ``scale`` multiplies the cycles (a sampled trace's frame)."""
        return self.run_config(machine_config(design, self.leaves), level, scale, self._cost(design))

    def work_bound(self, design: Design, level: int, scale: float = 1.0) -> Result | None:
        """A lower bound of the design's cycles at ``level`` (scaled as ``run``'s), nothing run:
        each stage's work over its processors (``fidelity.Evaluator.work_bound``); None where
        the level's run would not be the compiled replay's."""
        from ..machine.errors import ConfigError

        cfg = machine_config(design, self.leaves)
        try:
            b = self.evaluator(cfg).work_bound(cfg, level)
        except ConfigError:
            return None         # (the run says why)
        if b is None:
            return None
        return Result(cycles=float(np.floor(b * scale)), level=level, cost=self._cost(design), engine="work bound")

    def _cost(self, design: Design) -> float:
        """The design's hardware cost (kGE)."""
        return float(sum(cost_breakdown(design, self.unit_costs).values()))

    def run_config(self, cfg, level: int = 1, scale: float = 1.0, cost: float = 0.0) -> Result:
        """A machine configuration (``SystemConfig``) at a level.  Its window rule (``window =
        "auto"``) is applied for this trace's trees, and the window halved while it deadlocks
        (the ideal network's bound; on the ring a machine can still deadlock), as ``mprt
        simulate`` does; one that deadlocks even with one ray tree in flight is reported with
        ``bottleneck = "deadlock"`` and DEADLOCK_CYCLES."""
        from ..machine.config import halved_window, with_window_for
        from ..machine.errors import DeadlockError

        if level not in LEVELS:
            raise ValueError(f"level must be 0, 1, 2 or 3, not {level!r}")
        cfg = with_window_for(cfg, self.leaves)
        while True:
            try:
                e = self.evaluator(cfg).evaluate(cfg, level)
            except DeadlockError:
                cfg = halved_window(cfg)
                if cfg is None:
                    return Result(cycles=DEADLOCK_CYCLES, level=level, cost=cost, bottleneck="deadlock")
                continue
            return result_of(e, cfg, cost, scale)


def result_of(e, cfg, cost: float, scale: float = 1.0) -> Result:
    """The explorer's figures of a fidelity ``Evaluation`` of a configuration."""
    r = e.result
    util, loads = {}, {}
    for st in cfg.stages:
        node = r.nodes.get(st.name)
        if node is not None:
            util[st.name] = float(node["utilisation"])
            loads[st.name] = float(node["busy"]) * scale / (node["replicas"] * cfg.pes)
    return Result(cycles=float(round(r.cycles * scale)), level=e.level, cost=cost, loads=loads, utilisation=util,
                  bottleneck=max(util, key=util.get) if util else "", engine=e.engine)


def evaluate(trace, design: Design, level: int = 1, unit_costs: UnitCosts | None = None) -> Result:
    """Cycles and per-processor figures of ``design`` replaying ``trace`` at a fidelity level."""
    return TraceEvaluator(trace, unit_costs).run(design, level)


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
    """Evaluates points (subdivision + design) on one scene at one resolution
    and level (traced under ``rules``, with the cutoff ``threshold``: None is the
    library's default): one trace per grid, kept (with its evaluator) while the traces
    held stay under ``max_visits`` visits in all.  ``sample`` (a sampled-replay
    specification, e.g. ``stratified:16:1``): trace only those tiles of the
    frame and scale the cycles by the samples in the frame over those traced."""

    def __init__(self, scene, width: int, height: int, level: int = 1, shape: str = "cube",
                 unit_costs: UnitCosts | None = None, max_visits: int = 8_000_000, rules: str = "paper",
                 threads: int = 1, sample: str | None = None, threshold: float | None = None,
                 max_rays: int | None = None, max_depth: int | None = None):
        self.scene, self.width, self.height = scene, int(width), int(height)
        self.threshold = threshold
        self.max_rays, self.max_depth = max_rays, max_depth
        self.level, self.shape, self.rules, self.threads = level, shape, rules, threads
        self.unit_costs = unit_costs or UnitCosts()
        self.max_visits = max_visits
        self.sample = sample
        self._held: dict = {}             # dims -> (TraceEvaluator, scale)
        self.trace_seconds = 0.0
        self.traces_made = 0

    def evaluator(self, dims) -> tuple:
        """(TraceEvaluator, scale) of a grid's trace (made here once, kept while it fits)."""
        dims = tuple(dims)
        if dims in self._held:
            self._held[dims] = self._held.pop(dims)      # most recent last
        else:
            self._trace(dims, self.threads)
        return self._held[dims]

    def _trace(self, dims, threads: int) -> None:
        t0 = time.perf_counter()
        grid = self.scene.grid(dims)
        if self.sample:
            from ..fidelity import trace_sample
            st = trace_sample(grid, self.sample, self.width, self.height, rules=self.rules,
                              threshold=self.threshold, threads=threads, **self._limits())
            tr, scale = st.trace, 1.0 / st.fraction
        else:
            _, tr = grid.trace(self.width, self.height, rules=self.rules, threshold=self.threshold, threads=threads,
                               **self._limits())
            scale = 1.0
        ev = TraceEvaluator(tr, self.unit_costs, keep=KEEP_PROCESSORS)
        while self._held and sum(e.visits for e, _ in self._held.values()) + len(tr.visits) > self.max_visits:
            self._held.pop(next(iter(self._held)))
        self.trace_seconds += time.perf_counter() - t0
        self.traces_made += 1
        self._held[dims] = (ev, scale)

    def _limits(self) -> dict:
        """The ray budget and depth of the traces, where set (else the library's defaults)."""
        return {k: v for k, v in (("max_rays", self.max_rays), ("max_depth", self.max_depth)) if v is not None}

    def trace(self, dims):
        return self.evaluator(dims)[0].trace

    def run(self, point, level: int | None = None) -> Result:
        level = self.level if level is None else level
        ev, scale = self.evaluator(grid_dims(self.scene, point.subdivision, self.shape))
        if not isinstance(point.design, Design):          # a machine configuration
            return ev.run_config(point.design, level, scale)
        return ev.run(point.design, level, scale)

    def work_bound(self, point, level: int | None = None) -> Result | None:
        """``TraceEvaluator.work_bound`` of a point (None for a machine configuration, or where
        the compiled replay would not run it)."""
        if not isinstance(point.design, Design):
            return None
        ev, scale = self.evaluator(grid_dims(self.scene, point.subdivision, self.shape))
        return ev.work_bound(point.design, self.level if level is None else level, scale)

    def __call__(self, points) -> list[Result]:
        # grouped by grid (each trace made once per batch), then by processors (each costed once)
        dims = [grid_dims(self.scene, p.subdivision, self.shape) for p in points]
        units = [p.design.key() if isinstance(p.design, Design) else "" for p in points]
        res = [None] * len(points)
        for i in sorted(range(len(points)), key=lambda i: (dims[i], units[i])):
            res[i] = self.run(points[i])
        return res


__all__ = ["DEADLOCK_CYCLES", "Result", "is_deadlock", "SceneEvaluator", "TraceEvaluator", "evaluate", "grid_dims", "machine_config",
           "machine_fields", "STAGE_NAMES"]
